"""The benchmark's sections on the simulation and the study: the simulator, a search, the
paper profile's fill and book, the closed loop, Experiment 13 and the fill on a cluster.

* ``bench_simulation`` -- ``simulate()`` over 10 to 1000 environments, Dryden gusts;
* ``bench_search`` -- a random search of 50 loops on one and on two workers;
* ``bench_paper_profile`` -- the paper profile: its loops' cost, and with ``FULL=1`` the
  measured fill and book (``where_the_fill_goes``, ``page_cell_seconds``);
* ``bench_closed_loop`` -- Exp 12's episodes and rollouts;
* ``bench_exp13`` -- Exp 13's CPU seconds at each profile, and the checks behind its
  iteration cap and its lap length;
* ``bench_cluster`` -- a CEM run on a two-worker dask cluster, as one task and sample by
  sample.
"""

from __future__ import annotations

import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import uavwind as uw
from bench_common import host_cpu, loop_inputs, timeit
from uavwind.analysis.tables import source_commit
from uavwind.method.clustering import default_engine


def bench_simulation(report):
    thrust = uw.sample_paper(np.random.default_rng(0))
    print("\n== simulate(): one 12 s flight, dt = 0.1 s (median of 7) ==")
    rows = {}
    for n in (10, 100, 1000):
        # the halves layout: the inferred one places at most a few dozen a group (its
        # spacing would reach negative speeds), and the layout does not change the cost
        setting = uw.make_setting("light constant", "strong shear", n // 2, layout="halves")
        wind = setting.wind()
        t = timeit(lambda: uw.simulate(thrust, wind), repeat=7)
        rows[n] = t
        print(f"  {n:5d} environments: {t * 1e3:8.2f} ms   ({t / n * 1e6:7.2f} us per environment)")
    print(f"  cost ratio 1000 / 10 environments: {rows[1000] / rows[10]:.1f}x for 100x the work")
    report["simulate_seconds"] = rows

    print("\n== DrydenWind: build + 121 gust samples ==")
    w20 = np.linspace(11.18, 13.86, 1000)
    t = timeit(lambda: uw.DrydenWind(w20, seed=1).gusts(121), repeat=5)
    print(f"  1000 environments: {t * 1e3:8.1f} ms")
    w20 = np.linspace(11.18, 13.86, 3000)
    t3 = timeit(lambda: uw.DrydenWind(w20, seed=1).gusts(121), repeat=3)
    print(f"  3000 environments: {t3 * 1e3:8.1f} ms")
    tc = timeit(lambda: uw.DrydenWind(w20[:50], seed=1).gusts(121), repeat=3)
    print(f"  50 environments via control.sample_system: {tc * 1e3:8.1f} ms "
          f"({tc / 50 * 1e3:.2f} ms per environment)")
    report["dryden_seconds"] = {"1000": t, "3000": t3, "control_50": tc}


def bench_search(report):
    setting = uw.table3_setting()
    engine = default_engine()
    print(f"\n== random_search(): 50 loops of the worked example (engine {engine}) ==")
    res = {}
    for jobs in (1, 2):
        uw.random_search(setting, n_loops=2, seed=99, n_jobs=jobs, progress=False)  # warm workers
        t0 = time.perf_counter()
        uw.random_search(setting, n_loops=50, seed=0, n_jobs=jobs, progress=False)
        res[jobs] = time.perf_counter() - t0
        print(f"  n_jobs={jobs}: {res[jobs]:6.2f} s ({res[jobs] / 50 * 1e3:6.1f} ms per loop)")
    print(f"  speed-up 1 -> 2 workers: {res[1] / res[2]:.2f}x")
    report["random_search_50"] = {"n_jobs_1": res[1], "n_jobs_2": res[2],
                                  "speedup": res[1] / res[2]}
    if engine == "fast":
        s20 = uw.make_setting("light constant", "light constant", 10)
        sweep = {}
        for jobs in (1, 2):
            t0 = time.perf_counter()
            uw.random_search(s20, n_loops=200, seed=1, n_jobs=jobs, progress=False)
            sweep[jobs] = time.perf_counter() - t0
        print(f"  200-loop sweep, 20 environments: 1 worker {sweep[1]:.1f} s, 2 workers "
              f"{sweep[2]:.1f} s, speed-up {sweep[1] / sweep[2]:.2f}x")
        report["sweep_200"] = {"n_jobs_1": sweep[1], "n_jobs_2": sweep[2],
                               "speedup": sweep[1] / sweep[2]}


def bench_paper_profile(report, engine):
    from uavwind.study import EXPERIMENTS, PROFILES, n_loops_total
    from uavwind.study.runner import case_loops

    print("\n== the paper profile ==")
    prof = PROFILES["paper"]
    by_size = {}
    for exp in EXPERIMENTS.values():
        for c in exp.cases():
            n = (prof.cem.n_samples * prof.cem.max_iter if exp.search == "cem"
                 else case_loops(prof, c))
            by_size[c.setting.n_env] = by_size.get(c.setting.n_env, 0) + n
    per_loop = {}
    import numba
    threads = numba.get_num_threads()
    numba.set_num_threads(1)  # a loop as a fill's worker runs it: on one thread
    try:
        for n_env in sorted(by_size):
            inputs = [loop_inputs(max(n_env, 2), seed) for seed in range(3)]
            X, g = inputs[0]
            uw.score_loop(X, g, engine=engine)
            per_loop[n_env] = statistics.median(
                [timeit(lambda X=X, g=g: uw.score_loop(X, g, engine=engine), repeat=1)
                 for X, g in inputs])
    finally:
        numba.set_num_threads(threads)
    one_core = sum(by_size[n] * per_loop[n] for n in by_size)
    cores = os.cpu_count() or 1
    print(f"  {n_loops_total('paper')} loops (before cache sharing); engine {engine}")
    print(f"  estimated: {one_core / 60:.1f} min on one core, {one_core / cores / 60:.1f} min on "
          f"{cores} cores (point-mass per-loop medians x loop counts by environment count; "
          "the multirotor's flights and its 6-channel clustering cost more, so this is a floor)")
    from uavwind.study.fill import needed_entries
    entries = needed_entries("all", "paper", readings="all", engine=engine)
    unique_rows = sum(e.n_rows for e in entries)
    print(f"  {len(entries)} cache entries, {unique_rows} result rows (loops, CEM samples, "
          f"closed-loop belief reports) once shared settings are counted once (both readings)")
    report["paper_profile"] = {"loops": n_loops_total("paper"), "engine": engine,
                               "entries": len(entries), "unique_loops": unique_rows,
                               "estimated_seconds_one_core": one_core,
                               "estimated_seconds_all_cores": one_core / cores}
    if os.environ.get("FULL") == "1":
        fresh = os.environ.get("FRESH") == "1"
        wall, peak, peak_pss, cpu, times, pages, commit = _measure_paper_book(fresh)
        where = (f"on a fresh clone of {commit} (empty result and numba caches)" if fresh else
                 "from an empty result cache into a temporary folder")
        print(f"  measured (FULL=1{' FRESH=1' if fresh else ''}): make book PROFILE=paper "
              f"{where}: {wall / 60:.1f} min wall, {cpu:.0f}% CPU; peak memory "
              f"{peak:.0f} MiB summed RSS, {peak_pss:.0f} MiB summed PSS (over the process "
              "tree, sampled every 0.5 s)")
        print(f"  the pages' code cells: {sum(pages.values()):.1f} s in all (papermill's cell "
              f"durations); largest: " + ", ".join(f"{k} {v:.1f} s" for k, v in
                                                    list(pages.items())[:5]))
        report["paper_profile"].update(measured_seconds=wall, peak_tree_rss_mib=peak,
                                       peak_tree_pss_mib=peak_pss,
                                       cpu_percent=cpu, measured_command="make book PROFILE=paper",
                                       page_cell_seconds=pages,
                                       measured_commit=commit,
                                       host=host_cpu(),
                                       measured_how=(
                                           "make bench FULL=1 FRESH=1: a fresh clone of the "
                                           "commit, empty result and numba caches, the venv "
                                           "shared" if fresh else
                                           "make bench FULL=1: the venv and numba cache as "
                                           "they were") + ", memory summed over the process "
                                       "tree every 0.5 s",
                                       **where_the_fill_goes(times))


def where_the_fill_goes(times):
    """From the ``--times`` record of ``python -m uavwind run`` (a dict as written): the
    fill's wall seconds and its CPU seconds per experiment and reading, as report fields."""
    from uavwind.study.fill import time_by_experiment

    t = time_by_experiment(times["entries"]).reset_index()
    return {"fill_seconds": times["wall_seconds"],
            "by_experiment": t.round({"cpu_seconds": 1, "share": 1}).to_dict("records")}


def _measure_paper_book(fresh=False):
    """``make book PROFILE=paper`` into a temporary book folder with an empty result
    cache (the venv and the numba cache as they are), or with ``fresh`` on a fresh clone of
    HEAD (:func:`_fresh_clone`: empty result and numba caches, the venv shared, as the
    builds section runs the README's commands); return (wall seconds, peak summed RSS and
    peak summed PSS of the process tree in MiB, CPU time of the waited-for process tree as
    % of wall, the fill's ``--times`` record, the pages' cell seconds, the commit built).
    ``BENCH_KEEP=<empty folder>`` builds there instead and keeps the book, its results and
    the build's output (to read the paper pages afterwards)."""
    import contextlib

    import psutil

    root_dir = Path(__file__).resolve().parents[1]
    keep = os.environ.get("BENCH_KEEP")
    if keep and (not Path(keep).is_dir() or any(Path(keep).iterdir())):
        raise ValueError(f"BENCH_KEEP must name an existing empty folder, got {keep!r}")
    where = contextlib.nullcontext(keep) if keep else tempfile.TemporaryDirectory()
    with where as tmp:
        if fresh:
            head = _head_commit(root_dir)
            root_dir = _fresh_clone(root_dir, Path(tmp) / "clone", head)
            book, commit = root_dir / "book", head[:7]
        else:
            commit = source_commit(mark_changes=True)
            book = Path(tmp) / "book"
            book.mkdir()
            for f in (root_dir / "book").iterdir():
                if f.is_file():
                    shutil.copy(f, book / f.name)
        env = {**os.environ, "UAVWIND_RESULTS": str(Path(tmp) / "results")}
        env.pop("MPLBACKEND", None)
        cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        times = Path(tmp) / "times.json"
        log = open(Path(tmp) / "build.log", "w")  # the build's output: its tail on failure
        proc = subprocess.Popen(["make", "-C", str(root_dir), "book", "PROFILE=paper",
                                 f"BOOK={book}", f"RUN_FLAGS=--times {times}"], env=env,
                                stdout=log, stderr=subprocess.STDOUT)
        root, peak, peak_pss = psutil.Process(proc.pid), 0.0, 0.0
        while proc.poll() is None:
            try:  # RSS counts shared pages once per process; PSS splits them among sharers
                mem = [p.memory_full_info() for p in [root, *root.children(recursive=True)]]
                peak = max(peak, sum(m.rss for m in mem) / 2 ** 20)
                peak_pss = max(peak_pss, sum(m.pss for m in mem) / 2 ** 20)
            except psutil.Error:
                pass
            time.sleep(0.5)
        wall = time.perf_counter() - t0
        cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        log.close()
        if proc.returncode:
            tail = (Path(tmp) / "build.log").read_text()[-3000:]
            raise RuntimeError(f"make book PROFILE=paper failed with exit code "
                               f"{proc.returncode}; the end of its output:\n{tail}")
        cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
        return (wall, peak, peak_pss, 100 * cpu / wall, json.loads(times.read_text()),
                page_cell_seconds(book / "generated"), commit)


def page_cell_seconds(generated):
    """{page: seconds its code cells ran} of the executed pages in ``generated`` (papermill's
    per-cell durations), largest first."""
    pages = {}
    for nb in sorted(Path(generated).glob("*.ipynb")):
        cells = json.loads(nb.read_text())["cells"]
        pages[nb.stem] = round(sum(c.get("metadata", {}).get("papermill", {}).get("duration")
                                   or 0.0 for c in cells if c["cell_type"] == "code"), 1)
    return dict(sorted(pages.items(), key=lambda kv: -kv[1]))


def bench_closed_loop(report, per_scenario=4):
    """Experiment 12: seconds per closed-loop flight by vehicle and policy, over flights of
    the three scenarios (median, 10th and 90th percentile), the paper profile's CPU time
    estimated from them, and with FULL=1 the paper profile's fill measured."""
    from uavwind.method.closed_loop import ClosedLoop, episode_environment, fly_episode
    from uavwind.core.seeding import root_seed
    from uavwind.study import EXPERIMENTS, PROFILES

    print("\n== closed loop (Exp 12): seconds per flight ==")
    exp = EXPERIMENTS["exp12"]
    reading = exp.readings[0]
    policies = exp.search_options["policies"]
    root = root_seed(20240101)
    per = {}
    for case in exp.cases(reading):
        prob = ClosedLoop(setting=case.setting, decision_interval=2.0, report_interval=0.5)
        vehicle = case.labels["vehicle"]
        for pol in policies:  # the shared open-loop plan once, outside the timings
            fly_episode(prob, pol, 0, root)
        for ep in range(1, 1 + per_scenario):
            test = episode_environment(prob, ep, root)
            for pol in policies:
                t0 = time.perf_counter()
                fly_episode(prob, pol, ep, root, environment=test)
                per.setdefault((vehicle, pol), []).append(time.perf_counter() - t0)
    rows, total = {}, 0.0
    prof = PROFILES["paper"]
    for (vehicle, pol), t in per.items():
        q10, q50, q90 = np.percentile(t, [10, 50, 90])
        rows[f"{vehicle} / {pol}"] = {"median": q50, "p10": q10, "p90": q90, "flights": len(t)}
        total += float(np.mean(t)) * prof.episodes * 3  # three scenarios per vehicle
        print(f"  {vehicle:34s} {pol:9s} median {q50:6.3f} s  (10th-90th {q10:.3f}-{q90:.3f} s, "
              f"{len(t)} flights)")
    cores = os.cpu_count() or 1
    print(f"  paper profile ({prof.episodes} flights per case and policy): about "
          f"{total / 60:.1f} CPU-min, {total / cores / 60:.1f} min on {cores} cores, before the "
          f"open-loop plans and the gust series")
    report["closed_loop"] = {"per_flight": rows, "estimated_cpu_seconds": total,
                             "flights_timed_per_scenario": per_scenario}
    if os.environ.get("FULL") == "1":
        with tempfile.TemporaryDirectory() as tmp:
            env = {**os.environ, "UAVWIND_RESULTS": tmp}
            cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            cmd = [sys.executable, "-m", "uavwind", "run", "exp12", "--profile", "paper",
                   "--reading", "all", "--jobs", str(cores), "--no-tables"]
            subprocess.run(cmd, env=env, check=True, capture_output=True)
            wall = time.perf_counter() - t0
            cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (cpu1.ru_utime - cpu0.ru_utime) + (cpu1.ru_stime - cpu0.ru_stime)
        print(f"  measured (FULL=1): python -m uavwind run exp12 --profile paper from an empty "
              f"cache: {wall / 60:.1f} min wall, {cpu / 60:.1f} CPU-min on {cores} cores")
        report["closed_loop"].update(measured_seconds=wall, measured_cpu_seconds=cpu,
                                     measured_command=" ".join(["python"] + cmd[1:]))


def bench_exp13(report):
    """Experiment 13's real-flight part: its CPU seconds at each profile from an empty cache
    (a fresh process, the flights read and every pair, channel and controller clustered, one
    worker), the simulated part's beside it, and the check behind its iteration cap: every
    real-flight row at the paper profile with the k-means capped as the study caps it and
    at 100 (the paper's clustering), side by side, and with the laps resampled to the
    study's samples and to the paper's series length (:func:`_lap_length_check`)."""
    from uavwind.data.neuralfly import ENV_VAR
    folder = os.environ.get(ENV_VAR)
    print("\n== Experiment 13 (real flights) ==")
    if not folder:
        print(f"  skipped: set {ENV_VAR} to the Neural-Fly flights")
        return
    out = {}
    code = ("import sys, time, resource\n"
            "from uavwind.analysis.real_flights import real_flight_rows\n"
            "from uavwind.analysis.figure8 import sim_rows\n"
            "c0 = time.process_time(); real = real_flight_rows(profile=sys.argv[1], n_jobs=1)\n"
            "c1 = time.process_time(); sim = sim_rows(real, profile=sys.argv[1], n_jobs=1)\n"
            "print(c1 - c0, time.process_time() - c1)")
    for prof in ("quick", "paper"):
        with tempfile.TemporaryDirectory() as tmp:
            r = subprocess.run([sys.executable, "-c", code, prof], capture_output=True,
                               text=True, check=True, env={**os.environ, "UAVWIND_RESULTS": tmp})
        real_cpu, sim_cpu = map(float, r.stdout.split()[-2:])
        out[prof] = {"real_cpu_seconds": real_cpu, "sim_cpu_seconds": sim_cpu}
        print(f"  {prof}: real flights {real_cpu:.1f} CPU-s (target 60 at the paper profile), "
              f"simulated twin {sim_cpu:.1f} CPU-s")
    from dataclasses import replace

    from uavwind.analysis import real_flights as rf
    from uavwind.data import load_neuralfly
    flights = load_neuralfly(folder)
    capped = rf.compute_rows(flights, rf.STUDIES["paper"], n_jobs=-1)
    full = rf.compute_rows(flights, replace(rf.STUDIES["paper"], max_iter=100), n_jobs=-1)
    cl = capped["kind"] == "cluster"
    same = int((capped.loc[cl, "score"].to_numpy() == full.loc[cl, "score"].to_numpy()).sum())
    diff = float(np.abs(capped.loc[cl, "score"].to_numpy() - full.loc[cl, "score"].to_numpy()).max())
    print(f"  k-means capped at {rf.STUDIES['paper'].max_iter} against 100 iterations: {same} of {int(cl.sum())} scores "
          f"identical, largest difference {diff:.3g} points")
    out["iterations"] = {"cap": rf.STUDIES["paper"].max_iter, "identical": same,
                         "rows": int(cl.sum()), "largest_difference": diff}
    # the lap's length: the study's samples per lap against the paper's series length, on
    # what the page reads (each channel's controlled verdict, the orders of two channels
    # the real flights decide)
    paper_len = 120
    longer = rf.compute_rows(flights, replace(rf.STUDIES["paper"], n_samples=paper_len),
                             n_jobs=-1)
    out["samples"] = _lap_length_check(capped, longer, rf.STUDIES["paper"].n_samples, paper_len)
    s = out["samples"]
    print(f"  laps of {s['samples']} against {s['paper_samples']} samples: {s['verdicts_same']} "
          f"of {s['channels']} channel verdicts the same; orders of two channels decided "
          f"(CIs apart): {s['decided']} against {s['decided_paper']}, {s['reversed']} reversed")
    report["exp13"] = out


def _lap_length_check(rows, paper_rows, samples, paper_samples):
    """What a page reads of Exp 13's real rows at ``samples`` per lap against
    ``paper_samples``: how many channels keep their controlled verdict, how many orders of two
    channels each decides (their CIs over controllers apart) and how many it reverses."""
    from uavwind.analysis import real_flights as rf

    va = rf.controlled_table(rows).set_index("channel")["verdict"]
    vb = rf.controlled_table(paper_rows).set_index("channel")["verdict"].reindex(va.index)
    da, db = (set(rf.decided_orders(rf.channel_table(r))) for r in (rows, paper_rows))
    return {"samples": samples, "paper_samples": paper_samples, "channels": len(va),
            "verdicts_same": int((va == vb).sum()), "decided": len(da),
            "decided_paper": len(db), "reversed": len({(a, b) for a, b in da if (b, a) in db}),
            "undecided_here": sorted(f"{a} above {b}" for a, b in db - da)}


#: The CEM run the cluster section fills: Experiment 6's (point mass, 20 environments).
CLUSTER_CEM = {"n_samples": 12, "n_elite": 3, "max_iter": 4}


def _warm_worker():
    from uavwind.method import softdtw
    softdtw.warmup()


def bench_cluster(report):
    """One CEM run on a dask ``LocalCluster`` of 2 one-thread workers, side by side: as one
    task (``fill._compute_remote`` of the whole entry, how the fill ran a CEM run before
    its samples were tasks) and as the fill runs it now (its samples a few to a task).
    Alternated, 3 each, after each worker loaded the kernels; the rows are checked equal."""
    from distributed import Client, LocalCluster

    from uavwind.study import fill

    print("\n== a CEM run on a cluster: one task, or its samples as tasks ==")
    prof = {"loops": 2, "long_loops": 2, "fit_loops": 2, "cem": CLUSTER_CEM}
    one, tasks, same = [], [], True
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        client.run(_warm_worker)
        for _ in range(3):
            with tempfile.TemporaryDirectory() as tmp:
                entry = next(e for e in fill.needed_entries(["exp6"], prof, results=tmp)
                             if e.search == "cem")
                t0 = time.perf_counter()
                whole, _ = client.submit(fill._compute_remote, entry, pure=False).result()
                one.append(time.perf_counter() - t0)
                t0 = time.perf_counter()
                fill.fill_cache(["exp6"], profile=prof, results=tmp, progress=False,
                                scheduler=client)
                tasks.append(time.perf_counter() - t0)
                stored = entry.read()
                same &= all(np.array_equal(whole[c].to_numpy(), stored[c].to_numpy(),
                                           equal_nan=True)
                            for c in ("iteration", "sample", "score", "silhouette", "elite"))
    n = CLUSTER_CEM["n_samples"] * CLUSTER_CEM["max_iter"]
    out = {"experiment": "exp6", "workers": 2, **CLUSTER_CEM, "samples": n,
           "one_task_seconds": one, "sample_tasks_seconds": tasks, "same_rows": bool(same)}
    print(f"  exp6's CEM run, {CLUSTER_CEM['n_samples']} samples x {CLUSTER_CEM['max_iter']} "
          f"iterations, 2 workers: one task {statistics.median(one):.1f} s "
          f"({min(one):.1f}-{max(one):.1f}), samples as tasks "
          f"{statistics.median(tasks):.1f} s ({min(tasks):.1f}-{max(tasks):.1f}); "
          f"same rows: {same}")
    report["cluster"] = out


#: Targets of the build timings (issue 69): seconds of wall time on the machine's 2 cores of
#: the slower host kind (the venv is shared, not built: these are the commands' own times).
#: `make check` (what CI runs) has CI's limit.
BUILD_TARGETS = {"make test": 5 * 60, "quick book": 2 * 60, "make check": 90 * 60}
#: Each build's own timeout [s]: a hung step fails the section instead of hanging it.
BUILD_TIMEOUT = 1800


def _head_commit(root: Path) -> str:
    """The full hash of ``root``'s HEAD (what a fresh clone of it checks out)."""
    return subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], check=True,
                          capture_output=True, text=True).stdout.strip()


def _fresh_clone(root: Path, where: Path, commit: str) -> Path:
    """A clean clone of ``root`` at ``commit`` at ``where``, sharing ``root``'s virtual
    environment (its build is not what is timed: CI builds it once) and never rebuilding it."""
    subprocess.run(["git", "clone", "-q", str(root), str(where)], check=True)
    subprocess.run(["git", "-C", str(where), "checkout", "-q", commit], check=True)
    (where / ".venv").symlink_to(root / ".venv")
    old = time.mktime(time.strptime("2020-01-01", "%Y-%m-%d"))
    os.utime(where / "environment.txt", (old, old))  # older than the venv's stamp
    return where


def _timed(cmd, cwd, env) -> dict:
    """Run ``cmd`` (a list) in ``cwd``; wall seconds, the children's CPU seconds, the exit
    code and the last line of its output."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True,
                           timeout=BUILD_TIMEOUT)
        code, out = p.returncode, (p.stdout + p.stderr).strip().splitlines()
    except subprocess.TimeoutExpired:
        code, out = "timeout", [f"over {BUILD_TIMEOUT} s"]
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    last = next((line for line in reversed(out) if " passed" in line), out[-1] if out else "")
    return {"wall_seconds": wall, "cpu_seconds": cpu, "exit": code, "last_line": last}


def bench_builds(report, runs: int = 2):
    """``make test``, ``make book PROFILE=quick`` (empty result cache) and ``make check`` (what
    CI runs), each on a fresh clone of HEAD, ``runs`` times, taking turns: the README's two
    commands as a reader runs them and CI's, against :data:`BUILD_TARGETS`. Neural-Fly's
    flights are read where ``UAVWIND_NEURALFLY`` points (as CI finds them), else the Exp 13 parts skip."""
    root = Path(__file__).resolve().parents[1]
    # every run the same commit, whatever is committed meanwhile
    commit = _head_commit(root)
    print(f"\n== the README's commands on a fresh clone of {commit[:7]} ({runs} runs each, "
          "taking turns) ==")
    rows = {name: [] for name in BUILD_TARGETS}
    for i in range(runs):
        for name in rows:
            tmp = Path(tempfile.mkdtemp(prefix="uavwind-build-"))
            try:
                clone = _fresh_clone(root, tmp / "clone", commit)
                env = {**os.environ, "UAVWIND_RESULTS": str(tmp / "results")}
                env.pop("MPLBACKEND", None)
                cmd = (["make", "book", "PROFILE=quick", f"RUN_FLAGS=--times {tmp / 'times.json'}"]
                       if name == "quick book" else name.split())
                r = _timed(cmd, clone, env)
                if name == "quick book" and (tmp / "times.json").exists():
                    r["fill_wall_seconds"] = json.loads((tmp / "times.json").read_text())[
                        "wall_seconds"]
                rows[name].append(r)
                print(f"  {name}, run {i + 1}: {r['wall_seconds']:.0f} s wall, "
                      f"{r['cpu_seconds']:.0f} CPU-s, exit {r['exit']} ({r['last_line'][:70]})")
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
    report["builds"] = {
        name: {"runs": rs, "target_seconds": BUILD_TARGETS[name],
               "median_wall_seconds": statistics.median(r["wall_seconds"] for r in rs)}
        for name, rs in rows.items()}
    report["builds"]["host"] = host_cpu()
    report["builds"]["cores"] = os.cpu_count()  # what a target's wall time leaves of CPU
    report["builds"]["commit"] = commit[:7]
    report["builds"]["neuralfly"] = bool(os.environ.get("UAVWIND_NEURALFLY"))
