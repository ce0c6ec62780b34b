"""Shared fixtures: small, fast settings; the quick book built in the background."""
import contextlib
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

# The quick book builds beside the suite (below) on the same cores, so the suite's own
# soft-DTW kernels run serially unless a test asks for threads (parallel=True; the tests of
# the threaded kernels do). A numba thread that waits at a barrier for a core another process
# holds spins, and the threaded kernels are then several times slower than the serial ones
# (`ONLY=threads make bench`, for numba's OpenMP pool; the helper threads that replaced it
# in the lockstep kernels are gentler, but still share the cores). When this was set,
# `make test` as a whole did not change measurably: 686 s before and 695 s after on fresh
# clones, the same day. Set before uavwind is imported (the
# switch is read once); OMP_WAIT_POLICY before numba's OpenMP pool starts, so that the
# threaded tests sleep while they wait.
os.environ.setdefault("UAVWIND_SOFTDTW_PARALLEL", "0")
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import uavwind as uw  # noqa: E402


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def worked_example():
    return uw.table3_setting()


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Compile (or load) the fast engine's numba kernels once, in this process, before
    any test starts worker processes: they then load the on-disk cache instead of each
    compiling the same kernels at the same time."""
    from uavwind.method import softdtw
    from uavwind.method.clustering import cache_tslearn_kernels

    softdtw.warmup(parallel=True, every=True)
    # the test modules import tslearn anyway (its references): its kernels then load from
    # numba's cache (make venv compiled them) instead of compiling in every worker
    cache_tslearn_kernels()


# ---- the result store's tests (tests/test_cache.py, test_store.py, test_future_work.py,
# test_explore.py): forged entries, and reads that must not hang

def _rewrite_parquet(path, edit, keep_digest=True):
    """Edit a parquet entry's content, keeping its stored digest and key (as a careless editor
    would: a value changed, the metadata not) or writing it back without them (as
    ``to_parquet`` does)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    new = pa.Table.from_pandas(edit(table.to_pandas()), preserve_index=False)
    if keep_digest:  # the entry's digest and key kept (the store's metadata)
        kept = {k: v for k, v in table.schema.metadata.items() if k.startswith(b"uavwind.")}
        new = new.replace_schema_metadata({**(new.schema.metadata or {}), **kept})
    pq.write_table(new, path)


def _forge_parquet(path, edit, with_key=True):
    """Rewrite a parquet entry with ``edit(df)`` and its checksum recomputed: with its own
    key (``with_key``: a forger who knows the store's recipe; only the caller's range rules
    can tell) or as the checksum of before was made (of the content alone, no key)."""
    import pyarrow.parquet as pq

    from uavwind.core import store

    key = pq.read_table(path).schema.metadata[store.KEY_KEY].decode()
    df = edit(pd.read_parquet(path))
    if with_key:
        store.atomic_write(path, df, key=key)
    else:
        import pyarrow as pa
        table = pa.Table.from_pandas(df)
        pq.write_table(table.replace_schema_metadata(
            {**table.schema.metadata, store.DIGEST_KEY: store.content_digest(df).encode()}),
            path)


@pytest.fixture
def forge_parquet():
    """:func:`_forge_parquet`: ``forge_parquet(path, edit, with_key=True)``."""
    return _forge_parquet


@pytest.fixture
def rewrite_parquet():
    """:func:`_rewrite_parquet`: ``rewrite_parquet(path, edit, keep_digest=True)``."""
    return _rewrite_parquet


@contextlib.contextmanager
def _deadline(seconds):
    """Fail (``TimeoutError``) instead of hanging if the block runs longer than ``seconds``
    (SIGALRM: a read blocked in ``open`` on a named pipe is interrupted, PEP 475)."""
    def expire(signum, frame):
        raise TimeoutError(f"still running after {seconds} s (a read that hangs?)")
    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


@pytest.fixture
def deadline():
    """:func:`_deadline`: ``with deadline(60): ...`` fails the test rather than hanging it."""
    return _deadline


def _not_a_regular_file(path, what):
    """Put ``what`` (``"fifo"``, ``"folder"`` or ``"link to fifo"``) where ``path`` was."""
    if path.exists() or path.is_symlink():
        path.unlink()
    if what == "fifo":
        os.mkfifo(path)
    elif what == "folder":
        path.mkdir()
    else:
        os.mkfifo(path.with_name(path.name + ".pipe"))
        path.symlink_to(path.name + ".pipe")


@pytest.fixture
def not_a_regular_file():
    """:func:`_not_a_regular_file`: ``not_a_regular_file(path, "fifo" | "folder" |
    "link to fifo")``."""
    return _not_a_regular_file


# ---- one dask LocalCluster for the session (tests/test_cluster_fill.py, tests/test_parallel.py)

def _forbid_writes():
    """Run on every worker: any attempt to write a cache entry there fails its task."""
    from uavwind.core import store

    def refuse(*args, **kwargs):
        raise AssertionError("a cluster worker tried to write a cache entry")
    store.atomic_write = refuse
    return os.getcwd()


@pytest.fixture(scope="session")
def dask_client(tmp_path_factory):
    """A client of a LocalCluster of two one-thread worker processes, each with its own
    working folder and forbidden to write cache entries (a cluster fill's workers compute,
    its client writes). One for the session: each cluster's workers cost about 12 CPU-s to
    start and to load the kernels. The tests that use it run one after the other
    (:func:`pytest_collection_modifyitems`) and the cluster stops after the last of them
    (:func:`pytest_runtest_teardown`): idle, its scheduler and two workers cost about 8.6
    CPU-s a minute (measured here), about 80 CPU-s over the rest of a `make test`."""
    distributed = pytest.importorskip("distributed")
    work = tmp_path_factory.mktemp("workers")
    stack = contextlib.ExitStack()
    cluster = stack.enter_context(distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
        local_directory=str(work), env={"UAVWIND_RESULTS": str(work / "nowhere")}))
    c = stack.enter_context(distributed.Client(cluster))
    _dask.update(stack=stack, work=work)
    c.register_worker_callbacks(_forbid_writes)  # also on a restarted worker
    yield c
    _stop_dask()


_dask = {}  # the session's cluster while it runs; "last": the node id of its last test


def _stop_dask():
    stack = _dask.pop("stack", None)
    if stack is not None:
        stack.close()
        assert not (_dask["work"] / "nowhere").exists(), "a cluster worker wrote a cache entry"


def pytest_runtest_teardown(item, nextitem):
    """The dask cluster stops after the last test that uses it, not at the session's end."""
    if _plain(item.nodeid) == _dask.get("last"):
        _stop_dask()


# ---- the quick book, built beside the other tests ---------------------------------------
# tests/test_book.py reads a whole quick book (about 5 minutes on 2 cores). Its build runs in
# the background from the start of the session (or the end of collection), and its tests are
# moved to the end, so the rest of the suite runs while the fill, the pages and the HTML are
# made instead of after them.
#
# Under pytest-xdist (`make test` runs `-n <cores> --dist loadgroup`) the controller, which
# collects nothing, starts the one build before its workers start; they inherit its folder
# and process group (BOOK_ENV, BOOK_PID_ENV) and wait for the exit status the build writes
# beside it (`rc`). One group per test module (its module fixtures built once), the shared
# dask cluster's tests in one group, the book's in one group, scheduled last.

BOOK_BUILD_TIMEOUT = 1800  # [s] the whole `make book`; each step has its own timeout too
BOOK_ENV = "UAVWIND_TEST_BOOK"  # the build's folder, for xdist workers
BOOK_PID_ENV = "UAVWIND_TEST_BOOK_PID"  # its process group
_book_build = {}


def _is_worker():
    return "PYTEST_XDIST_WORKER" in os.environ


def _is_controller(config):
    """The xdist controller: it runs no test and collects nothing."""
    return not _is_worker() and bool(getattr(config.option, "numprocesses", None))


def _start_book_build():
    if _book_build or _is_worker() or os.environ.get("UAVWIND_SKIP_BOOK") == "1":
        return
    root = Path(__file__).resolve().parents[1]
    tmp = Path(tempfile.mkdtemp(prefix="uavwind-book-"))
    book = tmp / "book"
    book.mkdir()
    for f in (root / "book").iterdir():
        if f.is_file():
            shutil.copy(f, book / f.name)
    env = {**os.environ, "UAVWIND_RESULTS": str(tmp / "results"), "BOOK_RC": str(tmp / "rc")}
    env.pop("MPLBACKEND", None)
    log = open(tmp / "make.log", "wb")  # a file, not a pipe nobody reads: it never blocks
    # make's exit status lands in `rc` (written whole: a reader never sees half of it)
    cmd = ["sh", "-c", 'make "$@"; echo $? > "$BOOK_RC.new" && mv "$BOOK_RC.new" "$BOOK_RC"',
           "sh", "-C", str(root), "book", "PROFILE=quick", f"BOOK={book}", "JOBS=2",
           f"RUN_FLAGS=--times {tmp / 'times.json'}"]
    proc = subprocess.Popen(cmd, env=env, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True)  # its own process group, to stop it whole
    if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
        # a terminated session (`timeout make test`) ends as an interrupted one: the build
        # is stopped (pytest_unconfigure), not left running on its own
        signal.signal(signal.SIGTERM, _terminated)
    _book_build.update(proc=proc, tmp=tmp, book=book, log=log, started=time.monotonic(),
                       started_at=time.time())
    os.environ[BOOK_ENV], os.environ[BOOK_PID_ENV] = str(tmp), str(proc.pid)


def _terminated(signum, frame):
    raise KeyboardInterrupt(f"signal {signum}")


def _whole_suite(config):
    """No paths, the checkout, or the tests folder (with the package's doctests: the
    testpaths), and no -k/-m."""
    here = Path(__file__).resolve().parent
    paths = [Path(a).resolve() for a in config.args]
    whole = (all(p in (here, here.parent, here.parent / "uavwind") for p in paths)
             and any(p in (here, here.parent) for p in paths))
    return whole and not config.option.keyword and not config.option.markexpr


@pytest.hookimpl(tryfirst=True)  # before xdist starts its workers (they inherit BOOK_ENV)
def pytest_sessionstart(session):
    """The whole suite asked for (no paths, or the tests folder, and no -k/-m): the build
    starts now, beside the collection, instead of after it. Under xdist the controller
    starts it for the whole suite or for tests/test_book.py named."""
    cfg = session.config
    if _whole_suite(cfg) or (_is_controller(cfg) and any(
            Path(a.split("::")[0]).name == "test_book.py" for a in cfg.args)):
        _start_book_build()


def _group(item):
    names = getattr(item, "fixturenames", ())
    if "dask_client" in names:
        return "dask"
    if "built_book" in names:
        return "book"
    return item.nodeid.split("::")[0]


# ---- two tiers: `make test` and `make check` ------------------------------------------------
# `make test` runs `-m "not slow"`: every test but the evidence at scale, within 5 minutes on
# the slower host kind, venv included. `make check` (what CI runs: .ci/run) runs every test and
# builds the quick book beside them. A test is slow (``@pytest.mark.slow`` at its definition)
# when it costs seconds on 2 cores and what it shows at scale is also shown, smaller, by a
# test `make test` runs: tslearn on every paper scenario (one scenario in `make test`, and the
# engine's own exactness tests), a dask cluster (the whole group below), worker processes
# spawned to show that their number changes nothing, a signal sent to a running fill,
# RotorPy's integrators beside ours, an installed copy of the package, the fits run whole
# against their targets, and the quick book itself.

#: The units of work whose tests are all slow: the shared dask cluster's and the book's.
SLOW_GROUPS = ("dask", "book")


#: The longest units of work, longest first (the suite's own CPU time by module, measured on
#: 2 cores of an AMD EPYC): they start first and the short modules fill in behind them, so
#: that neither process is left with a long module after the other ran out of work
#: (modules start in collection order: `make test` passes --no-loadscope-reorder, or xdist
#: would start the groups of most tests first, the book's among them). A module not named
#: here keeps its place after them; the book's tests stay last.
LONGEST_FIRST = ("dask", "tests/test_lockstep.py", "tests/test_sensitivity.py",
                 "tests/test_real_flights.py", "tests/test_inference.py",
                 "tests/test_sensitivity_closed_loop.py", "tests/test_search.py",
                 "tests/test_cli.py", "tests/test_manoeuvres.py", "tests/test_future_work.py",
                 "tests/test_position_control.py", "tests/test_clustering.py")


def _longest_first(items, group=None):
    """``items`` (a list, reordered in place) with the groups of :data:`LONGEST_FIRST` first,
    in its order; each group's own tests and the other groups keep their order."""
    group = group or _group
    rank = {g: i for i, g in enumerate(LONGEST_FIRST)}
    items[:] = sorted(items, key=lambda i: rank.get(group(i), len(rank)))  # stable


def pytest_itemcollected(item):
    """xdist's unit of work (``--dist loadgroup``): a module, the dask tests, the book's. The
    dask cluster's tests and the book's are slow (:data:`SLOW_GROUPS`)."""
    group = _group(item)
    item.add_marker(pytest.mark.xdist_group(group))
    if group in SLOW_GROUPS:
        item.add_marker(pytest.mark.slow)


def _name_the_groups(config, items):
    """Under ``--dist loadgroup`` the scheduler sends the tests of one group to one process by
    the suffix ``@group`` of their node ids, which pytest-xdist's own collection hook appends
    by setting ``item._nodeid``; pytest 9 keeps a node's id in ``item._id`` instead, so that
    suffix never reached the scheduler and every test was a unit of work of its own (a
    module's fixtures built in both processes, the dask cluster started in each: xdist 3.8
    on pytest 9.2). Appended here where xdist's did not take; a no-op where it did."""
    if not getattr(config.option, "loadgroup", False):
        return
    try:
        from _pytest.nodeid import NodeId
    except ImportError:  # an older pytest: xdist's own suffix works there
        return
    for item in items:
        nodeid = item.nodeid
        if nodeid.rfind("@") > nodeid.rfind("]") or not isinstance(
                getattr(item, "_id", None), NodeId):
            continue
        item._id = NodeId.parse(f"{nodeid}@{_group(item)}")


def _plain(nodeid):
    return nodeid.split("@")[0]  # xdist appends "@group" under --dist loadgroup


@pytest.hookimpl(trylast=True)  # after -k / -m deselection: build only for tests that run
def pytest_collection_modifyitems(session, config, items):
    _name_the_groups(config, items)
    # the tests of the shared dask cluster one after the other, where the first of them was
    dask_items = [i for i in items if "dask_client" in getattr(i, "fixturenames", ())]
    if dask_items:
        first = items.index(dask_items[0])
        rest = [i for i in items if i not in dask_items]
        items[:] = rest[:first] + dask_items + rest[first:]
        _dask["last"] = _plain(dask_items[-1].nodeid)
    _longest_first(items)
    book_items = [i for i in items if "built_book" in getattr(i, "fixturenames", ())]
    if not book_items:
        _stop_book_build()  # started for a whole suite whose book tests are not collected
        return
    items[:] = [i for i in items if i not in book_items] + book_items
    _start_book_build()


def _build_running(pid):
    """Whether a process of the build's group ``pid`` is left (its leader reaped first when
    it is this process's child, or it would linger as a zombie)."""
    proc = _book_build.get("proc")
    if proc is not None:
        proc.poll()
    return _alive(pid)


def _alive(pid):
    try:
        os.killpg(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


@pytest.fixture(scope="session")
def built_book():
    """The quick book's folder: waits for the background build (:func:`pytest_sessionstart`
    or :func:`pytest_collection_modifyitems`, or the xdist controller's); a failed build
    fails with the end of its log."""
    if _book_build:
        tmp, pid = _book_build["tmp"], _book_build["proc"].pid
    elif _is_worker() and BOOK_ENV in os.environ:
        tmp, pid = Path(os.environ[BOOK_ENV]), int(os.environ[BOOK_PID_ENV])
    else:
        pytest.skip("the book build was not started (UAVWIND_SKIP_BOOK=1 or deselected)")
    rc_file = tmp / "rc"
    t0 = time.monotonic()
    done = rc_file.exists()
    rc = "ended without a status"
    # the build writes `rc` before its last process ends
    while not rc_file.exists() and _build_running(pid):
        if time.monotonic() - t0 > BOOK_BUILD_TIMEOUT:
            os.killpg(pid, signal.SIGTERM)
            rc = "timed out"
            break
        time.sleep(0.5)
    if rc != "timed out" and rc_file.exists():
        rc = int(rc_file.read_text())
    _book_build["waited"] = time.monotonic() - t0
    if not done and "took" not in _book_build and "started" in _book_build:
        _book_build["took"] = time.monotonic() - _book_build["started"]
    if rc != 0:
        pytest.fail(f"make book (quick) failed ({rc}):\n"
                    + (tmp / "make.log").read_text(errors="replace")[-6000:])
    return tmp / "book"


def book_builds():
    """Whether the quick book is built in this session (in this process, or by the xdist
    controller for its workers)."""
    return bool(_book_build) or (_is_worker() and BOOK_ENV in os.environ)


@pytest.fixture
def unless_the_book_builds():
    """Skips a test whose check a book test makes on what the background book's fill
    computes anyway (read from its cache instead of computed a second time): it runs
    where no book is built (``UAVWIND_SKIP_BOOK=1``, a module named alone)."""
    if book_builds():
        pytest.skip("the book's fill computes it and tests/test_book.py checks it there")


def _stop_book_build():
    """Stop the build's whole process group (the fill writes its record as it stops: wait
    for every process of it, not only the first, before its folder is removed)."""
    proc = _book_build.get("proc")
    if proc is None or not _build_running(proc.pid):
        return
    os.killpg(proc.pid, signal.SIGTERM)
    deadline = time.monotonic() + 30
    while _build_running(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.2)
    if _alive(proc.pid):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()


def pytest_runtest_logfinish(nodeid, location):
    """When the background build ends (seen after the test it ended during): how long the
    book took, for the summary, also when it ended before its tests were reached."""
    proc = _book_build.get("proc")
    if proc is not None and "took" not in _book_build and proc.poll() is not None:
        _book_build["took"] = time.monotonic() - _book_build["started"]
        _book_build["ended_during"] = nodeid


def pytest_terminal_summary(terminalreporter):
    """Where the suite's time went: the background book's build and the wait for it (the
    wait is a worker's under xdist: the controller says when the build ended)."""
    rc_file = _book_build["tmp"] / "rc" if _book_build else None
    if "waited" in _book_build:
        took = _book_build.get("took")
        terminalreporter.write_line(
            f"quick book: built in the background in "
            f"{'under the time the other tests took' if took is None else f'{took:.0f} s'}"
            + (f" (it ended during {_book_build['ended_during']})"
               if "ended_during" in _book_build else "")
            + f"; its tests waited {_book_build['waited']:.0f} s for it")
    elif rc_file is not None and rc_file.exists():
        took = rc_file.stat().st_mtime - _book_build["started_at"]
        terminalreporter.write_line(f"quick book: built in the background in {took:.0f} s "
                                    f"(exit {rc_file.read_text().strip()})")
    for line in _time_by_module(terminalreporter.stats) + _fill_by_experiment():
        terminalreporter.write_line(line)


def _time_by_module(stats, top=12):
    """The suite's wall time summed over each module's tests (setup, call and teardown), the
    largest ``top`` modules: where a cut would count (``--durations`` names single tests)."""
    by = {}
    for reports in stats.values():
        for r in reports:
            if getattr(r, "when", None) in ("setup", "call", "teardown") and hasattr(r, "nodeid"):
                module = r.nodeid.split("::")[0]
                by[module] = by.get(module, 0.0) + r.duration
    if not by:
        return []
    ranked = sorted(by.items(), key=lambda kv: -kv[1])
    return ([f"test time by module (wall s, {sum(by.values()):.0f} s over {len(by)} modules; "
             f"under xdist the workers' times add up):"]
            + [f"  {t:7.1f}  {m}" for m, t in ranked[:top]])


def _fill_by_experiment(top=8):
    """The background book's fill: CPU seconds by experiment, from its ``--times`` record."""
    if not _book_build:
        return []
    times = _book_build["tmp"] / "times.json"
    try:
        entries = json.loads(times.read_text())["entries"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    by = {}
    for e in entries:
        by[e["experiment"]] = by.get(e["experiment"], 0.0) + e["cpu_seconds"]
    ranked = sorted(by.items(), key=lambda kv: -kv[1])
    return ([f"quick book's fill: {sum(by.values()):.0f} CPU-s, by experiment:"]
            + [f"  {t:7.1f}  {m}" for m, t in ranked[:top]])


def pytest_unconfigure(config):
    """An interrupted session stops the build; its folder goes with the session."""
    if _book_build:
        _stop_book_build()
        _book_build["log"].close()
        shutil.rmtree(_book_build["tmp"], ignore_errors=True)
