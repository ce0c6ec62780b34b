"""The project's statistics: one confidence-interval function for every table and figure.

This module owns :func:`bootstrap_ci` (percentile bootstrap over loops) and
:func:`paired_difference` (the same for loop-by-loop differences between settings that
flew the same thrust sequences). Claims, summaries and figures all call these, so an
interval means the same thing everywhere.
"""

from __future__ import annotations

import numpy as np

__all__ = ["bootstrap_ci", "paired_difference", "N_BOOT", "SEED"]

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
