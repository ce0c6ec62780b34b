"""The closed-loop identification problem: one UAV, one unknown wind, two known conditions.

This module owns :class:`ClosedLoop`, the problem as a frozen value: a
:class:`~uavwind.sim.setting.Setting` whose two groups are the environments the UAV *knows*
(it may simulate them), the decision grid (a new segment every ``decision_interval``
seconds, a belief reported every ``report_interval``), the action set (the paper's segment
actions: one thrust vector held for a segment) and the position noise the UAV observes its
flight through. It also owns :func:`held_out`, the test environments: drawn from one group,
never among its known environments (a new speed between two known ones, a new turbulence
seed).

Seeds (spawn keys under the run's root, :mod:`uavwind.core.seeding`): the known turbulence
``(0,)``; episode ``i``'s test environment ``(1, i)``, its observation noise ``(2, i)``, its
policy's draws ``(3, i)``; the open-loop plan ``(4,)``; with a setting's ``variability``,
the flying vehicle's draws ``(5, i)``. Episode ``i`` is flown in group ``i % 2``. So every
policy meets the same test environments under the same noise draws (and the same vehicle).

A setting with ``variability`` (:class:`~uavwind.sim.variability.FlightVariability`: an
attitude estimate and a thrust off the true ones, the battery, gusts on the test wind) makes
the vehicle that *flies* (the truth, in the test environment) as unsteady as a real one,
drawn per episode; the replays the UAV predicts with (the known environments, its belief
and its planning) keep the setting's steady vehicle and winds: a belief built on a steady
model, tested on an unsteady vehicle (a model-mismatch test). A position controller's
spread does not apply: the closed loop flies thrust segments open loop (the setting
refuses it).
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, replace
from functools import cached_property

import numpy as np

from ...core.checks import Range, check_fields, check_instance, check_scalar
from ...core.seeding import child_rng, child_seed
from ...sim.actions import MAX_THRUST
from ...sim.multirotor import Multirotor
from ...sim.setting import EnvironmentGroup, Setting
from ...sim.wind import WindGroups

__all__ = ["ClosedLoop", "held_out", "segment_actions", "SEED_KNOWN", "SEED_TEST", "SEED_NOISE",
           "SEED_POLICY", "SEED_PLAN", "SEED_TRUTH"]

#: Spawn keys of the closed loop's draws (see the module text).
SEED_KNOWN, SEED_TEST, SEED_NOISE, SEED_POLICY, SEED_PLAN, SEED_TRUTH = 0, 1, 2, 3, 4, 5


def segment_actions(magnitude_step: float = 10.0, max_magnitude: float = MAX_THRUST) -> np.ndarray:
    """The paper's segment actions: thrust vectors [N] of magnitude ``0, step, 2 step, ...,
    max_magnitude`` along +x, +y or +z (the sampler's axes), zero once; shape (n, 3).

    >>> segment_actions(10.0).shape
    (16, 3)
    """
    max_magnitude = check_scalar(max_magnitude, "max_magnitude", low=0.0,
                                 low_inclusive=False, high=1e6)
    step = check_scalar(magnitude_step, "magnitude_step", low=0, low_inclusive=False,
                        high=max_magnitude)
    levels = np.arange(1, int(math.floor(max_magnitude / step + 1e-9)) + 1) * step
    axes = np.eye(3)
    return np.concatenate([np.zeros((1, 3)),
                           (levels[None, :, None] * axes[:, None, :]).reshape(-1, 3)])


def _divides(part, whole):
    """True if ``whole`` is a whole number (>= 1) of ``part``."""
    n = whole / part
    return round(n) >= 1 and abs(n - round(n)) < 1e-9 * max(1.0, n)


def _distinct_path(values):
    """The group's velocities ordered by speed, consecutive repeats dropped (n, 3)."""
    v = np.array(values, dtype=float)
    v = v[np.argsort(np.linalg.norm(v, axis=1), kind="stable")]
    keep = np.concatenate([[True], np.any(np.diff(v, axis=0) != 0, axis=1)])
    return v[keep]


def held_out(group: EnvironmentGroup, rng: np.random.Generator) -> EnvironmentGroup:
    """One test environment of ``group``'s condition that is none of its known ones.

    Constant and shear groups: a velocity on the path through the known velocities ordered
    by speed, at a uniform position along it (so between two known ones, never equal to
    either). Turbulence: a W20 uniform in the known range; what makes it new is its gust
    series, which the caller seeds apart from the known ones.

    Raises
    ------
    ValueError
        If a constant or shear group has fewer than two distinct velocities (there is
        nothing between them to draw a new one from).
    """
    check_instance(group, "group", EnvironmentGroup)
    check_instance(rng, "rng", np.random.Generator, "numpy.random.Generator")
    if group.kind == "turbulence":
        lo, hi = min(group.values), max(group.values)
        return replace(group, values=(lo + (hi - lo) * float(rng.random()),))
    path = _distinct_path(group.values)
    if path.shape[0] < 2:
        raise ValueError(f"group {group.label or group.kind!r} needs at least two distinct "
                         f"known velocities to draw a held-out environment between them, got "
                         f"{path.shape[0]}")
    known = {tuple(v) for v in group.values}
    while True:
        u = float(rng.random()) * (path.shape[0] - 1)
        i = min(int(u), path.shape[0] - 2)
        v = path[i] + (u - i) * (path[i + 1] - path[i])
        if tuple(v.tolist()) not in known:
            return replace(group, values=(tuple(v.tolist()),))


@dataclass(frozen=True, kw_only=True)
class ClosedLoop:
    """One vehicle in one unknown wind, telling which of two known conditions it is in.

    Parameters
    ----------
    setting : Setting
        The known environments (``group_a``, ``group_b``, at least two each), the vehicle,
        the time grid (``dt``, ``duration``, ``start_altitude``) and the observation noise
        (``setting.noise.position`` [m], white, per axis; none: only the models' own spread);
        its ``variability``, if any, acts on the flying vehicle only (see the module text).
    decision_interval : float
        Seconds between decisions [s]: the flight is ``duration / decision_interval``
        segments, each one thrust vector; must divide the flight into whole segments of
        whole samples. Default 2 s.
    report_interval : float
        Seconds between reported beliefs [s], dividing ``decision_interval`` into whole
        samples. Default 1 s.
    magnitude_step : float
        Step of the action set's magnitudes [N] (:func:`segment_actions`), in (0, 50].
        Default 10 N: 16 actions.
    min_thrust : float, optional
        Smallest thrust magnitude of the action set [N], in [0, 50]. Default: 0 for the
        point mass, one magnitude step for a multirotor: at 0 N its rotors stop, its
        attitude controller has no authority and the vehicle tumbles, so its flight
        depends chaotically on the wind (end points of winds 0.01 m/s apart land metres
        apart), which no finite set of known environments can predict.
    """

    setting: Setting
    decision_interval: float = 2.0
    report_interval: float = 1.0
    magnitude_step: float = 10.0
    min_thrust: float | None = None

    def __post_init__(self):
        s = check_instance(self.setting, "setting", Setting)
        for name in ("group_a", "group_b"):
            if getattr(s, name).n_env < 2:
                raise ValueError(f"setting.{name} must hold at least 2 known environments (a "
                                 f"group's spread is learnt from its members), got "
                                 f"{getattr(s, name).n_env}")
        for name in ("group_a", "group_b"):
            g = getattr(s, name)
            if (g.kind == "turbulence" and g.variant == "cited"
                    and (g.cited is None or g.cited.seeds is not None)):
                raise ValueError(
                    f"setting.{name}: the cited Dryden code with fixed seeds gives every "
                    f"environment of one W20 the same gust series, so no test environment "
                    f"could be new; use CitedDryden(seeds=None) (a seed per environment) or "
                    f"the 'mil-f-8785c' variant")
        d = check_scalar(self.decision_interval, "decision_interval", low=0,
                         low_inclusive=False, high=s.duration)
        r = check_scalar(self.report_interval, "report_interval", low=0, low_inclusive=False,
                         high=d)
        checks = (("decision_interval", d, s.duration, f"the flight ({s.duration:g} s)"),
                  ("decision_interval", s.dt, d, f"whole samples (dt = {s.dt:g} s)"),
                  ("report_interval", r, d, f"the decision interval ({d:g} s)"),
                  ("report_interval", s.dt, r, f"whole samples (dt = {s.dt:g} s)"))
        for name, part, whole, what in checks:
            if not _divides(part, whole):
                verb = "divide" if what.startswith("the") else "be made of"
                raise ValueError(f"{name} = {getattr(self, name):g} s must {verb} {what}")
        object.__setattr__(self, "decision_interval", d)
        object.__setattr__(self, "report_interval", r)
        check_fields(self, {"magnitude_step": Range(0, MAX_THRUST, low_inclusive=False)})
        if self.min_thrust is None:
            low = self.magnitude_step if isinstance(s.uav, Multirotor) else 0.0
            object.__setattr__(self, "min_thrust", low)
        check_fields(self, {"min_thrust": Range(0.0, MAX_THRUST)})
        top = math.floor(MAX_THRUST / self.magnitude_step + 1e-9) * self.magnitude_step
        if self.min_thrust > top + 1e-12:
            raise ValueError(f"min_thrust = {self.min_thrust:g} N leaves no action: the "
                             f"largest magnitude of magnitude_step = {self.magnitude_step:g} N "
                             f"within {MAX_THRUST:g} N is {top:g} N; lower min_thrust or "
                             f"choose a step that reaches it")
        if isinstance(s.uav, Multirotor) and MAX_THRUST > s.uav.max_thrust * (1 + 1e-12):
            raise ValueError(f"setting.uav: this multirotor's rotors make at most "
                             f"{s.uav.max_thrust:.1f} N, but the actions (the segment actions "
                             f"and the sampler's sequences) go up to {MAX_THRUST:g} N; give a "
                             f"vehicle that can fly them (mass >= "
                             f"{s.uav.mass * MAX_THRUST / s.uav.max_thrust:.2f} kg)")

    # -- the grid ------------------------------------------------------------ #
    @property
    def n_samples(self) -> int:
        """Samples of the whole flight."""
        return int(round(self.setting.duration / self.setting.dt))

    @property
    def n_segments(self) -> int:
        """Decisions (segments) of a flight."""
        return int(round(self.setting.duration / self.decision_interval))

    @property
    def segment_samples(self) -> int:
        """Samples per segment."""
        return int(round(self.decision_interval / self.setting.dt))

    @property
    def report_samples(self) -> int:
        """Samples between reported beliefs."""
        return int(round(self.report_interval / self.setting.dt))

    @property
    def sigma(self) -> float:
        """Position noise [m] per axis (0 without noise)."""
        return float(self.setting.noise.position) if self.setting.noise is not None else 0.0

    @cached_property
    def actions(self) -> np.ndarray:
        """The action set, (n_actions, 3) thrust vectors [N] of magnitude at least
        ``min_thrust`` (read-only)."""
        a = segment_actions(self.magnitude_step)
        a = a[np.linalg.norm(a, axis=1) >= self.min_thrust - 1e-12]
        a.setflags(write=False)
        return a

    @property
    def random_groups(self) -> tuple[bool, bool]:
        """Whether each group is a random process (turbulence) rather than a family of
        steady winds (see :class:`~uavwind.method.closed_loop.belief.Evidence`)."""
        return (self.setting.group_a.kind == "turbulence",
                self.setting.group_b.kind == "turbulence")

    @property
    def speeds(self) -> np.ndarray:
        """Speed [m/s] (or W20) of each known environment: what orders a family."""
        return np.concatenate([self.setting.group_a.speeds, self.setting.group_b.speeds])

    @property
    def groups(self) -> np.ndarray:
        """Group (0/1) of each known environment."""
        return self.setting.groups

    # -- the environments ---------------------------------------------------- #
    def known_wind(self, seed) -> WindGroups:
        """The known environments' wind (turbulence from spawn key ``(0,)`` of ``seed``)."""
        return self.setting.wind(child_seed(seed, SEED_KNOWN))

    def test_environment(self, episode: int, seed) -> tuple[int, EnvironmentGroup]:
        """``(group, environment)`` of episode ``episode``: group ``episode % 2``, a
        :func:`held_out` environment of it drawn from spawn key ``(1, episode)``."""
        episode = check_scalar(episode, "episode", low=0, integer=True)
        g = episode % 2
        group = self.setting.group_a if g == 0 else self.setting.group_b
        return g, held_out(group, child_rng(seed, SEED_TEST, episode))

    def test_wind(self, episode: int, seed):
        """The wind model of episode ``episode``'s test environment (turbulence from spawn
        key ``(1, episode, 0)``, apart from every known environment's)."""
        _, env = self.test_environment(episode, seed)
        return env.wind(child_seed(seed, SEED_TEST, episode, 0))

    def to_dict(self) -> dict:
        d = asdict(self)
        d["setting"] = self.setting.key()
        return d

    def key(self) -> str:
        """Stable digest of the problem (the setting's key and the grid)."""
        blob = json.dumps(self.to_dict(), sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]
