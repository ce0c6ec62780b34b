"""Command line: run experiments into the result cache.

    python -m uavwind list
    python -m uavwind run exp1 exp2 --profile paper --jobs -1
    python -m uavwind run all --reading all --profile paper --scheduler tcp://host:8786
    python -m uavwind run all --profile quick
    python -m uavwind run all --profile paper --reading all --no-tables   (what make book runs)
    python -m uavwind analyses --profile paper [--folder DIR]   (the analyses pages read:
        Exp 11's filter table; Exp 13 when Neural-Fly's flights are there)

`run` first computes every missing result of the chosen experiments and readings in one
pool of workers, longest task first, then prints each experiment's table from the cache.
``--times FILE`` keeps the CPU seconds of every entry it computed (JSON), for a profile of
where a build's time goes.
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
from functools import partial

from .analysis.exp13 import run_exp13
from .analysis.figure8 import calibration_of, ranking_verdict, sim_rows, validation_table
from .analysis.filters import filter_table
from .analysis.page_analyses import page_analyses
from .analysis.real_flights import channel_table, real_flight_rows
from .analysis.tables import summary_table
from .core.io import check_target
from .core.parallel import check_jobs, cores, stop_workers
from .core.store import atomic_write
from .data.neuralfly import ENV_VAR as NEURALFLY_ENV, neuralfly_folder
from .method.clustering import ENGINES
from .report.explore import fill_grid
from .study.cache import check_writable
from .study.fill import Analysis, fill_cache, time_by_experiment
from .study.profiles import PROFILES
from .study.readings import READINGS
from .study.registry import EXPERIMENTS, MEASURED, get_experiment
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
    sub.add_parser("list", help="list the experiments")
    real = sub.add_parser("analyses", help="the analyses the pages read, into the result "
                          "cache: Exp 11's filter table, Exp 13 (Neural-Fly's real flights and "
                          "their simulated twins)")
    real.add_argument("--folder", default=None, help="the Neural-Fly flights (default "
                      "$UAVWIND_NEURALFLY; without either, Exp 13 is skipped)")
    real.add_argument("--profile", default="quick", choices=sorted(PROFILES))
    real.add_argument("--jobs", type=_jobs, default=-1)
    run = sub.add_parser("run", help="run experiments (cached; resumes where it stopped)")
    run.add_argument("experiments", nargs="+",
                     help=f"ids ({', '.join([*EXPERIMENTS, *MEASURED])}) or 'all'")
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
                          "every entry (--jobs then applies to the tables only)")
    args = parser.parse_args(argv)

    if args.command == "analyses":
        return _analyses(args)
    if args.command == "list":
        for e in EXPERIMENTS.values():
            print(f"{e.id:14s} {e.title:36s} {e.paper_table:32s} {len(e.cases()):3d} cases  "
                  f"{e.notebook}")
        for m in MEASURED.values():
            print(f"{m.id:14s} {m.title:36s} {m.paper_table:32s} {'':3s}       {m.notebook} "
                  f"(needs ${m.data})")
        return 0
    if "all" in args.experiments and len(args.experiments) > 1:
        parser.error(f"'all' means every experiment: give it alone, not with "
                     f"{', '.join(e for e in args.experiments if e != 'all')}")
    everything = args.experiments == ["all"]
    ids = list(EXPERIMENTS) if everything else [i for i in args.experiments if i not in MEASURED]
    # the experiments on measured flights (Exp 13) run by name after the fill: asked for by
    # name they need their flights; `run all` runs them when the flights are there
    measured = list(MEASURED) if everything else [i for i in args.experiments if i in MEASURED]
    try:
        for i in ids:  # validate every name before any work starts
            get_experiment(i)
    except (ValueError, TypeError) as exc:
        parser.error(str(exc))
    for i in ([] if everything else measured):
        try:  # asked for by name without its flights: fails before any work
            MEASURED[i].check_data()
        except ValueError as exc:
            print(f"python -m uavwind run {i}: error: {exc} (or fill its analysis with "
                  f"`python -m uavwind analyses --folder FOLDER`)", file=sys.stderr)
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
        code = _run(args, ids, measured, everything, record, stop)
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


def _run(args, ids, measured, everything, record, stop) -> int:
    """``run``, its arguments checked: the fill of ``ids`` (the book's whole fill when
    ``everything`` under both readings, with the pages' analyses), the experiments on
    measured flights of ``measured``, then the tables; ``record`` keeps the ``--times``
    record, ``stop`` is set by a signal (checked between entries, after the fill, between
    experiments and between tables: each one ends the run with exit 130)."""
    kw = {} if args.seed is None else {"seed": args.seed}
    readings = list(READINGS) if args.reading == "all" else [args.reading]
    # the book's whole fill (`make results`: every experiment under both readings) computes
    # what the pages read beside the experiments, in the same pool: their analyses, Exp 11's
    # filter table, the explorer's grid and Exp 13's real flights (when they are there)
    book = everything and args.reading == "all" and args.seed is None
    try:
        analyses = _book_analyses(None) if book else []
        done = fill_cache(ids, profile=args.profile, n_jobs=args.jobs, engine=args.engine,
                          readings="all" if args.reading == "all" else args.reading,
                          progress=not args.no_progress, times=record.records, stop=stop,
                          scheduler=args.scheduler, analyses=analyses, **kw)
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
    print(f"results: {done['entries']} entries, {done['cached']} from the cache, "
          f"{done['computed']} computed ({done['rows_computed']} rows: loops, CEM samples or "
          f"closed-loop reports) in "
          f"{time.perf_counter() - record.t0:.1f} s")
    if done["times"]:
        by_exp = time_by_experiment(done["times"])
        print("CPU seconds of the computed entries, by experiment and reading:")
        print(by_exp.round({"cpu_seconds": 1, "share": 1}).to_string(), "\n")
    if book and not os.environ.get(NEURALFLY_ENV):
        print(f"exp13: no Neural-Fly folder (${NEURALFLY_ENV}); Experiment 13 is skipped",
              file=sys.stderr)
    if not book:  # the book's fill ran Exp 13 among its analyses
        for i in measured:  # Exp 13, the one experiment on measured flights
            if stop.is_set():
                break
            if _exp13(args):
                return 2
    for reading in readings:
        for i in ([] if args.no_tables else ids):
            if stop.is_set():
                break
            if args.reading == "all" and reading not in get_experiment(i).readings:
                continue  # the book runs it under its own readings only
            df = run_experiment(i, profile=args.profile, n_jobs=args.jobs, engine=args.engine,
                                progress=False, reading=reading, **kw)
            print(f"{i} ({df.attrs['reading']} reading): {len(df)} rows")
            print(summary_table(df).round(2).to_string(), "\n")
    if stop.is_set():  # after the fill: what it computed is complete, and recorded
        print("interrupted; finished chunks are kept, a rerun resumes", file=sys.stderr)
        return 130
    return 0


def _exp13(args) -> int:
    """``run exp13`` (and ``run all``): Experiment 13 through the registry
    (:func:`~uavwind.study.runner.run_experiment`: its rows into the cache, the flights from
    ``$UAVWIND_NEURALFLY``), then its channel table and its simulated twin's validation.
    Without the flights it is skipped, saying so (asked for by name, :func:`main` refused it
    first)."""
    if not os.environ.get(NEURALFLY_ENV):
        print(f"exp13: no Neural-Fly folder (${NEURALFLY_ENV}); Experiment 13 is skipped",
              file=sys.stderr)
        return 0
    try:
        real = run_experiment("exp13", profile=args.profile, n_jobs=args.jobs)
        sim = sim_rows(real, profile=args.profile)  # computed beside it: read from the cache
    except (ValueError, TypeError) as exc:
        print(f"python -m uavwind run exp13: error: {exc}", file=sys.stderr)
        return 2
    if args.no_tables:
        return 0
    real_ch, sim_ch = channel_table(real), channel_table(sim)
    print(f"exp13 ({args.profile} profile): real flights, mean score over controllers "
          f"(95% CI over controllers)")
    print(real_ch.round(2).to_string(), "\n")
    cal = calibration_of(sim)
    print(f"simulated twin (drag x {cal.drag_scale:.3f}, lift x {cal.lift_scale:.3f}, gusts "
          f"W20 = {cal.gust_scale:.3f} x the mean speed; fitted on "
          f"{', '.join(cal.controllers)}, checked on {sim.attrs['held_out']}):")
    print(validation_table(real, sim).round(2).to_string(), "\n")
    v = ranking_verdict(real_ch, sim_ch)
    print(f"does the simulation rank the channels as the real flights do? {v['verdict']} "
          f"(agree {len(v['agree'])}, disagree {len(v['disagree'])}, tied in the simulation "
          f"{len(v['sim_tied'])}, Spearman {v['spearman']:.2f})")
    return 0


def _exp13_fill(folder, profile, seed, results):
    """The fill's task for Experiment 13: its real-flight rows, then its calibrated twin's
    (:func:`~uavwind.analysis.exp13.run_exp13`, on one worker)."""
    run_exp13(profile, results=results, n_jobs=1, folder=folder)


def _filter_fill(profile, seed, results):
    """The fill's task for Experiment 11's filter table."""
    filter_table(profile=profile, results=results, n_jobs=1)


def _book_analyses(folder) -> list:
    """Every analysis the pages read, as the fill's tasks: the explorer's grid, Exp 11's
    filter table and Exp 13's real flights (first: long, and reading no experiment), then
    :func:`~uavwind.analysis.page_analyses.page_analyses` (each once what it reads is stored).
    Exp 13 only with its flights: ``folder``, else ``$UAVWIND_NEURALFLY`` (else left out)."""
    out = [Analysis("explore_grid", fill_grid, long=True),
           Analysis("exp11_filter_table", _filter_fill, long=True)]
    if folder is not None or os.environ.get(NEURALFLY_ENV):
        out.append(Analysis("exp13", partial(_exp13_fill, str(neuralfly_folder(folder))),
                            long=True))
    return out + page_analyses()


def _analyses(args) -> int:
    """Fill the caches of the analyses the pages read (:func:`_book_analyses`: the
    explorer's grid, Exp 11's filter table, Exp 13's real and simulated rows, the pages'
    summaries and exercises), in one pool: what ``run all --reading all`` computes beside
    the experiments, for a cache whose experiments were filled another way. Exp 13 is
    skipped, saying so, without Neural-Fly's folder."""
    try:
        have = args.folder is not None or bool(os.environ.get(NEURALFLY_ENV))
        folder = neuralfly_folder(args.folder) if have else None  # a bad folder: fail first
        t0 = time.perf_counter()
        done = fill_cache([], profile=args.profile, n_jobs=args.jobs, progress=False,
                          analyses=_book_analyses(folder))
        cpu = {r["experiment"]: r["cpu_seconds"] for r in done["times"]}
        print(f"analyses: {', '.join(f'{k} ({v:.1f} CPU-s)' for k, v in cpu.items())}, in "
              f"{time.perf_counter() - t0:.1f} s")
        if folder is None:
            print(f"analyses: no Neural-Fly folder (--folder or ${NEURALFLY_ENV}); Experiment 13 "
                  f"is skipped")
            return 0
        real = real_flight_rows(folder, profile=args.profile)  # read from the cache
        sim = sim_rows(real, profile=args.profile)
    except (ValueError, TypeError) as exc:
        print(f"python -m uavwind analyses: error: {exc}", file=sys.stderr)
        return 2
    print(f"analyses: Exp 13, {len(real)} real rows, {len(sim)} simulated rows (the twin's "
          f"drag scale {calibration_of(sim).drag_scale:.3f})")
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
