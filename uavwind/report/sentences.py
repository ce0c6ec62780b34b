"""Sentences that choose between answers, as functions of the numbers they are about.

This module owns the book's *verdict words* in prose: a sentence that says one thing is
higher, loses first, takes something away or groups the environments is computed here from
the numbers it describes, so it cannot contradict them when a profile, a count or a sizing
changes (issue 44). A verdict word is given only where the one rule of every verdict,
:func:`uavwind.core.stats.decide`, carries it: two intervals that overlap, or intervals over
fewer loops than a verdict needs, *cannot decide*, and the sentence says so.

Each function raises a ``ValueError`` naming the parameter on input it cannot judge (an
interval whose low end lies above its high end, a NaN, an empty set of rates). A mean with
its interval is written by :func:`uavwind.core.stats.interval_label`, the one formatter of
every interval a page prints.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from ..core.stats import UNDECIDED, decide, paired_difference

__all__ = ["interval_order", "compare_phrase", "grouping_phrase", "first_to_lose"]


def _interval(low: float, high: float, name: str) -> tuple[float, float]:
    low, high = float(low), float(high)
    if math.isnan(low) or math.isnan(high):
        raise ValueError(f"{name} must be a finite interval, got [{low}, {high}]")
    if low > high:
        raise ValueError(f"{name} must have low <= high, got [{low}, {high}]")
    return low, high


def interval_order(a: Sequence[float], b: Sequence[float], *, n: int) -> int:
    """``+1`` when interval ``a`` = (low, high) lies wholly above ``b``, ``-1`` wholly below,
    ``0`` when they overlap or either is over fewer than
    :data:`~uavwind.core.stats.MIN_DECIDE` loops (``n``, the fewer of the two): the
    intervals cannot decide which is higher. The one rule
    (:func:`~uavwind.core.stats.decide`) on ``a - b`` with ``[a_low - b_high, a_high - b_low]``."""
    a_lo, a_hi = _interval(*a, "a")
    b_lo, b_hi = _interval(*b, "b")
    d = decide((a_lo + a_hi - b_lo - b_hi) / 2, a_lo - b_hi, a_hi - b_lo, n)
    return {"higher": 1, "lower": -1}.get(d.word, 0)


def compare_phrase(a: Sequence[float], b: Sequence[float], higher: str, lower: str,
                   undecided: str, *, n: int) -> str:
    """``higher`` when ``a``'s interval lies above ``b``'s, ``lower`` when below, else
    ``undecided`` (:func:`interval_order` over ``n`` loops)."""
    return {1: higher, -1: lower, 0: undecided}[interval_order(a, b, n=n)]


def grouping_phrase(correct_rates: Mapping[str, float], what: str) -> str:
    """How often the loops of several cases (``what``, a noun phrase: "the zero-mean
    readings") grouped the environments correctly, from each case's correct rate in [0, 1]:
    ``"<what>: every loop grouped correctly"``, most loops misgrouped, one rate, or the range
    between the cases."""
    rates = {k: float(v) for k, v in dict(correct_rates).items()}
    if not rates:
        raise ValueError("correct_rates must hold at least one case")
    if any(math.isnan(v) or not 0.0 <= v <= 1.0 for v in rates.values()):
        raise ValueError(f"correct_rates must lie in [0, 1], got {rates}")
    lo, hi = min(rates.values()), max(rates.values())
    if lo == 1.0:
        return f"{what}: every loop grouped correctly"
    if hi < 0.5:
        return f"{what}: most loops misgrouped (at most {100 * hi:.0f}% grouped correctly)"
    if lo == hi:
        return f"{what}: {100 * lo:.0f}% of the loops grouped correctly"
    return (f"{what}: from {100 * lo:.0f}% to {100 * hi:.0f}% of the loops grouped correctly, "
            f"case by case")


def first_to_lose(clean: Mapping[str, float], noisy: Mapping[str, float],
                  losses: Mapping[str, Sequence[float]] | None = None) -> str:
    """Which channel loses most of its score when noise is added, from each channel's score
    without (``clean``) and with noise (``noisy``), keyed alike: ``"<name> loses most (<points>
    points)"`` (ties named together), or ``"no channel loses score to the noise"`` when none
    scores lower with it.

    With ``losses`` (channel -> its loss on each loop, the same loops for every channel) the
    ranking is the one rule's (:func:`~uavwind.core.stats.decide` on the paired difference
    between the largest loss and the runner-up's): where it cannot decide, the sentence names
    the runner-up and says so."""
    if set(clean) != set(noisy) or not clean:
        raise ValueError(f"clean and noisy must name the same channels, got {sorted(clean)} "
                         f"and {sorted(noisy)}")
    loss = {k: float(clean[k]) - float(noisy[k]) for k in clean}
    if any(math.isnan(v) for v in loss.values()):
        raise ValueError(f"clean and noisy must be numbers, got {dict(clean)}, {dict(noisy)}")
    top = max(loss.values())
    losers = sorted(k for k, v in loss.items() if v == top)
    if top <= 0:
        return "no channel loses score to the noise"
    text = f"{' and '.join(losers)} {'loses' if len(losers) == 1 else 'lose'} most ({top:.1f} points)"
    rest = sorted((k for k in loss if k not in losers), key=loss.get, reverse=True)
    if losses is None or len(losers) > 1 or not rest:
        return text
    second = rest[0]
    a, b = (np.asarray(losses[k], dtype=float) for k in (losers[0], second))
    n = min(a.size, b.size)
    d = decide(*paired_difference(a[:n], b[:n]), n) if n else decide(0.0, 0.0, 0.0, 0)
    if d.word == "higher":
        return text
    return (f"{text}, not told apart from {second} ({loss[second]:.1f} points): "
            f"{UNDECIDED} on these loops ({d.reason})")

