"""uavwind benchmark: speed and memory figures measured side by side in one run.

Prints figures (no pass/fail) and writes them to benchmarks/benchmark.json, which the
book's performance page reads. That file is committed: the book built from a fresh clone
shows the figures last measured (with their date and machine) until ``make bench`` is run
again on the machine at hand. ``FULL=1`` adds the measured paper profile (with
``BENCH_KEEP=<empty folder>``, its book, results and build output are kept there; with
``FRESH=1``, built on a fresh clone of HEAD, empty numba cache included).
Run with ``make bench``.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from bench_common import host_cpu, load_snapshot, machine_load
from bench_engine import (bench_agreement, bench_cold_compile, bench_heldout, bench_loops,
                          bench_spread, bench_threads, bench_where_time_goes)
from bench_study import (bench_builds, bench_closed_loop, bench_cluster, bench_exp13,
                         bench_paper_profile, bench_search, bench_simulation)
from uavwind.method.clustering import default_engine

OUT = Path(__file__).resolve().parent / "benchmark.json"


SECTIONS = {"simulation": bench_simulation, "loops": bench_loops, "spread": bench_spread,
            "agreement": bench_agreement, "search": bench_search,
            "profile": bench_where_time_goes, "compile": bench_cold_compile,
            "closed_loop": bench_closed_loop, "exp13": bench_exp13, "cluster": bench_cluster,
            "heldout": bench_heldout, "threads": bench_threads,
            "paper": lambda report: bench_paper_profile(report, default_engine())}
#: Sections a plain `make bench` leaves out (tens of minutes): run them with ONLY=<name>.
ON_REQUEST = {"builds": bench_builds}
#: Sections whose latest record on each host is kept as well, as ``<section>_hosts`` (CPU
#: model -> record, with the date it was measured): this machine kind comes as an AMD EPYC or
#: an Intel Xeon, so measuring a section again on one host keeps the other hosts' records.
BY_HOST = ("heldout", "builds", "paper_profile", "threads", "cold_compile")


def _measured(section, report):
    """Run ``section`` into ``report``; each record it writes also says what else the
    machine ran meanwhile (``machine_load``: quiet or not)."""
    before_keys = {k: id(v) for k, v in report.items()}
    before = load_snapshot()
    section(report)
    load = machine_load(before, load_snapshot())
    for key, value in report.items():
        if isinstance(value, dict) and before_keys.get(key) != id(value):
            value["machine_load"] = load
    if load.get("quiet") is False:
        print(f"  (not quiet: other processes used {load['others_cores']} cores on average "
              f"beside this section; its wall times are not this host's)")


def merged(old, fresh, stamp, host=None):
    """``fresh`` over ``old``; each :data:`BY_HOST` section in ``fresh`` also added, dated
    ``stamp``, to its ``<section>_hosts`` record under its host's CPU model (its own
    ``host``, else ``host``: the machine that measured it)."""
    out = {**old, **fresh}
    for name in BY_HOST:
        if name in fresh:
            h = fresh[name].get("host") or host or {}
            out[f"{name}_hosts"] = {**old.get(f"{name}_hosts", {}),
                                    h.get("model", "unknown"): {"measured": stamp, "host": h,
                                                                **fresh[name]}}
    return out


def main():
    only = os.environ.get("ONLY")
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    report = {"measured": stamp, "python": sys.version.split()[0],
              "machine": platform.machine(), "cpu": host_cpu(), "cores": os.cpu_count(),
              "numpy": np.__version__}
    print(f"uavwind benchmark on {report['cores']} cores, Python {report['python']}")
    on_file = json.loads(OUT.read_text()) if OUT.exists() else {}
    if only:  # one section, measured now, merged into the figures already on file
        every = {**SECTIONS, **ON_REQUEST}
        if only not in every:
            raise ValueError(f"ONLY must be one of {sorted(every)}, got {only!r}")
        fresh = {}
        _measured(every[only], fresh)
        report = merged(on_file or report, fresh, stamp, host_cpu())
        report.setdefault("sections_measured_later", {})[only] = stamp
        report.setdefault("sections_host", {})[only] = host_cpu()  # this host kind varies
    else:
        for section in SECTIONS.values():  # the paper profile last
            _measured(section, report)
        kept = {f"{k}_hosts": on_file[f"{k}_hosts"] for k in BY_HOST if f"{k}_hosts" in on_file}
        report = merged(kept, report, stamp, host_cpu())
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(report, indent=2, default=float))
    print(f"\nwritten to {OUT.relative_to(Path.cwd()) if OUT.is_relative_to(Path.cwd()) else OUT}")


if __name__ == "__main__":
    main()
