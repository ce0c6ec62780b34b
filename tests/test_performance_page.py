"""The performance page's presentation, from a report, without a browser."""
from uavwind.performance import report_tables, summary_lines

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
                                "unique_loops": 17580, "measured_seconds": 1200.0,
                                "cpu_percent": 196.4, "measured_command": "make book"},
              "cold_compile": {"import": 0.8, "softdtw_serial": 17.4, "first_loop_rest": 3.0,
                               "softdtw_threaded": 14.0, "process": 36.0}}
    t = report_tables(report)
    assert t["paper"].loc["CPU use over the run (% of one core)", "value"] == "196"
    assert t["paper"].loc["cache entries (chunks of <= 50 loops, whole CEM runs)", "value"] == "346"
    assert t["compile"].loc["soft-DTW kernels a loop uses (softdtw.warmup())",
                            "wall time (s)"] == 17.4
