"""uavwind benchmark: speed and memory figures measured side by side in one run.

Prints figures (no pass/fail) and writes them to data/results/benchmark.json,
which the book's performance page reads. ``FULL=1`` adds the paper profile.
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

OUT = Path(__file__).resolve().parents[1] / "data" / "results" / "benchmark.json"


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
    tc = timeit(lambda: uw.DrydenWind(w20[:50], seed=1, discretisation="control").gusts(121), repeat=3)
    print(f"  50 environments via control.sample_system: {tc * 1e3:8.1f} ms "
          f"({tc / 50 * 1e3:.2f} ms per environment)")
    report["dryden_seconds"] = {"1000": t, "3000": t3, "control_50": tc}


def main():
    report = {"python": sys.version.split()[0], "machine": platform.machine(),
              "cores": os.cpu_count(), "numpy": np.__version__}
    print(f"uavwind benchmark on {report['cores']} cores, Python {report['python']}")
    bench_simulation(report)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(report, indent=2, default=float))
    print(f"\nwritten to {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
