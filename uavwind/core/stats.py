"""The project's statistics: one summary and one confidence interval for every table and figure.

This module owns :func:`bootstrap_ci` (percentile bootstrap over loops, :data:`N_BOOT`
resamples, seed :data:`SEED`), :func:`paired_difference` (the same for loop-by-loop
differences between settings that flew the same thrust sequences), :func:`correct_share`
(the share of loops grouped correctly) and :func:`summarise` (max, mean with its interval,
correct share with its interval, count: the row of every summary table). Claims, summaries
and figures all call these, so an interval means the same thing everywhere;
:func:`loops_needed` turns one loop's spread into the loops a CI of a given half-width needs
(how the paper profile's counts beyond the paper are chosen: :mod:`uavwind.study.sizing`).

It also owns **the one rule of every verdict** (issue 67): :func:`decide` says whether an
estimate with its interval over ``n`` loops (episodes, controllers) is decided against a
threshold, and in which word, as a :class:`Decision`; every verdict word of the book (a
claim *reproduced* or *partly*, a channel *best* or *separates*, a share that *drops below*
one half, one case *higher* than another) is read from one. :func:`interval_label` is how an
interval is written: never a "95%" interval of fewer than :data:`MIN_INTERVAL` values, never a
zero-width one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from math import ceil, isnan, sqrt
from statistics import NormalDist
from typing import TYPE_CHECKING

import numpy as np

from .checks import check_scalar

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

__all__ = ["bootstrap_ci", "t_ci", "paired_difference", "correct_share", "summarise", "loops_needed",
           "ci_halfwidth", "wilson_ci", "N_BOOT", "SEED", "LEVEL", "Decision", "decide",
           "interval_label", "MIN_DECIDE", "MIN_INTERVAL", "UNDECIDED"]

#: Bootstrap resamples of every interval.
N_BOOT = 2000
#: Seed of the bootstrap draws (intervals are reproducible).
SEED = 12345
#: Coverage of every interval.
LEVEL = 0.95


def bootstrap_ci(values: ArrayLike, stat: Callable[..., ArrayLike] = np.mean,
                 n_boot: int = N_BOOT, level: float = LEVEL,
                 seed: int = SEED) -> tuple[float, float, float]:
    """Percentile bootstrap: ``(estimate, low, high)`` of ``stat`` over ``values``.

    >>> est, lo, hi = bootstrap_ci([1.0, 2.0, 3.0, 4.0])
    >>> est, lo <= est <= hi
    (2.5, True)
    """
    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError(f"values must be a non-empty 1-D array, got shape {v.shape}")
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, v.size, size=(n_boot, v.size))
    boots = stat(v[idx], axis=1)
    a = (1 - level) / 2
    return float(stat(v)), float(np.quantile(boots, a)), float(np.quantile(boots, 1 - a))


def t_ci(values: ArrayLike, level: float = LEVEL) -> tuple[float, float, float]:
    """Student's t interval of the mean: ``(mean, low, high)``; NaN bounds for one value.

    For a handful of replicates (Experiment 13's five controllers) a percentile bootstrap
    undercovers: it cannot reach beyond the values seen, and its spread is that of a
    population of n rather than of the mean's sampling distribution. The t interval
    ``mean +- t_{n-1} s / sqrt(n)`` is exact for normal replicates.

    >>> m, lo, hi = t_ci([1.0, 2.0, 3.0])
    >>> m, round(lo, 3), round(hi, 3)
    (2.0, -0.484, 4.484)
    """
    from scipy.stats import t as student_t

    v = np.asarray(values, dtype=float)
    if v.ndim != 1 or v.size == 0:
        raise ValueError(f"values must be a non-empty 1-D array, got shape {v.shape}")
    level = float(level)
    if not 0 < level < 1:
        raise ValueError(f"level must be in (0, 1), got {level!r}")
    m = float(v.mean())
    if v.size < 2:
        return m, float("nan"), float("nan")
    half = float(student_t.ppf(0.5 + level / 2, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size))
    return m, m - half, m + half


def paired_difference(a: ArrayLike, b: ArrayLike, n_boot: int = N_BOOT,
                      seed: int = SEED) -> tuple[float, float, float]:
    """Mean of ``a - b`` over loops paired by index, with a bootstrap 95% CI."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = min(a.size, b.size)
    return bootstrap_ci(a[:n] - b[:n], n_boot=n_boot, seed=seed)


def difference_ci(a: ArrayLike, b: ArrayLike, n_boot: int = N_BOOT, level: float = LEVEL,
                  seed: int = SEED) -> tuple[float, float, float]:
    """``mean(a) - mean(b)`` of two independent samples (not paired: a CEM iteration's loops
    against random search's), with a percentile bootstrap interval resampling each.

    >>> d, lo, hi = difference_ci([5.0, 6.0, 7.0], [1.0, 2.0, 3.0])
    >>> d, lo > 0
    (4.0, True)
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    for name, v in (("a", a), ("b", b)):
        if v.ndim != 1 or v.size == 0:
            raise ValueError(f"{name} must be a non-empty 1-D array, got shape {v.shape}")
    rng = np.random.default_rng(seed)
    boots = (a[rng.integers(0, a.size, size=(n_boot, a.size))].mean(axis=1)
             - b[rng.integers(0, b.size, size=(n_boot, b.size))].mean(axis=1))
    q = (1 - level) / 2
    return (float(a.mean() - b.mean()), float(np.quantile(boots, q)),
            float(np.quantile(boots, 1 - q)))


def correct_share(rows: pd.DataFrame | ArrayLike) -> float:
    """Share of loops whose clusters are the two groups: the ``correct`` column of a result
    table (a loop can be grouped correctly with a silhouette <= 0, so a score > 0 is not
    the same test); a bare score array falls back to ``score > 0``."""
    if hasattr(rows, "columns") and "correct" in rows.columns:
        return float(np.asarray(rows["correct"], dtype=bool).mean())
    s = np.asarray(rows["score"] if hasattr(rows, "columns") else rows, dtype=float)
    return float((s > 0).mean())


def summarise(rows: pd.DataFrame | ArrayLike) -> dict:
    """The summary row of a group of loops: ``max``, ``mean`` with its bootstrap ``ci_low``
    and ``ci_high``, ``correct_rate`` with ``correct_low`` and ``correct_high``, and
    ``n_loops``.

    Parameters
    ----------
    rows : pandas.DataFrame or array_like
        A result table (``score`` and, if present, ``correct`` and ``loop`` columns; rows are
        taken in loop order, so the interval does not depend on how the table was sorted),
        or a bare array of scores.

    >>> summarise([10.0, 0.0, 30.0])["max"]
    30.0
    """
    if hasattr(rows, "columns"):
        if "loop" in rows.columns:
            rows = rows.sort_values("loop", kind="stable")
        scores = np.asarray(rows["score"], dtype=float)
        correct = (np.asarray(rows["correct"], dtype=float) if "correct" in rows.columns
                   else (scores > 0).astype(float))
    else:
        scores = np.asarray(rows, dtype=float).ravel()
        correct = (scores > 0).astype(float)
    mean, lo, hi = bootstrap_ci(scores)
    rate, rlo, rhi = bootstrap_ci(correct)
    return {"max": float(scores.max()), "mean": mean, "ci_low": lo, "ci_high": hi,
            "correct_rate": rate, "correct_low": rlo, "correct_high": rhi,
            "n_loops": int(scores.size)}


def _z(level: float) -> float:
    """The two-sided normal quantile of ``level`` (1.96 at 0.95); the standard library's,
    equal to scipy.stats' ppf to 1e-16, without its import cost."""
    level = check_scalar(level, "level", low=0.0, high=1.0, low_inclusive=False,
                         high_inclusive=False)
    return NormalDist().inv_cdf(0.5 + level / 2)


def loops_needed(sd: float, halfwidth: float, level: float = 0.95) -> int:
    """Loops (or episodes) whose mean has a normal-approximation CI of ``+- halfwidth`` at
    ``level`` when one loop's value has standard deviation ``sd``: ``ceil((z sd / h)^2)``.

    >>> loops_needed(30.0, 5.0)   # scores with SD 30 points, a CI of +-5 points
    139
    """
    sd = check_scalar(sd, "sd", low=0.0)
    halfwidth = check_scalar(halfwidth, "halfwidth", low=0.0, low_inclusive=False)
    return max(2, ceil((_z(level) * sd / halfwidth) ** 2))


def ci_halfwidth(sd: float, n: int, level: float = 0.95) -> float:
    """The half-width ``z sd / sqrt(n)`` of the normal-approximation CI of a mean of ``n``
    loops whose values have standard deviation ``sd`` (infinite below 2 loops): the inverse
    of :func:`loops_needed`.

    >>> round(ci_halfwidth(30.0, 139), 2)
    4.99
    """
    n = check_scalar(n, "n", low=0, integer=True)
    return _z(level) * sd / sqrt(n) if n > 1 else float("inf")


def wilson_ci(k: int, n: int, level: float = LEVEL) -> tuple[float, float, float]:
    """``(share, low, high)`` of ``k`` successes in ``n`` trials, with Wilson's score
    interval at ``level``: never zero-width, inside [0, 1] (``n = 0``: all NaN).

    >>> share, lo, hi = wilson_ci(5, 5)
    >>> share, round(lo, 3), hi
    (1.0, 0.566, 1.0)
    """
    n = check_scalar(n, "n", low=0, integer=True)
    k = check_scalar(k, "k", low=0, high=n, integer=True)
    if n == 0:
        return float("nan"), float("nan"), float("nan")
    z, p = _z(level), k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return p, max(0.0, centre - half), min(1.0, centre + half)


# --------------------------------------------------------------------------- #
# the one rule of every verdict
# --------------------------------------------------------------------------- #
#: Fewest values (loops, episodes, controllers) any verdict reads. With every one of ``n``
#: loops grouped correctly, the exact one-sided 95% lower bound of the share,
#: ``0.05 ** (1 / n)``, first exceeds 1/2 at ``n = 5``; below it no count of loops can carry
#: a verdict, whatever its percentile bootstrap says (two loops' interval is [the lower loop,
#: the higher loop] and covers the mean about half the time). The minimum Exp 14 and claims
#: C3 and C7 named first.
MIN_DECIDE = 5
#: Fewest values an interval is shown for and called a 95% interval
#: (:func:`interval_label`): a percentile bootstrap of two values is their range.
MIN_INTERVAL = 3
#: The word of a comparison the evidence does not decide.
UNDECIDED = "cannot decide"


@dataclass(frozen=True)
class Decision:
    """What :func:`decide` concluded about one comparison or share.

    Attributes
    ----------
    decided : bool
        Whether the evidence carries a verdict.
    word : str
        The verdict word (the caller's ``above``, ``below`` or ``within``), or
        :data:`UNDECIDED`.
    reason : str
        Why, in words a page can print ("2 loops, fewer than the 5 a verdict needs").
    n : int
        The values (loops, episodes, controllers) the estimate is over.
    estimate, low, high : float
        The estimate and its 95% interval.
    threshold : float
        What it was compared with (0 for a difference, 1/2 for a share).
    margin : float or None
        The size of difference that counts as none (``within``), if one was asked.
    min_n : int
        The fewest values the verdict needed.
    """

    decided: bool
    word: str
    reason: str
    n: int
    estimate: float
    low: float
    high: float
    threshold: float = 0.0
    margin: float | None = None
    min_n: int = MIN_DECIDE

    @property
    def too_few(self) -> bool:
        """Undecided because ``n`` is below :attr:`min_n` (more loops may decide it)."""
        return self.n < self.min_n

    def __str__(self) -> str:
        return self.word


def decide(estimate: float, low: float, high: float, n: int, *, threshold: float = 0.0,
           margin: float | None = None, above: str = "higher", below: str = "lower",
           within: str = "no different", unit: str = "loops",
           min_n: int = MIN_DECIDE) -> Decision:
    """The one rule of every verdict: is ``estimate`` (with its 95% interval ``[low, high]``
    over ``n`` values) decidedly above ``threshold``, below it, or -- with ``margin`` -- within
    ``margin`` of it?

    In this order:

    1. ``n < min_n`` (default :data:`MIN_DECIDE`, 5): **undecided**, whatever the interval
       (too few loops; the reason says so and how many a verdict needs);
    2. a NaN estimate or bound: **undecided** (no interval);
    3. ``margin`` given and the interval inside ``(threshold - margin, threshold + margin)``:
       ``within`` (the difference is smaller than the size that matters);
    4. a zero-width interval (``low == high``: every one of the ``n`` values is the same, so
       a bootstrap has no spread to resample): decided by the estimate itself, ``above`` /
       ``below`` / ``within`` (equal to the threshold: a tie on every loop); at ``n >= 5`` a
       share of ``n`` out of ``n`` has an exact lower bound above 1/2, so this is no weaker
       than an interval;
    5. ``low > threshold``: ``above``; ``high < threshold``: ``below``;
    6. otherwise **undecided**: the interval spans the threshold.

    >>> decide(3.0, 1.0, 5.0, 50).word
    'higher'
    >>> decide(3.0, 1.0, 5.0, 2).word       # two loops decide nothing
    'cannot decide'
    >>> decide(0.2, -1.0, 1.4, 50, margin=5.0, within="no major effect").word
    'no major effect'
    """
    n = check_scalar(n, "n", low=0, integer=True)
    min_n = check_scalar(min_n, "min_n", low=1, integer=True)
    est, lo, hi, thr = (float(v) for v in (estimate, low, high, threshold))
    if margin is not None:
        margin = check_scalar(margin, "margin", low=0.0)
    if not isnan(lo) and not isnan(hi) and lo > hi:
        raise ValueError(f"low must not exceed high, got [{lo}, {hi}]")

    def out(decided, word, reason):
        return Decision(decided, word, reason, n, est, lo, hi, thr, margin, min_n)

    if n < min_n:
        return out(False, UNDECIDED, f"only {n} {unit}, fewer than the {min_n} a verdict needs")
    if isnan(est) or isnan(lo) or isnan(hi):
        return out(False, UNDECIDED, "no interval to read")
    if margin is not None and thr - margin < lo and hi < thr + margin:
        return out(True, within, f"the 95% interval lies within {margin:g} of {thr:g}")
    if lo == hi:
        word = above if est > thr else below if est < thr else within
        return out(True, word, f"every one of the {n} {unit} gives {est:g} (no spread)")
    if lo > thr:
        return out(True, above, f"the 95% interval lies above {thr:g}")
    if hi < thr:
        return out(True, below, f"the 95% interval lies below {thr:g}")
    return out(False, UNDECIDED, f"the 95% interval spans {thr:g}")


def interval_label(estimate: float, low: float, high: float, n: int, digits: int = 2,
                   scale: float = 1.0, unit: str = "loops", suffix: str = "",
                   signed: bool = False) -> str:
    """An estimate with its 95% interval as the book writes it, the one formatter of every
    interval a page prints: ``"85.00 [80.10, 89.90]"``; with fewer than :data:`MIN_INTERVAL`
    values no interval is called one (``"85.00 (2 loops, no interval)"``, ``"85.00 (1 loop,
    no interval)"``), and a zero-width interval is not shown as an interval (``"85.00 (the
    same on all 5 loops)"``). ``scale`` multiplies every number (100 for a share in percent)
    and ``suffix`` follows the estimate (``"%"``); ``signed`` writes every number with its
    sign, as a difference reads (``"+0.0 [-1.2, +1.5]"``; a value that rounds to zero is
    ``+0.0``). A NaN bound is no interval; a NaN estimate, ``n < 1`` or ``low > high`` raise
    a ``ValueError`` naming the parameter.

    >>> interval_label(0.5, 0.0, 1.0, 2, digits=0, scale=100)
    '50 (2 loops, no interval)'
    """
    n = check_scalar(n, "n", low=1, integer=True)
    digits = check_scalar(digits, "digits", low=0, integer=True)
    est, lo, hi = (float(v) * scale for v in (estimate, low, high))
    if isnan(est):
        raise ValueError(f"estimate must be a number, got {estimate}")
    if not isnan(lo) and not isnan(hi) and lo > hi:
        raise ValueError(f"low must not exceed high, got [{low}, {high}]")
    # round(., d) + 0.0: never "-0.00" (a bias of -1e-17 is none)
    e, lo_r, hi_r = (round(v, digits) + 0.0 for v in (est, lo, hi))
    f = f"{'+' if signed else ''}.{digits}f"
    if n < MIN_INTERVAL or isnan(lo) or isnan(hi):
        one = unit[:-1] if unit.endswith("s") else unit
        return f"{e:{f}}{suffix} ({n} {one if n == 1 else unit}, no interval)"
    if lo_r == hi_r:
        return f"{e:{f}}{suffix} (the same on all {n} {unit})"
    return f"{e:{f}}{suffix} [{lo_r:{f}}, {hi_r:{f}}]"
