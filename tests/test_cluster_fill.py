"""The fill on a dask.distributed cluster: the workers compute, the client writes.

A ``LocalCluster`` of worker processes, each with its own working folder and forbidden to
write cache entries, fills the cache: the rows equal a local fill's bit for bit, an
interrupted fill resumes, and a worker killed in the middle of a task loses nothing.
"""
import os
import signal
import threading
import time

import pytest
from helpers import exact_cells
from test_fill import TINY

from uavwind import study as ex
from uavwind.study import _dask_probe, fill

distributed = pytest.importorskip("distributed")

IDS = ["exp5", "exp6"]


@pytest.fixture
def client(dask_client):
    """The session's LocalCluster (conftest.py): workers that may not write cache entries."""
    return dask_client


def _rows(folder, reading):
    return {eid: exact_cells(ex.run_experiment(eid, profile=TINY, results=folder, n_jobs=1,
                                          progress=False, reading=reading))
            for eid in IDS}


def _entries(folder):
    return sorted(p.relative_to(folder) for p in folder.rglob("*.parquet"))


@pytest.fixture(scope="module")
def local_fill(tmp_path_factory):
    """TINY filled by one local process, once for the tests that compare a cluster's fill
    with it: ``(folder, fill_cache's summary)``."""
    folder = tmp_path_factory.mktemp("local")
    return folder, fill.fill_cache(IDS, profile=TINY, results=folder, readings="all",
                                   progress=False, n_jobs=1)


def test_a_cluster_fill_stores_what_a_local_fill_stores(tmp_path, client, local_fill):
    done = fill.fill_cache(IDS, profile=TINY, results=tmp_path / "cluster", readings="all",
                           progress=False, scheduler=client)
    assert done["computed"] == done["entries"] > 0 and done["cached"] == 0
    assert all(t["cpu_seconds"] > 0 for t in done["times"])   # timed on the workers
    # a CEM iteration's samples were tasks of SAMPLES_PER_TASK at most; a chunk, one task
    cem = TINY["cem"]
    assert {t["tasks"] for t in done["times"] if t["search"] == "cem"} == {
        -(-cem["n_samples"] // fill.SAMPLES_PER_TASK) * cem["max_iter"]}
    assert {t["tasks"] for t in done["times"] if t["search"] != "cem"} == {1}
    assert sum(t["rows"] for t in done["times"]) == done["rows_computed"]
    folder, local = local_fill
    assert _entries(tmp_path / "cluster") == _entries(folder)
    assert local["rows_computed"] == done["rows_computed"]
    for reading in ("inferred", "halves"):
        assert _rows(tmp_path / "cluster", reading) == _rows(folder, reading)
    again = fill.fill_cache(IDS, profile=TINY, results=tmp_path / "cluster", readings="all",
                            progress=False, scheduler=client)
    assert again["cached"] == again["entries"] and again["computed"] == 0


def test_an_interrupted_cluster_fill_resumes(tmp_path, client, local_fill):
    stop = threading.Event()

    class StopAfterFirst(list):  # the record of the first stored entry asks to stop
        def append(self, item):
            super().append(item)
            stop.set()
    with pytest.raises(KeyboardInterrupt):
        fill.fill_cache(IDS, profile=TINY, results=tmp_path, readings="all", progress=False,
                        scheduler=client, stop=stop, times=StopAfterFirst())
    kept = _entries(tmp_path)
    total = len(fill.needed_entries(IDS, TINY, "all", results=tmp_path))
    assert 1 <= len(kept) < total
    deadline = time.monotonic() + 30  # the rest were cancelled, not left running
    while any(client.processing().values()) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(client.processing().values())
    done = fill.fill_cache(IDS, profile=TINY, results=tmp_path, readings="all",
                           progress=False, scheduler=client)
    assert done["cached"] == len(kept) and done["computed"] == total - len(kept)
    assert _rows(tmp_path, "inferred") == _rows(local_fill[0], "inferred")


def test_a_worker_killed_mid_task_loses_nothing(tmp_path, client):
    prof = {**TINY, "loops": 6, "cem": {"n_samples": 4, "n_elite": 2, "max_iter": 3}}
    result, errors = {}, []

    def run():
        try:
            result.update(fill.fill_cache(IDS, profile=prof, results=tmp_path,
                                          readings="all", progress=False, scheduler=client))
        except BaseException as exc:  # pragma: no cover - reported below
            errors.append(exc)
    th = threading.Thread(target=run)
    th.start()
    deadline = time.monotonic() + 120
    while not _entries(tmp_path) and time.monotonic() < deadline:
        time.sleep(0.05)
    first = _entries(tmp_path)
    assert first, "no entry was stored within 120 s"
    stamp = {p: os.stat(tmp_path / p).st_mtime_ns for p in first}
    busy = {w: keys for w, keys in client.processing().items() if keys}
    pids = client.run(os.getpid)
    victim = next(iter(busy), None)
    assert victim is not None, "no task was running after the first entry came back"
    os.kill(pids[victim], signal.SIGKILL)
    th.join(300)
    assert not th.is_alive() and not errors, errors
    total = len(fill.needed_entries(IDS, prof, "all", results=tmp_path))
    assert len(_entries(tmp_path)) == total == result["entries"]
    assert result["computed"] == total  # each entry stored once: none lost, none redone
    assert {p: os.stat(tmp_path / p).st_mtime_ns for p in first} == stamp
    alone = tmp_path / "alone"
    fill.fill_cache(IDS, profile=prof, results=alone, readings="all", progress=False, n_jobs=1)
    for reading in ("inferred", "halves"):
        assert {e: exact_cells(ex.run_experiment(e, profile=prof, results=tmp_path, n_jobs=1,
                                            progress=False, reading=reading)) for e in IDS} == \
            {e: exact_cells(ex.run_experiment(e, profile=prof, results=alone, n_jobs=1,
                                         progress=False, reading=reading)) for e in IDS}


@pytest.mark.parametrize("scheduler, error, word", [
    (42, TypeError, "scheduler"), ("tcp://host 8786", ValueError, "scheduler"),
    ("", ValueError, "scheduler")])
def test_a_bad_scheduler_is_refused_before_any_work(tmp_path, scheduler, error, word):
    with pytest.raises(error, match=word):
        fill.fill_cache(IDS, profile=TINY, results=tmp_path / "r", progress=False,
                        scheduler=scheduler)
    assert not (tmp_path / "r").exists()


def test_an_unreachable_scheduler_is_a_value_error(tmp_path):
    import dask

    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        with pytest.raises(ValueError, match="cannot reach a dask scheduler"):
            fill.fill_cache(IDS, profile=TINY, results=tmp_path / "r", progress=False,
                            scheduler="tcp://127.0.0.1:9")
    assert not (tmp_path / "r").exists()


# --------------------------------------------------------------------------- #
# a scheduler address that is refused, silent or not dask fails fast (issue 33)
# --------------------------------------------------------------------------- #
class _FakeServer:
    """A TCP server on 127.0.0.1 that accepts and then stays silent, or sends ``reply``."""

    def __init__(self, reply=None):
        import socket

        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.port = self.sock.getsockname()[1]
        self.reply, self.conns = reply, []
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self):
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            self.conns.append(conn)
            if self.reply:
                conn.sendall(self.reply)

    def close(self):
        self.sock.close()
        for c in self.conns:
            c.close()


@pytest.mark.parametrize("kind, word", [
    ("silent", "no dask scheduler answered"),
    ("http", "is not a dask scheduler"),
    ("refused", "cannot reach a dask scheduler")])
def test_a_scheduler_address_that_is_not_a_dask_scheduler_fails_within_seconds(tmp_path,
                                                                              kind, word):
    import socket

    if kind == "refused":
        s = socket.socket()
        s.bind(("127.0.0.1", 0))  # bound, never listening: connections are refused
        port, server = s.getsockname()[1], s
    else:
        reply = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" if kind == "http" else None
        server = _FakeServer(reply)
        port = server.port
    t0 = time.monotonic()
    try:
        with pytest.raises(ValueError, match=word):
            fill.fill_cache(IDS, profile=TINY, results=tmp_path / "r", progress=False,
                            scheduler=f"tcp://127.0.0.1:{port}")
    finally:
        server.close()
    assert time.monotonic() - t0 < _dask_probe.PROBE_SECONDS + 3
    assert not (tmp_path / "r").exists()


def test_a_stop_request_ends_the_wait_for_a_silent_scheduler(tmp_path):
    server = _FakeServer()
    stop = threading.Event()
    threading.Timer(0.5, stop.set).start()
    t0 = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            fill.fill_cache(IDS, profile=TINY, results=tmp_path / "r", progress=False,
                            scheduler=f"tcp://127.0.0.1:{server.port}", stop=stop)
    finally:
        server.close()
    assert time.monotonic() - t0 < 2.0


def test_a_real_scheduler_address_passes_the_probe(client):
    _dask_probe._probe_scheduler(client.scheduler.address)  # no error, within the probe's time


def _where_it_ran(results):
    """An analysis that reads nothing: says which process ran it."""
    (results / "pid.txt").write_text(str(os.getpid()))


def test_a_cluster_fill_runs_its_analyses_on_local_workers(tmp_path, client, monkeypatch):
    """With a scheduler the analyses share the fill's pool: each is a task of the local
    workers (they read and write the result folder, which the cluster's workers need not
    see), put as soon as the entries it reads are stored by this process, while the cluster
    computes the rest -- not in this process after the cluster, one after the other."""
    from test_fill import _read_exp5

    from uavwind.study import registry

    monkeypatch.setattr(registry, "REGISTRY", dict(registry.REGISTRY))
    registry.computes("reads_exp5", reads=("exp5",))(_read_exp5)
    registry.computes("where", long=True)(_where_it_ran)
    res = tmp_path / "r"
    res.mkdir()
    done = fill.fill_cache(["exp6", "reads_exp5", "where"], profile=TINY, results=res,
                           n_jobs=2, progress=False, scheduler=client, readings="inferred")
    assert (res / "exp5_seen.txt").read_text().startswith(f"custom {ex.DEFAULT_SEED} ")
    assert int((res / "pid.txt").read_text()) != os.getpid()  # a local worker ran it
    kinds = [(t["experiment"], t["search"]) for t in done["times"]]
    assert ("reads_exp5", "analysis") in kinds and ("where", "analysis") in kinds
    assert done["computed"] == len(done["times"]) - 2 > 0
