"""Sharing a kernel call's lane groups with helper threads (:mod:`uavwind.method.softdtw._share`):
every group computed once whatever thread claims it, the caller never waiting for a helper that
has not started, a helper's error raised in the caller, the back-off when a helper's core is
busy, a forked child starting with no helpers, and the kernels giving the same doubles with
and without helpers."""
import itertools
import multiprocessing
import threading
import time

import numpy as np
import pytest

from uavwind.method.softdtw import _lockstep, _share
from uavwind.method.softdtw._share import announce, share


@pytest.fixture(autouse=True)
def _no_backoff():
    """Each test starts (and leaves) the helpers out of any back-off."""
    _share._BACKOFF.update(until=0.0, seconds=_share.BACKOFF)
    yield
    _share._BACKOFF.update(until=0.0, seconds=_share.BACKOFF)


def _claiming(n_tasks, seconds=0.0):
    """A ``work(enter)`` that claims tasks 0 .. n_tasks - 1 from a shared counter (as the
    kernels do with :func:`_share.fetch_add`) and records which thread did each."""
    counter = itertools.count()
    done = []

    def work(enter):
        announce(enter)
        while (k := next(counter)) < n_tasks:
            if seconds:
                time.sleep(seconds)  # lets the other thread in (the GIL is let go)
            done.append((k, threading.get_ident()))
    return work, done


def test_every_task_once_whoever_claims_it():
    work, done = _claiming(200, seconds=1e-4)
    share(work, 2)
    assert sorted(k for k, _ in done) == list(range(200))
    assert len({tid for _, tid in done}) <= 2


def test_one_thread_runs_alone():
    work, done = _claiming(5)
    share(work, 1)
    assert sorted(k for k, _ in done) == list(range(5))
    assert {tid for _, tid in done} == {threading.get_ident()}


def test_a_helper_that_never_starts_is_withdrawn(monkeypatch):
    """With the helper never told of the call, the caller does everything and returns."""
    share(_claiming(1)[0], 2)  # the helper exists
    monkeypatch.setattr(_share._Helper, "post", lambda self, call: None)
    work, done = _claiming(50)
    t0 = time.perf_counter()
    share(work, 2)
    assert time.perf_counter() - t0 < 5.0
    assert sorted(k for k, _ in done) == list(range(50))
    assert {tid for _, tid in done} == {threading.get_ident()}


def test_the_helpers_error_is_raised_in_the_caller():
    main = threading.get_ident()
    started = threading.Event()

    def work(enter):
        announce(enter)
        if threading.get_ident() != main:
            started.set()
            raise ValueError("helper failed")
        started.wait(10.0)  # until the helper has run (its error is then the call's)

    with pytest.raises(ValueError, match="helper failed"):
        share(work, 2)
    assert started.is_set()


def test_a_late_helper_makes_the_caller_back_off():
    """A helper that ends its share long after the caller (as when another process holds its
    core) sends the next calls to the caller alone for a while."""
    main = threading.get_ident()
    counter = itertools.count()

    def work(enter):
        announce(enter)
        if threading.get_ident() != main:
            next(counter)
            time.sleep(0.05)
        else:
            time.sleep(0.01)  # long enough for the helper to start

    share(work, 2)
    if next(counter) == 1:  # the helper took part (on a loaded machine it may not have)
        assert _share._BACKOFF["until"] > time.perf_counter()
        assert _share._BACKOFF["seconds"] == 2 * _share.BACKOFF
        again, done = _claiming(20)
        share(again, 2)
        assert {tid for _, tid in done} == {main}


def _cross_in_child(args):
    A, B = args
    out = np.empty((len(A), len(B)))
    _lockstep._sdtw_cross_lockstep(A, B, 0.5, out, nw=2)
    return out


def test_a_forked_child_makes_its_own_helpers():
    rng = np.random.default_rng(3)
    A, B = rng.normal(size=(9, 20, 3)), rng.normal(size=(2, 20, 3))
    here = np.empty((9, 2))
    _lockstep._sdtw_cross_lockstep(A, B, 0.5, here, nw=2)  # this process has a helper now
    with multiprocessing.get_context("fork").Pool(1) as pool:
        there = pool.map(_cross_in_child, [(A, B)], chunksize=1)[0]
    assert (there == here).all()


def test_kernels_give_the_same_doubles_with_helpers():
    rng = np.random.default_rng(4)
    X = rng.normal(size=(21, 30, 3)).cumsum(1)
    Zs = np.ascontiguousarray(X[[0, 11]] * 0.9)
    cid = np.repeat([0, 1], [11, 10]).astype(np.int64)
    starts = np.array([0, 11, 21], dtype=np.int64)
    one = _lockstep._objgrad_lockstep(Zs, cid, starts, X, 0.5, nw=1)
    for nw in (2, 3):
        objs, G = _lockstep._objgrad_lockstep(Zs, cid, starts, X, 0.5, nw=nw)
        assert (objs == one[0]).all() and (G == one[1]).all()
    a, b = np.empty((21, 2)), np.empty((21, 2))
    _lockstep._sdtw_cross_lockstep(X, Zs, 0.5, a, nw=1)
    _lockstep._sdtw_cross_lockstep(X, Zs, 0.5, b, nw=2)
    assert (a == b).all()
    d1, d2 = np.zeros((21, 21)), np.zeros((21, 21))
    _lockstep._dtw_upper_lockstep(X, d1, nw=1)
    _lockstep._dtw_upper_lockstep(X, d2, nw=2)
    assert (d1 == d2).all()


def test_the_kernels_run_serially_unless_threads_are_asked_for(monkeypatch):
    """Threads on request only: beside a busy core the helpers cost (`ONLY=threads make
    bench`), so a process without UAVWIND_SOFTDTW_PARALLEL runs serially; =1 asks for them.
    The switch's module is read on its own in a fresh process (without the package's
    imports: a fraction of a second)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from uavwind.method.softdtw import _consts

    path = Path(_consts.__file__)
    code = ("import importlib.util as u; s = u.spec_from_file_location('c', %r); "
            "m = u.module_from_spec(s); s.loader.exec_module(m); print(m.PARALLEL)" % str(path))
    env = {k: v for k, v in os.environ.items() if k != "UAVWIND_SOFTDTW_PARALLEL"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
    for value, expected in (("1", True), ("0", False)):
        monkeypatch.setenv("UAVWIND_SOFTDTW_PARALLEL", value)
        assert _consts.env_flag("PARALLEL", default=False) is expected
