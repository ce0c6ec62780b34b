"""The multirotor's parameters: RotorPy's hummingbird scaled into uavwind's presets, and the
settings of its position controller.

This module owns what a :class:`~uavwind.sim.multirotor.Multirotor` is made of: the presets
(:data:`PRESETS`) as RotorPy ``quad_params`` (:func:`rotorpy_params`) -- RotorPy 3.0.0's
``hummingbird_params`` (0.5 kg, :data:`BASE_MASS`) scaled to the vehicle's mass by mass
similarity, with the preset's drag (:data:`DRAG_KEYS` are the coefficients a drag factor
scales), and for ``"neuralfly"`` the frame, mass and thrust of Neural-Fly's quadrotor
(:data:`NEURAL_FLY`, :func:`default_mass`) -- and how reference flights are flown:
RotorPy's ``SE3Control`` gains (:data:`SE3_KP_POS`, :data:`SE3_KD_POS`) and
:class:`PositionControl`, an integral term and a thrust cone on top of them
(:data:`PX4_LIKE`, :data:`NEURAL_FLY_CONTROL`). Packing them into the kernels' parameter
vector, and flying, is :mod:`uavwind.sim.multirotor`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..core.checks import Range, check_array, check_choice, check_fields, check_scalar
from .vehicle import PAPER_UAV

__all__ = ["PRESETS", "EXTRA", "BASE_MASS", "GRAVITY", "NEURAL_FLY", "SE3_KP_POS", "SE3_KD_POS",
           "PositionControl", "PX4_LIKE", "NEURAL_FLY_CONTROL", "default_mass",
           "rotorpy_params", "DRAG_KEYS", "ROTOR_DRAG_KEYS"]

#: Presets: RotorPy's full aerodynamics (scaled), the paper's frame drag alone, or Neural-Fly's
#: quadrotor with RotorPy's aerodynamics.
PRESETS = ("rotorpy", "paper", "neuralfly")
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
    kp, kd : tuple of 3 float
        Position [1/s^2] and velocity [1/s] gains on x, y, z, each in (0, 1000]; default
        SE3's (:data:`SE3_KP_POS`, :data:`SE3_KD_POS`). Experiment 13's twin draws them per
        replicate (:meth:`scaled`).
    max_tilt : float
        Largest tilt of the desired force from up [deg], in (0, 89]; PX4's default 45.
    min_thrust, max_thrust : float
        Least and most collective thrust as a share of the rotors' full thrust [-]; PX4's
        defaults 0.12 and 1.
    max_integral_acceleration : float
        Bound on ``|ki I|`` per axis [m/s^2], in (0, 100]; default 10 (about g).
    """

    ki: tuple = (2.0, 2.0, 4.0)
    kp: tuple = SE3_KP_POS
    kd: tuple = SE3_KD_POS
    max_tilt: float = 45.0
    min_thrust: float = 0.12
    max_thrust: float = 1.0
    max_integral_acceleration: float = 10.0

    def __post_init__(self):
        ki = check_array(self.ki, "ki", shape=(3,))
        if np.any(ki < 0) or np.any(ki > 100):
            raise ValueError(f"ki must have every gain in [0, 100] [1/s^3], got {ki.tolist()}")
        object.__setattr__(self, "ki", tuple(float(k) for k in ki))
        for name in ("kp", "kd"):
            g = check_array(getattr(self, name), name, shape=(3,))
            if np.any(g <= 0) or np.any(g > 1000):
                raise ValueError(f"{name} must have every gain in (0, 1000], got {g.tolist()}")
            object.__setattr__(self, name, tuple(float(k) for k in g))
        check_fields(self, {
            "max_tilt": Range(0.0, 89.0, low_inclusive=False),
            "min_thrust": Range(0.0, 1.0),
            "max_thrust": lambda s: Range(s.min_thrust, 1.0, low_inclusive=False),
            "max_integral_acceleration": Range(0.0, 100.0, low_inclusive=False)})

    def scaled(self, bandwidth: float = 1.0, integral: float = 1.0) -> PositionControl:
        """The same law ``bandwidth`` times as fast: ``kp`` times its square, ``kd`` times it
        and ``ki`` times its cube (every root of ``s^3 + kd s^2 + kp s + ki`` times
        ``bandwidth``, the loop's shape kept), and ``ki`` also times ``integral``. Each factor
        in (0, 100]; ``scaled(1, 1)`` is this law."""
        b = check_scalar(bandwidth, "bandwidth", low=0.0, low_inclusive=False, high=100.0)
        i = check_scalar(integral, "integral", low=0.0, low_inclusive=False, high=100.0)
        return replace(self, kp=tuple(k * b * b for k in self.kp),
                       kd=tuple(k * b for k in self.kd),
                       ki=tuple(k * b ** 3 * i for k in self.ki))


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


#: The drag coefficients a vehicle's :attr:`~uavwind.sim.multirotor.Multirotor.drag_scale`
#: multiplies: frame drag (``c_D``), rotor drag (``k_d``) and induced inflow (``k_z``).
DRAG_KEYS = ("c_Dx", "c_Dy", "c_Dz", "k_d", "k_z")
#: The rotor-drag coefficients a vehicle's
#: :attr:`~uavwind.sim.multirotor.Multirotor.rotor_drag_scale` multiplies on top of its drag
#: factor: the rotors' H-force (``k_d``) and induced inflow (``k_z``), each linear in the
#: airspeed at a rotor speed, beside the frame's parasitic drag (``c_D``), quadratic in it.
ROTOR_DRAG_KEYS = ("k_d", "k_z")
