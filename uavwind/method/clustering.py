"""Cluster the trajectories of one loop and score the separation (DESIGN decision 6).

This module owns :func:`score_loop` and its result :class:`LoopResult`: soft-DTW
time-series k-means with two clusters on the raw positions, the silhouette of
that clustering under DTW, and the paper's rule that a loop scores
``100 x silhouette`` when the clusters reproduce the two wind groups (up to a
label swap) and 0 otherwise.

Engines compute the same clustering in different ways:

* ``"tslearn"`` -- the reference: ``tslearn.clustering.TimeSeriesKMeans`` and
  ``tslearn.clustering.silhouette_score``, exactly as the paper (and the Causal
  Curiosity reference code) call them;
* ``"fast"`` (default) -- :class:`uavwind.softdtw.SoftDTWKMeans` and
  :func:`uavwind.softdtw.silhouette_score`, a numba re-implementation of the same
  algorithm that gives the same labels and scores (tested with ``==`` against tslearn).

Both are driven by one adapter: an estimator with tslearn's interface and a silhouette.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..sim.vehicle import check_array, check_scalar

__all__ = ["score_loop", "LoopResult", "ENGINES", "DEFAULT_PARAMS", "check_groups", "check_engine"]

#: Fewest trajectories a loop can score: two clusters, one of them with two members.
MIN_TRAJECTORIES = 3
#: Largest position coordinate accepted [m].
MAX_COORDINATE = 1e9

#: Decision 6 defaults (every one can be overridden in :func:`score_loop`).
DEFAULT_PARAMS = {
    "gamma": 0.5,
    "max_iter": 100,
    "max_iter_barycenter": 5,
    "tol": 1e-6,
    "n_init": 1,
    "random_state": 0,
    "silhouette_metric": "dtw",
}


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
    def observations(self):
        """Cluster labels of each group: ``(labels of group 0, labels of group 1)``."""
        return self.labels[self.groups == 0], self.labels[self.groups == 1]

    def to_dict(self):
        """Flat row for a pandas table."""
        return {"score": self.score, "silhouette": self.silhouette, "correct": self.correct,
                "n_iter": self.n_iter, "labels": self.labels.tolist(), **self.metrics}

    def to_table(self, thrust=None):
        """The paper's "Simulation parameters and outputs after one simulation loop" table.

        Returns a one-column ``pandas.DataFrame``; pass the loop's
        :class:`~uavwind.actions.ThrustSequence` to add its rows.
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


def check_groups(groups, n_env):
    """Validate ``groups``: length ``n_env``, values 0/1, both present. Returns an int array."""
    g = np.asarray(groups)
    if g.ndim != 1 or g.shape[0] != n_env:
        raise ValueError(f"groups must have shape ({n_env},) (one entry per trajectory), got {g.shape}")
    if not np.issubdtype(g.dtype, np.number) and g.dtype != bool:
        raise TypeError(f"groups must hold 0/1 integers, got dtype {g.dtype}")
    if not np.all(np.isin(g, (0, 1))):
        raise ValueError(f"groups must hold only 0 and 1, got values {np.unique(g).tolist()}")
    g = g.astype(np.int64)
    if g.min() == g.max():
        raise ValueError("groups must contain two non-empty classes (both 0 and 1)")
    return g


def _tslearn_engine(p):
    from tslearn.clustering import TimeSeriesKMeans, silhouette_score

    km = TimeSeriesKMeans(n_clusters=2, metric="softdtw", metric_params={"gamma": p["gamma"]},
                          max_iter=p["max_iter"], max_iter_barycenter=p["max_iter_barycenter"],
                          tol=p["tol"], n_init=p["n_init"], random_state=p["random_state"])

    def silhouette(X, labels, metric, gamma):
        params = {"gamma": gamma} if metric == "softdtw" else None
        return silhouette_score(X, labels, metric=metric, metric_params=params)
    return km, silhouette


def _fast_engine(p):
    from .softdtw import SoftDTWKMeans, silhouette_score

    # serial kernels: parallelism comes from running loops in separate processes,
    # and a fixed order of operations keeps results independent of the machine
    km = SoftDTWKMeans(n_clusters=2, gamma=p["gamma"], max_iter=p["max_iter"],
                       max_iter_barycenter=p["max_iter_barycenter"], tol=p["tol"],
                       n_init=p["n_init"], random_state=p["random_state"], parallel=False)

    def silhouette(X, labels, metric, gamma):
        return silhouette_score(X, labels, metric=metric, gamma=gamma, parallel=False)
    return km, silhouette


#: Engine name -> ``params -> (estimator, silhouette(X, labels, metric, gamma))``: the
#: estimator has tslearn's interface (``fit_predict``, ``n_iter_``).
ENGINES = {"tslearn": _tslearn_engine, "fast": _fast_engine}


def _cluster(X, p, engine):
    """``(labels, silhouette, n_iter)`` of one loop with ``engine``: the one adapter."""
    km, silhouette = ENGINES[engine](p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        labels = np.asarray(km.fit_predict(X), dtype=np.int64)
    if len(np.unique(labels)) < 2:
        return labels, float("nan"), int(km.n_iter_)
    sil = silhouette(X, labels, p["silhouette_metric"],
                     p["gamma"] if p["silhouette_metric"] == "softdtw" else None)
    return labels, float(sil), int(km.n_iter_)


def _check_params(params):
    unknown = set(params) - set(DEFAULT_PARAMS)
    if unknown:
        raise TypeError(f"unknown clustering parameter(s) {sorted(unknown)}; "
                        f"allowed: {sorted(DEFAULT_PARAMS)}")
    p = {**DEFAULT_PARAMS, **params}
    p["gamma"] = check_scalar(p["gamma"], "gamma", low=0, low_inclusive=False)
    p["max_iter"] = check_scalar(p["max_iter"], "max_iter", low=1, integer=True)
    p["max_iter_barycenter"] = check_scalar(p["max_iter_barycenter"], "max_iter_barycenter",
                                            low=1, integer=True)
    p["tol"] = check_scalar(p["tol"], "tol", low=0)
    p["n_init"] = check_scalar(p["n_init"], "n_init", low=1, integer=True)
    p["random_state"] = check_scalar(p["random_state"], "random_state", low=0, integer=True)
    if p["silhouette_metric"] not in ("dtw", "softdtw"):
        raise ValueError(f"silhouette_metric must be 'dtw' or 'softdtw', got {p['silhouette_metric']!r}")
    return p


def default_engine():
    """The default engine: ``"fast"`` (equal to ``"tslearn"``, see the tests)."""
    return "fast"


def check_engine(engine):
    """``engine``, or :func:`default_engine` for None; ``ValueError`` if not in :data:`ENGINES`."""
    engine = default_engine() if engine is None else engine
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {sorted(ENGINES)}, got {engine!r}")
    return engine


def score_loop(trajectories, groups, engine=None, **params):
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
        ``gamma`` (soft-DTW smoothing, 0.5), ``max_iter`` (100),
        ``max_iter_barycenter`` (5), ``tol`` (1e-6), ``n_init`` (1),
        ``random_state`` (0), ``silhouette_metric`` (``"dtw"`` or ``"softdtw"``).

    Returns
    -------
    LoopResult

    Examples
    --------
    >>> import uavwind as uw
    >>> s = uw.table3_setting()
    >>> res = score_loop(s.simulate(uw.PAPER_EXAMPLE), s.groups, engine="tslearn")
    >>> res.correct
    True
    """
    X = check_array(trajectories, "trajectories", ndim=3)
    if X.shape[0] < MIN_TRAJECTORIES or X.shape[1] < 1:
        raise ValueError(f"trajectories must hold at least {MIN_TRAJECTORIES} series (the "
                         f"silhouette needs a cluster with two members) of at least 1 step, "
                         f"got shape {X.shape}")
    if np.abs(X).max() > MAX_COORDINATE:
        raise ValueError(f"trajectories must stay within +-{MAX_COORDINATE:g} m (squared DTW "
                         f"costs overflow beyond), got {np.abs(X).max():g}")
    g = check_groups(groups, X.shape[0])
    engine = check_engine(engine)
    p = _check_params(params)
    X = np.ascontiguousarray(X, dtype=np.float64)
    labels, sil, n_iter = _cluster(X, p, engine)
    two = len(np.unique(labels)) == 2
    correct = bool(two and (np.array_equal(labels, g) or np.array_equal(labels, 1 - g)))
    score = 100.0 * sil if correct and np.isfinite(sil) else 0.0
    return LoopResult(score=float(score), silhouette=float(sil), labels=labels, correct=correct,
                      n_iter=n_iter, groups=g)
