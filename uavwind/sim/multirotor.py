"""The multirotor: RotorPy's quadrotor physics as a second vehicle beside the point mass.

This module owns :class:`Multirotor`, a frozen value that flies a
:class:`~uavwind.sim.actions.ThrustSequence` through uavwind's own winds with the physics of
RotorPy 3.0.0's ``rotorpy.vehicles.multirotor.Multirotor`` (attitude dynamics, first-order
motors clipped to their speed range, quadratic frame drag, rotor drag, translational lift;
``uavwind.sim._rotor_kernels`` is that derivative ported to numba and vectorised over
environments, held to RotorPy's own methods by the tests).

*The vehicle.* RotorPy's ``hummingbird_params`` (0.5 kg) scaled to ``mass`` (default 2 kg,
the paper's) by mass similarity: mass, inertia, ``k_eta``, ``k_m`` and every aerodynamic
coefficient (``c_Dx, c_Dy, c_Dz, k_d, k_z, k_h, k_flap``) times ``mass / 0.5``; the geometry,
the motor time constant, the rotor speed range and the attitude gains unchanged. Every linear
and angular acceleration at a given state is then the hummingbird's: hover at 469.2 rad/s, a
thrust-to-weight ratio of 10.2 (200.5 N at 2 kg), the tuned attitude loop as RotorPy tunes it.
Two drag presets: ``"rotorpy"`` (the full aerodynamics, scaled) and ``"paper"`` (the paper's
frame drag, ``1/2 rho C_D S`` of :data:`~uavwind.sim.vehicle.PAPER_UAV` on every body axis,
which equals the point mass's ``-k |v_air| v_air`` exactly, and no rotor drag, lift or
flapping).

*The commands.* The paper applies a world-frame force ``F`` per segment and does not
compensate gravity; a multirotor turns its body to point its thrust. Each segment flies
RotorPy's ``cmd_ctatt``: collective thrust ``|F|`` with the body's z axis along ``F`` (the
minimal tilt from level, yaw 0), if ``F`` lies within ``tilt_limit`` degrees of up; beyond
it (a multirotor does not push itself downward) the body tilts to the limit towards ``F``'s
horizontal direction and the thrust is ``F``'s projection on that axis (the closest force
it can make; a purely downward or zero ``F`` gives a level body and no thrust). With the
default limit of 90 degrees the paper's commands (+x, +y, +z) are flown as the paper
states them; :attr:`~uavwind.sim.flight.Flight.tilt_limited` and
:attr:`~uavwind.sim.flight.Flight.motor_limited` say how often the limits bound.

*The starts.* ``"hover"``: at rest over the ground, level, rotors at hover speed, at the
start position (the wind acts through drag only). ``"drifting"``: moving with the air mass
(ground velocity = the wind at the start): the paper's reading, under which a constant wind
only adds ``w t`` to the still-air path, on this vehicle too.

*The integration.* ``control_rate`` (100 Hz) command updates, each held over ``substeps``
classical RK4 steps (2.5 ms) with the wind sampled at the step's start and position, the
structure of ``Multirotor.step`` with a fixed-step integrator (about ten times more accurate
than RotorPy's default RK45 tolerances on the paper's flights). Positions are recorded every
``dt`` of the flight, as for the point mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from .actions import AttitudeSequence, ThrustSequence
from .flight import Flight
from .vehicle import PAPER_UAV

if TYPE_CHECKING:
    from .wind import WindModel

__all__ = ["Multirotor", "PRESETS", "STARTS", "EXTRA", "rotorpy_params", "force_command"]

#: Drag presets: RotorPy's full aerodynamics (scaled), or the paper's frame drag alone.
PRESETS = ("rotorpy", "paper")
#: How a flight starts: at rest over the ground, or moving with the air mass.
STARTS = ("hover", "drifting")
#: The pip extra that installs RotorPy.
EXTRA = "multirotor"
#: The mass of RotorPy's hummingbird, the vehicle scaled [kg].
BASE_MASS = 0.5
#: RotorPy's gravity [m/s^2] (``Multirotor.g``).
GRAVITY = 9.81
#: Coefficients scaled by mass / BASE_MASS (mass similarity).
_SCALED = ("mass", "Ixx", "Iyy", "Izz", "Ixy", "Iyz", "Ixz", "k_eta", "k_m", "c_Dx", "c_Dy",
           "c_Dz", "k_d", "k_z", "k_h", "k_flap")


def _hummingbird() -> dict:
    try:
        from rotorpy.vehicles.hummingbird_params import quad_params
    except ImportError as exc:
        raise ImportError(f"the multirotor flies RotorPy's physics: install it with "
                          f"pip install 'uavwind[{EXTRA}]' (rotorpy==3.0.0)") from exc
    return quad_params


def rotorpy_params(preset: str = "rotorpy", mass: float = 2.0) -> dict:
    """The vehicle as a RotorPy ``quad_params`` dict (for ``rotorpy.vehicles.multirotor
    .Multirotor``): ``hummingbird_params`` scaled to ``mass`` [kg], with the ``preset``'s
    drag. Needs RotorPy (``ImportError`` naming the extra otherwise)."""
    check_choice(preset, "preset", PRESETS)
    mass = check_scalar(mass, "mass", low=0.0, low_inclusive=False, high=1e3)
    base = _hummingbird()
    f = mass / BASE_MASS
    qp = {k: (v * f if k in _SCALED else v) for k, v in base.items()}
    qp["rotor_pos"] = {k: np.array(v, dtype=float) for k, v in base["rotor_pos"].items()}
    if preset == "paper":
        c = PAPER_UAV.drag_factor  # 1/2 rho C_D S [kg/m], isotropic: the point mass's drag
        qp.update(c_Dx=c, c_Dy=c, c_Dz=c, k_d=0.0, k_z=0.0, k_h=0.0, k_flap=0.0)
    return qp


@lru_cache(maxsize=32)
def _packed(preset, mass):
    """The kernels' parameter vector (``uavwind.sim._rotor_kernels``' layout)."""
    qp = rotorpy_params(preset, mass)
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
    P = np.zeros(68)
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
    P.setflags(write=False)
    return P


def _tilt_quaternion(b3: np.ndarray) -> np.ndarray:
    """Quaternion [i, j, k, w] of the minimal rotation taking e_z to the unit vector b3 (yaw
    0: no rotation about the thrust axis; defined for every b3 but -e_z)."""
    c = min(max(float(b3[2]), -1.0), 1.0)
    half = 0.5 * math.acos(c)
    axis = np.array([-b3[1], b3[0], 0.0]) + 0.0  # e_z x b3 (+ 0.0: no negative zeros)
    n = float(np.linalg.norm(axis))
    axis = axis / n if n > 0 else np.array([1.0, 0.0, 0.0])
    return np.concatenate([math.sin(half) * axis, [math.cos(half)]])


def force_command(force, tilt_limit: float = 90.0) -> tuple[float, np.ndarray, bool]:
    """``(collective thrust [N], attitude quaternion [i, j, k, w], limited)`` that flies the
    world-frame ``force`` (3,) [N] as well as a multirotor can: exactly within
    ``tilt_limit`` degrees of up; beyond it, tilted to the limit towards the force's
    horizontal direction with the force's projection on that axis as thrust (``limited``
    True). A zero or purely downward force gives a level body and no thrust.

    >>> T, q, limited = force_command([15.0, 0.0, 0.0])      # 90 degrees: exact, on its side
    >>> round(T, 6), q.round(4).tolist(), limited
    (15.0, [0.0, 0.7071, 0.0, 0.7071], False)
    >>> T, q, limited = force_command([15.0, 0.0, 0.0], tilt_limit=60.0)
    >>> round(T, 3), limited
    (12.99, True)
    """
    F = check_array(force, "force", shape=(3,))
    th = math.radians(check_scalar(tilt_limit, "tilt_limit", low=0.0, low_inclusive=False,
                                   high=90.0))
    Fh = math.hypot(F[0], F[1])
    Fn = float(np.linalg.norm(F))
    if Fn == 0.0:
        return 0.0, np.array([0.0, 0.0, 0.0, 1.0]), False
    tilt = math.atan2(Fh, F[2])
    if tilt <= th + 1e-12:
        return Fn, _tilt_quaternion(F / Fn), False
    if Fh == 0.0:  # straight down: level, no thrust
        return 0.0, np.array([0.0, 0.0, 0.0, 1.0]), True
    az = math.atan2(F[1], F[0])
    b3 = np.array([math.sin(th) * math.cos(az), math.sin(th) * math.sin(az), math.cos(th)])
    return max(0.0, float(F @ b3)), _tilt_quaternion(b3), True


@dataclass(frozen=True, kw_only=True)
class Multirotor:
    """RotorPy's quadrotor, scaled to ``mass``, as a vehicle of uavwind (see the module text).

    Parameters
    ----------
    preset : {"rotorpy", "paper"}
        Drag: RotorPy's full aerodynamics, or the paper's frame drag alone.
    start : {"hover", "drifting"}
        At rest over the ground, or moving with the air mass.
    mass : float
        [kg], in (0, 1000]; default 2 (the paper's UAV).
    tilt_limit : float
        Largest tilt of the thrust from up [deg], in (0, 90]; default 90 (the paper's
        commands flown as stated).
    control_rate : float
        Command updates per second [Hz], in [10, 10000]; default 100 (RotorPy's).
    substeps : int
        RK4 steps per command update, in [1, 100]; default 4 (2.5 ms at 100 Hz).

    Examples
    --------
    >>> mr = Multirotor(preset="rotorpy", start="hover")
    >>> round(mr.max_thrust, 1), round(mr.hover_speed, 1)
    (200.5, 469.2)
    """

    preset: str = "rotorpy"
    start: str = "hover"
    mass: float = 2.0
    tilt_limit: float = 90.0
    control_rate: float = 100.0
    substeps: int = 4

    def __post_init__(self):
        check_choice(self.preset, "preset", PRESETS)
        check_choice(self.start, "start", STARTS)
        object.__setattr__(self, "mass", check_scalar(self.mass, "mass", low=0.0,
                                                      low_inclusive=False, high=1e3))
        object.__setattr__(self, "tilt_limit", check_scalar(
            self.tilt_limit, "tilt_limit", low=0.0, low_inclusive=False, high=90.0))
        object.__setattr__(self, "control_rate", check_scalar(
            self.control_rate, "control_rate", low=10.0, high=1e4))
        object.__setattr__(self, "substeps", check_scalar(self.substeps, "substeps", low=1,
                                                          high=100, integer=True))
        self.packed  # needs RotorPy: fail here, with the extra named, not mid-flight

    # -- the vehicle --------------------------------------------------------- #
    @property
    def packed(self) -> np.ndarray:
        """The kernels' parameter vector (read-only)."""
        return _packed(self.preset, self.mass)

    @property
    def gravity(self) -> float:
        """[m/s^2], RotorPy's."""
        return GRAVITY

    @property
    def weight(self) -> float:
        """m g [N]."""
        return self.mass * GRAVITY

    @property
    def max_thrust(self) -> float:
        """Collective thrust at full rotor speed [N] (no translational lift)."""
        P = self.packed
        return float(4 * P[23] * P[31] ** 2)

    @property
    def hover_speed(self) -> float:
        """Rotor speed whose thrust holds the vehicle in still air [rad/s]."""
        return math.sqrt(self.weight / (4 * self.packed[23]))

    def drag_force(self, airspeed: float) -> float:
        """Horizontal aerodynamic force [N] on the vehicle hovering level (rotors at hover
        speed) in a horizontal airspeed of ``airspeed`` [m/s], opposing it: what couples a
        hovering multirotor to the wind (``F(1 m/s)`` is the per-speed coupling of the rotor
        drag, which is linear; the frame drag is quadratic)."""
        from ._rotor_kernels import state_derivative

        S = self.initial_states(np.zeros(3), np.zeros((1, 3)))
        S[0, 13] = check_scalar(airspeed, "airspeed", low=0.0, high=1e3)  # wind along x
        U = np.full((1, 4), self.hover_speed)
        return float(state_derivative(self.packed, S, U)[0, 3] * self.mass)

    def quad_params(self) -> dict:
        """This vehicle as RotorPy's ``quad_params`` (for ``rotorpy``'s own ``Multirotor``)."""
        return rotorpy_params(self.preset, self.mass)

    # -- flying -------------------------------------------------------------- #
    def initial_states(self, start_position, winds0) -> np.ndarray:
        """(n_env, 20) states at t = 0: level, no rates, rotors at hover speed, at
        ``start_position``; at rest (``"hover"``) or with the wind ``winds0`` (n_env, 3)
        (``"drifting"``)."""
        start_position = check_array(start_position, "start_position", shape=(3,))
        winds0 = check_array(winds0, "winds0", shape=(None, 3))
        n = winds0.shape[0]
        s = np.zeros((n, 20))
        s[:, 0:3] = start_position
        s[:, 9] = 1.0
        s[:, 16:20] = self.hover_speed
        if self.start == "drifting":
            s[:, 3:6] = winds0
        return s

    def check_grid(self, dt: float) -> int:
        """Control steps per recorded sample ``dt`` [s]; ``ValueError`` unless ``dt`` is a
        whole number of control steps."""
        dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False, high=1e6)
        per = dt * self.control_rate
        k = int(round(per))
        if k < 1 or abs(per - k) > 1e-9 * max(1.0, per):
            raise ValueError(f"dt = {dt:g} s must be a whole number of the multirotor's "
                             f"control steps (1/{self.control_rate:g} s)")
        return k

    def segment_commands(self, action) -> list[tuple[float, np.ndarray, bool]]:
        """``(collective thrust [N], attitude quaternion, limited)`` of each segment of
        ``action``: a :class:`~uavwind.sim.actions.ThrustSequence` through
        :func:`force_command`, an :class:`~uavwind.sim.actions.AttitudeSequence` as given
        (limited where its tilt exceeds ``tilt_limit``, then tilted to the limit)."""
        check_instance(action, "action", (ThrustSequence, AttitudeSequence))
        if isinstance(action, ThrustSequence):
            return [force_command(v, self.tilt_limit) for v in action.vectors]
        out = []
        for T, q in zip(action.thrusts, action.quaternions()):
            b3 = _body_z(q)
            tilt = math.degrees(math.acos(min(max(b3[2], -1.0), 1.0)))
            if tilt > self.tilt_limit + 1e-9:
                Tc, qc, _ = force_command(T * b3, self.tilt_limit)
                out.append((Tc, qc, True))
            else:
                out.append((float(T), q, False))
        return out

    def check_thrust(self, thrust: ThrustSequence) -> None:
        """``ValueError`` if a segment asks for more thrust than the rotors make."""
        check_instance(thrust, "thrust", (ThrustSequence, AttitudeSequence))
        too_much = thrust.magnitudes > self.max_thrust * (1 + 1e-12)
        if np.any(too_much):
            raise ValueError(f"thrust magnitudes must be <= {self.max_thrust:.1f} N for this "
                             f"multirotor (its rotors at full speed), got "
                             f"{thrust.magnitudes.max():g} N")

    def fly(self, thrust: ThrustSequence | AttitudeSequence, wind: WindModel, dt: float, n: int,
            start: np.ndarray, record_all: bool = False) -> np.ndarray | Flight:
        """Fly ``thrust`` through every environment of ``wind`` for ``n`` samples of ``dt``
        [s] from ``start`` (3,) [m]: positions (n_env, n, 3) [m], or with ``record_all`` a
        :class:`~uavwind.sim.flight.Flight` with velocities, winds, attitudes, body rates,
        rotor speeds, specific forces and the limit shares. (Checked inputs: call it
        through :func:`uavwind.simulate` / :func:`uavwind.simulate_flight`.)"""
        from ._rotor_kernels import control_step

        self.check_thrust(thrust)
        per = self.check_grid(dt)
        P = self.packed
        n_env = wind.n_env
        h_ctrl = 1.0 / self.control_rate
        h = h_ctrl / self.substeps
        S = self.initial_states(start, wind._velocity(0.0, np.broadcast_to(start, (n_env, 3))))
        commands = self.segment_commands(thrust)
        T = np.empty(n_env)
        C = np.empty((n_env, 4))
        clipped = np.zeros(n_env, dtype=np.int64)
        limited_steps = 0
        positions = np.empty((n_env, n, 3))
        if record_all:
            rec = {k: np.empty((n_env, n, w)) for k, w in
                   (("v", 3), ("wind", 3), ("q", 4), ("w", 3), ("rotors", 4), ("f", 3))}
            forces = np.empty((n, 3))
        n_ctrl = n * per
        seg_of = thrust.segment(np.arange(n_ctrl) * h_ctrl)
        for k in range(n_ctrl):
            t = k * h_ctrl
            thrust_k, quat_k, limited = commands[int(max(seg_of[k], 0))]
            limited_steps += limited
            T[:] = thrust_k
            C[:] = quat_k
            S[:, 13:16] = wind._velocity(t, S[:, 0:3])
            if record_all and (k + 1) % per == 0:  # the held command, for the accelerometer
                u_held = _clipped_commands(P, S, T, C)
            control_step(P, S, T, C, 0, self.substeps, h, clipped)
            if (k + 1) % per == 0:
                j = (k + 1) // per - 1
                positions[:, j] = S[:, 0:3]
                if record_all:
                    rec["v"][:, j] = S[:, 3:6]
                    rec["wind"][:, j] = S[:, 13:16]
                    rec["q"][:, j] = S[:, 6:10]
                    rec["w"][:, j] = S[:, 10:13]
                    rec["rotors"][:, j] = S[:, 16:20]
                    rec["f"][:, j] = _specific_force(P, S, u_held)
                    T_j, q_j, _ = commands[int(max(seg_of[k], 0))]
                    forces[j] = T_j * _body_z(q_j)
        if not np.all(np.isfinite(positions)):
            raise ValueError("the multirotor's simulation produced non-finite positions (winds "
                             "or forces too large for float64); check the wind speeds")
        if not record_all:
            return positions
        return Flight(times=(np.arange(n) + 1) * dt, positions=positions,
                      ground_velocities=rec["v"], air_velocities=rec["v"] - rec["wind"],
                      winds=rec["wind"], thrust=forces, start=np.asarray(start, dtype=float),
                      attitudes=rec["q"], body_rates=rec["w"], rotor_speeds=rec["rotors"],
                      specific_forces=rec["f"], tilt_limited=limited_steps / n_ctrl,
                      motor_limited=float(clipped.sum()) / (n_ctrl * n_env))


def _body_z(q) -> np.ndarray:
    """The body's z axis in the world frame for the quaternion q [i, j, k, w]."""
    x, y, z, w = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)])


def _clipped_commands(P, S, T, C):
    from ._rotor_kernels import motor_commands
    return np.clip(motor_commands(P, S, T, C, 0), P[30], P[31])


def _specific_force(P, S, U):
    """What an accelerometer at the centre of mass reads, body frame [m/s^2]: ``R^T (dv/dt -
    g)`` at the states ``S`` under the held motor speeds ``U`` (RotorPy's IMU, no noise)."""
    from ._rotor_kernels import state_derivative

    vdot = state_derivative(P, S, U)[:, 3:6]
    acc = vdot - np.array([0.0, 0.0, -GRAVITY])
    q = S[:, 6:10] / np.linalg.norm(S[:, 6:10], axis=1, keepdims=True)
    x, y, z, w = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                  np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                  np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
                 axis=1)
    return np.einsum("nji,nj->ni", R, acc)
