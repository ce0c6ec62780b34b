"""Layouts, readings, the cited Dryden variant and the inference of the paper's setup."""
import numpy as np
import pandas as pd
import pytest
import scipy.signal as sg
from sklearn.metrics import silhouette_score

import uavwind as uw
from uavwind import study as ex
from uavwind.study import registry
from uavwind.analysis import inference as inf
from uavwind.study.layouts import Layout
from uavwind.sim.dryden import CitedDryden, cited_dryden_parameters, cited_transfer_functions


# --------------------------------------------------------------------------- #
# layouts
# --------------------------------------------------------------------------- #
def test_halves_layout_is_decision_5_bit_for_bit():
    # keys and speeds computed by the code before layouts existed (commit 79a1b00)
    assert uw.make_setting("light constant", "light constant", 5, layout="halves").key() \
        == "531858395b61aa2f"
    assert uw.make_setting("light constant", "strong turbulence", 5, layout="halves",
                           turbulence="mil-f-8785c").key() == "e02d5f44c1696134"
    assert uw.make_setting("strong shear", "strong shear", 10, layout="halves").key() \
        == "48178438c0780d2a"
    a, _ = uw.group_speeds("strong shear", "strong shear", 5, layout="halves")
    assert a.tolist() == [11.314, 11.581999999999999, 11.85, 12.118, 12.386]


@pytest.mark.parametrize("strength", ["light", "strong"])
@pytest.mark.parametrize("n", [3, 5, 10])
def test_lattice_layout_spans_the_class_range_with_the_fitted_gap(strength, n):
    lo, hi = uw.SPEED_RANGES[strength]
    a, b = uw.group_speeds(f"{strength} constant", f"{strength} constant", n,
                           layout=Layout("t", gap_ratio=7.0))
    assert a.size == b.size == n
    step = np.diff(a)
    assert np.allclose(step, step[0]) and np.allclose(np.diff(b), step[0])
    assert b[0] - a[-1] == pytest.approx(7.0 * step[0])
    assert a[0] == pytest.approx(lo) and b[-1] == pytest.approx(hi)


def test_lattice_with_an_absolute_spacing_starts_at_the_range():
    a, b = uw.group_speeds("light constant", "light shear", 3,
                           layout=Layout("t", gap_ratio=4.0, spacing=0.1))
    assert np.allclose(a, [0.45, 0.55, 0.65]) and np.allclose(b, [1.05, 1.15, 1.25])


def test_inferred_layout_uses_the_fitted_ratio_per_pair():
    for cond, rho in uw.INFERRED_GAP_RATIOS.items():
        s = uw.make_setting(cond, cond, 5)
        a, b = np.sort(s.group_a.speeds), np.sort(s.group_b.speeds)
        assert (b[0] - a[-1]) / (a[1] - a[0]) == pytest.approx(rho)
    # different strengths fill their own class ranges under every layout
    x = uw.make_setting("light constant", "strong constant", 5)
    y = uw.make_setting("light constant", "strong constant", 5, layout="halves")
    assert x.key() == y.key()


@pytest.mark.parametrize("kwargs, match", [
    ({"gap": 1.0}, "gap"), ({"gap": -0.1}, "gap"), ({"gap_ratio": 0.0}, "gap_ratio"),
    ({"gap_ratio": float("nan")}, "gap_ratio"), ({"gap_ratio": 1e9}, "gap_ratio"),
    ({"gap_ratio": 2.0, "spacing": -1.0}, "spacing"), ({"spacing": 0.1}, "spacing"),
    ({"direction": (0, 0, 0)}, "direction"), ({"direction": (1, 0)}, "direction"),
])
def test_bad_layout_parameters_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Layout("bad", **kwargs)


def test_unknown_layout_and_reading_are_rejected():
    with pytest.raises(ValueError, match="layout"):
        uw.make_setting("light constant", "light constant", 5, layout="thirds")
    with pytest.raises(TypeError, match="layout"):
        uw.make_setting("light constant", "light constant", 5, layout=3)
    with pytest.raises(ValueError, match="reading"):
        uw.get_reading("guess")
    with pytest.raises(ValueError, match="turbulence"):
        uw.make_setting("light constant", "strong turbulence", 5, turbulence="von karman")


def test_readings_build_every_experiment_and_label_rows(tmp_path):
    for rd in uw.READINGS:
        for exp in ex.EXPERIMENTS.values():
            assert len(exp.cases(rd)) > 0
    long_inferred = ex.EXPERIMENTS["exp1"].cases("inferred")[-1].setting
    long_halves = ex.EXPERIMENTS["exp1"].cases("halves")[-1].setting
    assert long_inferred.n_env == 20 and long_halves.n_env == 10
    df = ex.run_experiment("exp1", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                           cases=[1], reading="halves")
    assert (df["reading"] == "halves").all() and df.attrs["reading"] == "halves"


TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


# --------------------------------------------------------------------------- #
# the fit
# --------------------------------------------------------------------------- #
def _line_silhouette(rho, n=5):
    a = np.arange(n, dtype=float)
    x = np.r_[a, a[-1] + rho + a][:, None]
    return 100 * silhouette_score(x, np.repeat([0, 1], n))


def test_fit_ratio_recovers_a_known_ratio_on_a_synthetic_curve(rng):
    ratios = np.array(registry.FIT_RATIOS)
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
                           n_jobs=2, progress=False, cases=chosen)
    fits = inf.check_fits(inf.fit_layouts(df))
    assert list(fits.index) == [1, 4] and fits["in_ci"].all()
    # and the check bites: a constant far from its fit is refused, naming the scenario
    bad = fits.assign(in_use=[99.0, 5.7], in_ci=[False, True])
    with pytest.raises(ValueError, match="scenario 1"):
        inf.check_fits(bad)


def test_the_inferred_turbulence_is_the_closest_candidate(tmp_path):
    df = ex.run_experiment("fit_turbulence", profile=TINY, results=tmp_path, n_jobs=2,
                           progress=False)
    turb = inf.compare_turbulence(df)
    used = inf.check_turbulence(turb)
    assert turb.loc[used, "in_use"] and "base wind" in used
    far = turb.index[-1]  # the furthest candidate (MIL-F-8785C's zero-mean gusts) is refused
    with pytest.raises(ValueError, match="closest candidate"):
        inf.check_turbulence(turb.assign(in_use=turb.index == far))


def test_miss_reasons_tell_the_clustering_from_the_geometry():
    idx = pd.MultiIndex.from_tuples([("Table 6", "a"), ("Table 6", "b"), ("Table 5", "c")],
                                    names=["table", "row"])
    oos = pd.DataFrame({"difference": [-40.0, 5.0, 1.0], "correct_rate": [0.2, 0.9, 1.0],
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
def test_cited_sigmas_and_scale_lengths_follow_the_code_as_written():
    p = cited_dryden_parameters(15.0, 10.0, 12.0)
    h = 10.0 * 3.28084
    assert p["h"] == h and p["V"] == 12.0 * 3.28084
    assert p["sigma_w"] == pytest.approx(1.5)
    assert p["sigma_u"] == p["sigma_v"] == pytest.approx(1.5 / (0.177 + 0.000823 * h) ** 0.4)
    assert p["L_u"] == p["L_v"] == pytest.approx(h / (0.177 + 0.000823 * h) ** 0.2)
    assert p["L_w"] == h
    old = cited_dryden_parameters(15.0, 10.0, 12.0, CitedDryden(length_constant=0.00823))
    assert old["L_u"] == pytest.approx(h / (0.177 + 0.00823 * h) ** 0.2)
    w = uw.DrydenWind([12.0], variant="cited")
    assert w.sigmas[0] == pytest.approx(0.305 * np.array([p["sigma_u"], p["sigma_v"], 1.5]))


def test_cited_gusts_equal_scipy_lsim_of_the_published_code():
    """The control.tf + forced_response path against the cited code's own computation."""
    o = CitedDryden()
    got = uw.cited_gusts(15.0, 10.0, 12.0, o)
    t = np.linspace(0, 5, 1000)
    for j, H in enumerate(cited_transfer_functions(15.0, 10.0, 12.0, o)):
        np.random.seed(o.seeds[j])  # the published code seeds the global generator
        u = 10 * np.random.normal(0, 1, size=1000)
        tf = sg.TransferFunction(np.ravel(H.num[0][0]), np.ravel(H.den[0][0]))
        y = sg.lsim(tf, u, t)[1] * 0.305
        assert np.allclose(got[:, j], y, rtol=1e-9, atol=1e-12)


def test_cited_fixed_seeds_give_every_environment_the_same_gusts():
    w = uw.DrydenWind([11.5, 12.5, 13.5], airspeed=12.0, variant="cited", seed=1)
    g = w.gusts(120)
    assert np.array_equal(g[0], g[1]) and np.array_equal(g[1], g[2])
    assert np.array_equal(g, uw.DrydenWind([11.5, 12.5, 13.5], airspeed=12.0, variant="cited",
                                           seed=99).gusts(120))  # seed ignored
    # the 5 s series repeats (sample index int(t * 200) % 1000)
    rate = w.cited.rate
    assert np.array_equal(w.velocity(5.0, np.zeros((3, 3))), w.velocity(0.0, np.zeros((3, 3))))
    assert np.array_equal(w.velocity(7.3, np.zeros((3, 3))),
                          w._gusts._series[:, int(7.3 * rate) % 1000])


def test_cited_seed_per_environment_and_base_wind():
    o = CitedDryden(turbulence_level=None, seeds=None, base_direction=(1.0, 1.0, 0.0))
    w = uw.DrydenWind([12.0, 12.0], variant="cited", cited=o, seed=5)
    g = w.gusts(1000)
    assert not np.array_equal(g[0], g[1])
    assert np.array_equal(g, uw.DrydenWind([12.0, 12.0], variant="cited", cited=o,
                                           seed=5).gusts(1000))
    mean = g.mean(axis=1)
    assert np.allclose(mean[:, :2], 12.0 / np.sqrt(2), atol=0.5)
    assert np.allclose(mean[:, 2], 0.0, atol=0.5)


@pytest.mark.parametrize("kwargs, match", [
    ({"turbulence_level": 0.0}, "turbulence_level"), ({"seeds": (1, 2)}, "seeds"),
    ({"grid_samples": 1}, "grid_samples"), ({"grid_duration": 0.0}, "grid_duration"),
    ({"base_direction": (0, 0, 0)}, "base_direction"), ({"output_scale": -1}, "output_scale"),
])
def test_bad_cited_options_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        CitedDryden(**kwargs)


def test_dryden_variant_is_validated():
    with pytest.raises(ValueError, match="variant"):
        uw.DrydenWind([12.0], variant="karman")
    with pytest.raises(TypeError, match="cited"):
        uw.DrydenWind([12.0], variant="cited", cited={"turbulence_level": 3})


def test_replication_notes_quote_the_ratios_in_use():
    """The notes type the fitted ratios; they must be the ones the library uses."""
    from pathlib import Path

    notes = (Path(__file__).resolve().parents[1] / "book" / "replication_notes.md").read_text()
    quoted = ", ".join(f"{k} {v:g}" for k, v in uw.INFERRED_GAP_RATIOS.items())
    assert quoted in " ".join(notes.split()), quoted
