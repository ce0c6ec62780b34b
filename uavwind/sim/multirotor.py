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
    from .references import Reference
    from .wind import WindModel

__all__ = ["Multirotor", "GroundContact", "PRESETS", "STARTS", "EXTRA", "rotorpy_params",
           "force_command", "DRAG_KEYS", "NEURAL_FLY", "PositionControl", "PX4_LIKE",
           "NEURAL_FLY_CONTROL"]

#: Presets: RotorPy's full aerodynamics (scaled), the paper's frame drag alone, or Neural-Fly's
#: quadrotor with RotorPy's aerodynamics.
PRESETS = ("rotorpy", "paper", "neuralfly")
#: How a flight starts: at rest over the ground, or moving with the air mass.
STARTS = ("hover", "drifting")
#: The pip extra that installs RotorPy.
EXTRA = "multirotor"
#: The mass of RotorPy's hummingbird, the vehicle scaled [kg].
BASE_MASS = 0.5
#: RotorPy's gravity [m/s^2] (``Multirotor.g``).
GRAVITY = 9.81
#: The quadrotor of Neural-Fly's flights (O'Connell et al., "Neural-Fly enables rapid learning
#: for agile flight in strong winds", Science Robotics 7(66), eabm6597, 2022; arXiv 2205.06908,
#: "UAV Design"): "weighs 2.6 kg with a thrust to weight ratio of 2.2", "a wide-X configuration,
#: measuring 85 cm in width, 75 cm in length, and 93 cm diagonally". Assumed here (the article
#: gives no more): the 93 cm diagonal is hub to hub and the hubs lie on a rectangle of the
#: footprint's 75 : 85 aspect, so at x = +-0.3077 m (length), y = +-0.3487 m (width).
NEURAL_FLY = {"mass": 2.6, "thrust_to_weight": 2.2, "width": 0.85, "length": 0.75,
              "diagonal": 0.93}
#: ``SE3Control``'s position gains (``kp_pos`` [1/s^2], ``kd_pos`` [1/s]; RotorPy 3.0.0 fixes them).
SE3_KP_POS = (6.5, 6.5, 15.0)
SE3_KD_POS = (4.0, 4.0, 9.0)
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
    flies none). This module's one lazy import."""
    from . import _rotor_kernels
    return _rotor_kernels


@dataclass(frozen=True)
class PositionControl:
    """SE3's position law with an integral term and a thrust cone, as PX4's multicopter
    position controller has them (``MPC_TILTMAX_AIR``, ``MPC_THR_MIN``, ``MPC_THR_MAX``, and an
    integral that removes the steady error a steady wind leaves under a PD law).

    The desired force is RotorPy's ``SE3Control``'s, ``m (-kp e - kd e_v + a_ref + g e_z)``
    (its gains), plus ``-m ki I`` with ``I`` the integral of the position error; it is then
    limited with vertical priority: its vertical part within ``[min_thrust, max_thrust]`` of
    the rotors' full thrust, its horizontal part within the tilt cone and the rest of the
    full thrust. The integral stops while the force is limited (anti-windup).

    Parameters
    ----------
    ki : tuple of 3 float
        Integral gains on x, y, z [1/s^3], each in [0, 100]; default (2, 2, 4): per axis the
        loop ``s^3 + kd s^2 + kp s + ki`` with SE3's gains (kp 6.5, kd 4 on x, y; 15 and 9 on
        z) has every root's real part below -0.35 1/s.
    max_tilt : float
        Largest tilt of the desired force from up [deg], in (0, 89]; PX4's default 45.
    min_thrust, max_thrust : float
        Least and most collective thrust as a share of the rotors' full thrust [-]; PX4's
        defaults 0.12 and 1.
    max_integral_acceleration : float
        Bound on ``|ki I|`` per axis [m/s^2], in (0, 100]; default 10 (about g).
    """

    ki: tuple = (2.0, 2.0, 4.0)
    max_tilt: float = 45.0
    min_thrust: float = 0.12
    max_thrust: float = 1.0
    max_integral_acceleration: float = 10.0

    def __post_init__(self):
        ki = check_array(self.ki, "ki", shape=(3,))
        if np.any(ki < 0) or np.any(ki > 100):
            raise ValueError(f"ki must have every gain in [0, 100] [1/s^3], got {ki.tolist()}")
        object.__setattr__(self, "ki", tuple(float(k) for k in ki))
        object.__setattr__(self, "max_tilt", check_scalar(self.max_tilt, "max_tilt", low=0.0,
                                                          low_inclusive=False, high=89.0))
        object.__setattr__(self, "min_thrust", check_scalar(self.min_thrust, "min_thrust",
                                                            low=0.0, high=1.0))
        object.__setattr__(self, "max_thrust", check_scalar(self.max_thrust, "max_thrust",
                                                            low=self.min_thrust, high=1.0,
                                                            low_inclusive=False))
        object.__setattr__(self, "max_integral_acceleration", check_scalar(
            self.max_integral_acceleration, "max_integral_acceleration", low=0.0,
            low_inclusive=False, high=100.0))


#: PX4's defaults on RotorPy's SE3 gains.
PX4_LIKE = PositionControl()
#: The same with a 60 degree tilt cone, for the Neural-Fly quadrotor (Exps 13 and 14): its
#: thrust-to-weight 2.2 allows acos(1 / 2.2) = 63 degrees in level flight, and PX4's default
#: 45 would clip the lean that 12-14 m/s winds ask of it on top of a manoeuvre.
NEURAL_FLY_CONTROL = PositionControl(max_tilt=60.0)

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


def _neural_fly_hubs() -> tuple[float, float]:
    """Hub offsets (x along the length, y along the width) [m] of the Neural-Fly quadrotor."""
    half = NEURAL_FLY["diagonal"] / 2
    n = math.hypot(NEURAL_FLY["length"], NEURAL_FLY["width"])
    return half * NEURAL_FLY["length"] / n, half * NEURAL_FLY["width"] / n


def default_mass(preset: str) -> float:
    """The mass a preset flies at unless told otherwise [kg]: 2 (the paper's UAV), or 2.6
    for ``"neuralfly"`` (the article's)."""
    return NEURAL_FLY["mass"] if preset == "neuralfly" else 2.0


def rotorpy_params(preset: str = "rotorpy", mass: float | None = None) -> dict:
    """The vehicle as a RotorPy ``quad_params`` dict (for ``rotorpy.vehicles.multirotor
    .Multirotor``): ``hummingbird_params`` scaled to ``mass`` [kg] (default: the preset's,
    :func:`default_mass`), with the ``preset``'s drag. ``"neuralfly"`` also moves the hubs to
    the Neural-Fly quadrotor's (:data:`NEURAL_FLY`), scales each moment of inertia by the
    square of its arm's growth (``I ~ m L^2``) and sets the top rotor speed to its
    thrust-to-weight ratio 2.2. Needs RotorPy (``ImportError`` naming the extra otherwise)."""
    check_choice(preset, "preset", PRESETS)
    if mass is None:
        mass = default_mass(preset)
    mass = check_scalar(mass, "mass", low=0.0, low_inclusive=False, high=1e3)
    base = _hummingbird()
    f = mass / BASE_MASS
    qp = {k: (v * f if k in _SCALED else v) for k, v in base.items()}
    qp["rotor_pos"] = {k: np.array(v, dtype=float) for k, v in base["rotor_pos"].items()}
    if preset == "neuralfly":
        hx, hy = _neural_fly_hubs()
        old = [float(abs(v[0])) for v in base["rotor_pos"].values()][0]  # hummingbird d / sqrt 2
        qp["rotor_pos"] = {k: np.array([math.copysign(hx, v[0]), math.copysign(hy, v[1]), 0.0])
                           for k, v in base["rotor_pos"].items()}
        qp["Ixx"] = qp["Ixx"] * (hy / old) ** 2           # roll: arms along y
        qp["Iyy"] = qp["Iyy"] * (hx / old) ** 2           # pitch: arms along x
        qp["Izz"] = qp["Izz"] * (hx * hx + hy * hy) / (2 * old * old)
        qp["rotor_speed_max"] = math.sqrt(NEURAL_FLY["thrust_to_weight"] * mass * GRAVITY
                                          / (4 * qp["k_eta"]))
    if preset == "paper":
        c = PAPER_UAV.drag_factor  # 1/2 rho C_D S [kg/m], isotropic: the point mass's drag
        qp.update(c_Dx=c, c_Dy=c, c_Dz=c, k_d=0.0, k_z=0.0, k_h=0.0, k_flap=0.0)
    return qp


#: The drag coefficients :attr:`Multirotor.drag_scale` multiplies: frame drag (``c_D``),
#: rotor drag (``k_d``) and induced inflow (``k_z``).
DRAG_KEYS = ("c_Dx", "c_Dy", "c_Dz", "k_d", "k_z")


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
        Factor on the drag coefficients :data:`DRAG_KEYS` [-], in (0, 100]; default 1 (the
        preset's). Experiment 13 fits it to real flights.
    lift_scale : float
        Factor on the translational lift ``k_h`` [-], in [0, 100]; default 1 (the preset's).
        Experiment 13 fits it to the real flights' vertical force.
    position_control : PositionControl, optional
        How reference flights are flown: None (default) RotorPy's ``SE3Control`` as it is;
        a :class:`PositionControl` adds an integral term and a thrust cone (:data:`PX4_LIKE`).

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
    position_control: PositionControl | None = None

    def __post_init__(self):
        check_choice(self.preset, "preset", PRESETS)
        check_choice(self.start, "start", STARTS)
        mass = default_mass(self.preset) if self.mass is None else self.mass
        object.__setattr__(self, "mass", check_scalar(mass, "mass", low=0.0,
                                                      low_inclusive=False, high=1e3))
        object.__setattr__(self, "tilt_limit", check_scalar(
            self.tilt_limit, "tilt_limit", low=0.0, low_inclusive=False, high=90.0))
        object.__setattr__(self, "control_rate", check_scalar(
            self.control_rate, "control_rate", low=10.0, high=1e4))
        object.__setattr__(self, "substeps", check_scalar(self.substeps, "substeps", low=1,
                                                          high=100, integer=True))
        object.__setattr__(self, "drag_scale", float(check_scalar(
            self.drag_scale, "drag_scale", low=0.0, low_inclusive=False, high=100.0)))
        object.__setattr__(self, "lift_scale", float(check_scalar(
            self.lift_scale, "lift_scale", low=0.0, high=100.0)))
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
                       self.position_control)

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
        return float(4 * P[_K_ETA] * P[_SPEED_MAX] ** 2)

    @property
    def hover_speed(self) -> float:
        """Rotor speed whose thrust holds the vehicle in still air [rad/s]."""
        return math.sqrt(self.weight / (4 * self.packed[23]))

    def drag_force(self, airspeed: float) -> float:
        """Horizontal aerodynamic force [N] on the vehicle hovering level (rotors at hover
        speed) in a horizontal airspeed of ``airspeed`` [m/s], opposing it: what couples a
        hovering multirotor to the wind (``F(1 m/s)`` is the per-speed coupling of the rotor
        drag, which is linear; the frame drag is quadratic)."""
        state_derivative = _kernels().state_derivative

        S = self.initial_states(np.zeros(3), np.zeros((1, 3)))
        S[0, 13] = check_scalar(airspeed, "airspeed", low=0.0, high=1e3)  # wind along x
        U = np.full((1, 4), self.hover_speed)
        return float(state_derivative(self.packed, S, U)[0, 3] * self.mass)

    def hover_trim(self, airspeed: float) -> tuple[float, float]:
        """``(tilt [deg], collective thrust [N])`` that hold the vehicle still in a steady
        horizontal wind of ``airspeed`` [m/s], in [0, 100]: every rotor at one speed, the body
        pitched into the wind until the rotors' thrust, gravity and the aerodynamic forces
        (frame and rotor drag, induced inflow, translational lift) balance (Newton steps on
        the tilt and the rotor speed, to 1e-9 m/s^2). Tilting into the wind shows it more
        frame to drag, so the lean exceeds ``atan(drag_force / weight)``. ``ValueError`` if
        no speed within the rotors' range holds it."""
        state_derivative = _kernels().state_derivative

        airspeed = check_scalar(airspeed, "airspeed", low=0.0, high=100.0)
        P = self.packed

        def residual(x):
            th, om = x
            S = self.initial_states(np.zeros(3), np.zeros((1, 3)))
            S[0, 6:10] = [0.0, math.sin(th / 2), 0.0, math.cos(th / 2)]  # pitch about y
            S[0, 13] = airspeed
            S[0, 16:20] = om
            d = state_derivative(P, S, np.full((1, 4), om))[0]
            return np.array([d[3], d[5]])

        x = np.array([-math.atan2(self.drag_force(airspeed), self.weight), self.hover_speed])
        for _ in range(50):
            r = residual(x)
            if np.abs(r).max() < 1e-9:
                break
            J = np.empty((2, 2))
            for j, h in enumerate((1e-6, 1e-3)):
                dx = np.zeros(2)
                dx[j] = h
                J[:, j] = (residual(x + dx) - r) / h
            x = x - np.linalg.solve(J, r)
        if np.abs(residual(x)).max() > 1e-6 or not P[_SPEED_MIN] <= x[1] <= P[_SPEED_MAX]:
            raise ValueError(f"airspeed = {airspeed:g} m/s: no rotor speed within the rotors' "
                             f"range holds this vehicle still in it")
        return abs(math.degrees(x[0])), float(4 * P[_K_ETA] * x[1] ** 2)

    def quad_params(self) -> dict:
        """This vehicle as RotorPy's ``quad_params`` (for ``rotorpy``'s own ``Multirotor``)."""
        qp = rotorpy_params(self.preset, self.mass)
        if self.drag_scale != 1.0:
            qp.update({k: qp.get(k, 0.0) * self.drag_scale for k in DRAG_KEYS})
        if self.lift_scale != 1.0:
            qp["k_h"] = qp.get("k_h", 0.0) * self.lift_scale
        return qp

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
            start: np.ndarray, record_all: bool = False,
            clip_log: np.ndarray | None = None) -> np.ndarray | Flight:
        """Fly ``thrust`` through every environment of ``wind`` for ``n`` samples of ``dt``
        [s] from ``start`` (3,) [m]: positions (n_env, n, 3) [m], or with ``record_all`` a
        :class:`~uavwind.sim.flight.Flight` with velocities, winds, attitudes, body rates,
        rotor speeds, specific forces and the limit shares. ``clip_log``, a boolean array
        (n_env, n * control steps per sample), if given, is filled with whether a motor command
        was clipped in each control step (it changes nothing of the flight). (Checked inputs:
        call it through :func:`uavwind.simulate` / :func:`uavwind.simulate_flight`.)"""
        control_step = _kernels().control_step

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
        if clip_log is not None and clip_log.shape != (n_env, n_ctrl):
            raise ValueError(f"clip_log must have shape {(n_env, n_ctrl)}, got {clip_log.shape}")
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
            if clip_log is not None:
                before = clipped.copy()
            control_step(P, S, T, C, 0, self.substeps, h, clipped)
            if clip_log is not None:
                clip_log[:, k] = clipped != before
            if (k + 1) % per == 0:
                j = (k + 1) // per - 1
                positions[:, j] = S[:, 0:3]
                if record_all:
                    _record_state(rec, j, P, S, u_held)
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

    def fly_reference(self, reference: Reference, wind: WindModel, dt: float, n: int,
                      record_all: bool = False) -> np.ndarray | Flight:
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
        (Checked inputs: call it through :func:`uavwind.simulate` /
        :func:`uavwind.simulate_flight`.)"""
        control_step = _kernels().control_step

        if self.start != "hover":
            raise ValueError(f"start = {self.start!r}: a reference flight starts hovering at "
                             f"the reference's position at t = 0; use start='hover'")
        per = self.check_grid(dt)
        P = self.packed
        n_env = wind.n_env
        h_ctrl = 1.0 / self.control_rate
        h = h_ctrl / self.substeps
        n_ctrl = n * per
        t_ctrl = np.arange(n_ctrl) * h_ctrl
        flat = reference.flat_output(np.append(t_ctrl, n * dt))
        F = np.column_stack([flat["x"], flat["x_dot"], flat["x_ddot"], flat["yaw"],
                             flat["yaw_dot"]])
        low = int(np.argmin(F[:, 2]))
        if F[low, 2] < 0.0:
            raise ValueError(f"reference: its path goes below the ground (z = {F[low, 2]:.4g} m "
                             f"at t = {min(low, n_ctrl) * h_ctrl:.4g} s); keep it above z = 0")
        start = F[0, 0:3].copy()
        S = self.initial_states(start, np.zeros((n_env, 3)))
        mode = 2
        if self.position_control is not None:  # the integral of the position error, from 0
            S = np.hstack([S, np.zeros((n_env, _N_STATE_PI - _N_STATE))])
            mode = 3
        T = np.empty(n_env)
        clipped = np.zeros(n_env, dtype=np.int64)
        positions = np.empty((n_env, n, 3))
        if record_all:
            rec = {k: np.empty((n_env, n, w)) for k, w in
                   (("v", 3), ("wind", 3), ("q", 4), ("w", 3), ("rotors", 4), ("f", 3),
                    ("fa", 3), ("thrust", 3))}
            commands = np.empty((n_env, n))
        for k in range(n_ctrl):
            C = np.ascontiguousarray(np.broadcast_to(F[k], (n_env, 11)))
            S[:, 13:16] = wind._velocity(t_ctrl[k], S[:, 0:3])
            last = (k + 1) % per == 0
            if record_all and last:  # the command held over the step, for the sensors
                b3 = _body_z_batch(S[:, 6:10])
                u_held = _clipped_se3(P, S, C, mode)
            control_step(P, S, T, C, mode, self.substeps, h, clipped)
            finite = np.isfinite(S).all(axis=1)
            if not finite.all():
                i = int(np.argmin(finite))
                raise ValueError(f"environment {i}: the multirotor's state became non-finite at "
                                 f"t = {(k + 1) * h_ctrl:.4g} s flying the reference (winds or "
                                 f"forces too large for float64); check the wind speeds")
            below = S[:, 2] < 0.0
            if below.any():
                i = int(np.argmax(below))
                raise GroundContact(
                    f"environment {i} would go below the ground (z = {S[i, 2]:.4g} m) at "
                    f"t = {(k + 1) * h_ctrl:.4g} s flying the reference: the flight is refused "
                    f"(a multirotor does not fly through the floor); check the winds and the "
                    f"reference's height", env=i, time=(k + 1) * h_ctrl)
            if last:
                j = (k + 1) // per - 1
                positions[:, j] = S[:, 0:3]
                if record_all:
                    _record_state(rec, j, P, S, u_held)
                    rec["fa"][:, j] = _aero_force(P, S, u_held)
                    rec["thrust"][:, j] = T[:, None] * b3
                    commands[:, j] = T
        if not record_all:
            return positions
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
