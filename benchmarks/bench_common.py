"""What every section of the benchmark shares: the timer, one random loop's inputs, the
engines compared and the host measured on.

``timeit`` is the median wall time of a call; ``loop_inputs`` flies one random loop of a
Table 2 scenario (the trajectories and groups every engine section clusters);
``compared_engines`` are the clustering engines installed; ``host_cpu`` names the CPU a
figure was measured on (an engine's figures are one host's); ``load_snapshot`` and
``machine_load`` say whether anything else ran beside a section (a wall time counts only
from a quiet machine). ``bench.py`` runs the
sections; ``bench_engine.py`` and ``bench_study.py`` hold them.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

import uavwind as uw


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


def loop_inputs(n_env, seed, dt=0.1, scenario=None, layout="inferred"):
    """Trajectories and groups of one random loop (scenario cycles through Table 2)."""
    from uavwind.study.conditions import PAPER_SCENARIOS

    k = scenario or (seed % 7) + 1
    a, b = PAPER_SCENARIOS[k]
    setting = uw.make_setting(a, b, n_env // 2, dt=dt, layout=layout)
    thrust = setting.sample_thrust(np.random.default_rng(seed))
    return setting.simulate(thrust, seed=seed), setting.groups


def compared_engines():
    """The clustering engines installed, tslearn first."""
    from uavwind.method.clustering import ENGINES
    return [e for e in ("tslearn", "fast") if e in ENGINES]


def host_cpu():
    """The host's CPU model (``/proc/cpuinfo``), LLVM's name for it and the engine's lanes:
    a figure of the engine is a figure of one host (an AMD EPYC and an Intel Xeon of the
    same machine kind differ by half)."""
    from llvmlite import binding

    from uavwind.method.softdtw import LANES
    model = platform.processor() or "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"model": model, "llvm_cpu": binding.get_host_cpu_name(), "lanes": int(LANES)}


#: A section ran on a quiet machine when the other processes used at most this many cores on
#: average beside it [cores].
QUIET_CORES = 0.1


def _busy_cpu_seconds():
    """CPU seconds the whole machine has been busy (``/proc/stat``: user, nice, system, irq,
    softirq, steal), or None where there is no such file."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
    except OSError:
        return None
    user, nice, system, _idle, _iowait, irq, softirq, steal = (int(x) for x in fields[:8])
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def _own_cpu_seconds():
    """CPU seconds of this process, its reaped children and its live descendants."""
    import psutil

    t = os.times()
    own = t.user + t.system + t.children_user + t.children_system
    for child in psutil.Process().children(recursive=True):
        try:
            c = child.cpu_times()
            own += c.user + c.system
        except psutil.Error:  # ended between the listing and the reading
            pass
    return own


def load_snapshot():
    """(wall [s], the machine's busy CPU [s], this process tree's CPU [s]) now."""
    return time.monotonic(), _busy_cpu_seconds(), _own_cpu_seconds()


def machine_load(before, after):
    """What ran beside a section between two :func:`load_snapshot`: ``others_cores``, the
    average cores the machine spent on other processes; ``quiet``, at most
    :data:`QUIET_CORES`; ``load_1min``, the load average at the end."""
    wall = after[0] - before[0]
    if before[1] is None or after[1] is None or wall <= 0:
        return {"quiet": None, "note": "no /proc/stat: load not measured"}
    others = max(0.0, (after[1] - before[1]) - (after[2] - before[2])) / wall
    return {"seconds": round(wall, 1), "others_cores": round(others, 2),
            "quiet": others <= QUIET_CORES, "load_1min": round(os.getloadavg()[0], 2)}
