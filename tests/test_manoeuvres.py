"""Flyable manoeuvres (issue 31, item 4): the "waypoints" sampler keeps its limits, is seeded
by address, round-trips through CEM's vector, and Exp 14 runs end to end; the measurements
behind the Exp 10 page's corrections."""
import math
import tempfile
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import summary_table
from uavwind.analysis.manoeuvres import (MIN_VERDICT_LOOPS, best_channels, drift_offsets,
                                         flyable_table, flyable_verdicts, saturation_split,
                                         wind_sensitivity, zero_thrust_sensitivity)
from uavwind.core.seeding import child_rng, child_seed
from uavwind.sim.manoeuvres import (FLYABLE, FlyableLimits, check_flyable, required_tilt,
                                    sample_waypoints, waypoints_from_vector,
                                    waypoints_to_vector)
from uavwind.study import run_experiment
from uavwind.study.profiles import DEFAULT_SEED
from uavwind.study.cases import FUTURE_VEHICLE
from uavwind.study.registry import EXPERIMENTS


def _setting(observation="position", **kw):
    s = uw.make_setting("light constant", "strong constant", 2, layout="halves",
                        uav=FUTURE_VEHICLE)
    return replace(s, sampler="waypoints", observation=observation, **kw)


@pytest.mark.slow
def test_the_sampler_keeps_every_limit_on_many_draws():
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 12.0, 12001)
    box = FLYABLE.box((0.0, 0.0, 10.0))
    worst = {"speed": 0.0, "tilt": 0.0}
    for n_changes in (0, 1, 6, 11):
        for _ in range(60):
            ref = sample_waypoints(rng, n_changes=n_changes)
            assert ref.waypoints.shape == (n_changes + 2, 3)
            assert ref.waypoints[0].tolist() == [0.0, 0.0, 10.0]      # the hover start
            assert np.all(ref.waypoints >= box[:, 0]) and np.all(ref.waypoints <= box[:, 1])
            flat = ref.flat_output(t)
            assert flat["x"][:, 2].min() >= FLYABLE.floor            # the path, not only its points
            assert np.all(flat["x"] >= box[:, 0] - 1e-12) and np.all(flat["x"] <= box[:, 1] + 1e-12)
            worst["speed"] = max(worst["speed"], np.linalg.norm(flat["x_dot"], axis=1).max())
            worst["tilt"] = max(worst["tilt"], required_tilt(ref, t).max())
            # the collective thrust the reference asks for stays >= m g (1 - sin max_tilt)
            assert (9.81 + flat["x_ddot"][:, 2]).min() >= 9.81 * (1 - math.sin(math.radians(30)))
    assert worst["speed"] <= FLYABLE.max_speed and worst["tilt"] <= FLYABLE.max_tilt
    assert worst["tilt"] > 10.0  # the draws do use the room they have


def test_required_tilt_is_atan_of_the_horizontal_over_gravity_plus_vertical():
    ref = uw.WaypointSpline([[0, 0, 10], [2, 0, 11], [2, 0, 9]], [0.0, 2.0, 4.0])
    t = np.linspace(0, 4, 401)
    a = ref.flat_output(t)["x_ddot"]
    expect = np.degrees(np.arctan2(np.abs(a[:, 0]), 9.81 + a[:, 2]))
    np.testing.assert_allclose(required_tilt(ref, t), expect, atol=1e-12)


def test_check_flyable_refuses_what_breaks_a_limit_naming_it():
    fast = uw.WaypointSpline([[0, 0, 10], [3, 0, 10]], [0.0, 1.0])      # 5.6 m/s
    with pytest.raises(ValueError, match="max_speed = 3 m/s"):
        check_flyable(fast)
    steep = uw.WaypointSpline([[0, 0, 10], [1.5, 0, 10]], [0.0, 1.0])   # 2.8 m/s, 41 deg
    with pytest.raises(ValueError, match="max_tilt = 30 degrees"):
        check_flyable(steep)
    low = uw.WaypointSpline([[0, 0, 10], [0, 0, 7.5]], [0.0, 6.0])
    with pytest.raises(ValueError, match="outside the box"):
        check_flyable(low)
    with pytest.raises(ValueError, match="floor"):
        check_flyable(uw.WaypointSpline([[0, 0, 1], [0, 0, 1.5]], [0.0, 6.0]))
    ok = uw.WaypointSpline([[0, 0, 10], [1, 0, 10]], [0.0, 2.0])
    assert check_flyable(ok) is ok


def test_bad_input_names_the_parameter_and_its_range():
    with pytest.raises(ValueError, match="max_tilt"):
        FlyableLimits(max_tilt=90.0)
    with pytest.raises(ValueError, match="half_width"):
        FlyableLimits(half_width=0.0)
    with pytest.raises(ValueError, match="floor"):
        FlyableLimits(floor=-1.0)
    with pytest.raises(TypeError, match="rng must be a numpy.random.Generator"):
        sample_waypoints(0)
    with pytest.raises(ValueError, match="n_changes"):
        sample_waypoints(np.random.default_rng(0), n_changes=-1)
    with pytest.raises(ValueError, match="start must lie at or above the floor"):
        sample_waypoints(np.random.default_rng(0), start_altitude=1.0)
    with pytest.raises(TypeError, match="limits"):
        sample_waypoints(np.random.default_rng(0), limits={"max_tilt": 20})
    with pytest.raises(ValueError, match="vector"):
        waypoints_from_vector(np.zeros(5), [0.0, 1.0, 2.0], (0, 0, 10))
    with pytest.raises(ValueError, match="times"):
        waypoints_from_vector(np.zeros(3), [1.0, 2.0], (0, 0, 10))
    with pytest.raises(ValueError, match="sampler 'waypoints'.*Multirotor"):
        replace(uw.make_setting("light constant", "strong constant", 2, layout="halves"),
                sampler="waypoints")
    with pytest.raises(ValueError, match="start_altitude must be >= 2"):
        _setting(start_altitude=1.0)


def test_the_cem_vector_round_trips_and_every_decoded_draw_is_flyable():
    rng = np.random.default_rng(3)
    for _ in range(20):
        ref = sample_waypoints(rng)
        back = waypoints_from_vector(waypoints_to_vector(ref), ref.times, ref.waypoints[0])
        np.testing.assert_allclose(back.waypoints, ref.waypoints, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(back.times, ref.times)
    times = np.linspace(0, 12, 8)
    for _ in range(50):  # wild Gaussian draws are projected onto the limits
        v = rng.normal(0.0, 5.0, size=21)
        check_flyable(waypoints_from_vector(v, times, (0.0, 0.0, 10.0)))


def test_cem_searches_waypoint_offsets_and_decodes_them_flyable():
    s = _setting()
    res = uw.cem(s, n_samples=6, n_elite=2, max_iter=3, seed=1, n_jobs=1, progress=False,
                 objective=lambda x: -np.abs(x).sum(axis=1))
    assert len(res.history) == 3
    mu = np.array(res.history["mu"].iloc[-1])
    assert mu.shape == (3 * 7,)  # 8 waypoints: 7 offsets from the start
    assert isinstance(res.best_thrust, uw.WaypointSpline)
    check_flyable(res.best_thrust)
    np.testing.assert_array_equal(res.times, np.linspace(0, 12, 8))


@pytest.mark.slow
def test_random_search_on_waypoints_is_seeded_by_address_whatever_n_jobs():
    s = _setting("imu", noise=uw.CONSUMER_SENSORS)
    a = uw.random_search(s, n_loops=2, seed=5, n_jobs=1, progress=False)
    b = uw.random_search(s, n_loops=2, seed=5, n_jobs=2, progress=False)
    c = uw.random_search(s, n_loops=1, seed=5, n_jobs=1, progress=False, loop_offset=1)
    pd.testing.assert_frame_equal(a, b)
    assert c["waypoints"].iloc[0] == a["waypoints"].iloc[1]
    assert c["score"].iloc[0] == a["score"].iloc[1]
    for col in ("max_tilt", "max_tracking_error", "min_altitude", "min_thrust"):
        assert np.isfinite(a[col]).all()
    assert (a["min_altitude"] > 0).all() and (a["min_thrust"] > 0).all()


def test_the_setting_key_of_earlier_samplers_is_unchanged_and_waypoints_differ():
    s = uw.make_setting("light constant", "strong constant", 2, layout="halves",
                        uav=FUTURE_VEHICLE)
    assert replace(s, sampler="waypoints").key() != s.key()
    assert "waypoint_limits" not in s.to_dict()


def test_exp14_reuses_exp10_and_exp11_loops_for_its_raw_thrust_rows():
    cases = EXPERIMENTS["exp14"].cases()
    k10 = {c.setting.key() for c in EXPERIMENTS["exp10"].cases()}
    k11 = {c.setting.key() for c in EXPERIMENTS["exp11"].cases()}
    thrust = [c for c in cases if c.labels["action"] == "thrust"]
    assert len(thrust) == 7 + 2 * 2  # Exp 11 flies two of the seven (S1, S7)
    assert all(c.setting.key() in (k10 if c.labels["observation"] == "position" else k11)
               for c in thrust)
    assert sum(c.labels["action"] == "waypoints" and c.flyable for c in cases) == 7 * 3
    assert uw.study.PROFILES["quick"].flyable_loops == 1
    assert uw.study.PROFILES["paper"].flyable_loops == 20


@pytest.mark.slow
def test_exp14_end_to_end_at_a_tiny_profile():
    tiny = {"loops": 1, "long_loops": 1, "fit_loops": 1, "side_loops": 1, "flyable_loops": 2,
            "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 4}}
    cases = EXPERIMENTS["exp14"].cases()
    pick = [i for i, c in enumerate(cases) if c.labels["scenario_id"] == 2][:4]
    with tempfile.TemporaryDirectory() as d:
        df = run_experiment("exp14", profile=tiny, cases=pick, results=d, n_jobs=1,
                            progress=False)
        again = run_experiment("exp14", profile=tiny, cases=pick, results=d, n_jobs=1,
                               progress=False)
        cem = run_experiment("exp14_cem", profile=tiny, cases=[0], results=d, n_jobs=1,
                             progress=False)
    assert again.attrs["cached"] == again.attrs["chunks"]
    table = summary_table(df)
    assert list(table["action"]) == ["waypoints"] * 3 + ["thrust"]
    assert list(table["n_loops"]) == [2, 2, 2, 1]
    verdicts = flyable_verdicts(table)
    assert set(verdicts["verdict"]) == {"cannot decide"}  # fewer than MIN_VERDICT_LOOPS loops
    best = best_channels(table)
    assert best.index.tolist() == [table["scenario"].iloc[0]]
    assert table["max_tilt"].iloc[0] > 0 and np.isnan(table["max_tilt"].iloc[3])
    # the CEM is scaled: ceil(3 / 3) = 1 draw for ceil(4 / 4) = 1 iteration
    assert len(cem) == 1 and cem["iteration"].tolist() == [1]
    with pytest.raises(ValueError, match="action must be one of"):
        best_channels(table, action="attitude")


def test_verdicts_follow_the_interval_of_the_correct_share():
    n = MIN_VERDICT_LOOPS
    t = pd.DataFrame({"n_loops": [n, n, n, n - 1, n, 2],
                      "correct_rate": [0.8, 0.2, 0.6, 1.0, 1.0, 1.0],
                      "correct_low": [0.6, 0.1, 0.3, 0.9, 1.0, 1.0],
                      "correct_high": [1.0, 0.4, 0.8, 1.0, 1.0, 1.0]})
    # every loop of 5 correct (a zero-width bootstrap) separates; of 2, it cannot decide
    assert flyable_verdicts(t)["verdict"].tolist() == [
        "separates", "does not separate", "cannot decide", "cannot decide", "separates",
        "cannot decide"]


def test_flyable_table_summarises_every_combination():
    rows = pd.DataFrame({"scenario": ["a"] * 4, "action": ["waypoints"] * 2 + ["thrust"] * 2,
                         "observation": ["imu"] * 4, "noise": ["consumer"] * 4,
                         "loop": [0, 1, 0, 1], "score": [80.0, 90.0, 0.0, 50.0],
                         "correct": [True, True, False, True],
                         "max_tilt": [20.0, 25.0, np.nan, np.nan],
                         "motor_limited": [0.0, 0.0, 0.1, 0.3]})
    t = flyable_table(rows)
    assert t["mean"].tolist() == [85.0, 25.0]
    assert t["max_tilt"].iloc[0] == 25.0 and np.isnan(t["max_tilt"].iloc[1])
    assert t["motor_limited"].tolist() == pytest.approx([0.0, 0.2])


# --------------------------------------------------------------------------- #
# the Exp 10 corrections
# --------------------------------------------------------------------------- #
def test_saturation_splits_into_zero_thrust_slews_and_the_rest():
    s = uw.make_setting("light constant", "strong constant", 2, layout="halves",
                        uav=FUTURE_VEHICLE)
    out = saturation_split(s, n_loops=3, seed=DEFAULT_SEED)
    assert out.index.tolist() == ["zero-thrust segments", "slews", "the rest", "all"]
    assert out.loc["all", "steps"] == 3 * 4 * 1200
    assert out["limited"].iloc[:3].sum() == out.loc["all", "limited"]
    assert out["share_of_limited"].iloc[:3].sum() == pytest.approx(1.0)
    # the shares agree with the flights' own motor_limited
    per = [uw.simulate_flight(s.sample_thrust(child_rng(DEFAULT_SEED, i, 0)),
                              s.wind(child_seed(DEFAULT_SEED, i, 1)),
                              uav=FUTURE_VEHICLE).motor_limited for i in range(3)]
    assert out.loc["all", "limited_rate"] == pytest.approx(np.mean(per))
    with pytest.raises(ValueError, match="raw thrust"):
        saturation_split(_setting())


def test_a_drifting_start_is_still_air_plus_wt_until_a_segment_commands_zero_thrust():
    d = drift_offsets(20, seed=DEFAULT_SEED)
    assert d["zero_thrust"].any() and not d["zero_thrust"].all()
    assert d.loc[~d["zero_thrust"], "deviation"].max() < 1e-9      # saturating or not
    assert d.loc[~d["zero_thrust"], "motor_limited"].max() > 0.1
    assert d.loc[d["zero_thrust"], "deviation"].max() > 0.01       # centimetres
    with pytest.raises(ValueError, match="drifting"):
        drift_offsets(1, uav=FUTURE_VEHICLE)


def test_zero_thrust_turns_a_nano_change_of_wind_into_centimetres():
    d = zero_thrust_sensitivity(20, seed=DEFAULT_SEED)
    assert d.loc[~d["zero_thrust"], "shift"].max() < 2e-8          # about delta x 12 s
    assert d.loc[d["zero_thrust"], "shift"].max() > 0.05
    assert wind_sensitivity(uw.PAPER_EXAMPLE) < 2e-8
    with pytest.raises(ValueError, match="delta"):
        wind_sensitivity(uw.PAPER_EXAMPLE, delta=0.0)


def _strong_case():
    from uavwind.study.registry import EXPERIMENTS

    exp = EXPERIMENTS["exp14"]
    cases = exp.cases(exp.readings[0])
    return next((k, c) for k, c in enumerate(cases)
                if c.labels["action"] == "waypoints" and c.labels["observation"] == "position"
                and c.labels["scenario"].startswith("Light constant vs strong constant"))


def test_a_reference_loop_the_vehicle_cannot_fly_is_recorded_as_crashed_not_fatal():
    """Loop 6 of light constant vs strong constant as Exp 14 first flew it (RotorPy's
    hummingbird under plain SE3, the 12 m/s wind a step at t = 0): the step adds lift, SE3's
    vertical gains command a negative thrust, the body turns over and would fall through the
    ground. The simulator refuses the flight (GroundContact, naming the environment and the
    time); the search records the loop as crashed (score 0, one cluster, not correct)."""
    from uavwind.sim.multirotor import GroundContact
    from uavwind.study.cases import FUTURE_VEHICLE

    _, case = _strong_case()
    s = replace(case.setting, uav=FUTURE_VEHICLE, flyable=uw.FLYABLE, wind_ramp=0.0)
    ref = s.sample_thrust(child_rng(20240101, 6, 0))
    with pytest.raises(GroundContact, match="environment 6 would go below the ground") as err:
        uw.simulate(ref, s.wind(child_seed(20240101, 6, 1)), uav=s.uav, dt=s.dt,
                    duration=s.duration, start_altitude=s.start_altitude)
    assert err.value.env == 6 and 0 < err.value.time < s.duration
    df = uw.random_search(s, n_loops=1, seed=20240101, loop_offset=6, n_jobs=1, progress=False)
    row = df.iloc[0]
    assert row["crashed"] == 1.0 and row["score"] == 0.0 and not row["correct"]
    assert row["crash_time"] == pytest.approx(err.value.time)
    table = flyable_table(pd.concat([df.assign(scenario="s", action="waypoints",
                                               observation="position", noise="consumer")] * 2
                                    + [df.assign(crashed=0.0, score=80.0, correct=True,
                                                 scenario="s", action="waypoints",
                                                 observation="position", noise="consumer")]))
    r = table.iloc[0]  # the crashes counted apart: the flown loop alone is scored
    assert r["crashed"] == 2 and r["n_loops"] == 1 and r["mean"] == 80.0


def test_a_crash_inside_a_block_leaves_its_neighbours_as_they_are_alone(monkeypatch):
    """A search clusters its loops a block at a time (search.BLOCK); loops 5-7 of the case
    above, loop 6 crashed in the middle of their block, give the rows each gives alone:
    the crash recorded, the flown loops' scores and flight metrics unchanged."""
    from uavwind.method import search
    from uavwind.study.cases import FUTURE_VEHICLE

    _, case = _strong_case()
    s = replace(case.setting, uav=FUTURE_VEHICLE, flyable=uw.FLYABLE, wind_ramp=0.0)
    rows = {}
    for block in (1, 3):
        monkeypatch.setattr(search, "BLOCK", block)
        rows[block] = uw.random_search(s, n_loops=3, seed=20240101, loop_offset=5, n_jobs=1,
                                       progress=False)
    pd.testing.assert_frame_equal(rows[1], rows[3])
    assert rows[3]["crashed"].tolist() == [0.0, 1.0, 0.0]
    assert rows[3]["max_tilt"].notna().sum() == 2


def test_exp14_flies_its_strong_winds_without_a_crash_or_a_flip(tmp_path):
    """The same scenario as Exp 14 flies it now (the Neural-Fly quadrotor with its fitted
    drag, SE3 with an integral term, a thrust cone and yaw given up first, the wind ramped in
    over 3 s, the budget leaving room for the wind's lean): loops 0-6, loop 6 among them,
    fly; their rows are cached and read back."""
    from uavwind.study.runner import run_experiment

    k, _ = _strong_case()
    prof = {"loops": 7, "long_loops": 7, "fit_loops": 1, "cem": {"n_samples": 2, "n_elite": 1,
            "max_iter": 1}, "side_loops": 1, "episodes": 1, "flyable_loops": 7}
    res = run_experiment("exp14", profile=prof, cases=[k], results=tmp_path, n_jobs=1,
                         progress=False)
    assert len(res) == 7 and res["crashed"].sum() == 0 and res["flipped"].sum() == 0
    assert res["max_tilt"].max() < 60.0 + 5.0  # the cone, and the attitude loop's overshoot
    again = run_experiment("exp14", profile=prof, cases=[k], results=tmp_path, n_jobs=1,
                           progress=False)
    assert again.attrs["cached"] == again.attrs["chunks"]


def test_the_budget_in_wind_leaves_room_for_the_lean_and_a_thrust_margin():
    """``FlyableLimits.in_wind``: with the thrust ``c`` that holds the vehicle still at a lean
    ``l``, a reference acceleration of at most ``min(g sin 30, c sin(55 - l), T - c)`` keeps
    the total within the cone and the margin, in any direction (checked on a 1 ms grid)."""
    from uavwind.sim.manoeuvres import FLYABLE_IN_WIND, GRAVITY
    from uavwind.sim.multirotor import Multirotor
    from uavwind.sim.rotor_params import NEURAL_FLY_CONTROL
    from uavwind.study.cases import FLYABLE_VEHICLE

    assert FLYABLE_IN_WIND.in_wind(FLYABLE_VEHICLE, 0.0).max_acceleration == \
        pytest.approx(FLYABLE.max_acceleration)
    assert FLYABLE.in_wind(FLYABLE_VEHICLE, 13.0) is FLYABLE  # the still-air budget stays
    strong = FLYABLE_IN_WIND.in_wind(FLYABLE_VEHICLE, 13.86)
    tilt, thrust = FLYABLE_VEHICLE.hover_trim(13.86)
    c = thrust / FLYABLE_VEHICLE.mass
    assert strong.wind_lean == tilt and strong.hold_acceleration == c
    want = min(GRAVITY * math.sin(math.radians(30)), c * math.sin(math.radians(55 - tilt)),
               0.8 * FLYABLE_VEHICLE.max_thrust / FLYABLE_VEHICLE.mass - c)
    assert strong.max_acceleration == pytest.approx(want) and 0 < want < FLYABLE.max_acceleration
    ref = sample_waypoints(np.random.default_rng(5), limits=strong)
    assert check_flyable(ref, strong) is ref
    with pytest.raises(ValueError, match="with the strongest wind"):
        check_flyable(sample_waypoints(np.random.default_rng(5)), strong)
    # the preset's own drag leans 47.5 degrees in 13.86 m/s and needs 91% of its thrust
    with pytest.raises(ValueError, match="cannot hold this wind"):
        FLYABLE_IN_WIND.in_wind(Multirotor.neural_fly(position_control=NEURAL_FLY_CONTROL), 13.86)
    with pytest.raises(ValueError, match="thrust cone"):
        FLYABLE_IN_WIND.in_wind(Multirotor.neural_fly(position_control=uw.PositionControl()), 5.0)
    with pytest.raises(ValueError, match="thrust_margin"):
        FlyableLimits(thrust_margin=1.5)
    # a setting the vehicle cannot fly is refused when it is made, not mid-search
    s = uw.make_setting("strong constant", "strong constant", 5, uav=FLYABLE_VEHICLE)
    with pytest.raises(ValueError, match="cannot hold this wind"):
        replace(s, sampler="waypoints", uav=Multirotor.neural_fly(
            position_control=NEURAL_FLY_CONTROL), flyable=FLYABLE_IN_WIND)


def test_a_setting_ramps_its_wind_in_and_keeps_its_key_without():
    s = uw.make_setting("light constant", "strong constant", 2)
    assert s.key() == replace(s, wind_ramp=0.0).key() != replace(s, wind_ramp=3.0).key()
    w = replace(s, wind_ramp=3.0).wind(0)
    pos = np.zeros((4, 3)) + [0, 0, 10.0]
    assert np.array_equal(w.velocity(0.0, pos), np.zeros((4, 3)))
    assert np.array_equal(w.velocity(3.0, pos), s.wind(0).velocity(3.0, pos))
    a = uw.simulate(uw.PAPER_EXAMPLE, s.wind(0), dt=0.1, duration=12.0)
    b = uw.simulate(uw.PAPER_EXAMPLE, replace(s, wind_ramp=3.0).wind(0), dt=0.1, duration=12.0)
    assert np.abs(a - b).max() > 1.0  # the ramp changes the flight
    with pytest.raises(ValueError, match="wind_ramp"):
        replace(s, wind_ramp=13.0)
    with pytest.raises(TypeError, match="flyable"):
        replace(s, flyable={"max_tilt": 30})


def test_sample_waypoints_bounds_its_duration_before_allocating():
    """Issue 68: duration=1e6, inside the documented range then, asked for 7.45 GiB."""
    from uavwind.sim.manoeuvres import MAX_WAYPOINT_DURATION, sample_waypoints

    for duration in (1e6, MAX_WAYPOINT_DURATION * 1.001):
        with pytest.raises(ValueError, match=r"duration must be .*600"):
            sample_waypoints(np.random.default_rng(0), duration=duration)
