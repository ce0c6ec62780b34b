"""uavwind benchmark: speed and memory figures measured side by side in one run.

Prints figures (no pass/fail) and writes them to benchmarks/benchmark.json, which the
book's performance page reads. That file is committed: the book built from a fresh clone
shows the figures last measured (with their date and machine) until ``make bench`` is run
again on the machine at hand. ``FULL=1`` adds the measured paper profile (with
``BENCH_KEEP=<empty folder>``, its book, results and build output are kept there).
Run with ``make bench``.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import uavwind as uw
from uavwind.analysis.tables import source_commit
from uavwind.method.clustering import default_engine

OUT = Path(__file__).resolve().parent / "benchmark.json"


def timeit(fn, repeat=5, number=1):
    """Median wall time of ``fn`` [s] over ``repeat`` runs (after one warm-up)."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return statistics.median(times)


def bench_simulation(report):
    thrust = uw.sample_paper(np.random.default_rng(0))
    print("\n== simulate(): one 12 s flight, dt = 0.1 s (median of 7) ==")
    rows = {}
    for n in (10, 100, 1000):
        setting = uw.make_setting("light constant", "strong shear", n // 2)
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


def _loop_inputs(n_env, seed, dt=0.1, scenario=None, layout="inferred"):
    """Trajectories and groups of one random loop (scenario cycles through Table 2)."""
    from uavwind.study.conditions import PAPER_SCENARIOS

    k = scenario or (seed % 7) + 1
    a, b = PAPER_SCENARIOS[k]
    setting = uw.make_setting(a, b, n_env // 2, dt=dt, layout=layout)
    thrust = setting.sample_thrust(np.random.default_rng(seed))
    return setting.simulate(thrust, seed=seed), setting.groups


def _engines():
    from uavwind.method.clustering import ENGINES
    return [e for e in ("tslearn", "fast") if e in ENGINES]


def bench_loops(report):
    print("\n== score_loop(): one loop, median over 5 loops (same inputs for both engines) ==")
    engines = _engines()
    rows = {}
    cases = [(n, 0.1) for n in (10, 20, 40)] + [(20, dt) for dt in (0.2, 0.05)]
    for n_env, dt in cases:
        # the halves layout: the inferred one (Table 3's spacing) cannot fit 20 light
        # constant environments a group above 0 m/s; the engines see the same inputs
        inputs = [_loop_inputs(n_env, seed, dt=dt, scenario=2, layout="halves")
                  for seed in range(5)]
        for X, g in inputs[:1]:
            for e in engines:
                uw.score_loop(X, g, engine=e)  # warm-up: compile / load caches
        res = {}
        for e in engines:
            times = []
            for X, g in inputs:
                t0 = time.perf_counter()
                uw.score_loop(X, g, engine=e)
                times.append(time.perf_counter() - t0)
            res[e] = statistics.median(times)
        steps = int(round(12 / dt))
        ratio = res["tslearn"] / res["fast"] if "fast" in res else float("nan")
        print(f"  {n_env:3d} environments x {steps:3d} steps: "
              + "  ".join(f"{e} {t * 1e3:8.1f} ms" for e, t in res.items())
              + (f"   speed-up {ratio:5.1f}x" if "fast" in res else ""))
        rows[f"{n_env}env_{steps}steps"] = {**res, "speedup": ratio}
    report["loop_seconds"] = rows


def _agree(seed):
    X, g = _loop_inputs(10 + 10 * (seed % 2), seed)
    a = uw.score_loop(X, g, engine="tslearn")
    b = uw.score_loop(X, g, engine="fast")
    same = np.array_equal(a.labels, b.labels) or np.array_equal(a.labels, 1 - b.labels)
    return same, abs(a.score - b.score) if same else float("nan"), a.correct, b.correct


def bench_agreement(report, n_loops=200):
    if "fast" not in _engines():
        return
    from joblib import Parallel, delayed

    print(f"\n== fast vs tslearn: {n_loops} random loops over the 7 Table 2 scenarios, "
          "10 and 20 environments ==")
    t0 = time.perf_counter()
    out = Parallel(n_jobs=-1)(delayed(_agree)(seed) for seed in range(n_loops))
    same = np.array([o[0] for o in out])
    diffs = np.array([o[1] for o in out])
    print(f"  identical labels (up to swap): {same.sum()}/{n_loops} ({100 * same.mean():.1f}%)")
    print(f"  largest |score difference| where labels agree: {np.nanmax(diffs):.2e}")
    print(f"  ({time.perf_counter() - t0:.0f} s on all cores)")
    report["agreement"] = {"loops": n_loops, "identical_labels": int(same.sum()),
                           "max_abs_score_diff": float(np.nanmax(diffs))}


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
    for n_env in sorted(by_size):
        inputs = [_loop_inputs(max(n_env, 2), seed) for seed in range(3)]
        X, g = inputs[0]
        uw.score_loop(X, g, engine=engine)
        per_loop[n_env] = statistics.median(
            [timeit(lambda X=X, g=g: uw.score_loop(X, g, engine=engine), repeat=1)
             for X, g in inputs])
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
        wall, peak, peak_pss, cpu, times, pages = _measure_paper_book()
        print(f"  measured (FULL=1): make book PROFILE=paper from an empty result cache into a "
              f"temporary folder: {wall / 60:.1f} min wall, {cpu:.0f}% CPU; peak memory "
              f"{peak:.0f} MiB summed RSS, {peak_pss:.0f} MiB summed PSS (over the process "
              "tree, sampled every 0.5 s)")
        print(f"  the pages' code cells: {sum(pages.values()):.1f} s in all (papermill's cell "
              f"durations); largest: " + ", ".join(f"{k} {v:.1f} s" for k, v in
                                                    list(pages.items())[:5]))
        report["paper_profile"].update(measured_seconds=wall, peak_tree_rss_mib=peak,
                                       peak_tree_pss_mib=peak_pss,
                                       cpu_percent=cpu, measured_command="make book PROFILE=paper",
                                       page_cell_seconds=pages,
                                       measured_commit=source_commit(mark_changes=True),
                                       measured_how="make bench FULL=1: the venv and numba "
                                       "cache as they were, memory summed over the process "
                                       "tree every 0.5 s",
                                       **where_the_fill_goes(times))


def where_the_fill_goes(times):
    """From the ``--times`` record of ``python -m uavwind run`` (a dict as written): the
    fill's wall seconds and its CPU seconds per experiment and reading, as report fields."""
    from uavwind.study.fill import time_by_experiment

    t = time_by_experiment(times["entries"]).reset_index()
    return {"fill_seconds": times["wall_seconds"],
            "by_experiment": t.round({"cpu_seconds": 1, "share": 1}).to_dict("records")}


def _measure_paper_book():
    """``make book PROFILE=paper`` into a temporary book folder with an empty result
    cache (the venv and the numba cache as they are); return (wall seconds, peak summed
    RSS and peak summed PSS of the process tree in MiB, CPU time of the waited-for process
    tree as % of wall, the fill's ``--times`` record, the pages' cell seconds).
    ``BENCH_KEEP=<empty folder>`` builds there instead and keeps the book, its results and
    the build's output (to read the paper pages afterwards)."""
    import contextlib
    import shutil
    import subprocess
    import tempfile

    import psutil

    root_dir = Path(__file__).resolve().parents[1]
    keep = os.environ.get("BENCH_KEEP")
    if keep and (not Path(keep).is_dir() or any(Path(keep).iterdir())):
        raise ValueError(f"BENCH_KEEP must name an existing empty folder, got {keep!r}")
    where = contextlib.nullcontext(keep) if keep else tempfile.TemporaryDirectory()
    with where as tmp:
        book = Path(tmp) / "book"
        book.mkdir()
        for f in (root_dir / "book").iterdir():
            if f.is_file():
                shutil.copy(f, book / f.name)
        env = {**os.environ, "UAVWIND_RESULTS": str(Path(tmp) / "results")}
        env.pop("MPLBACKEND", None)
        import resource
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
                page_cell_seconds(book / "generated"))


def page_cell_seconds(generated):
    """{page: seconds its code cells ran} of the executed pages in ``generated`` (papermill's
    per-cell durations), largest first."""
    pages = {}
    for nb in sorted(Path(generated).glob("*.ipynb")):
        cells = json.loads(nb.read_text())["cells"]
        pages[nb.stem] = round(sum(c.get("metadata", {}).get("papermill", {}).get("duration")
                                   or 0.0 for c in cells if c["cell_type"] == "code"), 1)
    return dict(sorted(pages.items(), key=lambda kv: -kv[1]))


_COLD = """
import time
t0 = time.perf_counter()
import uavwind as uw
from uavwind.method import softdtw
t1 = time.perf_counter()
softdtw.warmup()
t2 = time.perf_counter()
s = uw.table3_setting()
uw.random_search(s, n_loops=1, seed=0, n_jobs=1, progress=False)
t3 = time.perf_counter()
softdtw.warmup(parallel=True)
t4 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2, t4 - t3)
"""


def _cold_run(extra_env):
    """One cold process (empty numba cache): its step times and its whole wall time."""
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": tmp, **extra_env}
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", _COLD], env=env, check=True,
                             capture_output=True, text=True).stdout.split()
        total = time.perf_counter() - t0
    return (*map(float, out[-4:]), total)


def bench_cold_compile(report, repeats=3):
    """The numba compile a fresh clone pays once: each figure in a new process with an
    empty numba cache (NUMBA_CACHE_DIR in a temporary folder), the engine's lockstep kernels
    and its scalar reference (UAVWIND_SOFTDTW_LOCKSTEP=0) alternating, ``repeats`` each;
    medians."""
    print(f"\n== cold numba compile (empty numba cache, median of {repeats}) ==")
    runs = {"lockstep": [], "scalar": []}
    for _ in range(repeats):
        runs["lockstep"].append(_cold_run({}))
        runs["scalar"].append(_cold_run({"UAVWIND_SOFTDTW_LOCKSTEP": "0"}))
    med = {k: np.median(np.array(v), axis=0) for k, v in runs.items()}
    imp, serial, first_loop, threaded, total = med["lockstep"]
    print(f"  import uavwind: {imp:.1f} s; soft-DTW kernels a loop uses (softdtw.warmup()): "
          f"{serial:.1f} s; the rest of a first loop (simulation, scoring): {first_loop:.1f} s; "
          f"threaded kernels (warmup(parallel=True)), compiled only when used: {threaded:.1f} s; "
          f"whole process {total:.1f} s")
    sc = med["scalar"]
    print(f"  the same with the scalar kernels: softdtw.warmup() {sc[1]:.1f} s, threaded "
          f"{sc[3]:.1f} s, whole process {sc[4]:.1f} s (warmup, lockstep runs: "
          f"{', '.join(f'{r[1]:.1f}' for r in runs['lockstep'])} s; scalar runs: "
          f"{', '.join(f'{r[1]:.1f}' for r in runs['scalar'])} s)")
    report["cold_compile"] = {"import": imp, "softdtw_serial": serial,
                              "first_loop_rest": first_loop, "softdtw_threaded": threaded,
                              "process": total, "repeats": repeats,
                              "scalar": {"softdtw_serial": sc[1], "softdtw_threaded": sc[3],
                                         "process": sc[4]},
                              "command": "NUMBA_CACHE_DIR=<empty> python -c <import uavwind; "
                                         "softdtw.warmup(); one loop; "
                                         "softdtw.warmup(parallel=True)>, each step timed; "
                                         "with and without UAVWIND_SOFTDTW_LOCKSTEP=0"}


def bench_where_time_goes(report, n_loops=20):
    """cProfile of the fast engine on ``n_loops`` loops of 20 environments: the share of
    time in each numba kernel (a kernel call is one opaque entry to the profiler)."""
    import cProfile
    import pstats

    setting = uw.make_setting("light constant", "light constant", 10)
    inputs = [setting.simulate(setting.sample_thrust(np.random.default_rng(i)), seed=i)
              for i in range(n_loops)]
    uw.score_loop(inputs[0], setting.groups)  # load the kernels
    prof = cProfile.Profile()
    prof.enable()
    iters = sum(uw.score_loop(X, setting.groups).n_iter for X in inputs)
    prof.disable()
    stats = pstats.Stats(prof)
    total = stats.total_tt
    names = {"_objgrad_serial": "barycentre updates: soft-DTW value + gradient",
             "_objgrad_par": "barycentre updates: soft-DTW value + gradient",
             "_objgrad_batch_serial": "barycentre updates: soft-DTW value + gradient",
             "_sdtw_cross_lockstep": "assignment: soft-DTW to both centres",
             "_sdtw_cross_serial": "assignment: soft-DTW to both centres",
             "_dtw_upper_lockstep": "silhouette: DTW matrix",
             "_dtw_upper_range": "silhouette: DTW matrix"}
    shares = {label: 0.0 for label in names.values()}
    for (_, _, name), (_, _, tt, _, _) in stats.stats.items():
        if name in names:
            shares[names[name]] += tt / total
    shares["everything else (Python, L-BFGS-B, k-means++)"] = 1.0 - sum(shares.values())
    print(f"\n== where a loop's time goes: fast engine, {n_loops} loops of 20 environments, "
          f"{iters} k-means iterations, {total:.2f} s under cProfile ==")
    for label, share in shares.items():
        print(f"  {100 * share:5.1f}%  {label}")
    # the cost per cell of the two kernels, on one loop's series against a centre-like series,
    # lockstep (the default) and scalar (the reference) interleaved in one run
    from uavwind.method import softdtw as fk
    from uavwind.method.softdtw import _consts
    from uavwind.method.softdtw._dispatch import _objgrad_many
    from uavwind.method.softdtw._lockstep import N

    X = np.ascontiguousarray(inputs[3])
    centres = np.ascontiguousarray(np.stack([X[:10].mean(0), X[10:].mean(0)]))
    cells = X.shape[1] * centres.shape[1]
    per_cell = {}
    for kernel, on in (("lockstep", True), ("scalar", False)):
        _consts.LOCKSTEP = on
        value = timeit(lambda: fk.soft_dtw_cross(X, centres, 0.5, parallel=False), repeat=20)
        grad = timeit(lambda: fk.soft_dtw_objgrad(centres[0], X[:10], 0.5, parallel=False),
                      repeat=20)
        # a k-means round: both clusters' objectives and gradients (one call in lockstep)
        both = timeit(lambda: _objgrad_many([centres[0], centres[1]], [X[:10], X[10:]], 0.5,
                                            False, True), repeat=20)
        per_cell[kernel] = (value / (len(X) * 2 * cells) * 1e9, grad / (10 * cells) * 1e9,
                            both / (len(X) * cells) * 1e9)
    _consts.LOCKSTEP = True
    ns_value, ns_grad, ns_both = per_cell["lockstep"]
    # where the gradient's extra goes: the costs alone, as the value needs them (squared
    # distances) and as tslearn's barycentre objective has them (sqrt(.) ** 2, one vector
    # square root a cell), every row of the same matrix
    from numba import njit

    from uavwind.method.softdtw._lockstep import R, _cost_rows, _pack_series

    @njit
    def all_costs(x, y, m, n, d, sqrtsq, D):
        for i0 in range(0, m, R):
            _cost_rows(x, y, i0, min(R, m - i0), n, d, sqrtsq, D)

    m, n, d = centres.shape[1], X.shape[1], X.shape[2]
    xs, ys, D = np.empty(m * d * N), np.empty(n * d * N), np.empty(R * n * N)
    _pack_series(np.ascontiguousarray(np.repeat(centres[:1], N, axis=0)), 0, xs)
    _pack_series(X, 0, ys)
    costs = {}
    for label, sq in (("squared distance", False), ("sqrt(.) ** 2", True)):
        costs[label] = timeit(lambda: all_costs(xs, ys, m, n, d, sq, D), repeat=50) / (
            N * m * n) * 1e9
    for kernel, (v, g, b) in per_cell.items():
        print(f"  per cell of a {X.shape[1]} x {centres.shape[1]} matrix, {kernel}"
              f"{f' ({N} lanes)' if kernel == 'lockstep' else ''}: soft-DTW value {v:.2f} ns, "
              f"value + gradient {g:.2f} ns (one cluster of 10), {b:.2f} ns (both clusters' "
              f"round, 10 + 10 series) (median of 20)")
    print(f"  the costs alone, lockstep, per cell: squared distance {costs['squared distance']:.2f} "
          f"ns, sqrt(.) ** 2 as the barycentre objective has them "
          f"{costs['sqrt(.) ** 2']:.2f} ns (median of 50)")
    report["time_shares"] = {"loops": n_loops, "iterations": iters, "seconds": total,
                             "shares": shares, "ns_per_cell_value": ns_value,
                             "ns_per_cell_value_and_gradient": ns_grad,
                             "ns_per_cell_value_and_gradient_both_clusters": ns_both,
                             "lanes": N, "ns_per_cell_costs": costs, "cluster_series": 10,
                             "ns_per_cell_scalar": {"value": per_cell["scalar"][0],
                                                    "value_and_gradient": per_cell["scalar"][1],
                                                    "value_and_gradient_both_clusters":
                                                        per_cell["scalar"][2]}}


def _varied_loop(i):
    """Loop ``i`` of the varied set: every Table 2 scenario and Exp 5's pair, both readings
    (so both layouts and both turbulence variants), 5-20 environments per group, the
    paper's and the continuous thrust sampler. Seeds 10_000 + i: no other section's loops."""
    from uavwind.study.conditions import PAPER_SCENARIOS

    pairs = [(a.label, b.label) for a, b in PAPER_SCENARIOS.values()]
    pairs.append(("light constant", "light shear"))
    a, b = pairs[i % len(pairs)]
    reading = uw.get_reading(("inferred", "halves")[(i // len(pairs)) % 2])
    sampler = ("paper", "continuous")[(i // 5) % 2]
    sizes = (5, 8, 10, 15, 20)
    for n in reversed(sizes[:(i // 3) % 5 + 1]):  # the largest the layout allows (a
        try:  # mixed pair spaced as Table 3 leaves its class range beyond ~12 environments)
            s = uw.make_setting(a, b, n, sampler=sampler, **reading.builder_kwargs)
            break
        except ValueError:
            continue
    thrust = s.sample_thrust(np.random.default_rng(10_000 + i))
    label = f"{a} vs {b}, {n}+{n}, {reading.name}, {sampler}"
    return s.simulate(thrust, seed=10_000 + i), s.groups, label


def _time_loop(i, engine, lockstep=True):
    """Seconds, labels and score of varied loop ``i`` on ``engine``; ``lockstep=False`` runs
    the fast engine's scalar kernels (its reference) instead of the lockstep ones."""
    from uavwind.method.softdtw import _consts

    X, g, _ = _varied_loop(i)
    _consts.LOCKSTEP = lockstep
    try:
        t0 = time.perf_counter()
        res = uw.score_loop(X, g, engine=engine)
        return time.perf_counter() - t0, res.labels.tolist(), res.score
    finally:
        _consts.LOCKSTEP = True


def bench_spread(report, n_loops=None):
    """Per-loop speed-up over tslearn on a varied set of loops, its median and spread, and
    throughput on 2 cores: tslearn with its own numba threads against 2 fast workers."""
    from joblib import Parallel, delayed

    n_loops = int(os.environ.get("SPREAD_LOOPS", "100")) if n_loops is None else n_loops
    print(f"\n== per-loop speed-up over tslearn on {n_loops} varied loops (one thread each) ==")
    import numba
    numba.set_num_threads(1)
    for e in ("fast", "tslearn"):
        _time_loop(0, e)  # compile / load caches
    _time_loop(0, "fast", lockstep=False)
    rows, same, scalar = [], 0, []
    for i in range(n_loops):
        tf, lf, sf = _time_loop(i, "fast")
        ts_, ls_, ss_ = _time_loop(i, "fast", lockstep=False)
        tt, lt, st = _time_loop(i, "tslearn")
        same += (lf == lt and sf == st and ls_ == lt and ss_ == st)
        rows.append((tt / tf, tf, tt, _varied_loop(i)[2]))
        scalar.append((tt / ts_, ts_ / tf))
    ratios = np.array([r[0] for r in rows])
    q10, q50, q90 = np.percentile(ratios, [10, 50, 90])
    sc = np.array(scalar)
    s10, s50, s90 = np.percentile(sc[:, 0], [10, 50, 90])
    l10, l50, l90 = np.percentile(sc[:, 1], [10, 50, 90])
    print(f"  speed-up, lockstep kernels: median {q50:.1f}x, 10th-90th percentile "
          f"{q10:.1f}x-{q90:.1f}x, min {ratios.min():.1f}x, max {ratios.max():.1f}x")
    print(f"  speed-up, scalar kernels (the reference): median {s50:.1f}x, 10th-90th "
          f"percentile {s10:.1f}x-{s90:.1f}x; lockstep over scalar: median {l50:.2f}x "
          f"({l10:.2f}x-{l90:.2f}x)")
    print(f"  identical labels and scores (lockstep, scalar, tslearn) on {same}/{n_loops}")
    slow = sorted(rows)[:3]
    for r in slow:
        print(f"    slowest speed-ups: {r[0]:.1f}x ({r[3]}; fast {r[1] * 1e3:.0f} ms, tslearn {r[2] * 1e3:.0f} ms)")
    n_tp = min(20, n_loops)
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    t0 = time.perf_counter()
    for i in range(n_tp):
        _time_loop(i, "tslearn")
    t_ts = time.perf_counter() - t0
    numba.set_num_threads(1)
    Parallel(n_jobs=2)(delayed(_time_loop)(i, "fast") for i in range(2))  # start the workers
    t0 = time.perf_counter()
    Parallel(n_jobs=2)(delayed(_time_loop)(i, "fast") for i in range(n_tp))
    t_fast = time.perf_counter() - t0
    print(f"  throughput on 2 cores, {n_tp} loops: tslearn with 2 numba threads {t_ts:.1f} s, "
          f"fast on 2 workers {t_fast:.1f} s ({t_ts / t_fast:.1f}x)")
    report["spread"] = {"loops": n_loops, "median": float(q50), "p10": float(q10),
                        "p90": float(q90), "min": float(ratios.min()), "max": float(ratios.max()),
                        "identical": int(same),
                        "scalar": {"median": float(s50), "p10": float(s10), "p90": float(s90)},
                        "lockstep_over_scalar": {"median": float(l50), "p10": float(l10),
                                                 "p90": float(l90)},
                        "throughput": {"loops": n_tp, "tslearn_2_threads": t_ts,
                                       "fast_2_workers": t_fast}}


def bench_closed_loop(report, per_scenario=4):
    """Experiment 12: seconds per closed-loop flight by vehicle and policy, over flights of
    the three scenarios (median, 10th and 90th percentile), the paper profile's CPU time
    estimated from them, and with FULL=1 the paper profile's fill measured."""
    from uavwind.method.closed_loop import ClosedLoop, fly_episode
    from uavwind.method.closed_loop.episode import _test_environment
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
            test = _test_environment(prob, ep, root)
            for pol in policies:
                t0 = time.perf_counter()
                fly_episode(prob, pol, ep, root, _test=test)
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
        import subprocess
        import tempfile
        import resource
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
    at 100 (the paper's clustering), side by side."""
    import subprocess
    import tempfile

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
    report["exp13"] = out


#: The CEM run the cluster section fills: Experiment 6's (point mass, 20 environments).
CLUSTER_CEM = {"n_samples": 12, "n_elite": 3, "max_iter": 4}


def _warm_worker():
    from uavwind.method import softdtw
    softdtw.warmup()


def bench_cluster(report):
    """One CEM run on a dask ``LocalCluster`` of 2 one-thread workers, side by side: as one
    task (``fill._compute_remote`` of the whole entry, how the fill ran a CEM run before
    its samples were tasks) and as the fill runs it now (each sample a task of its own).
    Alternated, 3 each, after each worker loaded the kernels; the rows are checked equal."""
    import tempfile

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


def host_cpu():
    """The host's CPU model (``/proc/cpuinfo``), LLVM's name for it and the engine's lanes:
    a figure of the engine is a figure of one host (an AMD EPYC and an Intel Xeon of the
    same machine kind differ by half)."""
    from llvmlite import binding

    from uavwind.method.softdtw._simd import N
    model = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"model": model, "llvm_cpu": binding.get_host_cpu_name(), "lanes": int(N)}


def _heldout_loop(i):
    """Loop ``i`` of the held-out check: Table 2 scenario ``i % 7 + 1``, 5 or 10 environments
    a group (alternately), 120 steps, seed 20_000 + i (no other section's loops)."""
    return _loop_inputs(2 * (5, 10)[i % 2], 20_000 + i, scenario=i % 7 + 1)


def heldout_times(engines=("fast", "tslearn"), n_loops=12):
    """``{engine: (wall seconds, CPU seconds, [(labels, score)])}`` over the held-out loops,
    the engines taking turns on each loop (so a burst of load falls on both)."""
    loops = [_heldout_loop(i) for i in range(n_loops)]
    for e in engines:
        uw.score_loop(*loops[0], engine=e)  # compile / load caches
    out = {e: [0.0, 0.0, []] for e in engines}
    for X, g in loops:
        for e in engines:
            w0, c0 = time.perf_counter(), time.process_time()
            r = uw.score_loop(X, g, engine=e)
            out[e][0] += time.perf_counter() - w0
            out[e][1] += time.process_time() - c0
            out[e][2].append((r.labels.tolist(), r.score))
    return out


def bench_heldout(report, n_loops=12):
    """The held-out check of the engine against tslearn: 12 loops of 5 or 10 environments a
    group, 120 steps, gamma 0.5, the default k-means and barycentre iterations, each engine
    with its default threads, side by side; then the fast engine alone with AVX2 code
    (``NUMBA_CPU_NAME=haswell``, a cache of its own) in a child process, the narrower vectors
    another host of this kind may give."""
    import subprocess
    import tempfile

    host = host_cpu()
    print(f"\n== held-out check: {n_loops} loops, fast vs tslearn side by side, on "
          f"{host['model']} ({host['llvm_cpu']}, {host['lanes']} lanes) ==")
    t = heldout_times(n_loops=n_loops)
    same = sum(a == b for a, b in zip(t["fast"][2], t["tslearn"][2]))
    wall, cpu = t["tslearn"][0] / t["fast"][0], t["tslearn"][1] / t["fast"][1]
    print(f"  fast {t['fast'][0]:.2f} s, tslearn {t['tslearn'][0]:.2f} s: {wall:.1f}x "
          f"(CPU time {cpu:.1f}x); identical labels and scores on {same}/{n_loops}")
    with tempfile.TemporaryDirectory() as cache:
        code = ("import json, sys; sys.path.insert(0, 'benchmarks'); import bench; "
                f"t = bench.heldout_times(('fast',), {n_loops}); "
                "print(json.dumps([t['fast'][0], t['fast'][1], t['fast'][2]]))")
        env = {**os.environ, "NUMBA_CPU_NAME": "haswell", "NUMBA_CACHE_DIR": cache}
        res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                             text=True, timeout=1800, check=True)
        avx2 = json.loads(res.stdout.strip().splitlines()[-1])
    avx2_same = sum(a == [b[0], b[1]] for a, b in zip(avx2[2], t["tslearn"][2]))
    print(f"  AVX2 code (NUMBA_CPU_NAME=haswell): fast {avx2[0]:.2f} s, "
          f"{t['tslearn'][0] / avx2[0]:.1f}x tslearn; identical on {avx2_same}/{n_loops}")
    report["heldout"] = {
        "host": host, "loops": n_loops, "identical": same,
        "fast_seconds": t["fast"][0], "tslearn_seconds": t["tslearn"][0],
        "speedup": wall, "cpu_speedup": cpu,
        "avx2": {"fast_seconds": avx2[0], "speedup": t["tslearn"][0] / avx2[0],
                 "identical": avx2_same},
        "command": "ONLY=heldout make bench"}


SECTIONS = {"simulation": bench_simulation, "loops": bench_loops, "spread": bench_spread,
            "agreement": bench_agreement, "search": bench_search,
            "profile": bench_where_time_goes, "compile": bench_cold_compile,
            "closed_loop": bench_closed_loop, "exp13": bench_exp13, "cluster": bench_cluster,
            "heldout": bench_heldout,
            "paper": lambda report: bench_paper_profile(report, default_engine())}


def main():
    only = os.environ.get("ONLY")
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    report = {"measured": stamp, "python": sys.version.split()[0],
              "machine": platform.machine(), "cpu": host_cpu(), "cores": os.cpu_count(),
              "numpy": np.__version__}
    print(f"uavwind benchmark on {report['cores']} cores, Python {report['python']}")
    if only:  # one section, measured now, merged into the figures already on file
        if only not in SECTIONS:
            raise ValueError(f"ONLY must be one of {sorted(SECTIONS)}, got {only!r}")
        fresh = {}
        SECTIONS[only](fresh)
        report = {**(json.loads(OUT.read_text()) if OUT.exists() else report), **fresh}
        report.setdefault("sections_measured_later", {})[only] = stamp
    else:
        for section in SECTIONS.values():  # the paper profile last
            section(report)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(report, indent=2, default=float))
    print(f"\nwritten to {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
