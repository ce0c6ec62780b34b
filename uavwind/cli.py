"""Command line: run what the registry lists into the result cache.

    python -m uavwind list          (every id: the experiments, then the analyses)
    python -m uavwind run exp1 exp2 --profile paper --jobs -1
    python -m uavwind run exp13 claims explore_grid --profile quick
    python -m uavwind run all --reading all --profile paper --scheduler tcp://host:8786
    python -m uavwind run all --profile paper --reading all --no-tables   (make results)

`run` first computes every missing result of the chosen ids in one pool of workers, longest
task first -- an experiment's entries under the chosen readings, an analysis (a page's
summary, Exp 11's filter table, the explorer's grid, Exp 13 on Neural-Fly's flights) once
what it reads is stored -- then prints each experiment's table (and what an analysis shows)
from the cache. ``run all --reading all`` is ``fill_cache("all")``. ``--times FILE`` keeps
the CPU seconds of every entry it computed (JSON), for a profile of where a build's time goes.
"""

from __future__ import annotations

import argparse
import faulthandler
import json
import os
import signal
import sys
import threading
import time
import warnings
from collections.abc import Sequence

from .analysis.tables import summary_table
from .core.io import check_target
from .core.parallel import check_jobs, cores, stop_workers
from .core.store import atomic_write
from .method.clustering import ENGINES
from .study.cache import check_writable, results_dir
from .study.fill import fill_cache, time_by_experiment
from .study.profiles import DEFAULT_SEED, PROFILES
from .study.readings import DEFAULT_READING, READINGS
from .study.registry import ANALYSES, REGISTRY, Analysis, get_experiment
from .study.runner import run_experiment


_CORES = cores()


def _jobs(text):
    """--jobs: an integer in [1, cores] or -1 (:func:`~uavwind.core.parallel.check_jobs`);
    more than the cores is capped with a warning."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if n < -1:
        raise argparse.ArgumentTypeError(f"must be -1 (all cores) or in [1, {_CORES}], got {n}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            n = check_jobs(n, "--jobs")
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    return n


def _seed(text):
    """--seed: an integer >= 0."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {n}")
    return n


def main(argv: Sequence[str] | None = None, program: bool = False) -> int:
    """The command line on ``argv`` (default ``sys.argv[1:]``); its exit code. ``program``:
    this process is the command (``python -m uavwind``), so once a run is over, its record
    written, SIGINT and SIGTERM are ignored while the interpreter shuts down (a Ctrl-C
    pressed again then has nothing left to stop; with the default handlers back it would be
    a traceback or a death by signal instead of the run's exit code). Called as a function,
    the handlers it replaced are restored."""
    parser = argparse.ArgumentParser(prog="python -m uavwind", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("list", help="list everything the book computes: the experiments and the "
                   "analyses, by id")
    run = sub.add_parser("run", help="run ids of the list (cached; resumes where it stopped)")
    run.add_argument("experiments", nargs="+",
                     help=f"ids ({', '.join(REGISTRY)}) or 'all'")
    run.add_argument("--profile", default="quick", choices=sorted(PROFILES))
    run.add_argument("--jobs", type=_jobs, default=-1,
                     help=f"worker processes, 1-{_CORES} (-1 = all cores)")
    run.add_argument("--seed", type=_seed, default=None, help="root seed, an integer >= 0")
    run.add_argument("--engine", default=None, choices=sorted(ENGINES),
                     help="clustering engine (default: fast)")
    run.add_argument("--reading", default=None, choices=sorted(READINGS) + ["all"],
                     help="reading of the paper (default: inferred; all: each experiment "
                          "under the readings its pages show)")
    run.add_argument("--no-progress", action="store_true")
    run.add_argument("--no-tables", action="store_true",
                     help="only fill the result cache; print no summary tables")
    run.add_argument("--times", default=None, metavar="FILE",
                     help="write the CPU seconds of every computed cache entry to FILE (JSON)")
    run.add_argument("--scheduler", default=None, metavar="ADDRESS",
                     help="fill the cache on a dask.distributed cluster (e.g. "
                          "tcp://host:8786): its workers compute, this process writes "
                          "every entry (--jobs then applies to the analyses and tables)")
    args = parser.parse_args(argv)

    if args.command == "list":
        _list()
        return 0
    if "all" in args.experiments and len(args.experiments) > 1:
        parser.error(f"'all' means every experiment and analysis: give it alone, not with "
                     f"{', '.join(e for e in args.experiments if e != 'all')}")
    everything = args.experiments == ["all"]
    ids = list(REGISTRY) if everything else list(dict.fromkeys(args.experiments))
    try:
        for i in ids:  # validate every name before any work starts
            get_experiment(i)
    except (ValueError, TypeError) as exc:
        parser.error(str(exc))
    for i in ([] if everything else ids):
        try:  # an analysis asked for by name without its data: fails before any work
            item = REGISTRY[i]
            if isinstance(item, Analysis):
                item.check_data()
        except ValueError as exc:
            print(f"python -m uavwind run {i}: error: {exc}", file=sys.stderr)
            return 2
    times = None
    if args.times is not None:
        try:
            times = check_target(args.times, "--times")
        except ValueError as exc:
            parser.error(str(exc))
        if not times.parent.is_dir():
            parser.error(f"--times must name a file in an existing, writable folder, got "
                         f"{args.times!r}")
        try:  # a test write, not os.access: a full disk or a read-only mount fails it
            check_writable(times.parent)
        except ValueError:
            parser.error(f"--times must name a file in an existing, writable folder, got "
                         f"{args.times!r} (a test write there failed)")
    record = _TimesRecord(times, args)
    stop = threading.Event()

    def stop_now(signum):
        """A second signal: the record of what finished, one line, and out at once (the
        entry under way is dropped; the workers with it)."""
        if not record.written:
            try:
                record.write(complete=False, error="interrupted")
            except Exception:  # pragma: no cover - its own warning met a busy stderr
                pass
        _say(f"{signal.Signals(signum).name} again: stopped now; finished entries are kept, "
             f"a rerun resumes")
        if "joblib" in sys.modules:  # a pool of workers may be running: they go too
            stop_workers()
        _exit(130)

    # for the whole run, fill, Exp 13 and tables: a signal asks it to stop, never raises
    previous = _on_signals(stop, stop_now) if _in_main_thread() else {}
    code = 1
    try:
        code = _run(args, ids, everything, record, stop)
        if record.failed and code == 0:  # the run's record was asked for and is lost
            code = 1
        return code
    finally:
        # a program exiting ignores them: CPython resets a Python handler to the default
        # one as it finalises, where a late signal would kill it, but it leaves SIG_IGN
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_IGN if program else handler)
        if program and code != 0:  # stopped or failed: its workers were killed
            _exit_within(code)


def _list() -> None:
    """``list``: every id of the registry, one line each -- the experiments (their paper
    table and cases), then the analyses (what they read) -- with the page that shows it."""
    print(f"{'id':30s} {'kind':10s} {'title':38s} {'what':34s} page")
    for item in REGISTRY.values():
        if isinstance(item, Analysis):
            what = ("reads " + ", ".join(item.reads)) if item.reads else "reads no experiment"
            if len(what) > 34:
                what = f"reads {len(item.reads)} experiments"
            if item.data:
                what = f"needs ${item.data}"
        else:
            what = f"{len(item.cases())} cases: {item.paper_table}"
        print(f"{item.id:30s} {item.kind:10s} {item.title[:38]:38s} {what[:34]:34s} "
              f"{item.notebook}")


def _run(args, ids, everything, record, stop) -> int:
    """``run``, its arguments checked: the fill of ``ids`` (``everything``: every id of the
    registry, ``fill_cache("all")`` under ``--reading all``), then the tables of the
    experiments among them and what the analyses show; ``record`` keeps the ``--times``
    record, ``stop`` is set by a signal (checked between entries, after the fill, and between
    tables: each one ends the run with exit 130)."""
    kw = {} if args.seed is None else {"seed": args.seed}
    readings = list(READINGS) if args.reading == "all" else [args.reading or DEFAULT_READING]
    try:
        done = fill_cache("all" if everything else ids, profile=args.profile, n_jobs=args.jobs,
                          engine=args.engine,
                          readings="all" if args.reading == "all" else readings[0],
                          progress=not args.no_progress, times=record.records, stop=stop,
                          scheduler=args.scheduler, **kw)
    except KeyboardInterrupt:
        print("interrupted; finished chunks are kept, a rerun resumes", file=sys.stderr)
        record.write(complete=False, error="interrupted")
        return 130
    except ValueError as exc:  # e.g. a results folder that cannot be written
        print(f"python -m uavwind run: error: {exc}", file=sys.stderr)
        record.write(complete=False, error=str(exc))
        return 2
    except Exception as exc:  # a full disk, a killed worker: say so, keep the record
        print(f"python -m uavwind run: error: {type(exc).__name__}: {exc}; finished chunks are "
              f"kept, a rerun resumes", file=sys.stderr)
        record.write(complete=False, error=f"{type(exc).__name__}: {exc}")
        return 1
    record.write(complete=True)
    n_analyses = sum(t.get("search") == "analysis" for t in done["times"])
    print(f"results: {done['entries']} entries, {done['cached']} from the cache, "
          f"{done['computed']} computed ({done['rows_computed']} rows: loops, CEM samples or "
          f"closed-loop reports), {n_analyses} analyses computed or read, in "
          f"{time.perf_counter() - record.t0:.1f} s")
    if done["times"]:
        by_exp = time_by_experiment(done["times"])
        print("CPU seconds of the computed entries, by experiment and reading:")
        print(by_exp.round({"cpu_seconds": 1, "share": 1}).to_string(), "\n")
    for i in done.get("skipped", ()):
        a = ANALYSES[i]
        print(f"{i}: ${a.data} is not set; {a.title or i} is left out (set it to run it)",
              file=sys.stderr)
    skipped = set(done.get("skipped", ()))
    for i in ([] if args.no_tables else ids):
        item = REGISTRY[i]
        if stop.is_set():
            break
        if isinstance(item, Analysis):
            if item.show is None or i in skipped:
                continue
            try:
                print(item.show(args.profile, args.seed if args.seed is not None
                                else DEFAULT_SEED, results_dir(None)), "\n")
            except (ValueError, TypeError) as exc:
                print(f"python -m uavwind run {i}: error: {exc}", file=sys.stderr)
                return 2
            continue
        for reading in readings:
            if stop.is_set():
                break
            if args.reading == "all" and reading not in item.readings:
                continue  # the book runs it under its own readings only
            df = run_experiment(i, profile=args.profile, n_jobs=args.jobs, engine=args.engine,
                                progress=False, reading=reading, **kw)
            print(f"{i} ({df.attrs['reading']} reading): {len(df)} rows")
            print(summary_table(df).round(2).to_string(), "\n")
    if stop.is_set():  # after the fill: what it computed is complete, and recorded
        print("interrupted; finished chunks are kept, a rerun resumes", file=sys.stderr)
        return 130
    return 0


def _on_signals(stop: threading.Event, now) -> dict:
    """SIGINT and SIGTERM ask the run to stop: worker processes are stopped at once (the
    entries they were computing are dropped, the finished ones are on disk), an entry
    computed in this process finishes first (the fill checks between entries, never inside
    a kernel); a second signal calls ``now(signum)``, which ends the process at once.
    Returns the handlers they replace.

    The handlers never raise. An exception raised in a handler surfaces wherever the main
    thread happens to be: inside a threaded numba kernel it becomes ``SystemError:
    CPUDispatcher(...) returned a result with an exception set``; inside the writing of the
    ``--times`` record it loses the record. For the same reason the notice goes straight to
    the file descriptor (:func:`_say`), not through ``print``."""
    def request(signum, frame):
        if stop.is_set():
            now(signum)
            return
        stop.set()
        _say(f"\n{signal.Signals(signum).name}: stopping; finished entries are kept, workers' "
             f"entries under way are dropped, one computed in this process finishes first "
             f"(again to stop now)")
    return {sig: signal.signal(sig, request) for sig in (signal.SIGINT, signal.SIGTERM)}


def _exit(code: int) -> None:
    """End the process now with ``code``, what is printed flushed first (no interpreter
    shutdown: a signal handler calls it to stop at once)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, RuntimeError, ValueError):  # closed, or inside a write
            pass
    os._exit(code)


#: [s] how long the interpreter may take to shut down once a run stopped early (interrupted,
#: or failed) with its record written and every finished entry on disk. Shutting down joins
#: the worker pool's manager thread (joblib's loky), and once in a fresh-clone `make test`
#: beside a book build that join did not return within 60 s of the workers being killed.
EXIT_GRACE = 5.0


def _exit_within(code: int, seconds: float = EXIT_GRACE) -> None:
    """Let the interpreter shut down the usual way, but end the process with ``code`` if it
    is still shutting down ``seconds`` later, saying so on stderr with where each thread
    waits (a daemon timer: it dies with the process when the shutdown finishes first).
    Nothing is lost: it is armed only after the run's record is written, and entries are
    written whole (a temporary file renamed) or not at all."""
    def expire():
        _say(f"python -m uavwind: still shutting down {seconds:g} s after the run stopped (a "
             f"worker pool that does not stop); exiting now, with exit code {code}. Where "
             f"each thread waits:")
        try:
            faulthandler.dump_traceback(file=sys.stderr, all_threads=True)
        except (OSError, RuntimeError, ValueError):  # pragma: no cover - stderr gone
            pass
        if "joblib" in sys.modules:  # no worker outlives the run
            stop_workers()
        _exit(code)

    timer = threading.Timer(seconds, expire)
    timer.daemon = True
    timer.start()


def _say(text: str) -> None:
    """``text`` and a newline on stderr, written straight to its file descriptor: a signal
    handler may run while the main thread is inside a write to ``sys.stderr`` (the progress
    bar), where ``print`` would raise "reentrant call" into the interrupted code."""
    try:
        os.write(2, (text + "\n").encode())
    except OSError:  # stderr closed (the terminal gone): nothing to tell
        pass


class _TimesRecord:
    """The ``--times`` file of one run (``path``, or ``None`` for none): the records of the
    entries computed, appended by the fill as each finishes, written once the fill is over
    (``complete``) or when the run stops early; ``written`` says whether it has been."""

    def __init__(self, path, args):
        self.path, self.args = path, args
        self.t0 = time.perf_counter()
        self.records = []
        self.written = False
        self.failed = False

    def write(self, complete: bool, error: str | None = None) -> None:
        if self.path is not None:
            self.failed = not _write_times(self.path, self.args, self.t0, self.records,
                                           complete, error)
        self.written = True


def _write_times(path, args, t0, records, complete, error=None):
    """The ``--times`` file, written atomically: the run's wall seconds and one record per
    computed entry (``complete`` is false after an interrupt). Returns whether it was
    written (else an error line on stderr; the run then does not exit 0)."""
    text = json.dumps({"profile": args.profile, "jobs": args.jobs, "complete": complete,
                       "wall_seconds": time.perf_counter() - t0, "entries": records,
                       **({"error": error} if error else {})}, indent=1)
    try:
        atomic_write(path, text, name="--times")
    except (OSError, ValueError) as exc:
        print(f"python -m uavwind run: error: --times {path} not written ({exc})",
              file=sys.stderr)
        return False
    return True


def _in_main_thread():
    return threading.current_thread() is threading.main_thread()


if __name__ == "__main__":
    sys.exit(main())
