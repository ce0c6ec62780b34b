"""Physical and numerical settings: the UAV and the simulation grid.

This module owns the constants of the paper's Table 4 (UAV and simulation
properties) as frozen, validated dataclasses, plus the small validation helpers
every other module uses so that bad input always fails the same way: a
``ValueError`` or ``TypeError`` that names the parameter and the allowed range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Standard gravity [m/s^2] (paper eq 4 uses 9.81).
GRAVITY = 9.81


# --------------------------------------------------------------------------- #
# validation helpers (shared by every module)
# --------------------------------------------------------------------------- #
def check_scalar(value, name, *, low=None, high=None, low_inclusive=True,
                 high_inclusive=True, integer=False):
    """Return ``value`` as a float (or int) after checking type, finiteness and range.

    Raises
    ------
    TypeError
        If ``value`` is not a real number (bools are rejected).
    ValueError
        If ``value`` is NaN/inf or outside ``[low, high]``; the message names
        ``name`` and the allowed range.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(
            value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a real number, got {type(value).__name__}")
    if integer:
        if not isinstance(value, (int, np.integer)):
            if not math.isfinite(float(value)):
                raise ValueError(f"{name} must be a finite integer, got {value}")
            if float(value) != int(value):
                raise TypeError(f"{name} must be an integer, got {value!r}")
        value = int(value)
    else:
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value}")
    lo_ok = low is None or (value >= low if low_inclusive else value > low)
    hi_ok = high is None or (value <= high if high_inclusive else value < high)
    if not (lo_ok and hi_ok):
        lb = "-inf" if low is None else f"{low}"
        hb = "inf" if high is None else f"{high}"
        rng = ("[" if low_inclusive and low is not None else "(") + f"{lb}, {hb}" + (
            "]" if high_inclusive and high is not None else ")")
        raise ValueError(f"{name} must be in {rng}, got {value}")
    return value


def check_array(value, name, *, shape=None, ndim=None, finite=True, dtype=float):
    """Return ``value`` as a float ndarray after checking shape and finiteness.

    ``shape`` may contain ``None`` for a free axis, e.g. ``(None, 3)``.
    """
    try:
        arr = np.asarray(value, dtype=dtype)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a numeric array: {exc}") from None
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"{name} must have {ndim} dimension(s), got shape {arr.shape}")
    if shape is not None:
        if arr.ndim != len(shape) or any(
                s is not None and s != a for s, a in zip(shape, arr.shape)):
            want = "(" + ", ".join("n" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if finite and arr.size and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must contain only finite values (no NaN or inf)")
    return arr


# --------------------------------------------------------------------------- #
# the UAV
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class UAV:
    """Point-mass multirotor (paper Table 4a).

    Parameters
    ----------
    mass : float
        Mass [kg], > 0. Paper: 2 kg.
    drag_coefficient : float
        Drag coefficient C_D [-], >= 0. Paper: 0.1.
    area : float
        Cross-sectional area S [m^2], >= 0. Paper: 0.01 m^2.
    air_density : float
        Air density rho [kg/m^3], >= 0. Paper: 1.225 kg/m^3.
    gravity : float
        Gravitational acceleration g [m/s^2], >= 0. Paper: 9.81 m/s^2.

    Examples
    --------
    >>> round(UAV().drag_factor, 10)   # 1/2 rho C_D S [kg/m]
    0.0006125
    """

    mass: float = 2.0
    drag_coefficient: float = 0.1
    area: float = 0.01
    air_density: float = 1.225
    gravity: float = GRAVITY

    def __post_init__(self):
        object.__setattr__(self, "mass",
                           check_scalar(self.mass, "mass", low=0, low_inclusive=False))
        for name in ("drag_coefficient", "area", "air_density", "gravity"):
            object.__setattr__(self, name, check_scalar(getattr(self, name), name, low=0))

    @property
    def drag_factor(self) -> float:
        """k = 1/2 rho C_D S [kg/m]; the drag force is -k |v_air| v_air [N]."""
        return 0.5 * self.air_density * self.drag_coefficient * self.area

    @property
    def weight(self) -> float:
        """m g [N]: the upward thrust that holds a hover in still air."""
        return self.mass * self.gravity


# --------------------------------------------------------------------------- #
# the simulation grid
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class SimulationSettings:
    """Time grid and initial condition of one flight (paper Table 4b).

    Parameters
    ----------
    dt : float
        Time step [s], > 0. Paper: 0.1 s.
    duration : float
        Flight duration [s], > 0 and a whole multiple of ``dt``. Paper: 12 s.
    start_altitude : float
        Initial height z0 [m] above ground. Default 10 m (DESIGN decision 1).

    Examples
    --------
    >>> SimulationSettings().n_steps
    120
    """

    dt: float = 0.1
    duration: float = 12.0
    start_altitude: float = 10.0

    def __post_init__(self):
        dt = check_scalar(self.dt, "dt", low=0, low_inclusive=False)
        duration = check_scalar(self.duration, "duration", low=0, low_inclusive=False)
        check_scalar(self.start_altitude, "start_altitude")
        object.__setattr__(self, "dt", dt)
        object.__setattr__(self, "duration", duration)
        object.__setattr__(self, "start_altitude", float(self.start_altitude))
        n_steps(dt, duration)  # validates the multiple

    @property
    def n_steps(self) -> int:
        """Number of recorded samples, duration / dt (120 for the paper)."""
        return n_steps(self.dt, self.duration)


def n_steps(dt: float, duration: float) -> int:
    """Number of integration steps ``duration / dt``; raises if not a whole number."""
    n = duration / dt
    k = int(round(n))
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ValueError(
            f"duration must be a positive whole multiple of dt, got duration={duration}, dt={dt}")
    return k


#: The paper's UAV and grid.
PAPER_UAV = UAV()
PAPER_SIMULATION = SimulationSettings()
