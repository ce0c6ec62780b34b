"""Experiment 13: the real-flight analysis on small flights the tests write (its rows, its
CIs over controllers, its verified cache), the simulated twin (wind, drag fit, flights in
the real flights' format) and the ranking verdict."""
import os
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import figure8, real_flights as rf, twin
from uavwind.data import load_neuralfly
from uavwind.sim.multirotor import Multirotor

from test_neuralfly import SHARED, write_flight

FORCES = {"nowind": 0.5, "35wind": -3.0, "100wind": -15.0}
TILTS = {"nowind": 0.08, "35wind": 0.13, "100wind": 0.5}
SMALL = rf.RealFlightStudy(max_laps=3, n_samples=40)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("nf")
    for k, ctl in enumerate(("A", "B", "C")):
        for cond in FORCES:
            write_flight(folder, ctl, cond, laps=5, force=FORCES[cond], tilt=TILTS[cond],
                         seed=10 * k + len(cond), rate=25.0)
    return folder


@pytest.fixture(scope="module")
def flights(folder):
    return load_neuralfly(folder)


@pytest.fixture(scope="module")
def rows(flights):
    return rf.compute_rows(flights, SMALL, n_jobs=1)


def test_every_pair_channel_and_controller_has_its_row(rows):
    cl = rows[rows.kind == "cluster"]
    assert len(cl) == 3 * 6 * (3 + 1)  # pairs x channels x (controllers + pooled)
    assert len(rows[rows.kind == "loco"]) == 3 * 6 * 3
    assert len(rows[rows.kind == "flight"]) == 9
    assert cl["score"].between(0, 100).all()
    assert (cl["n_windows"] == np.where(cl["controller"] == "pooled", 18, 6)).all()
    assert rows.loc[rows.kind == "loco", "accuracy"].between(0, 1).all()
    ctl = rows[rows.kind == "control"]  # each controller against the next, at each wind
    assert len(ctl) == 3 * 6 * 3 and (ctl["condition_a"] == ctl["condition_b"]).all()
    assert set(zip(ctl["controller"], ctl["other"])) == {("A", "B"), ("B", "C"), ("C", "A")}
    est = rows[(rows.kind == "estimate") & (rows.variant == "default")
               & (rows.method != "training mean")]
    # every flight under leave one controller out by each method; under leave one wind out
    # by the two drag-model methods (a classifier cannot name a held-out wind)
    assert (est.protocol == "controller").sum() == 3 * 9
    assert (est.protocol == "wind").sum() == 2 * 9
    variants = rows[(rows.kind == "estimate") & (rows.variant != "default")]
    # two variants of the drag model and the plain model ("no own offset") of drag and
    # ekf, both protocols
    assert len(variants) == (2 + 2) * 2 * 9
    assert set(variants.groupby("variant")["method"].unique().map(tuple)) == {
        ("drag",), ("drag", "ekf")}
    base = rows[(rows.kind == "estimate") & (rows.method == "training mean")]
    assert len(base) == 2 * 9  # the trivial baseline under both protocols
    assert len(rows[rows.kind == "series"]) > 0


def _controlled(winds, same):
    """Cluster and control rows of one channel: per controller its scores on two pairs of
    winds and on two same-wind controls."""
    rows = []
    for k, (w, c) in enumerate(zip(winds, same)):
        for pair in (("nowind", "35wind"), ("35wind", "100wind")):
            rows.append({"kind": "cluster", "controller": f"c{k}", "channel": "x",
                         "condition_a": pair[0], "condition_b": pair[1], "score": w,
                         "correct": w > 0})
        for cond in ("nowind", "100wind"):
            rows.append({"kind": "control", "controller": f"c{k}", "channel": "x",
                         "condition_a": cond, "condition_b": cond, "score": c, "correct": c > 0})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("winds, same, verdict", [
    ([80, 85, 90, 88, 83], [10, 0, 20, 5, 0], "separates the winds"),
    ([60, 50, 70, 65, 55], [70, 66, 80, 75, 68], "no better than its control"),
    ([60, 20, 70, 15, 55], [40, 50, 30, 60, 35], "cannot decide"),
    ([90], [0], "cannot decide"),  # one controller: no interval
])
def test_a_channel_separates_the_winds_only_where_it_beats_its_control(winds, same, verdict):
    t = rf.controlled_table(_controlled(winds, same)).iloc[0]
    assert t["verdict"] == verdict
    assert t["difference"] == pytest.approx(np.mean(winds) - np.mean(same))
    if len(winds) > 1:  # a t interval over controllers, about the mean difference
        d = np.array(winds) - np.array(same)
        half = 2.776 * d.std(ddof=1) / np.sqrt(len(d))  # t_{0.975, 4}
        assert t["ci_high"] - t["difference"] == pytest.approx(half, rel=1e-3)


def test_the_channels_that_carry_the_wind_separate_it(rows):
    """The flights differ by force and tilt only (the same path, the same noise level)."""
    ch = rf.channel_table(rows).set_index("channel")
    for c in ("aero_force", "attitude"):
        assert ch.loc[c, "pairs_separated"] == 3 and ch.loc[c, "loco_accuracy"] == 1.0
        assert ch.loc[c, "mean"] > 90
    assert ch.loc["position", "mean"] < ch.loc["attitude", "mean"]
    pairs = rf.pair_table(rows)
    assert len(pairs) == 18 and (pairs["n_controllers"] == 3).all()
    assert (pairs["ci_low"] <= pairs["mean"]).all() and (pairs["mean"] <= pairs["ci_high"]).all()


def test_the_flight_rows_are_the_laps_means(rows, flights):
    ft = rf.flight_table(rows).set_index("condition")
    for cond, force in FORCES.items():
        assert ft.loc[cond, "aero_force_x"] == pytest.approx(force, abs=0.05)
        assert ft.loc[cond, "tilt_deg"] == pytest.approx(np.degrees(TILTS[cond]), abs=1e-9)
        assert ft.loc[cond, "n_controllers"] == 3
    assert (rows.loc[rows.kind == "flight", "n_laps"] == 3).all()


@pytest.mark.slow
def test_rows_do_not_depend_on_the_number_of_workers(flights, rows):
    again = rf.compute_rows(flights, SMALL, n_jobs=2)
    pd.testing.assert_frame_equal(rows, again)


def test_the_design_and_the_study_are_checked(flights):
    with pytest.raises(ValueError, match=r"missing \(controller, condition\)"):
        rf.compute_rows(flights[1:], SMALL)
    with pytest.raises(ValueError, match="at least two wind conditions"):
        rf.compute_rows([f for f in flights if f.condition == "nowind"], SMALL)
    with pytest.raises(ValueError, match="not among the flights'"):
        rf.compute_rows(flights, rf.RealFlightStudy(conditions=("70wind", "nowind")))
    with pytest.raises(TypeError, match="flights"):
        rf.compute_rows("flights", SMALL)
    with pytest.raises(ValueError, match="channels must be among"):
        rf.RealFlightStudy(channels=("altitude",))
    with pytest.raises(TypeError, match="conditions"):
        rf.RealFlightStudy(conditions="nowind")
    for bad in ({"max_laps": -1}, {"n_samples": 2}, {"max_iter": 0}, {"drop_first": 1.5}):
        with pytest.raises((ValueError, TypeError), match=next(iter(bad))):
            rf.RealFlightStudy(**bad)
    with pytest.raises(TypeError, match="max_itr"):
        rf.compute_rows(flights, SMALL, max_itr=3)


def test_the_cache_is_read_back_and_a_tampered_copy_is_recomputed(flights, rows, tmp_path,
                                                                 monkeypatch):
    monkeypatch.setitem(rf.STUDIES, "quick", SMALL)

    def fixture_rows(fl, study, n_jobs=None):  # the `rows` fixture's own call
        assert fl is flights and study == SMALL and n_jobs == 1
        return rows.copy()
    monkeypatch.setattr(rf, "compute_rows", fixture_rows)
    first = rf.real_flight_rows(profile="quick", results=tmp_path, flights=flights, n_jobs=1)
    path, = (tmp_path / "analyses").glob("exp13_real-*.parquet")
    calls = []  # a recompute is the fixture's rows again (compute_rows' own doubles: the tests
    # of the workers and of a folder): what is checked here is which copy is read back
    monkeypatch.setattr(rf, "compute_rows", lambda *a, **k: calls.append(1) or fixture_rows(*a, **k))
    again = rf.real_flight_rows(profile="quick", results=tmp_path, flights=flights)
    assert calls == [] and again.equals(first)
    forged = pd.read_parquet(path)
    forged.loc[forged.index[0], "score"] = 100.0  # a changed number, the digest kept
    forged.attrs = dict(pd.read_parquet(path).attrs)
    forged.to_parquet(path, index=False)
    with pytest.warns(UserWarning, match="not trusted"):
        fixed = rf.real_flight_rows(profile="quick", results=tmp_path, flights=flights, n_jobs=1)
    assert calls == [1] and fixed.equals(first)
    path.write_bytes(b"not parquet")
    with pytest.warns(UserWarning, match="not trusted"):
        fixed = rf.real_flight_rows(profile="quick", results=tmp_path, flights=flights, n_jobs=1)
    assert fixed.equals(first)
    with pytest.raises(ValueError, match="profile"):
        rf.real_flight_rows(profile="full", flights=flights)


def test_ranking_verdict_checks_only_what_the_real_flights_can_order():
    real = pd.DataFrame({"channel": ["a", "b", "c"], "mean": [90.0, 60.0, 58.0],
                         "ci_low": [85.0, 50.0, 50.0], "ci_high": [95.0, 70.0, 66.0],
                         "n_controllers": 5})

    def sim(means):
        return pd.DataFrame({"channel": ["a", "b", "c"], "mean": means,
                             "ci_low": means, "ci_high": means})

    v = figure8.ranking_verdict(real, sim([99.0, 70.0, 80.0]))
    assert v["verdict"] == "yes" and v["agree"] == [("a", "b"), ("a", "c")]
    assert v["real_unordered"] == [("b", "c")]
    assert figure8.ranking_verdict(real, sim([50.0, 70.0, 80.0]))["verdict"] == "no"
    v = figure8.ranking_verdict(real, sim([100.0, 99.9, 99.5]))
    assert v["verdict"] == "cannot decide" and v["sim_tied"] == [("a", "b"), ("a", "c")]
    assert np.isnan(v["spearman_low"])  # three channels: no interval


def test_the_ranking_agreement_comes_with_its_interval():
    """Six channels, one swap of neighbours twice (rho = 1 - 6*4/210): Fisher's z with the
    standard error sqrt(1.06 / 3), in closed form."""
    ch = list("abcdef")
    real = pd.DataFrame({"channel": ch, "mean": [90.0, 80, 70, 60, 50, 40],
                         "ci_low": [88.0, 78, 68, 58, 48, 38], "ci_high": [92.0, 82, 72, 62, 52, 42],
                         "n_controllers": 5})
    sim = pd.DataFrame({"channel": ch, "mean": [80.0, 90, 60, 70, 50, 40],
                        "ci_low": 0.0, "ci_high": 100.0})
    v = figure8.ranking_verdict(real, sim)
    rho = 1 - 6 * 4 / (6 * 35)
    z, se = np.arctanh(rho), np.sqrt(1.06 / 3)
    assert v["spearman"] == pytest.approx(rho)
    assert (v["spearman_low"], v["spearman_high"]) == pytest.approx(
        (np.tanh(z - 1.96 * se), np.tanh(z + 1.96 * se)))
    assert v["spearman_low"] < rho < v["spearman_high"] <= 1


def test_sinusoidal_wind_is_its_closed_form():
    w = uw.SinusoidalWind([[-8.5, 0, 0], [1, 2, 3]], [[-2.4, 0, 0], [0, 0, 1]], period=2 * np.pi)
    for t in (0.0, 0.3, 7.0):
        np.testing.assert_allclose(w.velocity(t, np.zeros((2, 3))),
                                   [[-8.5 - 2.4 * np.sin(t), 0, 0], [1, 2, 3 + np.sin(t)]])
    with pytest.raises(ValueError, match="amplitude must have the shape"):
        uw.SinusoidalWind([[1, 0, 0]], [[1, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match="period"):
        uw.SinusoidalWind([[1, 0, 0]], [[1, 0, 0]], period=0.0)


def test_drag_scale_multiplies_the_drag_and_nothing_else():
    base, twice = Multirotor.neural_fly(), Multirotor.neural_fly(drag_scale=2.0)
    for v in (1.0, 5.0):
        assert twice.drag_force(v) == pytest.approx(2 * base.drag_force(v), rel=1e-12)
    assert twice.max_thrust == base.max_thrust and twice.hover_speed == base.hover_speed
    qp, q2 = base.quad_params(), twice.quad_params()
    assert q2["k_d"] == 2 * qp["k_d"] and q2["c_Dx"] == 2 * qp["c_Dx"] and q2["k_eta"] == qp["k_eta"]
    s = uw.make_setting("light constant", "light constant", 2, uav=Multirotor())
    assert s.key() == uw.make_setting("light constant", "light constant", 2,
                                      uav=Multirotor(drag_scale=1.0)).key()
    assert s.key() != uw.make_setting("light constant", "light constant", 2,
                                      uav=Multirotor(drag_scale=0.5)).key()
    for bad in (0.0, -1.0, float("nan"), 1e3):
        with pytest.raises(ValueError, match="drag_scale"):
            Multirotor(drag_scale=bad)


def test_a_simulated_flight_reads_as_a_real_one():
    f = figure8.simulated_flight(Multirotor.neural_fly(), "100wind", seed=1, duration=20.0,
                                 calibration=figure8.BARE)
    assert f.controller == "seed 1" and f.wind_speed == 12.1
    assert f.p.shape == (1000, 3) and f.R.shape == (1000, 3, 3)
    assert f.p[:, 2].min() > 0.5  # flown above the floor
    w = rf.flight_laps(f, ("aero_force", "tracking_error"))
    assert len(w["starts"]) == 1
    assert w["aero_force"][..., 0].mean() < -10  # the drag points downwind, along -x
    assert np.all(np.abs(np.linalg.det(f.R) - 1) < 1e-9)
    with pytest.raises(ValueError, match="condition"):
        figure8.simulated_flight(Multirotor.neural_fly(), "gale", calibration=figure8.BARE)
    with pytest.raises(TypeError, match="vehicle"):
        figure8.simulated_flight(uw.UAV(), "nowind", calibration=figure8.BARE)
    with pytest.raises(TypeError, match="requires calibration"):
        figure8.simulated_flight(Multirotor.neural_fly(), "nowind")


def test_every_seed_of_the_twin_changes_its_flight(monkeypatch):
    """The twin's seeds: a flight's ``seed`` (its gusts and noise), the number of seeds, and
    the root ``SIM_SEED`` each change what is flown; only the bare twin, asked for by name,
    flies the same flight whatever its seed."""
    cal = figure8.TwinCalibration(gust_scale=0.08, noise=(("100wind", "noise_aero_force_x",
                                                           0.3),))
    v = cal.vehicle()

    def fly(seed, c=cal):
        return figure8.simulated_flight(v, "100wind", seed, 13.0, c)
    a, b = fly(0), fly(1)
    for col in ("p", "fa", "R"):
        assert not np.array_equal(a.arrays[col], b.arrays[col]), col
    assert np.array_equal(fly(0).arrays["fa"], a.arrays["fa"])  # and the same seed, the same
    monkeypatch.setattr(twin, "SIM_SEED", twin.SIM_SEED + 1)  # where it is read
    assert not np.array_equal(fly(0).arrays["fa"], a.arrays["fa"])
    monkeypatch.undo()
    assert len(figure8.simulated_flights(cal, n_seeds=2, conditions=("nowind",),
                                         duration=13.0)) == 2
    bare0, bare1 = fly(0, figure8.BARE), fly(1, figure8.BARE)
    assert np.array_equal(bare0.arrays["fa"], bare1.arrays["fa"])


def test_a_study_that_keeps_some_laps_flies_them_and_no_more():
    """flight_duration: the quick study's 27 s flight holds the very laps a 50 s flight keeps
    (the same doubles), the paper study flies the real flights' 50 s."""
    quick, v = rf.STUDIES["quick"], Multirotor.neural_fly(drag_scale=0.84)
    assert figure8.flight_duration(rf.STUDIES["paper"]) == figure8.DURATION == 50.0
    assert figure8.flight_duration(quick) == 27.0
    assert figure8.flight_duration(rf.RealFlightStudy(max_laps=100)) == 50.0  # never longer
    chans, keep = quick.channels + ("aero_force",), slice(0, quick.max_laps)
    bare = figure8.BARE
    full = rf.flight_laps(figure8.simulated_flight(v, "100wind", 0, calibration=bare), chans,
                          quick.n_samples, quick.drop_first)
    cut = rf.flight_laps(figure8.simulated_flight(v, "100wind", 0, duration=27.0,
                                                  calibration=bare), chans,
                         quick.n_samples, quick.drop_first)
    assert len(full["starts"]) > len(cut["starts"]) >= quick.max_laps
    for ch in chans + ("starts", "tilt"):
        assert np.array_equal(full[ch][keep], cut[ch][keep]), ch


@pytest.mark.slow
def test_the_command_line_skips_without_data_and_refuses_a_bad_folder(tmp_path):
    """`run exp13` with a bad folder: a clear error; asked for without Neural-Fly's folder: an
    error naming the variable (issue 45: it exited 0); the `analyses` command is gone (issue
    68: `run` fills everything the registry lists), and saying it names `run`."""
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(rf.__file__).rsplit("/uavwind/", 1)[0],
           "UAVWIND_RESULTS": str(tmp_path)}
    run = [sys.executable, "-m", "uavwind", "run", "exp13", "--profile", "quick"]
    p = subprocess.run(run, env={**env, "UAVWIND_NEURALFLY": str(tmp_path / "none")},
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "existing folder" in p.stderr
    p = subprocess.run(run, env=env, capture_output=True, text=True, timeout=120)
    assert p.returncode != 0 and "UAVWIND_NEURALFLY" in p.stderr
    p = subprocess.run([sys.executable, "-m", "uavwind", "analyses"], env=env,
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "'run'" in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
def test_rows_read_from_a_folder_are_found_again_without_parsing_it(folder, rows, tmp_path,
                                                                    monkeypatch):
    from uavwind.data import neuralfly
    monkeypatch.setitem(rf.STUDIES, "quick", SMALL)
    first = rf.real_flight_rows(folder, profile="quick", results=tmp_path, n_jobs=1)
    assert first.equals(rows)
    monkeypatch.setattr(neuralfly, "read_columns", lambda f: pytest.fail(f"parsed {f}"))
    assert rf.real_flight_rows(folder, profile="quick", results=tmp_path).equals(first)
    # one changed byte in one file is another entry, computed from the changed flights
    copy = tmp_path / "copy"
    copy.mkdir()
    for f in sorted(folder.iterdir()):
        (copy / f.name).write_bytes(f.read_bytes())
    f = sorted(copy.iterdir())[0]
    f.write_bytes(f.read_bytes() + b"\n")
    with pytest.raises(pytest.fail.Exception, match="parsed"):
        rf.real_flight_rows(copy, profile="quick", results=tmp_path)


def test_a_page_never_computes_experiment_13(flights, tmp_path, monkeypatch):
    from uavwind.core.io import READ_ONLY_ENV
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    with pytest.raises(RuntimeError, match="the analysis exp13_real"):
        rf.real_flight_rows(profile="quick", results=tmp_path, flights=flights)


def test_page_analyses_are_computed_once_verified_and_never_by_a_page(tmp_path, monkeypatch):
    from uavwind.analysis.memo import memo
    from uavwind.core.io import READ_ONLY_ENV
    calls = []

    def compute():
        calls.append(1)
        return pd.DataFrame({"a": [1.0, 2.0]}, index=pd.Index(["x", "y"], name="k"))

    first = memo("toy", {"n": 2}, compute, results=tmp_path)
    again = memo("toy", {"n": 2}, compute, results=tmp_path)
    assert calls == [1] and again.equals(first) and list(again.index) == ["x", "y"]
    memo("toy", {"n": 3}, compute, results=tmp_path)  # other arguments: another entry
    assert calls == [1, 1]
    path = next((tmp_path / "analyses").glob("toy-*.parquet"))
    forged = pd.read_parquet(path)
    attrs = dict(forged.attrs)
    forged.loc["x", "a"] = 9.0
    forged.attrs = attrs
    for p in (tmp_path / "analyses").glob("toy-*.parquet"):
        forged.to_parquet(p)
    with pytest.warns(UserWarning, match="not trusted"):
        fixed = memo("toy", {"n": 2}, compute, results=tmp_path)
    assert fixed["a"].tolist() == [1.0, 2.0]
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    with pytest.raises(RuntimeError, match="the analysis toy"):
        memo("toy", {"n": 4}, compute, results=tmp_path)
    with pytest.raises(ValueError, match="identifier"):
        memo("not a name", {}, compute, results=tmp_path)


def test_the_fill_computes_exp13_in_its_pool_when_the_flights_are_there(folder, monkeypatch):
    """`make results` (fill_cache("all")) puts Experiment 13 in its pool as a long task when
    the flights are there (``$UAVWIND_NEURALFLY``), and leaves it out, saying so in
    ``skipped``, when they are not; the task pickles (it goes to a worker process)."""
    import pickle

    from uavwind.analysis.exp13 import run_exp13
    from uavwind.study import fill
    monkeypatch.delenv("UAVWIND_NEURALFLY", raising=False)
    _, analyses, skipped = fill._plan("all", "quick", "all", 0, None, None)
    names = [a.id for a in analyses]
    assert skipped == ["exp13"] and "exp13" not in names
    assert {"explore_grid", "exp11_filter_table", "claims"} <= set(names)
    monkeypatch.setenv("UAVWIND_NEURALFLY", str(folder))
    _, analyses, skipped = fill._plan("all", "quick", "all", 0, None, None)
    exp13, = [a for a in analyses if a.id == "exp13"]
    assert skipped == [] and exp13.long and exp13.reads == ()
    back = pickle.loads(pickle.dumps(exp13))
    assert back.fill is run_exp13 and back.takes == ("profile", "results", "n_jobs")


def test_an_interval_of_shares_stays_within_0_and_1_and_of_scores_within_0_and_100():
    """Five controllers' held-out accuracies near 1 gave a t interval up to 1.10 on the
    Exp 13 page (issue 44's reader): a share's interval is cut to [0, 1], a score's to
    [0, 100]; an unbounded quantity (a difference) keeps its t interval."""
    m, lo, hi = rf._ci([1.0, 1.0, 0.8, 1.0, 0.9], (0.0, 1.0))
    assert hi == 1.0 and 0.0 < lo < m < 1.0
    m, lo, hi = rf._ci([99.0, 100.0, 97.0], (0.0, 100.0))
    assert hi == 100.0 and lo < m
    assert rf._ci([1.0, 1.0, 0.8])[2] > 1.0  # without bounds: the t interval itself


def test_run_experiment_exp13_without_its_flights_fails_naming_the_variable(monkeypatch):
    """Experiment 13 is in the registry path (issue 45: run_experiment("exp13") raised
    "unknown experiment"): without $UAVWIND_NEURALFLY it is a ValueError naming the variable,
    before any work; it takes no seed, engine, cases or reading (its rows are the flights')."""
    monkeypatch.delenv("UAVWIND_NEURALFLY", raising=False)
    assert uw.run_experiment is uw.study.run_experiment
    for run in (uw.run_experiment, uw.study.run_experiment):
        with pytest.raises(ValueError, match=r"exp13.*\$UAVWIND_NEURALFLY is not set"):
            run("exp13")
    with pytest.raises(ValueError, match="takes no seed, reading"):
        uw.run_experiment("exp13", seed=5, reading="halves")
    exp13 = uw.study.get_experiment("exp13")  # one registry: Exp 13 is an entry of it
    assert exp13.kind == "analysis" and exp13.notebook == "exp13_real_flights.md"
    assert exp13.data == "UAVWIND_NEURALFLY" and not exp13.available
    assert uw.study.needed_entries(["exp13"]) == []  # it reads flights, not experiments


def test_run_experiment_exp13_computes_the_real_rows_and_then_the_twin(folder, flights, rows,
                                                                      tmp_path, monkeypatch):
    """run_experiment("exp13") on the flights $UAVWIND_NEURALFLY names (small ones here):
    the real-flight rows, as real_flight_rows caches them, then the simulated twin's rows
    from them (recorded here: these small flights have no 70wind flight to fit the twin on;
    the test below and tests/test_twin.py fly it)."""
    from uavwind.analysis import exp13
    from uavwind.core.io import READ_ONLY_ENV

    twins = []
    monkeypatch.setattr(exp13, "sim_rows", lambda real, **kw: twins.append((real, kw)))
    monkeypatch.setitem(rf.STUDIES, "quick", SMALL)
    computed = []  # the flights of the folder, with the study: the `rows` fixture's own call

    def fixture_rows(fl, study, n_jobs=None):
        computed.append(sorted((f.controller, f.condition) for f in fl))
        assert study == SMALL and n_jobs == 1
        return rows.copy()
    monkeypatch.setattr(rf, "compute_rows", fixture_rows)
    monkeypatch.setenv("UAVWIND_NEURALFLY", str(folder))
    df = uw.run_experiment("exp13", profile="quick", results=tmp_path, n_jobs=1)
    assert df.attrs["experiment"] == "exp13" and df.attrs["profile"] == "quick"
    monkeypatch.setenv(READ_ONLY_ENV, "1")  # the rows are cached: reading them computes nothing
    real = rf.real_flight_rows(folder, profile="quick", results=tmp_path)
    assert df.equals(real) and list(df.columns) == list(real.columns) and df.equals(rows)
    assert computed == [sorted((f.controller, f.condition) for f in flights)]
    (twin_of, kw), = twins
    assert twin_of.equals(real) and kw == {"profile": "quick", "results": tmp_path, "n_jobs": 1}


def test_decided_orders_are_the_pairs_whose_intervals_lie_apart():
    ch = pd.DataFrame({"channel": ["b", "a", "c"], "mean": [50.0, 80.0, 45.0],
                       "ci_low": [40.0, 70.0, 30.0], "ci_high": [60.0, 90.0, 60.0],
                       "n_controllers": 5})
    assert rf.decided_orders(ch) == [("a", "b"), ("a", "c")]
    ch.loc[0, "ci_high"] = 70.0  # b's interval now reaches a's: that order is undecided
    assert rf.decided_orders(ch) == [("a", "c")]
    # the one rule: fewer controllers than a verdict needs decide no order
    assert rf.decided_orders(ch.assign(n_controllers=4)) == []
    with pytest.raises(ValueError, match="n_controllers"):
        rf.decided_orders(ch.drop(columns="n_controllers"))
