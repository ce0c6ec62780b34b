"""Soft-DTW time-series k-means: :class:`SoftDTWKMeans`, the estimator, and its loop.

The estimator follows scikit-learn's conventions (parameters stored as given in
``__init__``, fitted attributes ending in ``_``) and reproduces
``tslearn.clustering.TimeSeriesKMeans(metric="softdtw")`` exactly: k-means++ from the
same ``RandomState`` stream, assignments by soft-DTW, centres as soft-DTW barycentres
(:mod:`uavwind.method.softdtw._lbfgsb`), tslearn's stopping rule and empty-cluster handling.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from sklearn.base import BaseEstimator, ClusterMixin, TransformerMixin
from sklearn.utils import check_random_state
from sklearn.utils.validation import check_is_fitted

from ._checks import _as_dataset, _check_gamma, _same_features, _use_parallel
from ._consts import env_flag
from ._dispatch import ObjgradBatch, _sdtw_cross
from ._lbfgsb import lbfgsb_many_known
from ._libm import _libm_selfcheck


# ---------------------------------------------------------------------------
# k-means
# ---------------------------------------------------------------------------
class EmptyClusterError(Exception):
    """The final assignment left a cluster empty (tslearn raises it at the same point)."""


class KMeansResult:
    """``labels``, ``cluster_centers``, ``inertia``, ``n_iter`` as tslearn's fitted
    estimator attributes ``labels_``, ``cluster_centers_``, ``inertia_``, ``n_iter_``.
    ``success`` is False when no initialisation succeeded (tslearn then
    leaves ``labels_`` from the last failed attempt; we do the same)."""
    __slots__ = ("labels", "cluster_centers", "inertia", "n_iter", "success",
                 "n_attempts")

    def __init__(self, labels, cluster_centers, inertia, n_iter, success,
                 n_attempts):
        self.labels = labels
        self.cluster_centers = cluster_centers
        self.inertia = inertia
        self.n_iter = n_iter
        self.success = success
        self.n_attempts = n_attempts

    def __repr__(self):
        return ("KMeansResult(labels=%r, inertia=%r, n_iter=%r, success=%r)"
                % (self.labels, self.inertia, self.n_iter, self.success))


def _k_init_metric(X, n_clusters, cdist_metric, random_state):
    """tslearn.clustering.kmeans._k_init_metric, verbatim."""
    n_samples, n_timestamps, n_features = X.shape
    centers = np.empty((n_clusters, n_timestamps, n_features), dtype=X.dtype)
    n_local_trials = 2 + int(np.log(n_clusters))
    center_id = random_state.randint(n_samples)
    centers[0] = X[center_id]
    closest_dist_sq = cdist_metric(centers[0, np.newaxis], X) ** 2
    current_pot = closest_dist_sq.sum()
    for c in range(1, n_clusters):
        rand_vals = random_state.random_sample(n_local_trials) * current_pot
        candidate_ids = np.searchsorted(
            np.cumsum(closest_dist_sq, dtype=np.float64), rand_vals)
        np.clip(candidate_ids, None, closest_dist_sq.size - 1,
                out=candidate_ids)
        distance_to_candidates = cdist_metric(X[candidate_ids], X) ** 2
        np.minimum(closest_dist_sq, distance_to_candidates,
                   out=distance_to_candidates)
        candidates_pot = distance_to_candidates.sum(axis=1)
        best_candidate = np.argmin(candidates_pot)
        current_pot = candidates_pot[best_candidate]
        closest_dist_sq = distance_to_candidates[best_candidate]
        best_candidate = candidate_ids[best_candidate]
        centers[c] = X[best_candidate]
    return centers



def _softdtw_barycenters(Xks, inits, known, gamma, max_iter, objgrad_batch, tol=1e-3):
    """``[tslearn.barycenters.softdtw_barycenter(X=Xks[k], gamma, max_iter, init=inits[k])]``
    with unit weights and no constraint: ``scipy.optimize.minimize(method="L-BFGS-B",
    tol=tol, jac=True, options={"maxiter": max_iter})``, i.e. ``ftol = gtol = tol``, run by
    :func:`~uavwind.method.softdtw._lbfgsb.lbfgsb_many`: every cluster's L-BFGS-B side by
    side, so each round's objectives and gradients are one call of
    ``objgrad_batch(Xks)`` (an :class:`~uavwind.method.softdtw._dispatch.ObjgradBatch`). A
    barycentre depends only on its own series and start, so this is tslearn's
    one-after-another update, value for value.

    ``known[k]``, if not None, is the objective and gradient of cluster k at
    ``inits[k]`` over ``Xks[k]`` (:func:`~uavwind.method.softdtw._lbfgsb.lbfgsb_many_known`:
    what the last round's run of the same series ended on), so it is not computed again.
    Returns ``(centres, finals)``: ``finals[k]`` the objective and gradient at centre k where
    the run ended on an evaluated point, else None (:func:`_fit_steps` keeps them for the
    next round)."""
    if max_iter <= 0:
        return list(inits), [None] * len(inits)
    m, d = inits[0].shape
    batch = objgrad_batch(Xks)

    def fg_many(asked):
        done = batch([x.reshape(m, d) for _, x in asked], [k for k, _ in asked])
        return [(float(obj), G.ravel()) for obj, G in done]

    xs, finals = lbfgsb_many_known(fg_many, [init.ravel() for init in inits], known,
                                   max_iter, ftol=tol, gtol=tol)
    return [x.reshape(m, d) for x in xs], finals


_TP_CONTROLLER = None


def _blas_single_thread():
    """Context manager limiting the BLAS used by scipy's L-BFGS-B to one
    thread (threadpoolctl, if installed).  The L-BFGS-B vectors are far below
    OpenBLAS' multi-threading thresholds, so results are unchanged, but an
    idle OpenBLAS pool costs ~0.5 ms per setulb call on a busy machine."""
    global _TP_CONTROLLER
    import contextlib
    if not env_flag("LIMIT_BLAS"):
        return contextlib.nullcontext()
    if _TP_CONTROLLER is None:
        try:
            from threadpoolctl import ThreadpoolController
            _TP_CONTROLLER = ThreadpoolController()
        except Exception:
            _TP_CONTROLLER = False
    if _TP_CONTROLLER is False:
        return contextlib.nullcontext()
    return _TP_CONTROLLER.limit(limits=1, user_api="blas")


def fit(X: ArrayLike, n_clusters: int = 2, gamma: float = 0.5, max_iter: int = 100,
        max_iter_barycenter: int = 5, tol: float = 1e-6, n_init: int = 1,
        random_state: int | np.random.RandomState | None = 0, parallel: bool | None = None,
        init: str | ArrayLike = "k-means++") -> KMeansResult:
    """Exact equivalent of::

        km = tslearn.clustering.TimeSeriesKMeans(
            n_clusters=n_clusters, metric="softdtw",
            metric_params={"gamma": gamma}, max_iter=max_iter,
            max_iter_barycenter=max_iter_barycenter, tol=tol, n_init=n_init,
            random_state=random_state, init=init)
        labels = km.fit_predict(X)

    Returns a KMeansResult (labels, cluster_centers, inertia, n_iter).
    X: (n_ts, sz, d) float array without NaN.  random_state: None, int or
    numpy RandomState (consumed exactly as tslearn does).  init: "k-means++",
    "random" or an array of starting centres (n_clusters, sz_c, d).
    Raises EmptyClusterError where tslearn raises it (final re-assignment).
    """
    est = SoftDTWKMeans(n_clusters=n_clusters, gamma=gamma, max_iter=max_iter,
                        max_iter_barycenter=max_iter_barycenter, tol=tol, n_init=n_init,
                        random_state=random_state, parallel=parallel, init=init)
    X, init, gamma = est._validate(X)
    with _blas_single_thread():
        return _fit(X, est.n_clusters, gamma, est.max_iter,
                    est.max_iter_barycenter, est.tol, est.n_init, est.random_state,
                    parallel, init)


def fit_many(Xs: Sequence[ArrayLike], n_clusters: int = 2, gamma: float = 0.5,
             max_iter: int = 100, max_iter_barycenter: int = 5, tol: float = 1e-6,
             n_init: int = 1, random_state: int | None = 0, parallel: bool | None = None,
             init: str | ArrayLike = "k-means++") -> list[KMeansResult]:
    """``[fit(X, ...) for X in Xs]``, the same results value for value, with the fits run
    side by side: datasets of one length and dimension share the barycentre kernel's
    vectors (:func:`_drive`), which a lone fit of two clusters of 5 or 10 series leaves a
    quarter to a third idle.

    ``random_state`` is an int or None (each fit starts its own ``RandomState`` from it, as
    each ``fit`` call would); a ``RandomState`` object would be consumed by one fit after
    another, so it is refused with a ``TypeError``. Every dataset and parameter is checked
    before any fit starts."""
    if isinstance(random_state, np.random.RandomState):
        raise TypeError("random_state must be None or an int for fit_many (a RandomState "
                        "would be shared by the fits, in an order that depends on the "
                        "batch); call fit on each dataset instead")
    if isinstance(Xs, np.ndarray) and Xs.ndim != 4 or not isinstance(Xs, (Sequence,
                                                                          np.ndarray)):
        raise TypeError(f"Xs must be a sequence of datasets (n_ts, sz, d), got "
                        f"{type(Xs).__name__}" + (f" of shape {Xs.shape}"
                                                  if isinstance(Xs, np.ndarray) else ""))
    est = SoftDTWKMeans(n_clusters=n_clusters, gamma=gamma, max_iter=max_iter,
                        max_iter_barycenter=max_iter_barycenter, tol=tol, n_init=n_init,
                        random_state=random_state, parallel=parallel, init=init)
    checked = [est._validate(X) for X in Xs]
    g = checked[0][2] if checked else _check_gamma(est.gamma)  # no dataset: still checked
    by_shape = {}
    for i, (X, _, _) in enumerate(checked):
        by_shape.setdefault(X.shape[1:], []).append(i)
    out = [None] * len(checked)
    with _blas_single_thread():
        for idx in by_shape.values():
            done = _drive([_fit_steps(checked[i][0], est.n_clusters, g, est.max_iter, est.tol,
                                      est.n_init, random_state, parallel, checked[i][1])
                           for i in idx], g, est.max_iter_barycenter, parallel)
            for i, r in zip(idx, done):
                out[i] = r
    return out


def _fit(X, n_clusters, gamma, max_iter, max_iter_barycenter, tol, n_init,
         random_state, parallel, init="k-means++"):
    """One fit: :func:`_fit_steps` driven alone."""
    return _drive([_fit_steps(X, n_clusters, gamma, max_iter, tol, n_init, random_state,
                              parallel, init)], gamma, max_iter_barycenter, parallel)[0]


def _drive(fits, gamma, max_iter_barycenter, parallel):
    """Run the k-means fits ``fits`` (generators of :func:`_fit_steps`) side by side: each
    round, the barycentre updates every unfinished fit asks for are one
    :func:`_softdtw_barycenters` call, so their series share the kernel's vectors (a
    cluster of 5 or 10 series alone leaves lanes idle). A barycentre depends only on its
    own series and start (:func:`~uavwind.method.softdtw._lbfgsb.lbfgsb_many`), so each
    fit's result is the one it gives alone, value for value; the list of results in the
    order of ``fits``."""
    par = _use_parallel(parallel)
    fx = _libm_selfcheck()

    def objgrad_batch(Xks):
        return ObjgradBatch(Xks, gamma, par, fx)

    out = [None] * len(fits)
    asked = {}
    for i, run in enumerate(fits):
        try:
            asked[i] = next(run)
        except StopIteration as done:
            out[i] = done.value
    while asked:
        order = list(asked)
        new, finals = _softdtw_barycenters([Xk for i in order for Xk in asked[i][0]],
                                           [c for i in order for c in asked[i][1]],
                                           [fg for i in order for fg in asked[i][2]], gamma,
                                           max_iter_barycenter, objgrad_batch)
        at = 0
        for i in order:
            k = len(asked[i][0])
            try:
                asked[i] = fits[i].send((new[at:at + k], finals[at:at + k]))
            except StopIteration as done:
                out[i] = done.value
                del asked[i]
            at += k
    return out


def _fit_steps(X, n_clusters, gamma, max_iter, tol, n_init, random_state, parallel,
               init="k-means++"):
    """tslearn's ``TimeSeriesKMeans.fit`` loop as a generator: it yields each barycentre
    update it needs, ``(Xks, inits, known)`` (the clusters' series, starting centres, and
    what is known of each start: the objective and gradient there when the cluster kept the
    series of the last round, whose run ended at this start, else None), is sent ``(new
    centres, finals)`` (:func:`_softdtw_barycenters`), and returns the
    :class:`KMeansResult` (:func:`_drive` runs it).

    Why ``known``: a barycentre's L-BFGS-B takes about three evaluations a round, the first
    at its start; where the labels settle early and the round cap is reached (100 rounds),
    that first one is the same objective at the same point over the same series as the last
    evaluation of the round before, so it is reused instead of computed (the same doubles:
    the kernels give one pair the same values in any batch)."""
    par = _use_parallel(parallel)
    fx = _libm_selfcheck()
    n_ts = X.shape[0]

    def cdist_sdtw(A, B):
        A = np.ascontiguousarray(A)
        out = np.empty((A.shape[0], B.shape[0]))
        _sdtw_cross(A, np.ascontiguousarray(B), gamma, out, par, fx)
        return out

    arange = np.arange(n_ts)

    def assign(centers):
        dists = cdist_sdtw(X, centers)
        labels = dists.argmin(axis=1)
        inertia = (dists[arange, labels] ** 2).sum() / n_ts  # np.sum's own reduction
        return labels, inertia

    rs = check_random_state(random_state)
    max_attempts = max(n_init, 10)

    state_labels = None
    state_centers = None
    best_centers = None
    min_inertia = np.inf
    n_iter_best = 0
    n_successful = 0
    n_attempts = 0
    while n_successful < n_init and n_attempts < max_attempts:
        n_attempts += 1
        if isinstance(init, np.ndarray):  # tslearn: self.init.copy(), every attempt
            centers = init.copy()
        elif init == "random":
            centers = X[rs.choice(X.shape[0], n_clusters, replace=False)].copy()
        else:
            centers = _k_init_metric(X, n_clusters, cdist_sdtw, rs)
        state_centers = centers
        old_inertia = np.inf
        failed = False
        it = 0
        last_labels, finals = None, [None] * n_clusters
        for it in range(max_iter):
            labels, inertia = assign(centers)
            state_labels = labels
            if np.any(np.bincount(labels, minlength=n_clusters) == 0):
                failed = True
                break
            # _update_centroids: the clusters' barycentres side by side
            Xks = [np.ascontiguousarray(X[labels == k]) for k in range(n_clusters)]
            known = [finals[k] if last_labels is not None
                     and np.array_equal(labels == k, last_labels == k) else None
                     for k in range(n_clusters)]
            new, finals = yield Xks, [centers[k] for k in range(n_clusters)], known
            for k in range(n_clusters):
                centers[k] = new[k]
            last_labels = labels
            if np.abs(old_inertia - inertia) < tol:
                break
            old_inertia = inertia
        if failed:
            continue
        if inertia < min_inertia:
            best_centers = centers.copy()
            min_inertia = inertia
            n_iter_best = it + 1
        n_successful += 1

    if np.isfinite(min_inertia) and best_centers is not None:
        labels, _ = assign(best_centers)
        if np.any(np.bincount(labels, minlength=n_clusters) == 0):
            raise EmptyClusterError(
                "final assignment leads to an empty cluster (tslearn raises "
                "EmptyClusterError here too)")
        return KMeansResult(labels, best_centers, min_inertia, n_iter_best,
                            True, n_attempts)
    # no successful init: tslearn keeps labels_ of the last failed attempt
    return KMeansResult(state_labels, state_centers, np.inf, 0, False,
                        n_attempts)


#: The constructor's parameters and how each is checked (name -> (kind, low)).
_INT_PARAMS = {"n_clusters": 1, "max_iter": 1, "max_iter_barycenter": 0, "n_init": 1}


class SoftDTWKMeans(TransformerMixin, ClusterMixin, BaseEstimator):
    """Time-series k-means under soft-DTW, equal to tslearn's, a scikit-learn estimator.

    ``SoftDTWKMeans(n_clusters, gamma, max_iter, max_iter_barycenter, tol, n_init,
    random_state, init)`` gives the labels, centres, inertia and iteration count of
    ``tslearn.clustering.TimeSeriesKMeans(n_clusters, metric="softdtw",
    metric_params={"gamma": gamma}, max_iter, max_iter_barycenter, tol, n_init,
    random_state, init)`` bit for bit, and the same :meth:`predict` and :meth:`transform`
    on new data, including series of another length (tested with ``==``). It follows
    scikit-learn's conventions (``get_params``/``set_params``, ``clone``, fitted attributes
    ending in ``_``, ``check_is_fitted``) and passes ``check_estimator`` but for the checks
    that cannot apply to time series (``tests/test_softdtw.py`` names each, with why).

    Input: a dataset ``(n_ts, sz, d)``, or ``(n_ts, sz)`` for univariate series (as tslearn
    reads a 2-D array). NaN-padded variable-length datasets, which tslearn accepts, are
    refused with a ``ValueError`` that says so.

    Parameters
    ----------
    n_clusters : int
        Number of clusters, >= 1 and at most the number of series.
    gamma : float
        Soft-DTW smoothing, > 0 (0.5 in the paper's reference code).
    max_iter : int
        Cap on k-means iterations, >= 1.
    max_iter_barycenter : int
        Cap on L-BFGS-B iterations per barycentre update, >= 0.
    tol : float
        Stop when the inertia changes by less than this, >= 0 (tslearn: 1e-6).
    n_init : int
        Starts kept, >= 1 (the best inertia wins; at most ``max(n_init, 10)`` are tried).
    random_state : None, int or numpy.random.RandomState
        Consumed exactly as tslearn consumes it.
    init : {"k-means++", "random"} or array of shape (n_clusters, sz_c, d)
        How the centres start: tslearn's k-means++ under soft-DTW, ``n_clusters`` distinct
        series drawn at random, or the given centres (any length ``sz_c``).
    parallel : bool, optional
        Run the batched kernels on the process's threads, as many as numba has (default:
        ``UAVWIND_SOFTDTW_PARALLEL``, off unless set to 1); the result does not depend on it.

    Attributes
    ----------
    labels_ : ndarray of int, shape (n_ts,)
    cluster_centers_ : ndarray, shape (n_clusters, sz, d)
    inertia_ : float
        Mean squared soft-DTW to the assigned centre (``inf`` if no start succeeded).
    n_iter_ : int
        Iterations run by the kept start.
    n_features_in_ : int
        Features per time step ``d`` of the series seen in :meth:`fit`.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.random.default_rng(0).normal(size=(6, 20, 2)) + np.repeat([0, 5], 3)[:, None, None]
    >>> km = SoftDTWKMeans(n_clusters=2, random_state=0).fit(X)
    >>> km.labels_.tolist(), km.predict(X[:, :15]).tolist()
    ([1, 1, 1, 0, 0, 0], [1, 1, 1, 0, 0, 0])
    """

    def __init__(self, n_clusters=2, gamma=0.5, max_iter=100, max_iter_barycenter=5,
                 tol=1e-6, n_init=1, random_state=None, init="k-means++", parallel=None):
        self.n_clusters = n_clusters
        self.gamma = gamma
        self.max_iter = max_iter
        self.max_iter_barycenter = max_iter_barycenter
        self.tol = tol
        self.n_init = n_init
        self.random_state = random_state
        self.init = init
        self.parallel = parallel

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.three_d_array = True  # (n_ts, sz, d) time-series datasets
        tags.input_tags.allow_nan = False     # NaN-padded variable-length data refused
        tags.input_tags.sparse = False
        return tags

    # -- checks -------------------------------------------------------------- #
    def _validate(self, X):
        """``(X, init, gamma)`` checked: the dataset and the parameters (a ValueError or
        TypeError names the parameter); ``init`` as a string or a float array, ``gamma`` a
        float. The public entries (``fit``, :func:`fit`, :func:`fit_many`) call it once;
        the kernels below them trust what it returns."""
        for name, low in _INT_PARAMS.items():
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
                raise TypeError(f"{name} must be an integer >= {low}, got {v!r}")
            if v < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {v!r}")
        gamma = _check_gamma(self.gamma)
        if (isinstance(self.tol, (bool, np.bool_)) or not isinstance(self.tol, numbers.Real)
                or not (math.isfinite(self.tol) and self.tol >= 0)):
            raise ValueError(f"tol must be a finite real number >= 0, got {self.tol!r}")
        _use_parallel(self.parallel)
        if not (self.random_state is None or isinstance(self.random_state, numbers.Integral)
                or isinstance(self.random_state, np.random.RandomState)):
            raise TypeError(f"random_state must be None, an int or a numpy RandomState, got "
                            f"{type(self.random_state).__name__}")
        X = _as_dataset(X, "X")
        init = self.init
        if isinstance(init, str):
            if init not in ("k-means++", "random"):
                raise ValueError(f"init must be 'k-means++', 'random' or an array of "
                                 f"centres, got {init!r}")
        elif hasattr(init, "__array__") or isinstance(init, (list, tuple)):
            init = _as_dataset(init, "init", n_features=X.shape[2])
            if init.shape[0] != self.n_clusters:
                raise ValueError(f"init must hold n_clusters = {self.n_clusters} centres, "
                                 f"got {init.shape[0]}")
        else:
            raise TypeError(f"init must be 'k-means++', 'random' or an array of centres, got "
                            f"{type(init).__name__}")
        if self.n_clusters > X.shape[0]:
            raise ValueError(f"n_clusters = {self.n_clusters} needs at least as many series, "
                             f"got n_samples = {X.shape[0]}")
        _same_features(X, X if isinstance(init, str) else init, "X", "X" if isinstance(
            init, str) else "init")
        return X, init, gamma

    def _check_new(self, X):
        check_is_fitted(self, "cluster_centers_")
        X = _as_dataset(X, "X", n_features=self.cluster_centers_.shape[2])
        _same_features(X, self.cluster_centers_, "X", "cluster_centers_")
        return X

    # -- scikit-learn's interface -------------------------------------------- #
    def fit(self, X: ArrayLike, y: None = None) -> SoftDTWKMeans:
        """Cluster ``X`` (n_ts, sz, d); returns ``self`` with the fitted attributes."""
        X, init, gamma = self._validate(X)
        with _blas_single_thread():
            res = _fit(X, self.n_clusters, gamma, self.max_iter,
                       self.max_iter_barycenter, self.tol, self.n_init, self.random_state,
                       self.parallel, init)
        self.labels_ = np.asarray(res.labels, dtype=np.int64)
        self.cluster_centers_ = res.cluster_centers
        self.inertia_ = float(res.inertia)
        self.n_iter_ = int(res.n_iter)
        self.n_features_in_ = int(X.shape[2])
        return self

    def fit_predict(self, X: ArrayLike, y: None = None) -> np.ndarray:
        """:meth:`fit`, then the labels of ``X``."""
        return self.fit(X).labels_

    def transform(self, X: ArrayLike) -> np.ndarray:
        """Soft-DTW of each series of ``X`` to each centre, shape (n_ts, n_clusters) (as
        tslearn's ``transform``; series may have another length than the centres)."""
        X = self._check_new(X)
        out = np.empty((X.shape[0], self.cluster_centers_.shape[0]))
        _sdtw_cross(X, np.ascontiguousarray(self.cluster_centers_), _check_gamma(self.gamma),
                    out, _use_parallel(self.parallel), _libm_selfcheck())
        return out

    def predict(self, X: ArrayLike) -> np.ndarray:
        """The nearest centre of each series of ``X`` under soft-DTW, shape (n_ts,)."""
        return self.transform(X).argmin(axis=1)
