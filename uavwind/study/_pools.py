"""Where the fill's tasks run: local worker processes, or a dask cluster.

This module owns the two pools :func:`uavwind.study.fill.fill_cache` hands its tasks to,
behind one interface (``put`` a task with a priority, ``wait`` for the tasks that finished,
``busy``, ``cancel`` the ones not started): :class:`_LocalPool`, joblib's reusable loky
workers with the pending tasks queued here in priority order, :class:`_ClusterPool`, a
``dask.distributed`` client whose scheduler orders them, and :class:`_SplitPool`, the two
side by side (a cluster's fill runs its analyses on the local workers); and :class:`_Watcher`, the thread
that stops the local workers as soon as a stop is requested. Which tasks there are, their
priorities and what is done with their results are the fill's.
"""

from __future__ import annotations

import heapq
import threading
import time
import uuid
from concurrent.futures import FIRST_COMPLETED, wait

from ..core.parallel import stop_workers


class _LocalPool:
    """Tasks on the local worker processes: joblib's reusable loky executor, made with the
    arguments joblib's own ``Parallel`` gives it (so a later ``Parallel`` in this process,
    e.g. Experiment 13's after the fill, reuses these workers instead of starting others),
    and which :func:`~uavwind.core.parallel.stop_workers` stops. At most one task per
    worker is handed out; the pending ones wait here in priority order, so a task put later
    with a higher priority (the next CEM iteration's samples) goes before those already
    waiting."""

    def __init__(self, n_workers: int, executor=None):
        from joblib import Parallel

        self.pending, self.running, self._seq = [], {}, 0
        if executor is not None:  # any concurrent.futures-style executor (tests)
            self.n, self.executor = n_workers, executor
            return
        try:  # the executor a Parallel(n_jobs=n_workers) would run on (joblib's private
            # set-up; tests/test_fill.py checks that a later Parallel reuses its workers)
            par = Parallel(n_jobs=n_workers)
            self.n = par._initialize_backend()
            self.executor = par._backend._workers
        except Exception:  # pragma: no cover - another joblib: its own workers, not shared
            from joblib.executor import get_memmapping_executor
            self.n, self.executor = n_workers, get_memmapping_executor(n_workers)

    def start(self, key, fn, *args):
        """Hand a task to the workers now, ahead of every task put (it counts as one of the
        tasks in flight)."""
        self.running[self.executor.submit(fn, *args)] = key

    def put(self, key, priority, fn, *args):
        heapq.heappush(self.pending, (-priority, self._seq, key, fn, args))
        self._seq += 1

    def busy(self) -> bool:
        return bool(self.pending or self.running)

    def wait(self, timeout: float, dispatch: bool = True) -> list:
        """``(key, result, error)`` of every task finished within ``timeout`` seconds
        (``error`` is ``None``, or the exception the task raised, its result ``None``);
        first (``dispatch``) the free workers get the next tasks."""
        while dispatch and self.pending and len(self.running) < self.n:
            _, _, key, fn, args = heapq.heappop(self.pending)
            self.running[self.executor.submit(fn, *args)] = key
        done, _ = wait(list(self.running), timeout=timeout, return_when=FIRST_COMPLETED)
        out = []
        for f in done:
            key, exc = self.running.pop(f), f.exception()
            out.append((key, None if exc is not None else f.result(), exc))
        return out

    def cancel(self):
        self.pending.clear()


class _ClusterPool:
    """Tasks on a dask cluster: each is submitted at once with its priority (the scheduler
    runs the highest first, and computes again a task whose worker died). Task names carry
    a token of this fill, so two fills on one cluster never share a task."""

    def __init__(self, client):
        from distributed import as_completed

        self.client, self.futures = client, {}
        self.arrivals = as_completed([])
        self.token = uuid.uuid4().hex[:8]

    def put(self, key, priority, fn, *args):
        # a chunk's key is its path; a CEM sample's (path, iteration, sample)
        name = (f"uavwind-fill-{key.stem}-{self.token}" if not isinstance(key, tuple)
                else f"uavwind-cem-{key[0].stem}-{key[1]}-{key[2]}-{self.token}")
        fut = self.client.submit(fn, *args, key=name, priority=priority, pure=False)
        self.futures[fut] = key
        self.arrivals.add(fut)

    def busy(self) -> bool:
        return bool(self.futures)

    def wait(self, timeout: float, dispatch: bool = True) -> list:
        """As :meth:`_LocalPool.wait` (every task was submitted when put)."""
        if not self.arrivals.has_ready():
            if timeout:
                time.sleep(min(timeout, 0.1))
            return []
        out = []
        for fut in self.arrivals.next_batch(block=False):
            key = self.futures.pop(fut)
            try:
                out.append((key, fut.result(), None))
            except Exception as exc:  # the task's error (or its cancellation)
                out.append((key, None, exc))
            fut.release()
        return out

    def cancel(self):
        if self.futures:
            self.client.cancel(list(self.futures), force=True)


class _SplitPool:
    """A cluster's pool for the experiments' tasks beside a local one for the analyses' (a key
    ``("analysis", id)``): an analysis reads and writes the result folder, which the
    cluster's workers need not see, so it runs on this machine's workers -- as soon as what
    it reads is stored, while the cluster computes the rest -- instead of after the cluster,
    one after the other. The interface is the pools'."""

    def __init__(self, cluster: _ClusterPool, local: _LocalPool):
        self.cluster, self.local = cluster, local

    def _pool(self, key):
        return self.local if isinstance(key, tuple) and key[0] == "analysis" else self.cluster

    def put(self, key, priority, fn, *args):
        self._pool(key).put(key, priority, fn, *args)

    def busy(self) -> bool:
        return self.cluster.busy() or self.local.busy()

    def wait(self, timeout: float, dispatch: bool = True) -> list:
        out = self.local.wait(0, dispatch) if self.local.busy() else []
        return out + self.cluster.wait(0 if out else timeout, dispatch)

    def cancel(self):
        self.local.cancel()
        self.cluster.cancel()


class _Watcher:
    """A thread that stops the local workers as soon as ``stop`` is set, so a fill waiting
    on entries that take minutes ends within a moment of a SIGINT or SIGTERM (the waiting
    loop then sees its workers gone, and raises ``KeyboardInterrupt``). The workers write
    each entry whole (a temporary file renamed), so an entry is on disk complete or not at
    all; the ones under way are computed again by the next run."""

    def __init__(self, stop: threading.Event):
        self.stop = stop
        self.done = threading.Event()
        self.thread = threading.Thread(target=self._watch, name="uavwind-fill-stop",
                                       daemon=True)
        self.thread.start()

    def _watch(self):
        while not self.done.wait(0.1):
            if self.stop.is_set():
                stop_workers()
                return

    def close(self):
        self.done.set()
        self.thread.join()
