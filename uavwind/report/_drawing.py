"""What every figure module of the book shares.

This module owns the drawing helpers :mod:`uavwind.report.plotting` (the paper's figures) and
:mod:`uavwind.report.beyond_figures` (the figures beyond it) both use: ``_plt``, pyplot
imported when a figure is drawn (a page that only reads results never loads matplotlib),
:data:`GROUP_COLOURS`, the two groups' colours, and ``_mark_zero_bars``, the "0" beside a bar
that scored 0.
"""

from __future__ import annotations

#: The colours of group 0 and group 1 in every figure.
GROUP_COLOURS = ("tab:blue", "tab:orange")


def _plt():
    import matplotlib.pyplot as plt
    return plt


def _mark_zero_bars(ax, bars) -> None:
    """A "0" beside every bar of ``bars`` (a horizontal ``BarContainer``) whose value is 0,
    so a case that ran and scored 0 does not look like a case that did not run."""
    for patch in bars.patches:
        if patch.get_width() == 0:
            ax.text(1.5, patch.get_y() + patch.get_height() / 2, "0", va="center", ha="left",
                    fontsize=7, color="0.2")
