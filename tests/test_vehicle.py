"""The point-mass UAV of the paper (Table 4a)."""
import math

import pytest

import uavwind as uw
from uavwind import UAV
from uavwind.sim.vehicle import n_steps


def test_paper_defaults():
    uav = UAV()
    assert (uav.mass, uav.drag_coefficient, uav.area, uav.air_density) == (2.0, 0.1, 0.01, 1.225)
    assert math.isclose(uav.drag_factor, 0.5 * 1.225 * 0.1 * 0.01)
    assert math.isclose(uav.weight, 2.0 * 9.81)
    s = uw.table3_setting()  # the paper's grid lives on the setting
    assert (s.dt, s.duration, s.start_altitude, n_steps(s.dt, s.duration)) == (0.1, 12.0, 10.0,
                                                                                 120)


@pytest.mark.parametrize("kwargs, name", [
    ({"mass": -1.0}, "mass"), ({"mass": 0.0}, "mass"), ({"mass": float("nan")}, "mass"),
    ({"drag_coefficient": -0.1}, "drag_coefficient"), ({"area": -1}, "area"),
    ({"air_density": float("inf")}, "air_density"),
])
def test_uav_rejects_bad_values(kwargs, name):
    with pytest.raises(ValueError, match=name):
        UAV(**kwargs)


def test_uav_rejects_wrong_types():
    with pytest.raises(TypeError, match="mass"):
        UAV(mass="2")
    with pytest.raises(TypeError, match="mass"):
        UAV(mass=True)


def test_frozen():
    with pytest.raises(AttributeError):
        UAV().mass = 3.0
