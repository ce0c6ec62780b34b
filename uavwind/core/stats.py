"""The project's statistics: one summary and one confidence interval for every table and figure.

This module owns :func:`bootstrap_ci` (percentile bootstrap over loops, :data:`N_BOOT`
resamples, seed :data:`SEED`), :func:`paired_difference` (the same for loop-by-loop
differences between settings that flew the same thrust sequences), :func:`correct_share`
(the share of loops grouped correctly) and :func:`summarise` (max, mean with its interval,
correct share with its interval, count: the row of every summary table). Claims, summaries
and figures all call these, so an interval means the same thing everywhere;
:func:`loops_needed` turns one loop's spread into the loops a CI of a given half-width needs
(how the paper profile's counts beyond the paper are chosen: :mod:`uavwind.study.sizing`).
"""

from __future__ import annotations

from collections.abc import Callable
from math import ceil, sqrt
from statistics import NormalDist
from typing import TYPE_CHECKING

import numpy as np

from .checks import check_scalar

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

__all__ = ["bootstrap_ci", "t_ci", "paired_difference", "correct_share", "summarise", "loops_needed",
           "ci_halfwidth", "wilson_ci", "N_BOOT", "SEED", "LEVEL"]

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
