"""The performance page's presentation, from a report, without a browser."""
from uavwind.report.performance import report_tables, summary_lines

REPORT = {"measured": "2026-11-22 12:00 UTC", "cores": 2, "machine": "x86_64", "python": "3.11.7",
          "numpy": "2.4.6",
          "spread": {"loops": 100, "median": 8.2, "p10": 5.1, "p90": 12.3, "min": 3.0, "max": 20.5,
                     "identical": 100, "throughput": {"loops": 20, "tslearn_2_threads": 40.0,
                                                      "fast_2_workers": 5.0}},
          "agreement": {"loops": 200, "identical_labels": 200, "max_abs_score_diff": 0.0}}


def test_spread_and_agreement_sentences_come_from_the_report():
    lines = summary_lines(REPORT)
    assert "8.2x faster" in lines["spread"] and "5.1x-12.3x" in lines["spread"]
    assert "(8.0x)" in lines["spread"]
    assert "200 of 200" in lines["agreement"]
    t = report_tables(REPORT)["spread"]
    assert t.loc["median", "speed-up over tslearn"] == 8.2


def test_an_empty_report_gives_no_sentences():
    assert summary_lines({}) == {} and report_tables({}) == {}


def test_paper_and_compile_tables_show_the_new_figures():
    report = {"paper_profile": {"loops": 12880, "engine": "fast", "entries": 346,
                                "unique_loops": 17580, "measured_seconds": 1200.0, "fill_seconds": 1140.0,
                                "cpu_percent": 196.4, "measured_command": "make book",
                                "by_experiment": [
                                    {"experiment": "exp1", "reading": "inferred", "entries": 4,
                                     "rows": 200, "cpu_seconds": 60.0, "share": 75.0},
                                    {"experiment": "exp6", "reading": "halves", "entries": 1,
                                     "rows": 100, "cpu_seconds": 20.0, "share": 25.0}]},
              "cold_compile": {"import": 0.8, "softdtw_serial": 17.4, "first_loop_rest": 3.0,
                               "softdtw_threaded": 14.0, "process": 36.0}}
    t = report_tables(report)
    assert t["paper"].loc["CPU use over the run (% of one core)", "value"] == "196"
    assert t["paper"].loc["cache entries (chunks of <= 50 loops, whole CEM runs)", "value"] == "346"
    assert t["paper"].loc["of which filling the result cache (min)", "value"] == "19.0"
    assert t["fill"].loc[("exp1", "inferred"), "CPU (min)"] == 1.0
    assert t["fill"].loc[("exp6", "halves"), "CPU per row (ms)"] == 200.0
    assert "measured on" not in t["paper"].index  # a record from before hosts were kept
    report["paper_profile"]["host"] = {"model": "Some Xeon", "llvm_cpu": "cpu", "lanes": 8}
    assert report_tables(report)["paper"].loc["measured on", "value"] == "Some Xeon (cpu, 8 lanes)"
    assert "how it was run" not in report_tables(report)["paper"].index
    report["paper_profile"]["measured_how"] = "make bench FULL=1 FRESH=1: a fresh clone of .."
    assert (report_tables(report)["paper"].loc["how it was run", "value"]
            == "a fresh clone, empty result and numba caches")
    report["paper_profile"]["measured_how"] = "make bench FULL=1: the venv and numba cache .."
    assert (report_tables(report)["paper"].loc["how it was run", "value"]
            == "the working tree, its numba cache as it was")
    line = summary_lines({**report, "cores": 2, "machine": "x86_64", "python": "3.11",
                          "numpy": "2"})["fill"]
    assert "19.0 of the build's 20.0 min" in line and "300 result rows (loops, CEM samples" in line
    assert "75% under the inferred reading only" in line
    assert line.count("exp1 (inferred) 75%") == 1 and "fits in a 10-minute build" in line
    slow = {**report["paper_profile"], "by_experiment": [
        {**r, "cpu_seconds": 10 * r["cpu_seconds"] * 27} for r in
        report["paper_profile"]["by_experiment"]]}
    line = summary_lines({**report, "paper_profile": slow, "cores": 2, "machine": "x86_64",
                          "python": "3.11", "numpy": "2"})["fill"]
    assert "would have 540 s on 2 cores: 20.0x fewer CPU-seconds" in line
    assert t["compile"].loc["soft-DTW kernels a loop uses (softdtw.warmup())",
                            "wall time (s)"] == 17.4


def test_the_paper_profile_says_which_targets_it_meets_and_by_how_much_it_misses():
    compile_ = {"import": 2.3, "softdtw_serial": 28.4}
    met = {"measured_seconds": 540.0, "peak_tree_rss_mib": 1500.0, "cpu_percent": 195.0}
    line = summary_lines({"paper_profile": met, "cold_compile": compile_})["paper"]
    assert "9.0 min wall, met" in line and "under 2 GB" in line and "CPU 195%, met" in line
    assert "30.7 s, 0.7 s over 30 s" in line
    missed = {"measured_seconds": 3432.0, "peak_tree_rss_mib": 2132.0, "cpu_percent": 180.0,
              "peak_tree_pss_mib": 1700.0}
    line = summary_lines({"paper_profile": missed})["paper"]
    assert "57.2 min wall, 5.7x the 10 minutes" in line
    assert "2132 MiB (RSS summed over the process tree), 84 MiB over 2 GB" in line
    assert "1700 MiB (PSS summed over the process tree), under 2 GB" in line
    assert "CPU 180%, 10 points below 190%" in line and "compile" not in line
    assert "earlier paper profile" not in line  # no loop count recorded: nothing to compare
    from uavwind.study import n_loops_total
    now = n_loops_total("paper")
    line = summary_lines({"paper_profile": {**missed, "loops": now}})["paper"]
    assert "earlier paper profile" not in line
    for then, word in ((now - 1000, "more"), (now + 1000, "less")):
        line = summary_lines({"paper_profile": {**missed, "loops": then}})["paper"]
        assert (f"earlier paper profile**: {then} loops (before cache sharing) then, {now} now"
                in line) and line.endswith(f"{word} work than this figure shows."), line
    header = summary_lines({"measured": "2026-11-22", "sections_measured_later": {
        "spread": "2026-11-24 03:00 UTC", "paper": "2026-11-24 04:44 UTC"}})["header"]
    assert header.endswith("since: spread 2026-11-24 03:00 UTC (host not recorded); paper "
                           "2026-11-24 04:44 UTC (host not recorded).")
    assert "CPU model was not recorded" in header  # nor for the first measurement
    header = summary_lines({"measured": "2026-11-22", "sections_measured_later": {
        "probe": "2026-11-27 22:47 UTC"}, "probe": {"host": {"model": "Xeon"}}})["header"]
    assert header.endswith("probe 2026-11-27 22:47 UTC on Xeon.")  # its own record (heldout)
    assert "not recorded" not in summary_lines({"measured": "2026-11-22",
                                                "cpu": {"model": "AMD EPYC"}})["header"]
    header = summary_lines({"measured": "2026-11-22", "sections_measured_later": {
        "exp13": "2026-11-28 03:50 UTC"}, "sections_host": {
        "exp13": {"model": "Intel(R) Xeon(R) Processor @ 2.50GHz", "lanes": 8}}})["header"]
    assert header.endswith("since: exp13 2026-11-28 03:50 UTC on Intel(R) Xeon(R) Processor "
                           "@ 2.50GHz (shown on the Exp 13 page).")


def test_the_closed_loop_section_shows_flights_and_the_measured_run():
    report = {"closed_loop": {
        "per_flight": {"point mass / greedy": {"median": 0.03, "p10": 0.02, "p90": 0.05,
                                               "flights": 12}},
        "estimated_cpu_seconds": 300.0, "flights_timed_per_scenario": 4}}
    t = report_tables(report)["closed_loop"]
    assert t.loc["point mass / greedy", "median (s)"] == 0.03
    assert "5.0 CPU-minutes" in summary_lines(report)["closed_loop"]
    report["closed_loop"].update(measured_seconds=261.0, measured_cpu_seconds=510.0,
                                 measured_command="python -m uavwind run exp12 --profile paper")
    line = summary_lines(report)["closed_loop"]
    assert "4.3 min wall" in line and "8.5 CPU-minutes" in line
    # a command as code: Markdown would turn its "--" into an en-dash a copy cannot run
    assert "(`python -m uavwind run exp12 --profile paper`, empty cache)" in line
    assert "fill table" not in line  # no paper fill on file: nothing to reconcile
    report["paper_profile"] = {"by_experiment": [  # the paper fill times Exp 12 too, under one reading
        {"experiment": "exp12", "reading": "halves", "entries": 6, "rows": 10, "share": 3.0,
         "cpu_seconds": 258.0}]}
    line = summary_lines(report)["closed_loop"]
    assert ("8.5 CPU-minutes (target: " in line and "the paper build's fill table above shows "
            "4.3 CPU-minutes for it, from another run" in line), line


def test_the_cluster_sentence_gives_both_ways_their_medians_spread_and_ratio():
    c = {"experiment": "exp6", "workers": 2, "n_samples": 12, "n_elite": 3, "max_iter": 4,
         "samples": 48, "one_task_seconds": [15.0, 13.0, 14.0],
         "sample_tasks_seconds": [8.0, 7.0, 9.5], "same_rows": True}
    line = summary_lines({**REPORT, "cluster": c})["cluster"]
    assert "12 samples x 4 iterations" in line and "2 one-thread workers" in line
    assert "14.0 s as one task (13.0-15.0 s over 3 runs)" in line
    assert "8.0 s with its samples as tasks (7.0-9.5 s)" in line and "1.8x" in line
    assert line.endswith("the same rows both ways.")
    line = summary_lines({**REPORT, "cluster": {**c, "same_rows": False}})["cluster"]
    assert "**the rows differed**" in line
    assert "cluster" not in summary_lines(REPORT)


def test_the_cells_sentence_splits_the_gradients_extra_cost_from_the_report():
    shares = {"loops": 20, "iterations": 500, "seconds": 2.0, "shares": {}, "lanes": 4,
              "ns_per_cell_value": 0.8, "ns_per_cell_value_and_gradient": 4.0,
              "ns_per_cell_value_and_gradient_both_clusters": 2.9,
              "ns_per_cell_scalar": {"value": 3.9, "value_and_gradient": 5.6,
                                     "value_and_gradient_both_clusters": 5.4},
              "ns_per_cell_costs": {"squared distance": 0.25, "sqrt(.) ** 2": 0.95}}
    line = summary_lines({"time_shares": shares})["cells"]
    # 20 series in 5 vectors of 4 lanes: no lane idle, 2.9 ns a lane-cell, 2.1 over the value
    assert "20 series in one call, 5 vectors of 4 lanes) takes 2.90 ns for the value with its gradient, " in line
    assert "idle" not in line  # the table's 2.90 is the same figure: nothing to explain
    assert "2.10 ns more than a value; 0.70 ns of that (33%)" in line
    shares["lanes"] = 8  # 3 vectors of 8: 4 of 24 lanes idle, 2.9 * 20 / 24 a lane-cell
    line = summary_lines({"time_shares": shares})["cells"]
    assert "3 vectors of 8 lanes) takes 2.42 ns" in line and "1.62 ns more" in line
    # the cells table shows 2.90 for the same run: the sentence says why it reads 2.42
    # 2.42 = 2.90 * 20 / 24: the table divides by the 20 series, the sentence by 24 lanes
    assert "(the table's 2.90 ns divides the time by the 20 series in use; this figure " \
           "divides it by all 24 lanes computed, 4 of them idle in the last vector)" in line
    del shares["ns_per_cell_costs"]  # a record from before the split: no such sentence
    assert "square root" not in summary_lines({"time_shares": shares})["cells"]


def test_the_one_loop_table_says_when_it_was_measured_and_on_which_footing():
    loops = {"10env_120steps": {"tslearn": 2.0, "fast": 0.1, "speedup": 20.0}}
    old = {**REPORT, "loop_seconds": loops,
           "sections_measured_later": {"spread": "2026-11-24 02:59 UTC"}}
    line = summary_lines(old)["loops"]
    assert line.startswith("*One-loop timings measured 2026-11-22 12:00 UTC*, each engine "
                           "as `score_loop` runs it (tslearn with the process's default numba "
                           "threads, the fast engine serially)")
    assert "times each engine on one thread" in line and "(measured 2026-11-24 02:59 UTC)." in line
    new = {**old, "sections_measured_later": {"loops": "2026-11-27 15:00 UTC"}}
    assert "measured 2026-11-27 15:00 UTC*" in summary_lines(new)["loops"]
    alone = {k: v for k, v in new.items() if k != "spread"}
    assert "one thread" not in summary_lines(alone)["loops"]


def test_the_held_out_check_says_which_host_it_ran_on():
    """A speed-up is a figure of one host: the held-out section names the CPU model, LLVM's
    name for it and the lanes, and shows the AVX2 code's figure beside the native one."""
    rep = {"measured": "2026-11-27 21:56 UTC",
           "heldout": {"host": {"model": "Some CPU @ 2.5GHz", "llvm_cpu": "cascadelake",
                                "lanes": 8},
                       "loops": 12, "identical": 12, "fast_seconds": 2.0,
                       "tslearn_seconds": 40.0, "speedup": 20.0, "cpu_speedup": 21.0,
                       "avx2": {"fast_seconds": 2.5, "speedup": 16.0, "identical": 11}}}
    line = summary_lines(rep)["heldout"]
    assert "Some CPU @ 2.5GHz" in line and "cascadelake" in line and "8 float64 lanes" in line
    assert "20.0 times faster" in line and "21.0 times in CPU time" in line
    t = report_tables(rep)["heldout"]
    assert t["speed-up"].tolist() == [20.0, 16.0] and t["identical"].tolist() == ["12/12",
                                                                                  "11/12"]
    assert "AVX2" in t.index[1]
    assert "rounds" not in line  # a record of one round says nothing of a range
    rep["heldout"]["rounds"] = [{"fast_seconds": f, "tslearn_seconds": ts, "speedup": ts / f}
                                for f, ts in ((2.0, 40.0), (1.9, 30.4), (2.1, 44.1))]
    line = summary_lines(rep)["heldout"]
    assert ("the median of 3 rounds, which ranged 16.0-21.0 times (tslearn 30.4-44.1 s, "
            "fast 1.90-2.10 s)") in line
    assert "side by side" not in line and "alone" not in line
    # the loops side by side (score_loops), and the native code alone beside the AVX2 code
    for r, sbs in zip(rep["heldout"]["rounds"], (1.6, 1.9, 1.5)):
        r.update(side_by_side_seconds=sbs, side_by_side_speedup=r["tslearn_seconds"] / sbs)
    rep["heldout"].update(side_by_side_seconds=1.6, side_by_side_speedup=25.0,
                          side_by_side_identical=12)
    rep["heldout"]["native_alone"] = {"fast_seconds": 1.6, "identical": 12}
    line = summary_lines(rep)["heldout"]
    assert ("the same loops took 1.60 s, 25.0 times faster than tslearn (rounds "
            "16.0-29.4), identical on 12 of 12") in line
    assert "The rows marked *alone* ran the fast engine by itself" in line
    t = report_tables(rep)["heldout"]
    assert t["speed-up"].tolist() == [20.0, 25.0, 16.0, 25.0]
    assert [i.split(", ", 1)[1] for i in t.index] == [
        "native code, serially", "native code, alone",
        "AVX2 code (NUMBA_CPU_NAME=haswell), alone",
        "native code, the loops side by side (score_loops)"]
    assert "the fast engine serially)" in line  # a record before 2026-12-04: score_loop serial
    rep["heldout"]["fast_threads"] = 2  # from 2026-12-04: the engine's default threads
    assert report_tables(rep)["heldout"].index[0] == "8 lanes, native code, on 2 threads"
    assert ("(each with its default threads: tslearn on numba's, the fast engine on 2 "
            "threads)" in summary_lines(rep)["heldout"])
    del rep["heldout"]["fast_threads"]
    # a record from 2026-12-02 on names the AVX2 child's code and its own lanes
    rep["heldout"]["avx2"].update(lanes=4, code="NUMBA_CPU_NAME=haswell, no AVX-512")
    t = report_tables(rep)["heldout"]
    assert t.index[2] == "4 lanes, AVX2 code (NUMBA_CPU_NAME=haswell, no AVX-512), alone"
    assert t.index[0].startswith("8 lanes, native code")


def test_each_hosts_held_out_record_is_kept_and_the_gap_is_put_where_it_is():
    """The held-out check on each host kind, side by side, oldest first: the sentence says
    whose time moves between the hosts (the fast engine's or tslearn's), from the records."""
    def rec(when, model, lanes, fast, slow):
        return {"measured": when, "commit": "abc1234",
                "host": {"model": model, "llvm_cpu": "cpu", "lanes": lanes}, "loops": 12,
                "identical": 12, "fast_seconds": fast, "tslearn_seconds": slow,
                "speedup": slow / fast, "side_by_side_speedup": slow / fast * 1.1,
                "rounds": [{"speedup": slow / fast - 1}, {"speedup": slow / fast + 1}]}
    one = {"heldout_hosts": {"EPYC": rec("2026-12-01 10:00 UTC", "EPYC", 4, 2.0, 60.0)}}
    line = summary_lines(one)["heldout_hosts"]
    assert line.startswith("*The held-out check has run on one host so far:*")
    assert "the fast engine took 2.00 s (serially) and tslearn 60.0 s, 30.0 times" in line
    two = {"heldout_hosts": {**one["heldout_hosts"],
                             "Xeon": rec("2026-11-28 10:00 UTC", "Xeon", 8, 2.5, 40.0)}}
    line = summary_lines(two)["heldout_hosts"]
    assert line.index("on Xeon (8 lanes") < line.index("on EPYC (4 lanes")  # oldest first
    assert ("the fast engine's time differs by 1.25 times and tslearn's by 1.50 times: the "
            "speed-up moves with tslearn's own time, not the fast engine's") in line
    t = report_tables(two)["heldout_hosts"]
    assert list(t.index) == ["Xeon (cpu, 8 lanes)", "EPYC (cpu, 4 lanes)"]
    assert t["speed-up"].tolist() == [16.0, 30.0] and t["rounds"].tolist() == ["15.0-17.0",
                                                                               "29.0-31.0"]
    # the engine's own time moving more than tslearn's is said so, not the other way round
    two["heldout_hosts"]["Xeon"] = rec("2026-11-28 10:00 UTC", "Xeon", 8, 4.0, 64.0)
    assert "moves with the fast engine's own time more than tslearn's" in summary_lines(
        two)["heldout_hosts"]
    # records of one commit say nothing of the code; of several, they name them
    assert "different commits" not in summary_lines(two)["heldout_hosts"]
    two["heldout_hosts"]["Xeon"]["commit"] = "def5678"
    assert ("of different commits (def5678, abc1234), so the fast engine's time also moves "
            "with its code") in summary_lines(two)["heldout_hosts"]
    assert "with its threads" not in summary_lines(two)["heldout_hosts"]
    # a record whose fast engine ran on threads beside serial ones: said, host by host
    two["heldout_hosts"]["EPYC"]["fast_threads"] = 2
    line = summary_lines(two)["heldout_hosts"]
    assert "took 2.00 s (on 2 threads)" in line and "took 4.00 s (serially)" in line
    assert "and with its threads (the records did not all run it the same way" in line
    assert report_tables(two)["heldout_hosts"]["fast engine"].tolist() == ["serially",
                                                                           "on 2 threads"]


def test_a_section_measured_on_another_host_keeps_the_first_hosts_record(monkeypatch):
    """``ONLY=heldout make bench`` on a second host adds its record, dated, to
    ``heldout_hosts`` and keeps the first host's (bench.merged); the plain record is the
    latest; a section not kept by host gets no such record."""
    import importlib
    import sys
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    sys.modules.pop("bench", None)
    bench = importlib.import_module("bench")  # always there: a broken import fails, not skips
    a = {"host": {"model": "A"}, "speedup": 16}
    old = {"heldout": a, "heldout_hosts": {"A": {"measured": "day 1", **a}}, "x": 1}
    b = {"host": {"model": "B"}, "speedup": 30}
    out = bench.merged(old, {"heldout": b, "threads": {"host": {"model": "B"}}}, "day 2")
    assert out["heldout"] == b and out["x"] == 1
    assert out["threads_hosts"] == {"B": {"measured": "day 2", "host": {"model": "B"}}}
    # a section that names no host of its own is filed under the machine that measured it
    c = bench.merged(out, {"cold_compile": {"process": 9.0}}, "day 4", {"model": "C"})
    assert c["cold_compile_hosts"]["C"] == {"measured": "day 4", "host": {"model": "C"},
                                            "process": 9.0}
    assert out["heldout_hosts"] == {"A": {"measured": "day 1", **a},
                                    "B": {"measured": "day 2", **b}}
    again = bench.merged(out, {"heldout": {**a, "speedup": 17}}, "day 3")
    assert again["heldout_hosts"]["A"] == {"measured": "day 3", **a, "speedup": 17}
    assert again["heldout_hosts"]["B"] == out["heldout_hosts"]["B"]
    assert "builds" in bench.BY_HOST  # the README's build times are a host's too


def test_the_threads_section_sets_threads_against_serial_idle_and_beside_busy_cores():
    """The threads record: a table of both machines and the three kernel settings, and a
    sentence whose ratios come from its medians (a gain on the idle machine, a loss beside
    busy cores), which says when the runs were not identical."""
    def case(serial, threads, passive):
        return {name: {"wall_seconds": w, "cpu_seconds": c, "wall_range": [w - 0.1, w + 0.1]}
                for name, (w, c) in (("serial", serial), ("threads", threads),
                                     ("threads, passive wait", passive))}
    rep = {"measured": "2026-11-28 15:00 UTC",
           "threads": {"host": {"model": "Some CPU"}, "loops": 6, "rounds": 3, "busy_cores": 1,
                       "threads": 2, "identical": True,
                       "cases": {"idle": case((1.0, 1.0), (0.8, 1.5), (0.9, 1.1)),
                                 "busy": case((1.1, 1.1), (3.3, 3.4), (1.65, 1.2))}}}
    line = summary_lines(rep)["threads"]
    assert "*Measured 2026-11-28 15:00 UTC on Some CPU*" in line
    assert "ran 1.25 times as fast as the serial ones" in line
    assert "with 1 other core busy, 3.00 times slower than them" in line
    assert "using 3.40 CPU seconds against 1.10" in line
    assert "1.50 times slower than them with `OMP_WAIT_POLICY=PASSIVE`" in line
    assert "identical in every run" in line
    rep["threads"]["identical"] = False
    assert "**not** identical" in summary_lines(rep)["threads"]
    t = report_tables(rep)["threads"]
    assert t.loc[("1 other core busy", "threads"), "wall (s)"] == 3.3
    assert t.loc[("idle", "serial"), "wall range (s)"] == "0.90-1.10"
    assert len(t) == 6
    # from 2026-12-04: serial against the helper threads, no OpenMP pool
    for c in rep["threads"]["cases"].values():
        del c["threads, passive wait"]
    rep["threads"]["identical"] = True
    line = summary_lines(rep)["threads"]
    assert "OMP_WAIT_POLICY" not in line and "shared with a helper thread" in line
    assert len(report_tables(rep)["threads"]) == 4


def test_the_builds_sentence_gives_every_run_against_its_target():
    run = lambda w, code=0: {"wall_seconds": w, "cpu_seconds": 2 * w, "exit": code,
                             "last_line": "1075 passed"}
    b = {"make test": {"runs": [run(600.0), run(650.0)], "target_seconds": 420},
         "quick book": {"runs": [run(170.0), run(175.0, 2)], "target_seconds": 180},
         "host": {"model": "Xeon", "lanes": 8}, "commit": "abc1234", "neuralfly": True}
    line = summary_lines({"builds": b})["builds"]
    assert line.startswith("*Measured on Xeon* (8 float64 lanes), each on a fresh clone of "
                           "abc1234")
    assert "`make test` 600 s and 650 s (target 7 min: missed by 230 s (1.5x))" in line
    assert "`make book PROFILE=quick` 170 s and 175 s (target 3 min: met), **1 run(s) failed**" \
        in line
    b["quick book"]["runs"][1] = run(187.0)  # a miss under a tenth: two decimals, not 1.0x
    assert "(target 3 min: missed by 7 s (1.04x))" in summary_lines({"builds": b})["builds"]
    # a record from before `make check`: its `make test` ran what `make check` runs now
    assert "(target 7 min: missed by 230 s (1.5x)) (every test with the quick book beside " \
        "them: what `make check` runs now);" in line
    b["make check"] = {"runs": [run(800.0), run(820.0)], "target_seconds": 5400}
    now = summary_lines({"builds": b})["builds"]
    assert "; `make check` 800 s and 820 s (target 90 min: met)." in now
    assert "what `make check` runs now" not in now
    # each host's record, dated, oldest first
    epyc = {**b, "host": {"model": "EPYC", "lanes": 4}, "measured": "2026-12-01 22:00 UTC"}
    hosts = {"EPYC": epyc, "Xeon": {**b, "measured": "2026-11-28 15:50 UTC"}}
    line = summary_lines({"builds": epyc, "builds_hosts": hosts})["builds"]
    assert line.startswith("*Measured 2026-11-28 15:50 UTC on Xeon* (8 float64 lanes)")
    assert " *Measured 2026-12-01 22:00 UTC on EPYC* (4 float64 lanes)" in line


def test_the_builds_sentence_sets_each_commands_cpu_against_what_its_target_leaves():
    """A wall time under T on c cores needs at most T x c CPU seconds: a command that used
    more misses its target however its work is spread, and the sentence says by how much."""
    run = lambda w, cpu: {"wall_seconds": w, "cpu_seconds": cpu, "exit": 0,
                          "last_line": "1075 passed"}
    b = {"make test": {"runs": [run(200.0, 380.0), run(210.0, 390.0)], "target_seconds": 300},
         "quick book": {"runs": [run(370.0, 660.0), run(374.0, 672.0)], "target_seconds": 120},
         "host": {"model": "EPYC", "lanes": 4}, "commit": "abc1234", "cores": 2}
    line = summary_lines({"builds": b})["builds"]
    assert ("`make test` 380-390 CPU-s, where 300 s on 2 cores hold 600: the same work fits"
            in line)
    assert ("`make book PROFILE=quick` 660-672 CPU-s, where 120 s on 2 cores hold 240: it needs "
            "2.8x less CPU, however it is spread over the cores" in line)
    # a record that names no cores takes the report's; one core halves the room
    del b["cores"]
    line = summary_lines({"builds": b, "cores": 1})["builds"]
    assert "`make test` 380-390 CPU-s, where 300 s on 1 core hold 300: it needs 1.3x less" in line
    # without any count of cores, the CPU alone
    assert "`make test` 380-390 CPU-s;" in summary_lines({"builds": b})["builds"]


def test_the_benchmark_on_file_gives_tables_and_sentences():
    """The performance page reads benchmarks/benchmark.json: every table a DataFrame, every
    sentence a string (a sentence once landed among the tables and the page failed)."""
    from pathlib import Path

    import pandas as pd

    from uavwind.report.performance import load_report

    report = load_report(Path(__file__).parents[1] / "benchmarks" / "benchmark.json")
    assert report
    assert all(isinstance(t, pd.DataFrame) for t in report_tables(report).values())
    lines = summary_lines(report)
    assert all(isinstance(v, str) for v in lines.values()) and "builds" in lines


def test_each_hosts_record_stands_in_its_own_column_with_its_date_and_commit():
    """host_records: one column per host, each figure with when and at which commit it was
    measured; a figure a host has no record of says so; a figure of no known host is left
    out, not shown as anyone's."""
    from uavwind.report.performance import HOST_FIGURES, host_records
    a = {"model": "AMD EPYC", "llvm_cpu": "znver3", "lanes": 4}
    x = {"model": "Xeon", "llvm_cpu": "rocketlake", "lanes": 8}
    report = {
        "heldout_hosts": {"AMD EPYC": {"measured": "2026-12-07 06:07 UTC", "host": a,
                                       "speedup": 28.49, "commit": "79de3a5",
                                       "machine_load": {"quiet": True}},
                          "Xeon": {"measured": "2026-12-04 05:03 UTC", "host": x,
                                   "speedup": 26.9, "commit": "5329418"}},
        "paper_profile": {"measured_seconds": 1208.7, "measured_commit": "accaeb1", "host": x},
        "sections_measured_later": {"paper": "2026-12-04 04:37 UTC"},
        "cold_compile": {"process": 50.9},  # its host never recorded
    }
    t = host_records(report)
    assert list(t.columns) == ["AMD EPYC (znver3, 4 lanes)", "Xeon (rocketlake, 8 lanes)"]
    assert list(t.index) == list(HOST_FIGURES)
    held = "engine against tslearn, held-out loops [x]"
    assert t.loc[held, "AMD EPYC (znver3, 4 lanes)"] == "28.5 (2026-12-07, 79de3a5, quiet)"
    assert t.loc[held, "Xeon (rocketlake, 8 lanes)"] == "26.9 (2026-12-04, 5329418)"
    paper = "make book (paper), empty cache [min]"
    assert t.loc[paper, "Xeon (rocketlake, 8 lanes)"] == "20.1 (2026-12-04, accaeb1)"
    assert t.loc[paper, "AMD EPYC (znver3, 4 lanes)"] == "not measured"
    assert (t.loc["cold numba compile, one process [s]"] == "not measured").all()
    # a builds record from before the two tiers: its make test is the row of make check
    before = {"make test": {"median_wall_seconds": 268.4}, "quick book": {
        "median_wall_seconds": 150.0}, "commit": "a6e75f7", "measured": "2026-12-04 03:50 UTC"}
    now = {"make test": {"median_wall_seconds": 204.5}, "make check": {
        "median_wall_seconds": 729.6}, "commit": "c9a426d", "measured": "2026-12-07 21:02 UTC"}
    t = host_records({**report, "builds_hosts": {"Xeon": {**before, "host": x},
                                                 "AMD EPYC": {**now, "host": a}}})
    fast, every = list(HOST_FIGURES)[:2]
    assert t.loc[fast].tolist() == ["204 (2026-12-07, c9a426d)", "not measured"]
    assert t.loc[every].tolist() == ["730 (2026-12-07, c9a426d)", "268 (2026-12-04, a6e75f7)"]


def test_a_section_says_whether_anything_else_ran_beside_it(monkeypatch):
    """bench_common.machine_load: the machine's busy CPU minus this process tree's, over the
    wall time, in cores; quiet at most QUIET_CORES; bench._measured files it with every
    record the section writes."""
    import importlib
    import sys
    from pathlib import Path

    monkeypatch.syspath_prepend(str(Path(__file__).resolve().parents[1] / "benchmarks"))
    sys.modules.pop("bench", None)
    common = importlib.import_module("bench_common")
    bench = importlib.import_module("bench")
    busy = common.machine_load((0.0, 100.0, 10.0), (10.0, 118.0, 20.0))  # 8 CPU-s of others
    assert busy == {"seconds": 10.0, "others_cores": 0.8, "quiet": False,
                    "load_1min": busy["load_1min"]}
    assert common.machine_load((0.0, 100.0, 10.0), (10.0, 110.5, 20.0))["quiet"] is True
    assert common.machine_load((0.0, None, 1.0), (1.0, None, 2.0))["quiet"] is None
    snaps = iter([(0.0, 50.0, 5.0), (4.0, 54.0, 9.0)])
    monkeypatch.setattr(bench, "load_snapshot", lambda: next(snaps))
    report = {"old": {"kept": 1}}
    bench._measured(lambda r: r.update(new={"x": 1}), report)
    assert report["new"]["machine_load"]["quiet"] is True and "machine_load" not in report["old"]
