"""Worker processes: how many, one thread each, and stopping them at once.

This module owns the rules every pool of the project follows: :func:`check_jobs` (``-1`` for
all cores, or a count capped at the cores with a warning), :func:`pin_threads` (a worker runs
BLAS, OpenMP and numba on one thread, so two workers never oversubscribe two cores) and
:func:`stop_workers` (after an interrupt or an error, no worker is left running).
"""

from __future__ import annotations

import os
import warnings

from .checks import check_scalar

__all__ = ["check_jobs", "pin_threads", "stop_workers", "cores"]

_PINNED = False


def cores() -> int:
    """Cores this process may use."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def check_jobs(n_jobs: int | None, name: str = "n_jobs") -> int:
    """``n_jobs`` checked: ``None`` or ``-1`` mean all cores (returned as -1), a negative
    ``-k`` all but ``k - 1``; more than the cores is capped at the cores with a warning."""
    if n_jobs is None:
        return -1
    n = cores()
    n_jobs = check_scalar(n_jobs, name, integer=True)
    if n_jobs == 0 or n_jobs < -n:
        raise ValueError(f"{name} must be in [1, {n}] or in [-{n}, -1] (-1 = all cores), "
                         f"got {n_jobs}")
    if n_jobs > n:
        warnings.warn(f"{name} = {n_jobs} is more than the {n} cores of this machine: "
                      f"using {n}", UserWarning, stacklevel=3)
        n_jobs = n
    return n_jobs


def pin_threads() -> None:
    """Limit BLAS/OpenMP/numba to one thread in this process (once)."""
    global _PINNED
    if _PINNED:
        return
    _PINNED = True
    try:
        from threadpoolctl import threadpool_limits
        threadpool_limits(1)
    except Exception:  # pragma: no cover - threadpoolctl ships with scikit-learn
        pass
    try:
        import numba
        numba.set_num_threads(1)
    except Exception:  # pragma: no cover
        pass


def stop_workers() -> None:
    """Stop the reusable worker pool at once (after an interrupt or an error): its workers
    are killed, whatever they are computing. Calling it again is harmless.

    Three things about joblib's loky pool (joblib 1.6) decide how:

    - the pool is read from loky's module global, never through ``get_reusable_executor``:
      called on a pool already shut down, that *waits* for the old pool's manager thread
      and then starts a new pool;
    - ``shutdown(wait=False, kill_workers=True)`` only raises a flag and wakes the pool's
      manager thread, which then kills the workers. Once, beside a book build, the manager
      thread was never woken: the workers kept computing and the interpreter's exit waited
      on that thread. So the workers are also killed here, with their descendants;
    - a killed worker's sentinel wakes the manager thread, which then ends (a broken pool)."""
    try:
        from joblib.externals.loky import reusable_executor
        from joblib.externals.loky.backend.utils import kill_process_tree
    except Exception:  # pragma: no cover - another joblib: nothing of ours to stop
        return
    executor = reusable_executor._executor
    if executor is None:
        return
    workers = list(getattr(executor, "_processes", {}).values())
    try:
        if not executor._flags.shutdown:
            executor.shutdown(wait=False, kill_workers=True)
    except Exception:  # pragma: no cover - best effort on the way out
        pass
    for p in workers:
        try:
            kill_process_tree(p)
        except Exception:  # already gone
            pass
