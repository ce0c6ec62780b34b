"""The paper's vehicle: a point-mass UAV (paper Table 4a), and the time grid rule.

This module owns :class:`UAV` (mass, drag coefficient, area, air density, gravity as a
frozen, validated value) and :func:`n_steps`, the one rule that turns a time step and a
flight duration into a number of samples.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.checks import Range, check_fields, check_scalar

#: Standard gravity [m/s^2] (paper eq 4 uses 9.81).
GRAVITY = 9.81


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
        check_fields(self, dict.fromkeys(("drag_coefficient", "area", "air_density", "gravity"),
                                         Range(0)))

    @property
    def drag_factor(self) -> float:
        """``k = 1/2 rho C_D S`` [kg/m]; the drag force is ``-k |v_air| v_air`` [N]."""
        return 0.5 * self.air_density * self.drag_coefficient * self.area

    @property
    def weight(self) -> float:
        """m g [N]: the upward thrust that holds a hover in still air."""
        return self.mass * self.gravity


def n_steps(dt: float, duration: float) -> int:
    """Number of integration steps ``duration / dt``; raises if not a whole number."""
    n = duration / dt
    k = int(round(n))
    if k < 1 or abs(n - k) > 1e-9 * max(1.0, n):
        raise ValueError(
            f"duration must be a positive whole multiple of dt, got duration={duration}, dt={dt}")
    return k


#: The paper's UAV.
PAPER_UAV = UAV()
