"""Random exploration and CEM: determinism, workers, convergence, physics sanity."""

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind import study as ex
from uavwind.method import search
from uavwind.method.search import cem_step


TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


def small(a="light constant", b="strong shear", n=3):
    return uw.make_setting(a, b, n, dt=0.2, duration=4.0, n_changes=3)


def test_random_search_table_and_determinism():
    s = small()
    a = uw.random_search(s, n_loops=4, seed=7, n_jobs=1, progress=False)
    b = uw.random_search(s, n_loops=4, seed=7, n_jobs=1, progress=False)
    pd.testing.assert_frame_equal(a, b)
    assert list(a["loop"]) == [0, 1, 2, 3]
    assert {"score", "silhouette", "correct", "labels", "times", "magnitudes",
            "directions"} <= set(a.columns)
    assert a.attrs["max"] == a["score"].max() and a.attrs["mean"] == a["score"].mean()
    c = uw.random_search(s, n_loops=4, seed=8, n_jobs=1, progress=False)
    assert not a["magnitudes"].equals(c["magnitudes"])


@pytest.fixture(scope="module")
def two_workers():
    """6 loops of one setting spread over two worker processes (once for the module): what
    one process must give, loop by loop and in blocks of any size."""
    s = small("light constant", "strong turbulence")
    return s, uw.random_search(s, n_loops=6, seed=3, n_jobs=2, progress=False)


@pytest.mark.slow
def test_workers_do_not_change_results(two_workers):
    s, two = two_workers
    one = uw.random_search(s, n_loops=6, seed=3, n_jobs=1, progress=False)
    pd.testing.assert_frame_equal(one, two)


@pytest.mark.slow
@pytest.mark.parametrize("block", [1, 4])
def test_blocks_of_loops_clustered_side_by_side_do_not_change_results(monkeypatch, block,
                                                                      two_workers):
    """evaluate() with n_jobs=1 clusters search.BLOCK loops side by side: 6 loops in blocks
    of 1 or 4 (the last block short) give the rows of one process per loop."""
    s, spread = two_workers
    monkeypatch.setattr(search, "BLOCK", block)
    pd.testing.assert_frame_equal(
        uw.random_search(s, n_loops=6, seed=3, n_jobs=1, progress=False), spread)


def test_loops_are_prefix_stable_and_extendable():
    s = small()
    full = uw.random_search(s, n_loops=4, seed=1, n_jobs=1, progress=False)
    head = uw.random_search(s, n_loops=2, seed=1, n_jobs=1, progress=False)
    tail = uw.random_search(s, n_loops=2, seed=1, n_jobs=1, progress=False, loop_offset=2)
    pd.testing.assert_frame_equal(pd.concat([head, tail], ignore_index=True), full,
                                  check_like=False)


def test_common_random_numbers_across_settings():
    a = uw.random_search(small(n=2), n_loops=3, seed=5, n_jobs=1, progress=False)
    b = uw.random_search(small("light shear", "light shear", n=3), n_loops=3, seed=5, n_jobs=1,
                         progress=False)
    assert a["magnitudes"].equals(b["magnitudes"]) and a["times"].equals(b["times"])


def test_cem_step_is_eqs_cem1_cem2():
    x = np.arange(12.0).reshape(6, 2)
    scores = [1, 5, 3, 5, 0, 2]
    mu, sigma, elite = cem_step(x, scores, 3)
    assert elite.tolist() == [1, 3, 2]  # ties keep the lower index
    sel = x[[1, 3, 2]]
    assert np.allclose(mu, sel.mean(0)) and np.allclose(sigma, sel.std(0))


def test_cem_converges_on_a_known_optimum():
    s = uw.make_setting("light constant", "strong shear", n_changes=0)  # one segment: 4 dims
    k = 1
    target = np.tile([30.0, 0.5, -0.5, 0.2], k)
    scale = np.tile([50.0, 0.33, 0.33, 0.33], k)  # each coordinate on its initial spread

    def objective(samples):
        return -np.sum(((samples - target) / scale) ** 2, axis=1)

    res = uw.cem(s, n_samples=100, n_elite=10, max_iter=40, seed=2, objective=objective,
                 progress=False)
    mu = np.array(res.history["mu"].iloc[-1])
    assert np.all(np.abs(mu - target) < 0.05 * scale), mu
    assert res.history["max"].iloc[-1] > -0.01 > res.history["max"].iloc[0]
    assert np.all(np.diff(res.history["best_so_far"]) >= 0)


def test_cem_patience_stops_early():
    s = small()
    res = uw.cem(s, n_samples=5, n_elite=2, max_iter=30, seed=0, patience=3, progress=False,
                 objective=lambda x: np.zeros(len(x)))
    assert res.stopped_early and len(res.history) == 4


@pytest.mark.slow
def test_cem_on_the_worked_example_never_loses_its_best():
    s = uw.table3_setting(n_changes=2)
    res = uw.cem(s, n_samples=6, n_elite=2, max_iter=3, seed=1, n_jobs=1, progress=False)
    h = res.history
    assert len(h) == 3 and len(res.samples) == 18
    assert np.all(h["best_so_far"] >= h["max"].iloc[0])
    assert np.all(np.diff(h["best_so_far"]) >= 0)
    assert res.best_score == h["max"].max()
    assert res.samples["elite"].sum() == 6
    traj = s.simulate(res.best_thrust)
    assert uw.score_loop(traj, s.groups).score == res.best_score


def test_cem_ranked_by_raw_silhouette_picks_the_best_silhouettes():
    s = uw.make_setting("light constant", "light shear", 4, n_changes=1)
    res = uw.cem(s, n_samples=6, n_elite=2, max_iter=2, seed=3, n_jobs=1, progress=False,
                 rank_by="silhouette")
    first = res.samples[res.samples["iteration"] == 1]
    sil = first["silhouette"].fillna(-1.0).to_numpy()
    assert set(np.flatnonzero(first["elite"])) == set(np.argsort(-sil, kind="stable")[:2])
    assert res.best_score == res.samples["score"].max()  # the paper's score is reported
    with pytest.raises(ValueError, match="rank_by"):
        uw.cem(s, n_samples=2, n_elite=1, max_iter=1, rank_by="inertia", progress=False)


@pytest.mark.parametrize("call, err, match", [
    (lambda: uw.random_search("setting"), TypeError, "setting"),
    (lambda: uw.random_search(small(), n_loops=0), ValueError, "n_loops"),
    (lambda: uw.random_search(small(), n_loops=1, n_jobs=0), ValueError, "n_jobs"),
    (lambda: uw.random_search(small(), n_loops=1, seed="a"), TypeError, "seed"),
    (lambda: uw.cem(small(), n_samples=3, n_elite=4), ValueError, "n_elite"),
    (lambda: uw.cem(small(), magnitude_std=-1), ValueError, "magnitude_std"),
])
def test_bad_input(call, err, match):
    with pytest.raises(err, match=match):
        call()


@pytest.mark.slow
def test_physics_sanity_on_paper_settings():
    """Strong shear vs light constant is nearly always grouped; light/light scores lower
    than light/strong on the same 20 thrust sequences."""
    shear = uw.random_search(uw.make_setting("strong shear", "light constant", 5), n_loops=20,
                             seed=0, progress=False)
    assert shear["correct"].mean() >= 0.9
    ll = uw.random_search(uw.make_setting("light constant", "light constant", 5), n_loops=20,
                          seed=0, progress=False)
    ls = uw.random_search(uw.make_setting("light constant", "strong constant", 5), n_loops=20,
                          seed=0, progress=False)
    assert ll["magnitudes"].equals(ls["magnitudes"])
    assert ll["score"].mean() < ls["score"].mean()


def test_cem_refuses_a_wrong_objective():
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    with pytest.raises(ValueError, match="one score per sample"):
        uw.cem(s, n_samples=4, n_elite=2, max_iter=1, objective=lambda x: np.zeros(3),
               progress=False)
    with pytest.raises(ValueError, match="NaN"):
        uw.cem(s, n_samples=4, n_elite=2, max_iter=1, progress=False,
               objective=lambda x: np.full(len(x), np.nan))


def test_cem_keeps_its_cap_apart_from_the_k_means_cap(tmp_path):
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    res = uw.cem(s, n_samples=3, n_elite=1, max_iter=2, seed=0, n_jobs=1, progress=False,
                 clustering={"max_iter": 1})
    assert len(res.history) == 2 and (res.samples["n_iter"] <= 1).all()
    df = ex.run_experiment("exp6", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                           max_iter=1)
    assert (df["n_iter"] <= 1).all() and df["iteration"].max() == 2


def test_cem_history_ignores_nan_scores():
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    res = uw.cem(s, n_samples=4, n_elite=2, max_iter=1, progress=False,
                 objective=lambda x: np.array([1.0, np.nan, 3.0, 2.0]))
    assert res.history["max"].iloc[0] == 3.0 and res.history["mean"].iloc[0] == 2.0


def test_an_interrupt_shuts_the_workers_down(monkeypatch):
    stopped = []
    monkeypatch.setattr(search, "stop_workers", lambda: stopped.append(True))

    class Interrupted:
        def __init__(self, *a, **k):
            pass

        def __call__(self, tasks):
            def gen():
                raise KeyboardInterrupt
                yield
            return gen()
    monkeypatch.setattr("joblib.Parallel", Interrupted)
    s = uw.make_setting("light constant", "strong shear", 2)
    with pytest.raises(KeyboardInterrupt):
        uw.random_search(s, n_loops=2, n_jobs=2, progress=False)
    assert stopped == [True]


def test_a_cem_run_stepped_by_hand_is_cem_to_the_double():
    s = uw.make_setting("light constant", "light shear", 3, dt=0.2, duration=4.0, n_changes=1)
    whole = uw.cem(s, n_samples=4, n_elite=2, max_iter=2, seed=5, n_jobs=1, progress=False,
                   rank_by="silhouette", clustering={"max_iter": 5})
    run = search.CEMRun(s, n_samples=4, n_elite=2, max_iter=2, seed=5, rank_by="silhouette",
                        params={"max_iter": 5})
    with pytest.raises(ValueError, match="ask"):
        run.tell([])
    with pytest.raises(ValueError, match="finished an iteration"):
        run.result()
    while not run.done:
        thrusts, seeds = run.ask()
        again, _ = run.ask()  # asking twice gives the same draws
        assert [t.to_dict() for t in again] == [t.to_dict() for t in thrusts]
        with pytest.raises(ValueError, match="one loop result per sample"):
            run.tell([])
        # each sample scored on its own, in reverse order, as a worker would
        res = [search.evaluate(s, [th], [ws], engine=run.engine, n_jobs=1, progress=False,
                               **run.params)[0] for th, ws in reversed(list(zip(thrusts, seeds)))]
        run.tell(res[::-1])
    with pytest.raises(ValueError, match="done"):
        run.ask()
    got = run.result()
    assert got.samples.to_dict("list") == whole.samples.to_dict("list")
    assert got.history.to_dict("list") == whole.history.to_dict("list")
    assert got.best_score == whole.best_score and run.iteration == 2
    # an objective instead of loops, with patience
    f = lambda x: -np.abs(x).sum(axis=1)  # noqa: E731
    run = search.CEMRun(s, n_samples=5, n_elite=2, max_iter=9, seed=1, patience=2)
    while not run.done:
        run.ask()
        run.tell_scores(f(run.draws()))
    whole = uw.cem(s, n_samples=5, n_elite=2, max_iter=9, seed=1, patience=2, objective=f,
                   progress=False)
    assert run.result().history.to_dict("list") == whole.history.to_dict("list")
    with pytest.raises(ValueError, match="max_iter"):
        search.CEMRun(s, max_iter=0)
    with pytest.raises(ValueError, match="engine"):
        search.CEMRun(s, engine="slow")


def test_a_search_checks_its_clustering_parameters_once_not_per_loop(monkeypatch):
    """evaluate() checks the groups, engine and clustering parameters once (a LoopScorer)
    and scores every loop with them; the paper sampler freezes its draws without checking
    them again. Counted on a random search of 6 loops."""
    from uavwind.method import clustering
    from uavwind.sim import actions
    made = {"params": 0, "sequences": 0}
    post, init = clustering.ClusteringParams.__post_init__, actions.ThrustSequence.__init__

    def count_params(self):
        made["params"] += 1
        post(self)

    def count_sequences(self, *a, **k):
        made["sequences"] += 1
        init(self, *a, **k)
    monkeypatch.setattr(clustering.ClusteringParams, "__post_init__", count_params)
    monkeypatch.setattr(actions.ThrustSequence, "__init__", count_sequences)
    setting = uw.table3_setting()
    df = uw.random_search(setting, n_loops=6, seed=0, n_jobs=1, progress=False)
    assert len(df) == 6 and made == {"params": 1, "sequences": 0}
