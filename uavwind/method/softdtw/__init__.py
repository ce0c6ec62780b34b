"""The ``"fast"`` clustering engine: tslearn's soft-DTW k-means and DTW silhouette, exactly.

The face of this subpackage is one scikit-learn style estimator,
:class:`SoftDTWKMeans`, and :func:`silhouette_score`; together they give the labels and
the silhouette of ``tslearn.clustering.TimeSeriesKMeans(metric="softdtw")`` and
``tslearn.clustering.silhouette_score(metric="dtw")`` bit for bit, several times faster
(the performance page has the figures). Behind them, as tslearn splits ``metrics/``
kernels from ``clustering/`` estimators and scikit-learn ``_kmeans.py`` from its
``_k_means_*`` kernels:

* :mod:`._libm` -- bit-exact replicas of glibc's ``exp``/``log`` and their self-check;
* :mod:`._scalar_forward` -- the soft-DTW forward recursion the kernels start from;
* :mod:`._kernels` -- the numba kernels (soft-DTW value, gradient, barycentre
  objective, DTW), each tslearn's arithmetic in a faster schedule;
* :mod:`._lockstep_forward`, :mod:`._lockstep` -- the same kernels on ``N`` pairs per
  vector (:mod:`._simd`), one pair per lane, and :mod:`._dispatch`, which chooses;
* :mod:`.metrics` -- the kernels as functions of series and batches;
* :mod:`._lbfgsb` -- the L-BFGS-B driver of the barycentres, with a scipy-version guard;
* :mod:`.kmeans` -- :class:`SoftDTWKMeans` and its loop, and :func:`fit_many`, several fits
  side by side;
* :mod:`.silhouette` -- :func:`silhouette_score`;
* :mod:`._cache` -- the stamp of these sources beside numba's cache, which clears the
  entries compiled from other sources (numba's cache sees only a kernel's own file).

What the benchmarks measure is named here too, so they import no private module:
:data:`LANES` (pairs per vector on this host), :func:`n_threads`, :func:`use_lockstep`
(the lockstep or the scalar kernels inside a block) and :func:`lockstep_costs` (the
lockstep kernel's pair costs alone).

The replication notes ("The fast engine") say why the arithmetic is the same and where it
could stop being so.

*Compile time.* A kernel called from another with a constant (``0``, ``True``), a loop
counter that starts at one, or a ``prange`` index (``uint64``) is compiled by numba once for
that argument type as well as for the ``int64`` or ``bool`` a Python call gives: the same
code compiled two or three times, on every cold cache. The calls between kernels therefore
pass ``np.int64(...)`` and ``np.bool_(...)``, so each kernel compiles once (the same
operations on the same doubles); ``tests/test_softdtw.py`` checks the kernels' signatures.
"""

from __future__ import annotations

import contextlib

import numpy as np
from numpy.typing import ArrayLike

from . import _cache, _consts, _lockstep
from ._checks import _as_dataset, _as_series, _same_features
from ._kernels import _n_workers
from ._lockstep_forward import R, _all_cost_rows
from ._simd import N
from .kmeans import EmptyClusterError, KMeansResult, SoftDTWKMeans, fit, fit_many
from .metrics import (dtw, dtw_pdist, soft_dtw, soft_dtw_cross, soft_dtw_grad, soft_dtw_objgrad,
                      soft_dtw_objgrad_many)
from .silhouette import silhouette

# before any kernel loads: entries numba cached from other sources of this subpackage go
_cache.check(_lockstep._objgrad_serial)

__all__ = ["SoftDTWKMeans", "fit_many", "silhouette_score", "EmptyClusterError", "soft_dtw",
           "soft_dtw_cross", "soft_dtw_grad", "soft_dtw_objgrad", "soft_dtw_objgrad_many", "dtw",
           "dtw_pdist", "warmup", "LANES", "n_threads", "use_lockstep", "lockstep_costs"]

#: Pairs the lockstep kernels compute in one SIMD vector on this host (8 with AVX-512,
#: else 4): a figure of the engine is a figure of one host's lanes.
LANES = N


def n_threads() -> int:
    """Threads the kernels use in this process: numba's thread count where their helper
    threads are on (``UAVWIND_SOFTDTW_PARALLEL=1``; off by default), else 1."""
    return _n_workers(_consts.PARALLEL, 1 << 30)


@contextlib.contextmanager
def use_lockstep(on: bool = True):
    """Inside the block, soft-DTW values and barycentre objectives run on the lockstep
    kernels (``on``; the default unless ``UAVWIND_SOFTDTW_LOCKSTEP=0``) or on the scalar
    reference kernels (one pair at a time; the same doubles). The switch is the process's:
    it is restored on leaving, and no other thread should run kernels meanwhile."""
    before = _consts.LOCKSTEP
    _consts.LOCKSTEP = bool(on)
    try:
        yield
    finally:
        _consts.LOCKSTEP = before


def lockstep_costs(Z: ArrayLike, X: ArrayLike, sqrtsq: bool = False):
    """The lockstep kernel's pair costs alone, for timing them: ``(fill, cells)``.

    ``fill()`` computes the squared Euclidean costs of :data:`LANES` copies of ``Z`` against
    the first :data:`LANES` series of ``X`` (the last one repeated if ``X`` has fewer), one
    per lane, every block of rows of the ``len(Z)`` x ``X.shape[1]`` matrix, as the soft-DTW
    value needs them; with ``sqrtsq``, ``sqrt(.) ** 2`` of each, as tslearn's barycentre
    objective has them. The series are lane-interleaved here, once; ``cells`` is the number
    of costs one ``fill()`` computes (``LANES * len(Z) * X.shape[1]``)."""
    Z = _as_series(Z, "Z")
    X = _as_dataset(X, "X")
    _same_features(Z, X, "Z", "X")
    m, d = Z.shape
    n = X.shape[1]
    xs, ys, D = np.empty(m * d * N), np.empty(n * d * N), np.empty(R * n * N)
    _lockstep._pack_series(np.ascontiguousarray(np.repeat(Z[None], N, axis=0)), 0, xs)
    _lockstep._pack_series(np.ascontiguousarray(X), 0, ys)
    sq = bool(sqrtsq)
    return (lambda: _all_cost_rows(xs, ys, m, n, d, sq, D)), N * m * n


def silhouette_score(X: ArrayLike, labels: ArrayLike, metric: str = "dtw",
                     gamma: float | None = None, parallel: bool | None = None) -> float:
    """= ``tslearn.clustering.silhouette_score(X, labels, metric=metric)`` (``"dtw"``,
    ``"softdtw"`` with ``gamma``, or ``"precomputed"``)."""
    return silhouette(X, labels, metric=metric, gamma=gamma, parallel=parallel)


def warmup(parallel: bool = False, every: bool = False) -> KMeansResult:
    """Compile (or load from numba's on-disk cache) the kernels, once per process.

    Parameters
    ----------
    parallel : bool
        Also what the threads use: the helper threads' spins (:mod:`._share`; the lockstep
        kernels are the same code with and without helpers) and the scalar kernels'
        ``prange`` variants. A pool's worker runs the serial path only; otherwise they
        compile on their first use.
    every : bool
        Also the kernels of the other entry points (:func:`soft_dtw`, :func:`soft_dtw_grad`,
        the soft-DTW silhouette). By default only what a loop uses compiles: k-means (soft-DTW
        values and the barycentre objective) and the DTW silhouette.
    """
    rng = np.random.RandomState(0)
    X = rng.randn(4, 6, 3)
    # the serial kernels a loop uses come last: a process warming more of them beside one
    # warming only a loop's (the test session beside the book's fill, both starting on a
    # fresh clone) then compiles other kernels meanwhile, and reads the loop's from numba's
    # on-disk cache when it reaches them instead of compiling them a second time
    if every:
        for g in (0.5, 0.1):
            soft_dtw(X[0], X[1], g)
            soft_dtw_grad(X[0], X[1], g)
    for par in (True, False) if parallel else (False,):
        # the serial ones, the ones every process of a fill needs, under a lock beside
        # numba's cache: a process reaching them while another compiles them waits, then
        # loads what it wrote
        with (_compile_lock() if not par else contextlib.nullcontext()):
            r = fit(X, n_clusters=2, gamma=0.5, max_iter=2, max_iter_barycenter=2,
                    parallel=par)
            silhouette(X, np.array([0, 0, 1, 1]), metric="dtw", parallel=par)
        if every:
            silhouette(X, np.array([0, 0, 1, 1]), metric="softdtw", gamma=0.5,
                       parallel=par)
    return r


#: [s] the longest a process waits for another's compile of the loop kernels before it
#: compiles them itself (a cold compile takes about a minute on 2 busy cores)
COMPILE_WAIT = 600.0


@contextlib.contextmanager
def _compile_lock(wait: float = COMPILE_WAIT):
    """An exclusive lock (:func:`~uavwind.core.store.file_lock`) on a file beside numba's
    on-disk cache of these kernels (``$NUMBA_CACHE_DIR``, else this package's
    ``__pycache__``), held while a process compiles or loads the loop kernels: a test session
    and a book's fill starting together on a fresh clone then compile them once, not once
    each. Best effort: where the file cannot be made (a read-only install), or after ``wait``
    seconds, it goes on without the lock."""
    from pathlib import Path

    from numba.core.config import CACHE_DIR

    from ...core.store import file_lock

    folder = Path(CACHE_DIR) if CACHE_DIR else Path(__file__).parent / "__pycache__"
    with contextlib.ExitStack() as stack:
        try:
            folder.mkdir(parents=True, exist_ok=True)
            stack.enter_context(file_lock(folder / "uavwind-loop-kernels.lock", wait))
        except OSError:  # no lock file: compile without it
            pass
        yield
