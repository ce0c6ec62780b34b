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
