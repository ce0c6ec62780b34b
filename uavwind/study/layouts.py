"""Layouts: where a pair of wind conditions puts its environments inside the class ranges.

This module owns :class:`Layout` and the named layouts (replication notes, decision 5):
``"halves"`` (our first guess: adjacent halves of the range), ``"gap"`` (the middle third
empty) and ``"inferred"`` (the paper reading: the evenly spaced lattice of Table 3 with the
gap between the groups fitted from Table 4, :data:`INFERRED_GAP_RATIOS`, resolved per pair by
:func:`resolve_layout`), and :func:`group_speeds`, the speeds [m/s] a layout gives a pair.

Under eqs 2-8 a constant (or shear) pair's silhouette depends on this geometry almost alone
(see :mod:`uavwind.analysis.inference`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.checks import Range, check_choice, check_fields, check_scalar
from .conditions import HORIZONTAL, WindCondition

#: Where a mixed-strength group sits in its class range.
PLACEMENTS = ("centre", "low", "high")

__all__ = ["Layout", "LAYOUTS", "INFERRED_GAP_RATIOS", "TABLE3_SPACING", "PLACEMENTS",
           "resolve_layout", "group_speeds"]

@dataclass(frozen=True)
class Layout:
    """Where a pair of wind conditions puts its environments (replication notes, decision 5).

    Groups of different strengths (light vs strong) each sit in their own class range:
    at the centres of ``n`` equal cells of it (``mixed_spacing=None``, decision 5), or, with
    ``mixed_spacing`` [m/s], ``n`` environments that far apart centred on the range's middle
    (the paper's Table 3 puts each group's environments 0.1 m/s apart on each axis: the
    inferred reading's :data:`TABLE3_SPACING`; a group of many environments may then reach
    beyond its class range, as Table 3's own light group does). Groups of the same strength
    share the class range, group A below group B:

    * ``gap_ratio=None``: a fraction ``gap`` of the range is left empty in the
      middle and each group puts cell centres in its part (``"halves"``: gap 0,
      two adjacent halves; ``"gap"``: the middle third empty);
    * ``gap_ratio=rho``: an evenly spaced lattice, the family of the paper's
      Table 3: neighbours inside a group are one *spacing* apart and the nearest
      environments of the two groups ``rho`` spacings apart. The lattice spans the
      class range (the outer environments at its ends) unless ``spacing`` [m/s] is
      given; then group A starts at the lower end of the range.

    Under eqs 2-8 a constant (or shear) pair's silhouette depends on this
    geometry through ``rho`` almost alone (see :mod:`uavwind.analysis.inference`).

    Parameters
    ----------
    name : str
    gap : float
        Empty middle fraction of the range, in [0, 1) (cell layouts only).
    gap_ratio : float, optional
        Gap between the groups in within-group spacings, in (0, 10000].
    spacing : float, optional
        Within-group spacing [m/s], in (0, 100] (lattice only).
    direction : tuple of 3 floats
        Direction of constant and shear winds (normalised); default x = y.
    mixed_spacing : float, optional
        Spacing [m/s] along ``direction`` inside each group of a mixed-strength pair, in
        (0, 100]; None: cell centres of each class range.
    mixed_placement : {"centre", "low", "high"}
        Where such a group sits in its class range: centred on its middle, or starting at
        its lower end, or ending at its upper end.

    >>> Layout("x", gap_ratio=2.0).speeds((0.0, 1.0), 2, 2).round(2).tolist()
    [[0.0, 0.25], [0.75, 1.0]]
    """

    name: str = ""
    gap: float = 0.0
    gap_ratio: float | None = None
    spacing: float | None = None
    direction: tuple = HORIZONTAL
    mixed_spacing: float | None = None
    mixed_placement: str = "centre"

    def __post_init__(self):
        if not isinstance(self.name, str):
            raise TypeError(f"name must be a string, got {type(self.name).__name__}")
        check_fields(self, {"gap": Range(0.0, 1.0, high_inclusive=False)})
        if self.gap_ratio is not None:
            if self.gap:
                raise ValueError(f"gap applies to cell layouts, gap_ratio to lattice layouts: "
                                 f"give one, got gap={self.gap:g} and gap_ratio={self.gap_ratio!r}")
            check_fields(self, {"gap_ratio": Range(0.0, 1e4, low_inclusive=False)})
        if self.spacing is not None:
            if self.gap_ratio is None:
                raise ValueError("spacing applies to lattice layouts only: give gap_ratio too")
            check_fields(self, {"spacing": Range(0.0, 100.0, low_inclusive=False)})
        if self.mixed_spacing is not None:
            check_fields(self, {"mixed_spacing": Range(0.0, 100.0, low_inclusive=False)})
        check_choice(self.mixed_placement, "mixed_placement", PLACEMENTS)
        d = np.asarray(self.direction, dtype=float)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.linalg.norm(d) > 0:
            raise ValueError(f"direction must be a finite, non-zero 3-vector, got {self.direction!r}")
        object.__setattr__(self, "direction", tuple(float(x) for x in d / np.linalg.norm(d)))

    def speeds(self, speed_range: tuple[float, float], n_a: int,
               n_b: int) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Speeds [m/s] of two same-strength groups sharing ``speed_range``: ``(2, n)``
        when ``n_a == n_b``, else a pair of arrays."""
        lo, hi = speed_range
        if self.gap_ratio is None:
            if self.gap == 0.0:  # decision 5: adjacent halves (this form keeps cached results valid)
                a_hi = b_lo = 0.5 * (lo + hi)
            else:
                part = 0.5 * (1.0 - self.gap) * (hi - lo)
                a_hi, b_lo = lo + part, hi - part
            a, b = _cell_centres(lo, a_hi, n_a), _cell_centres(b_lo, hi, n_b)
        else:
            span = (n_a - 1) + self.gap_ratio + (n_b - 1)
            step = self.spacing if self.spacing is not None else (hi - lo) / span
            a = lo + step * np.arange(n_a)
            b = lo + step * ((n_a - 1) + self.gap_ratio + np.arange(n_b))
            if b[-1] > hi * (1 + 1e-12):
                raise ValueError(f"layout {self.name!r}: spacing {self.spacing:g} m/s with "
                                 f"gap_ratio {self.gap_ratio:g} puts {n_a} + {n_b} environments "
                                 f"up to {b[-1]:.4g} m/s, beyond the class range "
                                 f"[{lo:g}, {hi:g}] m/s; use a smaller spacing or fewer "
                                 f"environments")
        return np.array([a, b]) if n_a == n_b else (a, b)

    def group_speeds(self, speed_range: tuple[float, float], n: int) -> np.ndarray:
        """Speeds [m/s] of one group of a mixed-strength pair in its class ``speed_range``:
        cell centres, or ``n`` speeds ``mixed_spacing`` apart placed by ``mixed_placement``
        (all > 0; ``ValueError`` otherwise).

        >>> Layout("t3", mixed_spacing=0.1).group_speeds((0.45, 1.34), 3).round(3).tolist()
        [0.795, 0.895, 0.995]
        """
        lo, hi = speed_range
        if self.mixed_spacing is None:
            return _cell_centres(lo, hi, n)
        steps = self.mixed_spacing * np.arange(n)
        if self.mixed_placement == "centre":
            out = 0.5 * (lo + hi) + self.mixed_spacing * (np.arange(n) - 0.5 * (n - 1))
        elif self.mixed_placement == "low":
            out = lo + steps
        else:
            out = hi - steps[::-1]
        if out[0] <= 0:
            raise ValueError(f"layout {self.name!r}: {n} environments {self.mixed_spacing:g} "
                             f"m/s apart centred on {0.5 * (lo + hi):g} m/s reach "
                             f"{out[0]:.3g} m/s; a wind speed must be > 0: use a smaller "
                             f"mixed_spacing or fewer environments")
        return out


#: The fixed named layouts (``"inferred"`` is resolved per pair by :func:`resolve_layout`).
LAYOUTS = {"halves": Layout("halves"), "gap": Layout("gap", gap=1 / 3)}


#: The paper reading of the same-strength pairs: the gap between the groups, in
#: within-group spacings, fitted from Table 4 alone by
#: :func:`uavwind.analysis.inference.fit_layouts` (paper profile; the book's "What the
#: paper's numbers reveal" page refits them and fails if these values leave the
#: fit's 95% interval). Keyed by group A's condition: a mixed same-strength pair
#: (Exp 5's light constant vs light shear) takes group A's ratio, a turbulent group A
#: group B's.
INFERRED_GAP_RATIOS = {
    "light constant": 11.2,
    "strong constant": 64.0,
    "light shear": 5.7,
    "strong shear": 94.0,
}


#: The paper reading of the mixed-strength pairs: Table 3's spacing inside a group, 0.1 m/s
#: on each of the x and y axes, i.e. 0.1 sqrt(2) m/s along the x = y direction [m/s]. Chosen
#: over 0.1 m/s in magnitude by Table 4's S2 and S5 rows (the replication notes give both).
TABLE3_SPACING = 0.1 * math.sqrt(2.0)


def resolve_layout(layout: Layout | str, condition_a: str | WindCondition,
                   condition_b: str | WindCondition) -> Layout:
    """The :class:`Layout` that ``layout`` (a Layout or a name) means for this pair."""
    if isinstance(layout, Layout):
        return layout
    if not isinstance(layout, str):
        raise TypeError(f"layout must be a Layout or one of {[*LAYOUTS, 'inferred']}, "
                        f"got {type(layout).__name__}")
    if layout in LAYOUTS:
        return LAYOUTS[layout]
    if layout != "inferred":
        raise ValueError(f"layout must be a Layout or one of {[*LAYOUTS, 'inferred']}, "
                         f"got {layout!r}")
    ca, cb = WindCondition.parse(condition_a), WindCondition.parse(condition_b)
    if ca.strength != cb.strength:
        # constant and shear pairs: Table 3's spacing; a turbulent pair keeps the class cells
        # its turbulence reading was chosen on (W20 speeds are not Table 3's velocities)
        if "turbulence" in (ca.kind, cb.kind):
            return Layout("inferred")
        return Layout("inferred", mixed_spacing=TABLE3_SPACING)
    # the ratio of group A's condition; a turbulent group A takes group B's (the paper
    # fitted no turbulent same-strength pair)
    for c in (ca, cb):
        if c.label in INFERRED_GAP_RATIOS:
            return Layout("inferred", gap_ratio=INFERRED_GAP_RATIOS[c.label])
    raise ValueError(f"layout 'inferred' has no fitted gap for {ca.label} vs {cb.label}: "
                     f"pass a Layout (e.g. Layout(gap_ratio=10.0)) or layout='halves'")


def _cell_centres(lo, hi, n):
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


def group_speeds(condition_a: str | WindCondition, condition_b: str | WindCondition,
                 n_a: int = 5, n_b: int | None = None,
                 layout: Layout | str = "inferred") -> tuple[np.ndarray, np.ndarray]:
    """Speeds [m/s] of the two groups under ``layout`` (see :class:`Layout`).

    >>> a, b = group_speeds("light constant", "strong constant", 2)  # Table 3's spacing
    >>> a.round(4).tolist(), b.round(3).tolist()
    ([0.8243, 0.9657], [12.449, 12.591])
    >>> a, b = group_speeds("light constant", "strong constant", 2, layout="halves")
    >>> a.round(4).tolist(), b.round(3).tolist()
    ([0.6725, 1.1175], [11.85, 13.19])
    >>> a, b = group_speeds("light constant", "light constant", 2, layout="gap")
    >>> a.round(4).tolist(), b.round(4).tolist()
    ([0.5242, 0.6725], [1.1175, 1.2658])
    """
    ca, cb = WindCondition.parse(condition_a), WindCondition.parse(condition_b)
    n_b = n_a if n_b is None else n_b
    n_a = check_scalar(n_a, "n_a", low=1, high=10_000, integer=True)
    n_b = check_scalar(n_b, "n_b", low=1, high=10_000, integer=True)
    lay = resolve_layout(layout, ca, cb)
    if ca.strength == cb.strength:
        out = lay.speeds(ca.speed_range, n_a, n_b)
        return out[0], out[1]
    return lay.group_speeds(ca.speed_range, n_a), lay.group_speeds(cb.speed_range, n_b)
