"""The bridge between the multirotor's Python code and its numba kernels.

This module owns the bridge between :class:`uavwind.sim.multirotor.Multirotor` and
``uavwind.sim._rotor_kernels``: ``_packed``, the vehicle's parameters packed once into the
kernels' parameter vector (RotorPy's ``quad_params`` from
:func:`uavwind.sim.rotor_params.rotorpy_params`, the drag and lift factors, SE3's gains and a
:class:`~uavwind.sim.rotor_params.PositionControl`) written through the names of
``uavwind.sim._slots``, what a recorded flight stores at each sample
(velocities, winds, attitudes, body rates, rotor speeds, the accelerometer's specific force,
the aerodynamic force; ``_recorded``, ``_specific_force``, ``_aero_force``) and
``_kernels``, the one lazy access to the kernels themselves.
"""

from __future__ import annotations

import importlib
import math
import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np

from ._slots import (AERO, C_D, G, INERTIA, INERTIA_INV, INTEGRAL_ACC, K_D, K_ETA, K_FLAP, K_H,
                     K_M, K_W, K_Z, KD_ATT, KD_POS, KI_POS, KP_ATT, KP_POS, LAYOUT, MASS, N_PARAMS,
                     ROTOR_DIR, ROTOR_POS, S_QUAT, S_RATES, S_ROTORS, S_VEL, S_WIND, SE3_KD_ATT,
                     SE3_KP_ATT, SPEED_MAX, SPEED_MIN, TAN_TILT, TAU_M, THRUST_HIGH, THRUST_LOW,
                     TM_TO_F)
from .rotor_params import DRAG_KEYS, GRAVITY, ROTOR_DRAG_KEYS, SE3_KD_POS, SE3_KP_POS, rotorpy_params


@lru_cache(maxsize=None)
def _kernels():
    """:mod:`._rotor_kernels`, imported where a vehicle first flies: it imports numba (about
    1 s), which ``import uavwind`` does not need (the registry builds vehicles at import and
    flies none). The multirotor and its rollouts reach the kernels through here only.
    Kernels that numba's cache holds compiled under another layout of
    ``uavwind.sim._slots`` than the present one (its cache does not see that file) are
    compiled again (:func:`_recompiled`), never flown."""
    # the package's one import of the rotor kernels: kept in a function so that importing
    # uavwind, which builds multirotors but flies none, does not load numba
    from . import _rotor_kernels
    if _rotor_kernels.compiled_layout() != LAYOUT:
        return _recompiled(_rotor_kernels)
    return _rotor_kernels


def _recompiled(module, reload=importlib.reload):
    """``module`` (the rotor kernels) imported again after deleting its stale entries from
    numba's cache, with a warning naming them, so every kernel compiles under the present
    layout; ``RuntimeError`` if the kernels still report another one."""
    folder = Path(module.compiled_layout._cache._cache_path)
    stem = module.__name__.rsplit(".", 1)[-1]
    stale = sorted(folder.glob(f"{stem}.*.nb[ic]"))
    for f in stale:
        f.unlink(missing_ok=True)
    warnings.warn(f"numba's cache held {stem} compiled under another layout of "
                  f"uavwind.sim._slots: {len(stale)} stale file(s) deleted from {folder}, "
                  f"the kernels compile again", RuntimeWarning, stacklevel=3)
    module = reload(module)
    if module.compiled_layout() != LAYOUT:
        raise RuntimeError(f"{module.__name__} still reports another layout of "
                           f"uavwind.sim._slots after its cache in {folder} was cleared")
    return module


@lru_cache(maxsize=32)
def _packed(preset, mass, drag_scale=1.0, lift_scale=1.0, control=None,
            hover_throttle=None, rotor_drag_scale=1.0):  # mass resolved
    """The kernels' parameter vector (``uavwind.sim._rotor_kernels``' layout)."""
    qp = rotorpy_params(preset, mass)
    if drag_scale != 1.0:
        qp.update({k: qp.get(k, 0.0) * drag_scale for k in DRAG_KEYS})
    if rotor_drag_scale != 1.0:
        qp.update({k: qp.get(k, 0.0) * rotor_drag_scale for k in ROTOR_DRAG_KEYS})
    if lift_scale != 1.0:
        qp["k_h"] = qp.get("k_h", 0.0) * lift_scale
    inertia = np.array([[qp["Ixx"], qp["Ixy"], qp["Ixz"]],
                        [qp["Ixy"], qp["Iyy"], qp["Iyz"]],
                        [qp["Ixz"], qp["Iyz"], qp["Izz"]]])
    geometry = np.vstack([qp["rotor_pos"][k] for k in qp["rotor_pos"]])
    direction = np.asarray(qp["rotor_directions"], dtype=float)
    k = qp["k_m"] / qp["k_eta"]  # as Multirotor.__init__ builds f_to_TM
    f_to_TM = np.vstack((np.ones((1, qp["num_rotors"])),
                         np.hstack([np.cross(qp["rotor_pos"][key], np.array([0, 0, 1]))
                                    .reshape(-1, 1)[0:2] for key in qp["rotor_pos"]]),
                         (k * direction).reshape(1, -1)))
    P = np.zeros(N_PARAMS)
    P[MASS], P[G] = qp["mass"], GRAVITY
    P[INERTIA] = inertia.ravel()
    P[INERTIA_INV] = np.linalg.inv(inertia).ravel()
    P[C_D] = [qp.get("c_Dx", 0.0), qp.get("c_Dy", 0.0), qp.get("c_Dz", 0.0)]
    P[K_ETA], P[K_M] = qp["k_eta"], qp["k_m"]
    P[K_D], P[K_Z], P[K_H] = qp.get("k_d", 0.0), qp.get("k_z", 0.0), qp.get("k_h", 0.0)
    P[K_FLAP], P[TAU_M] = qp.get("k_flap", 0.0), qp["tau_m"]
    P[SPEED_MIN], P[SPEED_MAX] = qp["rotor_speed_min"], qp["rotor_speed_max"]
    P[ROTOR_POS] = geometry.ravel()
    P[ROTOR_DIR] = direction
    P[TM_TO_F] = np.linalg.inv(f_to_TM).ravel()
    P[K_W] = qp.get("k_w", 1.0)
    P[KP_ATT], P[KD_ATT] = qp.get("kp_att", 3000.0), qp.get("kd_att", 360.0)
    P[AERO] = 1.0
    P[KP_POS] = SE3_KP_POS  # SE3Control.__init__'s gains (its attitude gains from quad_params,
    P[KD_POS] = SE3_KD_POS  # with its own defaults)
    P[SE3_KP_ATT], P[SE3_KD_ATT] = qp.get("kp_att", 310.0), qp.get("kd_att", 57.0)
    if hover_throttle is not None:  # the rotors' top speed: full thrust = weight / throttle
        P[SPEED_MAX] = math.sqrt(qp["mass"] * GRAVITY / (4 * P[K_ETA] * hover_throttle))
    if control is not None:
        full = 4 * P[K_ETA] * P[SPEED_MAX] ** 2
        P[KP_POS], P[KD_POS] = control.kp, control.kd
        P[KI_POS] = control.ki
        P[TAN_TILT] = math.tan(math.radians(control.max_tilt))
        P[THRUST_LOW] = control.min_thrust * full
        P[THRUST_HIGH] = control.max_thrust * full
        P[INTEGRAL_ACC] = control.max_integral_acceleration
    P.setflags(write=False)
    return P


def _body_z(q) -> np.ndarray:
    """The body's z axis in the world frame for the quaternion q [i, j, k, w]: the row of
    :func:`_body_z_batch` for it, so one sample's axis is the batch's to the double."""
    return _body_z_batch(np.asarray(q, dtype=float).reshape(1, 4))[0]


def _recorded(P, states, held, aero: bool = False) -> dict:
    """What a recorded flight stores, from the states ``states`` (n_env, n, width) after each
    sample and the motor speeds ``held`` (n_env, n, 4) held over its last control step:
    velocities, winds, attitudes, body rates and rotor speeds (each (n_env, n, k)), the
    accelerometer's specific force ``"f"`` and, with ``aero`` (a reference flight), the
    aerodynamic force ``"fa"``, both from one state derivative. One batch over every sample
    after the flight, not one small one per sample: each row is computed alone (the kernels
    and numpy's elementwise operations work row by row), so the doubles are those of a
    sample-by-sample record."""
    n_env, n, width = states.shape
    S = states.reshape(n_env * n, width)
    vdot = _vdot(P, S, held.reshape(n_env * n, 4))
    rec = {k: np.ascontiguousarray(states[:, :, cols]) for k, cols in
           (("v", S_VEL), ("wind", S_WIND), ("q", S_QUAT), ("w", S_RATES), ("rotors", S_ROTORS))}
    rec["f"] = _specific_force(P, S, vdot=vdot).reshape(n_env, n, 3)
    if aero:
        rec["fa"] = _aero_force(P, S, vdot=vdot).reshape(n_env, n, 3)
    return rec


def _vdot(P, S, U):
    """The acceleration dv/dt (n, 3) [m/s^2] at the states ``S`` under the held motor speeds
    ``U``."""
    return _kernels().state_derivative(P, S, U)[:, S_VEL]


def _clipped_commands(P, S, T, C):
    motor_commands = _kernels().motor_commands
    return np.clip(motor_commands(P, S, T, C, 0), P[SPEED_MIN], P[SPEED_MAX])


def _specific_force(P, S, U=None, vdot=None):
    """What an accelerometer at the centre of mass reads, body frame [m/s^2]: ``R^T (dv/dt -
    g)`` at the states ``S`` under the held motor speeds ``U`` (RotorPy's IMU, no noise), or
    from their acceleration ``vdot`` (:func:`_vdot`) when it is at hand."""
    if vdot is None:
        vdot = _vdot(P, S, U)
    acc = vdot - np.array([0.0, 0.0, -GRAVITY])
    q = S[:, S_QUAT] / np.linalg.norm(S[:, S_QUAT], axis=1, keepdims=True)
    x, y, z, w = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                  np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                  np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
                 axis=1)
    return np.einsum("nji,nj->ni", R, acc)


def _body_z_batch(Q) -> np.ndarray:
    """The body's z axis (n, 3) in the world frame for quaternions Q (n, 4) [i, j, k, w].
    The norm is one elementwise expression, summed in component order, as numpy's reduction
    over a batch's rows sums it: ``np.linalg.norm`` of one quaternion calls BLAS's dot
    product, which on an AVX-512 Xeon rounded 2,416 of 20,000 random quaternions' norms
    otherwise (a flight's recorded thrust then differed from the sample-by-sample formula's);
    elementwise arithmetic is the same double on every host."""
    x, y, z, w = np.asarray(Q, dtype=float).T
    norm = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.stack([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)], axis=1)


def _clipped_se3(P, S, C, mode=2):
    se3_commands, se3i_commands = _kernels().se3_commands, _kernels().se3i_commands
    u = se3_commands(P, S, C)[0] if mode == 2 else se3i_commands(P, S, C)[0]
    return np.clip(u, P[SPEED_MIN], P[SPEED_MAX])


def _aero_force(P, S, U=None, vdot=None):
    """World-frame aerodynamic force [N] on the vehicle at the states ``S``: ``m dv/dt`` less
    gravity and the rotors' nominal thrust ``R e_z sum k_eta omega^2`` (frame drag, rotor
    drag, induced inflow and translational lift: the simulated counterpart of Neural-Fly's
    ``fa``), ``dv/dt`` given as ``vdot`` or computed under the held motor commands ``U``
    (which do not change it: only the motors' rates)."""
    if vdot is None:
        vdot = _vdot(P, S, U)
    m = P[MASS]
    nominal = P[K_ETA] * np.sum(S[:, S_ROTORS] ** 2, axis=1)
    gravity = np.array([0.0, 0.0, m * P[G]])
    return m * vdot + gravity - nominal[:, None] * _body_z_batch(S[:, S_QUAT])
