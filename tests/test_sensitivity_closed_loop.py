"""Exp 12 with the real vehicle's variability (issue 66, item 3): the rollout flies
Multirotor.fly's state errors and added gusts exactly as the open-loop simulation does, the
variability reaches the vehicle that flies only (never the replays the belief predicts
with), zero is none bit for bit, a seed repeats, bad input is named; and the sensitivity rows
(without: the chapter's own episodes; the sources at 0: the same numbers)."""
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import sensitivity as se
from uavwind.core.seeding import child_seed, root_seed
from uavwind.method.closed_loop import ClosedLoop, fly_episode
from uavwind.method.closed_loop.episode import episode_environment, truth_rollout
from uavwind.method.closed_loop.policies import Policy
from uavwind.method.closed_loop.problem import SEED_TRUTH
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.rollout import Rollout, WindTable
from uavwind.sim.variability import FlightVariability
from uavwind.sim.wind import ConstantWind, ShearWind
from uavwind.study.profiles import get_profile
from uavwind.study.registry import EXPERIMENTS

ON = FlightVariability(attitude_error=0.3, thrust_error=0.03, battery=0.04, gust_scale=0.05)
EXP = EXPERIMENTS["exp12"]
MR = "multirotor, RotorPy drag, hover"


def _case(scenario="Light constant vs light shear", vehicle=MR):
    return next(c for c in EXP.cases(EXP.readings[0])
                if c.labels == {"scenario": scenario, "vehicle": vehicle})


def _problem(variability=None, **kw):
    grid = {k: v for k, v in EXP.search_options.items() if k != "policies"}
    s = _case(**kw).setting
    return ClosedLoop(setting=replace(s, variability=variability), **grid)


def _segments(ro, seq, env, state, errors=None):
    """Fly ``seq`` through ``ro`` segment by segment (2 s segments of 20 samples)."""
    per, parts = ro.steps_per_sample, []
    for j, a in enumerate(range(0, ro.n_samples, 20)):
        f = np.repeat(seq.vectors[j][None], env.size, axis=0)
        e = None if errors is None else errors[:, a * per:(a + 20) * per]
        state, p = ro.advance(state, env, f, a, 20, state_errors=e)
        parts.append(p)
    return np.concatenate(parts, axis=1)


# --------------------------------------------------------------------------- #
# the rollout: state errors and gusts as the open-loop simulation flies them
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("wind", [ConstantWind([[1.5, -0.5, 0.0]]),
                                  ShearWind([[1.5, 0.5, 0.0]])])
def test_the_rollout_flies_state_errors_and_gusts_as_simulate_flight(wind):
    mr = Multirotor(start="hover")
    seq = uw.sample_paper(np.random.default_rng(5), n_changes=5, time_step=2.0)
    var = FlightVariability(attitude_error=0.3, thrust_error=0.03, gust_scale=0.2)
    vs = np.random.SeedSequence(11)
    gusts = var.gusts(np.array([1.5]), 10.0, 0.1, vs)
    E = var.state_errors(1, 1200, mr.control_rate, vs)
    ref = uw.simulate_flight(seq, wind + gusts, uav=mr, state_errors=E)
    ro = Rollout.for_flight(mr, wind, 0.1, 12.0, gusts=gusts)
    env = np.zeros(1, dtype=np.intp)
    pos = _segments(ro, seq, env, ro.start(env, [0.0, 0.0, 10.0]), E)
    assert np.array_equal(pos, ref.positions)
    # the errors and the gusts each move the flight (not a vacuous equality)
    plain = Rollout.for_flight(mr, wind, 0.1, 12.0)
    p0 = _segments(plain, seq, env, plain.start(env, [0.0, 0.0, 10.0]))
    assert np.abs(pos - p0).max() > 1e-3
    assert np.abs(_segments(ro, seq, env, ro.start(env, [0.0, 0.0, 10.0])) - pos).max() > 1e-4


def test_zero_state_errors_fly_bit_for_bit_as_none():
    mr = Multirotor(start="hover")
    seq = uw.sample_paper(np.random.default_rng(2), n_changes=5, time_step=2.0)
    ro = Rollout.for_flight(mr, ConstantWind([[1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]), 0.1, 12.0)
    env = np.arange(2)
    st = ro.start(env, [0.0, 0.0, 10.0])
    a = _segments(ro, seq, env, st)
    b = _segments(ro, seq, env, st, np.zeros((2, 1200, 6)))
    assert np.array_equal(a, b)


def test_the_rollout_names_bad_errors_and_gusts():
    mr = Multirotor(start="hover")
    ro = Rollout.for_flight(mr, ConstantWind([[1.0, 0.0, 0.0]]), 0.1, 2.0)
    env = np.zeros(1, dtype=np.intp)
    st = ro.start(env, [0.0, 0.0, 10.0])
    f = np.array([[0.0, 0.0, 20.0]])
    with pytest.raises(ValueError, match="state_errors"):
        ro.advance(st, env, f, 0, 5, state_errors=np.zeros((1, 10, 6)))
    with pytest.raises(ValueError, match="state_errors must have small"):
        ro.advance(st, env, f, 0, 5, state_errors=np.full((1, 50, 6), 0.6))
    pm = Rollout.for_flight(uw.UAV(), ConstantWind([[1.0, 0.0, 0.0]]), 0.1, 2.0)
    with pytest.raises(ValueError, match="state_errors needs a multirotor"):
        pm.advance(pm.start(env, [0, 0, 10.0]), env, f, 0, 5, state_errors=np.zeros((1, 5, 6)))
    times = np.arange(10) * 0.1
    with pytest.raises(ValueError, match="gusts"):
        WindTable(ConstantWind([[1.0, 0, 0]]), times,
                  gusts=FlightVariability(gust_scale=0.1).gusts(np.ones(2), 10.0, 0.1, 1))
    with pytest.raises(TypeError, match="gusts"):
        WindTable(ConstantWind([[1.0, 0, 0]]), times, gusts=ShearWind([[1.0, 0, 0]]))
    with pytest.raises(TypeError, match="gusts"):
        WindTable(ConstantWind([[1.0, 0, 0]]), times, gusts="gusts")


# --------------------------------------------------------------------------- #
# the episode: the truth varies, the replays do not
# --------------------------------------------------------------------------- #
@dataclass(frozen=True, kw_only=True)
class _Recorder(Policy):
    """Holds 30 N up and along x, and records the replays' states it is shown."""

    key: ClassVar[str] = "recorder"
    name: ClassVar[str] = "recorder"
    seen: list

    def choose(self, sit):
        self.seen.append(sit.states.copy())
        return np.repeat([[20.0, 0.0, 25.0]], sit.problem.segment_samples, axis=0)


def test_the_truth_varies_and_the_replays_the_belief_predicts_with_do_not():
    steady, varied = _problem(), _problem(ON)
    seen_s, seen_v = [], []
    a = fly_episode(steady, _Recorder(seen=seen_s), 1, seed=3)
    b = fly_episode(varied, _Recorder(seen=seen_v), 1, seed=3)
    for x, y in zip(seen_s, seen_v):  # the same replays, bit for bit
        assert np.array_equal(x, y)
    pa = np.array([r["p_group_b"] for r in a])
    pb = np.array([r["p_group_b"] for r in b])
    assert np.abs(pa - pb).max() > 1e-6  # the flight it observes is another one
    # the truth is the episode's own draw: the vehicle, the test wind plus gusts, the errors
    ro, E = truth_rollout(varied, 1, 3)
    vs = child_seed(root_seed(3), SEED_TRUTH, 1)
    assert ro.uav == ON.vehicle(varied.setting.uav, vs) and ro.uav != varied.setting.uav
    assert np.array_equal(E, ON.state_errors(1, 1200, ro.uav.control_rate, vs))
    _, env, test_wind = episode_environment(varied, 1, 3)
    gusts = ON.gusts(np.array([env.speeds[0]]), varied.setting.start_altitude, 0.1, vs)
    seq = uw.ThrustSequence(np.arange(6) * 2.0, [np.hypot(20.0, 25.0)] * 6,
                            [[20.0, 0.0, 25.0]] * 6)
    ref = uw.simulate_flight(seq, test_wind + gusts, uav=ro.uav, state_errors=E,
                             start_altitude=varied.setting.start_altitude)
    one = np.zeros(1, dtype=np.intp)
    pos = _segments(ro, seq, one, ro.start(one, [0.0, 0.0, varied.setting.start_altitude]), E)
    assert np.array_equal(pos, ref.positions)


def test_variability_off_is_the_episode_as_before_and_keeps_its_keys():
    steady, off = _problem(), _problem(FlightVariability())
    assert off.key() == steady.key()
    a = pd.DataFrame(fly_episode(steady, "greedy", 2, seed=4))
    b = pd.DataFrame(fly_episode(off, "greedy", 2, seed=4))
    pd.testing.assert_frame_equal(a, b)


def test_a_varied_episode_repeats_bit_for_bit_and_another_seed_differs():
    p = _problem(ON, scenario="Light constant vs strong turbulence")
    a = pd.DataFrame(fly_episode(p, "random", 1, seed=5))
    b = pd.DataFrame(fly_episode(p, "random", 1, seed=5))
    pd.testing.assert_frame_equal(a, b)
    ra, _ = truth_rollout(p, 1, 5)
    rb, _ = truth_rollout(p, 1, 6)
    assert ra.uav != rb.uav


def test_bad_truth_input_is_named():
    with pytest.raises(ValueError, match="no variability"):
        truth_rollout(_problem(), 0, 1)
    with pytest.raises(ValueError, match="variability needs uav=Multirotor"):
        _problem(ON, vehicle="point mass")
    with pytest.raises(ValueError, match="gain_spread"):  # no controller flies the segments
        _problem(FlightVariability(gain_spread=0.25))
    with pytest.raises(ValueError, match="episode"):
        truth_rollout(_problem(ON), -1, 1)


# --------------------------------------------------------------------------- #
# the sensitivity rows
# --------------------------------------------------------------------------- #
def test_exp12s_sources_exclude_the_controller_and_its_headlines_are_the_multirotor():
    v = se.chapter_variability("exp12")
    assert v.gain_spread == v.integral_spread == v.velocity_error == 0.0
    assert v.thrust_error == se.FITTED["thrust_error"] and v.gust_scale > 0 and v.battery > 0
    cases = EXP.cases(EXP.readings[0])
    assert [cases[i].labels["vehicle"] for i in se.headline_cases("exp12")] == [MR] * 3
    assert "exp12_sensitivity" in uw.study.registry.REGISTRY


#: The quick profile with 2 episodes a case: the fewest that pair episodes and give a spread
#: (the quick profile's 6, flown three times over -- without, on and off -- cost a minute)
TINY = replace(get_profile("quick"), episodes=2, name="tiny")


@pytest.fixture(scope="module")
def exp12_rows(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sensitivity12")
    on = se.sensitivity_table("exp12", TINY, results=folder)
    off = se.sensitivity_table("exp12", TINY, results=folder, scale=0.0)
    return folder, on, off


@pytest.mark.slow
def test_without_is_the_chapters_own_episodes_and_sources_off_give_the_same(exp12_rows):
    folder, on, off = exp12_rows
    own = uw.run_experiment("exp12", TINY, results=folder, progress=False,
                            cases=se.headline_cases("exp12"), reading=EXP.readings[0])
    end = own["time"].max()
    for _, r in on[on["kind"] == "identifies"].iterrows():
        ep = own[(own["scenario"] == r["scenario"]) & (own["vehicle"] == MR)
                 & (own["policy"] == r["row"]) & (own["time"] == end)]
        assert r["time"] == end and r["without_n_loops"] == len(ep)
        assert r["without_mean"] == pytest.approx(100 * ep["correct"].mean(), abs=1e-9)
    cols = [c for c in on.columns if c.startswith("without_")]
    pd.testing.assert_frame_equal(on[cols], off[cols])
    for k in ("mean", "ci_low", "ci_high", "n_loops", "verdict"):
        assert (off[f"with_{k}"] == off[f"without_{k}"]).all()
    assert (off["change"] == 0.0).all() and off["survives"].all()
    assert len(on) == 3 * (4 + len(se.CLOSED_LOOP_PAIRS))
    # 2 episodes decide nothing (a verdict needs 5): the words say so on both sides
    assert set(on["with_verdict"]) == set(on["without_verdict"]) == {"cannot decide"}


@pytest.mark.slow
def test_the_rows_are_cached_and_repeat(exp12_rows):
    folder, on, _ = exp12_rows
    pd.testing.assert_frame_equal(on, se.sensitivity_table("exp12", TINY, results=folder))
    assert list((folder / "analyses").glob("exp12_sensitivity-*.parquet"))
    shown = se.shown(on, "exp12")
    assert len(shown) == len(on) and set(shown["survives"]) <= {"yes", "no",
                                                                 "no verdict to keep"}


def _row(kind, without, with_, change=(0.0, 0.0, 0.0), scenario="Light constant vs light shear"):
    r = {"scenario": scenario, "vehicle": MR, "kind": kind,
         "row": "greedy" if kind == "identifies" else "best - random",
         "time": 12.0 if kind == "identifies" else 4.0,
         "change": change[0], "change_low": change[1], "change_high": change[2]}
    for side, (verdict, mean) in (("without", without), ("with", with_)):
        r.update({f"{side}_verdict": verdict, f"{side}_mean": mean, f"{side}_ci_low": mean - 5,
                  f"{side}_ci_high": mean + 5, f"{side}_n_loops": 200})
    r["survives"] = without[0] == with_[0]
    return r


def test_the_sentence_tells_a_lost_verdict_from_a_new_one():
    lost = pd.DataFrame([_row("identifies", ("identifies", 90.0), ("cannot decide", 55.0),
                              (-35.0, -40.0, -30.0)),
                         _row("comparison", ("helps", 20.0), ("helps", 18.0))])
    text = se.verdict_sentence(lost, "exp12")
    assert text.startswith("1 of 2 headline verdicts survive")
    assert ("light constant vs light shear, closed-loop greedy, right at 12 s: identifies "
            "without it, cannot decide with it") in text
    assert "Each verdict that changes was the simulator's steadiness" in text
    assert "-35.0 points" in text and "1 of 2 rows (every one lower with it)" in text
    assert list(se.shown(lost, "exp12")["survives"]) == ["no", "yes"]
    # a row that decides nothing without it has no verdict to lose
    gained = pd.DataFrame([_row("comparison", ("cannot decide", 3.0), ("helps", 9.0)),
                           _row("comparison", ("helps", 9.0), ("helps", 9.0),
                                scenario="Light constant vs light constant")])
    text = se.verdict_sentence(gained, "exp12")
    assert text.startswith("1 of 1 headline verdicts survive the real vehicle's variability (1 "
                           "of the 2 rows decide nothing without it")
    assert "None was the simulator's steadiness." in text
    assert list(se.shown(gained, "exp12")["survives"]) == ["no verdict to keep", "yes"]
    kept = pd.DataFrame([_row("comparison", ("helps", 9.0), ("helps", 9.0))])
    assert se.verdict_sentence(kept, "exp12").endswith("None was the simulator's steadiness.")
    few = pd.DataFrame([_row("comparison", ("cannot decide", 3.0), ("cannot decide", 3.0))])
    assert "neither side decides" in se.verdict_sentence(few, "exp12")
