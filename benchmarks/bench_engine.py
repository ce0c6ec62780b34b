"""The benchmark's sections on the clustering engine: its speed, its agreement with tslearn,
its compile and where a loop's time goes.

* ``bench_loops`` -- one loop per engine, on 10 to 40 environments and three time steps;
* ``bench_agreement`` -- fast against tslearn on 200 random loops (labels and scores);
* ``bench_cold_compile`` -- a process on an empty numba cache, step by step;
* ``bench_where_time_goes`` -- a profile of the fast engine: the share of a loop's time in
  each numba kernel;
* ``bench_spread`` -- the per-loop speed-up over tslearn on varied loops, its median and
  spread, and the throughput of two cores;
* ``bench_heldout`` -- the held-out check on this host, and with AVX2 code
  (``heldout_times`` is also what its child process runs).
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

import numpy as np

import uavwind as uw
from bench_common import compared_engines, host_cpu, loop_inputs, timeit
from uavwind.analysis.tables import source_commit


def fast_threads():
    """Threads the fast engine's kernels use as ``score_loop`` runs them in this process:
    numba's thread count where the kernels' threads are on (``UAVWIND_SOFTDTW_PARALLEL=1``;
    off by default since 2026-12-07), else 1 (a pool's worker is pinned to 1)."""
    from uavwind.method.softdtw import n_threads
    return n_threads()


def bench_loops(report):
    print("\n== score_loop(): one loop, median over 5 loops (same inputs for both engines) ==")
    engines = compared_engines()
    rows = {}
    cases = [(n, 0.1) for n in (10, 20, 40)] + [(20, dt) for dt in (0.2, 0.05)]
    for n_env, dt in cases:
        # the halves layout: the inferred one (Table 3's spacing) cannot fit 20 light
        # constant environments a group above 0 m/s; the engines see the same inputs
        inputs = [loop_inputs(n_env, seed, dt=dt, scenario=2, layout="halves")
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
    report["loop_threads"] = fast_threads()


def _agree(seed):
    X, g = loop_inputs(10 + 10 * (seed % 2), seed)
    a = uw.score_loop(X, g, engine="tslearn")
    b = uw.score_loop(X, g, engine="fast")
    same = np.array_equal(a.labels, b.labels) or np.array_equal(a.labels, 1 - b.labels)
    return same, abs(a.score - b.score) if same else float("nan"), a.correct, b.correct


def bench_agreement(report, n_loops=200):
    if "fast" not in compared_engines():
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
    # the kernels as this thread enters them: serially, or its share of a call whose lane
    # groups a helper thread shares (cProfile sees this thread only; its wait for the helper
    # is a row of its own)
    names = {"_objgrad_serial": "barycentre updates: soft-DTW value + gradient",
             "_objgrad_groups": "barycentre updates: soft-DTW value + gradient",
             "_objgrad_batch_serial": "barycentre updates: soft-DTW value + gradient",
             "_cross_groups": "assignment: soft-DTW to both centres",
             "_sdtw_cross_serial": "assignment: soft-DTW to both centres",
             "_dtw_upper_groups": "silhouette: DTW matrix",
             "_dtw_upper_range": "silhouette: DTW matrix",
             "_spin_until": "waiting for the helper thread to finish its lane groups"}
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

    X = np.ascontiguousarray(inputs[3])
    centres = np.ascontiguousarray(np.stack([X[:10].mean(0), X[10:].mean(0)]))
    cells = X.shape[1] * centres.shape[1]
    per_cell = {}
    for kernel, on in (("lockstep", True), ("scalar", False)):
        with fk.use_lockstep(on):
            value = timeit(lambda: fk.soft_dtw_cross(X, centres, 0.5, parallel=False),
                           repeat=20)
            grad = timeit(lambda: fk.soft_dtw_objgrad(centres[0], X[:10], 0.5, parallel=False),
                          repeat=20)
            # a k-means round: both clusters' objectives and gradients (one call in lockstep)
            both = timeit(lambda: fk.soft_dtw_objgrad_many([centres[0], centres[1]],
                                                           [X[:10], X[10:]], 0.5,
                                                           parallel=False), repeat=20)
        per_cell[kernel] = (value / (len(X) * 2 * cells) * 1e9, grad / (10 * cells) * 1e9,
                            both / (len(X) * cells) * 1e9)
    ns_value, ns_grad, ns_both = per_cell["lockstep"]
    # where the gradient's extra goes: the costs alone, as the value needs them (squared
    # distances) and as tslearn's barycentre objective has them (sqrt(.) ** 2, one vector
    # square root a cell), every row of the same matrix
    costs = {}
    for label, sq in (("squared distance", False), ("sqrt(.) ** 2", True)):
        fill, n_cells = fk.lockstep_costs(centres[0], X, sqrtsq=sq)
        costs[label] = timeit(fill, repeat=50) / n_cells * 1e9
    for kernel, (v, g, b) in per_cell.items():
        lanes = f" ({fk.LANES} lanes)" if kernel == "lockstep" else ""
        print(f"  per cell of a {X.shape[1]} x {centres.shape[1]} matrix, {kernel}"
              f"{lanes}: soft-DTW value {v:.2f} ns, "
              f"value + gradient {g:.2f} ns (one cluster of 10), {b:.2f} ns (both clusters' "
              f"round, 10 + 10 series) (median of 20)")
    print(f"  the costs alone, lockstep, per cell: squared distance {costs['squared distance']:.2f} "
          f"ns, sqrt(.) ** 2 as the barycentre objective has them "
          f"{costs['sqrt(.) ** 2']:.2f} ns (median of 50)")
    report["time_shares"] = {"loops": n_loops, "iterations": iters, "seconds": total,
                             "shares": shares, "ns_per_cell_value": ns_value,
                             "ns_per_cell_value_and_gradient": ns_grad,
                             "ns_per_cell_value_and_gradient_both_clusters": ns_both,
                             "lanes": fk.LANES, "ns_per_cell_costs": costs, "cluster_series": 10,
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
    from uavwind.method.softdtw import use_lockstep

    X, g, _ = _varied_loop(i)
    with use_lockstep(lockstep):
        t0 = time.perf_counter()
        res = uw.score_loop(X, g, engine=engine)
        return time.perf_counter() - t0, res.labels.tolist(), res.score


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


def _heldout_loop(i):
    """Loop ``i`` of the held-out check: Table 2 scenario ``i % 7 + 1``, 5 or 10 environments
    a group (alternately), 120 steps, seed 20_000 + i (no other section's loops)."""
    return loop_inputs(2 * (5, 10)[i % 2], 20_000 + i, scenario=i % 7 + 1)


#: How the held-out check's AVX2 child compiles: Haswell's name and the host's features with
#: every AVX-512 (and AMX, AVX10) feature off.
AVX2_CODE = "NUMBA_CPU_NAME=haswell, NUMBA_CPU_FEATURES without AVX-512"


def avx2_features():
    """The host's LLVM feature string with every AVX-512, AMX and AVX10 feature off: the code
    an AVX2 host of this machine kind would run (``NUMBA_CPU_NAME`` alone keeps them on)."""
    from llvmlite import binding
    feats = binding.get_host_cpu_features()
    for name in list(feats):
        if name.startswith(("avx512", "amx", "avx10", "evex512")):
            feats[name] = False
    return feats.flatten()


def heldout_times(engines=("fast", "tslearn"), n_loops=12, side_by_side=False):
    """``{engine: (wall seconds, CPU seconds, [(labels, score)])}`` over the held-out loops,
    the engines taking turns on each loop (so a burst of load falls on both). With
    ``side_by_side``, also ``"side by side"``: the fast engine on all the loops at once
    (:func:`uavwind.score_loops`, as a search scores a block of its loops), timed between
    the first and the second half of the loops one by one."""
    loops = [_heldout_loop(i) for i in range(n_loops)]
    for e in engines:
        uw.score_loop(*loops[0], engine=e)  # compile / load caches
    out = {e: [0.0, 0.0, []] for e in engines}
    for i, (X, g) in enumerate(loops):
        if side_by_side and i == n_loops // 2:
            w0, c0 = time.perf_counter(), time.process_time()
            rs = uw.score_loops([X for X, _ in loops], [g for _, g in loops], engine="fast")
            out["side by side"] = [time.perf_counter() - w0, time.process_time() - c0,
                                   [(r.labels.tolist(), r.score) for r in rs]]
        for e in engines:
            w0, c0 = time.perf_counter(), time.process_time()
            r = uw.score_loop(X, g, engine=e)
            out[e][0] += time.perf_counter() - w0
            out[e][1] += time.process_time() - c0
            out[e][2].append((r.labels.tolist(), r.score))
    return out


def bench_heldout(report, n_loops=12, rounds=3):
    """The held-out check of the engine against tslearn: 12 loops of 5 or 10 environments a
    group, 120 steps, gamma 0.5, the default k-means and barycentre iterations, each engine
    as ``score_loop`` runs it (each with its default threads: tslearn numba's, the fast
    engine serially unless UAVWIND_SOFTDTW_PARALLEL=1 asks for helper threads,
    :func:`fast_threads` of them),
    side by side, ``rounds`` times (this host's speed drifts: the
    same 12 loops took tslearn 26-45 s in one day, so one round's ratio is not the host's);
    the figures are the rounds' medians, with the range. Then the fast engine alone with AVX2
    code (:data:`AVX2_CODE`, a cache of its own) in a child process, the narrower vectors
    another host of this kind may give, set against the median tslearn time: 4 lanes, as an
    AVX2 host runs them (``NUMBA_CPU_NAME=haswell`` alone kept the host's AVX-512 features,
    so that child ran 512-bit code)."""
    import subprocess
    import tempfile

    host = host_cpu()
    print(f"\n== held-out check: {n_loops} loops, fast vs tslearn side by side, {rounds} "
          f"rounds, on {host['model']} ({host['llvm_cpu']}, {host['lanes']} lanes) ==")
    runs = []
    for k in range(rounds):
        t = heldout_times(n_loops=n_loops, side_by_side=True)
        same = sum(a == b for a, b in zip(t["fast"][2], t["tslearn"][2]))
        both = sum(a == b for a, b in zip(t["side by side"][2], t["tslearn"][2]))
        runs.append({"fast_seconds": t["fast"][0], "tslearn_seconds": t["tslearn"][0],
                     "speedup": t["tslearn"][0] / t["fast"][0],
                     "cpu_speedup": t["tslearn"][1] / t["fast"][1], "identical": same,
                     "side_by_side_seconds": t["side by side"][0],
                     "side_by_side_speedup": t["tslearn"][0] / t["side by side"][0],
                     "side_by_side_identical": both})
        print(f"  round {k + 1}: fast {t['fast'][0]:.2f} s, tslearn {t['tslearn'][0]:.2f} s: "
              f"{runs[-1]['speedup']:.1f}x (CPU time {runs[-1]['cpu_speedup']:.1f}x); "
              f"identical labels and scores on {same}/{n_loops}; the loops side by side "
              f"(score_loops) {t['side by side'][0]:.2f} s: "
              f"{runs[-1]['side_by_side_speedup']:.1f}x, identical on {both}/{n_loops}")
    med = {key: statistics.median(r[key] for r in runs)
           for key in ("fast_seconds", "tslearn_seconds", "speedup", "cpu_speedup",
                       "side_by_side_seconds", "side_by_side_speedup")}
    same = min(r["identical"] for r in runs)
    ratios = [r["speedup"] for r in runs]
    sbs = [r["side_by_side_speedup"] for r in runs]
    print(f"  median {med['speedup']:.1f}x (rounds {min(ratios):.1f}x-{max(ratios):.1f}x); "
          f"side by side {med['side_by_side_speedup']:.1f}x ({min(sbs):.1f}x-{max(sbs):.1f}x)")
    code = ("import json, sys; sys.path.insert(0, 'benchmarks'); import bench_engine; "
            "from uavwind.method.softdtw import LANES; "
            f"t = bench_engine.heldout_times(('fast',), {n_loops}); "
            "print(json.dumps([t['fast'][0], t['fast'][1], t['fast'][2], LANES]))")

    def alone(**env):
        """The fast engine alone on the loops, in a child process (no tslearn between its
        loops, so warmer caches than in the rounds above): ``[wall, CPU, results]``."""
        res = subprocess.run([sys.executable, "-c", code], env={**os.environ, **env},
                             capture_output=True, text=True, timeout=1800, check=True)
        return json.loads(res.stdout.strip().splitlines()[-1])
    native = alone()  # the native code, as the AVX2 code below is run: like for like
    with tempfile.TemporaryDirectory() as cache:
        avx2 = alone(NUMBA_CPU_NAME="haswell", NUMBA_CPU_FEATURES=avx2_features(),
                     NUMBA_CACHE_DIR=cache)
    avx2_same, native_same = (sum(a == [b[0], b[1]] for a, b in zip(r[2], t["tslearn"][2]))
                              for r in (avx2, native))
    print(f"  alone in a child process (no tslearn between the loops): native code "
          f"{native[0]:.2f} s, AVX2 code ({AVX2_CODE}, {avx2[3]} lanes) {avx2[0]:.2f} s, "
          f"{med['tslearn_seconds'] / avx2[0]:.1f}x the median tslearn; identical on "
          f"{avx2_same}/{n_loops}")
    report["heldout"] = {
        "host": host, "loops": n_loops, "identical": same, "fast_threads": fast_threads(),
        "side_by_side_identical": min(r["side_by_side_identical"] for r in runs), **med,
        "rounds": runs,
        "native_alone": {"fast_seconds": native[0], "identical": native_same},
        "avx2": {"fast_seconds": avx2[0], "speedup": med["tslearn_seconds"] / avx2[0],
                 "identical": avx2_same, "lanes": avx2[3], "code": AVX2_CODE},
        "command": "ONLY=heldout make bench", "commit": source_commit(mark_changes=True)}


#: The kernels' thread settings :func:`bench_threads` compares: name -> the child's environment
#: (records before 2026-12-04 also have "threads, passive wait": numba's OpenMP pool with
#: ``OMP_WAIT_POLICY=PASSIVE``, which the lockstep kernels no longer use).
THREAD_SETTINGS = {
    "serial": {"UAVWIND_SOFTDTW_PARALLEL": "0"},
    "threads": {"UAVWIND_SOFTDTW_PARALLEL": "1"},
}


def engine_times(n_loops):
    """``[wall seconds, CPU seconds, [(labels, inertia)]]`` of the engine's k-means
    (:func:`uavwind.method.softdtw.fit`, the parameters of :func:`uavwind.score_loop`) on the
    first ``n_loops`` held-out loops, with the process's default threads (``parallel=None``:
    ``UAVWIND_SOFTDTW_PARALLEL``), as ``score_loop`` runs them outside a pool's workers."""
    from uavwind.method import softdtw
    from uavwind.method.clustering import DEFAULT_PARAMS

    p = {k: DEFAULT_PARAMS[k] for k in ("gamma", "max_iter", "max_iter_barycenter", "tol",
                                        "n_init", "random_state")}
    loops = [np.ascontiguousarray(_heldout_loop(i)[0], dtype=np.float64) for i in range(n_loops)]
    softdtw.fit(loops[0], n_clusters=2, **p)  # compile / load caches, start the threads
    w0, c0 = time.perf_counter(), time.process_time()
    fits = [softdtw.fit(X, n_clusters=2, **p) for X in loops]
    return [time.perf_counter() - w0, time.process_time() - c0,
            [(f.labels.tolist(), float(f.inertia)) for f in fits]]


def bench_threads(report, n_loops=6, rounds=3):
    """When the kernels' threads pay: the engine's k-means on the first ``n_loops`` held-out
    loops (:func:`engine_times`), serially and with the kernels' threads (a call's lane
    groups shared with a helper thread, :mod:`uavwind.method.softdtw._share`), each run in a
    child process, ``rounds`` times, the settings
    taking turns; on an idle machine, then beside busy cores (one process spinning on each
    core but one, as when a book builds beside the tests). The figures are the rounds' medians
    of the wall and CPU seconds; the labels and scores of every run are compared with the
    serial run's."""
    import subprocess

    host = host_cpu()
    busy_cores = max(1, (os.cpu_count() or 2) - 1)
    print(f"\n== threads: {n_loops} held-out loops, serial against threaded, idle and beside "
          f"{busy_cores} busy core(s), {rounds} rounds, on {host['model']} ==")
    code = ("import json, sys; sys.path.insert(0, 'benchmarks'); import bench_engine; "
            f"print(json.dumps(bench_engine.engine_times({n_loops})))")

    env = {k: v for k, v in os.environ.items()
           if k not in ("UAVWIND_SOFTDTW_PARALLEL", "OMP_WAIT_POLICY")}

    def run(setting):
        res = subprocess.run([sys.executable, "-c", code], env={**env, **THREAD_SETTINGS[setting]},
                             capture_output=True, text=True, timeout=1800, check=True)
        return json.loads(res.stdout.strip().splitlines()[-1])

    cases, reference, identical = {}, None, True
    for condition in ("idle", "busy"):
        spinners = []
        if condition == "busy":  # one process spinning per core but one, ended below
            spinners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                        for _ in range(busy_cores)]
        try:
            got = {s: [] for s in THREAD_SETTINGS}
            for _ in range(rounds):
                for s in THREAD_SETTINGS:
                    wall, cpu, results = run(s)
                    got[s].append((wall, cpu))
                    reference = reference or results
                    identical &= results == reference
        finally:
            for p in spinners:
                p.kill()
                p.wait()
        cases[condition] = {
            s: {"wall_seconds": statistics.median(w for w, _ in v),
                "cpu_seconds": statistics.median(c for _, c in v),
                "wall_range": [min(w for w, _ in v), max(w for w, _ in v)]}
            for s, v in got.items()}
        print(f"  {condition}: " + "; ".join(
            f"{s} {c['wall_seconds']:.2f} s wall ({c['cpu_seconds']:.2f} s CPU)"
            for s, c in cases[condition].items()))
    print(f"  labels and scores identical in every run: {identical}")
    report["threads"] = {"host": host, "loops": n_loops, "rounds": rounds,
                         "busy_cores": busy_cores, "threads": os.cpu_count(), "cases": cases,
                         "identical": identical, "command": "ONLY=threads make bench"}
