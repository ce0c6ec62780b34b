"""Setting builders: the paper's words turned into the settings its experiments fly.

This module owns :func:`make_group` and :func:`make_setting` (two conditions, a number of
environments per group, a layout and a turbulence reading) and the builders of the
experiments' sweeps: :func:`range_similarity_settings` (Exp 2),
:func:`environment_count_settings` (Exp 3) and :func:`direction_settings` (Exp 5), each
taking ``layout=`` and ``turbulence=`` (a reading's :attr:`~uavwind.study.readings.Reading.builder_kwargs`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..sim.setting import EnvironmentGroup, Setting
from .conditions import HORIZONTAL, WindCondition
from .layouts import group_speeds, resolve_layout
from .readings import INFERRED_TURBULENCE, turbulence_fields

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..sim.cited_dryden import CitedDryden
    from .layouts import Layout

__all__ = ["make_group", "make_setting", "range_similarity_settings",
           "environment_count_settings", "direction_settings"]

def make_group(condition: str | WindCondition, speeds: ArrayLike,
               direction: ArrayLike = HORIZONTAL, turbulence: str | CitedDryden = "mil-f-8785c",
               **kwargs: Any) -> EnvironmentGroup:
    """An :class:`EnvironmentGroup` of ``condition`` with the given ``speeds`` [m/s]."""
    cond = WindCondition.parse(condition)
    speeds = np.asarray(speeds, dtype=float)
    if cond.kind == "turbulence":
        variant, cited = turbulence_fields(turbulence)
        return EnvironmentGroup(cond.kind, tuple(speeds), label=cond.label, variant=variant,
                                cited=cited, **kwargs)
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    values = tuple(map(tuple, speeds[:, None] * d[None, :]))
    return EnvironmentGroup(cond.kind, values, label=cond.label, **kwargs)


def make_setting(condition_a: str | WindCondition, condition_b: str | WindCondition,
                 n_per_group: int = 5, n_changes: int = 6, name: str = "",
                 layout: Layout | str = "inferred",
                 turbulence: str | CitedDryden = INFERRED_TURBULENCE, **kwargs: Any) -> Setting:
    """Setting of two generated groups with ``n_per_group`` environments each.

    ``layout`` places the environments (a :class:`Layout` or ``"inferred"``,
    ``"halves"``, ``"gap"``); ``turbulence`` is the Dryden variant of turbulence
    groups (``"mil-f-8785c"``, ``"cited"`` or a CitedDryden). Extra keyword
    arguments go to :class:`Setting` (``sampler``, ``uav``, ``dt``, ...).

    >>> s = make_setting("light constant", "light constant", 3, layout="halves")
    >>> s.group_a.speeds.round(3).tolist(), s.group_b.speeds.round(3).tolist()
    ([0.524, 0.673, 0.821], [0.969, 1.118, 1.266])
    """
    ca, cb = WindCondition.parse(condition_a), WindCondition.parse(condition_b)
    lay = resolve_layout(layout, ca, cb)
    sa, sb = group_speeds(ca, cb, n_per_group, layout=lay)
    return Setting(make_group(ca, sa, lay.direction, turbulence),
                   make_group(cb, sb, lay.direction, turbulence), n_changes=n_changes,
                   name=name or f"{ca.label} vs {cb.label}", **kwargs)


def _lower_first(setting):
    """(low, high, swapped): the group with the lower mean speed first."""
    a, b = setting.group_a, setting.group_b
    if a.speeds.mean() <= b.speeds.mean():
        return a, b, False
    return b, a, True


def range_similarity_settings(condition_a: str | WindCondition, condition_b: str | WindCondition,
                              start: int = 10, stop: int = 3, **kwargs: Any) -> list[Setting]:
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


def environment_count_settings(condition_a: str | WindCondition,
                               condition_b: str | WindCondition, start: int = 10, stop: int = 3,
                               **kwargs: Any) -> list[Setting]:
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


def direction_settings(condition_a: str | WindCondition = "light constant",
                       condition_b: str | WindCondition = "light shear",
                       n_per_group: int = 10, **kwargs: Any) -> list[Setting]:
    """Exp 5: the same pair with similar and with opposite wind directions
    (group B's velocities negated)."""
    same = make_setting(condition_a, condition_b, n_per_group, **kwargs)
    opposite = replace(same, group_b=same.group_b.negated(),
                       name=f"{same.name} - opposite direction")
    return [replace(same, name=f"{same.name} - similar direction"), opposite]
