"""The sweep pages' one call (Exps 2-4): it runs the experiment as the page asks and hands
back the page's parts -- provenance, the paper's table, the mean and maximum per setting,
the stamped figure -- each what the pages computed cell by cell before."""
import matplotlib

matplotlib.use("agg")  # noqa: E402 -- headless
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from uavwind.analysis.tables import comparison_table, summary_table  # noqa: E402
from uavwind.report import sweeps  # noqa: E402
from uavwind.report.display import pretty  # noqa: E402
from uavwind.study.paper import load_paper_values  # noqa: E402


def _sweep(experiment="exp2", parameter="n_env", values=(6, 20)):
    """Synthetic results laid out as the sweep's: 5 loops per scenario and setting."""
    rng = np.random.default_rng(0)
    paper = load_paper_values(experiment)
    rows = []
    for case, ((sid, name), value) in enumerate(
            (k, v) for k in dict.fromkeys(zip(paper["scenario_id"], paper["scenario"]))
            for v in values):
        for loop in range(5):
            sil = float(rng.uniform(0.3, 0.9))
            rows.append({"experiment": experiment, "case": case, "scenario_id": sid,
                         "scenario": name, parameter: value, "loop": loop, "correct": True,
                         "silhouette": sil, "score": 100 * sil})
    df = pd.DataFrame(rows)
    df.attrs.update(experiment=experiment, reading="inferred", profile="quick", seed=1,
                    engine="fast", cached=3, chunks=8)
    return df


def test_sweep_page_runs_the_experiment_as_the_page_asks(monkeypatch):
    calls = []

    def fake_run(exp_id, **kwargs):
        calls.append((exp_id, kwargs))
        return _sweep()

    monkeypatch.setattr(sweeps, "run_experiment", fake_run)
    page = sweeps.sweep_page("exp2", profile="paper", seed=7, n_jobs=1, reading="halves")
    assert calls == [("exp2", {"profile": "paper", "seed": 7, "n_jobs": 1,
                               "reading": "halves"})]
    assert isinstance(page, sweeps.SweepPage) and page.experiment == "exp2"
    with pytest.raises(ValueError, match="experiment"):
        sweeps.sweep_page("exp1")


@pytest.mark.parametrize("experiment, parameter, values", [
    ("exp2", "n_env", (6, 20)), ("exp3", "n_env", (6, 20)),
    ("exp4", "thrust_changes", (0, 6, 12))])
def test_the_parts_are_the_tables_the_pages_showed(experiment, parameter, values):
    df = _sweep(experiment, parameter, values)
    page = sweeps.SweepPage(df)
    assert page.parameter == parameter
    pd.testing.assert_frame_equal(page.comparison(),
                                  pretty(comparison_table(df).drop(columns="case")))
    for stat in ("mean", "max"):
        expected = summary_table(df)[stat].unstack("scenario")
        pd.testing.assert_frame_equal(page.scores(stat), expected, check_names=False)
        assert page.scores(stat).index.name == sweeps.SWEEPS[experiment]  # not the code's name
        assert list(page.scores(stat).index) == list(values)
    with pytest.raises(ValueError, match="stat"):
        page.scores("median")
    fig = page.figure()
    try:
        text = " ".join(t.get_text() for t in fig.texts)
        assert f"experiment {experiment}" in text  # stamped
        assert fig.axes[0].get_xlabel() == sweeps.SWEEPS[experiment]
    finally:
        plt.close(fig)


def test_show_provenance_prints_the_line_and_the_profile_note(capsys, monkeypatch):
    shown = []
    monkeypatch.setattr("IPython.display.display", shown.append)
    sweeps.SweepPage(_sweep()).show_provenance()
    out = capsys.readouterr().out
    assert "experiment exp2" in out and "(3 of 8 chunks from the cache)" in out
    assert len(shown) == 1 and "quick" in shown[0].data
