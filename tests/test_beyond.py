"""Beyond the paper: observation noise, observation channels, the physics baseline."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import beyond
from uavwind import study as ex
from uavwind.analysis import tables
from uavwind.method.baseline import estimate_wind
from uavwind.sim.observation import CONSUMER_NOISE, Noise, gauss_markov, noise_seed, observe

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


def _flight(wind, thrust=uw.PAPER_EXAMPLE):
    return uw.simulate_flight(thrust, wind)


# --------------------------------------------------------------------------- #
# noise
# --------------------------------------------------------------------------- #
def test_white_position_noise_has_its_sigma_and_mean_zero():
    f = _flight(uw.ConstantWind([[1.0, 1.0, 0.0]] * 200))
    err = observe(f, "position", Noise(position=0.3), seed=1) - f.positions
    assert err.std() == pytest.approx(0.3, rel=0.02)
    assert abs(err.mean()) < 4 * 0.3 / np.sqrt(err.size)


def test_gauss_markov_bias_is_stationary_with_its_autocorrelation():
    dt, sigma, tau = 0.1, 2.0, 3.0
    b = gauss_markov((4000, 120, 3), dt, sigma, tau, np.random.default_rng(0))
    phi = np.exp(-dt / tau)
    assert b[:, 0].std() == pytest.approx(sigma, rel=0.03)    # stationary from the start
    assert b[:, -1].std() == pytest.approx(sigma, rel=0.03)
    for lag in (1, 10, 50):
        r = np.mean(b[:, lag:] * b[:, :-lag]) / sigma ** 2
        assert r == pytest.approx(phi ** lag, abs=0.02)


def test_noise_seeds_come_from_the_loop_seed():
    f = _flight(uw.ConstantWind([[1.0, 0.0, 0.0]] * 3))
    root = np.random.SeedSequence(5, spawn_key=(3, 1))
    a = observe(f, "position", Noise(position=1.0), seed=noise_seed(root))
    b = observe(f, "position", Noise(position=1.0), seed=noise_seed(root))
    c = observe(f, "position", Noise(position=2.0), seed=noise_seed(root))
    assert np.array_equal(a, b)
    assert np.allclose(c - f.positions, 2 * (a - f.positions))  # common random numbers
    assert noise_seed(root).spawn_key == (3, 1, 2)


def test_results_do_not_depend_on_the_number_of_workers(tmp_path):
    kw = dict(profile=TINY, progress=False, cases=[4, 5, 12, 20])
    one = ex.run_experiment("exp7", n_jobs=1, results=tmp_path / "a", **kw)
    two = ex.run_experiment("exp7", n_jobs=2, results=tmp_path / "b", **kw)
    pd.testing.assert_frame_equal(one, two)
    assert "noise_sigma" in one.columns and "baseline_rmse" in one.columns


# --------------------------------------------------------------------------- #
# observation channels
# --------------------------------------------------------------------------- #
def test_channels_equal_the_simulators_velocities_and_accelerations():
    uav = uw.UAV()
    w = np.array([[1.2, -0.4, 0.0], [0.3, 0.9, 0.0]])
    f = _flight(uw.ConstantWind(w))
    assert np.array_equal(observe(f, "velocity"), f.ground_velocities)
    assert np.array_equal(observe(f, "position"), f.positions)
    pv = observe(f, "position+velocity")
    assert pv.shape == (2, 120, 6) and np.array_equal(pv[..., 3:], f.ground_velocities)
    # specific force, closed form of the explicit update: F/m - (k/m)|v_prev| v_prev
    va = f.air_velocities
    prev = np.concatenate([np.zeros_like(va[:, :1]), va[:, :-1]], axis=1)
    speed = np.linalg.norm(prev, axis=2, keepdims=True)
    expected = f.thrust[None] / uav.mass - uav.drag_factor / uav.mass * speed * prev
    assert np.allclose(observe(f, "acceleration"), expected, atol=1e-9)
    # a constant wind is invisible to an accelerometer
    assert np.allclose(observe(f, "acceleration")[0], observe(f, "acceleration")[1], atol=1e-9)


# --------------------------------------------------------------------------- #
# the physics baseline
# --------------------------------------------------------------------------- #
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


def test_baseline_summary_and_a_wrong_model(tmp_path):
    df = ex.run_experiment("exp9", profile=TINY, n_jobs=1, progress=False, results=tmp_path,
                           cases=[11, 12])  # light vs light: no noise, 0.02 m
    t = tables.summary_table(df)
    assert t["rmse"].iloc[0] < 1e-9 and t["baseline_correct_rate"].iloc[0] == 1.0
    assert (t["rmse_mass+20%"] > 1.0).all()


# --------------------------------------------------------------------------- #
# the tables and bad input
# --------------------------------------------------------------------------- #
def test_breaking_level_reads_the_first_level_below_one_half():
    rows = [{"scenario": "s", "noise_sigma": sig, "noise_bias": 0.0, "loop": i,
             "score": 80.0 if ok else 0.0, "correct": ok}
            for sig, rate in ((0.0, 1.0), (0.5, 0.9), (1.0, 0.6), (2.0, 0.2), (5.0, 0.0))
            for i, ok in enumerate(np.arange(10) < 10 * rate)]
    lv = beyond.breaking_level(pd.DataFrame(rows)).loc["s"]
    assert lv["last_ok"] == 1.0 and lv["first_broken"] == 2.0
    assert lv["correct_rate_at_first_broken"] == pytest.approx(0.2)


def test_breaking_sentences_and_rows_at_a_noise_level():
    rows = [{"scenario": s, "noise_sigma": sig, "noise_bias": 0.0, "loop": i,
             "score": 80.0 if ok else 0.0, "correct": ok}
            for s, rates in (("s", ((0.0, 1.0), (1.0, 0.6), (2.0, 0.2))),
                             ("t", ((0.0, 1.0), (1.0, 0.9), (2.0, 0.8))))
            for sig, rate in rates for i, ok in enumerate(np.arange(10) < 10 * rate)]
    df = pd.DataFrame(rows)
    text = beyond.breaking_sentences(beyond.breaking_level(df))
    assert text["s"] == "drops below half between 1 m (60% correct) and 2 m (20%)"
    assert text["t"].startswith("still groups 80%") and "2 m, the largest" in text["t"]
    table = beyond.noise_table(df)
    assert list(beyond.at_noise(table, sigma=1.0).index) == ["s", "t"]
    with pytest.raises(ValueError, match="noise_sigma = 3"):
        beyond.at_noise(table, sigma=3.0)


@pytest.mark.parametrize("call, match", [
    (lambda: Noise(position=-0.1), "position"),
    (lambda: Noise(bias_time=0.0), "bias_time"),
    (lambda: Noise(velocity=float("nan")), "velocity"),
    (lambda: gauss_markov((1, 5, 3), 0.1, 1.0, -1.0, np.random.default_rng(0)), "tau"),
    (lambda: observe(_flight(uw.ConstantWind([[0, 0, 0]])), "attitude"), "observation"),
    (lambda: estimate_wind(np.zeros((2, 5)), uw.PAPER_EXAMPLE), "positions"),
    (lambda: estimate_wind(np.zeros((2, 5, 2)), uw.PAPER_EXAMPLE), "positions"),
    (lambda: estimate_wind(np.zeros((2, 5, 3)), uw.PAPER_EXAMPLE, model="kalman"), "model"),
    (lambda: estimate_wind(np.zeros((2, 5, 3)), uw.PAPER_EXAMPLE, dt=0.0), "dt"),
    (lambda: replace(uw.table3_setting(), observation="gyro"), "observation"),
])
def test_bad_inputs_name_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_consumer_noise_levels_are_the_cited_figures():
    assert CONSUMER_NOISE.position == pytest.approx(2.5 / 1.1774)
    assert CONSUMER_NOISE.velocity == 0.05
    assert CONSUMER_NOISE.acceleration == pytest.approx(0.0088, abs=1e-4)


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
