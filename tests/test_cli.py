"""The command line: one-line usage errors, --jobs, --times."""
import json
import os
import time

import pytest

from uavwind import study as ex
from uavwind.cli import main
from uavwind.study import fill

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


@pytest.mark.parametrize("argv, option", [
    (["run", "exp1", "--jobs", "0"], "--jobs"), (["run", "exp1", "--seed", "-5"], "--seed"),
    (["run", "exp1", "--engine", "bogus"], "--engine"), (["run", "exp99"], "exp99"),
])
def test_cli_usage_errors_are_one_line(argv, option, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error" in err and option in err and "Traceback" not in err


def test_cli_caps_jobs_and_reports_an_unwritable_folder(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    monkeypatch.setenv("UAVWIND_RESULTS", str(blocker))
    assert main(["run", "exp5", "--jobs", "999", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "using" in err and "cannot be written" in err


def test_cli_times_file_records_every_computed_entry(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(ex.PROFILES, "tiny", ex.get_profile({**TINY, "name": "tiny"}))
    monkeypatch.setenv("UAVWIND_RESULTS", str(tmp_path / "r"))
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    rec = json.loads(out.read_text())
    assert rec["profile"] == "tiny"
    assert len(rec["entries"]) == len(fill.needed_entries(["exp5"], "tiny", "inferred")) > 0
    assert {e["experiment"] for e in rec["entries"]} == {"exp5"}
    assert "by experiment and reading" in capsys.readouterr().out
    # a second run computes nothing and says so in the file
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    assert json.loads(out.read_text())["entries"] == []
    with pytest.raises(SystemExit) as stop:
        main(["run", "exp5", "--profile", "tiny", "--times", str(tmp_path / "no" / "t.json")])
    assert stop.value.code == 2 and "--times" in capsys.readouterr().err


def test_cli_keeps_the_times_of_finished_entries_when_interrupted(tmp_path, monkeypatch):
    import uavwind.cli as cli

    def interrupted(*args, times=None, **kwargs):
        times.append({"experiment": "exp5", "reading": "inferred", "rows": 2,
                      "cpu_seconds": 1.5})
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "fill_cache", interrupted)
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--no-progress", "--times", str(out)]) == 130
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["entries"][0]["cpu_seconds"] == 1.5
    assert [p.name for p in tmp_path.iterdir()] == ["times.json"]  # no temporary file left


@pytest.mark.parametrize("experiment", ["exp2", pytest.param("exp10", marks=pytest.mark.slow),
                                        pytest.param("exp12", marks=pytest.mark.slow)])
def test_a_signal_during_a_serial_run_stops_between_entries_and_keeps_the_record(tmp_path,
                                                                                  experiment):
    """SIGTERM while a kernel runs: the entry under way finishes, is stored and recorded,
    then the run stops (no SystemError from inside numba), with complete: false. For each
    kind of kernel a fill runs: the point mass and the soft-DTW engine (Exp 2), the
    multirotor (Exp 10), the closed loop's episodes (Exp 12)."""
    import signal
    import subprocess
    import sys

    env = {**os.environ, "UAVWIND_RESULTS": str(tmp_path / "r")}
    out = tmp_path / "t.json"
    proc = subprocess.Popen([sys.executable, "-m", "uavwind", "run", experiment, "--profile",
                             "quick", "--jobs", "1", "--no-tables", "--no-progress",
                             "--times", str(out)], env=env, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while time.time() < deadline and not list((tmp_path / "r").rglob("*.lock")):
        time.sleep(0.2)  # the first entry is being computed
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    assert "SystemError" not in err and "Traceback" not in err
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["error"] == "interrupted"
    assert len(rec["entries"]) >= 1  # the entry under way finished and was kept
    stored = list((tmp_path / "r").rglob("*.parquet"))
    assert len(stored) == len(rec["entries"])


def test_a_failing_fill_writes_its_record_and_one_error_line(tmp_path, monkeypatch, capsys):
    import uavwind.cli as cli

    def disk_full(*args, times=None, **kwargs):
        times.append({"experiment": "exp5", "reading": "inferred", "rows": 2,
                      "cpu_seconds": 1.0})
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(cli, "fill_cache", disk_full)
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--no-progress", "--times", str(out)]) == 1
    err = capsys.readouterr().err
    assert "No space left" in err and "Traceback" not in err
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and "No space" in rec["error"] and len(rec["entries"]) == 1


def test_times_refuses_a_pipe_or_a_device(tmp_path, capsys):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for target in (fifo, "/dev/null", tmp_path):
        with pytest.raises(SystemExit) as stop:
            main(["run", "exp5", "--times", str(target)])
        assert stop.value.code == 2 and "--times" in capsys.readouterr().err
    assert fifo.is_fifo()  # never replaced by a regular file


def test_all_with_other_ids_is_a_clear_error(capsys):
    with pytest.raises(SystemExit):
        main(["run", "exp1", "all"])
    assert "'all' means every experiment" in capsys.readouterr().err


def _group_kill(proc):
    """End the subprocess this test started and its workers (its own session)."""
    import signal

    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


@pytest.mark.slow
def test_a_signal_stops_a_run_with_two_workers_within_seconds(tmp_path):
    """SIGTERM to the main process of `run exp12 exp6 --jobs 2` on a cold numba cache, as
    on a fresh checkout: one worker compiles the clustering kernels (tens of seconds, which
    nothing can interrupt), the other flies an entry that takes minutes. It stops within
    seconds, exit 130, with its workers; every recorded entry is on disk. (When the fill's
    own process compiled, a SIGTERM waited for the compile: 22-24 s.)"""
    import signal
    import subprocess
    import sys

    env = {**os.environ, "UAVWIND_RESULTS": str(tmp_path / "r"),
           "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    out = tmp_path / "t.json"
    proc = subprocess.Popen([sys.executable, "-m", "uavwind", "run", "exp12", "exp6",
                             "--profile", "paper", "--jobs", "2", "--no-tables",
                             "--no-progress", "--times", str(out)], env=env,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not list((tmp_path / "r").rglob("*.lock")):
            time.sleep(0.2)  # a worker is flying an entry, the other compiling
        time.sleep(1.0)
        proc.send_signal(signal.SIGTERM)
        t0 = time.monotonic()
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - t0
    finally:
        _group_kill(proc)
    assert proc.returncode == 130, err
    assert took < 10, f"stopped {took:.1f} s after SIGTERM"
    assert "Traceback" not in err
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["error"] == "interrupted"
    stored = {p.name for p in (tmp_path / "r").rglob("*.parquet")}
    assert len(stored) >= len(rec["entries"])  # nothing recorded is missing


@pytest.mark.parametrize("hangs", [True, False])
def test_a_stopped_run_ends_within_its_grace_even_if_the_shutdown_hangs(tmp_path, hangs):
    """Once a run stopped early, a shutdown that waits forever (as a worker pool's manager
    thread once did, beside a book build) ends after the grace with the run's exit code,
    saying so and where each thread waited; a shutdown that does not wait ends at once,
    silently."""
    import subprocess
    import sys

    script = ("import sys, threading, time\n"
              "from uavwind import cli\n"
              f"if {hangs}:\n"
              "    threading._register_atexit(lambda: time.sleep(600))\n"
              "cli._exit_within(130, 1.0)\n"
              "sys.exit(130)\n")
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-c", script], stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        _group_kill(proc)
    took = time.monotonic() - t0
    assert proc.returncode == 130, err
    if hangs:
        assert "still shutting down 1 s after the run stopped" in err
        assert "Thread 0x" in err and "Traceback" not in err
        assert 1.0 <= took < 30
    else:
        assert err == ""


@pytest.mark.slow
def test_a_silent_scheduler_is_a_clear_error_within_seconds(tmp_path):
    import socket
    import subprocess
    import sys

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(4)  # accepts (the kernel's backlog) and never replies
    port = server.getsockname()[1]
    env = {**os.environ, "UAVWIND_RESULTS": str(tmp_path / "r")}
    t0 = time.monotonic()
    proc = subprocess.Popen([sys.executable, "-m", "uavwind", "run", "exp12", "--no-tables",
                             "--no-progress", "--scheduler", f"tcp://127.0.0.1:{port}"],
                            env=env, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _, err = proc.communicate(timeout=60)
    finally:
        _group_kill(proc)
        server.close()
    assert proc.returncode == 2 and "no dask scheduler answered" in err, err
    assert err.count("\n") == 1 and time.monotonic() - t0 < 30


def test_run_exp13_asked_for_without_neural_fly_fails_naming_the_variable(monkeypatch, capsys):
    """Asked for explicitly, Exp 13 without its flights is an error, not a silent exit 0
    (issue 45); `run all` skips it, saying so."""
    monkeypatch.delenv("UAVWIND_NEURALFLY", raising=False)
    code = main(["run", "exp13", "--no-progress"])
    err = capsys.readouterr().err
    assert code != 0 and "UAVWIND_NEURALFLY" in err and "exp13" in err


@pytest.mark.parametrize("reading", [[], ["--reading", "all"]])
def test_run_all_skips_exp13_without_its_flights_saying_so(reading, monkeypatch, capsys):
    """`run all` (and the book's `run all --reading all`) without $UAVWIND_NEURALFLY fills the
    other experiments and skips Exp 13 with a message, exit 0; asked for by name it fails."""
    import uavwind.cli as cli

    asked = []

    def fill_(ids, *args, readings="all", **kwargs):
        asked.append(ids)
        _, analyses, skipped = fill._plan(ids, "quick", readings, 0, None, None)
        return {"entries": 0, "cached": 0, "computed": 0, "rows_computed": 0, "times": [],
                "skipped": skipped}
    monkeypatch.setattr(cli, "fill_cache", fill_)
    monkeypatch.delenv("UAVWIND_NEURALFLY", raising=False)
    assert main(["run", "all", "--no-tables", "--no-progress", *reading]) == 0
    err = capsys.readouterr().err
    assert ("exp13: $UAVWIND_NEURALFLY is not set; Real flights (Neural-Fly) is left out"
            in err)
    assert asked == ["all"]
    assert main(["run", "exp13", "exp5", "--no-progress"]) == 2  # asked for: an error, first
    assert len(asked) == 1 and "UAVWIND_NEURALFLY" in capsys.readouterr().err


def test_signals_again_while_a_serial_run_stops_end_it_at_once_with_the_record(tmp_path):
    """SIGTERM while `run exp2 --jobs 1` computes an entry in its own process, then SIGINT
    and SIGTERM again every 0.1 s until it ends (a user pressing Ctrl-C again, or `make`
    and `timeout` both passing a signal on): it ends with exit 130, one line per signal and
    no traceback, and its --times record lists the entries that finished, each stored.
    (Before: the handler raised KeyboardInterrupt wherever the process was -- inside a
    threaded numba kernel that is `SystemError: CPUDispatcher(...) returned a result with an
    exception set`, inside the writing of the record a traceback and no record -- and once
    the fill had returned, a signal met the default handlers: killed, or a traceback.)"""
    import signal
    import subprocess
    import sys

    env = {**os.environ, "UAVWIND_RESULTS": str(tmp_path / "r")}
    out = tmp_path / "t.json"
    proc = subprocess.Popen([sys.executable, "-m", "uavwind", "run", "exp2", "--profile",
                             "quick", "--jobs", "1", "--times", str(out)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        # the first entry is stored, the next one is being computed (on a loaded machine the
        # first entry took over 120 s: the wait is long, and ends as soon as it is stored)
        deadline = time.time() + 600
        while time.time() < deadline and not list((tmp_path / "r").rglob("*.parquet")):
            time.sleep(0.05)
        assert list((tmp_path / "r").rglob("*.parquet")), "no entry was stored within 600 s"
        sigs = [signal.SIGTERM, signal.SIGINT]
        for k in range(600):
            if proc.poll() is not None:
                break
            proc.send_signal(sigs[k % 2])
            time.sleep(0.1)
        _, err = proc.communicate(timeout=120)
    finally:
        _group_kill(proc)
    assert proc.returncode == 130, err[-3000:]
    assert "Traceback" not in err and "SystemError" not in err, err[-3000:]
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["error"] == "interrupted"
    stored = {p.name for p in (tmp_path / "r").rglob("*.parquet")}
    assert len(rec["entries"]) >= 1 and len(stored) >= len(rec["entries"])


def test_a_times_record_that_cannot_be_written_is_an_error_not_exit_0(tmp_path, monkeypatch,
                                                                     capsys):
    """Issue 68: `--times` to a full disk lost the record with exit 0 (the folder was checked
    with os.access, not a test write)."""
    import errno

    import uavwind.cli as cli

    def fill(ids, *args, times=None, **kwargs):
        times.append({"experiment": "exp5", "reading": "inferred", "rows": 2,
                      "cpu_seconds": 1.5})
        return {"entries": 1, "cached": 0, "computed": 1, "rows_computed": 2, "times": times}

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(cli, "fill_cache", fill)
    monkeypatch.setattr(cli, "atomic_write", full)
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--no-progress", "--no-tables", "--times", str(out)]) == 1
    assert "--times" in capsys.readouterr().err and not out.exists()
    monkeypatch.setattr(cli, "check_writable", lambda folder: (_ for _ in ()).throw(
        ValueError("results folder cannot be written (No space left on device)")))
    with pytest.raises(SystemExit) as stop:  # refused before any work
        main(["run", "exp5", "--no-progress", "--times", str(out)])
    assert stop.value.code == 2 and "test write" in capsys.readouterr().err


def test_run_with_a_missing_flight_folder_refuses_before_computing_anything(
        tmp_path, monkeypatch, capsys):
    """Issue 68: `run example exp13` with $UAVWIND_NEURALFLY naming a missing folder computed
    `example` first."""
    import uavwind.cli as cli

    monkeypatch.setattr(cli, "fill_cache", lambda *a, **k: pytest.fail("computed first"))
    monkeypatch.setenv("UAVWIND_NEURALFLY", str(tmp_path / "missing"))
    assert main(["run", "example", "exp13", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "UAVWIND_NEURALFLY" in err and "not an existing folder" in err
