"""The fill: every missing result of the registry's entries, under both readings, in one pool.

This module owns how the book's results are computed in one go (``make results``, ``python
-m uavwind run all --reading all``, ``fill_cache("all")``: the same call):
:func:`needed_entries` lists the cache entries (:class:`~uavwind.study.runner.Entry`) the
experiments need -- those asked for, and those the asked-for analyses read -- each once,
however many experiments and readings share it; :func:`fill_cache` computes the missing ones
as tasks -- one per chunk, longest first, and one per sample of a CEM run, ahead of the
chunks, each iteration put as the last one returns -- over a pool of local workers or on
a ``dask.distributed`` cluster (``scheduler=``), with each asked-for
:class:`~uavwind.study.registry.Analysis` a task of the same pool once what it reads is
stored, and records the CPU seconds of each entry; :func:`time_by_experiment` sums those records per experiment and reading. Where the
tasks run (the local and the cluster pool, ``uavwind.study._pools``), how a scheduler address
is checked before it is trusted (``uavwind.study._dask_probe``) and the CPU accounting behind
the records (``uavwind.study._timing``) are modules of their own.

Local workers write their chunks themselves (the results folder is theirs too); a CEM run
is written by the fill's own process, which steps it. Cluster workers only compute: each
returns its rows to the client, which verifies and writes every entry, so the workers need
no shared folder, and a task whose worker dies is computed again elsewhere by the
scheduler while the entries already returned stay written.

What an entry holds, where it is cached and how it is verified is
:mod:`uavwind.study.runner`' (and :mod:`uavwind.study.cache`'s): the rows a fill stores are the
same doubles :func:`~uavwind.study.runner.run_experiment` computes, whatever the number of
workers, and it then reads them from the cache.
"""

from __future__ import annotations

import os
import sys
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from ..core.parallel import check_jobs, pin_threads, stop_workers
from ..method.clustering import ClusteringParams, softdtw_engine
from ..method.search import CEMRun, evaluate
from ._dask_probe import _check_scheduler
from ._pools import _ClusterPool, _LocalPool, _SplitPool, _Watcher
from ._timing import _analysis_record, _cpu_seconds, _entry_record, time_by_experiment
from .cache import check_writable, results_dir
from .profiles import DEFAULT_SEED, get_profile
from .readings import DEFAULT_READING, READINGS, get_reading
from .registry import REGISTRY, Analysis, Experiment, get_experiment
from .runner import check_seed_engine, experiment_entries

if TYPE_CHECKING:
    from .profiles import Profile
    from .readings import Reading
    from .runner import Entry

__all__ = ["fill_cache", "needed_entries", "time_by_experiment"]


def _run_analysis(analysis, profile, seed, results, pin=True, n_jobs=1):
    """A task: ``analysis`` computed (``pin``: in a worker process, on one thread; else over
    ``n_jobs`` workers), and the CPU seconds it took."""
    if pin:
        pin_threads()
    cpu0 = time.process_time()
    analysis.run(profile, seed, results, n_jobs=n_jobs)
    return None, time.process_time() - cpu0


def needed_entries(exp_ids: str | Iterable[str] = "all",
                   profile: str | Profile | Mapping[str, Any] = "quick",
                   readings: str | Iterable[str | Reading] | None = None,
                   seed: int = DEFAULT_SEED, engine: str | None = None,
                   results: os.PathLike | str | None = None,
                   **params: float | str) -> list[Entry]:
    """The cache entries ``exp_ids`` need, each once: a setting that two experiments or two
    readings share is one entry. Computes nothing. The arguments are :func:`fill_cache`'s;
    bad ones raise ``ValueError`` here. An analysis needs the entries of the experiments it
    reads (``needed_entries(["exp13"])`` is empty: it reads flights, not experiments)."""
    return list(_needed(exp_ids, profile, readings, seed, engine, results, **params))


def _needed(exp_ids, profile, readings, seed, engine, results, **params):
    """:func:`needed_entries` as a dict: entry -> the (experiment, reading) pairs that need
    it, in the order they ask (readings first, then experiments in registry order)."""
    return _plan(exp_ids, profile, readings, seed, engine, results, **params)[0]


def _plan(exp_ids, profile, readings, seed, engine, results, check_data=False, **params):
    """``(entries, analyses, skipped)``: :func:`_needed`'s dict, the analyses asked for, in
    registry order, and the ids of those ``"all"`` leaves out for want of their data
    (:attr:`Analysis.data <uavwind.study.registry.Analysis.data>`; asked for by id, such an
    analysis is a ``ValueError`` naming the variable when ``check_data``: a fill)."""
    if isinstance(exp_ids, str) and exp_ids != "all":
        exp_ids = [exp_ids]
    everything = isinstance(exp_ids, str)
    items = [get_experiment(i) for i in (list(REGISTRY) if everything else list(exp_ids))]
    analyses = [a for a in items if isinstance(a, Analysis)]
    skipped = [a.id for a in analyses if everything and not a.available]
    analyses = [a for a in analyses if a.id not in skipped]
    for a in analyses if check_data else ():  # asked for by id without its data: before any work
        a.check_data()
    exps = [e for e in items if isinstance(e, Experiment)]
    all_readings = False
    if readings is None:  # "all" is the book (make results); an id, as run_experiment reads it
        readings = "all" if everything else [DEFAULT_READING]
    if readings == "all":
        readings = list(READINGS)
        all_readings = True
    elif isinstance(readings, str):
        readings = [readings]
    rds = [get_reading(r) for r in readings]
    prof = get_profile(profile)
    seed, engine = check_seed_engine(seed, engine)
    params = ClusteringParams.from_kwargs(params, "clustering parameters").to_dict() if params else {}
    folder = results_dir(results)
    # what the analyses read, under the readings the book shows each under (what they read)
    asked = {(e.id, rd.name) for rd in rds for e in exps
             if not all_readings or rd.name in e.readings}
    for a in analyses:
        asked |= {(i, r) for i in a.reads for r in REGISTRY[i].readings}
    order = exps + [REGISTRY[i] for i in dict.fromkeys(i for a in analyses for i in a.reads)
                    if i not in [e.id for e in exps]]
    rds += [get_reading(r) for r in READINGS if r not in [x.name for x in rds]]
    first, users = {}, {}
    for rd in rds:  # the asked readings first, then those only the analyses need
        for exp in order:
            if (exp.id, rd.name) not in asked:
                continue
            cases = exp.cases(rd)
            for e in experiment_entries(exp, prof, rd, seed, engine, folder, params,
                                        range(len(cases))):
                first.setdefault(e.path, e)
                pair = (exp.id, rd.name)
                if pair not in users.setdefault(e.path, []):
                    users[e.path].append(pair)
    return {e: users[path] for path, e in first.items()}, analyses, skipped


def _fill_one(entry, pin=True, n_jobs=1):
    """One entry of :func:`fill_cache` in this process (``pin``: a worker process, limited to
    one thread); ``(path, rows, from_cache, CPU seconds)``. With ``n_jobs`` > 1 the entry is
    spread over that many workers (its rows do not depend on it) and their CPU counts too."""
    if pin:
        pin_threads()
    clock = _cpu_seconds if n_jobs != 1 else (lambda: {0: time.process_time()})
    cpu0 = clock()
    df, hit = entry.fill(n_jobs=n_jobs, progress=False)
    cpu1 = clock()
    return entry.path, len(df), hit, sum(t - cpu0.get(pid, 0.0) for pid, t in cpu1.items())


def _fill_siblings(entries, pin=True):
    """A task: ``entries`` (chunks of cases that fly the same loops, :func:`_siblings`) one
    after another in this process, each as :func:`_fill_one` (its own CPU seconds); the
    first flies the loops, the others read the flights this process kept
    (:meth:`Setting.observe <uavwind.sim.setting.Setting.observe>`)."""
    return [_fill_one(e, pin=pin) for e in entries]


def _siblings(entry):
    """What ``entry``'s loops fly (random chunks only; ``None`` for others): its setting but
    for what is observed, its seed and its loops. Chunks of equal keys fly the same
    flights, and differ only in the channel and noise they read from them (Exp 11's five
    channels and two noise levels of one scenario and action, Exp 14's three channels)."""
    if entry.search != "random":
        return None
    s = entry.setting
    return (replace(s, observation="position", noise=None, baseline=False, name=""),
            entry.seed, entry.start, entry.stop)


def _compute_remote(entry):
    """A cluster task: ``entry``'s rows and the CPU seconds they took, computed on one
    thread of the worker; nothing is written there (the client stores the rows)."""
    pin_threads()
    cpu0 = time.process_time()
    df = entry.compute(n_jobs=1, progress=False)
    return df, time.process_time() - cpu0


def _cem_samples(setting, thrusts, wind_seeds, engine, params):
    """A task: a few CEM samples' loops (:func:`~uavwind.method.search.evaluate` of
    :data:`SAMPLES_PER_TASK` actions at most, on one thread, clustered side by side) and
    the CPU seconds they took; the run is stepped where the fill runs."""
    pin_threads()
    cpu0 = time.process_time()
    res = evaluate(setting, thrusts, wind_seeds, engine=engine, n_jobs=1, progress=False,
                   **params)
    return res, time.process_time() - cpu0


#: CEM samples per task: their loops are clustered side by side (a lone loop leaves a
#: quarter to a third of the kernel's vectors idle), and an iteration of the paper's 30
#: samples still spreads over 4 tasks. The rows do not depend on it.
SAMPLES_PER_TASK = 8


#: Priority of a CEM sample's task: above every entry's (an entry's is its cost, capped
#: below this), since each CEM iteration waits for its last sample.
SAMPLE_PRIORITY = 2 ** 62 + 1
#: Priority of a long :class:`Analysis` (Exp 13's flights, Exp 11's filter table): above
#: every chunk, below CEM samples; the others go when they are ready, after the chunks
#: waiting then (priority 0), as they read what the last chunks wrote.
ANALYSIS_PRIORITY = 2 ** 62


#: The key of the task that compiles the clustering kernels (see :func:`_run_tasks`).
_WARM = "compile the clustering kernels"


@dataclass(eq=False)
class _Stepping:
    """A CEM entry the fill is stepping: its run, the loop results of the iteration under
    way (``None`` where a sample has not returned) and the CPU seconds of its samples."""

    entry: Entry
    run: CEMRun
    results: list = field(default_factory=list)
    cpu: float = 0.0


def _run_tasks(missing, pool, local, stop=None, bar=None, warm=None, analyses=()):
    """Yield ``(path, rows, from_cache, CPU seconds, rows shown, tasks)`` as each entry of
    ``missing`` is done, its work handed out as tasks on ``pool``.

    A chunk is one task (``local``: the worker writes it, :func:`_fill_one`; on a cluster it
    only computes, :func:`_compute_remote`, and it is stored here by :meth:`Entry.store
    <uavwind.study.runner.Entry.store>`). A CEM run is stepped here
    (:meth:`Entry.cem_run <uavwind.study.runner.Entry.cem_run>`): an iteration's samples
    are tasks of :data:`SAMPLES_PER_TASK` samples, above every chunk in priority, the next
    iteration's put as the last sample returns, and the run stored here when it is done. A
    run's samples thus spread over every worker instead of one, and the cores stay busy
    through its iterations with other entries' chunks.

    Every task that finished is taken in before a failed one's error is raised, and every
    entry finished is stored before it is yielded, so neither an error nor an interrupt
    loses a finished entry. ``stop`` is checked every 0.1 s: once set, what has finished
    is taken in and ``KeyboardInterrupt`` raised; on leaving early the remaining tasks are
    cancelled. ``bar`` counts each CEM sample as it returns ("rows shown"), a chunk when it
    is done.

    ``warm`` (local workers): the first task, on one worker, to compile (or load) the
    clustering kernels once, for the other workers to load from numba's cache; no task
    that clusters is handed out before it returns, and meanwhile the other workers fly
    closed-loop entries (Experiment 12's episodes cluster nothing), so the compile of a
    fresh checkout leaves no core idle. It runs on a worker, not here, so that this
    process, which only waits, answers a stop request at once (a compile cannot be
    interrupted, and takes tens of seconds).

    ``analyses``: ``(analysis, args, paths)`` triples; an :class:`Analysis` is put (a task of
    its own, ``args`` its arguments) once every entry of ``paths`` (those of the
    experiments it reads) is stored; it yields ``(("analysis", name), 0, False, CPU
    seconds, 0, 1)`` when done."""
    if all(e.search == "closed_loop" for e in missing) and not analyses:
        warm = None  # nothing to cluster
    runs = {}  # entry path -> its _Stepping
    by_path = {e.path: e for e in missing}
    held = [] if warm is not None else None  # tasks that cluster, until the kernels compile

    def put(key, priority, fn, *args):
        if held is None:
            pool.put(key, priority, fn, *args)
        else:
            held.append((key, priority, fn, *args))

    def put_iteration(st):
        thrusts, seeds = st.run.ask()
        st.results = [None] * len(thrusts)
        for j in range(0, len(thrusts), SAMPLES_PER_TASK):
            put((st.entry.path, st.run.iteration, j), SAMPLE_PRIORITY, _cem_samples,
                st.entry.setting, thrusts[j:j + SAMPLES_PER_TASK],
                seeds[j:j + SAMPLES_PER_TASK], st.run.engine, st.run.params)

    waiting = [(a, args, set(paths)) for a, args, paths in analyses]

    def put_ready(path=None):
        """Put every analysis no longer waiting on an entry (``path``: just stored)."""
        for w in list(waiting):
            w[2].discard(path)
            if not w[2]:
                waiting.remove(w)
                a = w[0]
                put(("analysis", a.id), ANALYSIS_PRIORITY if a.long else 0, _run_analysis,
                    a, *w[1])

    def take(finished):
        """The entries ``finished`` completes, stored; then the first error, raised."""
        nonlocal held
        done, error = [], None
        for key, res, exc in finished:
            if exc is not None:
                error = error or exc
                continue
            if isinstance(key, tuple) and key[0] == "analysis":
                done.append((key, 0, False, res[1], 0, 1))
                continue
            if isinstance(key, tuple) and key[0] == "siblings":  # chunks a worker wrote
                for r in res:
                    done.append((*r, 0, 1))
                    put_ready(r[0])
                continue
            if key is _WARM:  # the kernels are compiled: the clustering tasks may go
                for task in held:
                    pool.put(*task)
                held = None
                continue
            if not isinstance(key, tuple):  # a chunk
                if local:
                    done.append((*res, 0, 1))
                else:
                    e = by_path[key]
                    back, hit = e.store(res[0])
                    done.append((e.path, len(back), hit, res[1], 0, 1))
                put_ready(key)
                continue
            path, _, j = key
            st = runs.get(path)
            if st is None:  # a run given up after an error
                continue
            st.results[j:j + len(res[0])], st.cpu = res[0], st.cpu + res[1]
            if bar is not None:
                bar.update(len(res[0]))
            if None in st.results:
                continue
            e, run = st.entry, st.run
            try:
                run.tell(st.results)
            except Exception as exc:  # e.g. an iteration whose every score is NaN
                error = error or exc
                del runs[path]
                continue
            if not run.done:
                if error is None and not (stop is not None and stop.is_set()):
                    put_iteration(st)
                continue
            del runs[path]
            back, hit = e.store(run.result().samples)
            n = run.iteration * run.n_samples
            done.append((e.path, len(back), hit, st.cpu, n,
                         run.iteration * -(-run.n_samples // SAMPLES_PER_TASK)))
            put_ready(path)
        if error is not None:
            raise error
        return done

    try:
        if warm is not None:
            pool.start(_WARM, warm)
        # local workers: chunks that fly the same loops are one task, so that one worker
        # flies them once (their rows are what each computes alone)
        groups = {}
        for e in missing if local else ():
            k = _siblings(e)
            if k is not None:
                groups.setdefault(k, []).append(e)
        for e in missing:
            if e.search == "cem":
                put_iteration(runs.setdefault(e.path, _Stepping(e, e.cem_run())))
            elif local and e.search == "random":
                group = groups.pop(_siblings(e), None)
                if group is None:  # put with the first of its siblings
                    continue
                if len(group) == 1:
                    put(e.path, int(min(e.cost, 2 ** 62)), _fill_one, e)
                else:
                    put(("siblings", e.path), int(min(sum(g.cost for g in group), 2 ** 62)),
                        _fill_siblings, group)
            else:
                (pool.put if e.search == "closed_loop" else put)(
                    e.path, int(min(e.cost, 2 ** 62)), _fill_one if local else _compute_remote,
                    e)
        put_ready()
        while pool.busy():
            if stop is not None and stop.is_set():
                take(pool.wait(0, dispatch=False))  # what finished meanwhile is kept
                raise KeyboardInterrupt
            yield from take(pool.wait(0.1))
    finally:
        pool.cancel()


def fill_cache(exp_ids: str | Iterable[str] = "all",
               profile: str | Profile | Mapping[str, Any] = "quick", seed: int = DEFAULT_SEED,
               n_jobs: int | None = None, engine: str | None = None,
               results: os.PathLike | str | None = None,
               readings: str | Iterable[str | Reading] | None = None, progress: bool = True,
               times: list[dict] | None = None, stop: threading.Event | None = None,
               scheduler: Any = None, **params: float | str) -> dict:
    """Compute every missing result of ``exp_ids`` (ids of the registry) in one pool.

    ``fill_cache("all")`` is ``make results`` (``python -m uavwind run all --reading all``):
    every experiment under the readings the book shows it under, and every analysis, each
    once what it reads is stored (Exp 13 only when ``$UAVWIND_NEURALFLY`` names its flights;
    else it is left out, its id in the result's ``skipped``).

    :func:`~uavwind.study.runner.run_experiment` runs one experiment's entries one after the other, each spread
    over the workers, so a worker idles at the end of every chunk and every CEM iteration.
    Here every missing chunk is one task and every sample of a CEM run is one task (the
    run is stepped in this process, its next iteration's samples put as the last one
    returns, ahead of any chunk); chunks run longest first (:attr:`Entry.cost
    <uavwind.study.runner.Entry.cost>`) with one worker per task, and an entry is written
    as soon as it is done: the cores stay busy until the last few tasks, a CEM run is not
    bound to one worker, an interrupt keeps every finished entry, and the rows are the
    same doubles as :func:`~uavwind.study.runner.run_experiment`'s (which then reads them
    from the cache).

    Parameters
    ----------
    exp_ids : "all", str or list of str
        Ids of :data:`~uavwind.study.registry.REGISTRY`: an experiment's entries under
        ``readings``; an analysis (:class:`~uavwind.study.registry.Analysis`), computed in the
        same pool as one task once the entries of the experiments it reads (under the readings
        the book shows each under, computed here too) are stored, recorded in ``times`` with
        ``search`` = ``"analysis"``. ``"all"``: every id (an analysis whose data is not
        there left out). An analysis asked for by id without its data is a ``ValueError``
        naming the variable, before any work.
    profile, seed, engine, results, **params
        As :func:`~uavwind.study.runner.run_experiment`.
    n_jobs : int, optional
        Local worker processes (-1/None = all cores); with ``scheduler``, those of the
        analyses.
    readings : "all", str or list of str, optional
        The experiments' readings (:data:`~uavwind.study.readings.READINGS`); ``"all"``:
        each experiment under the readings the book shows it under (its ``readings``). The
        default is the book's: ``"all"`` for ``exp_ids="all"`` (``make results``), else
        :data:`~uavwind.study.readings.DEFAULT_READING` (the reading
        :func:`~uavwind.study.runner.run_experiment` reads by default).
    progress : bool
        A progress bar over rows (stderr).
    times : list, optional
        Where to append the records of ``times`` (below) as entries finish, so that a caller
        keeps them when the run is interrupted.
    stop : threading.Event, optional
        Once set, ``KeyboardInterrupt`` is raised within a moment, every finished entry on
        disk: local worker processes are stopped at once (the entries they were computing
        are dropped, to be computed by the next run), an entry computed in this process
        finishes first (so an interrupt never lands inside a kernel), cluster tasks are
        cancelled; it is also checked while a ``scheduler`` address is probed. The command
        line sets it on SIGINT or SIGTERM.
    scheduler : str or distributed.Client, optional
        Fill on a ``dask.distributed`` cluster instead of local workers: the address of its
        scheduler (``"tcp://host:8786"``) or a ``Client``. A ``tcp://`` address that refuses
        the connection, stays silent or is not a dask scheduler is a ``ValueError`` within
        ``uavwind.study._dask_probe.PROBE_SECONDS``. Each worker computes one task (a chunk, or
        one CEM sample) at a time per thread and returns its rows; this process steps the
        CEM runs, verifies and writes every entry (the workers need no access to
        ``results``). The rows equal a local fill's, bit for bit. The analyses run on
        ``n_jobs`` local workers (they read and write ``results``, which the cluster's
        workers need not see), each as soon as what it reads is stored, while the cluster
        computes the rest.

    Returns
    -------
    dict
        ``entries`` (needed, after removing duplicates), ``cached`` (already there, or
        filled meanwhile by another run on the same folder), ``computed``, ``rows_computed``,
        and ``times``: one record per computed entry, in the order they finished --
        ``experiment`` (the first that needs it), ``reading`` (``"both"`` if both readings
        need it), ``shared_with`` (the other experiments that need it), ``case``, ``search``,
        ``n_env``, ``rows``, ``tasks`` (1 for a chunk or an entry computed in this process, a
        CEM run's samples when they were tasks) and ``cpu_seconds`` (of the processes that
        computed it); ``skipped``: the analyses ``"all"`` left out for want of their data.
        :func:`time_by_experiment` sums them.
    """
    n_jobs = check_jobs(n_jobs)
    plan = _plan(exp_ids, profile, readings, seed, engine, results, check_data=True, **params)
    client, owned = (None, False) if scheduler is None else _check_scheduler(scheduler, stop)
    try:
        return _fill(plan, profile, seed, n_jobs, results, progress, times, stop, client)
    finally:
        if owned:
            client.close()


def _fill(plan, profile, seed, n_jobs, results, progress, times, stop, client):
    """:func:`fill_cache` once its work is planned (``plan``: :func:`_plan`'s) and its pool
    chosen (``client``: a cluster, or ``None``)."""
    from joblib import Parallel, delayed, effective_n_jobs
    from joblib._parallel_backends import LokyBackend
    from joblib.parallel import get_active_backend

    users, analyses, skipped = plan
    unique = list(users)
    missing = sorted((e for e in unique if not e.present()),
                     key=lambda e: (-e.cost, str(e.path)))
    if missing:  # before any work: keep what is computed (a complete cache is only read)
        check_writable(results_dir(results))
    out = {"entries": len(unique), "cached": len(unique) - len(missing), "computed": 0,
           "rows_computed": 0, "times": [] if times is None else times, "skipped": skipped}
    by_path = {e.path: e for e in missing}
    if not missing and not analyses:
        return out
    # an analysis waits for the missing entries of the experiments it reads
    tasks = [(a, (get_profile(profile).name, seed, results),
              [e.path for e in missing if any(x in a.reads for x, _ in users[e])])
             for a in analyses]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=sum(e.n_rows for e in missing), desc="results", unit="loop",
                   file=sys.stderr)
    watcher = done = None
    try:
        if client is not None:
            # the analyses read and write the result folder here: on the local workers, each
            # as soon as what it reads is stored, while the cluster computes the rest
            pool = _ClusterPool(client)
            if tasks:
                pool = _SplitPool(pool, _LocalPool(effective_n_jobs(n_jobs)))
                if stop is not None:
                    watcher = _Watcher(stop)
            done = _run_tasks(missing, pool, False, stop, bar, analyses=tasks)
        elif effective_n_jobs(n_jobs) == 1 or len(missing) + len(tasks) == 1:
            # in this process; a lone entry still gets every worker
            done = _then(((*_fill_one(e, pin=False, n_jobs=n_jobs), 0, 1) for e in missing),
                         tasks, n_jobs)
        else:
            # the loop kernels compiled (or loaded from numba's cache) once, first: on a fresh
            # checkout, workers that each compiled them at once would spend a core-minute on
            # copies of the same work; now they load what one of them wrote (imported here:
            # a page that only reads results needs neither the kernels nor scikit-learn)
            softdtw = softdtw_engine()
            if isinstance(get_active_backend()[0], LokyBackend):
                # one task per chunk and per CEM sample, dispatched in priority order as
                # workers free up (closed-loop entries fly while the kernels compile)
                done = _run_tasks(missing, _LocalPool(effective_n_jobs(n_jobs)), True, stop,
                                  bar, warm=softdtw.warmup, analyses=tasks)
            else:  # another joblib backend (joblib.parallel_config): one task per entry
                softdtw.warmup()
                done = _then(((*r, 0, 1) for r in Parallel(
                    n_jobs=n_jobs, batch_size=1, pre_dispatch="n_jobs",
                    return_as="generator_unordered")(delayed(_fill_one)(e) for e in missing)),
                    tasks)
            if stop is not None:  # waiting on the workers: a stop request ends them at once
                watcher = _Watcher(stop)
        for path, n_rows, hit, cpu, shown, n_tasks in done:
            if isinstance(path, tuple):  # an analysis
                out["times"].append(_analysis_record(path[1], cpu))
                continue
            out["computed"] += not hit
            out["cached"] += hit  # another run on the same folder got there first
            out["rows_computed"] += 0 if hit else n_rows
            if not hit:
                e = by_path[path]
                out["times"].append(_entry_record(e, users[e], n_rows, n_tasks, cpu))
            if bar is not None:
                bar.update(max(0, n_rows - shown))
            if stop is not None and stop.is_set():
                raise KeyboardInterrupt
    except BaseException:  # interrupted or failed: finished entries are on disk
        if client is None or tasks:  # local workers (a cluster's fill: its analyses')
            stop_workers()
        if stop is not None and stop.is_set():
            raise KeyboardInterrupt from None  # the workers were stopped on request
        raise
    finally:
        if watcher is not None:
            watcher.close()
        if done is not None:
            done.close()  # cancels the tasks still pending
        if bar is not None:
            bar.close()
    return out


def _then(done, tasks, n_jobs=1):
    """What ``done`` yields, then the analyses of ``tasks`` in this process, one after the
    other (each over ``n_jobs`` workers), as :func:`_run_tasks` yields them (a generator:
    closing it closes ``done``)."""
    yield from done
    for a, args, _ in tasks:
        cpu = _run_analysis(a, *args, pin=False, n_jobs=n_jobs)[1]
        yield ("analysis", a.id), 0, False, cpu, 0, 1
