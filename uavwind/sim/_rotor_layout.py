"""The numba kernels' layouts as the multirotor's Python code sees them.

This module owns the bridge between :class:`uavwind.sim.multirotor.Multirotor` and
``uavwind.sim._rotor_kernels``: ``_packed``, the vehicle's parameters packed once into the
kernels' parameter vector (RotorPy's ``quad_params`` from
:func:`uavwind.sim.rotor_params.rotorpy_params`, the drag and lift factors, SE3's gains and a
:class:`~uavwind.sim.rotor_params.PositionControl`), the slots of that vector and the columns
of the kernels' state read outside them, what a recorded flight stores at each sample
(velocities, winds, attitudes, body rates, rotor speeds, the accelerometer's specific force,
the aerodynamic force; ``_record_state``, ``_specific_force``, ``_aero_force``) and
``_kernels``, the one lazy access to the kernels themselves.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .rotor_params import DRAG_KEYS, GRAVITY, SE3_KD_POS, SE3_KP_POS, rotorpy_params

#: Slots of the parameter vector (``uavwind.sim._rotor_kernels``' layout) read here.
_K_ETA, _SPEED_MIN, _SPEED_MAX = 23, 30, 31
_KI, _TAN_TILT, _THRUST_LOW, _THRUST_HIGH, _INTEGRAL_ACC = slice(76, 79), 79, 80, 81, 82
#: Length of the parameter vector.
_N_PARAMS = 83
#: State columns of a flight under :class:`PositionControl`: RotorPy's 20, then the integral
#: of the position error (3) [m s].
_N_STATE, _N_STATE_PI = 20, 23


def _kernels():
    """:mod:`._rotor_kernels`, imported where a vehicle first flies: it imports numba (about
    1 s), which ``import uavwind`` does not need (the registry builds vehicles at import and
    flies none). The multirotor and its rollouts reach the kernels through here only."""
    # the package's one import of the rotor kernels: kept in a function so that importing
    # uavwind, which builds multirotors but flies none, does not load numba
    from . import _rotor_kernels
    return _rotor_kernels


@lru_cache(maxsize=32)
def _packed(preset, mass, drag_scale=1.0, lift_scale=1.0, control=None):  # mass resolved
    """The kernels' parameter vector (``uavwind.sim._rotor_kernels``' layout)."""
    qp = rotorpy_params(preset, mass)
    if drag_scale != 1.0:
        qp.update({k: qp.get(k, 0.0) * drag_scale for k in DRAG_KEYS})
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
    P = np.zeros(_N_PARAMS)
    P[0], P[1] = qp["mass"], GRAVITY
    P[2:11] = inertia.ravel()
    P[11:20] = np.linalg.inv(inertia).ravel()
    P[20:23] = [qp.get("c_Dx", 0.0), qp.get("c_Dy", 0.0), qp.get("c_Dz", 0.0)]
    P[23:32] = [qp["k_eta"], qp["k_m"], qp.get("k_d", 0.0), qp.get("k_z", 0.0),
                qp.get("k_h", 0.0), qp.get("k_flap", 0.0), qp["tau_m"], qp["rotor_speed_min"],
                qp["rotor_speed_max"]]
    P[32:44] = geometry.ravel()
    P[44:48] = direction
    P[48:64] = np.linalg.inv(f_to_TM).ravel()
    P[64:67] = [qp.get("k_w", 1.0), qp.get("kp_att", 3000.0), qp.get("kd_att", 360.0)]
    P[67] = 1.0
    P[68:71] = SE3_KP_POS  # SE3Control.__init__'s gains (its attitude gains from quad_params,
    P[71:74] = SE3_KD_POS  # with its own defaults)
    P[74:76] = [qp.get("kp_att", 310.0), qp.get("kd_att", 57.0)]
    if control is not None:
        full = 4 * P[_K_ETA] * P[_SPEED_MAX] ** 2
        P[_KI] = control.ki
        P[_TAN_TILT] = math.tan(math.radians(control.max_tilt))
        P[_THRUST_LOW] = control.min_thrust * full
        P[_THRUST_HIGH] = control.max_thrust * full
        P[_INTEGRAL_ACC] = control.max_integral_acceleration
    P.setflags(write=False)
    return P


def _body_z(q) -> np.ndarray:
    """The body's z axis in the world frame for the quaternion q [i, j, k, w]."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)])


def _record_state(rec, j, P, S, u_held):
    """Sample ``j`` of a recorded flight: velocities, winds, attitudes, body rates, rotor
    speeds and the accelerometer's specific force under the held motor speeds."""
    rec["v"][:, j] = S[:, 3:6]
    rec["wind"][:, j] = S[:, 13:16]
    rec["q"][:, j] = S[:, 6:10]
    rec["w"][:, j] = S[:, 10:13]
    rec["rotors"][:, j] = S[:, 16:20]
    rec["f"][:, j] = _specific_force(P, S, u_held)


def _clipped_commands(P, S, T, C):
    motor_commands = _kernels().motor_commands
    return np.clip(motor_commands(P, S, T, C, 0), P[30], P[31])


def _specific_force(P, S, U):
    """What an accelerometer at the centre of mass reads, body frame [m/s^2]: ``R^T (dv/dt -
    g)`` at the states ``S`` under the held motor speeds ``U`` (RotorPy's IMU, no noise)."""
    state_derivative = _kernels().state_derivative

    vdot = state_derivative(P, S, U)[:, 3:6]
    acc = vdot - np.array([0.0, 0.0, -GRAVITY])
    q = S[:, 6:10] / np.linalg.norm(S[:, 6:10], axis=1, keepdims=True)
    x, y, z, w = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                  np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                  np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
                 axis=1)
    return np.einsum("nji,nj->ni", R, acc)


def _body_z_batch(Q) -> np.ndarray:
    """The body's z axis (n, 3) in the world frame for quaternions Q (n, 4) [i, j, k, w]."""
    Q = Q / np.linalg.norm(Q, axis=1, keepdims=True)
    x, y, z, w = Q.T
    return np.stack([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)], axis=1)


def _clipped_se3(P, S, C, mode=2):
    se3_commands, se3i_commands = _kernels().se3_commands, _kernels().se3i_commands
    u = se3_commands(P, S, C)[0] if mode == 2 else se3i_commands(P, S, C)[0]
    return np.clip(u, P[_SPEED_MIN], P[_SPEED_MAX])


def _aero_force(P, S, U):
    """World-frame aerodynamic force [N] on the vehicle at the states ``S``: ``m dv/dt`` less
    gravity and the rotors' nominal thrust ``R e_z sum k_eta omega^2`` (frame drag, rotor
    drag, induced inflow and translational lift: the simulated counterpart of Neural-Fly's
    ``fa``). ``U`` (the held motor commands) does not change it (only the motors' rates)."""
    state_derivative = _kernels().state_derivative

    vdot = state_derivative(P, S, U)[:, 3:6]
    m = P[0]
    nominal = P[23] * np.sum(S[:, 16:20] ** 2, axis=1)
    gravity = np.array([0.0, 0.0, m * P[1]])
    return m * vdot + gravity - nominal[:, None] * _body_z_batch(S[:, 6:10])
