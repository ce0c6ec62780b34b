"""The project's statistics: one confidence-interval function for every table and figure.

This module owns :func:`bootstrap_ci` (percentile bootstrap over loops) and
:func:`paired_difference` (the same for loop-by-loop differences between settings that
flew the same thrust sequences). Claims, summaries and figures all call these, so an
interval means the same thing everywhere.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bootstrap_ci", "paired_difference", "correct_share", "N_BOOT", "SEED"]

N_BOOT = 2000
SEED = 12345


def bootstrap_ci(values, stat=np.mean, n_boot=N_BOOT, level=0.95, seed=SEED):
    """Percentile bootstrap: ``(estimate, low, high)`` of ``stat`` over ``values``."""
    v = np.asarray(values, dtype=float)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, v.size, size=(n_boot, v.size))
    boots = stat(v[idx], axis=1)
    a = (1 - level) / 2
    return float(stat(v)), float(np.quantile(boots, a)), float(np.quantile(boots, 1 - a))


def paired_difference(a, b, n_boot=N_BOOT, seed=SEED):
    """Mean of ``a - b`` over loops paired by index, with a bootstrap 95% CI."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    n = min(a.size, b.size)
    return bootstrap_ci(a[:n] - b[:n], n_boot=n_boot, seed=seed)


def correct_share(rows):
    """Share of loops whose clusters are the two groups: the ``correct`` column of a result
    table (a loop can be grouped correctly with a silhouette <= 0, so a score > 0 is not
    the same test); a bare score array falls back to ``score > 0``."""
    if hasattr(rows, "columns") and "correct" in rows.columns:
        return float(np.asarray(rows["correct"], dtype=bool).mean())
    s = np.asarray(rows["score"] if hasattr(rows, "columns") else rows, dtype=float)
    return float((s > 0).mean())
