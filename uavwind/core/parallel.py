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


#: [s] how long :func:`stop_workers` lets the pool's manager thread kill the workers itself
#: before it kills the ones left
STOP_WAIT = 2.0


def stop_workers() -> None:
    """Stop the reusable worker pool at once (after an interrupt or an error): its workers
    are killed, whatever they are computing. Calling it again is harmless.

    Three things about joblib's loky pool (joblib 1.6) decide how:

    - the pool is read from loky's module global, never through ``get_reusable_executor``:
      called on a pool already shut down, that calls ``shutdown(wait=True,
      kill_workers=False)`` on it, which clears the kill flag of the first call (when the
      pool's manager thread had not yet acted on it, under load, the thread then waited for
      the workers' tasks to finish, and the interpreter's exit waited on the thread), and
      then starts a new pool;
    - ``shutdown(wait=False, kill_workers=True)`` only raises the flag and wakes the manager
      thread, which kills the workers and ends; it is given :data:`STOP_WAIT` seconds;
    - the workers still alive then are killed here, with their descendants (a killed
      worker's sentinel wakes the manager thread, which ends with the pool broken)."""
    import threading

    try:
        from joblib.externals.loky import reusable_executor
        from joblib.externals.loky.backend.utils import kill_process_tree
    except Exception:  # pragma: no cover - another joblib: nothing of ours to stop
        return
    executor = reusable_executor._executor
    if executor is None:
        return
    workers = list(getattr(executor, "_processes", {}).values())
    manager = getattr(executor, "_executor_manager_thread", None)
    try:
        if not executor._flags.shutdown:
            executor.shutdown(wait=False, kill_workers=True)
            if manager is not None and manager is not threading.current_thread():
                manager.join(timeout=STOP_WAIT)
    except Exception:  # pragma: no cover - best effort on the way out
        pass
    for p in workers:
        try:
            if p.is_alive():
                kill_process_tree(p)
        except Exception:  # already gone
            pass
