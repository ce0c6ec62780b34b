"""Flying closed-loop episodes: one vehicle, one held-out wind, each policy, a belief every
report interval.

This module owns :func:`fly_episode` (one flight of one policy, its rows),
:func:`episode_environment` (an episode's held-out wind, built once for its policies) and
:func:`run_episodes` (a range of episodes, every policy in each, over worker processes, in
episode order; the same rows whatever the number of workers, since every draw of an
episode comes from its own spawn key).

One episode: the test environment of episode ``i`` (:meth:`ClosedLoop.test_environment`)
and the known environments are rows of one :class:`~uavwind.sim.rollout.Rollout`; at each
decision the policy sees the belief and the replays' states and returns the next segment's
thrust; the vehicle flies it in the test environment (the *world*) and in every known
environment (the *replays*, which the UAV can compute: it knows its actions and where it
started); the world's positions plus the episode's noise are the observations; the belief
is reported every ``report_interval``. Every policy of one episode meets the same test
environment under the same noise draws (its gusts are built once).

With a setting's ``variability`` the world is flown apart from the replays, by
:func:`truth_rollout`: the vehicle drawn for the episode (its battery), the test wind plus
Dryden gusts on its mean, and the attitude-estimate and thrust errors within the flight,
all from spawn key ``(5, episode)``, the same for every policy; the replays and the planner
keep the steady vehicle (:mod:`~uavwind.method.closed_loop.problem`: a model-mismatch test).
Without it (or with every source 0) the episode is flown exactly as before it existed.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence

import numpy as np
import pandas as pd

from ...core.checks import check_instance, check_scalar
from ...core.io import refuse_to_compute
from ...core.parallel import check_jobs, pin_threads, stop_workers
from ...core.seeding import child_rng, child_seed, root_seed
from ...sim.rollout import Rollout
from ...sim.vehicle import n_steps as _n_steps
from ...sim.wind import WindGroups
from .belief import Evidence
from .policies import Policy, Situation, get_policy
from .problem import SEED_NOISE, SEED_POLICY, SEED_TEST, SEED_TRUTH, ClosedLoop

__all__ = ["fly_episode", "episode_environment", "truth_rollout", "run_episodes",
           "EPISODE_COLUMNS"]

#: The columns of an episode's rows (one row per policy and reported belief).
EPISODE_COLUMNS = ("episode", "policy", "test_group", "test_speed", "time", "segment",
                   "p_group_b", "p_true", "predicted", "correct", "log_loss", "thrust",
                   "planned_rows")

_KNOWN: OrderedDict = OrderedDict()  # (problem, seed) -> the known wind, per process


def _known_wind(problem, root):
    key = (problem.key(), repr(root.entropy), tuple(root.spawn_key))
    if key not in _KNOWN:
        _KNOWN[key] = problem.known_wind(root)
        while len(_KNOWN) > 16:
            _KNOWN.popitem(last=False)
    return _KNOWN[key]


def _runs(forces):
    """``(start, stop)`` of each run of equal rows of ``forces``."""
    change = np.flatnonzero(np.any(np.diff(forces, axis=0) != 0, axis=1)) + 1
    edges = np.concatenate([[0], change, [forces.shape[0]]])
    return list(zip(edges[:-1].tolist(), edges[1:].tolist()))


def fly_episode(problem: ClosedLoop, policy: str | Policy, episode: int,
                seed: int | np.random.SeedSequence = 0, *,
                environment: tuple | None = None) -> list[dict]:
    """Fly episode ``episode`` of ``problem`` with ``policy``: one row per reported belief
    (the columns of :data:`EPISODE_COLUMNS`; ``time`` [s] when the belief was formed,
    ``thrust`` the mean thrust [N] flown since the previous report). ``environment``:
    :func:`episode_environment` of the same problem, episode and seed, to build the test
    wind once for several policies (trusted as such); None builds it here."""
    check_instance(problem, "problem", ClosedLoop)
    policy = get_policy(policy)
    episode = check_scalar(episode, "episode", low=0, high=10 ** 9, integer=True)
    root = root_seed(seed)
    s = problem.setting
    group, env, test_wind = environment or _episode_environment(problem, episode, root)
    known = _known_wind(problem, root)
    world = Rollout.for_flight(s.uav, WindGroups(known, test_wind), s.dt, s.duration)
    n_known = known.n_env
    rows_env = np.arange(n_known + 1)  # the known environments, then the world
    start = np.array([0.0, 0.0, s.start_altitude])
    states = world.start(rows_env, start)
    truth = None
    if s.varies:  # the world flies apart: the unsteady vehicle; the replays stay steady
        truth, errors = _truth_rollout(problem, episode, root, env, test_wind)
        rows_env = rows_env[:n_known]
        states = states[:n_known]
        truth_state = truth.start(np.zeros(1, dtype=np.intp), start)
        per = truth.steps_per_sample
    noise = problem.sigma * child_rng(root, SEED_NOISE, episode).standard_normal(
        (problem.n_samples, 3))
    evidence = Evidence(problem.groups, problem.sigma, random=problem.random_groups,
                        speeds=problem.speeds)
    substeps = getattr(policy, "planning_substeps", None)
    planner = world if substeps is None else world.with_substeps(substeps)
    sit = Situation(problem=problem, planner=planner, states=states[:n_known], sample=0,
                    segment=0, belief=evidence.belief(),
                    rng=child_rng(root, SEED_POLICY, episode), seed=root,
                    members=evidence.members)
    m, every = problem.segment_samples, problem.report_samples
    speed = float(env.speeds[0])
    out = []
    for j in range(problem.n_segments):
        sit.states, sit.sample, sit.segment = states[:n_known], j * m, j
        forces = np.asarray(policy.choose(sit), dtype=float)
        if forces.shape != (m, 3) or not np.all(np.isfinite(forces)):
            raise ValueError(f"policy {policy.name!r} must return finite forces of shape "
                             f"({m}, 3), got {forces.shape}")
        pos = np.empty((n_known + 1, m, 3))
        for a, b in _runs(forces):
            f = np.repeat(forces[a][None], rows_env.size, axis=0)
            states, pos[:rows_env.size, a:b] = world.advance(states, rows_env, f, j * m + a,
                                                             b - a)
            if truth is not None:
                k0, k1 = (j * m + a) * per, (j * m + b) * per
                truth_state, pos[n_known:, a:b] = truth.advance(
                    truth_state, np.zeros(1, dtype=np.intp), forces[a][None], j * m + a,
                    b - a, state_errors=None if errors is None else errors[:, k0:k1])
        observed = pos[n_known] + noise[j * m:(j + 1) * m]
        for a in range(0, m, every):
            evidence.add(observed[a:a + every], pos[:n_known, a:a + every])
            belief = evidence.belief()
            out.append({"episode": episode, "policy": policy.key, "test_group": group,
                        "test_speed": speed, "time": round((j * m + a + every) * s.dt, 9),
                        "segment": j, "p_group_b": float(belief.p[1]),
                        "p_true": float(belief.p[group]), "predicted": belief.predicted,
                        "correct": belief.predicted == group,
                        "log_loss": belief.log_loss(group),
                        "thrust": forces[a:a + every].mean(axis=0).tolist(),
                        "planned_rows": sit.planned_rows})
        sit.belief = belief
    return out


def episode_environment(problem: ClosedLoop, episode: int,
                        seed: int | np.random.SeedSequence = 0) -> tuple:
    """``(group, environment, wind)`` of episode ``episode`` of ``problem`` under ``seed``:
    the held-out test environment (:meth:`ClosedLoop.test_environment`) and its wind, built
    once, which every policy of the episode flies through (``fly_episode(...,
    environment=...)``)."""
    check_instance(problem, "problem", ClosedLoop)
    episode = check_scalar(episode, "episode", low=0, high=10 ** 9, integer=True)
    return _episode_environment(problem, episode, root_seed(seed))


def truth_rollout(problem: ClosedLoop, episode: int, seed: int | np.random.SeedSequence = 0,
                  ) -> tuple[Rollout, np.ndarray | None]:
    """``(rollout, state_errors)`` of the vehicle that flies episode ``episode`` of a problem
    whose setting has ``variability``: one row, the episode's vehicle
    (:meth:`~uavwind.sim.variability.FlightVariability.vehicle`, its battery) in its test
    wind plus Dryden gusts on the test environment's mean speed (none on a turbulence
    group's zero mean, beyond the floor), and its state errors (1, control steps of the
    flight, 6) or None, all drawn from spawn key ``(5, episode)`` of ``seed``
    (:mod:`~uavwind.method.closed_loop.episode`). ``ValueError`` without variability."""
    check_instance(problem, "problem", ClosedLoop)
    episode = check_scalar(episode, "episode", low=0, high=10 ** 9, integer=True)
    if not problem.setting.varies:
        raise ValueError("problem.setting has no variability (None or every source 0): the "
                         "world flies with the replays, there is no separate truth")
    root = root_seed(seed)
    _, env, test_wind = _episode_environment(problem, episode, root)
    return _truth_rollout(problem, episode, root, env, test_wind)


def _truth_rollout(problem, episode, root, env, test_wind):
    s = problem.setting
    var = s.variability
    vs = child_seed(root, SEED_TRUTH, episode)
    uav = var.vehicle(s.uav, vs)
    mean = 0.0 if env.kind == "turbulence" else float(env.speeds[0])
    gusts = var.gusts(np.array([mean]), s.start_altitude, s.dt, vs)
    rollout = Rollout.for_flight(uav, test_wind, s.dt, s.duration, gusts=gusts)
    errors = None
    if var.has_errors:
        n_ctrl = _n_steps(s.dt, s.duration) * uav.check_grid(s.dt)
        errors = var.state_errors(1, n_ctrl, uav.control_rate, vs)
    return rollout, errors


def _episode_environment(problem, episode, root):
    """:func:`episode_environment` on checked inputs (the fill's episodes, fly_episode)."""
    group, env = problem.test_environment(episode, root)
    return group, env, env.wind(child_seed(root, SEED_TEST, episode, 0))


def _episode(problem, policies, episode, root, pin):
    if pin:
        pin_threads()
    test = _episode_environment(problem, episode, root)
    return [row for p in policies
            for row in fly_episode(problem, p, episode, root, environment=test)]


def _check_policies(policies):
    if isinstance(policies, (str, Policy)):
        policies = [policies]
    if not isinstance(policies, Sequence) or not policies:
        raise ValueError(f"policies must be a policy or a non-empty list of them, got "
                         f"{policies!r}")
    out = [get_policy(p) for p in policies]
    keys = [p.key for p in out]
    if len(set(keys)) != len(keys):
        raise ValueError(f"policies must not repeat a kind of policy, got {keys}")
    return out


def run_episodes(problem: ClosedLoop, policies: str | Policy | Sequence[str | Policy],
                 start: int = 0, stop: int = 20, seed: int | np.random.SeedSequence = 0,
                 n_jobs: int | None = 1) -> pd.DataFrame:
    """Episodes ``start .. stop-1`` of ``problem``, each flown by every policy of
    ``policies`` (names of :data:`~uavwind.method.closed_loop.policies.POLICIES` or
    :class:`Policy` values): one row per episode, policy and reported belief
    (:data:`EPISODE_COLUMNS`), in episode order; the rows do not depend on ``n_jobs``
    (-1/None: all cores). Under ``UAVWIND_PAGES_READ_ONLY`` a ``RuntimeError``: a book
    page reads episodes the fill flew."""
    refuse_to_compute("closed-loop episodes (run_episodes)")
    check_instance(problem, "problem", ClosedLoop)
    policies = _check_policies(policies)
    start = check_scalar(start, "start", low=0, high=10 ** 9, integer=True)
    stop = check_scalar(stop, "stop", low=start + 1, high=10 ** 9, integer=True)
    n_jobs = check_jobs(n_jobs)
    root = root_seed(seed)
    if n_jobs == 1:
        parts = [_episode(problem, policies, i, root, False) for i in range(start, stop)]
    else:
        from joblib import Parallel, delayed
        try:
            parts = Parallel(n_jobs=n_jobs)(delayed(_episode)(problem, policies, i, root, True)
                                            for i in range(start, stop))
        except BaseException:
            stop_workers()
            raise
    df = pd.DataFrame([r for part in parts for r in part], columns=list(EPISODE_COLUMNS))
    df.attrs.update(problem=problem.key(), policies=[p.to_dict() for p in policies])
    return df
