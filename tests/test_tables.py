"""Summary and comparison tables in the paper's layout; the paper's values."""
import pytest

from uavwind import study as ex
from uavwind.analysis import tables
from uavwind.study.paper import PAPER_FILES, load_paper_values

TINY = {"loops": 2, "long_loops": 3, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


def test_both_readings_are_tabulated_and_compared_as_exp1(tmp_path):
    t4 = load_paper_values("exp1").set_index("scenario")
    for reading in ("inferred", "halves"):
        df = ex.run_experiment("exp1", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                               cases=[0, 2, 3], reading=reading)
        assert (df["reading"] == reading).all()
        assert len(tables.summary_table(df)) == 3
        cmp = tables.comparison_table(df)
        assert list(cmp.index) == [t4.index[k] for k in (0, 2, 3)]
        assert cmp["paper_mean"].tolist() == [t4.iloc[k]["mean"] for k in (0, 2, 3)]
        assert "'" + reading + "' reading" in tables.provenance(df)
    with pytest.raises(ValueError, match="no paper table"):
        tables.comparison_table(df.assign(experiment="exp6"))


def test_paper_values_load_with_sources():
    for exp_id in PAPER_FILES:
        df = load_paper_values(exp_id)
        assert "source" in df.columns and len(df) >= 2
    t4 = load_paper_values("exp1")
    assert t4.set_index("scenario_id").loc[4, "maximum"] == 79.83
    assert t4.set_index(["scenario_id", "long_run"]).loc[(1, True), "mean"] == 79.30
    assert set(load_paper_values("exp2")["n_env"]) == {6, 20}
    with pytest.raises(ValueError, match="unknown experiment"):
        load_paper_values("exp9")


def test_source_commit_marks_a_changed_tree_and_says_unknown_outside_git(monkeypatch):
    import re
    import subprocess

    head = tables.source_commit()
    assert re.fullmatch(r"[0-9a-f]{4,40}|unknown", head)
    marked = tables.source_commit(mark_changes=True)
    assert marked in (head, head + "+changes")
    dirty = [line for line in subprocess.run(
        ["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True,
        text=True, cwd=tables.__file__.rsplit("/", 1)[0]).stdout.splitlines()
        if line.split(None, 1)[-1] != tables.RECORDS_FILE]
    if head != "unknown":
        assert marked == (head + "+changes" if dirty else head)

    # the benchmark's own record (rewritten by every section) does not mark a tree changed;
    # any other tracked file does
    real_run = subprocess.run
    for status, mark in ((" M benchmarks/benchmark.json\n", ""),
                         (" M benchmarks/benchmark.json\n M uavwind/sim/wind.py\n", "+changes"),
                         ("M  uavwind/sim/wind.py\n", "+changes"), ("", "")):
        def fake_git(args, *a, status=status, **kw):
            out = "abc1234" if args[1] == "rev-parse" else status
            return subprocess.CompletedProcess(args, 0, stdout=out, stderr="")
        monkeypatch.setattr(subprocess, "run", fake_git)
        assert tables.source_commit(mark_changes=True) == "abc1234" + mark
        assert tables.source_commit() == "abc1234"
    monkeypatch.setattr(subprocess, "run", real_run)

    def no_git(*args, **kwargs):
        raise FileNotFoundError("git")

    monkeypatch.setattr(subprocess, "run", no_git)
    assert tables.source_commit() == "unknown"
    assert tables.source_commit(mark_changes=True) == "unknown"


def test_pretty_shows_shares_as_percentages_in_side_by_side_tables_too():
    import pandas as pd

    import uavwind as uw
    df = pd.concat({"a": pd.DataFrame({"mean": [1.0], "correct_rate": [0.5]}),
                    "b": pd.DataFrame({"mean": [2.0], "correct_rate": [0.25]})}, axis=1)
    out = uw.pretty(df)
    assert out[("a", "correct (%)")].tolist() == ["50.00"]
    assert out[("b", "correct (%)")].tolist() == ["25.00"]
    assert out[("b", "mean")].tolist() == ["2.00"]


def test_pretty_writes_every_float_with_the_tables_decimals_and_counts_whole():
    """pandas prints a column of whole floats as "100.0" (all zeros as "0.0", halves as
    "50.0") beside another column's "98.50": pretty gives every float column the table's
    decimals, a count (loops) none, and a yes/no column words."""
    import pandas as pd

    import uavwind as uw
    df = pd.DataFrame({"mean": [98.5, 97.25], "correct_rate": [1.0, 1.0],
                       "best_so_far": [0.0, 0.0], "n_loops": [2.0, 4.0],
                       "noise_bias": [0.5, 1.0], "decided": [True, False]})
    out = uw.pretty(df)
    assert out["correct (%)"].tolist() == ["100.00", "100.00"]
    assert out["best so far"].tolist() == ["0.00", "0.00"]
    assert out["loops"].tolist() == [2, 4]
    assert out["mean"].tolist() == ["98.50", "97.25"]
    assert out["noise bias (m)"].tolist() == ["0.50", "1.00"]
    assert out["placed by the one rule"].tolist() == ["yes", "no"]
    assert uw.pretty(df, precision=1)["correct (%)"].tolist() == ["100.0", "100.0"]


def test_a_missing_value_is_shown_as_a_dash_not_nan():
    import numpy as np
    import pandas as pd

    import uavwind as uw
    from uavwind.report.display import MISSING
    df = pd.DataFrame({"mean": [1.0, 2.0], "motor_limited": [np.nan, 0.25]})
    out = uw.pretty(df)
    col = [c for c in out.columns if c != "mean"][0]
    # a share, shown as the prose quotes it: a percentage (issue 67: 0.02 beside "3.1%")
    assert col == "motor limited (%)"
    # and with the table's decimals, though the dash makes the column text ("2.0" beside "2.09")
    assert out[col].tolist() == [MISSING, "25.00"] and out["mean"].tolist() == ["1.00", "2.00"]


def test_pretty_shows_no_interval_for_one_loop():
    """n = 1 has no interval: not '95% CI 85.0-85.0' (issue 44); nor has n = 2, whose
    bootstrap is the two loops' range (issue 67); n = 3 keeps its bounds, unless they are
    one number (a zero-width interval is not shown as one)."""
    import pandas as pd

    import uavwind as uw
    df = pd.DataFrame({"mean": [85.0, 80.0, 80.0], "ci_low": [85.0, 70.0, 70.0],
                       "ci_high": [85.0, 90.0, 90.0],
                       "correct_rate": [1.0, 0.5, 1.0], "correct_low": [1.0, 0.0, 1.0],
                       "correct_high": [1.0, 1.0, 1.0], "runner_up_low": [2.0, -1.0, -1.0],
                       "runner_up_high": [2.0, 3.0, 3.0], "n_loops": [1, 2, 3]})
    out = uw.pretty(df)
    one, two, three = out.iloc[0], out.iloc[1], out.iloc[2]
    assert [one[c] for c in ("95% CI low", "95% CI high", "correct, CI low (%)")] == ["–"] * 3, one
    bounds = ("95% CI low", "95% CI high", "difference, 95% CI high")
    assert [two[c] for c in bounds] == ["–"] * 3, two
    # a column with a dash is text: its numbers keep the table's two decimals
    assert three["95% CI low"] == "70.00" and three["95% CI high"] == "90.00"
    assert one["mean"] == "85.00"
    assert three["difference, 95% CI high"] == "3.00"  # a paired difference's CI
    assert three["correct, CI low (%)"] == "–"  # 100% [100, 100]: zero width, not shown


def test_channel_names_read_as_words():
    import pytest

    from uavwind.report.display import channel_name
    assert channel_name("body_rates") == "body rates" and channel_name("imu") == "IMU"
    assert channel_name("position") == "position" and channel_name("a_b") == "a b"
    with pytest.raises(ValueError, match="name must be"):
        channel_name(None)


def test_the_baseline_table_names_its_loops_so_two_show_no_interval():
    """Exp 9's wind RMSE interval is a bootstrap over loops: with 2 loops a case it is the
    two loops' range, so the table carries n_loops and pretty() shows no interval (issue 67);
    with 5 loops the interval stays."""
    import numpy as np
    import pandas as pd

    import uavwind as uw
    from uavwind.analysis.beyond import baseline_table

    def loops(n):
        rng = np.random.default_rng(n)
        cols = ("baseline_rmse", "baseline_rmse_mass", "baseline_rmse_drag", "score")
        return pd.DataFrame({"scenario": 1, "noise_sigma": 0.1, "noise_bias": 0.0,
                             **{c: rng.uniform(0.1, 1.0, n) for c in cols},
                             **{c: rng.uniform(size=n) > 0.5 for c in (
                                 "baseline_correct", "correct", "baseline_correct_mass",
                                 "baseline_correct_drag")}})
    two, five = uw.pretty(baseline_table(loops(2))), uw.pretty(baseline_table(loops(5)))
    assert (two[["RMSE CI low", "RMSE CI high"]] == "–").all(axis=None)
    assert (five[["RMSE CI low", "RMSE CI high"]] != "–").all(axis=None)


def test_verdicts_markdown_writes_one_item_per_case_with_its_markdown_rendered():
    """A verdict's evidence is prose with Markdown (`make book`): shown as a DataFrame cell it
    printed its backticks (C1 on each vehicle, issue 67); as a list item it is rendered."""
    import pandas as pd
    import pytest

    from uavwind.report.display import verdicts_markdown
    df = pd.DataFrame({"vehicle": ["point mass", "multirotor"], "noise": ["none", "consumer"],
                       "verdict": ["cannot decide", "reproduced"],
                       "evidence": ["only 2 loops (`make book` runs enough)", "S1 lowest"]}
                      ).set_index(["vehicle", "noise"])
    text = verdicts_markdown(df)
    assert text.splitlines() == [
        "- **point mass, none**: *cannot decide*. Only 2 loops (`make book` runs enough)",
        "- **multirotor, consumer**: *reproduced*. S1 lowest"]  # a sentence after the stop
    with pytest.raises(ValueError, match="verdicts must have"):
        verdicts_markdown(df.drop(columns="evidence"))


def test_a_mis_modelled_estimators_columns_read_as_words():
    import pandas as pd

    import uavwind as uw
    df = pd.DataFrame({"rmse_mass+20%": [7.71], "correct_rate_drag+20%": [1.0], "odd_name": [1.5]})
    assert list(uw.pretty(df).columns) == ["wind RMSE, mass +20% (m/s)",
                                           "correct, drag coefficient +20% (%)", "odd name"]
    assert uw.pretty(df)["correct, drag coefficient +20% (%)"].tolist() == ["100.00"]
