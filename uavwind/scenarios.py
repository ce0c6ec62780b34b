"""The paper's wind conditions, environment groups and loop settings.

This module owns the translation from the paper's words ("light constant vs
strong shear, 5 environments each") into concrete environments (DESIGN
decision 5):

* :data:`SPEED_RANGES` -- the US National Weather Service ranges [m/s];
* :data:`PAPER_SCENARIOS` -- the seven condition pairs of Table 2;
* :func:`table3_setting` -- the worked example of Table 3, verbatim;
* :class:`EnvironmentGroup` -- one wind condition's environments;
* :class:`Setting` -- everything one loop needs (two groups, thrust sampler,
  UAV, time grid); hashable, with a stable :meth:`Setting.key` for caching;
* builders for the experiments: :func:`make_setting`,
  :func:`range_similarity_settings` (Exp 2), :func:`environment_count_settings`
  (Exp 3), :func:`direction_settings` (Exp 5).

Generated groups place ``n`` speeds at the centres of ``n`` equal cells of the
condition's range, along the horizontal direction x = y; speeds are wind-speed
magnitudes [m/s] (for turbulence: W20). When both groups have the same
strength the range is split into two adjacent halves, lower half to group A.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import pandas as pd

from .actions import SAMPLERS
from .config import UAV, check_scalar
from .wind import CombinedWind, ConstantWind, DrydenWind, ShearWind

__all__ = [
    "SPEED_RANGES", "KINDS", "WindCondition", "EnvironmentGroup", "Setting",
    "PAPER_SCENARIOS", "scenario_table", "group_speeds", "make_group", "make_setting",
    "table3_setting", "range_similarity_settings", "environment_count_settings",
    "direction_settings", "HORIZONTAL",
]

#: NWS wind-speed classes [m/s] (paper section "Experiments").
SPEED_RANGES = {"light": (0.45, 1.34), "strong": (11.18, 13.86)}
#: Wind models a condition can use.
KINDS = ("constant", "shear", "turbulence")
#: Default direction of generated winds: horizontal, x = y.
HORIZONTAL = (math.sqrt(0.5), math.sqrt(0.5), 0.0)


@dataclass(frozen=True)
class WindCondition:
    """A wind class: strength (``"light"``/``"strong"``) and kind (constant, shear, turbulence).

    >>> WindCondition.parse("light shear")
    WindCondition(strength='light', kind='shear')
    """

    strength: str
    kind: str

    def __post_init__(self):
        if self.strength not in SPEED_RANGES:
            raise ValueError(f"strength must be one of {sorted(SPEED_RANGES)}, got {self.strength!r}")
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {list(KINDS)}, got {self.kind!r}")

    @classmethod
    def parse(cls, text):
        """From ``"light constant"``, ``"strong turbulence"``, ... (or a WindCondition)."""
        if isinstance(text, WindCondition):
            return text
        if not isinstance(text, str):
            raise TypeError(f"condition must be a string like 'light constant', got {type(text).__name__}")
        parts = text.lower().split()
        if len(parts) != 2:
            raise ValueError(f"condition must read '<strength> <kind>', e.g. 'light constant', got {text!r}")
        return cls(*parts)

    @property
    def label(self):
        return f"{self.strength} {self.kind}"

    @property
    def speed_range(self):
        return SPEED_RANGES[self.strength]


#: Table 2: scenario number -> (wind condition 1, wind condition 2).
PAPER_SCENARIOS = {
    1: (WindCondition("light", "constant"), WindCondition("light", "constant")),
    2: (WindCondition("light", "constant"), WindCondition("strong", "constant")),
    3: (WindCondition("strong", "constant"), WindCondition("strong", "constant")),
    4: (WindCondition("light", "shear"), WindCondition("light", "shear")),
    5: (WindCondition("light", "shear"), WindCondition("strong", "shear")),
    6: (WindCondition("strong", "shear"), WindCondition("strong", "shear")),
    7: (WindCondition("light", "constant"), WindCondition("strong", "turbulence")),
}


def scenario_table():
    """Table 2 as a DataFrame (index: scenario)."""
    return pd.DataFrame(
        [(k, a.label, b.label) for k, (a, b) in PAPER_SCENARIOS.items()],
        columns=["Scenario", "Wind condition 1", "Wind condition 2"]).set_index("Scenario")


@dataclass(frozen=True)
class EnvironmentGroup:
    """The environments of one wind condition.

    Parameters
    ----------
    kind : {"constant", "shear", "turbulence"}
    values : tuple
        ``constant``/``shear``: one velocity ``(x, y, z)`` [m/s] per environment
        (for shear, at ``reference_height``); ``turbulence``: one W20 [m/s]
        per environment.
    label : str
        Human-readable name, e.g. ``"light constant"``.
    alpha, reference_height, floor : float
        Shear profile (see :class:`~uavwind.wind.ShearWind`).
    altitude : float
        Altitude of the Dryden parameters [m] (see :class:`~uavwind.wind.DrydenWind`).
    """

    kind: str
    values: tuple
    label: str = ""
    alpha: float = 0.143
    reference_height: float = 10.0
    floor: float = 0.5
    altitude: float = 10.0

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {list(KINDS)}, got {self.kind!r}")
        if self.kind == "turbulence":
            vals = tuple(float(v) for v in np.ravel(self.values))
            if any(not (math.isfinite(v) and v > 0) for v in vals):
                raise ValueError("values (W20 speeds) must be finite and > 0 m/s")
        else:
            arr = np.asarray(self.values, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != 3:
                raise ValueError(f"values must have shape (n_env, 3) for {self.kind} wind, got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError("values must contain only finite velocities (no NaN or inf)")
            vals = tuple(tuple(float(x) for x in row) for row in arr)
        if len(vals) == 0:
            raise ValueError("values must describe at least one environment")
        object.__setattr__(self, "values", vals)

    @property
    def n_env(self):
        return len(self.values)

    @property
    def speeds(self):
        """Wind speed of each environment [m/s]: |velocity| or W20."""
        if self.kind == "turbulence":
            return np.array(self.values)
        return np.linalg.norm(np.array(self.values), axis=1)

    def wind(self, seed=None):
        """The :class:`~uavwind.wind.WindModel` of this group (``seed`` for turbulence)."""
        if self.kind == "constant":
            return ConstantWind(self.values)
        if self.kind == "shear":
            return ShearWind(self.values, reference_height=self.reference_height,
                             alpha=self.alpha, floor=self.floor)
        return DrydenWind(self.values, altitude=self.altitude, seed=seed)

    def subset(self, keep):
        """Group with only the environments at indices ``keep`` (order kept)."""
        keep = sorted(int(i) for i in keep)
        return replace(self, values=tuple(self.values[i] for i in keep))

    def negated(self):
        """Same group with every wind velocity reversed (Exp 5's opposite direction)."""
        if self.kind == "turbulence":
            raise ValueError("a turbulence group is zero-mean: it has no direction to negate")
        return replace(self, values=tuple(tuple(-x for x in v) for v in self.values),
                       label=f"{self.label} (reversed)".strip())

    def to_frame(self):
        """The group as the paper prints it (Table 3): one row per environment."""
        if self.kind == "turbulence":
            return pd.DataFrame({"W20 (m/s)": self.values})
        return pd.DataFrame(np.array(self.values),
                            columns=["x axis (m/s)", "y axis (m/s)", "z axis (m/s)"])

    def __str__(self):
        return f"{self.label or self.kind} ({self.n_env} environments)\n{self.to_frame().to_string(index=False)}"


@dataclass(frozen=True)
class Setting:
    """Everything one simulation loop needs, apart from the thrust and the seed.

    Parameters
    ----------
    group_a, group_b : EnvironmentGroup
        The two wind conditions (groups 0 and 1).
    n_changes : int
        Thrust changes after t = 0 drawn by the sampler. Paper: 6.
    sampler : {"paper", "continuous"}
        Thrust sampler (see :mod:`uavwind.actions`).
    uav : UAV
    dt, duration, start_altitude : float
        Time step [s], flight time [s], initial height [m].
    name : str
        Short label for tables.
    """

    group_a: EnvironmentGroup
    group_b: EnvironmentGroup
    n_changes: int = 6
    sampler: str = "paper"
    uav: UAV = field(default_factory=UAV)
    dt: float = 0.1
    duration: float = 12.0
    start_altitude: float = 10.0
    name: str = ""

    def __post_init__(self):
        for g in ("group_a", "group_b"):
            if not isinstance(getattr(self, g), EnvironmentGroup):
                raise TypeError(f"{g} must be an EnvironmentGroup, got {type(getattr(self, g)).__name__}")
        if self.sampler not in SAMPLERS:
            raise ValueError(f"sampler must be one of {sorted(SAMPLERS)}, got {self.sampler!r}")
        object.__setattr__(self, "n_changes", check_scalar(self.n_changes, "n_changes", low=0,
                                                           integer=True))
        if not isinstance(self.uav, UAV):
            raise TypeError(f"uav must be a UAV, got {type(self.uav).__name__}")

    @property
    def n_env(self):
        return self.group_a.n_env + self.group_b.n_env

    @property
    def groups(self):
        """Group of each environment, shape (n_env,): 0 for ``group_a``, 1 for ``group_b``."""
        return np.repeat([0, 1], [self.group_a.n_env, self.group_b.n_env])

    @property
    def has_turbulence(self):
        return "turbulence" in (self.group_a.kind, self.group_b.kind)

    def wind(self, seed=None):
        """A :class:`~uavwind.wind.CombinedWind` of both groups.

        ``seed`` (int or SeedSequence) seeds the turbulence; each group draws
        from its own child, so the groups' gusts are independent.
        """
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        sa, sb = ss.spawn(2)
        return CombinedWind(self.group_a.wind(sa), self.group_b.wind(sb))

    def sample_thrust(self, rng):
        """Draw one thrust sequence with this setting's sampler."""
        return SAMPLERS[self.sampler](rng, n_changes=self.n_changes, duration=self.duration)

    def simulate(self, thrust, seed=None):
        """Positions (n_env, n_steps, 3) [m] of all environments under ``thrust``."""
        from .dynamics import simulate
        return simulate(thrust, self.wind(seed), uav=self.uav, dt=self.dt,
                        duration=self.duration, start_altitude=self.start_altitude)

    def to_dict(self):
        return asdict(self)

    def key(self):
        """Stable 16-hex-digit digest of every field that changes results (all but ``name``)."""
        fields = self.to_dict()
        fields.pop("name")
        blob = json.dumps(fields, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def to_frame(self):
        """Both groups side by side, as in the paper's Table 3."""
        a, b = self.group_a.to_frame(), self.group_b.to_frame()
        return pd.concat({self.group_a.label or "group A": a, self.group_b.label or "group B": b},
                         axis=1)

    def __str__(self):
        return (f"Setting {self.name!r}: {self.group_a.label} ({self.group_a.n_env}) vs "
                f"{self.group_b.label} ({self.group_b.n_env}), {self.n_changes} thrust changes")


# --------------------------------------------------------------------------- #
# builders
# --------------------------------------------------------------------------- #
def _cell_centres(lo, hi, n):
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


def group_speeds(condition_a, condition_b, n_a=5, n_b=None, gap=0.0):
    """Speeds [m/s] of the two groups (DESIGN decision 5).

    Different strengths: each group spreads ``n`` cell-centred speeds over its
    own range. Same strength: the range is split between the groups, lower part
    to group A, so the ``n_a + n_b`` speeds never coincide. With ``gap = 0``
    (decision 5) the parts are two adjacent halves; ``gap`` in [0, 1) leaves that
    fraction of the range empty in the middle (each group keeps ``(1 - gap) / 2``
    of it at its end), the replication notes' alternative for same-strength pairs.

    >>> a, b = group_speeds("light constant", "strong constant", 2)
    >>> a.round(4).tolist(), b.round(3).tolist()
    ([0.6725, 1.1175], [11.85, 13.19])
    >>> a, b = group_speeds("light constant", "light constant", 2, gap=0.5)
    >>> a.round(4).tolist(), b.round(4).tolist()
    ([0.5056, 0.6169], [1.1731, 1.2844])
    """
    ca, cb = WindCondition.parse(condition_a), WindCondition.parse(condition_b)
    n_b = n_a if n_b is None else n_b
    n_a = check_scalar(n_a, "n_a", low=1, integer=True)
    n_b = check_scalar(n_b, "n_b", low=1, integer=True)
    gap = check_scalar(gap, "gap", low=0.0, high=1.0, high_inclusive=False)
    if ca.strength == cb.strength:
        lo, hi = ca.speed_range
        if gap == 0.0:  # decision 5: adjacent halves (this form keeps cached results valid)
            a_hi = b_lo = 0.5 * (lo + hi)
        else:
            part = 0.5 * (1.0 - gap) * (hi - lo)
            a_hi, b_lo = lo + part, hi - part
        return _cell_centres(lo, a_hi, n_a), _cell_centres(b_lo, hi, n_b)
    return _cell_centres(*ca.speed_range, n_a), _cell_centres(*cb.speed_range, n_b)


def make_group(condition, speeds, direction=HORIZONTAL, **kwargs):
    """An :class:`EnvironmentGroup` of ``condition`` with the given ``speeds`` [m/s]."""
    cond = WindCondition.parse(condition)
    speeds = np.asarray(speeds, dtype=float)
    if cond.kind == "turbulence":
        values = tuple(speeds)
    else:
        d = np.asarray(direction, dtype=float)
        d = d / np.linalg.norm(d)
        values = tuple(map(tuple, speeds[:, None] * d[None, :]))
    return EnvironmentGroup(cond.kind, values, label=cond.label, **kwargs)


def make_setting(condition_a, condition_b, n_per_group=5, n_changes=6, name="", gap=0.0,
                 **kwargs):
    """Setting of two generated groups with ``n_per_group`` environments each.

    ``gap`` is the empty middle fraction of the range for same-strength pairs (see
    :func:`group_speeds`; 0 = decision 5). Extra keyword arguments go to
    :class:`Setting` (``sampler``, ``uav``, ``dt``, ...).
    """
    sa, sb = group_speeds(condition_a, condition_b, n_per_group, gap=gap)
    ca, cb = WindCondition.parse(condition_a), WindCondition.parse(condition_b)
    return Setting(make_group(ca, sa), make_group(cb, sb), n_changes=n_changes,
                   name=name or f"{ca.label} vs {cb.label}", **kwargs)


def table3_setting(**kwargs):
    """The worked example, Table 3 verbatim: strong shear (group 0) vs light constant (group 1)."""
    shear = EnvironmentGroup("shear", [(2.1 + 0.1 * i, 10.1 + 0.1 * i, 0.0) for i in range(5)],
                             label="strong shear")
    const = EnvironmentGroup("constant", [(1.1 + 0.1 * i,) * 2 + (0.0,) for i in range(5)],
                             label="light constant")
    kwargs.setdefault("name", "strong shear vs light constant (Table 3)")
    return Setting(shear, const, **kwargs)


def _lower_first(setting):
    """(low, high, swapped): the group with the lower mean speed first."""
    a, b = setting.group_a, setting.group_b
    if a.speeds.mean() <= b.speeds.mean():
        return a, b, False
    return b, a, True


def range_similarity_settings(condition_a, condition_b, start=10, stop=3, **kwargs):
    """Exp 2: from ``start`` per group, repeatedly drop the two closest environments
    across the gap (the top of the lower group, the bottom of the upper group).

    Returns a list of settings with ``start, start-1, ..., stop`` environments per group.
    """
    base = make_setting(condition_a, condition_b, start, **kwargs)
    out = [replace(base, name=f"{base.name}, {2 * start} env")]
    a, b = base.group_a, base.group_b
    for n in range(start - 1, stop - 1, -1):
        cur = replace(base, group_a=a, group_b=b)
        low, high, swapped = _lower_first(cur)
        low = low.subset(np.argsort(low.speeds)[:-1])
        high = high.subset(np.argsort(high.speeds)[1:])
        a, b = (high, low) if swapped else (low, high)
        out.append(replace(base, group_a=a, group_b=b, name=f"{base.name}, {2 * n} env"))
    return out


def environment_count_settings(condition_a, condition_b, start=10, stop=3, **kwargs):
    """Exp 3: from ``start`` per group, repeatedly drop each group's median environment
    (index ``n // 2`` of the sorted speeds), keeping the outer speeds and the gap."""
    base = make_setting(condition_a, condition_b, start, **kwargs)
    out = [replace(base, name=f"{base.name}, {2 * start} env")]
    a, b = base.group_a, base.group_b
    for n in range(start - 1, stop - 1, -1):
        a = a.subset(np.delete(np.argsort(a.speeds), a.n_env // 2))
        b = b.subset(np.delete(np.argsort(b.speeds), b.n_env // 2))
        out.append(replace(base, group_a=a, group_b=b, name=f"{base.name}, {2 * n} env"))
    return out


def direction_settings(condition_a="light constant", condition_b="light shear",
                       n_per_group=10, **kwargs):
    """Exp 5: the same pair with similar and with opposite wind directions
    (group B's velocities negated)."""
    same = make_setting(condition_a, condition_b, n_per_group, **kwargs)
    opposite = replace(same, group_b=same.group_b.negated(),
                       name=f"{same.name} - opposite direction")
    return [replace(same, name=f"{same.name} - similar direction"), opposite]
