"""A setting: two groups of environments, the vehicle and the grid of one loop."""
import numpy as np
import pytest

import uavwind as uw


def test_turbulence_group_builds_dryden():
    s = uw.make_setting("light constant", "strong turbulence", 4)
    w = s.wind(seed=1)
    assert isinstance(w.models[1], uw.DrydenWind)
    assert np.allclose(w.models[1].w20, s.group_b.speeds)


def test_setting_key_is_stable_and_sensitive():
    a = uw.make_setting("light constant", "strong constant", 5)
    b = uw.make_setting("light constant", "strong constant", 5)
    assert a.key() == b.key() and hash(a) == hash(b) and a == b
    assert a.key() != uw.make_setting("light constant", "strong constant", 6).key()
    assert a.key() != uw.make_setting("light constant", "strong constant", 5, n_changes=4).key()
    assert a.key() != uw.make_setting("light constant", "strong constant", 5, uav=uw.UAV(mass=3)).key()


@pytest.mark.parametrize("call, err, match", [
    (lambda: uw.WindCondition("medium", "constant"), ValueError, "strength"),
    (lambda: uw.WindCondition("light", "breeze"), ValueError, "kind"),
    (lambda: uw.WindCondition.parse("light"), ValueError, "condition"),
    (lambda: uw.WindCondition.parse(3), TypeError, "condition"),
    (lambda: uw.make_setting("light constant", "strong shear", 0), ValueError, "n_a"),
    (lambda: uw.make_setting("light constant", "strong shear", sampler="sobol"), ValueError, "sampler"),
    (lambda: uw.EnvironmentGroup("constant", [[1.0, np.nan, 0.0]]), ValueError, "finite"),
    (lambda: uw.EnvironmentGroup("constant", [[1.0, 0.0]]), ValueError, "shape"),
    (lambda: uw.EnvironmentGroup("turbulence", [0.0]), ValueError, "W20"),
    (lambda: uw.Setting("a", "b"), TypeError, "group_a"),
])
def test_validation(call, err, match):
    with pytest.raises(err, match=match):
        call()
