import math

import pytest

from uavwind import UAV, SimulationSettings
from uavwind.core.checks import check_scalar


def test_paper_defaults():
    uav = UAV()
    assert (uav.mass, uav.drag_coefficient, uav.area, uav.air_density) == (2.0, 0.1, 0.01, 1.225)
    assert math.isclose(uav.drag_factor, 0.5 * 1.225 * 0.1 * 0.01)
    assert math.isclose(uav.weight, 2.0 * 9.81)
    s = SimulationSettings()
    assert (s.dt, s.duration, s.start_altitude, s.n_steps) == (0.1, 12.0, 10.0, 120)


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


@pytest.mark.parametrize("kwargs, name", [
    ({"dt": 0.0}, "dt"), ({"dt": -0.1}, "dt"), ({"duration": -1.0}, "duration"),
    ({"dt": 0.07, "duration": 1.0}, "multiple of dt"),
])
def test_settings_reject_bad_values(kwargs, name):
    with pytest.raises(ValueError, match=name):
        SimulationSettings(**kwargs)


def test_frozen():
    with pytest.raises(AttributeError):
        UAV().mass = 3.0


def test_check_scalar_message_names_range():
    with pytest.raises(ValueError, match=r"alpha must be in \[0.0, 1.0\]|alpha must be in \[0, 1\]"):
        check_scalar(2.0, "alpha", low=0, high=1)
