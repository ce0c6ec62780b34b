"""Cluster the trajectories of one loop and score the separation (replication notes, decision 6).

This module owns :func:`score_loop` and its result :class:`LoopResult`: soft-DTW
time-series k-means with two clusters on the raw positions, the silhouette of
that clustering under DTW, and the paper's rule that a loop scores
``100 x silhouette`` when the clusters reproduce the two wind groups (up to a
label swap) and 0 otherwise.

Engines compute the same clustering in different ways:

* ``"tslearn"`` -- the reference: ``tslearn.clustering.TimeSeriesKMeans`` and
  ``tslearn.clustering.silhouette_score``, exactly as the paper (and the Causal
  Curiosity reference code) call them;
* ``"fast"`` (default) -- :class:`uavwind.method.softdtw.SoftDTWKMeans` and
  :func:`uavwind.method.softdtw.silhouette_score`, a numba re-implementation of the same
  algorithm that gives the same labels and scores (tested with ``==`` against tslearn).

Both are driven by one adapter: an estimator with tslearn's interface and a silhouette.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.checks import Range, check_array, check_choice, check_fields, check_kwargs
from ..core.io import refuse_to_compute

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

    from ..sim.actions import ThrustSequence

__all__ = ["score_loop", "score_loops", "LoopScorer", "LoopResult", "ClusteringParams", "ENGINES",
           "DEFAULT_PARAMS",
           "check_groups", "check_engine", "default_engine", "softdtw_engine"]

#: Fewest trajectories a loop can score: two clusters, one of them with two members.
MIN_TRAJECTORIES = 3
#: Largest position coordinate accepted [m].
MAX_COORDINATE = 1e9

@dataclass(frozen=True, kw_only=True)
class ClusteringParams:
    """How one loop is clustered and scored (replication notes, decision 6).

    Attributes
    ----------
    gamma : float
        Soft-DTW smoothing, > 0. Default 0.5 (the Causal Curiosity code).
    max_iter : int
        Cap on the k-means iterations, >= 1. Default 100.
    max_iter_barycenter : int
        Cap on the L-BFGS-B iterations of each barycentre update, >= 1. Default 5.
    tol : float
        k-means stopping tolerance on the inertia, >= 0. Default 1e-6.
    n_init : int
        k-means restarts, >= 1. Default 1.
    random_state : int
        Seed of the k-means++ initialisation, >= 0. Default 0.
    silhouette_metric : {"dtw", "softdtw"}
        Metric of the silhouette. Default ``"dtw"``.

    >>> ClusteringParams(gamma=1).gamma
    1.0
    """

    gamma: float = 0.5
    max_iter: int = 100
    max_iter_barycenter: int = 5
    tol: float = 1e-6
    n_init: int = 1
    random_state: int = 0
    silhouette_metric: str = "dtw"

    def __post_init__(self):
        check_fields(self, {"gamma": Range(0, 1e300, low_inclusive=False),
                            "max_iter": Range(1, 10 ** 6, integer=True),
                            "max_iter_barycenter": Range(1, 10 ** 6, integer=True),
                            "tol": Range(0),
                            "n_init": Range(1, 10 ** 4, integer=True),
                            "random_state": Range(0, 2 ** 32 - 1, integer=True)})
        check_choice(self.silhouette_metric, "silhouette_metric", ("dtw", "softdtw"))

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_kwargs(cls, kwargs: Mapping[str, Any], where: str) -> "ClusteringParams":
        """From the ``**params`` of a function called ``where``: an unknown keyword is a
        ``TypeError`` that names it, the function and the allowed ones."""
        check_kwargs(kwargs, [f.name for f in fields(cls)], where)
        return cls(**kwargs)


#: Decision 6 defaults, as a plain mapping (part of every cache key).
DEFAULT_PARAMS = ClusteringParams().to_dict()


@dataclass(frozen=True)
class LoopResult:
    """Outcome of one simulation loop.

    Attributes
    ----------
    score : float
        ``100 * silhouette`` if ``correct`` else 0 (the paper's score, <= 100).
    silhouette : float
        Raw silhouette coefficient in [-1, 1] (NaN when only one cluster was found).
    labels : ndarray of int, shape (n_env,)
        Cluster of each environment.
    correct : bool
        The two clusters reproduce the two groups, up to a label swap.
    n_iter : int
        k-means iterations run.
    groups : ndarray of int, shape (n_env,)
        The true group (0/1) of each environment.
    metrics : dict
        Further per-loop figures (e.g. the physics baseline's), added to the row.
    """

    score: float
    silhouette: float
    labels: np.ndarray = field(repr=False)
    correct: bool
    n_iter: int
    groups: np.ndarray = field(repr=False)
    metrics: dict = field(default_factory=dict, repr=False)

    @property
    def observations(self) -> tuple[np.ndarray, np.ndarray]:
        """Cluster labels of each group: ``(labels of group 0, labels of group 1)``."""
        return self.labels[self.groups == 0], self.labels[self.groups == 1]

    def to_dict(self) -> dict:
        """Flat row for a pandas table."""
        return {"score": self.score, "silhouette": self.silhouette, "correct": self.correct,
                "n_iter": self.n_iter, "labels": self.labels.tolist(), **self.metrics}

    def to_table(self, thrust: ThrustSequence | None = None) -> pd.DataFrame:
        """The paper's "Simulation parameters and outputs after one simulation loop" table.

        Returns a one-column ``pandas.DataFrame``; pass the loop's
        :class:`~uavwind.sim.actions.ThrustSequence` to add its rows.
        """
        import pandas as pd

        def fmt(a):
            return "[" + " ".join(str(int(x)) if float(x).is_integer() else f"{x:g}"
                                  for x in np.ravel(a)) + "]"

        o1, o2 = self.observations
        rows = {"Silhouette score": f"{self.score:.2f}", "Observations1": fmt(o1),
                "Observations2": fmt(o2)}
        if thrust is not None:
            rows["Thrust change times (s)"] = fmt(thrust.times)
            rows["Thrust magnitude (N)"] = fmt(thrust.magnitudes)
            rows["Thrust directions [x y z]"] = "[" + " ".join(
                fmt(np.round(d, 3)) for d in thrust.directions) + "]"
        return pd.DataFrame({"value": rows})

    def __str__(self):
        return self.to_table().to_string(header=False)


def check_groups(groups: ArrayLike, n_env: int | None) -> np.ndarray:
    """Validate ``groups``: one dimension of length ``n_env`` (any length for None), values
    0/1, both present. Returns an int array."""
    g = np.asarray(groups)
    if n_env is None and g.ndim != 1:
        raise ValueError(f"groups must be a 1-D array of 0/1, one entry per trajectory, "
                         f"got shape {g.shape}")
    if g.ndim != 1 or (n_env is not None and g.shape[0] != n_env):
        raise ValueError(f"groups must have shape ({n_env},) (one entry per trajectory), got {g.shape}")
    if not np.issubdtype(g.dtype, np.number) and g.dtype != bool:
        raise TypeError(f"groups must hold 0/1 integers, got dtype {g.dtype}")
    if not np.all(np.isin(g, (0, 1))):
        raise ValueError(f"groups must hold only 0 and 1, got values {np.unique(g).tolist()}")
    g = g.astype(np.int64)
    if g.min() == g.max():
        raise ValueError("groups must contain two non-empty classes (both 0 and 1)")
    return g


def cache_tslearn_kernels() -> int:
    """Let tslearn's numba kernels use numba's on-disk cache, as ours do; returns how many
    were switched on.

    tslearn compiles its kernels without ``cache=True``, so every new process that runs its
    soft-DTW k-means compiled them again (about 17 CPU-s on an AMD EPYC; each test worker, the
    benchmark's reference runs, a reader's comparison). The cached machine code is what a
    compile in this process would produce (numba keys the cache on the source file and the
    CPU), so tslearn's doubles do not change, only when they are computed. Kernels already
    compiled in this process, or whose folder numba cannot write or locate, are left as they
    are. Called where the ``"tslearn"`` engine is made; safe to call again."""
    import importlib

    from numba.core.registry import CPUDispatcher

    with warnings.catch_warnings():  # tslearn warns at import that h5py (unused here) is missing
        warnings.filterwarnings("ignore", message="h5py not installed")
        import tslearn.barycenters  # noqa: F401  (with tslearn.metrics: every module below)
        import tslearn.metrics  # noqa: F401
    switched = 0
    for name in ("tslearn.metrics.soft_dtw_fast", "tslearn.metrics._soft_dtw",
                 "tslearn.metrics._dtw", "tslearn.metrics._masks", "tslearn.metrics.utils",
                 "tslearn.metrics.dtw_variants", "tslearn.metrics.softdtw_variants",
                 "tslearn.metrics._gak", "tslearn.metrics._frechet",
                 "tslearn.barycenters.softdtw", "tslearn.barycenters.dba"):
        try:
            module = importlib.import_module(name)
        except ImportError:  # another tslearn version: what it has is cached, nothing else
            continue
        for obj in vars(module).values():
            if (isinstance(obj, CPUDispatcher) and obj.__module__ == name
                    and not obj.signatures and obj._cache.__class__.__name__ == "NullCache"):
                try:
                    obj.enable_caching()
                except RuntimeError:  # no writable cache folder: it compiles, as before
                    continue
                switched += 1
    return switched


def _tslearn_engine(p):
    cache_tslearn_kernels()
    with warnings.catch_warnings():  # tslearn warns at import that h5py (unused here) is missing
        warnings.filterwarnings("ignore", message="h5py not installed")
        from tslearn.clustering import TimeSeriesKMeans, silhouette_score

    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": p["gamma"]},
                          max_iter=p["max_iter"], max_iter_barycenter=p["max_iter_barycenter"],
                          tol=p["tol"], n_init=p["n_init"], random_state=p["random_state"])

    def silhouette(X, labels, metric, gamma):
        params = {"gamma": gamma} if metric == "softdtw" else None
        return silhouette_score(X, labels, metric=metric, metric_params=params)
    return km, silhouette


def softdtw_engine():
    """:mod:`uavwind.method.softdtw`, the ``"fast"`` engine, imported when first asked for:
    it loads numba and scikit-learn (about 1.9 s), which ``import uavwind`` and a page that
    only reads results never need. Every module that clusters, compares laps by DTW or warms
    the kernels reaches the engine through here."""
    # the package's one import of the engine: kept in a function so that importing uavwind
    # (or any module that only names the engine) does not load numba and scikit-learn
    from . import softdtw
    return softdtw


def _fast_engine(p):
    engine = softdtw_engine()
    SoftDTWKMeans, silhouette_score = engine.SoftDTWKMeans, engine.silhouette_score

    # the kernels' default threads: serial unless UAVWIND_SOFTDTW_PARALLEL=1 asks for helper
    # threads (then a call's lane groups are shared with them where numba has more than one;
    # a worker process of a pool is pinned to one, core.parallel.pin_threads). Either way the
    # same doubles: a lane group's arithmetic does not depend on the thread that runs it
    km = SoftDTWKMeans(n_clusters=2, gamma=p["gamma"], max_iter=p["max_iter"],
                       max_iter_barycenter=p["max_iter_barycenter"], tol=p["tol"],
                       n_init=p["n_init"], random_state=p["random_state"], parallel=None)

    def silhouette(X, labels, metric, gamma):
        return silhouette_score(X, labels, metric=metric, gamma=gamma, parallel=None)
    return km, silhouette


#: Engine name -> ``params -> (estimator, silhouette(X, labels, metric, gamma))``: the
#: estimator has tslearn's interface (``fit_predict``, ``n_iter_``).
ENGINES = {"tslearn": _tslearn_engine, "fast": _fast_engine}


def _cluster(X, p, engine):
    """``(labels, silhouette, n_iter)`` of one loop with ``engine``: the one adapter
    (``p``: a :class:`ClusteringParams` as a dict)."""
    km, silhouette = ENGINES[engine](p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        labels = np.asarray(km.fit_predict(X), dtype=np.int64)
    return _with_silhouette(X, labels, int(km.n_iter_), p, silhouette)


def _cluster_many(Xs, p, engine):
    """:func:`_cluster` of every loop of ``Xs``, the same triples: the fast engine fits
    them side by side (:func:`uavwind.method.softdtw.fit_many`: their clusters share the
    kernel's vectors), tslearn one after another."""
    if engine != "fast":
        return [_cluster(X, p, engine) for X in Xs]
    km, silhouette = ENGINES[engine](p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits = softdtw_engine().fit_many(Xs, **km.get_params())
    return [_with_silhouette(X, np.asarray(f.labels, dtype=np.int64), int(f.n_iter), p,
                             silhouette) for X, f in zip(Xs, fits)]


def _with_silhouette(X, labels, n_iter, p, silhouette):
    """``(labels, silhouette, n_iter)``: the silhouette NaN when the labels name one cluster."""
    if len(np.unique(labels)) < 2:
        return labels, float("nan"), n_iter
    sil = silhouette(X, labels, p["silhouette_metric"],
                     p["gamma"] if p["silhouette_metric"] == "softdtw" else None)
    return labels, float(sil), n_iter


def default_engine() -> str:
    """The default engine: ``"fast"`` (equal to ``"tslearn"``, see the tests)."""
    return "fast"


def check_engine(engine: str | None) -> str:
    """``engine``, or :func:`default_engine` for None; ``ValueError`` if not in :data:`ENGINES`."""
    engine = default_engine() if engine is None else engine
    return check_choice(engine, "engine", sorted(ENGINES))


@dataclass(frozen=True, eq=False)
class LoopScorer:
    """How the loops of one setting are clustered and scored, checked once.

    The groups, the engine and the clustering parameters are checked when the scorer is
    made; calling it on a loop's trajectories then trusts them, as scikit-learn's private
    helpers assume prior validation: a search makes one scorer and scores every loop with
    it, instead of re-checking the same values loop after loop (:func:`score_loop` is the
    public entry, which checks the trajectories too).

    Attributes
    ----------
    groups : ndarray of {0, 1}, shape (n_env,)
        True wind group of each environment; both present.
    engine : {"tslearn", "fast"}
        Implementation (same answers).
    params : ClusteringParams
    """

    groups: np.ndarray
    engine: str
    params: ClusteringParams

    def __post_init__(self):
        object.__setattr__(self, "groups", check_groups(self.groups, None))
        object.__setattr__(self, "engine", check_engine(self.engine))
        if not isinstance(self.params, ClusteringParams):
            raise TypeError(f"params must be a ClusteringParams, got "
                            f"{type(self.params).__name__}")

    @classmethod
    def of(cls, groups: ArrayLike, engine: str | None = None, **params: float | str
           ) -> "LoopScorer":
        """The scorer of ``groups`` with ``engine`` (default :func:`default_engine`) and the
        fields of :class:`ClusteringParams` as keywords (an unknown one is a ``TypeError``)."""
        return cls(groups, engine, ClusteringParams.from_kwargs(params, "clustering parameters"))

    def __call__(self, trajectories: np.ndarray) -> LoopResult:
        """Cluster one loop's trajectories (a float array of shape (n_env, n_steps, d), one
        series per group entry, as the simulator returns it) and score them. Under
        ``UAVWIND_PAGES_READ_ONLY`` it refuses with a ``RuntimeError``."""
        refuse_to_compute("a clustering loop (score_loop)")
        X = self._shaped(trajectories)
        return self._result(*_cluster(X, self.params.to_dict(), self.engine))

    def many(self, trajectories: Sequence[np.ndarray]) -> list[LoopResult]:
        """``[self(t) for t in trajectories]``, the same results, the loops clustered side
        by side (:func:`_cluster_many`): what a search scores one block of loops with."""
        refuse_to_compute("a clustering loop (score_loop)")
        Xs = [self._shaped(t) for t in trajectories]
        return [self._result(*r) for r in _cluster_many(Xs, self.params.to_dict(),
                                                         self.engine)]

    def _shaped(self, trajectories):
        X = np.ascontiguousarray(trajectories, dtype=np.float64)
        g = self.groups
        if X.ndim != 3 or X.shape[0] != g.shape[0]:  # the one shape every caller shares
            raise ValueError(f"trajectories must have shape ({g.shape[0]}, n_steps, d), one "
                             f"series per group entry, got {X.shape}")
        return X

    def _result(self, labels, sil, n_iter):
        g = self.groups
        two = len(np.unique(labels)) == 2
        correct = bool(two and (np.array_equal(labels, g) or np.array_equal(labels, 1 - g)))
        score = 100.0 * sil if correct and np.isfinite(sil) else 0.0
        return LoopResult(score=float(score), silhouette=float(sil), labels=labels,
                          correct=correct, n_iter=n_iter, groups=g)


def score_loop(trajectories: ArrayLike, groups: ArrayLike, engine: str | None = None,
               **params: float | str) -> LoopResult:
    """Cluster one loop's trajectories into two clusters and score them.

    Parameters
    ----------
    trajectories : array_like, shape (n_env, n_steps, d)
        Position time series [m] (d = 3 for the UAV), finite.
    groups : array_like of {0, 1}, shape (n_env,)
        True wind group of each environment; both groups non-empty.
    engine : {"tslearn", "fast"}, optional
        Implementation (same answers); default :func:`default_engine`.
    **params
        The fields of :class:`ClusteringParams`: ``gamma`` (soft-DTW smoothing, 0.5),
        ``max_iter`` (100), ``max_iter_barycenter`` (5), ``tol`` (1e-6), ``n_init`` (1),
        ``random_state`` (0), ``silhouette_metric`` (``"dtw"`` or ``"softdtw"``); an unknown
        keyword is a ``TypeError``.

    Returns
    -------
    LoopResult

    Examples
    --------
    >>> import uavwind as uw
    >>> s = uw.table3_setting()
    >>> res = score_loop(s.simulate(uw.PAPER_EXAMPLE), s.groups)
    >>> res.correct
    True

    ``engine="tslearn"`` gives the same result, double for double, 25-28 times slower on this
    loop (tests/test_clustering.py runs it).

    Under ``UAVWIND_PAGES_READ_ONLY`` it refuses with a ``RuntimeError``: a book page reads
    loops the fill scored, it never scores one.
    """
    refuse_to_compute("a clustering loop (score_loop)")
    X = _checked_trajectories(trajectories, "trajectories")
    g = check_groups(groups, X.shape[0])
    return LoopScorer(g, engine, ClusteringParams.from_kwargs(params, "score_loop"))(X)


def score_loops(trajectories: Sequence[ArrayLike], groups: Sequence[ArrayLike],
                engine: str | None = None, **params: float | str) -> list[LoopResult]:
    """:func:`score_loop` of several loops, the same results, the loops clustered side by
    side: with the fast engine their k-means fits share the barycentre kernel's vectors
    (:func:`uavwind.method.softdtw.fit_many`), which one loop's two clusters of 5 or 10
    series leave a quarter to a third idle. A search scores its loops this way, a block at
    a time (:func:`uavwind.method.search.evaluate`).

    Parameters
    ----------
    trajectories : sequence of array_like, each of shape (n_env, n_steps, d)
        Each loop's position time series [m], as for :func:`score_loop`; loops may differ
        in ``n_env`` and ``n_steps`` (loops of one ``(n_steps, d)`` share the vectors).
    groups : sequence of array_like of {0, 1}
        Each loop's true wind groups, one entry per trajectory.
    engine, **params
        As for :func:`score_loop`, one choice for every loop.

    Returns
    -------
    list of LoopResult, in the order of ``trajectories``.
    """
    refuse_to_compute("a clustering loop (score_loop)")
    if isinstance(trajectories, np.ndarray) or not isinstance(trajectories, Sequence):
        raise TypeError(f"trajectories must be a sequence of loops (a list of arrays of shape "
                        f"(n_env, n_steps, d)), got {type(trajectories).__name__}")
    if isinstance(groups, np.ndarray) and groups.ndim != 2 or not isinstance(
            groups, (Sequence, np.ndarray)) or len(groups) != len(trajectories):
        raise ValueError(f"groups must hold one array of 0/1 per loop ({len(trajectories)} "
                         f"loops), got {type(groups).__name__} of length "
                         f"{len(groups) if hasattr(groups, '__len__') else '?'}")
    Xs = [_checked_trajectories(t, f"trajectories[{i}]") for i, t in enumerate(trajectories)]
    p = ClusteringParams.from_kwargs(params, "score_loops")
    scorers = [LoopScorer(check_groups(g, X.shape[0]), engine, p) for X, g in zip(Xs, groups)]
    engine = scorers[0].engine if scorers else check_engine(engine)
    return [sc._result(*r) for sc, r in zip(scorers, _cluster_many(Xs, p.to_dict(), engine))]


def _checked_trajectories(trajectories, name):
    """One loop's trajectories as :func:`score_loop` takes them: a finite float array of
    shape (n_env >= MIN_TRAJECTORIES, n_steps >= 1, d) within +-MAX_COORDINATE m."""
    X = check_array(trajectories, name, ndim=3)
    if X.shape[0] < MIN_TRAJECTORIES or X.shape[1] < 1:
        raise ValueError(f"{name} must hold at least {MIN_TRAJECTORIES} series (the "
                         f"silhouette needs a cluster with two members) of at least 1 step, "
                         f"got shape {X.shape}")
    if np.abs(X).max() > MAX_COORDINATE:
        raise ValueError(f"{name} must stay within +-{MAX_COORDINATE:g} m (squared DTW "
                         f"costs overflow beyond), got {np.abs(X).max():g}")
    return X
