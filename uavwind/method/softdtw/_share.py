"""One kernel call's lane groups shared between the calling thread and helper threads.

A lockstep kernel call is a few independent lane groups (two or three on a k-means loop of 5 or
10 environments a group). :func:`share` runs ``work`` on the calling thread and, at the same
time, on up to ``n - 1`` helper threads; ``work`` is a numba kernel (``nogil``) that claims
groups one at a time from a counter (:func:`fetch_add`) until none is left. So a thread that
starts late only takes fewer groups, and the caller never waits for a helper that has not
started on the call: it withdraws the call from it and returns. It waits only for a helper that
is computing a group it claimed. Which thread computes a group changes no double: each group
writes only its own outputs, and every reduction runs after :func:`share` returns.

Why not numba's ``prange``: its OpenMP team splits the groups in fixed shares and each call ends
at a barrier, so with another process busy on the second core a call waits for a thread the
system has not scheduled. Measured on an Intel Xeon of 2 cores, the held-out check's 12 loops
as ``score_loop`` runs them (one round each, a spinning process on one core for "busy"):
serial 0.64 s idle and busy; OpenMP's pool 0.49 s idle, 2.1-2.9 s busy (0.74 s busy and
0.58 s idle with ``OMP_WAIT_POLICY=PASSIVE``); these helpers 0.47-0.50 s idle, 0.71-0.73 s
busy. ``ONLY=threads make bench`` measures the last against serial.

A helper spins (without the GIL, :func:`_spin`) for about :data:`SPIN_TICKS` after each call
before it sleeps: the L-BFGS-B step between two barycentre calls takes tens of microseconds,
less than waking a sleeping thread takes on a virtual machine (52-66 us here, the median
from posting a call to a sleeping helper starting it, on a guest that does not poll before
it halts; 8.7 us with the spin and the mailbox below). It wakes when the caller's kernel announces itself
(:func:`announce`), so it takes the GIL while the caller has let go of it, and the caller
waits for it, spinning too, until it has let go of the GIL again. After a call whose helper
ended much later than the caller (its core was busy), calls run on the caller alone for
:data:`BACKOFF` seconds, doubled each time it happens again in a row. Helpers are daemon
threads, made the first time a call asks for them; a process forked from one starts with none.
One call uses the helpers at a time; a call made while another thread's call holds them runs on
its own thread.
"""

import os
import threading
import time

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.extending import intrinsic

#: Timestamp-counter ticks a helper spins for after a call before it sleeps (about 1 ms).
SPIN_TICKS = 3_000_000
#: Ticks the caller spins for, waiting for a helper that has started, before it blocks.
WAIT_TICKS = 30_000_000
#: Seconds :func:`share` runs calls on the caller's thread alone after a helper finished a
#: call's last group long after the caller (the helper's core is busy with another process);
#: doubled after each such call in a row (up to :data:`MAX_BACKOFF`), reset after a good one.
BACKOFF = 0.02
MAX_BACKOFF = 1.0


@intrinsic
def fetch_add(typingctx, counter, value):
    """``counter[0] += value`` as one atomic operation; returns the value before (``counter``:
    a 1-D int64 array shared by the threads)."""
    sig = types.int64(counter, types.int64)

    def codegen(context, builder, signature, args):
        arr = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.atomic_rmw("add", arr.data, args[1], "seq_cst")
    return sig, codegen


@intrinsic
def _load_acquire(typingctx, counter):
    """``counter[0]`` read with acquire ordering: a plain read could be hoisted out of a spin."""
    sig = types.int64(counter)

    def codegen(context, builder, signature, args):
        arr = context.make_array(signature.args[0])(context, builder, args[0])
        return builder.load_atomic(arr.data, "acquire", 8)
    return sig, codegen


@intrinsic
def _ticks(typingctx):
    """The processor's timestamp counter (``llvm.readcyclecounter``): a clock for the spins."""
    sig = types.int64()

    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.IntType(64), []),
                                            "llvm.readcyclecounter")
        return builder.call(fn, [])
    return sig, codegen


@njit(cache=True, nogil=True, inline="always")
def announce(enter):
    """A kernel's first step on the calling thread's run: tell the helpers (spinning on
    ``enter``, the mailbox) that the caller is inside the kernel, so the GIL is free for them;
    ``enter`` is empty on a helper's run and on a serial call."""
    if enter.size > 0:
        fetch_add(enter, 1)


@njit(cache=True, nogil=True)
def _spin(word, seen, back, ticks):
    """Bump ``back`` (if not empty: the last call's 'helper is back' count), then whether
    ``word[0]``, which only grows (the mailbox), grows past ``seen`` within about ``ticks``
    timestamp ticks."""
    if back.size > 0:
        fetch_add(back, 1)
    return _spin_until(word, seen + 1, ticks)


@njit(cache=True, nogil=True)
def _spin_until(word, target, ticks):
    """Whether ``word[0] >= target`` within about ``ticks`` timestamp ticks."""
    t0 = _ticks()
    while True:
        for _ in range(64):
            if _load_acquire(word) >= target:
                return True
        if _ticks() - t0 > ticks:
            return False


_PENDING, _RUNNING, _WITHDRAWN = 0, 1, 2
#: The helpers' mailbox: a caller's kernel bumps it on entry (:func:`announce`).
_MAILBOX = np.zeros(1, dtype=np.int64)
#: What a helper's run and a serial call pass as ``enter``: nothing to announce.
NO_MAILBOX = np.zeros(0, dtype=np.int64)


class _Call:
    """One call handed to one helper: ``work``, its state, the helper's error if any, and
    ``back``, which the helper bumps once its run is over and it has let go of the GIL."""
    __slots__ = ("work", "state", "done", "error", "back")

    def __init__(self, work):
        self.work = work
        self.state = _PENDING
        self.done = threading.Event()
        self.error = None
        self.back = np.zeros(1, dtype=np.int64)


class _Helper:
    """A daemon thread that runs the call posted to it last, when a caller's kernel announces
    itself in the mailbox; it spins (without the GIL) for :data:`SPIN_TICKS` after each call,
    then sleeps until the next is posted."""

    def __init__(self):
        self._call = None
        self._asleep = False
        self._lock = threading.Lock()  # guards a call's state
        self._wake = threading.Condition(threading.Lock())
        threading.Thread(target=self._run, name="uavwind-softdtw-helper", daemon=True).start()

    def _pending(self):
        call = self._call
        return call is not None and call.state == _PENDING

    def _run(self):
        seen = int(_MAILBOX[0])
        back = NO_MAILBOX
        while True:
            if not _spin(_MAILBOX, seen, back, SPIN_TICKS):
                with self._wake:
                    self._asleep = True
                    while not self._pending():
                        self._wake.wait()
                    self._asleep = False
            back = NO_MAILBOX
            seen = int(_MAILBOX[0])
            call = self._call
            with self._lock:
                if call is None or call.state != _PENDING:
                    continue
                call.state = _RUNNING
            try:
                call.work(NO_MAILBOX)
            except BaseException as error:  # handed to the caller, which raises it
                call.error = error
            call.done.set()
            back = call.back

    def post(self, call):
        with self._wake:
            self._call = call
            if self._asleep:
                self._wake.notify()

    def withdraw(self, call):
        """True if the helper had not started ``call`` (it never will); False if it has."""
        with self._lock:
            if call.state == _PENDING:
                call.state = _WITHDRAWN
                return True
        return False


_HELPERS = []
_IN_USE = threading.Lock()
_BACKOFF = {"until": 0.0, "seconds": BACKOFF}


def _forget_helpers():
    """In a forked child: the parent's helper threads do not exist there."""
    global _IN_USE
    _HELPERS.clear()
    _IN_USE = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_helpers)


def share(work, n):
    """Run ``work(enter)`` on this thread and on up to ``n - 1`` helper threads at once;
    return when this thread's run has returned and every helper that started has finished
    (a helper that had not started is withdrawn). ``work`` must claim its share of the
    call's work itself (:func:`fetch_add`), so that any number of runs, from one to ``n``,
    completes it, and its kernel must :func:`announce` ``enter`` first. The first error of
    any run is raised."""
    if n <= 1 or time.perf_counter() < _BACKOFF["until"] or not _IN_USE.acquire(blocking=False):
        work(NO_MAILBOX)
        return
    try:
        while len(_HELPERS) < n - 1:
            _HELPERS.append(_Helper())
        calls = [(helper, _Call(work)) for helper in _HELPERS[:n - 1]]
        for helper, call in calls:
            helper.post(call)
        error = None
        t0 = time.perf_counter()
        try:
            work(_MAILBOX)
        except BaseException as err:
            error = err
        t1 = time.perf_counter()
        for helper, call in calls:
            if not helper.withdraw(call):
                # started: wait, spinning first, until its run is over and the GIL is free
                if not _spin_until(call.back, 1, WAIT_TICKS):
                    call.done.wait()
                if error is None and call.error is not None:
                    error = call.error
        t2 = time.perf_counter()
        # a helper that ended much later than the caller was not given its core: back off
        if t2 - t1 > (t1 - t0) + 1e-4:
            _BACKOFF["until"] = t2 + _BACKOFF["seconds"]
            _BACKOFF["seconds"] = min(MAX_BACKOFF, 2 * _BACKOFF["seconds"])
        else:
            _BACKOFF["seconds"] = BACKOFF
        if error is not None:
            raise error
    finally:
        _IN_USE.release()
