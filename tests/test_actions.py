import math
import pickle

import numpy as np
import pytest

from uavwind import PAPER_EXAMPLE, ThrustSequence, sample_continuous, sample_paper


def test_piecewise_constant_thrust():
    seq = PAPER_EXAMPLE
    assert np.array_equal(seq.thrust(0.0), [0, 0, 40])
    assert np.array_equal(seq.thrust(3.99), [0, 0, 40])
    assert np.array_equal(seq.thrust(4.0), [15, 0, 0])       # a change at t counts from t
    assert np.array_equal(seq.thrust(0.1 * 40), [15, 0, 0])
    assert np.array_equal(seq.thrust(11.9), [0, 45, 0])
    assert seq.thrust(np.arange(120) * 0.1).shape == (120, 3)
    # float grid times just below a change still switch (0.1 * 30 = 3.0000000000000004)
    seq2 = ThrustSequence([0, 3], [1, 2], [[1, 0, 0]] * 2)
    assert np.array_equal(seq2.thrust(np.arange(120) * 0.1)[30], [2, 0, 0])


def test_directions_are_normalised():
    seq = ThrustSequence([0, 1], [10, 20], [[0, 0, 2], [1, 1, 0]])
    assert np.allclose(np.linalg.norm(seq.directions, axis=1), 1.0)
    assert np.allclose(seq.thrust(1.5), 20 * np.array([1, 1, 0]) / np.sqrt(2))


@pytest.mark.parametrize("args, match", [
    (([1, 2], [1, 1], [[1, 0, 0]] * 2), "times\\[0\\]"),
    (([0, 2, 2], [1, 1, 1], [[1, 0, 0]] * 3), "strictly increasing"),
    (([0, 1], [1, -1], [[1, 0, 0]] * 2), "magnitudes"),
    (([0, 1], [1, 1], [[1, 0, 0], [0, 0, 0]]), "directions"),
    (([0, 1], [1, 1], [[1, 0], [0, 1]]), "directions"),
    (([0, 1], [1, 1, 1], [[1, 0, 0]] * 2), "magnitudes"),
    (([0, np.nan], [1, 1], [[1, 0, 0]] * 2), "times"),
    (([], [], np.zeros((0, 3))), "times"),
])
def test_validation(args, match):
    with pytest.raises(ValueError, match=match):
        ThrustSequence(*args)


def test_immutable_and_picklable():
    with pytest.raises(AttributeError):
        PAPER_EXAMPLE.times = [0]
    seq = sample_continuous(np.random.default_rng(3))
    assert pickle.loads(pickle.dumps(seq)) == seq


def test_paper_sampler(rng):
    for n in range(12):
        seq = sample_paper(rng, n_changes=n)
        assert seq.n_changes == n
        assert seq.times[0] == 0 and np.all(seq.times[1:] == np.round(seq.times[1:]))
        assert np.all((seq.times[1:] > 0) & (seq.times[1:] < 12))
        assert np.all(seq.magnitudes % 5 == 0) and np.all((seq.magnitudes >= 0) & (seq.magnitudes <= 50))
        assert np.all(np.isin(seq.directions, (0.0, 1.0))) and np.all(seq.directions.sum(1) == 1)
    with pytest.raises(ValueError, match="n_changes"):
        sample_paper(rng, n_changes=12)
    with pytest.raises(TypeError, match="rng"):
        sample_paper(0)


def test_paper_sampler_covers_levels_and_axes():
    rng = np.random.default_rng(0)
    seqs = [sample_paper(rng) for _ in range(300)]
    mags = np.concatenate([s.magnitudes for s in seqs])
    assert set(np.unique(mags)) == set(np.arange(0, 55, 5.0))
    signed = np.concatenate([sample_paper(rng, axes="signed").directions for _ in range(100)])
    assert (signed < 0).any()


def test_sampler_is_deterministic_per_generator():
    a = sample_paper(np.random.default_rng(7))
    b = sample_paper(np.random.default_rng(7))
    assert a == b and hash(a) == hash(b)


def test_continuous_sampler(rng):
    seq = sample_continuous(rng, n_changes=4)
    assert seq.n_changes == 4
    assert np.all((seq.magnitudes >= 0) & (seq.magnitudes <= 50))
    assert np.allclose(np.linalg.norm(seq.directions, axis=1), 1)


def test_vector_round_trip_and_clipping():
    v = PAPER_EXAMPLE.to_vector()
    assert v.shape == (12,)
    assert ThrustSequence.from_vector(v, PAPER_EXAMPLE.times) == PAPER_EXAMPLE
    raw = np.array([-10, 0, 0, 3, 80, 1, 1, 0, 20, 0, 0, 0])
    seq = ThrustSequence.from_vector(raw, [0, 4, 8])
    assert seq.magnitudes.tolist() == [0, 50, 20]
    assert np.allclose(seq.directions, [[0, 0, 1], [2 ** -0.5, 2 ** -0.5, 0], [0, 0, 1]])
    with pytest.raises(ValueError, match="vector"):
        ThrustSequence.from_vector(raw[:-1], [0, 4, 8])


# --------------------------------------------------------------------------- #
# steps checked against their limits (issue 33)
# --------------------------------------------------------------------------- #
def test_sampled_attitudes_never_pass_their_limits():
    from uavwind.sim.actions import sample_attitude

    rng = np.random.default_rng(0)
    for _ in range(50):
        seq = sample_attitude(rng, tilt_step=0.3, magnitude_step=30.0)
        assert np.abs(seq.angles[:, :2]).max() <= math.radians(30.0) + 1e-12
        assert seq.thrusts.max() <= 50.0
    paper = np.concatenate([sample_paper(rng, magnitude_step=30.0).magnitudes
                            for _ in range(50)])
    assert set(np.unique(paper)) == {0.0, 30.0}


@pytest.mark.parametrize("kwargs, word", [
    ({"tilt_step": 0.0}, "tilt_step"), ({"tilt_step": 1.0}, "tilt_step"),
    ({"max_tilt": np.nan}, "max_tilt"), ({"max_tilt": 2.0}, "max_tilt"),
    ({"magnitude_step": 0.0}, "magnitude_step"), ({"magnitude_step": 60.0}, "magnitude_step"),
    ({"max_magnitude": -1.0}, "max_magnitude"), ({"max_magnitude": np.nan}, "max_magnitude"),
    ({"yaw_step": 0.0}, "yaw_step"), ({"yaw_step": np.nan}, "yaw_step"),
    ({"time_step": 0.0}, "time_step"), ({"time_step": -1.0}, "time_step")])
def test_sample_attitude_names_a_bad_step_or_limit(kwargs, word):
    from uavwind.sim.actions import sample_attitude

    with pytest.raises(ValueError, match=word):
        sample_attitude(np.random.default_rng(0), **kwargs)


@pytest.mark.parametrize("sampler, kwargs, word", [
    ("paper", {"magnitude_step": 0.0}, "magnitude_step"),
    ("paper", {"max_magnitude": np.nan}, "max_magnitude"),
    ("paper", {"time_step": 0.0}, "time_step"), ("paper", {"axes": "diagonal"}, "axes"),
    ("continuous", {"max_magnitude": -5.0}, "max_magnitude"),
    ("continuous", {"time_step": np.nan}, "time_step")])
def test_the_thrust_samplers_name_a_bad_step_or_limit(sampler, kwargs, word):
    from uavwind.sim.actions import SAMPLERS

    with pytest.raises(ValueError, match=word):
        SAMPLERS[sampler](np.random.default_rng(0), **kwargs)


@pytest.mark.parametrize("kwargs, word", [
    ({"max_tilt": np.nan}, "max_tilt"), ({"max_tilt": -0.1}, "max_tilt"),
    ({"max_magnitude": np.nan}, "max_magnitude"), ({"max_magnitude": -1.0}, "max_magnitude")])
def test_from_vector_names_a_bad_limit(kwargs, word):
    from uavwind.sim.actions import AttitudeSequence

    with pytest.raises(ValueError, match=word):
        AttitudeSequence.from_vector(np.zeros(4), [0.0], **kwargs)
    if "max_magnitude" in kwargs:
        with pytest.raises(ValueError, match=word):
            ThrustSequence.from_vector(np.zeros(4), [0.0], **kwargs)


def test_euler_to_quaternion_refuses_bad_angles():
    from uavwind.sim.actions import euler_to_quaternion

    with pytest.raises(ValueError, match="angles"):
        euler_to_quaternion([[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match="angles"):
        euler_to_quaternion([[0.0, 0.0]])
