"""Closed-loop identification (Exp 12): held-out test environments, the belief, the
policies, determinism, and bad input."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from scipy.stats import multivariate_normal

import uavwind as uw
from uavwind.method.closed_loop.belief import directions
from uavwind.method.closed_loop import (ClosedLoop, Evidence, Greedy, OpenLoopBest,
                                        RecedingCEM, categorical_cem, fly_episode, held_out,
                                        run_episodes, segment_actions, separation_bound)
from uavwind.method.closed_loop.policies import Situation
from uavwind.sim.cited_dryden import CitedDryden
from uavwind.sim.observation import CONSUMER_NOISE, Noise
from uavwind.sim.rollout import Rollout
from uavwind.sim.setting import EnvironmentGroup, Setting
from uavwind.study import EXPERIMENTS, run_experiment
from uavwind.study.cache import Expected, _problem
from uavwind.study.conditions import table3_setting

NOISE = Noise(position=CONSUMER_NOISE.position)


def _scenario(a, b, reading="halves", uav=None):
    case = next(c for c in EXPERIMENTS["exp12"].cases(reading)
                if c.labels["scenario"] == f"{a} vs {b}" and c.labels["vehicle"] == "point mass")
    s = case.setting
    return s if uav is None else replace(s, uav=uav)


SCENARIOS = [("Light constant", "light constant"), ("Light constant", "light shear"),
             ("Light constant", "strong turbulence")]


# --------------------------------------------------------------------------- #
# the test environments are held out
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("reading", ["halves", "inferred"])
@pytest.mark.parametrize("pair", SCENARIOS)
def test_no_test_environment_is_ever_a_known_one(reading, pair):
    prob = ClosedLoop(setting=_scenario(*pair, reading=reading))
    s = prob.setting
    known = prob.known_wind(5)
    n_steps = 200
    for episode in range(60):
        group, env = prob.test_environment(episode, 5)
        assert group == episode % 2
        g = s.group_a if group == 0 else s.group_b
        assert env.kind == g.kind and env.n_env == 1
        assert env.values[0] not in g.values  # a new speed (or velocity)
        lo, hi = g.speeds.min(), g.speeds.max()
        assert lo - 1e-12 <= env.speeds[0] <= hi + 1e-12
        if env.kind == "turbulence":  # a new gust series, none of the known ones
            test = prob.test_wind(episode, 5).gusts(n_steps)[0]
            model = known.models[group]
            for k in range(model.n_env):
                assert not np.allclose(test, model.gusts(n_steps)[k], atol=1e-3)


def test_held_out_refuses_a_group_with_nothing_between_its_members():
    one = EnvironmentGroup("constant", ((1.0, 0.0, 0.0), (1.0, 0.0, 0.0)), "same")
    with pytest.raises(ValueError, match="two distinct"):
        held_out(one, np.random.default_rng(0))


def test_a_cited_dryden_group_with_fixed_seeds_cannot_be_held_out():
    a = EnvironmentGroup("constant", ((0.5, 0.5, 0.0), (0.7, 0.7, 0.0)), "c")
    fixed = EnvironmentGroup("turbulence", (11.0, 13.0), "t", variant="cited")
    with pytest.raises(ValueError, match="setting.group_b.*fixed seeds"):
        ClosedLoop(setting=Setting(a, fixed))
    free = replace(fixed, cited=CitedDryden(seeds=None))
    ClosedLoop(setting=Setting(a, free))


# --------------------------------------------------------------------------- #
# the belief
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("random", [(False, False), (False, True), (True, True)])
def test_the_likelihood_is_the_dense_gaussian_mixture(random):
    rng = np.random.default_rng(1)
    groups = np.array([0, 1, 0, 1, 0, 1, 1])
    speeds = rng.uniform(0, 2, 7)
    pred = rng.normal(0, 3.0, (7, 8, 3)).cumsum(axis=1)
    y = pred[4] + rng.normal(0, 2.0, (8, 3))
    ev = Evidence(groups, 2.0, random=random, speeds=speeds)
    ev.add(y[:5], pred[:, :5])  # in two parts: the sums are additive
    ev.add(y[5:], pred[:, 5:])
    got = ev.log_likelihoods()
    flat, yy = pred.reshape(7, -1), y.ravel()
    for g in (0, 1):
        idx = np.flatnonzero(groups == g)
        idx = idx[np.argsort(speeds[idx])]
        assert ev.members[g].tolist() == idx.tolist()
        u = (directions(idx.size, random[g]) @ flat[idx]).T  # (numbers, directions)
        cov = 4.0 * np.eye(yy.size) + u @ u.T
        for e in idx:
            want = multivariate_normal(flat[e], cov).logpdf(yy)
            assert got[e] == pytest.approx(want, rel=1e-9, abs=1e-9)


def test_a_family_s_directions_are_neighbours_and_curvature_a_process_s_all_pairs():
    fam = directions(5, random=False)
    assert fam.shape == (4 + 3, 5) and np.allclose(fam.sum(axis=1), 0.0)
    # neighbours only: each difference row touches two consecutive members
    assert all(np.flatnonzero(r).tolist() == [i, i + 1] for i, r in enumerate(fam[:4]))
    proc = directions(5, random=True)
    assert proc.shape == (10, 5) and np.allclose(proc.sum(axis=1), 0.0)
    # members 0 .. 4 at 0, 1, 2 ... along one axis: each neighbour difference is 1 and the
    # curvature 0, and a new member uniform between two neighbours differs from the nearer
    # by u, |u| <= 1/2: second moment 1/12
    p = np.arange(5.0)[:, None]
    assert np.trace((fam @ p).T @ (fam @ p)) == pytest.approx(1.0 / 12)
    u = np.random.default_rng(0).uniform(-0.5, 0.5, 200_000)
    assert np.mean(u ** 2) == pytest.approx(1.0 / 12, rel=1e-2)
    # on a parabola the chord misses by u (1 - u) / 2 times the second difference
    v = np.random.default_rng(1).uniform(0, 1, 200_000)
    assert np.mean((v * (1 - v) / 2) ** 2) == pytest.approx(1.0 / 120, rel=1e-2)


def test_probabilities_are_probabilities_and_the_loss_is_finite():
    rng = np.random.default_rng(2)
    for scale in (0.01, 1.0, 100.0):  # from undecided to sure beyond float64's 1 - p
        ev = Evidence([0, 0, 1, 1], 0.5)
        pred = rng.normal(0, scale, (4, 30, 3))
        ev.add(pred[3] + rng.normal(0, 0.5, (30, 3)), pred)
        b = ev.belief()
        assert np.all((b.p >= 0) & (b.p <= 1)) and b.p.sum() == pytest.approx(1.0, abs=1e-15)
        assert b.weights.sum() == pytest.approx(1.0) and np.all(b.weights >= 0)
        for g in (0, 1):
            assert np.isfinite(b.log_loss(g)) and b.log_loss(g) >= 0
            if b.p[g] > 1e-300:
                assert b.log_loss(g) == pytest.approx(-np.log(b.p[g]), rel=1e-9, abs=1e-12)
    prior = Evidence([0, 0, 1, 1], 0.5).belief()
    assert prior.p.tolist() == [0.5, 0.5] and prior.predicted == 0


def test_noise_free_identical_trajectories_give_a_finite_belief():
    ev = Evidence([0, 0, 1, 1], 0.0)
    ev.add(np.ones((5, 3)), np.ones((4, 5, 3)))
    b = ev.belief()
    assert np.all(np.isfinite(b.p)) and b.p.tolist() == [0.5, 0.5]


def test_a_turbulent_flight_is_not_confidently_misread():
    """The case that made the belief learn a group's covariance (the isotropic kernel
    said p(true) = 1e-74 here): point mass, light constant vs strong turbulence."""
    prob = ClosedLoop(setting=_scenario(*SCENARIOS[2]), report_interval=2.0)
    df = run_episodes(prob, "greedy", 0, 16, seed=1)
    last = df[df["time"] == 12.0]
    assert last["log_loss"].max() < 5.0
    assert last["correct"].mean() >= 0.9


# --------------------------------------------------------------------------- #
# the policies
# --------------------------------------------------------------------------- #
def test_categorical_cem_finds_a_separable_optimum_and_keeps_an_incumbent():
    target = np.array([3, 0, 7, 7, 1])

    def score(plans):
        return (plans != target).sum(axis=1).astype(float)

    plan, val, probs = categorical_cem(score, 5, 10, np.random.default_rng(0), 200, 20, 8, 0.7)
    assert plan.tolist() == target.tolist() and val == 0.0
    assert np.allclose(probs.sum(axis=1), 1.0)
    _, val2, _ = categorical_cem(score, 5, 10, np.random.default_rng(1), 4, 2, 1, 0.7,
                                 incumbent=target)
    assert val2 == 0.0  # never worse than the incumbent


def _situation(prob, seed=0):
    wind = prob.known_wind(seed)
    ro = Rollout.for_flight(prob.setting.uav, wind, prob.setting.dt, prob.setting.duration)
    env = np.arange(wind.n_env)
    ev = Evidence(prob.groups, prob.sigma, random=prob.random_groups, speeds=prob.speeds)
    return Situation(problem=prob, planner=ro, states=ro.start(env, [0, 0, 10.0]), sample=0,
                     segment=0, belief=ev.belief(), rng=np.random.default_rng(0),
                     seed=np.random.SeedSequence(seed), members=ev.members)


def test_the_separation_bound_is_its_formula():
    prob = ClosedLoop(setting=_scenario(*SCENARIOS[1]))
    sit = _situation(prob)
    plans = np.array([[0, 15], [15, 15], [3, 0]])
    got = separation_bound(sit, plans)
    s = prob.setting
    w = sit.belief.weights
    # equal prior weights: the slowest, the middle and the fastest member of each group
    order = [np.flatnonzero(prob.groups == g)[np.argsort(prob.speeds[prob.groups == g])]
             for g in (0, 1)]
    live_a, live_b = (sorted(o[[0, 2, 4]].tolist()) for o in order)
    for k, plan in enumerate(plans):
        seq = uw.ThrustSequence([0.0, 2.0], np.linalg.norm(prob.actions[plan], axis=1) + 0.0,
                                [a if a.any() else [0, 0, 1] for a in prob.actions[plan]])
        pos = uw.simulate(seq, prob.known_wind(0), uav=s.uav, duration=4.0)
        within = sum(((pos[i] - pos[j]) ** 2).sum() for g in (live_a, live_b)
                     for x, i in enumerate(g) for j in g[x + 1:])
        spread = sit.belief.spread + within / (6 * pos[0].size)
        terms = [0.5 * np.log(w[a] * w[b]) - ((pos[a] - pos[b]) ** 2).sum() / (8 * spread)
                 for a in live_a for b in live_b]
        assert got[k] == pytest.approx(np.logaddexp.reduce(terms), rel=1e-9)
    # a sure belief leaves nothing to separate
    sit.belief = replace(sit.belief, weights=np.r_[np.ones(5), np.zeros(5)] / 5)
    assert np.all(separation_bound(sit, plans) == -np.inf)


def test_a_manoeuvre_that_scatters_a_group_is_not_rewarded():
    """Separating the groups by scattering every environment (members of one condition as
    much as the two conditions) must not score better than the same separation with each
    condition kept together."""
    prob = ClosedLoop(setting=_scenario(*SCENARIOS[0]))
    sit = _situation(prob)

    class Fake:  # predicted positions: groups 0 and 1 apart by 10 m along x
        def __init__(self, scatter):
            self.scatter = scatter

        def advance(self, states, rows, forces, sample0, n):
            g = (rows >= 5).astype(float)
            pos = np.zeros((rows.size, n, 3))
            pos[:, :, 0] = 10.0 * g[:, None]
            pos[:, :, 1] = self.scatter * (rows % 5)[:, None]
            return states, pos

    plans = np.array([[0]])
    sit.planner = Fake(0.0)
    kept = separation_bound(sit, plans)[0]
    sit.planner = Fake(10.0)
    scattered = separation_bound(sit, plans)[0]
    assert kept < scattered


def test_receding_cem_starts_with_the_open_loop_plan():
    prob = ClosedLoop(setting=_scenario(*SCENARIOS[1]))
    df = run_episodes(prob, ["best", "receding"], 0, 4, seed=3)
    first = df[df["segment"] == 0].groupby(["episode", "policy"])["thrust"].first().unstack()
    for _, row in first.iterrows():
        assert np.array_equal(row["best"], row["receding"])
    assert len({tuple(t) for t in first["best"]}) == 1  # one plan, every flight


@pytest.mark.parametrize("uav", [uw.UAV(), uw.Multirotor(start="hover")],
                         ids=["point mass", "multirotor"])
def test_far_apart_groups_are_told_apart_after_the_first_segment(uav):
    """Strong shear vs light constant (Table 3): every policy is sure after one segment."""
    s = table3_setting(uav=uav, noise=NOISE)
    prob = ClosedLoop(setting=s, decision_interval=2.0, report_interval=1.0)
    n = 6 if isinstance(uav, uw.UAV) else 2
    policies = ["random", "best", "greedy", "receding"]
    if not isinstance(uav, uw.UAV):
        policies = ["random", "greedy", OpenLoopBest(n_samples=8, n_iter=1)]
    df = run_episodes(prob, policies, 0, n, seed=4)
    after = df[df["time"] >= prob.decision_interval]
    assert after["correct"].all() and (after["p_true"] > 0.99).all()


def test_the_same_seed_gives_the_same_decisions_whatever_the_workers():
    prob = ClosedLoop(setting=_scenario(*SCENARIOS[1]), report_interval=1.0)
    pols = ["random", "greedy", RecedingCEM(n_samples=12, n_iter=2, replan_samples=6)]
    one = run_episodes(prob, pols, 0, 6, seed=11, n_jobs=1)
    two = run_episodes(prob, pols, 0, 6, seed=11, n_jobs=2)
    pd.testing.assert_frame_equal(one, two, check_exact=True)
    other = run_episodes(prob, pols, 0, 6, seed=12, n_jobs=1)
    assert not one["p_group_b"].equals(other["p_group_b"])


# --------------------------------------------------------------------------- #
# bad input
# --------------------------------------------------------------------------- #
def test_bad_input_gets_a_value_error_naming_the_parameter():
    s = _scenario(*SCENARIOS[0])
    with pytest.raises(ValueError, match="decision_interval = 5 s must divide the flight"):
        ClosedLoop(setting=s, decision_interval=5.0)
    with pytest.raises(ValueError, match="decision_interval = 0.25 s must be made of whole"):
        ClosedLoop(setting=s, decision_interval=0.25, report_interval=0.25)
    with pytest.raises(ValueError, match="report_interval = 0.75 s must divide the decision"):
        ClosedLoop(setting=s, decision_interval=2.0, report_interval=0.75)
    with pytest.raises(ValueError, match="decision_interval must be in"):
        ClosedLoop(setting=s, decision_interval=0.0)
    with pytest.raises(ValueError, match="setting.group_a must hold at least 2"):
        ClosedLoop(setting=replace(s, group_a=s.group_a.subset([0])))
    with pytest.raises(ValueError, match="values must"):
        EnvironmentGroup("constant", (), "empty")
    with pytest.raises(ValueError, match="policy must be one of"):
        run_episodes(ClosedLoop(setting=s), "clever", 0, 2)
    with pytest.raises(ValueError, match="policies must not repeat"):
        run_episodes(ClosedLoop(setting=s), ["greedy", Greedy()], 0, 2)
    with pytest.raises(ValueError, match="stop must be in"):
        run_episodes(ClosedLoop(setting=s), "greedy", 3, 3)
    with pytest.raises(ValueError, match="episode must be in"):
        fly_episode(ClosedLoop(setting=s), "greedy", -1)
    with pytest.raises(ValueError, match="n_elite must be in"):
        RecedingCEM(n_samples=4, n_elite=5)
    with pytest.raises(ValueError, match="replan_samples must be >= n_elite"):
        RecedingCEM(replan_samples=2)
    with pytest.raises(ValueError, match="magnitude_step must be in"):
        segment_actions(0.0)
    with pytest.raises(TypeError, match="setting"):
        ClosedLoop(setting="light constant")


# --------------------------------------------------------------------------- #
# the experiment
# --------------------------------------------------------------------------- #
def test_experiment_12_end_to_end_and_its_cache(tmp_path, monkeypatch):
    prof = {"loops": 2, "long_loops": 2, "fit_loops": 2, "episodes": 3,
            "cem": {"n_samples": 2, "n_elite": 1, "max_iter": 1}}
    df = run_experiment("exp12", profile=prof, reading="halves", cases=[2], results=tmp_path,
                        n_jobs=1, progress=False)
    n_reports = 12 * 2
    assert len(df) == 3 * 4 * n_reports
    assert set(df["policy"]) == {"random", "best", "greedy", "receding"}
    assert df.attrs["cached"] == 0 and df["engine"].eq("none").all()
    again = run_experiment("exp12", profile=prof, reading="halves", cases=[2],
                           results=tmp_path, n_jobs=1, progress=False)
    assert again.attrs["cached"] == 1
    pd.testing.assert_frame_equal(df, again)
    # the cache's rules for closed-loop rows
    expect = Expected(df["setting_key"].iloc[0], int(df["seed"].iloc[0]), "none", len(df),
                      kind="episodes", key="the chunk")
    assert _problem(df, expect) == ""
    bad = df.copy()
    bad.loc[0, "p_true"] = 1.0 - bad.loc[0, "p_true"] + 0.25
    assert "p_true" in _problem(bad, expect)
    bad = df.copy()
    bad.loc[3, "correct"] = not bad.loc[3, "correct"]
    assert "correct" in _problem(bad, expect)
    # the page's summaries (the curves' bootstraps, time to confidence, closing the loop)
    # are made by the fill, kept under the table's digest and read back equal
    from uavwind.analysis import closed_loop as cl
    from uavwind.analysis import page_analyses
    from uavwind.core.io import READ_ONLY_ENV
    made = page_analyses.exp12_summaries(df, results=tmp_path)
    for name, f in (("curves", cl.accuracy_over_time), ("time_to_confidence",
                                                         cl.time_to_confidence),
                    ("closing", cl.closing_the_loop)):
        assert made[name].equals(f(df)), name
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    read = page_analyses.exp12_summaries(again, results=tmp_path)
    assert all(read[k].equals(made[k]) for k in made)
    with pytest.raises(RuntimeError, match="the analysis exp12_curves"):
        page_analyses.exp12_summaries(df.iloc[:-1], results=tmp_path)  # another table: not cached


def test_a_flight_unlike_every_member_is_not_read_with_certainty():
    """Both conditions share the 'neither' component: a flight far from all members of
    both stays near one half instead of going, certain, to the less bad condition."""
    groups = [0, 0, 0, 1, 1, 1]
    t = np.linspace(0, 1, 20)[:, None] * np.ones(3)
    pred = np.stack([t * v for v in (1.0, 1.1, 1.2, 2.0, 2.1, 2.2)])
    ev = Evidence(groups, 0.1)
    ev.add(t * 30.0, pred)  # 30 m/s: beyond both, nearer group 1
    b = ev.belief()
    assert 0.3 < b.p[1] < 0.7
    near = Evidence(groups, 0.1)
    near.add(t * 2.05, pred)  # between two members of group 1
    assert near.belief().p[1] > 0.999


def test_the_multirotor_keeps_thrust_because_zero_thrust_is_chaotic():
    mr = uw.Multirotor()
    s = replace(_scenario(*SCENARIOS[1]), uav=mr)
    assert ClosedLoop(setting=s).min_thrust == 10.0
    assert np.linalg.norm(ClosedLoop(setting=s).actions, axis=1).min() == 10.0
    assert np.linalg.norm(ClosedLoop(setting=_scenario(*SCENARIOS[1])).actions, axis=1).min() == 0
    speeds = np.linspace(1.1, 1.2, 11)
    from uavwind.sim.wind import ShearWind
    wind = ShearWind([[v / np.sqrt(2), v / np.sqrt(2), 0.0] for v in speeds])
    steps = {}
    for low in (0.0, 10.0):
        acts = np.array([[0, 30, 0], [0, 0, low], [0, 10, 0], [20, 0, 0]], dtype=float)
        seq = uw.ThrustSequence([0.0, 2.0, 4.0, 6.0], np.linalg.norm(acts, axis=1),
                                [a if a.any() else [0, 0, 1] for a in acts])
        end = uw.simulate(seq, wind, uav=mr, duration=8.0)[:, -1]
        steps[low] = np.linalg.norm(np.diff(end, axis=0), axis=1).max()
    assert steps[0.0] > 5 * steps[10.0]  # 0.01 m/s apart: metres apart after a free fall


# --------------------------------------------------------------------------- #
# nothing silently wrong (issue 33)
# --------------------------------------------------------------------------- #
def test_an_empty_action_set_is_refused_at_construction():
    s = _scenario(*SCENARIOS[0])
    with pytest.raises(ValueError, match="min_thrust = 50 N leaves no action"):
        ClosedLoop(setting=s, magnitude_step=15.0, min_thrust=50.0)
    assert len(ClosedLoop(setting=s, magnitude_step=10.0, min_thrust=50.0).actions) == 3


def test_an_underpowered_multirotor_is_refused_as_simulate_refuses_it():
    weak = uw.Multirotor(mass=0.1)  # 10 N at full rotor speed
    s = _scenario(*SCENARIOS[0], uav=weak)
    with pytest.raises(ValueError, match="thrust"):
        uw.simulate(uw.PAPER_EXAMPLE, uw.ConstantWind([[1.0, 0.0, 0.0]]), uav=weak)
    with pytest.raises(ValueError, match=r"setting.uav: .* at most 10\.0 N"):
        ClosedLoop(setting=s)


@pytest.mark.parametrize("groups, word", [
    ([0, 0, 1, 2], "only 0 and 1"), ([0, 0, 0, 0], "at least 2"), ([0, 0, 1], "at least 2"),
    ([0, 0.5, 1, 1], "only 0 and 1"), ([[0, 0], [1, 1]], "groups"), ([0, 0, 1, np.nan], "groups")])
def test_evidence_refuses_groups_other_than_two_of_zero_and_one(groups, word):
    with pytest.raises(ValueError, match=word):
        Evidence(groups, 0.5)


@pytest.mark.parametrize("kwargs, error, word", [
    ({"sigma": np.nan}, ValueError, "sigma"), ({"sigma": -1.0}, ValueError, "sigma"),
    ({"speeds": [0.0, 1.0, np.nan, 2.0]}, ValueError, "speeds"),
    ({"speeds": [0.0, 1.0]}, ValueError, "speeds"),
    ({"random": (True,)}, TypeError, "random"), ({"random": "yes"}, TypeError, "random")])
def test_evidence_names_a_bad_noise_speed_or_kind(kwargs, error, word):
    kw = {"sigma": 0.5, **kwargs}
    with pytest.raises(error, match=word):
        Evidence([0, 0, 1, 1], **kw)


@pytest.mark.parametrize("what, word", [
    ("nan observed", "observed"), ("nan predicted", "predicted"), ("far observed", "observed"),
    ("far predicted", "predicted"), ("wrong members", "predicted"), ("wrong samples", "predicted"),
    ("flat observed", "observed")])
def test_evidence_refuses_observations_it_cannot_weigh(what, word):
    t = np.linspace(0, 1, 5)[:, None] * np.ones(3)
    pred = np.stack([t * v for v in (1.0, 1.1, 2.0, 2.1)])
    y = t * 1.05
    if what == "nan observed":
        y = y.copy()
        y[2, 1] = np.nan
    elif what == "nan predicted":
        pred = pred.copy()
        pred[1, 2, 0] = np.nan
    elif what == "far observed":
        y = y + 1e160
    elif what == "far predicted":
        pred = pred * 1e160
    elif what == "wrong members":
        pred = pred[:3]
    elif what == "wrong samples":
        pred = pred[:, :4]
    else:
        y = y.ravel()
    ev = Evidence([0, 0, 1, 1], 0.5)
    with pytest.raises(ValueError, match=word):
        ev.add(y, pred)
    assert ev.n_obs == 0  # nothing half added
    ev.add(t * 1.05, np.stack([t * v for v in (1.0, 1.1, 2.0, 2.1)]))
    assert np.all(np.isfinite(ev.belief().p))


@pytest.mark.parametrize("group", [2, -1, 0.5, "b"])
def test_log_loss_refuses_a_group_other_than_zero_or_one(group):
    b = Evidence([0, 0, 1, 1], 0.5).belief()
    with pytest.raises(ValueError, match="group"):
        b.log_loss(group)


def test_the_planning_helpers_name_bad_input():
    with pytest.raises(ValueError, match="k"):
        directions(0, random=False)
    with pytest.raises(TypeError, match="rng"):
        held_out(_scenario(*SCENARIOS[0]).group_a, 0)
    with pytest.raises(ValueError, match="max_magnitude"):
        segment_actions(10.0, max_magnitude=np.nan)
    rng = np.random.default_rng(0)
    score = lambda plans: plans.sum(axis=1)  # noqa: E731
    for kwargs, word in (({"n_elite": 9}, "n_elite"), ({"smoothing": 0.0}, "smoothing"),
                         ({"n_actions": 0}, "n_actions"),
                         ({"start": np.ones((2, 3))}, "start"),
                         ({"incumbent": np.array([0, 5])}, "plans")):
        kw = {"n_planned": 2, "n_actions": 3, "rng": rng, "n_samples": 8, "n_elite": 2,
              "n_iter": 2, "smoothing": 0.5, **kwargs}
        with pytest.raises(ValueError, match=word):
            categorical_cem(score, **kw)


def test_an_episodes_environment_built_once_flies_as_the_episode_builds_it():
    """episode_environment (what the benchmarks build outside their timings) is the wind
    fly_episode builds itself: the same rows either way; its inputs are checked."""
    from uavwind.method.closed_loop import ClosedLoop, episode_environment, fly_episode

    s = uw.make_setting("light constant", "strong constant", 2, layout="halves")
    prob = ClosedLoop(setting=s, decision_interval=6.0, report_interval=3.0)
    env = episode_environment(prob, 1, 5)
    assert env[0] in (0, 1)
    own = fly_episode(prob, "random", 1, 5)
    assert fly_episode(prob, "random", 1, 5, environment=env) == own
    with pytest.raises(ValueError, match="episode"):
        episode_environment(prob, -1, 5)
