"""Layouts, readings, the cited Dryden variant and the inference of the paper's setup."""
import numpy as np
import pandas as pd
import pytest
from sklearn.metrics import silhouette_score

import uavwind as uw
from uavwind import study as ex
from uavwind.analysis import inference as inf
from uavwind.study import cases, registry


TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}

# --------------------------------------------------------------------------- #
# layouts
# --------------------------------------------------------------------------- #


# --------------------------------------------------------------------------- #
# the fit
# --------------------------------------------------------------------------- #
def _line_silhouette(rho, n=5):
    a = np.arange(n, dtype=float)
    x = np.r_[a, a[-1] + rho + a][:, None]
    return 100 * silhouette_score(x, np.repeat([0, 1], n))


def test_fit_ratio_recovers_a_known_ratio_on_a_synthetic_curve(rng):
    ratios = np.array(cases.FIT_RATIOS)
    truth = 9.0
    curve = np.array([_line_silhouette(r) for r in ratios])
    scores = curve[:, None] + rng.normal(0, 0.3, size=(ratios.size, 200))
    est = inf.fit_ratio(ratios, scores, _line_silhouette(truth))
    assert est == pytest.approx(truth, rel=0.05)
    assert inf.fit_ratio(ratios, scores, 100.5) == float("inf")
    assert inf.fit_ratio(ratios, scores, 10.0) == ratios[0]
    with pytest.raises(ValueError, match="ratios"):
        inf.fit_ratio([2.0, 1.0], scores[:2], 50.0)


def test_fit_layouts_recovers_a_ratio_from_simulated_loops(tmp_path, monkeypatch):
    # the target is the mean score simulated at ratio 8: the fit must land on 8
    df = ex.run_experiment("fit_layout", profile=TINY, results=tmp_path, n_jobs=1,
                           progress=False, cases=list(range(4, 8)))  # S1, ratios 6..15
    at8 = df.loc[df["gap_ratio"] == 8.0, "score"].mean()
    paper = inf._paper_table4()
    paper.loc[1, "mean"] = at8
    monkeypatch.setattr(inf, "_paper_table4", lambda: paper)
    fit = inf.fit_layouts(df, n_boot=50)
    assert fit.loc[1, "ratio"] == pytest.approx(8.0)
    assert fit.loc[1, "ci_low"] <= 8.0 <= fit.loc[1, "ci_high"]


@pytest.mark.slow
def test_the_inferred_constants_agree_with_their_fit_on_a_small_case(tmp_path):
    """INFERRED_GAP_RATIOS checked against their fit here, not only in the paper build:
    20 loops of the light pairs, on the three grid ratios around each constant (the same
    loops as the paper profile's fit: the first 20 of the experiment's seed)."""
    fit = registry.EXPERIMENTS["fit_layout"]
    cases = fit.cases()
    around = {1: (8.0, 11.0, 15.0), 4: (4.0, 6.0, 8.0)}
    chosen = [i for i, c in enumerate(cases)
              if c.labels["gap_ratio"] in around.get(c.labels["scenario_id"], ())]
    df = ex.run_experiment("fit_layout", profile={**TINY, "fit_loops": 20}, results=tmp_path,
                           n_jobs=1, progress=False, cases=chosen)
    fits = inf.check_fits(inf.fit_layouts(df))
    assert list(fits.index) == [1, 4] and fits["in_ci"].all()
    # the page reads the same table from the fill's cache, keyed by the loops it is fitted to
    from uavwind.analysis import page_analyses
    from uavwind.core.io import READ_ONLY_ENV
    assert page_analyses.layout_fits(df, results=tmp_path).equals(fits)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(READ_ONLY_ENV, "1")
        assert page_analyses.layout_fits(df, results=tmp_path).equals(fits)  # read, not computed
        with pytest.raises(RuntimeError, match="inference_layout_fits"):
            # other loops: not in the cache
            page_analyses.layout_fits(df.iloc[1:], results=tmp_path)
    # and the check bites: a constant far from its fit is refused, naming the scenario
    bad = fits.assign(in_use=[99.0, 5.7], in_ci=[False, True])
    with pytest.raises(ValueError, match="scenario 1"):
        inf.check_fits(bad)


@pytest.mark.slow
def test_the_inferred_turbulence_is_the_closest_candidate(tmp_path):
    df = ex.run_experiment("fit_turbulence", profile=TINY, results=tmp_path, n_jobs=1,
                           progress=False)
    turb = inf.compare_turbulence(df)
    used = inf.check_turbulence(turb)
    assert turb.loc[used, "in_use"] and "base wind" in used
    far = turb.index[-1]  # the furthest candidate (MIL-F-8785C's zero-mean gusts) is refused
    with pytest.raises(ValueError, match="closest candidate"):
        inf.check_turbulence(turb.assign(in_use=turb.index == far))


def test_the_rival_of_the_reading_in_use_is_never_itself():
    # sorted by distance, as compare_turbulence returns it
    turb = pd.DataFrame({"distance": [1.74, 1.89, 9.0], "in_use": [False, True, False]},
                        index=["closest", "in use", "far"])
    assert inf.rival(turb) == "closest"  # the reading flies the runner-up: compare with the closest
    turb = turb.assign(in_use=[True, False, False])
    assert inf.rival(turb) == "in use"  # it flies the closest: compare with the runner-up
    with pytest.raises(ValueError, match="besides"):
        inf.rival(turb.iloc[:1])


def test_out_of_sample_puts_each_difference_beside_its_own_quantity(monkeypatch):
    # the maxima table showed a "difference" that was the difference of the means
    table = pd.DataFrame({"row": ["r"], "case": [0], "paper_max": [90.0], "max": [80.0],
                          "paper_mean": [50.0], "mean": [53.0], "ci_low": [49.0],
                          "ci_high": [57.0], "correct_rate": [1.0], "n_loops": [20]})
    monkeypatch.setattr(inf, "comparison_table", lambda df: table.set_index("row"))
    oos = inf.out_of_sample({"exp3": pd.DataFrame({"reading": ["inferred"]})}).iloc[0]
    assert oos["mean_difference"] == pytest.approx(3.0)
    assert oos["max_difference"] == pytest.approx(-10.0)
    assert oos["paper_in_ci"] and "difference" not in oos.index


def test_miss_reasons_tell_the_clustering_from_the_geometry():
    idx = pd.MultiIndex.from_tuples([("Table 6", "a"), ("Table 6", "b"), ("Table 5", "c")],
                                    names=["table", "row"])
    oos = pd.DataFrame({"mean_difference": [-40.0, 5.0, 1.0], "correct_rate": [0.2, 0.9, 1.0],
                        "geometry_alone": [55.0, 80.0, 90.0]}, index=idx)
    m = inf.miss_reasons(oos)
    assert list(m.index.get_level_values("row")) == ["a", "b"]  # within CLOSE points: no miss
    assert m["why"].iloc[0].startswith("the clustering") and "20%" in m["why"].iloc[0]
    assert m["why"].iloc[1].startswith("a residual of the layout")


def test_constant_layout_silhouette_is_scale_invariant():
    """Under eqs 2-8 a constant wind adds w t to the still-air path: scaling every wind of
    a constant layout by 10 moves the mean silhouette by less than 0.02 (of 1) and no
    loop by more than 0.08 (DTW's warping is what is not scale-free)."""
    s = uw.make_setting("light constant", "light constant", 5)
    d = inf.scale_invariance(s, factor=10.0, n_loops=6, seed=3)
    assert abs(d["difference"].mean()) < 0.02
    assert d["difference"].abs().max() < 0.08
    assert d["silhouette"].min() > 0.7


# --------------------------------------------------------------------------- #
# the cited Dryden variant
# --------------------------------------------------------------------------- #


def test_replication_notes_quote_the_ratios_in_use():
    """The notes quote the fitted ratios the library uses glued from the inference page's
    fit table (whose ``in_use`` column is ``uw.INFERRED_GAP_RATIOS``), one per fitted
    scenario, and never typed (issue 44: a number in prose comes from the results)."""
    import re
    from pathlib import Path

    notes = (Path(__file__).resolve().parents[1] / "book" / "replication_notes.md").read_text()
    glued = set(re.findall(r"inference\.ipynb::fit_in_use_(\d+)", notes))
    assert len(glued) == len(uw.INFERRED_GAP_RATIOS)
    for v in uw.INFERRED_GAP_RATIOS.values():
        assert not re.search(rf"(?<![\w.:]){re.escape(format(v, 'g'))}(?![\w.])", notes), v


@pytest.mark.parametrize("scores, target, match", [
    ([[50.0, np.nan], [70.0, 71.0]], 60.0, "scores must be finite"),
    ([[50.0, np.inf], [70.0, 71.0]], 60.0, "scores must be finite"),
    ([[50.0, 51.0], [70.0, 71.0]], np.nan, "target"),
])
def test_fit_ratio_refuses_what_would_come_out_as_a_number(scores, target, match):
    with pytest.raises(ValueError, match=match):
        inf.fit_ratio([1.0, 4.0], scores, target)


def test_compare_and_closer_mixed_measure_the_distance_to_table_4(tmp_path):
    prof = {"loops": 2, "long_loops": 2, "fit_loops": 2,
            "cem": {"n_samples": 2, "n_elite": 1, "max_iter": 1}}
    r = ex.run_experiment("fit_mixed", profile=prof, results=tmp_path, n_jobs=1,
                          progress=False, cases=[0, 3])  # S2 centre, per axis and magnitude
    m = inf.compare_mixed(r)
    row = m.iloc[0]
    assert row["distance"] == max(abs(row["mean"] - row["paper_mean"]),
                                  abs(row["max"] - row["paper_max"]))
    closer, total = inf.closer_mixed(m)
    assert closer == total.idxmin() and set(total.index) == {"per axis", "magnitude"}
