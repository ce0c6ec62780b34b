"""Wind models: the shared contract, the shear power law, Dryden vs MIL-F-8785C."""

import math

import numpy as np
import pytest

import uavwind as uw
from uavwind.sim.rollout import WindTable
from uavwind.sim.wind import libm_pow


def _models():
    return {
        "constant": uw.ConstantWind([[1.0, 1.0, 0.0], [2.0, -1.0, 0.5]]),
        "shear": uw.ShearWind([[2.1, 10.1, 0.0], [1.0, 1.0, 0.0]]),
        "dryden": uw.DrydenWind([11.5, 13.0], seed=3),
        "combined": uw.WindGroups(uw.ConstantWind([[1.0, 0, 0]]),
                                  uw.ShearWind([[0, 2.0, 0]] * 2),
                                  uw.DrydenWind([12.0], seed=1)),
        "sum": uw.ConstantWind([[-8.5, 0, 0]] * 2) + uw.DrydenWind([8.5, 8.5], seed=2),
        "ramped": uw.RampedWind(uw.ShearWind([[3.0, 0, 0]] * 2), ramp=2.0),
    }


def _twice(model):
    return model + model  # one term counted twice


@pytest.mark.parametrize("name", list(_models()) + ["sinusoidal", "cited", "ramped sum"])
def test_a_position_free_wind_gives_a_whole_flights_winds_as_its_steps(name):
    """A wind that reads no position says so (``position_free``) and gives the winds at many
    times at once, each exactly the one it gives at that time alone (the flight's kernel
    flies them): the shear, groups of winds and anything summed or ramped with a shear read
    the position and say so."""
    extra = {"sinusoidal": uw.SinusoidalWind([[-8.5, 0, 0], [1, 2, 3]], [[-2.4, 0, 0], [0, 1, 0]],
                                             period=2 * np.pi),
             "cited": uw.DrydenWind([11.5, 12.5, 13.5], airspeed=12.0, variant="cited", seed=1),
             "ramped sum": uw.RampedWind(_twice(uw.ConstantWind([[-8.5, 0, 0]] * 2))
                                         + uw.DrydenWind([8.5, 8.5], dt=0.01, seed=2), ramp=3.0)}
    model = {**_models(), **extra}[name]
    reads_position = name in ("shear", "combined", "ramped")
    assert model.position_free is not reads_position
    if reads_position:
        return
    times = np.arange(4001) * 0.0025  # 10 s, past the ramp, the period and the gust blocks
    here = np.zeros((model.n_env, 3))
    want = np.stack([model.velocity(t, here) for t in times])
    got = model._velocities(times)
    assert got.shape == (times.size, model.n_env, 3) and np.array_equal(got, want)
    assert np.ptp(want, axis=0).max() > 0 or name == "constant"


@pytest.mark.parametrize("name", list(_models()))
def test_every_model_honours_the_contract(name):
    model = _models()[name]
    assert isinstance(model, uw.WindModel)
    n = model.n_env
    assert len(model) == n
    pos = np.column_stack([np.zeros(n), np.zeros(n), np.linspace(1, 30, n)])
    for t in (0.0, 0.05, 1.0, 11.95, 30.0):
        v = model.velocity(t, pos)
        assert v.shape == (n, 3) and v.dtype == float and np.all(np.isfinite(v))
        assert np.array_equal(v, model.velocity(t, pos))  # pure function of (t, r)
    with pytest.raises(ValueError, match="positions"):
        model.velocity(0.0, np.zeros((n + 1, 3)))
    with pytest.raises(ValueError, match="positions"):
        model.velocity(0.0, np.full((n, 3), np.nan))
    with pytest.raises(ValueError, match="t must"):
        model.velocity(-1.0, pos)


def test_constant_wind_is_constant():
    w = uw.ConstantWind([[1.1, 1.1, 0.0]])
    for t, z in ((0, 10), (5, -3), (12, 500)):
        assert np.array_equal(w.velocity(t, [[3, 4, z]]), [[1.1, 1.1, 0.0]])


def test_shear_follows_power_law_and_floor():
    ref = np.array([[2.1, 10.1, 0.0], [1.0, 0.5, 0.0]])
    w = uw.ShearWind(ref, reference_height=10.0, alpha=0.143, floor=0.5)
    for z in (0.5, 3.0, 10.0, 25.0, 120.0):
        v = w.velocity(0.0, [[0, 0, z]] * 2)
        assert np.allclose(v, ref * (z / 10.0) ** 0.143, rtol=1e-14)
    at_floor = w.velocity(0.0, [[0, 0, 0.5]] * 2)
    for z in (0.49, 0.0, -20.0):  # below the floor the wind is held
        assert np.array_equal(w.velocity(0.0, [[0, 0, z]] * 2), at_floor)
    assert np.array_equal(w.velocity(0.0, [[0, 0, 10.0]] * 2), ref)


def test_shear_profile_is_libm_pow_on_every_cpu():
    """The profile factor is libm's ``pow`` bit for bit, in the model and in the rollouts' wind
    table. ``np.power`` is not: on an AVX-512 host numpy's own vector power differs from
    libm's in the last bit in a few percent of calls (an AVX2 host calls libm), which changed
    the trajectories of exp6's halves case 0 and the pinned digest of its rows
    (tests/test_pins.py). On such a host ``np.power`` fails the same check."""
    heights = np.concatenate([np.linspace(-5.0, 150.0, 3001), [0.5, 10.0, 10.0 + 2.0 ** -40]])
    for alpha in (0.143, 0.1, 0.2, 1 / 7, 0.4):
        w = uw.ShearWind([[2.0, 1.0, 0.0]] * len(heights), reference_height=10.0, alpha=alpha,
                         floor=0.5)
        expect = np.array([math.pow(max(z, 0.5) / 10.0, alpha) for z in heights])
        assert np.array_equal(w.factor(heights), expect)
        assert np.array_equal(libm_pow(np.maximum(heights, 0.5) / 10.0, alpha), expect)
        # a scalar exponent skips the broadcast; an array of exponents takes it: same doubles
        assert np.array_equal(libm_pow(np.maximum(heights, 0.5) / 10.0,
                                       np.full(len(heights), alpha)), expect)
        assert libm_pow(np.float64(2.5), alpha).shape == ()
        pos = np.zeros((len(heights), 3))
        pos[:, 2] = heights
        assert np.array_equal(w.velocity(0.0, pos), expect[:, None] * [2.0, 1.0, 0.0])
        got = WindTable(w, [0.0]).lookup(np.arange(len(heights)))(0, pos)
        assert np.array_equal(got, expect[:, None] * [2.0, 1.0, 0.0])


@pytest.mark.parametrize("kwargs, match", [
    ({"reference_height": 0.0}, "reference_height"), ({"alpha": -0.1}, "alpha"),
    ({"alpha": 1.5}, "alpha"), ({"floor": 0.0}, "floor"),
])
def test_shear_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        uw.ShearWind([[1.0, 1.0, 0.0]], **kwargs)


@pytest.mark.parametrize("bad, err, match", [
    ([[1.0, 1.0]], ValueError, "shape"), ([1.0, 1.0, 0.0], ValueError, "velocities"),
    ([[np.nan, 1.0, 0.0]], ValueError, "finite"), ([[np.inf, 1.0, 0.0]], ValueError, "finite"),
    (np.zeros((0, 3)), ValueError, "at least one"), ([["a", "b", "c"]], TypeError, "velocities"),
])
def test_constant_validation(bad, err, match):
    with pytest.raises(err, match=match):
        uw.ConstantWind(bad)


def test_combined_validation_and_groups():
    with pytest.raises(ValueError, match="models"):
        uw.WindGroups()
    with pytest.raises(TypeError, match="models\\[1\\]"):
        uw.WindGroups(uw.ConstantWind([[1, 0, 0]]), "shear")
    w = uw.WindGroups([uw.ConstantWind([[1, 0, 0]] * 2), uw.ShearWind([[0, 1, 0]] * 3)])
    assert w.groups.tolist() == [0, 0, 1, 1, 1]
    pos = np.array([[0, 0, 10.0]] * 2 + [[0, 0, 20.0]] * 3)
    v = w.velocity(0.0, pos)
    assert np.array_equal(v[:2], [[1, 0, 0]] * 2)
    assert np.allclose(v[2:, 1], 2 ** 0.143)


def test_groups_keep_the_old_name():
    assert uw.CombinedWind is uw.WindGroups


def test_sum_adds_winds_over_the_same_environments():
    mean = uw.ConstantWind([[-8.5, 0.0, 0.0]])
    gusts = uw.DrydenWind([8.5], altitude=2.15, dt=0.02, seed=4)
    w = mean + gusts
    assert isinstance(w, uw.SumWind) and w.n_env == 1
    pos = np.array([[0.0, 0.0, 2.15]])
    v = np.array([w.velocity(t, pos)[0] for t in np.arange(0, 20, 0.02)])
    g = np.array([gusts.velocity(t, pos)[0] for t in np.arange(0, 20, 0.02)])
    assert np.array_equal(v, g + [-8.5, 0.0, 0.0])
    assert v[:, 0].std() > 0.1  # the gusts are there: a sum, not groups side by side
    # a grouping of the same two models is two environments, the first without gusts
    groups = uw.WindGroups(mean, gusts)
    assert groups.n_env == 2
    assert np.array_equal(groups.velocity(3.0, np.repeat(pos, 2, 0))[0], [-8.5, 0.0, 0.0])


def test_sum_validation():
    with pytest.raises(ValueError, match="same environments"):
        uw.SumWind(uw.ConstantWind([[1, 0, 0]]), uw.ConstantWind([[1, 0, 0]] * 2))
    with pytest.raises(ValueError, match="at least one"):
        uw.SumWind()
    with pytest.raises(TypeError, match="models\\[1\\]"):
        uw.SumWind(uw.ConstantWind([[1, 0, 0]]), 3.0)
    assert uw.ConstantWind([[1, 0, 0]]).__add__(1.0) is NotImplemented


def test_ramp_fades_the_wind_in():
    base = uw.ConstantWind([[4.0, -2.0, 0.0]])
    w = uw.RampedWind(base, ramp=3.0)
    pos = np.zeros((1, 3))
    speeds = [w.velocity(t, pos)[0, 0] for t in np.linspace(0, 3, 31)]
    assert speeds[0] == 0.0 and speeds[-1] == 4.0
    assert np.all(np.diff(speeds) > 0)
    assert np.array_equal(w.velocity(7.0, pos), base.velocity(7.0, pos))
    with pytest.raises(ValueError, match="ramp"):
        uw.RampedWind(base, ramp=0.0)
    with pytest.raises(TypeError, match="model"):
        uw.RampedWind("wind", ramp=1.0)


# --------------------------------------------------------------------------- #
# Dryden
# --------------------------------------------------------------------------- #


# --------------------------------------------------------------------------- #
# the closed-form zero-order hold: the oracle python-control's discretisation is held to
# --------------------------------------------------------------------------- #




def test_a_deeply_nested_sum_is_flat_and_evaluated_in_one_loop():
    """Issue 68: 3,000 nested sums raised RecursionError, and `w = w + w` forty times made
    2^40 calls (a hang)."""
    w = uw.ConstantWind([[0.5, 0.0, 0.0]])
    for _ in range(3000):
        w = w + uw.ConstantWind([[0.5, 0.0, 0.0]])
    assert len(w.terms) == 3001 and all(k == 1 for _, k in w.terms)
    assert w.velocity(0.0, [[0, 0, 10]])[0].tolist() == [1500.5, 0.0, 0.0]
    v = uw.ConstantWind([[1.0, -2.0, 0.0]])
    for _ in range(40):
        v = v + v
    assert v.terms[0][1] == 2 ** 40 and len(v.terms) == 1
    assert v.velocity(0.0, [[0, 0, 10]])[0].tolist() == [2.0 ** 40, -2.0 ** 41, 0.0]
    a, b = uw.ConstantWind([[1.0, 0, 0]]), uw.ConstantWind([[0, 1.0, 0]])
    assert [k for _, k in (a + (b + a)).terms] == [2, 1]  # one model added twice: one term


@pytest.mark.parametrize("wrap", ["sum", "ramp", "groups", "sum of a ramp"])
def test_with_seed_reseeds_the_gusts_inside_sums_ramps_and_groups(wrap):
    """Issue 68: with_seed on a sum or a RampedWind left its gusts' seed unchanged."""
    gusts = uw.DrydenWind([12.0], seed=0)
    calm = uw.ConstantWind([[1.0, 0.0, 0.0]])
    model = {"sum": calm + gusts, "ramp": uw.RampedWind(gusts, 1.0),
             "groups": uw.WindGroups(calm, gusts),
             "sum of a ramp": calm + uw.RampedWind(gusts, 1.0)}[wrap]
    pos = np.tile([[0.0, 0.0, 10.0]], (model.n_env, 1))

    def at(m):
        return m.velocity(3.0, pos)
    one, again, two = model.with_seed(1), model.with_seed(1), model.with_seed(2)
    assert np.array_equal(at(one), at(again))  # same seed, same gusts
    assert not np.array_equal(at(one), at(model)) and not np.array_equal(at(one), at(two))
    assert np.array_equal(at(model), at(model.with_seed(0))) == (wrap == "ramp")
    if wrap == "ramp":  # a ramp passes the seed on: its model's gusts, faded in
        assert np.array_equal(at(one), at(gusts.with_seed(1)))
    assert calm.with_seed(1) is calm and (calm + calm).with_seed(3).terms[0][0] is calm
    with pytest.raises(TypeError, match="seed"):
        model.with_seed("one")
