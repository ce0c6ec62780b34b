"""The fast engine against tslearn itself: kernels, k-means, silhouette, whole loops."""
import json
import os
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest
from tslearn.barycenters.softdtw import _acc_softdtw_func, _softdtw_func
from tslearn.clustering import TimeSeriesKMeans, silhouette_score
from tslearn.metrics import dtw as ts_dtw
from tslearn.metrics import soft_dtw as ts_soft_dtw

import uavwind as uw
from uavwind.method import softdtw as fk
from uavwind.method.clustering import score_loop
from uavwind.method.softdtw._lbfgsb import _lbfgsb
from uavwind.study.conditions import PAPER_SCENARIOS


def _pairs(seed):
    rng = np.random.default_rng(seed)
    for m, n in ((12, 12), (9, 15), (20, 7)):
        yield rng.normal(size=(m, 3)).cumsum(0), rng.normal(size=(n, 3)).cumsum(0)


@pytest.mark.parametrize("gamma", [0.1, 0.5, 1.0])
def test_soft_dtw_value_and_gradient_equal_tslearn(gamma):
    for x, y in _pairs(int(gamma * 10)):
        assert fk.soft_dtw(x, y, gamma) == pytest.approx(ts_soft_dtw(x, y, gamma=gamma),
                                                         rel=1e-12, abs=1e-9)
        val, grad = fk.soft_dtw_grad(x, y, gamma)
        ref_val, ref_grad = _softdtw_func(x, y, 1.0, gamma, 0, None, None)
        assert val == pytest.approx(ref_val, rel=1e-12, abs=1e-9)
        assert np.allclose(grad, ref_grad, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("maxiter", [1, 5, 50])
def test_lbfgsb_driver_is_bit_identical_to_scipy_minimize(maxiter):
    """The direct L-BFGS-B loop returns exactly scipy.optimize.minimize's x, on the
    soft-DTW barycentre objective (as k-means uses it) and on a Rosenbrock valley."""
    from scipy.optimize import minimize, rosen, rosen_der

    rng = np.random.default_rng(7)
    Xs = rng.normal(size=(4, 16, 3)).cumsum(1)
    Z0 = Xs[0] + rng.normal(scale=0.3, size=(16, 3))

    def bary(z):
        obj, G = fk.soft_dtw_objgrad(z.reshape(16, 3), Xs, 0.5, parallel=False)
        return obj, np.ravel(G)

    def rosenbrock(z):
        return rosen(z), rosen_der(z)

    for fg, x0 in ((bary, Z0.ravel()), (rosenbrock, rng.normal(size=6))):
        for tol in (1e-3, 1e-8):
            ref = minimize(fg, x0, method="L-BFGS-B", tol=tol, jac=True,
                           options=dict(maxiter=maxiter)).x
            ours = _lbfgsb(fg, x0, maxiter, ftol=tol, gtol=tol)
            assert np.array_equal(ours, ref)
    # side by side (k-means' clusters, one kernel call per round): each problem gets what it
    # gets alone, though they stop after different numbers of evaluations
    from uavwind.method.softdtw._lbfgsb import lbfgsb_many
    problems = [(bary, Z0.ravel()), (rosenbrock, rng.normal(size=6)), (bary, Xs[2].ravel())]
    calls = []

    def fg_many(asked):
        calls.append([k for k, _ in asked])
        return [problems[k][0](x) for k, x in asked]
    for tol in (1e-3, 1e-8):
        alone = [_lbfgsb(fg, x0, maxiter, ftol=tol, gtol=tol) for fg, x0 in problems]
        together = lbfgsb_many(fg_many, [x0 for _, x0 in problems], maxiter, tol, tol)
        assert all(np.array_equal(a, b) for a, b in zip(alone, together))
    assert calls[0] == [0, 1, 2] and any(len(c) < 3 for c in calls)
    # told the value at a start (a k-means round whose cluster kept its series starts where
    # the last round's run ended): the same final x, one evaluation fewer for that problem,
    # and each run's last evaluation returned, which is what the next round is told
    from uavwind.method.softdtw._lbfgsb import lbfgsb_many_known
    for tol in (1e-3, 1e-8):
        first, finals = lbfgsb_many_known(fg_many, [x0 for _, x0 in problems], [None] * 3,
                                          maxiter, tol, tol)
        for (fg, _), x, fin in zip(problems, first, finals):
            assert fin is not None and fin[0] == fg(x)[0] and np.array_equal(fin[1], fg(x)[1])
        calls.clear()
        again, _ = lbfgsb_many_known(fg_many, first, finals, maxiter, tol, tol)
        asked = [k for c in calls for k in c]
        calls.clear()
        ref = lbfgsb_many(fg_many, first, maxiter, tol, tol)
        assert all(np.array_equal(a, b) for a, b in zip(again, ref))
        assert all(asked.count(k) == [k for c in calls for k in c].count(k) - 1
                   for k in range(3))
    with pytest.raises(ValueError, match="known must give one entry per start"):
        lbfgsb_many_known(fg_many, [x0 for _, x0 in problems], [None], maxiter, 1e-3, 1e-3)


def test_barycentre_objective_equals_tslearn():
    rng = np.random.default_rng(3)
    Xs = rng.normal(size=(5, 14, 3)).cumsum(1)
    Z = rng.normal(size=(14, 3)).cumsum(0)
    obj, G = fk.soft_dtw_objgrad(Z, Xs, 0.5)
    ref_obj, ref_G = _acc_softdtw_func(Z.ravel(), Xs, np.ones(5), 0.5)
    assert obj == pytest.approx(ref_obj, rel=1e-12)
    assert np.allclose(np.ravel(G), ref_G, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("lockstep", [True, False])
def test_a_barycentre_batch_is_each_clusters_objective_whichever_clusters_it_is_asked(
        lockstep):
    """ObjgradBatch (one k-means round's clusters, packed once) gives, for every set of
    clusters asked and in the order asked, each cluster's objective and gradient alone
    (``_objgrad``) with ==; its packing is made once for each set of clusters (asked
    again, the same arrays), on the lockstep and the scalar kernels."""
    from uavwind.method.softdtw._dispatch import ObjgradBatch, _objgrad

    rng = np.random.default_rng(11)
    Xss = [rng.normal(size=(n, 14, 3)).cumsum(1) for n in (3, 6, 1)]
    Zs = [rng.normal(size=(14, 3)).cumsum(0) for _ in Xss]
    batch = ObjgradBatch(Xss, 0.5, False, True, lockstep)
    for ks in ([0, 1, 2], [2, 0], [1], [0, 1, 2], [2, 0]):
        got = batch([Zs[k] for k in ks], ks)
        for k, (obj, G) in zip(ks, got):
            ref_obj, ref_G = _objgrad(Zs[k], Xss[k], 0.5, False, True, lockstep)
            assert obj == ref_obj and np.array_equal(G, ref_G)
    if lockstep:
        assert sorted(batch._packed) == [(0, 1, 2), (1,), (2, 0)]


def test_dtw_equals_tslearn():
    for x, y in _pairs(7):
        assert fk.dtw(x, y) == pytest.approx(ts_dtw(x, y), rel=1e-12)


def _loop(scenario, seed, n_per_group=5):
    a, b = PAPER_SCENARIOS[scenario]
    s = uw.make_setting(a, b, n_per_group)
    thrust = s.sample_thrust(np.random.default_rng(seed))
    return s.simulate(thrust, seed=seed), s.groups


# whole Table 2 loops, the fast engine against tslearn's, exactly: tests/test_lockstep.py
# (every scenario, the two readings alternating)


def test_fast_equals_tslearn_k_means_directly():
    X, _ = _loop(7, seed=11)  # turbulence
    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": 0.5},
                          max_iter=100, max_iter_barycenter=5, random_state=0)
    labels = km.fit_predict(X)
    ours = fk.SoftDTWKMeans(n_clusters=2, gamma=0.5, max_iter=100, max_iter_barycenter=5,
                            random_state=0, parallel=False).fit(X)
    assert np.array_equal(ours.labels_, labels)
    assert np.array_equal(ours.cluster_centers_, km.cluster_centers_)
    assert ours.inertia_ == km.inertia_ and ours.n_iter_ == km.n_iter_
    assert fk.silhouette_score(X, labels) == silhouette_score(X, labels, metric="dtw")
    sil_soft = fk.silhouette(X, labels, metric="softdtw", gamma=0.5)
    ref_soft = silhouette_score(X, labels, metric="softdtw", metric_params={"gamma": 0.5})
    assert sil_soft == pytest.approx(ref_soft, abs=1e-9)


def test_a_round_whose_clusters_kept_their_series_reuses_the_last_evaluation(monkeypatch):
    """A cluster that keeps its series starts its barycentre where the last round's run
    ended, so that run's last objective and gradient are the first the new run asks: the
    fit reuses them (lbfgsb_many_known) and evaluates fewer centres, with the same labels,
    centres, inertia and rounds as without (==) and as tslearn's on the same loop."""
    from uavwind.method.softdtw import kmeans

    X, _ = _loop(1, seed=5)  # its labels settle early, and it runs tens of rounds more
    evaluated = []
    objgrad = kmeans.ObjgradBatch.__call__
    monkeypatch.setattr(kmeans.ObjgradBatch, "__call__",
                        lambda self, Zs, ks: evaluated.append(len(Zs)) or objgrad(self, Zs, ks))
    reusing = fk.fit(X, random_state=0, parallel=False)
    n_reusing = sum(evaluated)
    known_many = kmeans.lbfgsb_many_known
    monkeypatch.setattr(kmeans, "lbfgsb_many_known",  # told nothing: every start computed
                        lambda fg, x0s, known, *a, **k: known_many(fg, x0s, [None] * len(x0s),
                                                                   *a, **k))
    evaluated.clear()
    alone = fk.fit(X, random_state=0, parallel=False)
    assert np.array_equal(reusing.labels, alone.labels)
    assert np.array_equal(reusing.cluster_centers, alone.cluster_centers)
    assert (reusing.inertia, reusing.n_iter) == (alone.inertia, alone.n_iter)
    # at most one evaluation a cluster a round saved, and at least one in most rounds
    assert sum(evaluated) - 2 * alone.n_iter <= n_reusing < sum(evaluated) - alone.n_iter
    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": 0.5},
                          max_iter=100, max_iter_barycenter=5, random_state=0)
    assert np.array_equal(km.fit_predict(X), reusing.labels)
    assert np.array_equal(km.cluster_centers_, reusing.cluster_centers)
    assert km.n_iter_ == reusing.n_iter


@pytest.mark.slow
def test_fits_side_by_side_are_each_fit_and_tslearn_to_the_double(monkeypatch):
    """fit_many runs several k-means fits in one barycentre kernel call per round; each
    result is the fit's alone, and tslearn's, with ==: loops of 3 and 5 environments a
    group, three scenarios, a dataset of another length (its own batch) and n_init = 2.
    The calls are counted: side by side they are fewer than one fit after another."""
    from uavwind.method.softdtw import kmeans

    Xs = [_loop(s, seed=20 + s, n_per_group=n)[0] for s, n in ((1, 3), (4, 5), (7, 3))]
    Xs.append(Xs[1][:, :40])
    calls = []
    objgrad = kmeans.ObjgradBatch.__call__
    monkeypatch.setattr(kmeans.ObjgradBatch, "__call__",
                        lambda *a: calls.append(1) or objgrad(*a))
    for par in (False, True):
        for n_init in (1, 2):
            calls.clear()
            many = fk.fit_many(Xs, random_state=0, n_init=n_init, parallel=par)
            side_by_side = len(calls)
            for X, r in zip(Xs, many):
                one = fk.fit(X, random_state=0, n_init=n_init, parallel=par)
                assert np.array_equal(r.labels, one.labels)
                assert np.array_equal(r.cluster_centers, one.cluster_centers)
                assert (r.inertia, r.n_iter, r.n_attempts) == (one.inertia, one.n_iter,
                                                               one.n_attempts)
            assert side_by_side < len(calls) - side_by_side
    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": 0.5},
                          max_iter=100, max_iter_barycenter=5, random_state=0, n_init=2)
    assert np.array_equal(km.fit_predict(Xs[2]), many[2].labels)
    assert np.array_equal(km.cluster_centers_, many[2].cluster_centers)
    assert fk.fit_many([]) == []


def test_fits_side_by_side_refuse_a_shared_random_state_and_check_every_dataset():
    X, _ = _loop(2, seed=3, n_per_group=3)
    with pytest.raises(TypeError, match="random_state must be None or an int for fit_many"):
        fk.fit_many([X, X], random_state=np.random.RandomState(0))
    with pytest.raises(TypeError, match="Xs must be a sequence of datasets"):
        fk.fit_many(X[0])
    with pytest.raises(ValueError, match="X"):
        fk.fit_many([X, X[:, :, 0:0]])
    with pytest.raises(ValueError, match="n_clusters = 9 needs at least as many series"):
        fk.fit_many([X, X], n_clusters=9)


def test_parallel_kernels_give_the_same_answer():
    X, _ = _loop(4, seed=5, n_per_group=6)
    a = fk.fit(X, parallel=False)
    b = fk.fit(X, parallel=True)
    assert np.array_equal(a.labels, b.labels) and a.inertia == b.inertia


@pytest.mark.slow
def test_exact_with_the_libm_replica_forced_off():
    """UAVWIND_SOFTDTW_GLIBC_REPLICA=0: the kernels call libm like tslearn; still equal.
    tslearn's references are computed here, where its kernels are compiled already (it
    caches none: 17 CPU-s of compiling in a fresh process); the child runs only ours."""
    s = uw.make_setting("light constant", "light shear", 4)
    ref = []
    for seed in range(3):
        r = score_loop(s.simulate(s.sample_thrust(np.random.default_rng(seed))), s.groups,
                       engine="tslearn")
        ref.append({"labels": [int(v) for v in r.labels], "score": float(r.score).hex()})
    code = ("import json, numpy as np, uavwind as uw\n"
            "from uavwind.method.softdtw._libm import _libm_selfcheck\n"
            "assert _libm_selfcheck() is False\n"
            "s = uw.make_setting('light constant', 'light shear', 4)\n"
            "out = []\n"
            "for seed in range(3):\n"
            "    X = s.simulate(s.sample_thrust(np.random.default_rng(seed)))\n"
            "    a = uw.score_loop(X, s.groups, engine='fast')\n"
            "    out.append({'labels': [int(v) for v in a.labels], 'score': float(a.score).hex()})\n"
            "print(json.dumps(out))\n")
    env = {**os.environ, "UAVWIND_SOFTDTW_GLIBC_REPLICA": "0"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
    assert json.loads(out.stdout.strip().splitlines()[-1]) == ref  # scores as exact hex floats


def test_a_failed_selfcheck_warns_once_and_falls_back(monkeypatch):
    from uavwind.method.softdtw import _libm

    monkeypatch.setattr(_libm, "_FASTMATH_OK", None)
    monkeypatch.setattr(_libm, "_selfcheck_kernel", lambda xe, xl: 3)
    with pytest.warns(RuntimeWarning, match="differ from this platform's libm"):
        assert _libm._libm_selfcheck(n=10) is False
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _libm._libm_selfcheck(n=10) is False  # once


def test_an_untested_scipy_falls_back_to_minimize(monkeypatch):
    from uavwind.method.softdtw import _lbfgsb as lb

    monkeypatch.setattr(lb, "_SCIPY_OK", None)
    monkeypatch.setattr(lb, "SCIPY_TESTED", ("0.1",))
    with pytest.warns(RuntimeWarning, match="not one the L-BFGS-B driver was tested"):
        x = lb.lbfgsb(lambda z: (float(z @ z), 2 * z), np.ones(3), 50, 1e-8, 1e-8)
    assert np.allclose(x, 0, atol=1e-6)


def test_estimator_follows_scikit_learn_conventions():
    from sklearn.base import clone

    est = fk.SoftDTWKMeans(n_clusters=3, gamma=0.3, max_iter=7, random_state=5)
    assert est.get_params()["gamma"] == 0.3 and est.n_clusters == 3
    assert not hasattr(est, "labels_")  # fitted attributes appear with fit
    twin = clone(est)
    assert twin.get_params() == est.get_params() and twin is not est
    X, _ = _loop(1, seed=3)
    a = est.fit(X)
    assert a is est and est.labels_.shape == (10,) and est.cluster_centers_.shape == (3, 120, 3)
    assert est.n_iter_ <= 7 and np.isfinite(est.inertia_)
    assert np.array_equal(twin.fit_predict(X), est.labels_)  # random_state=5: reproducible
    assert est.set_params(n_clusters=2) is est and est.n_clusters == 2
    with pytest.raises(ValueError, match="metric"):
        est.set_params(metric="dtw")
    for bad, match in (({"n_clusters": 0}, "n_clusters"), ({"max_iter": 0}, "max_iter"),
                       ({"n_clusters": 11}, "n_clusters"), ({"tol": -1.0}, "tol")):
        with pytest.raises(ValueError, match=match):
            fk.SoftDTWKMeans(**{"random_state": 0, **bad}).fit(X)


# --------------------------------------------------------------------------- #
# a scikit-learn estimator (issue: the engine as a library others can trust)
# --------------------------------------------------------------------------- #
#: check_estimator's checks that cannot apply to time-series input, each with why. A 2-D
#: array is n_ts univariate series of length X.shape[1] (as tslearn reads it), so the
#: number of columns is a series length, not a feature count.
NOT_FOR_TIME_SERIES = {
    "check_n_features_in": "n_features_in_ is the features per time step d (1 for a 2-D "
                           "array of univariate series), not X.shape[1] (a series length)",
    "check_n_features_in_after_fitting": "series of another length (another X.shape[1] in "
                                         "2-D) are valid input to predict and transform, as "
                                         "in tslearn; only another d is refused",
    "check_transformer_general": "the same reason: transform accepts series of another "
                                 "length, so a different X.shape[1] is not an error",
}


def test_check_estimator_passes_but_for_the_checks_time_series_cannot_meet():
    from sklearn.utils.estimator_checks import check_estimator

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        results = check_estimator(fk.SoftDTWKMeans(max_iter=5, random_state=0),
                                  expected_failed_checks=NOT_FOR_TIME_SERIES, on_fail=None)
    status = {}
    for r in results:
        status.setdefault(r["check_name"], set()).add(r["status"])
    failed = {k for k, v in status.items() if "failed" in v}
    assert not failed, failed
    assert len(status) > 40  # the suite ran
    # the exemptions are real: each one does fail when not expected
    assert {k for k, v in status.items() if "xfail" in v} == set(NOT_FOR_TIME_SERIES)


def test_clone_tags_and_is_clusterer():
    from sklearn.base import clone, is_clusterer
    from sklearn.exceptions import NotFittedError
    from sklearn.utils import get_tags

    est = fk.SoftDTWKMeans(n_clusters=3, init="random", random_state=1)
    assert is_clusterer(est) and clone(est).get_params() == est.get_params()
    tags = get_tags(est)
    assert tags.input_tags.three_d_array and not tags.input_tags.allow_nan
    with pytest.raises(NotFittedError):
        est.predict(np.zeros((2, 5, 1)))


def _tslearn_km(**kw):
    from tslearn.clustering import TimeSeriesKMeans
    return TimeSeriesKMeans(metric="softdtw", metric_params={"gamma": kw.pop("gamma", 0.5)},
                            **kw)


@pytest.mark.parametrize("init", ["k-means++", "random", "array"])
@pytest.mark.parametrize("n_init", [1, 3])
def test_fit_predict_transform_equal_tslearn_on_new_data_of_another_length(init, n_init):
    rng = np.random.RandomState(0)
    X = rng.randn(15, 10, 3)
    new = rng.randn(7, 13, 3)  # another length than the centres
    start = X[:3, :6].copy() if init == "array" else init  # centres of yet another length
    kw = dict(n_clusters=3, max_iter=5, max_iter_barycenter=5, random_state=0, n_init=n_init,
              init=start)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = _tslearn_km(**kw).fit(X)
    u = fk.SoftDTWKMeans(gamma=0.5, **kw).fit(X)
    assert np.array_equal(t.labels_, u.labels_)
    assert np.array_equal(t.cluster_centers_, u.cluster_centers_)
    assert t.inertia_ == u.inertia_ and t.n_iter_ == u.n_iter_
    assert t.n_features_in_ == u.n_features_in_ == 3
    assert np.array_equal(t.transform(new), u.transform(new))
    assert np.array_equal(t.predict(new), u.predict(new))


# tslearn's own soft-DTW k-means tests (tslearn/tests/test_clustering.py), ported
def test_tslearn_labels_are_the_nearest_centres_and_predict_agrees():
    rng = np.random.RandomState(0)
    X = rng.randn(15, 10, 3)
    km = fk.SoftDTWKMeans(n_clusters=3, max_iter=5, random_state=rng).fit(X)
    dists = fk.soft_dtw_cross(X, km.cluster_centers_, gamma=km.gamma)
    assert np.array_equal(km.labels_, dists.argmin(axis=1))
    assert np.array_equal(km.labels_, km.predict(X))
    assert np.array_equal(km.transform(X), dists)


def test_tslearn_forced_init_keeps_the_centres_length():
    rng = np.random.RandomState(0)
    X = rng.randn(15, 10, 1)
    barys = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 2.0], [3.0, 2.0, 1.0]])[:, :, None]
    km = fk.SoftDTWKMeans(n_clusters=3, max_iter=5, init=barys, random_state=rng).fit(X)
    assert km.cluster_centers_.shape == (3, 3, 1)


def test_more_clusters_than_series_is_refused_where_tslearn_leaves_it_unfitted():
    X = np.random.RandomState(0).randn(15, 10, 3)
    with pytest.raises(ValueError, match="n_samples = 15"):
        fk.SoftDTWKMeans(n_clusters=101, random_state=0).fit(X)


def test_nan_padded_variable_length_datasets_are_refused_with_a_message_that_says_so():
    from tslearn.utils import to_time_series_dataset

    X = to_time_series_dataset([[1, 2, 3, 4], [1, 2, 3], [2, 5, 6, 7, 8, 9]])
    with pytest.raises(ValueError, match="NaN-padded variable-length"):
        fk.SoftDTWKMeans(n_clusters=2, random_state=0).fit(X)
    with pytest.raises(ValueError, match="NaN-padded variable-length"):
        fk.silhouette_score(X, [0, 0, 1])


@pytest.mark.parametrize("kwargs, err, match", [
    ({"gamma": 0.0}, ValueError, "gamma"), ({"gamma": -1.0}, ValueError, "gamma"),
    ({"gamma": float("nan")}, ValueError, "gamma"), ({"gamma": float("inf")}, ValueError, "gamma"),
    ({"gamma": "0.5"}, TypeError, "gamma"), ({"n_clusters": 1.5}, TypeError, "n_clusters"),
    ({"max_iter": 0}, ValueError, "max_iter"), ({"tol": float("nan")}, ValueError, "tol"),
    ({"init": "kmeans"}, ValueError, "init"), ({"init": np.zeros((3, 5, 2))}, ValueError, "init"),
    ({"init": np.zeros((2, 5, 1))}, ValueError, "init"), ({"random_state": "a"}, TypeError,
                                                          "random_state"),
    ({"parallel": "yes"}, TypeError, "parallel"),
])
def test_bad_parameters_name_themselves(kwargs, err, match):
    X = np.random.RandomState(0).randn(6, 5, 1)
    with pytest.raises(err, match=match):
        fk.SoftDTWKMeans(**{"n_clusters": 3, **kwargs}).fit(X)


#: every public entry point, called on input that used to reach the kernels unchecked
#: (zero-length series, mismatched feature counts, overflow, complex, sparse, 1-D data)
HOSTILE = [
    ("fk.soft_dtw(np.zeros((0, 3)), np.zeros((5, 3)))", "x"),
    ("fk.soft_dtw(np.zeros((5, 3)), np.zeros((0, 3)))", "y"),
    ("fk.dtw(np.ones((5, 3)), np.zeros((5, 2)))", "same number of features"),
    ("fk.dtw(np.zeros((0, 3)), np.zeros((5, 3)))", "x"),
    ("fk.soft_dtw_cross(np.zeros((2, 0, 3)), np.zeros((2, 5, 3)))", "A"),
    ("fk.soft_dtw_cross(np.zeros((2, 5, 3)), np.zeros((2, 5, 2)))", "same number of features"),
    ("fk.soft_dtw_grad(np.zeros((5, 3)), np.zeros((5, 2)))", "same number of features"),
    ("fk.soft_dtw_objgrad(np.zeros((5, 3)), np.zeros((4, 5, 2)))", "same number of features"),
    ("fk.dtw_pdist(np.zeros((3, 0, 2)))", "X"),
    ("fk.silhouette_score(np.zeros((4, 0, 3)), [0, 0, 1, 1])", "X"),
    ("fk.silhouette_score(np.zeros((4, 5, 3)), [0, 1])", "labels"),
    ("fk.silhouette_score(np.ones((4, 5, 3)) * 1e200, [0, 0, 1, 1])", "overflow"),
    ("fk.SoftDTWKMeans(n_clusters=2).fit(np.ones((4, 5, 3)) * 1e200)", "overflow"),
    ("fk.SoftDTWKMeans(n_clusters=2).fit(np.ones((4, 5)) * 1j)", "Complex"),
    ("fk.SoftDTWKMeans(n_clusters=2).fit(np.ones(8))", "2-D|1-D"),
    ("fk.SoftDTWKMeans(n_clusters=2).fit(scipy.sparse.csr_matrix(np.ones((4, 5))))", "sparse"),
    ("fk.SoftDTWKMeans(n_clusters=2).fit(np.zeros((0, 5, 3)))", "empty"),
    ("fk.SoftDTWKMeans(n_clusters=2, random_state=0).fit(np.random.rand(4, 5, 3))"
     ".predict(np.zeros((2, 5, 2)))", "features"),
    ("fk.soft_dtw(np.zeros((5, 3)), np.zeros((5, 3)), gamma=0.0)", "gamma"),
]


@pytest.mark.slow
def test_no_entry_point_reads_past_an_array_or_crashes():
    """Each case runs in a fresh process, so a kernel reading past an array (which used to
    return garbage, then abort with malloc(): invalid size or SIGSEGV) fails this test
    instead of killing the run."""
    code = ["import numpy as np, scipy.sparse, sys",
            "from uavwind.method import softdtw as fk",
            "bad = []"]
    for call, match in HOSTILE:
        code += ["try:", f"    {call}", f"    bad.append(('no error', {call!r}))",
                 "except (ValueError, TypeError) as exc:",
                 "    import re",
                 f"    if not re.search({match!r}, str(exc)): bad.append((str(exc), {call!r}))"]
    code += ["print(bad)", "sys.exit(1 if bad else 0)"]
    proc = subprocess.run([sys.executable, "-c", "\n".join(code)], capture_output=True,
                          text=True)
    assert proc.returncode == 0, (proc.returncode, proc.stdout[-3000:], proc.stderr[-3000:])


def test_the_loop_kernels_compile_under_one_lock_that_never_hangs(tmp_path, monkeypatch):
    """While one process holds the compile lock of the loop kernels (beside numba's cache),
    another waits for it, then goes on; past its wait it goes on without the lock, and where
    the lock file cannot be made it goes on at once."""
    import threading

    from uavwind.method import softdtw

    monkeypatch.setattr("numba.core.config.CACHE_DIR", str(tmp_path / "numba"))
    entered = threading.Event()

    def second():
        with softdtw._compile_lock():
            entered.set()

    with softdtw._compile_lock():
        t = threading.Thread(target=second, daemon=True)
        t.start()
        assert not entered.wait(1.0)  # waits while the first holds it
    assert entered.wait(10.0)  # then has it
    t.join(10.0)
    assert (tmp_path / "numba" / "uavwind-loop-kernels.lock").is_file()
    with softdtw._compile_lock():
        t0 = time.monotonic()
        with softdtw._compile_lock(wait=0.5):
            pass
        assert 0.4 < time.monotonic() - t0 < 10
    (tmp_path / "file").write_text("")
    monkeypatch.setattr("numba.core.config.CACHE_DIR", str(tmp_path / "file" / "numba"))
    t0 = time.monotonic()
    with softdtw._compile_lock(wait=60):
        pass
    assert time.monotonic() - t0 < 5


_KERNEL_MODULES = ("_kernels", "_scalar_forward", "_lockstep", "_lockstep_forward", "_libm",
                   "_vlibm", "_simd")


def _kernel_dispatchers():
    import importlib

    from numba.core.registry import CPUDispatcher

    for name in _KERNEL_MODULES:
        mod = importlib.import_module(f"uavwind.method.softdtw.{name}")
        for attr, obj in vars(mod).items():
            if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == mod.__name__:
                yield mod, attr, obj


def test_calls_between_kernels_pass_no_literal_or_prange_index():
    """A kernel called from another with a constant (``0``, ``True``) or a ``prange`` index
    (``uint64``) is compiled by numba once more for that type, beside the ``int64``/``bool``
    of a Python call: the same code twice or thrice on every cold cache (about 12 CPU-s of
    the suite's compile). Read from the source: no call from a kernel to a kernel passes a
    bare constant or a ``prange`` loop variable, and a loop counter passed to one does not
    start as a bare constant (``np.int64(...)``, ``np.bool_(...)`` instead)."""
    import ast
    import inspect

    # kernels compiled on their own (an inline="always" one is typed inside its caller)
    kernels = {attr for _, attr, d in _kernel_dispatchers()
               if d.targetoptions.get("inline", "never") != "always"}
    bad = []
    for mod in {m for m, _, _ in _kernel_dispatchers()}:
        tree = ast.parse(inspect.getsource(mod))
        for fn in (n for n in tree.body if isinstance(n, ast.FunctionDef)):
            if fn.name not in kernels:
                continue
            prange_vars = {t.target.id for t in ast.walk(fn) if isinstance(t, ast.For)
                           and isinstance(t.iter, ast.Call) and getattr(t.iter.func, "id", "")
                           == "prange" and isinstance(t.target, ast.Name)}
            assigned = {t.id for a in ast.walk(fn)  # names given a bare int somewhere
                        if isinstance(a, ast.Assign) and isinstance(a.value, ast.Constant)
                        and type(a.value.value) in (int, bool)
                        for t in a.targets if isinstance(t, ast.Name)}
            augmented = {a.target.id for a in ast.walk(fn) if isinstance(a, ast.AugAssign)
                         and isinstance(a.target, ast.Name)}
            for call in (c for c in ast.walk(fn) if isinstance(c, ast.Call)):
                if getattr(call.func, "id", None) not in kernels:
                    continue
                for arg in call.args:
                    if isinstance(arg, ast.Constant) and type(arg.value) in (int, bool):
                        bad.append(f"{mod.__name__}.{fn.name}: {ast.unparse(call)}")
                    elif isinstance(arg, ast.Name) and (arg.id in prange_vars or (
                            arg.id in assigned and arg.id in augmented)):
                        bad.append(f"{mod.__name__}.{fn.name}: {ast.unparse(call)} ({arg.id})")
    assert not bad, "\n".join(bad)


def test_no_kernel_is_compiled_for_a_literal_or_uint64_argument():
    """What the source check above keeps away, in the compiled kernels of this session (after
    the session's warm-up of every kernel, serial and threaded): no signature with a
    ``Literal`` or ``uint64`` argument (a kernel loaded whole from numba's cache registers
    only its own signature, so on a warm cache this sees less than on a cold one)."""
    bad = [f"{mod.__name__}.{attr}{sig}" for mod, attr, disp in _kernel_dispatchers()
           for sig in disp.signatures if any("Literal" in str(t) or str(t) == "uint64"
                                             for t in sig)]
    assert not bad, "\n".join(bad)


def test_cached_kernels_of_other_sources_are_cleared_before_any_loads(tmp_path):
    """numba's cache sees only a kernel's own file: the engine's stamp (the SHA-256 of its
    sources) beside the cache decides. A folder whose stamp is another digest, or has none,
    loses every entry of the engine's modules (another package's stay) and gets the stamp;
    one whose stamp matches keeps them; the digest changes with any source's bytes."""
    from pathlib import Path

    from uavwind.method.softdtw import _cache, _lockstep

    package = Path(_cache.__file__).parent
    mine = [tmp_path / "_lockstep._objgrad_serial-307.py311.nbi",
            tmp_path / "_lockstep_forward._forward-131.py311.1.nbc",
            tmp_path / "_vlibm.vexp-27.py311.nbi"]
    theirs = tmp_path / "_rotor_kernels.step-40.py311.nbi"
    for f in mine + [theirs]:
        f.write_bytes(b"x")
    (tmp_path / _cache.STAMP).write_text("0" * 64 + "\n")
    gone = _cache.clear_stale(tmp_path, package)
    assert sorted(gone) == sorted(mine) and not any(f.exists() for f in mine)
    assert theirs.exists()
    digest = _cache.sources_digest(package)
    assert (tmp_path / _cache.STAMP).read_text().strip() == digest
    mine[0].write_bytes(b"x")  # compiled from the present sources: kept
    assert _cache.clear_stale(tmp_path, package) == [] and mine[0].exists()
    (tmp_path / _cache.STAMP).unlink()  # no stamp (a cache from before stamps): cleared
    assert _cache.clear_stale(tmp_path, package) == [mine[0]]
    copy = tmp_path / "pkg"
    copy.mkdir()
    for f in package.glob("*.py"):
        (copy / f.name).write_bytes(f.read_bytes())
    assert _cache.sources_digest(copy) == digest
    (copy / "_lockstep_forward.py").write_bytes(
        (copy / "_lockstep_forward.py").read_bytes() + b"\n# changed\n")
    assert _cache.sources_digest(copy) != digest
    # the engine's own cache folder carries the present stamp once the package is imported
    folder = Path(_lockstep._objgrad_serial._cache._cache_path)
    assert (folder / _cache.STAMP).read_text().strip() == digest
