"""What every figure module of the book shares.

This module owns the drawing helpers :mod:`uavwind.report.plotting` (the paper's figures) and
:mod:`uavwind.report.beyond_figures` (the figures beyond it) both use: ``_plt``, pyplot
imported when a figure is drawn (a page that only reads results never loads matplotlib),
:data:`GROUP_COLOURS`, the two groups' colours, and ``_mark_zero_bars``, the "0" beside a bar
that scored 0, ``_legend_above``, one legend above a figure's panels, and ``_errors``, the
error bars of a 95% interval, left out where there is none to show.
"""

from __future__ import annotations

import numpy as np

from ..core.stats import MIN_INTERVAL

#: The colours of group 0 and group 1 in every figure.
GROUP_COLOURS = ("tab:blue", "tab:orange")


def _plt():
    import matplotlib.pyplot as plt
    return plt


def _mark_zero_bars(ax, bars, fontsize: float = 7) -> None:
    """A "0" beside every bar of ``bars`` (a ``BarContainer``, horizontal or vertical) whose
    value is 0, so a case that ran and scored 0 does not look like a case that did not run
    (a NaN bar, not run, stays blank)."""
    horizontal = bars.orientation == "horizontal"
    for patch in bars.patches:
        if (patch.get_width() if horizontal else patch.get_height()) != 0:
            continue
        if horizontal:
            ax.text(1.5, patch.get_y() + patch.get_height() / 2, "0", va="center", ha="left",
                    fontsize=fontsize, color="0.2")
        else:
            ax.text(patch.get_x() + patch.get_width() / 2, 1.0, "0", ha="center",
                    va="bottom", fontsize=fontsize, color="0.2")


def _legend_above(fig, axes, fontsize: float = 8) -> None:
    """One legend for every panel of ``axes``, above them (inside, a panel's data would pass
    under it): each label once, from whichever panel drew it, at most five to a row."""
    seen = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen), fontsize=fontsize,
                   loc="outside upper center", ncol=min(len(seen), 5))


def _errors(frame, mean: str = "mean", low: str = "ci_low", high: str = "ci_high",
            n: str = "n_loops") -> np.ndarray:
    """The (2, k) error bars of ``frame``'s 95% intervals around ``mean``: NaN (no bar) for a
    row of fewer than :data:`~uavwind.core.stats.MIN_INTERVAL` loops (``n``: two loops'
    bootstrap is their range, not a 95% interval) or with a zero-width interval."""
    err = np.clip(np.vstack([np.asarray(frame[mean] - frame[low], float),
                             np.asarray(frame[high] - frame[mean], float)]), 0, None)
    flat = np.asarray(frame[low], float) == np.asarray(frame[high], float)
    few = (np.asarray(frame[n], float) < MIN_INTERVAL) if n in frame else np.zeros_like(flat)
    err[:, flat | few] = np.nan
    return err
