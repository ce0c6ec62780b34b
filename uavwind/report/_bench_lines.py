"""The sentences of the performance page's records, one function a record: the helpers of
:func:`uavwind.report.performance.summary_lines` (the held-out check across hosts, the
builds, the gradient's split, the threads), each from the record's own figures.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

def _by_date(records):
    """``(name, record)`` pairs of ``records`` (name -> a record with its ``"measured"``
    date), oldest first."""
    return sorted(records.items(), key=lambda kv: (kv[1].get("measured", ""), kv[0]))

def _hosts_line(hosts: Mapping[str, Any]) -> str:
    """Which part of the speed-up changes with the host: the fast engine's own time or
    tslearn's, from the held-out check on each host (oldest first)."""
    rows = _by_date(hosts)
    each = "; ".join(
        f"on {model} ({h['host'].get('lanes', '?')} lanes, {h.get('measured', '?')}) the fast "
        f"engine took {h['fast_seconds']:.2f} s ({_threads_of(h)}) and tslearn "
        f"{h['tslearn_seconds']:.1f} s, {h['speedup']:.1f} times" for model, h in rows)
    if len(rows) < 2:
        return f"*The held-out check has run on one host so far:* {each}."
    fast = [h["fast_seconds"] for _, h in rows]
    slow = [h["tslearn_seconds"] for _, h in rows]
    f_ratio, t_ratio = max(fast) / min(fast), max(slow) / min(slow)
    whose = ("tslearn's own time, not the fast engine's" if t_ratio > f_ratio
             else "the fast engine's own time more than tslearn's")
    commits = list(dict.fromkeys(h.get("commit", "?") for _, h in rows))
    code = ("" if len(commits) < 2 else
            f" and of different commits ({', '.join(commits)}), so the fast engine's time also "
            "moves with its code")
    if len({_threads_of(h) for _, h in rows}) > 1:
        code += (", and with its threads (the records did not all run it the same way: "
                 "the host by host figures above say how each did)")
    return (f"*The same twelve loops on each host the check has run on:* {each}. Between the "
            f"hosts the fast engine's time differs by {f_ratio:.2f} times and tslearn's by "
            f"{t_ratio:.2f} times: the speed-up moves with {whose}. The records are of "
            f"different days{code}, and a host's speed drifts within a day (the rounds' "
            "ranges).")

def _span(rows, key, fmt):
    """``"low-high"`` of ``key`` over ``rows`` (a section's rounds), each as ``fmt``."""
    v = [r[key] for r in rows]
    return f"{min(v):{fmt}}-{max(v):{fmt}}"

def _before_tiers(builds: Mapping[str, Any]) -> bool:
    """Whether a builds record was made before the two tiers: it has no ``make check``, and
    its ``make test`` ran every test with the quick book beside them."""
    return "make check" not in builds


def _cpu_budget(cpu: list[float], target: float, cores: int | None) -> str:
    """Whether the CPU seconds ``cpu`` (a command's runs) fit in ``target`` seconds on
    ``cores`` cores at all: a wall time under the target needs at most ``target x cores`` CPU
    seconds, so work beyond that misses it however well it is packed on the cores."""
    used = f"{min(cpu):.0f}" + (f"-{max(cpu):.0f}" if max(cpu) - min(cpu) >= 0.5 else "")
    if not cores:
        return f"{used} CPU-s"
    room = target * cores
    return (f"{used} CPU-s, where {target:.0f} s on {cores} core{'s' * (cores != 1)} hold "
            f"{room:.0f}: "
            + ("the same work fits" if max(cpu) <= room else
               f"it needs {max(cpu) / room:.1f}x less CPU, however it is spread over the "
               "cores"))


def _builds_line(b: Mapping[str, Any], cores: int | None = None) -> str:
    """The README's two commands and CI's ``make check``, each run on a fresh clone (``make
    bench ONLY=builds``): every run's wall time, against its target, and the host (a record
    made before ``make check`` existed has the first two only); then each command's CPU
    against what its target leaves on the record's cores (``cores``: the machine's, for a
    record that names none: :func:`_cpu_budget`)."""
    host = b.get("host", {})
    cores = b.get("cores") or cores
    parts, budget = [], []
    command = {"make test": "make test", "quick book": "make book PROFILE=quick",
               "make check": "make check"}
    for name in command:
        if name not in b:
            continue
        rec, target = b[name], b[name]["target_seconds"]
        walls = [r["wall_seconds"] for r in rec["runs"]]
        failed = [r for r in rec["runs"] if r["exit"] != 0]
        worst = max(walls)
        over = worst / target  # two decimals where one would round a miss to "1.0x"
        verdict = ("met" if worst <= target else
                   f"missed by {worst - target:.0f} s ({over:.{2 if over < 1.1 else 1}f}x)")
        parts.append(f"`{command[name]}` "
                     + " and ".join(f"{w:.0f} s" for w in walls)
                     + f" (target {target / 60:g} min: {verdict})"
                     + (f", **{len(failed)} run(s) failed**" if failed else ""))
        cpu = [r["cpu_seconds"] for r in rec["runs"] if "cpu_seconds" in r]
        if cpu:
            budget.append(f"`{command[name]}` " + _cpu_budget(cpu, target, cores))
    if _before_tiers(b) and "make test" in b:
        parts[0] += (" (every test with the quick book beside them: what `make check` runs "
                     "now)")
    when = f" {b['measured']}" if "measured" in b else ""
    return (f"*Measured{when} on {host.get('model', '?')}* ({host.get('lanes', '?')} float64 "
            "lanes), "
            f"each on a fresh clone of {b.get('commit', '?')} with an empty result cache, "
            f"the runs taking turns (`make bench ONLY=builds`; the virtual environment "
            f"already built; Neural-Fly's flights {'present' if b.get('neuralfly') else 'absent'}"
            "): " + "; ".join(parts) + "."
            + (" Their CPU (user and system time of the whole process tree): " + "; ".join(budget)
               + "." if budget else ""))

def _gradient_split(t: Mapping[str, Any]) -> str:
    """The sentence saying how much of what the gradient adds per cell is the square root of
    tslearn's barycentre costs, every figure per lane of a vector at one cell: a value call's
    pairs fill their vectors, a k-means round's ``2 * cluster_series`` series leave lanes
    idle in the last one, so its figure is scaled to the lanes used."""
    lanes, k = t["lanes"], 2 * t.get("cluster_series", 10)
    slots = -(-k // lanes) * lanes
    raw = t["ns_per_cell_value_and_gradient_both_clusters"]
    both = raw * k / slots
    added = both - t["ns_per_cell_value"]
    # the cells table shows ``raw`` (the time over the series in use; the benchmark divides
    # by them), this sentence ``both`` (the time over every lane computed, idle ones too, as
    # a value's full vectors are): say why the two differ
    footing = ("" if slots == k else
               f" (the table's {raw:.2f} ns divides the time by the {k} series in use; this "
               f"figure divides it by all {slots} lanes computed, {slots - k} of them idle in "
               f"the last vector)")
    costs = t["ns_per_cell_costs"]
    root = costs["sqrt(.) ** 2"] - costs["squared distance"]
    return (f"Per lane of a vector at one cell, a k-means round (both clusters' {k} series in "
            f"one call, {slots // lanes} vectors of {lanes} lanes) takes {both:.2f} ns for the value with its gradient{footing}, "
            f"{added:.2f} ns more than a value; {root:.2f} ns of that ({100 * root / added:.0f}%) "
            "is the square root the forward pass takes at every cell: tslearn's barycentre "
            "objective has its costs as `cdist(Z, X) ** 2`, the square of the square root of "
            "each squared distance, which is not always the same double, so an exact engine "
            f"pays for that root (the costs alone take {costs['sqrt(.) ** 2']:.2f} ns a lane-cell "
            f"with it and {costs['squared distance']:.2f} ns without). ")

def _threads_of(record: Mapping[str, Any]) -> str:
    """How a record's fast engine ran: ``"serially"`` or ``"on 2 threads"`` (its
    ``fast_threads``; records before 2026-12-04 have none: ``score_loop`` was serial then)."""
    n = int(record.get("fast_threads", 1))
    return "serially" if n <= 1 else f"on {n} threads"

def _threads_line(t: Mapping[str, Any], when: str | None) -> str:
    """The sentence under the threads table: what the threads gain on an idle machine and
    what they cost beside busy cores, each against the serial kernels, from the medians."""
    idle, busy = t["cases"]["idle"], t["cases"]["busy"]

    def ratio(case, setting):
        return case["serial"]["wall_seconds"] / case[setting]["wall_seconds"]

    def phrase(r):
        # one format for both directions: "1.18 times as fast", "1.13 times slower"
        return f"{r:.2f} times as fast as" if r >= 1 else f"{1 / r:.2f} times slower than"
    host = t.get("host", {})
    return (f"*Measured {when or '(date not recorded)'} on {host.get('model', '?')}*, "
            f"the engine's k-means on {t['loops']} held-out loops, the median of {t['rounds']} "
            f"rounds, each run in a child process, {t['threads']} threads: on an idle machine "
            f"the threaded kernels "
            f"ran {phrase(ratio(idle, 'threads'))} the serial ones; with {t['busy_cores']} "
            f"other core{'s' if t['busy_cores'] != 1 else ''} busy, "
            f"{phrase(ratio(busy, 'threads'))} them, using "
            f"{busy['threads']['cpu_seconds']:.2f} CPU seconds against "
            f"{busy['serial']['cpu_seconds']:.2f}"
            + (f" (numba's OpenMP pool: a thread waiting at a barrier for a core another "
               f"process holds spins), and {phrase(ratio(busy, 'threads, passive wait'))} "
               f"them with `OMP_WAIT_POLICY=PASSIVE`"
               if "threads, passive wait" in busy else
               " (a call's lane groups shared with a helper thread: the caller never waits for "
               "a helper that has not started, and runs alone for a while after one that was "
               "late)")
            + ". Labels and scores were "
            f"{'identical in every run' if t['identical'] else '**not** identical in every run'}. "
            "The setting applies wherever the engine runs in a process of its own "
            "(`score_loop`, the searches with one job, `SoftDTWKMeans`, `fit`); a pool's "
            "workers run one thread each. The book's pages, which run side by side, and "
            "the tests, which run beside the quick book they build, default to serial kernels "
            "(`UAVWIND_SOFTDTW_PARALLEL=0`).")
