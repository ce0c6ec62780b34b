"""Exps 10, 11 and 14 with the real vehicle's variability (issue 66, item 3): the sources as a
value a loop flies (sim.variability), the open-loop flight on an imperfect attitude estimate
and thrust against closed forms, the settings' keys kept, and the sensitivity rows (without:
the chapter's own loops; with the sources at 0: the same numbers)."""
import math
import os
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import sensitivity as se
from uavwind.core.stats import summarise
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.variability import FlightVariability
from uavwind.study.cases import FLYABLE_VEHICLE, _flyable
from uavwind.study.registry import EXPERIMENTS

ON = FlightVariability(attitude_error=0.3, thrust_error=0.03, battery=0.04, gust_scale=0.05)


def _setting(**kw):
    return uw.make_setting("light constant", "light constant", 2, uav=Multirotor(), **kw)


def _flight(s, thrust=uw.PAPER_EXAMPLE, seed=7):
    return s._flight(thrust, np.random.SeedSequence(seed))


# --------------------------------------------------------------------------- #
# the open-loop flight on an imperfect state, against closed forms
# --------------------------------------------------------------------------- #
def _hover_flight(errors, preset="paper", duration=3.0):
    mr = Multirotor(preset=preset)
    hold = uw.ThrustSequence([0.0], [mr.weight], [[0, 0, 1]])
    n_ctrl = int(round(duration * mr.control_rate))
    E = None if errors is None else np.broadcast_to(np.asarray(errors, float),
                                                    (1, n_ctrl, 6)).copy()
    return uw.simulate_flight(hold, uw.ConstantWind([[0.0, 0.0, 0.0]]), uav=mr,
                              duration=duration, state_errors=E), mr


def test_a_tilt_error_flies_the_true_attitude_off_by_it():
    """The attitude loop holds its ESTIMATE level: the true body z axis settles at E^T e_z,
    the rotation by -ex about x: (0, sin ex, cos ex)."""
    ex = 0.02
    f, _ = _hover_flight([ex, 0, 0, 0, 0, 0])
    q = f.attitudes[0, -1]
    from scipy.spatial.transform import Rotation
    b3 = Rotation.from_quat(q).as_matrix()[:, 2]
    assert b3 == pytest.approx([0.0, math.sin(ex), math.cos(ex)], abs=2e-5)
    # about y: the rotation by -ey about y takes e_z to (-sin ey, 0, cos ey)
    f, _ = _hover_flight([0, ex, 0, 0, 0, 0])
    b3 = Rotation.from_quat(f.attitudes[0, -1]).as_matrix()[:, 2]
    assert b3 == pytest.approx([-math.sin(ex), 0.0, math.cos(ex)], abs=2e-5)


def test_a_thrust_error_climbs_at_e_g():
    """Level, the weight commanded, the rotors make (1 + e) times it: the vehicle climbs at
    e g (the paper preset's quadratic drag is below 1e-3 of it at these speeds)."""
    e = 0.05
    f, mr = _hover_flight([0, 0, e, 0, 0, 0], duration=2.0)
    vz = f.ground_velocities[0, :, 2]
    t = f.times
    slope = np.polyfit(t[5:], vz[5:], 1)[0]  # past the motors' lag
    assert slope == pytest.approx(e * mr.gravity, rel=5e-3)
    assert f.thrust[-1] == pytest.approx([0.0, 0.0, mr.weight])  # the record: the command


def test_zero_errors_fly_bit_for_bit_as_none():
    a, _ = _hover_flight(None)
    b, _ = _hover_flight(np.zeros(6))
    for k in ("positions", "attitudes", "rotor_speeds", "specific_forces"):
        assert np.array_equal(getattr(a, k), getattr(b, k))
    s = _setting()
    th = uw.sample_paper(np.random.default_rng(3))
    base = uw.simulate(th, s.wind(1), uav=s.uav)
    mr = s.uav
    n_ctrl = int(round(12.0 * mr.control_rate))
    zero = uw.simulate_flight(th, s.wind(1), uav=mr,
                              state_errors=np.zeros((s.n_env, n_ctrl, 6)))
    assert np.array_equal(base, zero.positions)


# --------------------------------------------------------------------------- #
# the setting: keys kept, off is off, on changes the flights, determinism
# --------------------------------------------------------------------------- #
def test_every_registered_setting_keeps_its_key_and_off_is_no_variability():
    for exp_id in ("exp10", "exp11", "exp12", "exp14"):
        exp = EXPERIMENTS[exp_id]
        for case in exp.cases(uw.get_reading(exp.readings[0]))[:12]:
            s = case.setting
            assert "variability" not in str(s.key()) and s.variability is None
            if isinstance(s.uav, Multirotor):
                assert replace(s, variability=FlightVariability()).key() == s.key()
    s = _setting()
    assert replace(s, variability=ON).key() != s.key()
    assert replace(s, variability=replace(ON, thrust_error=0.02)).key() != replace(
        s, variability=ON).key()


def test_variability_off_flies_exactly_as_without():
    s = _setting(noise=uw.CONSUMER_SENSORS)
    off = replace(s, variability=FlightVariability())
    a, b = _flight(s), _flight(off)
    assert np.array_equal(a.positions, b.positions)
    oa, _, _ = s.observe(uw.PAPER_EXAMPLE, np.random.SeedSequence(4))
    ob, _, _ = off.observe(uw.PAPER_EXAMPLE, np.random.SeedSequence(4))
    assert np.array_equal(oa, ob)


def test_each_source_changes_the_flight_and_a_seed_repeats_bit_for_bit():
    s = _setting()
    base = _flight(s)
    for src in (dict(attitude_error=0.3), dict(thrust_error=0.03), dict(gust_scale=0.5)):
        f = _flight(replace(s, variability=FlightVariability(**src)))
        assert np.abs(f.positions - base.positions).max() > 1e-4, src
    on = replace(s, variability=ON)
    a, b = _flight(on, seed=7), _flight(on, seed=7)
    assert np.array_equal(a.positions, b.positions)
    assert not np.array_equal(a.positions, _flight(on, seed=8).positions)
    # each environment draws its own errors: two environments in the same wind part
    same = replace(s, group_b=s.group_a, variability=FlightVariability(thrust_error=0.03))
    f = _flight(same)
    assert np.abs(f.positions[0] - f.positions[2]).max() > 1e-4
    assert np.array_equal(_flight(replace(same, variability=None)).positions[0],
                          _flight(replace(same, variability=None)).positions[2])
    # the battery is the rotors' top speed, drawn per loop
    v = FlightVariability(battery=0.04)
    drawn = [v.vehicle(s.uav, np.random.SeedSequence(k)) for k in range(3)]
    tops = {round(d.max_thrust, 6) for d in drawn}
    assert len(tops) == 3 and all(abs(t / s.uav.max_thrust - 1) < 0.3 for t in tops)


def test_the_state_errors_have_their_sd():
    v = FlightVariability(attitude_error=0.5, thrust_error=0.02, velocity_error=0.1)
    e = v.state_errors(40, 20_000, 100.0, np.random.SeedSequence(2))
    sd = e.reshape(-1, 6).std(axis=0)
    assert sd[:4] == pytest.approx([math.radians(0.5)] * 2 + [0.02, 0.1], rel=0.05)
    assert np.all(sd[4:] == 0.0)


def test_a_reference_flight_draws_its_controller_and_flies_mode_4():
    base = _flyable(uw.make_setting("light constant", "light constant", 2, uav=FLYABLE_VEHICLE),
                    "position")
    var = se.chapter_variability("exp14")
    s = replace(base, variability=var)
    th = s.sample_thrust(np.random.default_rng(0))
    a = s._flight(th, np.random.SeedSequence(1))
    b = base._flight(th, np.random.SeedSequence(1))
    assert np.abs(a.positions - b.positions).max() > 1e-4
    drawn = var.vehicle(FLYABLE_VEHICLE, np.random.SeedSequence(1))
    assert drawn.position_control != FLYABLE_VEHICLE.position_control
    assert drawn.hover_throttle is not None


def test_bad_variability_is_refused_naming_the_parameter():
    with pytest.raises(ValueError, match="attitude_error"):
        FlightVariability(attitude_error=-0.1)
    with pytest.raises(ValueError, match="thrust_error"):
        FlightVariability(thrust_error=0.5)
    with pytest.raises(ValueError, match="error_time"):
        FlightVariability(error_time=0.0)
    s = _setting()
    with pytest.raises(TypeError, match="variability"):
        replace(s, variability={"thrust_error": 0.03})
    with pytest.raises(ValueError, match="variability needs uav=Multirotor"):
        replace(s, uav=uw.UAV(), variability=ON)
    with pytest.raises(ValueError, match="velocity_error"):
        replace(s, variability=FlightVariability(velocity_error=0.03))
    with pytest.raises(ValueError, match="state_errors"):
        _hover_flight([0, 0, 0.6, 0, 0, 0])
    mr = Multirotor(preset="paper")
    hold = uw.ThrustSequence([0.0], [mr.weight], [[0, 0, 1]])
    with pytest.raises(ValueError, match="state_errors must have shape"):
        uw.simulate_flight(hold, uw.ConstantWind([[0.0, 0.0, 0.0]]), uav=mr, duration=1.0,
                           state_errors=np.zeros((1, 5, 6)))
    with pytest.raises(ValueError, match="point mass"):
        uw.simulate_flight(hold, uw.ConstantWind([[0.0, 0.0, 0.0]]), uav=uw.UAV(),
                           duration=1.0, state_errors=np.zeros((1, 10, 6)))
    with pytest.raises(ValueError, match="chapter"):
        se.chapter_variability("exp9")
    with pytest.raises(ValueError, match="scale"):
        se.chapter_variability("exp10", scale=-1.0)
    with pytest.raises(ValueError, match="chapter"):
        se.sensitivity_table("exp13")


# --------------------------------------------------------------------------- #
# the sensitivity rows
# --------------------------------------------------------------------------- #
def test_the_chapters_sources_are_named_and_a_controller_only_where_one_flies():
    for ch in ("exp10", "exp11"):
        v = se.chapter_variability(ch)
        assert v.attitude_error == se.FITTED["attitude_error"] and v.gust_scale > 0
        assert v.gain_spread == v.integral_spread == v.velocity_error == 0.0
        assert v.vertical_velocity_error == 0.0  # flown open loop: nothing reads a velocity
    v = se.chapter_variability("exp14")
    assert v.gain_spread == se.FITTED["gain_spread"] and v.velocity_error > 0
    assert v.vertical_velocity_error == se.FITTED["vertical_velocity_error"] > 0
    assert v.sds()[5] == v.vertical_velocity_error  # the kernels' velocity z column
    assert se.chapter_variability("exp14", 0.0).off
    t = se.sources_table("exp10")
    assert t.loc["controller bandwidth (log-SD)", "flown"] == 0.0
    assert t["applies"].str.startswith("no").sum() == 4
    for ch in se.CHAPTERS:  # one case per headline, and the registry runs each
        assert len(se.headline_cases(ch)) == len(se.HEADLINES[ch])
        assert f"{ch}_sensitivity" in uw.study.registry.REGISTRY


@pytest.fixture(scope="module")
def exp10_rows(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sensitivity")
    on = se.sensitivity_table("exp10", "quick", results=folder)
    off = se.sensitivity_table("exp10", "quick", results=folder, scale=0.0)
    return folder, on, off


@pytest.mark.slow
def test_without_is_the_chapters_own_loops_and_sources_off_give_the_same(exp10_rows):
    folder, on, off = exp10_rows
    own = uw.run_experiment("exp10", "quick", results=folder, progress=False,
                            cases=se.headline_cases("exp10"))
    for i, ci in enumerate(se.headline_cases("exp10")):
        s = summarise(own[own["case"] == ci])
        for k in ("mean", "ci_low", "ci_high", "correct_rate", "n_loops"):
            assert on.loc[i, f"without_{k}"] == s[k]
            assert off.loc[i, f"with_{k}"] == off.loc[i, f"without_{k}"] == s[k]
        assert off.loc[i, "change"] == 0.0 and bool(off.loc[i, "survives"])
    # switched on, the flights change (the noise-free light pair's score moves)
    assert (on["with_mean"] != on["without_mean"]).any()
    assert set(on["with_verdict"]) <= {"separates", "does not separate", "cannot decide"}


@pytest.mark.slow
def test_the_rows_are_cached_and_repeat(exp10_rows, tmp_path):
    folder, on, _ = exp10_rows
    again = se.sensitivity_table("exp10", "quick", results=folder)
    pd.testing.assert_frame_equal(on, again)
    assert list((folder / "analyses").glob("exp10_sensitivity-*.parquet"))


needs_flights = pytest.mark.skipif(not os.environ.get("UAVWIND_NEURALFLY"),
                                   reason="needs the Neural-Fly flights ($UAVWIND_NEURALFLY)")


@pytest.mark.slow
@needs_flights
@pytest.mark.usefixtures("unless_the_book_builds")  # test_book.py reads the fill's fit
def test_the_fitted_values_are_figure8s_fit(tmp_path):
    """FITTED is what figure8.calibrate_twin returns on the quick study (FITTED_BY), to the
    decimals it keeps."""
    from uavwind.analysis import figure8
    from uavwind.analysis.real_flights import STUDIES, real_flight_rows

    real = real_flight_rows(profile="quick", results=tmp_path, n_jobs=1)
    cal = figure8.calibrate_twin(real, STUDIES["quick"])
    half = 0.5 * 10.0 ** -se.FITTED_DECIMALS + 1e-12
    for k, v in se.FITTED.items():
        assert abs(getattr(cal, k) - v) <= half, (k, getattr(cal, k), v)


def _table(without, with_, n=50, change=(-3.0, -5.0, -1.0)):
    row = {"scenario": "Light constant vs light constant", "scenario_id": 1, "noise": "none",
           "with_crashed": 0, "change": change[0], "change_low": change[1],
           "change_high": change[2]}
    for side, (verdict, rate) in (("without", without), ("with", with_)):
        row.update({f"{side}_verdict": verdict, f"{side}_correct_rate": rate,
                    f"{side}_n_loops": n, f"{side}_mean": 50.0, f"{side}_ci_low": 40.0,
                    f"{side}_ci_high": 60.0})
    row["survives"] = without[0] == with_[0]
    return pd.DataFrame([row])


def test_the_sentence_names_a_changed_verdict_and_says_when_nothing_decides():
    changed = _table(("separates", 0.9), ("cannot decide", 0.6))
    text = se.verdict_sentence(changed, "exp10")
    assert text.startswith("0 of 1 headline verdicts survive")
    assert "separates without it, cannot decide with it" in text and "90%" in text
    assert "-3.0 points" in text
    assert se.shown(changed, "exp10").iloc[0]["survives"] == "no"
    kept = _table(("separates", 1.0), ("separates", 1.0), change=(0.0, 0.0, 0.0))
    assert se.verdict_sentence(kept, "exp10") == (
        "1 of 1 headline verdicts survive the real vehicle's variability. None was the "
        "simulator's steadiness.")
    assert "steady simulator only" in text
    few = _table(("cannot decide", 1.0), ("cannot decide", 1.0), n=2)
    assert "On 2 loops a case neither side decides" in se.verdict_sentence(few, "exp14")


def test_a_case_that_decides_nothing_without_the_variability_has_no_verdict_to_keep():
    """Two rows, one decided and kept, one undecided on both sides: the sentence counts the
    decided one only and says the other had nothing to keep; the table does not call it
    'yes'."""
    both = pd.concat([_table(("separates", 1.0), ("separates", 1.0)),
                      _table(("cannot decide", 0.6), ("cannot decide", 0.5))],
                     ignore_index=True)
    text = se.verdict_sentence(both, "exp10")
    assert text.startswith("1 of 1 headline verdicts survive the real vehicle's variability "
                           "(1 of the 2 cases decide nothing without it, so have no verdict "
                           "to keep)")
    assert se.shown(both.iloc[[1]], "exp10").iloc[0]["survives"] == "no verdict to keep"


def test_a_change_every_loop_shares_shows_no_interval():
    """A zero-width interval (every loop's score moved alike, e.g. 0 to 0) is said in words,
    not shown as '+0.0 [+0.0, +0.0]'; fewer than MIN_INTERVAL loops show the change alone."""
    flat = _table(("does not separate", 0.0), ("does not separate", 0.0), n=20,
                  change=(0.0, 0.0, 0.0))
    assert se.shown(flat, "exp10").iloc[0]["change [95% CI]"] == "+0.0 (the same on all 20 loops)"
    moved = _table(("separates", 0.9), ("separates", 0.8), n=20)
    assert se.shown(moved, "exp10").iloc[0]["change [95% CI]"] == "-3.0 [-5.0, -1.0]"
    few = _table(("cannot decide", 1.0), ("cannot decide", 1.0), n=2)
    assert se.shown(few, "exp10").iloc[0]["change [95% CI]"] == "-3.0"


def test_a_verdict_that_flips_on_noise_is_not_called_the_steadiness():
    """A changed verdict whose paired change holds 0 (one loop of a few) is not blamed on the
    simulator's steadiness; a decided change is; a mix says which."""
    noise = _table(("separates", 1.0), ("cannot decide", 0.83), n=6, change=(-16.7, -50.0, 0.0))
    text = se.verdict_sentence(noise, "exp10")
    assert "No change of verdict is itself decided" in text and "more loops decide" in text
    assert "was the simulator's steadiness:" not in text
    firm = _table(("separates", 0.9), ("cannot decide", 0.6), change=(-3.0, -5.0, -1.0))
    assert "Each verdict that changes was the simulator's steadiness" in se.verdict_sentence(
        firm, "exp10")
    both = pd.concat([firm, noise.assign(scenario="Light constant vs light shear")],
                     ignore_index=True)
    assert "1 of the 2 changes of verdict are decided" in se.verdict_sentence(both, "exp10")
