"""score_loop against tslearn itself, the paper's scoring rule, and bad input."""
import numpy as np
import pytest
from tslearn.clustering import TimeSeriesKMeans, silhouette_score

import uavwind as uw
from uavwind.method.clustering import ENGINES, score_loop


def _reference(X):
    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": 0.5},
                          max_iter=100, max_iter_barycenter=5, random_state=0)
    labels = km.fit_predict(X)
    return labels, silhouette_score(X, labels, metric="dtw")


def _short(a, b, n=3, seed=0, **kw):
    """A small loop (n per group, 4 s at dt = 0.2 s) to keep tslearn quick."""
    s = uw.make_setting(a, b, n, dt=0.2, duration=4.0, n_changes=3, **kw)
    thrust = s.sample_thrust(np.random.default_rng(seed))
    return s.simulate(thrust, seed=seed), s.groups


CASES = [("light constant", "strong shear", 0), ("light shear", "light shear", 1),
         ("light constant", "strong turbulence", 2)]


@pytest.mark.parametrize("a, b, seed", CASES)
def test_tslearn_engine_is_tslearn(a, b, seed):
    X, groups = _short(a, b, seed=seed)
    labels, sil = _reference(X)
    res = score_loop(X, groups, engine="tslearn")
    assert np.array_equal(res.labels, labels)
    assert res.silhouette == sil
    assert res.correct == (np.array_equal(labels, groups) or np.array_equal(labels, 1 - groups))
    assert res.score == (100 * sil if res.correct else 0.0)


@pytest.mark.slow
def test_worked_example_is_grouped(worked_example):
    res = score_loop(worked_example.simulate(uw.PAPER_EXAMPLE), worked_example.groups,
                     engine="tslearn")
    assert res.correct and 90 < res.score <= 100
    o1, o2 = res.observations
    assert len(set(o1)) == 1 and len(set(o2)) == 1 and o1[0] != o2[0]
    table = res.to_table(uw.PAPER_EXAMPLE)
    assert table.loc["Thrust change times (s)", "value"] == "[0 4 10]"
    assert table.loc["Thrust directions [x y z]", "value"] == "[[0 0 1] [1 0 0] [0 1 0]]"
    assert "Observations1" in str(res)
    row = res.to_dict()
    assert row["score"] == res.score and len(row["labels"]) == 10


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_wrong_grouping_scores_zero_and_swap_is_invariant(engine):
    X, groups = _short("light constant", "strong constant", seed=3)
    right = score_loop(X, groups, engine=engine)
    assert right.correct and right.score > 0
    swapped = score_loop(X, 1 - groups, engine=engine)
    assert swapped.score == right.score and swapped.correct
    wrong = groups.copy()
    wrong[[0, -1]] = wrong[[-1, 0]]
    res = score_loop(X, wrong, engine=engine)
    assert not res.correct and res.score == 0.0
    assert res.silhouette == right.silhouette  # the clustering itself is unchanged


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_identical_trajectories_score_zero(engine):
    X = np.zeros((6, 10, 3))
    res = score_loop(X, [0, 0, 0, 1, 1, 1], engine=engine)
    assert res.score == 0.0 and not res.correct


@pytest.mark.parametrize("kwargs, err, match", [
    ({"trajectories": np.full((4, 5, 3), np.nan)}, ValueError, "finite"),
    ({"trajectories": np.full((4, 5, 3), np.inf)}, ValueError, "finite"),
    ({"trajectories": np.zeros((4, 5))}, ValueError, "trajectories"),
    ({"trajectories": np.zeros((1, 5, 3)), "groups": [0]}, ValueError, "at least 3"),
    ({"groups": [0, 0, 1]}, ValueError, "groups must have shape"),
    ({"groups": [0, 0, 0, 0]}, ValueError, "two non-empty"),
    ({"groups": [0, 1, 2, 1]}, ValueError, "only 0 and 1"),
    ({"groups": ["a", "b", "a", "b"]}, TypeError, "groups"),
    ({"engine": "gpu"}, ValueError, "engine"),
    ({"gamma": 0.0}, ValueError, "gamma"),
    ({"max_iter": 0}, ValueError, "max_iter"),
    ({"silhouette_metric": "euclid"}, ValueError, "silhouette_metric"),
    ({"metric": "dtw"}, TypeError, "unexpected keyword.*metric"),
])
def test_bad_input(kwargs, err, match):
    args = {"trajectories": np.random.default_rng(0).normal(size=(4, 5, 3)), "groups": [0, 0, 1, 1],
            "engine": "tslearn", **kwargs}
    with pytest.raises(err, match=match):
        score_loop(args.pop("trajectories"), args.pop("groups"), **args)


def test_parameters_reach_tslearn():
    X, groups = _short("light constant", "strong constant", seed=4)
    a = score_loop(X, groups, engine="tslearn", silhouette_metric="softdtw", gamma=1.0)
    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": 1.0},
                          max_iter=100, max_iter_barycenter=5, random_state=0)
    labels = km.fit_predict(X)
    sil = silhouette_score(X, labels, metric="softdtw", metric_params={"gamma": 1.0})
    assert np.array_equal(a.labels, labels) and a.silhouette == sil


# ---- LoopScorer: the checks once, the loops trusted -------------------------------------- #
def test_a_scorer_scores_as_score_loop_and_checks_once_when_made(worked_example):
    from uavwind.method.clustering import ClusteringParams, LoopScorer
    s = worked_example
    X = s.simulate(uw.PAPER_EXAMPLE)
    scorer = LoopScorer.of(s.groups, max_iter=20)
    a, b = scorer(X), score_loop(X, s.groups, max_iter=20)
    assert (a.score, a.silhouette, a.n_iter, a.correct) == (b.score, b.silhouette, b.n_iter,
                                                            b.correct)
    assert np.array_equal(a.labels, b.labels)
    with pytest.raises(ValueError, match="groups must contain two non-empty classes"):
        LoopScorer(np.zeros(4, int), "fast", ClusteringParams())
    with pytest.raises(ValueError, match=r"groups must be a 1-D array .* got shape \(\)"):
        LoopScorer(1, "fast", ClusteringParams())
    with pytest.raises(ValueError, match="engine"):
        LoopScorer(s.groups, "slow", ClusteringParams())
    with pytest.raises(TypeError, match="params must be a ClusteringParams"):
        LoopScorer(s.groups, "fast", {"gamma": 0.5})
    with pytest.raises(TypeError, match="gama"):
        LoopScorer.of(s.groups, gama=0.5)
    with pytest.raises(ValueError, match=r"trajectories must have shape \(%d, n_steps, d\)"
                       % len(s.groups)):
        scorer(X[:-1])


# ---- loops side by side: score_loops and LoopScorer.many ---------------------------------- #
def test_loops_side_by_side_score_as_each_loop_alone_and_as_tslearn():
    """score_loops and LoopScorer.many give score_loop's results, field for field with ==,
    whatever the mix: loops of 3 and 4 environments a group, another length, one whose
    clusters are not the groups, a softdtw silhouette; the tslearn engine too."""
    loops = [_short(a, b, seed=seed) for a, b, seed in CASES]
    loops.append(_short("light constant", "strong constant", n=4, seed=5))
    X, g = _short("light constant", "strong shear", seed=6)
    loops.append((X[:, :12], g))
    loops.append((loops[0][0], np.array([0, 1, 0, 1, 0, 1])))  # groups the clusters are not
    for engine, params in (("fast", {}), ("fast", {"silhouette_metric": "softdtw"}),
                           ("tslearn", {})):
        many = uw.score_loops([X for X, _ in loops], [g for _, g in loops], engine=engine,
                              **params)
        for (X, g), r in zip(loops, many):
            one = score_loop(X, g, engine=engine, **params)
            assert (r.score, r.silhouette, r.n_iter, r.correct) == (
                one.score, one.silhouette, one.n_iter, one.correct)
            assert np.array_equal(r.labels, one.labels) and np.array_equal(r.groups, g)
        if engine == "fast" and not params:
            fast = many
    assert any(not r.correct for r in fast) and any(r.correct for r in fast)
    labels, sil = _reference(loops[0][0])
    assert np.array_equal(fast[0].labels, labels) and fast[0].silhouette == sil
    from uavwind.method.clustering import LoopScorer
    X, g = loops[0]
    scorer = LoopScorer.of(g)
    assert [r.score for r in scorer.many([X, X[:, :10]])] == [scorer(X).score,
                                                               scorer(X[:, :10]).score]
    assert uw.score_loops([], []) == []


@pytest.mark.parametrize("call, err, match", [
    (lambda X, g: uw.score_loops(X, [g]), TypeError, "trajectories must be a sequence of loops"),
    (lambda X, g: uw.score_loops([X, X], [g]), ValueError, "groups must hold one array of 0/1 "
                                                           "per loop"),
    (lambda X, g: uw.score_loops([X, X[:2]], [g, g[:2]]), ValueError,
     r"trajectories\[1\] must hold at least 3 series"),
    (lambda X, g: uw.score_loops([X], [g[:-1]]), ValueError, "groups must have shape"),
    (lambda X, g: uw.score_loops([X], [g], engine="gpu"), ValueError, "engine"),
    (lambda X, g: uw.score_loops([X], [g], gama=1.0), TypeError, "gama"),
])
def test_loops_side_by_side_refuse_bad_input(call, err, match):
    X, g = _short("light constant", "strong shear", seed=0)
    with pytest.raises(err, match=match):
        call(X, g)


@pytest.mark.slow
def test_tslearns_kernels_load_from_the_cache_and_give_the_same_doubles():
    """cache_tslearn_kernels lets tslearn's kernels use numba's cache: after this process ran
    tslearn (its kernels compiled into the cache, or loaded from make venv's), a new process
    loads them from there and gives this process's labels and silhouette to the last bit."""
    import json
    import subprocess
    import sys

    X, groups = _short("light constant", "strong shear", seed=0)
    res = score_loop(X, groups, engine="tslearn")
    code = ("import json, numpy as np, uavwind as uw\n"
            "from uavwind.method.clustering import score_loop, cache_tslearn_kernels\n"
            "import tslearn.barycenters.softdtw as b\n"
            "s = uw.make_setting('light constant', 'strong shear', 3, dt=0.2, duration=4.0,"
            " n_changes=3)\n"
            "X = s.simulate(s.sample_thrust(np.random.default_rng(0)), seed=0)\n"
            "r = score_loop(X, s.groups, engine='tslearn')\n"
            "f = b._njit_softdtw_func_from_distance_matrix\n"
            "print(json.dumps([r.labels.tolist(), r.silhouette.hex(),"
            " type(f._cache).__name__, f._cache_hits.total(), cache_tslearn_kernels()]))\n")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                         text=True, timeout=600).stdout.strip().splitlines()[-1]
    labels, sil, cache, hits, again = json.loads(out)
    assert labels == res.labels.tolist() and float.fromhex(sil) == res.silhouette
    assert cache == "FunctionCache" and hits > 0  # loaded, not compiled
    assert again == 0  # switched on once, where the engine was made
