"""Readable tables of the benchmark figures (``make bench``) for the book's performance page.

This module owns the presentation of ``benchmarks/benchmark.json`` (written by
``benchmarks/bench.py``): :func:`load_report` reads it, :func:`report_tables` turns
it into small ``pandas`` tables with units in the column names and the issue's targets
beside the measured values. It measures nothing itself.
"""

from __future__ import annotations

import json
import os
import statistics
from collections.abc import Mapping
from pathlib import Path
from dataclasses import dataclass
from typing import Any

import pandas as pd

from ..study.runner import n_loops_total
from ._bench_lines import (_before_tiers, _builds_line, _by_date, _gradient_split, _hosts_line,
                           _span, _threads_line, _threads_of)
from .display import show_missing

__all__ = ["TARGETS", "PAPER_TARGET", "PaperTarget", "load_report", "report_tables",
           "summary_lines", "fill_cpu_seconds", "HOST_FIGURES", "host_records"]


@dataclass(frozen=True)
class PaperTarget:
    """The paper-profile build's target: the bounds the page states and holds figures to."""

    wall_minutes: float = 10.0     # [min] make book PROFILE=paper, empty result cache
    memory_mib: float = 2048.0     # [MiB] peak memory of the whole build
    cpu_percent: float = 190.0     # [%] CPU use, of 100% per core on 2 cores
    compile_seconds: float = 30.0  # [s] cold numba compile: import and a loop's kernels


PAPER_TARGET = PaperTarget()
_T = PAPER_TARGET  # a short name for the f-strings below


#: The performance targets the figures are held against (no test enforces them).
TARGETS = {
    "speedup": "fast engine at least 30x faster per loop than tslearn 0.10 as the median over "
               "at least 100 varied loops, and at least 20x at their 10th percentile, with "
               "identical labels and scores on all of them",
    "agreement": "identical labels on at least 99% of 200 random loops, "
                 "|score difference| <= 1e-6 where they agree",
    "workers": "2 workers at least 1.8x faster than 1 on a 200-loop sweep",
    "paper": f"make book PROFILE=paper in at most {_T.wall_minutes:g} min wall, peak memory "
             f"under {_T.memory_mib / 1024:g} GB, CPU use above {_T.cpu_percent:g}% of 200%; the "
             f"cold numba compile under {_T.compile_seconds:g} s",
    "closed_loop": "Experiment 12's paper profile (200 flights per case and policy) in at "
                   "most 5 min on 2 cores",
}


def fill_cpu_seconds(report: Mapping[str, Any], experiments) -> float | None:
    """The CPU seconds the paper build's fill (``report["paper_profile"]["by_experiment"]``,
    every reading) spent on ``experiments`` (ids); None when it timed none of them."""
    rows = [r for r in report.get("paper_profile", {}).get("by_experiment", [])
            if r.get("experiment") in experiments]
    return sum(r["cpu_seconds"] for r in rows) if rows else None


#: The figures each host's record holds (:func:`host_records`): row label -> (the report's
#: section, how to read the figure from one record of it (None: the record has none), its
#: format). A builds record from before the two tiers has its ``make test`` in the row of
#: ``make check``: it ran every test with the quick book.
HOST_FIGURES = {
    "make test (the tests but the slow ones), fresh clone [s]": (
        "builds", lambda r: None if _before_tiers(r) else r["make test"]["median_wall_seconds"],
        "{:.0f}"),
    "make check (every test, the quick book beside them; make test before the tiers), "
    "fresh clone [s]": ("builds", lambda r: r["make test" if _before_tiers(r) else "make check"][
        "median_wall_seconds"], "{:.0f}"),
    "make book PROFILE=quick, fresh clone [s]": (
        "builds", lambda r: r["quick book"]["median_wall_seconds"], "{:.0f}"),
    "make book (paper), empty cache [min]": (
        "paper_profile", lambda r: r["measured_seconds"] / 60, "{:.1f}"),
    "engine against tslearn, held-out loops [x]": ("heldout", lambda r: r["speedup"],
                                                   "{:.1f}"),
    "helper threads beside a busy core, wall over serial [-]": (
        "threads", lambda r: (r["cases"]["busy"]["threads"]["wall_seconds"]
                              / r["cases"]["busy"]["serial"]["wall_seconds"]), "{:.2f}"),
    "cold numba compile, one process [s]": ("cold_compile", lambda r: r["process"], "{:.1f}"),
}


_ONLY_NAME = {"paper_profile": "paper", "cold_compile": "compile"}


def _host_label(host: Mapping[str, Any]) -> str:
    """``model (llvm_cpu, N lanes)``: how every table of this page names a host."""
    return (f"{host.get('model', '?')} ({host.get('llvm_cpu', '?')}, "
            f"{host.get('lanes', '?')} lanes)")


def host_records(report: Mapping[str, Any]) -> pd.DataFrame:
    """Each host's latest record side by side: one row per figure of :data:`HOST_FIGURES`,
    one column per host (CPU model, LLVM CPU, float64 lanes), each cell the figure with the
    date and commit it was measured at, and ``quiet`` or ``not quiet`` where ``make bench``
    measured what else ran beside it; a host without that figure says so. Read from the
    sections' ``<section>_hosts`` records (``make bench`` keeps each host's latest), and
    from a section's own record where it names its host; a figure whose host was never
    recorded is left out (no figure without its host)."""
    cells: dict[str, dict[str, str]] = {}
    hosts: dict[str, Mapping[str, Any]] = {}
    for label, (section, read, fmt) in HOST_FIGURES.items():
        records = dict(report.get(f"{section}_hosts", {}))
        own = report.get(section)
        only = _ONLY_NAME.get(section, section)  # the name `ONLY=` measures it again by
        host = (own.get("host") if isinstance(own, Mapping) else None) \
            or report.get("sections_host", {}).get(only)
        if isinstance(own, Mapping) and isinstance(host, Mapping) \
                and host.get("model") not in records:
            records[host["model"]] = {"host": host, "measured": own.get(
                "measured", report.get("sections_measured_later", {}).get(only)), **own}
        for model, rec in records.items():
            host = rec.get("host") or {"model": model}
            key = _host_label(host)
            hosts[key] = host
            try:
                figure = read(rec)
            except (KeyError, TypeError, ZeroDivisionError):
                continue
            if figure is None:
                continue
            value = fmt.format(figure)
            when = str(rec.get("measured", "date not recorded"))[:10]
            commit = rec.get("commit") or rec.get("measured_commit")
            quiet = (rec.get("machine_load") or {}).get("quiet")
            cells.setdefault(label, {})[key] = (
                f"{value} ({when}" + (f", {commit}" if commit else "")
                + {True: ", quiet", False: ", not quiet"}.get(quiet, "") + ")")
    columns = sorted(hosts)
    return pd.DataFrame([[cells.get(label, {}).get(h, "not measured") for h in columns]
                         for label in HOST_FIGURES],
                        index=pd.Index(list(HOST_FIGURES), name="figure"),
                        columns=pd.Index(columns, name="host"))


def load_report(path: os.PathLike | str) -> dict:
    """The benchmark report at ``path`` as a dict (empty if the file does not exist)."""
    path = Path(path)
    return json.loads(path.read_text()) if path.exists() else {}


def _loop_label(key):
    # "20env_120steps" -> "20 environments x 120 steps"
    env, steps = key.split("_")
    return f"{env.removesuffix('env')} environments x {steps.removesuffix('steps')} steps"


def report_tables(report: Mapping[str, Any]) -> dict[str, pd.DataFrame]:
    """Tables of ``report`` (a dict from :func:`load_report`), by section name.

    Returns
    -------
    dict of str -> pandas.DataFrame
        ``"simulation"``, ``"loops"``, ``"workers"``, ``"time"``, ``"spread"``, ``"paper"``,
        ``"fill"`` (the paper build's CPU time by experiment and reading), ``"cells"`` (ns per
        soft-DTW cell, lockstep against scalar kernels), ``"compile"``,
        ``"closed_loop"`` (seconds per Exp 12 flight by vehicle and policy), ``"heldout"``
        (the held-out check against tslearn, with its host), ``"threads"`` (the fast engine
        serial and threaded, on an idle machine and beside busy cores): only the sections
        present in the report.

    Examples
    --------
    >>> t = report_tables({"loop_seconds": {"10env_120steps": {"tslearn": 2.0, "fast": 0.1,
    ...                                                          "speedup": 20.0}}})
    >>> float(t["loops"].loc["10 environments x 120 steps", "speed-up"])
    20.0
    """
    out = {}
    if "heldout" in report:
        h = report["heldout"]
        host = h.get("host", {})  # its model is named in the line above the table
        lanes = host.get("lanes", "?")
        avx2, alone = h["avx2"], h.get("native_alone")
        rows = [(f"{lanes} lanes, native code, {_threads_of(h)}", h["fast_seconds"],
                 h["speedup"], h["identical"])]
        if alone:  # both alone in a child process: like for like
            rows.append((f"{lanes} lanes, native code, alone", alone["fast_seconds"],
                         h["tslearn_seconds"] / alone["fast_seconds"], alone["identical"]))
        # records before 2026-12-02 compiled it with NUMBA_CPU_NAME=haswell alone, which kept
        # the host's AVX-512 features and its lanes: what they ran, named as they ran it
        rows.append((f"{avx2.get('lanes', lanes)} lanes, AVX2 code "
                     f"({avx2.get('code', 'NUMBA_CPU_NAME=haswell')})"
                     + (", alone" if alone else ""),
                     avx2["fast_seconds"], avx2["speedup"], avx2["identical"]))
        if "side_by_side_seconds" in h:
            rows.append((f"{lanes} lanes, native code, the loops side by side (score_loops)",
                         h["side_by_side_seconds"], h["side_by_side_speedup"],
                         h["side_by_side_identical"]))
        out["heldout"] = pd.DataFrame(
            {"vectors": [r[0] for r in rows], "fast (s)": [r[1] for r in rows],
             "tslearn (s)": [h["tslearn_seconds"]] * len(rows),
             "speed-up": [r[2] for r in rows],
             "identical": [f"{r[3]}/{h['loops']}" for r in rows]}).set_index("vectors")
    if report.get("heldout_hosts"):
        out["heldout_hosts"] = pd.DataFrame(
            [{"host": _host_label({**h["host"], "model": model}),
              "measured": h.get("measured", "?"), "commit": h.get("commit", "?"),
              "fast (s)": h["fast_seconds"], "tslearn (s)": h["tslearn_seconds"],
              "speed-up": h["speedup"],
              "rounds": _span(h["rounds"], "speedup", ".1f") if h.get("rounds") else "-",
              "side by side": h.get("side_by_side_speedup", float("nan")),
              "fast engine": _threads_of(h),
              "identical": f"{h['identical']}/{h['loops']}"}
             for model, h in _by_date(report["heldout_hosts"])]).set_index("host")
    if "threads" in report:
        t = report["threads"]
        cores = f"core{'s' if t['busy_cores'] != 1 else ''}"
        machine = {"idle": "idle", "busy": f"{t['busy_cores']} other {cores} busy"}
        out["threads"] = pd.DataFrame(
            [{"machine": machine[cond], "kernels": setting, "wall (s)": c["wall_seconds"],
              "CPU (s)": c["cpu_seconds"],
              "wall range (s)": f"{c['wall_range'][0]:.2f}-{c['wall_range'][1]:.2f}"}
             for cond in ("idle", "busy")
             for setting, c in t["cases"][cond].items()]).set_index(["machine", "kernels"])
    if "simulate_seconds" in report:
        sim = {f"simulate(), {n} environments": t for n, t in report["simulate_seconds"].items()}
        dry = report.get("dryden_seconds", {})
        names = {"1000": "DrydenWind, 1000 environments", "3000": "DrydenWind, 3000 environments",
                 "control_50": "DrydenWind via control.sample_system, 50 environments"}
        sim.update({names.get(k, k): t for k, t in dry.items()})
        out["simulation"] = pd.DataFrame({"wall time (ms)": {k: 1e3 * v for k, v in sim.items()}})
    if "loop_seconds" in report:
        rows = {_loop_label(k): {"tslearn (ms)": 1e3 * v["tslearn"], "fast (ms)": 1e3 * v["fast"],
                                 "speed-up": v["speedup"]}
                for k, v in report["loop_seconds"].items()}
        out["loops"] = pd.DataFrame(rows).T
    workers = {}
    for key, label in (("random_search_50", "50 loops, worked example (10 environments)"),
                       ("sweep_200", "200 loops, light vs light (20 environments)")):
        if key in report:
            r = report[key]
            workers[label] = {"1 worker (s)": r["n_jobs_1"], "2 workers (s)": r["n_jobs_2"],
                              "speed-up": r["speedup"]}
    if workers:
        out["workers"] = pd.DataFrame(workers).T
    if "time_shares" in report:
        t = report["time_shares"]
        out["time"] = pd.DataFrame({"share of the time (%)": {
            k: 100 * v for k, v in t["shares"].items()}})
        if "ns_per_cell_scalar" in t:
            out["cells"] = pd.DataFrame({
                f"lockstep, {t['lanes']} lanes (ns)": {
                    "soft-DTW value": t["ns_per_cell_value"],
                    "value + gradient": t["ns_per_cell_value_and_gradient"]},
                "scalar (ns)": {"soft-DTW value": t["ns_per_cell_scalar"]["value"],
                                "value + gradient": t["ns_per_cell_scalar"]["value_and_gradient"]}})
            if "ns_per_cell_value_and_gradient_both_clusters" in t:  # one k-means round
                out["cells"].loc["value + gradient, both clusters in one call"] = [
                    t["ns_per_cell_value_and_gradient_both_clusters"],
                    t["ns_per_cell_scalar"]["value_and_gradient_both_clusters"]]
            out["cells"]["ratio"] = out["cells"].iloc[:, 1] / out["cells"].iloc[:, 0]
            out["cells"].index.name = "per cell, median of 20"
    if "spread" in report:
        sp = report["spread"]
        out["spread"] = pd.DataFrame({"speed-up over tslearn": {
            "median": sp["median"], "10th percentile": sp["p10"], "90th percentile": sp["p90"],
            "smallest": sp["min"], "largest": sp["max"]}})
        if "scalar" in sp:  # the scalar kernels, timed on the same loops in the same run
            out["spread"]["scalar kernels, over tslearn"] = pd.Series({
                "median": sp["scalar"]["median"], "10th percentile": sp["scalar"]["p10"],
                "90th percentile": sp["scalar"]["p90"]})
            out["spread"]["lockstep over scalar"] = pd.Series({
                "median": sp["lockstep_over_scalar"]["median"],
                "10th percentile": sp["lockstep_over_scalar"]["p10"],
                "90th percentile": sp["lockstep_over_scalar"]["p90"]})
    if "paper_profile" in report:
        p = report["paper_profile"]
        rows = {"loops (before cache sharing)": f"{p['loops']}"}
        if "unique_loops" in p:
            rows["result rows computed (loops, CEM samples, closed-loop belief reports), "
                 "both readings, shared settings once"] = f"{p['unique_loops']}"
            rows["cache entries (chunks of <= 50 loops, whole CEM runs)"] = f"{p['entries']}"
        if "estimated_seconds_one_core" in p:
            # a floor: point-mass loops timed, multiplied by every experiment's loop count
            rows["floor estimated from point-mass loop timings, one core (min)"] = \
                f"{p['estimated_seconds_one_core'] / 60:.1f}"
            rows["floor estimated from point-mass loop timings, all cores (min)"] = \
                f"{p['estimated_seconds_all_cores'] / 60:.1f}"
        if "measured_seconds" in p:
            rows[f"measured: {p.get('measured_command', 'paper run')} (min)"] = \
                f"{p['measured_seconds'] / 60:.1f}"
            if "measured_commit" in p:
                rows["measured at commit"] = p["measured_commit"]
            if "measured_how" in p:  # the working tree's caches, or a fresh clone's
                rows["how it was run"] = ("a fresh clone, empty result and numba caches"
                                          if "FRESH=1" in p["measured_how"] else
                                          "the working tree, its numba cache as it was")
            if "host" in p:  # the machine kind comes as an AMD EPYC or an Intel Xeon
                rows["measured on"] = _host_label(p["host"])
            if "fill_seconds" in p:
                rows["of which filling the result cache (min)"] = f"{p['fill_seconds'] / 60:.1f}"
            if "cpu_percent" in p:
                rows["CPU use over the run (% of one core)"] = f"{p['cpu_percent']:.0f}"
            if "peak_tree_rss_mib" in p:
                rows["peak memory, whole process tree (MiB)"] = f"{p['peak_tree_rss_mib']:.0f}"
            if "peak_tree_pss_mib" in p:  # shared pages split among the processes sharing them
                rows["peak memory, whole process tree, shared pages split (PSS, MiB)"] = \
                    f"{p['peak_tree_pss_mib']:.0f}"
            if "peak_rss_largest_process_mib" in p:
                rows["peak memory, largest single process (MiB)"] = \
                    f"{p['peak_rss_largest_process_mib']:.0f}"
        out["paper"] = pd.DataFrame({"value": rows})
        if p.get("by_experiment"):
            t = pd.DataFrame(p["by_experiment"]).set_index(["experiment", "reading"])
            out["fill"] = pd.DataFrame({
                "cache entries": t["entries"],
                "rows (loops, CEM samples, belief reports)": t["rows"],
                "CPU (min)": (t["cpu_seconds"] / 60).round(1), "share (%)": t["share"],
                "CPU per row (ms)": (t["cpu_seconds"] / t["rows"] * 1e3).round(1)})
    if "closed_loop" in report:
        c = report["closed_loop"]
        out["closed_loop"] = pd.DataFrame({
            "median (s)": {k: round(v["median"], 3) for k, v in c["per_flight"].items()},
            "10th percentile (s)": {k: round(v["p10"], 3) for k, v in c["per_flight"].items()},
            "90th percentile (s)": {k: round(v["p90"], 3) for k, v in c["per_flight"].items()},
            "flights": {k: v["flights"] for k, v in c["per_flight"].items()}})
        out["closed_loop"].index.name = "vehicle / policy"
    if "cold_compile" in report:
        c = report["cold_compile"]
        out["compile"] = pd.DataFrame({"wall time (s)": {k: round(v, 1) for k, v in {
            "import uavwind": c["import"],
            "soft-DTW kernels a loop uses (softdtw.warmup())": c["softdtw_serial"],
            "the rest of the first loop (simulation, scoring)": c["first_loop_rest"],
            "threaded kernels, compiled only when used (warmup(parallel=True))":
                c["softdtw_threaded"],
            "the whole process": c["process"]}.items()}})
        if "scalar" in c:  # the scalar kernels, cold, alternating with the lockstep runs
            out["compile"]["scalar kernels (s)"] = pd.Series({
                "soft-DTW kernels a loop uses (softdtw.warmup())": c["scalar"]["softdtw_serial"],
                "threaded kernels, compiled only when used (warmup(parallel=True))":
                    c["scalar"]["softdtw_threaded"],
                "the whole process": c["scalar"]["process"]}).round(1)
    return {k: show_missing(v) for k, v in out.items()}


#: Sections of the benchmark another page shows instead of this one.


SHOWN_ELSEWHERE = {"exp13": "the Exp 13 page"}


def summary_lines(report: Mapping[str, Any]) -> dict[str, str]:
    """The sentences the performance page prints around its tables, by section (each
    built from the report's numbers, so none is typed)."""
    out = {}
    # `make bench ONLY=<section>` re-measures one section and dates it here
    later = report.get("sections_measured_later", {})
    if report:
        cpu = report.get("cpu", {}).get("model")
        out["header"] = (f"Measured {report.get('measured', '(date not recorded)')} on "
                         f"{report.get('cores', '?')} cores ({report.get('machine', '?')}"
                         + (f", {cpu}" if cpu else "") + "), "
                         f"Python {report.get('python', '?')}, numpy {report.get('numpy', '?')}.")
        if not cpu:  # the first records named no CPU: a reader must not take them for one
            out["header"] += (" Its CPU model was not recorded: this machine kind comes as an "
                              "AMD EPYC or an Intel Xeon, and a figure measured then may be "
                              "of either.")
        # the host each was measured again on (a section may also record its own, e.g.
        # heldout's "host")
        def host_of(name):
            section = report.get(name)
            return (report.get("sections_host", {}).get(name)
                    or (section.get("host") if isinstance(section, dict) else None))
        hosts = {name: h for name in later if (h := host_of(name))}
        if later:
            out["header"] += " Sections measured again since: " + "; ".join(
                f"{name} {when}" + (f" on {hosts[name].get('model', '?')}" if name in hosts
                                    else " (host not recorded)")
                + (f" (shown on {SHOWN_ELSEWHERE[name]})" if name in SHOWN_ELSEWHERE else "")
                for name, when in sorted(later.items(), key=lambda kv: kv[1])) + "."
    if "loop_seconds" in report:  # dated, and set beside the varied loops' speed-up, which
        # is timed on another footing: a reader must see why the two differ
        when = later.get("loops", report.get("measured", "(date not recorded)"))
        out["loops"] = (f"*One-loop timings measured {when}*, each engine as `score_loop` "
                        "runs it (tslearn with the process's default numba threads, the fast "
                        f"engine {_threads_of({'fast_threads': report.get('loop_threads', 1)})})"
                        ", on one scenario.")
        if "spread" in report:
            out["loops"] += (" The speed-up across varied loops below times each engine on "
                             "one thread, over many scenarios and group sizes; that is the "
                             "figure the speed-up target is judged on"
                             + (f" (measured {later['spread']})" if "spread" in later else "")
                             + ".")
    if "heldout" in report:
        h = report["heldout"]
        host = h.get("host", {})
        when = later.get("heldout", report.get("measured", "(date not recorded)"))
        out["heldout"] = (f"*Measured {when} on {host.get('model', '?')}* "
                          f"({host.get('llvm_cpu', '?')}, {host.get('lanes', '?')} float64 "
                          f"lanes): {h['loops']} loops, the engines taking turns on each "
                          f"(each with its default threads: tslearn on numba's, the fast "
                          f"engine {_threads_of(h)}), "
                          f"the fast engine {h['speedup']:.1f} times faster in wall time "
                          f"({h['cpu_speedup']:.1f} times in CPU time), labels and scores "
                          f"identical on {h['identical']} of {h['loops']}"
                          + (f"; the median of {len(h['rounds'])} rounds, which ranged "
                             f"{_span(h['rounds'], 'speedup', '.1f')} times (tslearn "
                             f"{_span(h['rounds'], 'tslearn_seconds', '.1f')} s, fast "
                             f"{_span(h['rounds'], 'fast_seconds', '.2f')} s)"
                             if h.get("rounds") else "")
                          + (f". Scored side by side, as a search scores a block of its loops "
                             f"(`score_loops`: the loops' clusters share the kernel's vectors), "
                             f"the same loops took {h['side_by_side_seconds']:.2f} s, "
                             f"{h['side_by_side_speedup']:.1f} times faster than tslearn "
                             f"(rounds {_span(h['rounds'], 'side_by_side_speedup', '.1f')}), "
                             f"identical on {h['side_by_side_identical']} of {h['loops']}"
                             if "side_by_side_seconds" in h else "")
                          + (". The rows marked *alone* ran the fast engine by itself in a "
                             "child process, with no tslearn between its loops (warmer "
                             "caches), each set against the rounds' median tslearn time"
                             if "native_alone" in h else "")
                          + ". The same machine kind comes as an AMD EPYC or an Intel Xeon: a "
                          "speed-up is a figure of one host.")
    if report.get("heldout_hosts"):
        out["heldout_hosts"] = _hosts_line(report["heldout_hosts"])
    if "threads" in report:
        out["threads"] = _threads_line(report["threads"],
                                       later.get("threads", report.get("measured")))
    if "agreement" in report:
        a = report["agreement"]
        out["agreement"] = (f"Identical labels (up to a swap) on {a['identical_labels']} of "
                            f"{a['loops']} random loops; largest score difference where they "
                            f"agree: {a['max_abs_score_diff']:.1e}.")
    if "spread" in report:
        sp = report["spread"]
        tp = sp["throughput"]
        out["spread"] = (
            f"Over {sp['loops']} varied loops (every Table 2 scenario and Exp 5's pair, both "
            f"readings, 5-20 environments per group, both thrust samplers) the fast engine is "
            f"{sp['median']:.1f}x faster than tslearn per loop (median; 10th-90th percentile "
            f"{sp['p10']:.1f}x-{sp['p90']:.1f}x), with identical labels and scores on "
            f"{sp['identical']} of them"
            + (f"; its scalar kernels, timed on the same loops, are {sp['scalar']['median']:.1f}x "
               f"(so the lockstep kernels gain {sp['lockstep_over_scalar']['median']:.2f}x per "
               f"loop, the median of the per-loop ratios, not the ratio of the two medians)"
               if "scalar" in sp else "")
            + f". On 2 cores, {tp['loops']} loops take "
            f"{tp['tslearn_2_threads']:.1f} s with tslearn on its own 2 numba threads and "
            f"{tp['fast_2_workers']:.1f} s with the fast engine on 2 workers "
            f"({tp['tslearn_2_threads'] / tp['fast_2_workers']:.1f}x).")
    if "time_shares" in report:
        t = report["time_shares"]
        line = (f"{t['loops']} loops, {t['iterations']} k-means iterations, "
                f"{t['seconds']:.2f} s under cProfile")
        out["time"] = line + (f" (measured {later['profile']})" if "profile" in later else "") + "."
        if "ns_per_cell_value" in t:
            out["cells"] = (
                "Nearly all of a loop is soft-DTW arithmetic that has to match tslearn's "
                "operation for operation: 120 x 120 cells per pair of series, "
                f"{t['ns_per_cell_value']:.2f} ns per cell for a value and "
                f"{t['ns_per_cell_value_and_gradient']:.2f} ns for a value with its gradient "
                "on this machine"
                + (f" with the lockstep kernels ({t['ns_per_cell_scalar']['value']:.2f} and "
                   f"{t['ns_per_cell_scalar']['value_and_gradient']:.2f} ns with the scalar "
                   "ones)" if "ns_per_cell_scalar" in t else "")
                + ". "
                + (_gradient_split(t) if "ns_per_cell_costs" in t else "")
                + "That, not Python, is where a clustering loop spends its time; the "
                "multirotor's flights and Experiment 12's closed-loop episodes (no clustering) "
                "add their own, experiment by experiment below.")
    if "builds" in report:  # each host's latest record, oldest first (bench.BY_HOST)
        hosts = report.get("builds_hosts") or {"": report["builds"]}
        out["builds"] = " ".join(_builds_line(b, report.get("cores"))
                                 for _, b in _by_date(hosts))
    if "closed_loop" in report:
        c = report["closed_loop"]
        line = (f"Experiment 12 at the paper profile: about {c['estimated_cpu_seconds'] / 60:.1f} "
                f"CPU-minutes of flights, estimated from the mean of the flights timed above")
        if "measured_seconds" in c:
            line = (f"Experiment 12 at the paper profile, measured (`{c['measured_command']}`, "
                    f"empty cache): {c['measured_seconds'] / 60:.1f} min wall, "
                    f"{c['measured_cpu_seconds'] / 60:.1f} CPU-minutes (target: "
                    f"{TARGETS['closed_loop']})")
            in_fill = fill_cpu_seconds(report, ("exp12",))
            if in_fill is not None:  # the fill table times Exp 12 too: say why they differ
                line += (f"; the paper build's fill table above shows {in_fill / 60:.1f} "
                         f"CPU-minutes for it, from another run (the whole book's fill, timed entry by "
                         f"entry with `--times`), not this one")
        out["closed_loop"] = line + "."
    if "cluster" in report:
        c = report["cluster"]
        one, tasks = sorted(c["one_task_seconds"]), sorted(c["sample_tasks_seconds"])
        med = statistics.median
        out["cluster"] = (
            f"Measured on a local cluster of {c['workers']} one-thread workers "
            f"(`make bench ONLY=cluster`), one CEM run of {c['experiment']} "
            f"({c['n_samples']} samples x {c['max_iter']} iterations): {med(one):.1f} s as one "
            f"task ({one[0]:.1f}-{one[-1]:.1f} s over {len(one)} runs) and {med(tasks):.1f} s "
            f"with its samples as tasks ({tasks[0]:.1f}-{tasks[-1]:.1f} s), "
            f"{med(one) / med(tasks):.1f}x; "
            + ("the same rows both ways." if c["same_rows"] else
               "**the rows differed**."))
    p = report.get("paper_profile", {})
    if "measured_seconds" in p:
        out["paper"] = "Against the target: " + "; ".join(_paper_verdicts(
            p, report.get("cold_compile"))) + "."
        now = n_loops_total("paper")
        if "loops" in p and p["loops"] != now:
            more = now > p["loops"]
            out["paper"] += (
                f" **This measurement is of an earlier paper profile**: {p['loops']} loops "
                f"(before cache sharing) then, {now} now (the sizing of Exps 7-12, "
                f"`uavwind.study.sizing`), so today's build does "
                + ("more work than this figure shows." if more else
                   "less work than this figure shows."))
    if p.get("by_experiment") and "measured_seconds" in p:
        t = pd.DataFrame(p["by_experiment"])
        cpu = t["cpu_seconds"].sum()
        by_reading = t.groupby("reading")["cpu_seconds"].sum() / cpu * 100
        top = t.sort_values("cpu_seconds", ascending=False).head(3)
        out["fill"] = (
            f"Filling the result cache took {p['fill_seconds'] / 60:.1f} of the build's "
            f"{p['measured_seconds'] / 60:.1f} min and {cpu / 60:.0f} CPU-minutes for "
            f"{t['rows'].sum()} result rows (loops, CEM samples, closed-loop belief reports; "
            + ", ".join(f"{share:.0f}% for entries both readings share" if r == "both"
                        else f"{share:.0f}% under the {r} reading only"
                        for r, share in by_reading.items())
            + "). The largest: "
            + "; ".join(f"{r.experiment} ({r.reading}) {r.share:.0f}%"
                        for r in top.itertuples())
            + ".")
        # the rest of the build unchanged
        budget = _T.wall_minutes * 60 - (p["measured_seconds"] - p["fill_seconds"])
        cores = report.get("cores", 2)
        if budget > 0 and cpu > budget * cores:
            out["fill"] += (
                f" For the build to fit in {_T.wall_minutes:g} minutes with the rest of it "
                f"unchanged, the fill would have {budget:.0f} s on {cores} cores: "
                f"{cpu / (budget * cores):.1f}x fewer CPU-seconds than it used.")
        elif budget > 0:
            out["fill"] += f" The fill fits in a {_T.wall_minutes:g}-minute build on these cores."
    return out


def _paper_verdicts(p, compile_=None):
    """One phrase per part of :data:`PAPER_TARGET`: met, or missed by how much."""
    wall = p["measured_seconds"] / 60
    out = [f"{wall:.1f} min wall, " + ("met" if wall <= _T.wall_minutes else
                                       f"{wall / _T.wall_minutes:.1f}x the "
                                       f"{_T.wall_minutes:g} minutes")]
    gb = f"{_T.memory_mib / 1024:g} GB"
    for key, how in (("peak_tree_rss_mib", "RSS"), ("peak_tree_pss_mib", "PSS")):
        if key in p:
            mib = p[key]
            out.append(f"peak memory {mib:.0f} MiB ({how} summed over the process tree), "
                       + (f"under {gb}" if mib < _T.memory_mib
                          else f"{mib - _T.memory_mib:.0f} MiB over {gb}"))
    if "cpu_percent" in p:
        cpu = p["cpu_percent"]
        # a floor, not a ceiling: "under 190%" beside the memory's "under 2 GB" read as met
        out.append(f"CPU {cpu:.0f}%, " + ("met" if cpu > _T.cpu_percent else
                                          f"{_T.cpu_percent - cpu:.0f} points below "
                                          f"{_T.cpu_percent:g}%"))
    if compile_:
        c = compile_["import"] + compile_["softdtw_serial"]
        limit = _T.compile_seconds
        out.append(f"cold compile (import and the kernels a loop uses) {c:.1f} s, "
                   + (f"under {limit:g} s" if c < limit else f"{c - limit:.1f} s over {limit:g} s"))
    return out
