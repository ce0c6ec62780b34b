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


def test_cases_that_differ_in_what_they_observe_fly_each_loop_once(monkeypatch):
    """Setting.observe keeps the flights it flew: a setting that differs only in its
    observation, noise or baseline reads the same flight (read-only), and observes what it
    would have observed from a flight of its own, to the bit."""
    from dataclasses import replace

    from uavwind.sim import setting as st

    base = uw.make_setting("light constant", "strong constant", 2)
    thrust = base.sample_thrust(np.random.default_rng(3))
    seed = np.random.SeedSequence(7, spawn_key=(1,))
    kin = replace(base, observation="velocity", noise=uw.Noise(position=0.5), baseline=True)
    monkeypatch.setattr(st, "_FLIGHTS", type(st._FLIGHTS)())
    obs_a, flight_a, _ = base.observe(thrust, seed)
    obs_b, flight_b, pos_b = kin.observe(thrust, seed)
    assert flight_b is flight_a and len(st._FLIGHTS) == 1
    assert not flight_a.positions.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        flight_a.positions[0, 0, 0] = 1.0
    # another seed, wind or thrust is another flight
    assert base.observe(thrust, np.random.SeedSequence(8))[1] is not flight_a
    assert uw.make_setting("light constant", "strong constant", 3).observe(
        thrust, seed)[1] is not flight_a
    assert base.observe(base.sample_thrust(np.random.default_rng(4)), seed)[1] is not flight_a
    assert len(st._FLIGHTS) == 4
    assert base.observe(thrust, None)[1] is not flight_a and len(st._FLIGHTS) == 4  # never kept
    # kept or not, the same doubles
    monkeypatch.setattr(st, "FLIGHTS_KEPT", 0)
    monkeypatch.setattr(st, "_FLIGHTS", type(st._FLIGHTS)())
    alone_b, flight, alone_pos = kin.observe(thrust, seed)
    assert len(st._FLIGHTS) == 0 and flight is not flight_a
    assert np.array_equal(alone_b, obs_b) and np.array_equal(alone_pos, pos_b)
    assert np.array_equal(flight.positions, flight_a.positions)
    assert np.array_equal(base.observe(thrust, seed)[0], obs_a)
