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
Three presets: ``"rotorpy"`` (the full aerodynamics, scaled), ``"paper"`` (the paper's
frame drag, ``1/2 rho C_D S`` of :data:`~uavwind.sim.vehicle.PAPER_UAV` on every body axis,
which equals the point mass's ``-k |v_air| v_air`` exactly, and no rotor drag, lift or
flapping) and ``"neuralfly"``, the quadrotor of Neural-Fly's wind-tunnel flights (see
:meth:`Multirotor.neural_fly`: its mass, thrust-to-weight ratio and size from the article,
RotorPy's aerodynamics scaled to it).

*Position control.* :meth:`Multirotor.fly_reference` flies a position reference
(:mod:`uavwind.sim.references`) with RotorPy's ``SE3Control`` (its default gains), ported to
the kernels and held to RotorPy's own controller by the tests; it starts hovering at the
reference's position at t = 0 and refuses a flight that would go below the ground (z = 0).

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

The vehicle's numbers (the presets, RotorPy's scaled parameters,
:class:`~uavwind.sim.rotor_params.PositionControl`) are :mod:`uavwind.sim.rotor_params`' and
are re-exported here; their packing into the kernels' parameter vector and what a recorded
flight stores at each sample are ``uavwind.sim._rotor_layout``'s, the slots of that vector
and the columns of the state ``uavwind.sim._slots``'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import (Range, check_array, check_choice, check_fields, check_instance,
                           check_scalar)
from ._rotor_layout import (_body_z, _body_z_batch, _clipped_commands, _clipped_se3, _kernels,
                            _packed, _recorded)
from ._slots import (FLAT_ACC, FLAT_ERR, FLAT_POS, FLAT_VEL, FLAT_YAW, FLAT_YAW_RATE, K_ETA,
                     N_FLAT, N_FLAT_ERR, N_STATE, N_STATE_PI, S_POS, S_QUAT, S_ROTORS, S_VEL, S_WIND, SPEED_MAX,
                     SPEED_MIN)
from .actions import AttitudeSequence, ThrustSequence
from .flight import Flight
from .rotor_params import (DRAG_KEYS, GRAVITY, PRESETS, ROTOR_DRAG_KEYS, PositionControl,
                           default_mass, rotorpy_params)

if TYPE_CHECKING:
    from .references import Reference
    from .wind import WindModel

__all__ = ["Multirotor", "GroundContact", "STARTS", "force_command"]

#: How a flight starts: at rest over the ground, or moving with the air mass.
STARTS = ("hover", "drifting")
#: :meth:`Multirotor.hover_trim` takes this many Newton steps past its tolerance, to the
#: root's last digits, then rounds its tilt and thrust to :data:`TRIM_DIGITS` significant
#: digits (about 1e-11 relative): where the solve stopped, and so the trim's last digits,
#: depended on the path its steps took, and an AVX-512 Xeon and an AVX2 EPYC gave Exp 14
#: different waypoint limits, so different cache keys; rounded, the trim's noise (about 1e-15
#: relative) is far below the last digit kept.
TRIM_POLISH = 3
TRIM_DIGITS = 12


class GroundContact(ValueError):
    """A reference flight that would go below the ground (z = 0): refused, never flown
    through. ``env`` is the first environment to touch it, ``time`` when [s]."""

    def __init__(self, message: str, env: int, time: float):
        super().__init__(message)
        self.env, self.time = env, time


def _tilt_quaternion(b3: np.ndarray) -> np.ndarray:
    """Quaternion [i, j, k, w] of the minimal rotation taking e_z to the unit vector b3 (yaw
    0: no rotation about the thrust axis; defined for every b3 but -e_z)."""
    c = min(max(float(b3[2]), -1.0), 1.0)
    half = 0.5 * math.acos(c)
    axis = np.array([-b3[1], b3[0], 0.0]) + 0.0  # e_z x b3 (+ 0.0: no negative zeros)
    n = float(np.linalg.norm(axis))
    axis = axis / n if n > 0 else np.array([1.0, 0.0, 0.0])
    return np.concatenate([math.sin(half) * axis, [math.cos(half)]])


def rotvec_quaternions(ex: np.ndarray, ey: np.ndarray) -> np.ndarray:
    """Quaternions [i, j, k, w] (..., 4) of the rotations by the rotation vectors
    ``(ex, ey, 0)`` [rad] (the same rotation as the kernels' ``_tilt_error``)."""
    th = np.hypot(ex, ey)
    half = 0.5 * th
    s = np.where(th > 0, np.sin(half) / np.where(th > 0, th, 1.0), 0.5)
    return np.stack([s * ex, s * ey, np.zeros_like(ex), np.cos(half)], axis=-1)


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products ``a b`` of quaternions [i, j, k, w] (rotation ``a`` after ``b``), a
    (n, 4) and b (4,) or (n, 4)."""
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


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


#: The multirotor's number fields: mass [kg], tilt limit [deg], control rate [Hz], RK4
#: substeps per control step, drag and translational-lift factors [-].
_RANGES = {"mass": Range(0.0, 1e3, low_inclusive=False),
           "tilt_limit": Range(0.0, 90.0, low_inclusive=False),
           "control_rate": Range(10.0, 1e4),
           "substeps": Range(1, 100, integer=True),
           "drag_scale": Range(0.0, 100.0, low_inclusive=False),
           "lift_scale": Range(0.0, 100.0),
           "rotor_drag_scale": Range(0.0, 100.0, low_inclusive=False),
           "hover_throttle": Range(0.01, 1.0)}


def _refuse_step(status, k, i, S, h_ctrl):
    """The refusal of :meth:`Multirotor.fly_reference` when environment ``i`` became
    non-finite (``status`` 1) or went below the ground (2) in control step ``k``."""
    t = (k + 1) * h_ctrl
    if status == 1:
        raise ValueError(f"environment {i}: the multirotor's state became non-finite at "
                         f"t = {t:.4g} s flying the reference (winds or forces too large for "
                         f"float64); check the wind speeds")
    z = S[i, S_POS.start + 2]
    raise GroundContact(
        f"environment {i} would go below the ground (z = {z:.4g} m) at t = {t:.4g} s flying "
        f"the reference: the flight is refused (a multirotor does not fly through the floor); "
        f"check the winds and the reference's height", env=i, time=t)


@dataclass(frozen=True, kw_only=True)
class Multirotor:
    """RotorPy's quadrotor, scaled to ``mass``, as a vehicle of uavwind (see the module text).

    Parameters
    ----------
    preset : {"rotorpy", "paper", "neuralfly"}
        RotorPy's hummingbird with its full aerodynamics, the same with the paper's frame
        drag alone, or Neural-Fly's quadrotor with RotorPy's aerodynamics
        (:meth:`neural_fly`).
    start : {"hover", "drifting"}
        At rest over the ground, or moving with the air mass (reference flights start
        hovering at the reference: ``"hover"`` only).
    mass : float, optional
        [kg], in (0, 1000]; default the preset's: 2 (the paper's UAV), 2.6 for
        ``"neuralfly"``.
    tilt_limit : float
        Largest tilt of the thrust from up [deg], in (0, 90]; default 90 (the paper's
        commands flown as stated). Reference flights ignore it (RotorPy's SE3 controller has
        no tilt limit).
    control_rate : float
        Command updates per second [Hz], in [10, 10000]; default 100 (RotorPy's).
    substeps : int
        RK4 steps per command update, in [1, 100]; default 4 (2.5 ms at 100 Hz).
    drag_scale : float
        Factor on the drag coefficients :data:`~uavwind.sim.rotor_params.DRAG_KEYS` [-], in
        (0, 100]; default 1 (the preset's). Experiment 13 fits it to real flights.
    rotor_drag_scale : float
        Further factor on the rotor drag alone (H-force and induced inflow,
        :data:`~uavwind.sim.rotor_params.ROTOR_DRAG_KEYS`, linear in the airspeed at a rotor
        speed), in (0, 100]; default 1 (the
        preset's ratio of rotor to frame drag). With ``drag_scale`` it sets the linear and the
        quadratic drag apart: Experiment 13 fits both on the real flights' force per wind.
    lift_scale : float
        Factor on the translational lift ``k_h`` [-], in [0, 100]; default 1 (the preset's).
        Experiment 13 fits it to the real flights' vertical force.
    position_control : PositionControl, optional
        How reference flights are flown: None (default) RotorPy's ``SE3Control`` as it is;
        a :class:`~uavwind.sim.rotor_params.PositionControl` adds an integral term and a
        thrust cone (:data:`~uavwind.sim.rotor_params.PX4_LIKE`).
    hover_throttle : float, optional
        The weight over the rotors' full thrust [-], in [0.01, 1] (the reciprocal of the
        thrust-to-weight ratio; a battery's charge moves it): sets the rotors' top speed.
        Default None, the preset's (1 / 2.2 = 0.455 for ``"neuralfly"``).

    Examples
    --------
    >>> mr = Multirotor(preset="rotorpy", start="hover")
    >>> round(mr.max_thrust, 1), round(mr.hover_speed, 1)
    (200.5, 469.2)
    """

    preset: str = "rotorpy"
    start: str = "hover"
    mass: float | None = None
    tilt_limit: float = 90.0
    control_rate: float = 100.0
    substeps: int = 4
    drag_scale: float = 1.0
    lift_scale: float = 1.0
    rotor_drag_scale: float = 1.0
    position_control: PositionControl | None = None
    hover_throttle: float | None = None

    def __post_init__(self):
        check_choice(self.preset, "preset", PRESETS)
        check_choice(self.start, "start", STARTS)
        mass = default_mass(self.preset) if self.mass is None else self.mass
        object.__setattr__(self, "mass", mass)
        check_fields(self, {k: r for k, r in _RANGES.items()
                            if k != "hover_throttle" or self.hover_throttle is not None})
        if self.position_control is not None:
            check_instance(self.position_control, "position_control", PositionControl)
        self.packed  # needs RotorPy: fail here, with the extra named, not mid-flight

    @classmethod
    def neural_fly(cls, **kwargs) -> Multirotor:
        """The quadrotor of Neural-Fly's wind-tunnel flights (O'Connell et al., Science
        Robotics 7(66), eabm6597, 2022, "UAV Design"), ``preset="neuralfly"``:

        * mass 2.6 kg and thrust-to-weight ratio 2.2 (the article: "weighs 2.6 kg with a
          thrust to weight ratio of 2.2"): top rotor speed 695.9 rad/s, 56.1 N at full speed;
        * hubs at x = +-0.308 m, y = +-0.349 m (the article's wide-X frame, "85 cm in width,
          75 cm in length, and 93 cm diagonally"; assumed: the diagonal is hub to hub and the
          hubs keep the 75 : 85 aspect; its tilted motors are not modelled);
        * everything the article does not give is RotorPy's hummingbird scaled by mass
          similarity (as for the other presets): ``k_eta``, ``k_m`` and every drag coefficient
          times 2.6 / 0.5, so hover at 469.2 rad/s; inertia times 5.2 and the square of each
          axis's arm growth (Ixx 0.160, Iyy 0.125, Izz 0.274 kg m^2); motor time constant,
          attitude gains and SE3 gains RotorPy's.

        ``kwargs`` are the other fields (``start``, ``control_rate``, ...; ``mass`` too, to
        scale the same vehicle).

        >>> mr = Multirotor.neural_fly()
        >>> mr.mass, round(mr.max_thrust / mr.weight, 3)
        (2.6, 2.2)
        """
        if "preset" in kwargs:
            raise TypeError("neural_fly() sets preset='neuralfly'; give the other fields only")
        return cls(preset="neuralfly", **kwargs)

    # -- the vehicle --------------------------------------------------------- #
    @property
    def packed(self) -> np.ndarray:
        """The kernels' parameter vector (read-only)."""
        return _packed(self.preset, self.mass, self.drag_scale, self.lift_scale,
                       self.position_control, self.hover_throttle, self.rotor_drag_scale)

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
        return float(4 * P[K_ETA] * P[SPEED_MAX] ** 2)

    @property
    def thrust_coefficient(self) -> float:
        """The rotors' thrust coefficient ``k_eta`` [N/(rad/s)^2]: a rotor turning at
        ``omega`` [rad/s] makes ``k_eta omega^2`` of thrust (no translational lift)."""
        return float(self.packed[K_ETA])

    @property
    def hover_speed(self) -> float:
        """Rotor speed whose thrust holds the vehicle in still air [rad/s]."""
        return math.sqrt(self.weight / (4 * self.packed[K_ETA]))

    def drag_force(self, airspeed: float) -> float:
        """Horizontal aerodynamic force [N] on the vehicle hovering level (rotors at hover
        speed) in a horizontal airspeed of ``airspeed`` [m/s], opposing it: what couples a
        hovering multirotor to the wind (``F(1 m/s)`` is the per-speed coupling of the rotor
        drag, which is linear; the frame drag is quadratic)."""
        state_derivative = _kernels().state_derivative

        S = self.initial_states(np.zeros(3), np.zeros((1, 3)))
        S[0, S_WIND.start] = check_scalar(airspeed, "airspeed", low=0.0, high=1e3)  # along x
        U = np.full((1, 4), self.hover_speed)
        return float(state_derivative(self.packed, S, U)[0, S_VEL.start] * self.mass)  # x

    def hover_trim(self, airspeed: float) -> tuple[float, float]:
        """``(tilt [deg], collective thrust [N])`` that hold the vehicle still in a steady
        horizontal wind of ``airspeed`` [m/s], in [0, 100]: every rotor at one speed, the body
        pitched into the wind until the rotors' thrust, gravity and the aerodynamic forces
        (frame and rotor drag, induced inflow, translational lift) balance (Newton steps on
        the tilt and the rotor speed, to 1e-9 m/s^2, then :data:`TRIM_POLISH` more, both
        rounded to :data:`TRIM_DIGITS` significant digits: the same doubles on every host).
        Tilting into the wind shows it more
        frame to drag, so the lean exceeds ``atan(drag_force / weight)``. ``ValueError`` if
        no speed within the rotors' range holds it."""
        state_derivative = _kernels().state_derivative

        airspeed = check_scalar(airspeed, "airspeed", low=0.0, high=100.0)
        P = self.packed

        def residual(x):
            th, om = x
            S = self.initial_states(np.zeros(3), np.zeros((1, 3)))
            S[0, S_QUAT] = [0.0, math.sin(th / 2), 0.0, math.cos(th / 2)]  # pitch about y
            S[0, S_WIND.start] = airspeed  # along x
            S[0, S_ROTORS] = om
            dv = state_derivative(P, S, np.full((1, 4), om))[0, S_VEL]
            return np.array([dv[0], dv[2]])  # x and z

        def newton_step(x, r):
            """``x`` less the Newton step on ``r = residual(x)``: the Jacobian by forward
            differences and the 2 x 2 system by Cramer's rule in Python floats, not a BLAS
            kernel (which the CPU chooses: the one host-dependent step the solve had)."""
            J = np.empty((2, 2))
            for j, h in enumerate((1e-6, 1e-3)):
                dx = np.zeros(2)
                dx[j] = h
                J[:, j] = (residual(x + dx) - r) / h
            (a, b), (c, d) = J.tolist()
            det = a * d - b * c
            return x - np.array([(d * r[0] - b * r[1]) / det, (a * r[1] - c * r[0]) / det])

        x = np.array([-math.atan2(self.drag_force(airspeed), self.weight), self.hover_speed])
        r = residual(x)
        for _ in range(50):
            if np.abs(r).max() < 1e-9:
                break
            x = newton_step(x, r)
            r = residual(x)
        if np.abs(r).max() > 1e-6 or not P[SPEED_MIN] <= x[1] <= P[SPEED_MAX]:
            raise ValueError(f"airspeed = {airspeed:g} m/s: no rotor speed within the rotors' "
                             f"range holds this vehicle still in it")
        for _ in range(TRIM_POLISH):  # on to the root's last digits, wherever the solve stopped
            x = newton_step(x, r)
            r = residual(x)
        tilt, thrust = abs(math.degrees(x[0])), float(4 * P[K_ETA] * x[1] ** 2)
        return float(f"{tilt:.{TRIM_DIGITS}g}"), float(f"{thrust:.{TRIM_DIGITS}g}")

    def quad_params(self) -> dict:
        """This vehicle as RotorPy's ``quad_params`` (for ``rotorpy``'s own ``Multirotor``)."""
        qp = rotorpy_params(self.preset, self.mass)
        if self.drag_scale != 1.0:
            qp.update({k: qp.get(k, 0.0) * self.drag_scale for k in DRAG_KEYS})
        if self.rotor_drag_scale != 1.0:
            qp.update({k: qp.get(k, 0.0) * self.rotor_drag_scale for k in ROTOR_DRAG_KEYS})
        if self.lift_scale != 1.0:
            qp["k_h"] = qp.get("k_h", 0.0) * self.lift_scale
        if self.hover_throttle is not None:
            qp["rotor_speed_max"] = math.sqrt(self.weight / (4 * qp["k_eta"]
                                                             * self.hover_throttle))
        return qp

    # -- flying -------------------------------------------------------------- #
    def initial_states(self, start_position, winds0) -> np.ndarray:
        """(n_env, 20) states (``uavwind.sim._slots``' columns) at t = 0: level, no rates,
        rotors at hover speed, at ``start_position``; at rest (``"hover"``) or with the wind
        ``winds0`` (n_env, 3) (``"drifting"``)."""
        start_position = check_array(start_position, "start_position", shape=(3,))
        winds0 = check_array(winds0, "winds0", shape=(None, 3))
        n = winds0.shape[0]
        s = np.zeros((n, N_STATE))
        s[:, S_POS] = start_position
        s[:, S_QUAT] = [0.0, 0.0, 0.0, 1.0]  # level: the identity [i, j, k, w]
        s[:, S_ROTORS] = self.hover_speed
        if self.start == "drifting":
            s[:, S_VEL] = winds0
        return s

    def check_grid(self, dt: float) -> int:
        """Control steps per recorded sample ``dt`` [s]; ``ValueError`` unless ``dt`` is a
        whole number of control steps."""
        dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False, high=1e6)
        per = dt * self.control_rate
        k = self.steps_per_sample(dt)
        if k < 1 or abs(per - k) > 1e-9 * max(1.0, per):
            raise ValueError(f"dt = {dt:g} s must be a whole number of the multirotor's "
                             f"control steps (1/{self.control_rate:g} s)")
        return k

    def steps_per_sample(self, dt: float) -> int:
        """Control steps per recorded sample ``dt`` [s], unchecked: ``dt`` already passed
        :meth:`check_grid` (the private paths below a public entry use this)."""
        return int(round(dt * self.control_rate))

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
            start: np.ndarray, record_all: bool = False,
            clip_log: np.ndarray | None = None,
            state_errors: np.ndarray | None = None) -> np.ndarray | Flight:
        """Fly ``thrust`` through every environment of ``wind`` for ``n`` samples of ``dt``
        [s] from ``start`` (3,) [m]: positions (n_env, n, 3) [m], or with ``record_all`` a
        :class:`~uavwind.sim.flight.Flight` with velocities, winds, attitudes, body rates,
        rotor speeds, specific forces and the limit shares. ``clip_log``, a boolean array
        (n_env, n * control steps per sample), if given, is filled with whether a motor command
        was clipped in each control step (it changes nothing of the flight).

        ``state_errors`` (n_env, n * control steps per sample, 6), as
        :meth:`fly_reference`'s: at each control step the attitude loop reads an attitude
        estimate off the true attitude by the world rotation ``E`` of ``(e_x, e_y, 0)`` [rad]
        (columns 0, 1), which is exactly the true attitude flying the command ``E^T R_d``, so
        the command is rotated so; and the rotors make ``1 + e_t`` times the commanded thrust
        (column 2). Columns 3-5 (a velocity estimate) are not read: nothing flown open loop
        reads a velocity. The record keeps the true state and the commanded thrust. None
        (default): the command as given, the same code path as before the errors existed.
        (Checked inputs: call it through :func:`uavwind.simulate` /
        :func:`uavwind.simulate_flight`, which check the thrust and the grid once; this
        trusts them.)"""
        control_step = _kernels().control_step

        per = self.steps_per_sample(dt)
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
        if record_all:  # each sample's state, and the commands held over its last control
            states = np.empty((n_env, n, S.shape[1]))  # step: the sensors, after the flight
            before = np.empty((n_env, n, S.shape[1]))
            held_thrust = np.empty(n)
            held_quat = np.empty((n, 4))
            forces = np.empty((n, 3))
        n_ctrl = n * per
        if clip_log is not None and clip_log.shape != (n_env, n_ctrl):
            raise ValueError(f"clip_log must have shape {(n_env, n_ctrl)}, got {clip_log.shape}")
        if state_errors is not None:
            state_errors = check_array(state_errors, "state_errors", shape=(n_env, n_ctrl, 6))
            if not np.all(np.abs(state_errors[..., :3]) < 0.5):
                raise ValueError("state_errors must have small attitude and thrust errors: each "
                                 "|error| of columns 0-2 below 0.5 (rad, or a share of the "
                                 "thrust)")
            q_err = rotvec_quaternions(-state_errors[..., 0], -state_errors[..., 1])  # E^T
            gain = 1.0 + state_errors[..., 2]
            if record_all:
                held_thrust = np.empty((n_env, n))
                held_quat = np.empty((n_env, n, 4))
        seg_of = thrust.segment(np.arange(n_ctrl) * h_ctrl)
        for k in range(n_ctrl):
            t = k * h_ctrl
            thrust_k, quat_k, limited = commands[int(max(seg_of[k], 0))]
            limited_steps += limited
            if state_errors is None:
                T[:] = thrust_k
                C[:] = quat_k
            else:  # the thrust the rotors make, the command the true attitude flies
                T[:] = thrust_k * gain[:, k]
                C[:] = quaternion_product(q_err[:, k], quat_k)
            S[:, S_WIND] = wind._velocity(t, S[:, S_POS])
            last = (k + 1) % per == 0
            j = (k + 1) // per - 1
            if record_all and last:  # the state the held command is computed from
                before[:, j] = S
                if state_errors is None:
                    held_thrust[j], held_quat[j] = thrust_k, quat_k
                else:
                    held_thrust[:, j], held_quat[:, j] = T, C
            if clip_log is not None:
                clipped_before = clipped.copy()
            control_step(P, S, T, C, 0, self.substeps, h, clipped)
            if clip_log is not None:
                clip_log[:, k] = clipped != clipped_before
            if last:
                positions[:, j] = S[:, S_POS]
                if record_all:
                    states[:, j] = S
                    forces[j] = thrust_k * _body_z(quat_k)
        if not np.all(np.isfinite(positions)):
            raise ValueError("the multirotor's simulation produced non-finite positions (winds "
                             "or forces too large for float64); check the wind speeds")
        if not record_all:
            return positions
        u_held = _clipped_commands(P, before.reshape(n_env * n, -1),
                                   np.broadcast_to(held_thrust, (n_env, n)).ravel(),
                                   np.broadcast_to(held_quat, (n_env, n, 4)).reshape(-1, 4))
        # (with state errors the rotor speeds are those flown; Flight.thrust is the command)
        rec = _recorded(P, states, u_held.reshape(n_env, n, 4))
        return Flight(times=(np.arange(n) + 1) * dt, positions=positions,
                      ground_velocities=rec["v"], air_velocities=rec["v"] - rec["wind"],
                      winds=rec["wind"], thrust=forces, start=np.asarray(start, dtype=float),
                      attitudes=rec["q"], body_rates=rec["w"], rotor_speeds=rec["rotors"],
                      specific_forces=rec["f"], tilt_limited=limited_steps / n_ctrl,
                      motor_limited=float(clipped.sum()) / (n_ctrl * n_env))

    def fly_reference(self, reference: Reference, wind: WindModel, dt: float, n: int,
                      record_all: bool = False,
                      state_errors: np.ndarray | None = None) -> np.ndarray | Flight:
        """Fly the position ``reference`` with RotorPy's ``SE3Control`` through every
        environment of ``wind`` for ``n`` samples of ``dt`` [s]: positions (n_env, n, 3) [m],
        or with ``record_all`` a :class:`~uavwind.sim.flight.Flight` that also carries the
        reference positions, the commanded collective thrusts and the aerodynamic forces.

        The vehicle starts hovering (level, at rest, rotors at hover speed) at the reference's
        position at t = 0. Every control step (``1 / control_rate``) the controller reads the
        state and the reference's flat output at the step's start, as RotorPy's
        ``simulate`` does; ``tilt_limit`` does not apply (``SE3Control`` has none: the
        record's ``tilt_limited`` is 0, ``motor_limited`` counts clipped motor commands).
        ``ValueError`` if the reference goes below the ground (z < 0)
        within the flight (before flying), or if an environment does (naming it and when).

        ``state_errors`` (n_env, n * control steps per sample, 6), with a
        :class:`~uavwind.sim.rotor_params.PositionControl` only: at each control step the
        controller reads an attitude estimate off the true attitude by the world rotation
        ``(e_x, e_y, 0)`` [rad] (columns 0, 1), the rotors make ``1 + e_t`` times the thrust it
        commands (column 2) and it reads the velocity off by columns 3-5 [m/s] (the kernels'
        mode 4); the record keeps the true state and the commanded thrust.
        None (default) or all zeros: a perfect state.
        (Checked inputs: call it through :func:`uavwind.simulate` /
        :func:`uavwind.simulate_flight`.)"""
        control_step = _kernels().control_step

        if self.start != "hover":
            raise ValueError(f"start = {self.start!r}: a reference flight starts hovering at "
                             f"the reference's position at t = 0; use start='hover'")
        per = self.steps_per_sample(dt)  # checked by the caller (check_grid)
        P = self.packed
        n_env = wind.n_env
        h_ctrl = 1.0 / self.control_rate
        h = h_ctrl / self.substeps
        n_ctrl = n * per
        t_ctrl = np.arange(n_ctrl) * h_ctrl
        t_flat = np.append(t_ctrl, n * dt)
        flat = reference.flat_output(t_flat)
        F = np.empty((t_flat.size, N_FLAT))  # one flat-output row per control step, and the end
        F[:, FLAT_POS], F[:, FLAT_VEL], F[:, FLAT_ACC] = flat["x"], flat["x_dot"], flat["x_ddot"]
        F[:, FLAT_YAW], F[:, FLAT_YAW_RATE] = flat["yaw"], flat["yaw_dot"]
        z_ref = F[:, FLAT_POS.start + 2]
        low = int(np.argmin(z_ref))
        if z_ref[low] < 0.0:
            raise ValueError(f"reference: its path goes below the ground (z = {z_ref[low]:.4g} m "
                             f"at t = {min(low, n_ctrl) * h_ctrl:.4g} s); keep it above z = 0")
        start = F[0, FLAT_POS].copy()
        S = self.initial_states(start, np.zeros((n_env, 3)))
        mode = 2
        if self.position_control is not None:  # the integral of the position error, from 0
            S = np.hstack([S, np.zeros((n_env, N_STATE_PI - N_STATE))])
            mode = 3
        if state_errors is not None:
            if self.position_control is None:
                raise ValueError("state_errors needs a vehicle with position_control (the "
                                 "integral law flies them); this one flies RotorPy's SE3")
            state_errors = check_array(state_errors, "state_errors", shape=(n_env, n_ctrl, 6))
            if not np.all(np.abs(state_errors[..., :3]) < 0.5):
                raise ValueError("state_errors must have small attitude and thrust errors: each "
                                 "|error| of columns 0-2 below 0.5 (rad, or a share of the "
                                 "thrust)")
            mode = 4
        width = N_FLAT_ERR if mode == 4 else N_FLAT
        C = np.empty((n_env, width))
        T = np.empty(n_env)
        clipped = np.zeros(n_env, dtype=np.int64)
        positions = np.empty((n_env, n, 3))
        if record_all:  # each sample's state, and the state its held command is computed
            states = np.empty((n_env, n, S.shape[1]))  # from: the sensors, after the flight
            before = np.empty((n_env, n, S.shape[1]))
            commands = np.empty((n_env, n))
        if wind.position_free:  # the whole loop in the kernel, the winds computed at once
            W = np.ascontiguousarray(wind._velocities(t_ctrl), dtype=float)
            E = (np.ascontiguousarray(state_errors, dtype=float) if mode == 4
                 else np.empty((n_env, 0, 6)))
            if not record_all:
                states = before = np.empty((0, 0, 0))
                commands = np.empty((0, 0))
            status, k, i = _kernels().fly_flat(P, S, F, E, W, mode, self.substeps, h, per, T,
                                               clipped, positions, before, states, commands,
                                               record_all)
            if status:
                _refuse_step(status, k, i, S, h_ctrl)
        else:  # a wind that reads where the vehicle is: asked step by step
            for k in range(n_ctrl):
                C[:, :N_FLAT] = F[k]
                if mode == 4:
                    C[:, FLAT_ERR] = state_errors[:, k]
                S[:, S_WIND] = wind._velocity(t_ctrl[k], S[:, S_POS])
                last = (k + 1) % per == 0
                j = (k + 1) // per - 1
                if record_all and last:  # the state the held command is computed from
                    before[:, j] = S
                control_step(P, S, T, C, mode, self.substeps, h, clipped)
                finite = np.isfinite(S).all(axis=1)
                if not finite.all():
                    _refuse_step(1, k, int(np.argmin(finite)), S, h_ctrl)
                below = S[:, S_POS.start + 2] < 0.0
                if below.any():
                    _refuse_step(2, k, int(np.argmax(below)), S, h_ctrl)
                if last:
                    positions[:, j] = S[:, S_POS]
                    if record_all:
                        states[:, j] = S
                        commands[:, j] = T
        if not record_all:
            return positions
        last_steps = np.arange(per - 1, n_ctrl, per)  # each sample's last control step
        held_from = before.reshape(n_env * n, -1)
        rows = np.empty((n_env, n, width))
        rows[:, :, :N_FLAT] = F[last_steps]
        if mode == 4:
            rows[:, :, FLAT_ERR] = state_errors[:, last_steps]
        u_held = _clipped_se3(P, held_from, rows.reshape(-1, width), mode)
        rec = _recorded(P, states, u_held.reshape(n_env, n, 4), aero=True)
        rec["thrust"] = commands[:, :, None] * _body_z_batch(
            held_from[:, S_QUAT]).reshape(n_env, n, 3)
        times = (np.arange(n) + 1) * dt
        return Flight(times=times, positions=positions, ground_velocities=rec["v"],
                      air_velocities=rec["v"] - rec["wind"], winds=rec["wind"],
                      thrust=rec["thrust"], start=start, attitudes=rec["q"],
                      body_rates=rec["w"], rotor_speeds=rec["rotors"], specific_forces=rec["f"],
                      tilt_limited=0.0, motor_limited=float(clipped.sum()) / (n_ctrl * n_env),
                      references=np.broadcast_to(reference.positions(times),
                                                 (n_env, n, 3)).copy(),
                      thrust_commands=commands,
                      aero_forces=rec["fa"])
