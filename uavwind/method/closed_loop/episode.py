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
from ...sim.wind import WindGroups
from .belief import Evidence
from .policies import Policy, Situation, get_policy
from .problem import SEED_NOISE, SEED_POLICY, SEED_TEST, ClosedLoop

__all__ = ["fly_episode", "episode_environment", "run_episodes", "EPISODE_COLUMNS"]

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
    states = world.start(rows_env, np.array([0.0, 0.0, s.start_altitude]))
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
            f = np.repeat(forces[a][None], n_known + 1, axis=0)
            states, pos[:, a:b] = world.advance(states, rows_env, f, j * m + a, b - a)
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
