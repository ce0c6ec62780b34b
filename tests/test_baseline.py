"""The physics baseline: a least-squares wind estimate from the same positions."""
import numpy as np
import pytest

import uavwind as uw
from uavwind.method.baseline import estimate_wind
from uavwind.sim.observation import Noise, observe


def _flight(wind, thrust=uw.PAPER_EXAMPLE):
    return uw.simulate_flight(thrust, wind)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_estimate_wind_is_exact_on_noise_free_constant_wind(seed):
    rng = np.random.default_rng(seed)
    thrust = uw.sample_paper(rng)
    w = rng.uniform(-5, 5, size=(4, 3))
    pos = uw.simulate(thrust, uw.ConstantWind(w))
    assert np.allclose(estimate_wind(pos, thrust), w, rtol=0, atol=1e-12)
    path = estimate_wind(pos, thrust, model="path")
    assert path.shape == (4, 120, 3) and np.allclose(path, w[:, None], atol=1e-9)


def test_path_model_recovers_a_shear_wind_along_the_path():
    f = uw.simulate_flight(uw.PAPER_EXAMPLE, uw.ShearWind([[2.0, 10.0, 0.0]]))
    est = estimate_wind(f.positions, uw.PAPER_EXAMPLE, model="path")
    assert np.allclose(est, f.winds, atol=1e-9)


def test_estimate_wind_is_unbiased_under_white_noise():
    w = np.array([[1.0, 0.5, 0.0]])
    f = _flight(uw.ConstantWind(w))
    est = np.array([estimate_wind(observe(f, "position", Noise(position=1.0), seed=s),
                                  uw.PAPER_EXAMPLE)[0] for s in range(400)])
    err = est - w[0]
    se = err.std(axis=0, ddof=1) / np.sqrt(len(err))
    assert np.all(np.abs(err.mean(axis=0)) < 3 * se)


def test_the_std_is_the_noise_carried_through_the_estimate():
    """With the positions' noise given, the std is sigma / sqrt(sum t^2) (the closed form),
    and it is what the spread over noise draws shows; without it, the residuals' reading is
    close to it; zero without noise."""
    w = np.array([[1.0, 0.5, 0.0]])
    f = _flight(uw.ConstantWind(w))
    t = (np.arange(120) + 1.0) * 0.1
    mean, std = estimate_wind(f.positions, uw.PAPER_EXAMPLE, return_std=True)
    assert np.allclose(mean, w, atol=1e-12) and np.all(std < 1e-12)
    _, std = estimate_wind(f.positions, uw.PAPER_EXAMPLE, return_std=True, position_noise=1.0)
    assert np.allclose(std, 1.0 / np.sqrt(np.dot(t, t)), rtol=1e-15)
    draws = [estimate_wind(observe(f, "position", Noise(position=1.0), seed=s), uw.PAPER_EXAMPLE,
                           return_std=True) for s in range(300)]
    spread = np.std([m[0] for m, _ in draws], axis=0, ddof=1)
    assert np.allclose(spread, std[0], rtol=0.15)
    read = np.mean([sd[0] for _, sd in draws], axis=0)  # the residuals' own reading
    assert np.all((read > 0.5 * std[0]) & (read < 3.0 * std[0]))
    _, sp = estimate_wind(f.positions, uw.PAPER_EXAMPLE, model="path", return_std=True,
                          position_noise=0.5)
    assert sp.shape == (1, 120, 3) and np.allclose(sp[0, 1:], np.sqrt(2) * 0.5 / 0.1)
    assert np.allclose(sp[0, 0], 0.5 / 0.1)
    with pytest.raises(ValueError, match="position_noise"):
        estimate_wind(f.positions, uw.PAPER_EXAMPLE, model="path", return_std=True)
    with pytest.raises(ValueError, match="position_noise"):
        estimate_wind(f.positions, uw.PAPER_EXAMPLE, position_noise=-1.0)
    with pytest.raises(TypeError, match="return_std"):
        estimate_wind(f.positions, uw.PAPER_EXAMPLE, return_std=1)


def test_two_means_separates_two_clouds_and_matches_kmeans():
    from sklearn.cluster import KMeans

    from uavwind.method.baseline import two_means

    rng = np.random.default_rng(4)
    for trial in range(20):
        x = np.concatenate([rng.normal(0, 0.3, (6, 3)), rng.normal(rng.uniform(1, 4), 0.3, (7, 3))])
        ours = two_means(x)
        ref = KMeans(n_clusters=2, n_init=10, random_state=0).fit_predict(x)
        assert np.array_equal(ours, ref) or np.array_equal(ours, 1 - ref)
    assert two_means(np.zeros((4, 3))).tolist() == [0, 0, 0, 0]


@pytest.mark.parametrize("call, match", [
    (lambda: estimate_wind(np.full((2, 120, 3), 1e307), uw.PAPER_EXAMPLE), "positions"),
    (lambda: estimate_wind(np.zeros((2, 120, 3)), uw.PAPER_EXAMPLE, dt=1e6), "dt must be"),
    (lambda: __import__("uavwind.method.baseline", fromlist=["two_means"]).two_means(
        np.array([[0.0], [np.nan], [5.0]])), "points"),
])
def test_the_baseline_names_the_bad_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()
