"""How the UAV chooses its next segment: four policies, one planning objective.

This module owns the policies a closed-loop episode compares, each a small frozen value
with one method, ``choose(situation) -> forces`` (the thrust [N] of every sample of the
next segment):

* :class:`OpenLoopRandom` -- the paper's loop read as a classifier of one flight: a thrust
  sequence from the setting's sampler, drawn before take-off, flown whatever is seen;
* :class:`OpenLoopBest` -- the sequence of segment actions a CEM finds best on the known
  environments before take-off (one plan per problem, shared by every flight), then flown;
* :class:`Greedy` -- at each decision, the segment action with the best expected separation
  of the two groups over the next segment, predicted from where the vehicle would now be in
  each known environment;
* :class:`RecedingCEM` -- at each decision, a CEM plan of the rest of the flight (or of
  ``horizon`` segments), of which one segment is flown before planning again; its first
  plan is :class:`OpenLoopBest`'s, so the two differ only in replanning.

The planning objective (:func:`separation_bound`) is the Bhattacharyya bound on the
probability of misidentifying the group after the planned segments: for known environments
``a`` of group 0 and ``b`` of group 1 with posterior weights ``w_a``, ``w_b`` (the belief so
far) and predicted positions that differ by ``D_ab`` [m^2] (summed over the planned
samples), ``log sum_ab sqrt(w_a w_b) exp(-D_ab / (8 s^2))``. Lower is better: the manoeuvre
pulls the predictions of the environments still in doubt apart. ``s^2`` [m^2 per number] is
what blurs them: the noise, the groups' spread so far (the belief's), and the groups' own
spread *under the planned manoeuvre* (the mean squared distance between members of one
group over the planned samples). Without that last term the planner chose manoeuvres that
tear every environment apart, members of one condition as much as the two conditions: on
the multirotor a 50 N sideways thrust and a free fall at 0 N, with the motors at their
limits, after which the end point flipped between y = +50 m and -40 m across neighbouring
wind speeds of one group. Such a manoeuvre separates nothing that generalises to a new
environment, and the belief was confidently wrong after it (log-loss 33 nats in the worst
of 200 flights). To keep planning affordable on the multirotor, it looks at the
:data:`PLAN_MEMBERS` most probable known environments of each group, and leaves out any
whose weight is below :data:`PRUNE` of the largest (their terms are negligible); a group
with none left means the belief is sure, and every plan scores alike.

The CEM over segment actions is the discrete one (Rubinstein's, a categorical distribution
per planned segment, refit to the elite's frequencies with smoothing): the action set is
the paper's segment actions (:func:`~uavwind.method.closed_loop.problem.segment_actions`),
the same for every policy that plans.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ...core.checks import Range, check_array, check_fields, check_instance, check_scalar
from ...core.seeding import child_rng
from .problem import SEED_PLAN

if TYPE_CHECKING:
    from ...sim.rollout import Rollout
    from .belief import Belief
    from .problem import ClosedLoop

__all__ = ["Situation", "Policy", "OpenLoopRandom", "OpenLoopBest", "Greedy", "RecedingCEM",
           "POLICIES", "get_policy", "separation_bound", "categorical_cem", "open_loop_plan",
           "PRUNE", "PLAN_MEMBERS"]

#: Known environments whose posterior weight is below this share of the largest are left
#: out of the planning.
PRUNE = 1e-6
#: The planning looks at this many known environments of each group at most: the most
#: probable ones.
PLAN_MEMBERS = 3


@dataclass
class Situation:
    """What a policy knows when it chooses a segment.

    Attributes
    ----------
    problem : ClosedLoop
    planner : Rollout
        The known environments' rollout the policy plans with (rows ``0 .. n_known-1``).
    states : ndarray, shape (n_known, state_size)
        Where the vehicle would now be in each known environment (its replays).
    sample : int
        Samples flown so far.
    segment : int
        Index of the segment to choose.
    belief : Belief
        The posterior after the samples flown.
    rng : numpy.random.Generator
        The episode's own draws for the policy (spawn key ``(3, episode)``).
    seed : numpy.random.SeedSequence
        The run's root (for what every episode shares, such as the open-loop plan).
    memory : dict
        The policy's notes within one episode.
    planned_rows : int
        Row-samples the policy's planning has simulated in this flight (a cost count; the
        open-loop plan every flight shares is not counted).
    members : list of 2 arrays, optional
        Each group's known environments in speed order (default: index order).
    """

    problem: ClosedLoop
    planner: Rollout
    states: np.ndarray
    sample: int
    segment: int
    belief: Belief
    rng: np.random.Generator
    seed: Any
    memory: dict = field(default_factory=dict)
    planned_rows: int = 0
    members: list | None = None


def _spread_order(k):
    """Positions 0 .. k-1 ordered to cover a range early: the ends, the middle, then the
    middles between (0, k-1, k//2, ...)."""
    order, spans = [0, k - 1][:k], [(0, k - 1)]
    while len(order) < k:
        nxt = []
        for a, b in spans:
            m = (a + b) // 2
            if m not in order and a < m < b:
                order.append(m)
            nxt += [(a, m), (m, b)]
        if not nxt or spans == nxt:
            order += [i for i in range(k) if i not in order]
        spans = nxt
    return order


def _most_probable(idx, w):
    """The :data:`PLAN_MEMBERS` of ``idx`` (a group's members, in speed order) with the
    largest weights, ties broken to cover the group's range (its ends and middle first),
    returned in speed order."""
    if idx.size <= PLAN_MEMBERS:
        return idx
    rank = np.empty(idx.size, dtype=np.intp)
    rank[_spread_order(idx.size)] = np.arange(idx.size)
    order = np.lexsort((rank, -w[idx]))  # by weight, then by spread rank
    return idx[np.sort(order[:PLAN_MEMBERS])]


def separation_bound(sit: Situation, plans: np.ndarray) -> np.ndarray:
    """The planning objective of each plan (lower separates better; see the module text).

    Parameters
    ----------
    sit : Situation
    plans : ndarray of int, shape (n_plans, n_planned)
        Action indices of the next ``n_planned`` segments.

    Returns
    -------
    ndarray, shape (n_plans,)
        ``log`` of the Bhattacharyya bound after the planned segments.
    """
    prob = sit.problem
    w = sit.belief.weights
    groups = prob.groups
    live = w >= PRUNE * w.max()
    members = sit.members if sit.members is not None else [np.flatnonzero(groups == g)
                                                             for g in (0, 1)]
    a, b = (_most_probable(m[live[m]], w) for m in members)
    plans = _check_plans(plans, len(prob.actions))
    if a.size == 0 or b.size == 0:  # the belief is sure: nothing left to separate
        return np.full(plans.shape[0], -np.inf)
    uniq, inv = np.unique(plans, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    envs = np.concatenate([a, b])
    n_live = envs.size
    rows = np.tile(envs, uniq.shape[0])
    states = sit.states[rows]
    m = prob.segment_samples
    pair = np.zeros((uniq.shape[0], a.size, b.size))
    within = np.zeros(uniq.shape[0])  # summed squared distances within the groups
    n_within = a.size * (a.size - 1) // 2 + b.size * (b.size - 1) // 2
    for r in range(uniq.shape[1]):
        forces = np.repeat(prob.actions[uniq[:, r]], n_live, axis=0)
        states, pos = sit.planner.advance(states, rows, forces, sit.sample + r * m, m)
        pos = pos.reshape(uniq.shape[0], n_live, m, 3)
        d = pos[:, :a.size, None] - pos[:, None, a.size:]
        pair += np.einsum("kabts,kabts->kab", d, d)
        for part in (pos[:, :a.size], pos[:, a.size:]):
            dd = part[:, :, None] - part[:, None, :]
            within += 0.5 * np.einsum("kijts,kijts->k", dd, dd)
    sit.planned_rows += rows.size * m * uniq.shape[1]
    # the groups' own spread under the plan blurs its separation (per number, per pair)
    n_numbers = 3 * m * uniq.shape[1]
    spread = sit.belief.spread + (within / (n_within * n_numbers) if n_within else 0.0)
    log_c = 0.5 * (np.log(w[a])[:, None] + np.log(w[b])[None, :])
    from scipy.special import logsumexp  # here: see belief.Evidence.belief
    val = logsumexp(log_c[None] - pair / (8.0 * spread[:, None, None]), axis=(1, 2))
    return val[inv]


def _check_plans(plans, n_actions):
    """``plans`` as an (n_plans, n_planned) index array of actions in ``[0, n_actions)``."""
    arr = np.asarray(plans)
    if arr.ndim != 2 or arr.shape[0] < 1 or arr.shape[1] < 1 or arr.dtype.kind not in "iu":
        raise ValueError(f"plans must be a 2-D array of action indices (n_plans, n_planned), "
                         f"got shape {arr.shape} and dtype {arr.dtype}")
    if arr.min() < 0 or arr.max() >= n_actions:
        raise ValueError(f"plans must hold action indices in [0, {n_actions - 1}], got "
                         f"{arr.min()} .. {arr.max()}")
    return arr.astype(np.intp, copy=False)


def categorical_cem(score, n_planned: int, n_actions: int, rng: np.random.Generator,
                    n_samples: int, n_elite: int, n_iter: int, smoothing: float,
                    start: np.ndarray | None = None,
                    incumbent: np.ndarray | None = None) -> tuple[np.ndarray, float, np.ndarray]:
    """Discrete CEM: ``(best plan (n_planned,), its score, final distributions)``, lower
    scores better.

    Each iteration draws ``n_samples`` plans, each segment's action from its categorical
    distribution (``start`` (n_planned, n_actions), else uniform); the ``n_elite``
    lowest-scoring plans (ties: the earlier) refit every distribution to
    ``(1 - smoothing) p + smoothing f``, ``f`` the elite's action frequencies. An
    ``incumbent`` plan takes the place of the first iteration's first sample (a replan is
    then never worse, by the objective, than keeping the plan). The best plan seen in any
    iteration is returned.
    """
    n_planned = check_scalar(n_planned, "n_planned", low=1, high=10 ** 4, integer=True)
    n_actions = check_scalar(n_actions, "n_actions", low=1, high=10 ** 6, integer=True)
    n_samples = check_scalar(n_samples, "n_samples", low=1, high=10 ** 6, integer=True)
    n_elite = check_scalar(n_elite, "n_elite", low=1, high=n_samples, integer=True)
    n_iter = check_scalar(n_iter, "n_iter", low=1, high=10 ** 4, integer=True)
    smoothing = check_scalar(smoothing, "smoothing", low=0.0, low_inclusive=False, high=1.0)
    check_instance(rng, "rng", np.random.Generator, "numpy.random.Generator")
    if start is None:
        probs = np.full((n_planned, n_actions), 1.0 / n_actions)
    else:
        probs = check_array(start, "start", shape=(n_planned, n_actions)).copy()
        if np.any(probs < 0) or np.any(np.abs(probs.sum(axis=1) - 1.0) > 1e-9):
            raise ValueError("start must hold one probability distribution per planned "
                             "segment (rows >= 0 summing to 1)")
    if incumbent is not None:
        incumbent = _check_plans(np.asarray(incumbent)[None], n_actions)[0]
        if incumbent.shape[0] != n_planned:
            raise ValueError(f"incumbent must plan {n_planned} segments, got "
                             f"{incumbent.shape[0]}")
    best, best_val = None, np.inf
    for it in range(n_iter):
        u = rng.random((n_samples, n_planned))
        cdf = np.cumsum(probs, axis=1)
        plans = np.minimum((u[:, :, None] > cdf[None]).sum(axis=2), n_actions - 1)
        if it == 0 and incumbent is not None:
            plans[0] = incumbent
        vals = np.asarray(score(plans), dtype=float)
        order = np.argsort(vals, kind="stable")
        if best is None or vals[order[0]] < best_val:
            best, best_val = plans[order[0]].copy(), float(vals[order[0]])
        elite = plans[order[:n_elite]]
        freq = np.stack([np.bincount(elite[:, r], minlength=n_actions) for r in range(n_planned)])
        probs = (1.0 - smoothing) * probs + smoothing * freq / n_elite
    return best, best_val, probs


_PLANS: OrderedDict = OrderedDict()  # (problem, CEM size, seed) -> open-loop plan, per process


def open_loop_plan(sit: Situation, n_samples: int, n_elite: int, n_iter: int,
                   smoothing: float, planning_substeps: int) -> tuple[np.ndarray, np.ndarray]:
    """``(plan, final distributions)``: the CEM's best sequence of segment actions for the
    whole flight from the prior, drawn from spawn key ``(4,)`` of the run's root. Every
    flight of a problem starts from the same situation (nothing seen yet, the same known
    environments), so the plan is computed once per process and shared."""
    seed = sit.seed
    key = (sit.problem.key(), n_samples, n_elite, n_iter, smoothing, planning_substeps,
           repr(seed.entropy), tuple(seed.spawn_key))
    if key not in _PLANS:
        counted = sit.planned_rows  # shared work: not any one flight's planning cost
        plan, _, probs = categorical_cem(lambda p: separation_bound(sit, p),
                                         sit.problem.n_segments, len(sit.problem.actions),
                                         child_rng(seed, SEED_PLAN), n_samples, n_elite,
                                         n_iter, smoothing)
        sit.planned_rows = counted
        _PLANS[key] = (plan, probs)
        while len(_PLANS) > 64:
            _PLANS.popitem(last=False)
    return _PLANS[key]


def _hold(sit, action):
    return np.repeat(sit.problem.actions[action][None], sit.problem.segment_samples, axis=0)


@dataclass(frozen=True, kw_only=True)
class Policy:
    """A way of choosing the next segment (see the module text)."""

    key: ClassVar[str] = ""
    name: ClassVar[str] = ""
    closed: ClassVar[bool] = False

    def choose(self, sit: Situation) -> np.ndarray:  # pragma: no cover - abstract
        """The thrust [N] of each sample of the next segment, shape (segment_samples, 3)."""
        raise NotImplementedError

    def to_dict(self) -> dict:
        """The policy's short name and its fields."""
        return {"policy": self.key, **asdict(self)}


@dataclass(frozen=True, kw_only=True)
class OpenLoopRandom(Policy):
    """The paper's loop: a sequence from the setting's sampler, drawn before take-off."""

    key: ClassVar[str] = "random"
    name: ClassVar[str] = "open-loop random"

    def choose(self, sit: Situation) -> np.ndarray:
        s = sit.problem.setting
        if "sequence" not in sit.memory:
            sit.memory["sequence"] = s.sample_thrust(sit.rng)
        t = (sit.sample + np.arange(sit.problem.segment_samples)) * s.dt
        return sit.memory["sequence"].thrust(t)


#: The CEM policies' sizes (a policy's ``__post_init__`` checks them once).
_CEM_RANGES = {"n_samples": Range(1, 10 ** 4, integer=True),
               "n_elite": lambda s: Range(1, s.n_samples, integer=True),
               "n_iter": Range(1, 1000, integer=True),
               "smoothing": Range(0, 1, low_inclusive=False),
               "planning_substeps": Range(1, 100, integer=True)}


def _check_cem(self):
    check_fields(self, _CEM_RANGES)


@dataclass(frozen=True, kw_only=True)
class OpenLoopBest(Policy):
    """The CEM's best sequence of segment actions on the known environments, planned once
    before take-off from the prior and flown as planned.

    Parameters
    ----------
    n_samples, n_elite, n_iter : int
        The CEM's plans per iteration, elite and iterations.
    smoothing : float
        In (0, 1]: the weight of the elite's frequencies in each refit.
    planning_substeps : int
        RK4 steps per control step of the multirotor the plan is simulated with (the
        point mass ignores it).
    """

    key: ClassVar[str] = "best"
    name: ClassVar[str] = "open-loop best"
    n_samples: int = 64
    n_elite: int = 6
    n_iter: int = 5
    smoothing: float = 0.7
    planning_substeps: int = 1

    def __post_init__(self):
        _check_cem(self)

    def choose(self, sit: Situation) -> np.ndarray:
        plan, _ = open_loop_plan(sit, self.n_samples, self.n_elite, self.n_iter,
                                 self.smoothing, self.planning_substeps)
        return _hold(sit, plan[sit.segment])


@dataclass(frozen=True, kw_only=True)
class Greedy(Policy):
    """Each segment: every action of the set tried from the current replays, the one with
    the best separation over that segment flown.

    Parameters
    ----------
    planning_substeps : int
        RK4 steps per control step of the multirotor the candidates are simulated with.
    """

    key: ClassVar[str] = "greedy"
    name: ClassVar[str] = "closed-loop greedy"
    closed: ClassVar[bool] = True
    planning_substeps: int = 1

    def __post_init__(self):
        check_fields(self, {"planning_substeps": _CEM_RANGES["planning_substeps"]})

    def choose(self, sit: Situation) -> np.ndarray:
        plans = np.arange(len(sit.problem.actions))[:, None]
        vals = separation_bound(sit, plans)
        return _hold(sit, int(np.argmin(vals)))


@dataclass(frozen=True, kw_only=True)
class RecedingCEM(Policy):
    """Each segment: a CEM plan of the rest of the flight (at most ``horizon`` segments)
    from the current replays and belief; its first segment is flown, then it plans again.

    The first plan is :class:`OpenLoopBest`'s (the same situation, the same CEM: computed
    once). Each replan is warm-started: its distributions start from the previous plan's
    final ones, shifted by the segment flown and mixed half and half with uniform, and the
    rest of the previous plan is one of its samples.

    Parameters
    ----------
    n_samples, n_elite, n_iter, smoothing, planning_substeps
        As :class:`OpenLoopBest`, for the first plan.
    replan_samples, replan_iter : int
        Plans per iteration and iterations of each replan.
    horizon : int, optional
        Segments planned at most (default: the rest of the flight).
    """

    key: ClassVar[str] = "receding"
    name: ClassVar[str] = "closed-loop receding CEM"
    closed: ClassVar[bool] = True
    n_samples: int = 64
    n_elite: int = 6
    n_iter: int = 5
    smoothing: float = 0.7
    planning_substeps: int = 1
    replan_samples: int = 16
    replan_iter: int = 2
    horizon: int | None = None

    def __post_init__(self):
        _check_cem(self)
        check_fields(self, {"replan_samples": Range(1, 10 ** 4, integer=True),
                            "replan_iter": Range(1, 10 ** 4, integer=True)})
        if self.replan_samples < self.n_elite:
            raise ValueError(f"replan_samples must be >= n_elite ({self.n_elite}), got "
                             f"{self.replan_samples}")
        if self.horizon is not None:
            check_fields(self, {"horizon": Range(1, 10 ** 4, integer=True)})

    def choose(self, sit: Situation) -> np.ndarray:
        prob = sit.problem
        left = prob.n_segments - sit.segment
        n_planned = left if self.horizon is None else min(self.horizon, left)
        if sit.segment == 0:
            plan, probs = open_loop_plan(sit, self.n_samples, self.n_elite, self.n_iter,
                                         self.smoothing, self.planning_substeps)
        else:
            prev_plan, prev_probs = sit.memory["plan"]
            uniform = np.full((n_planned, len(prob.actions)), 1.0 / len(prob.actions))
            start = uniform.copy()
            keep = min(n_planned, prev_probs.shape[0] - 1)
            start[:keep] = 0.5 * prev_probs[1:1 + keep] + 0.5 * uniform[:keep]
            incumbent = np.zeros(n_planned, dtype=np.intp)
            incumbent[:keep] = prev_plan[1:1 + keep]
            plan, _, probs = categorical_cem(lambda p: separation_bound(sit, p), n_planned,
                                             len(prob.actions), sit.rng, self.replan_samples,
                                             self.n_elite, self.replan_iter, self.smoothing,
                                             start=start, incumbent=incumbent)
        sit.memory["plan"] = (plan[:n_planned], probs[:n_planned])
        return _hold(sit, int(plan[0]))


#: The policies by their short names.
POLICIES = {"random": OpenLoopRandom, "best": OpenLoopBest, "greedy": Greedy,
            "receding": RecedingCEM}


def get_policy(policy: str | Policy) -> Policy:
    """A :class:`Policy`: itself, or the default of a name of :data:`POLICIES`."""
    if isinstance(policy, Policy):
        return policy
    if isinstance(policy, str) and policy in POLICIES:
        return POLICIES[policy]()
    if isinstance(policy, str):
        raise ValueError(f"policy must be one of {sorted(POLICIES)} or a Policy, got {policy!r}")
    return check_instance(policy, "policy", Policy)
