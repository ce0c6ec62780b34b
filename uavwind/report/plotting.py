"""The paper's figures, numbered as in the paper, and the helpers every figure uses.

This module owns the drawing of what the paper shows: each function takes library objects
or result tables and returns a ``matplotlib.figure.Figure`` (nothing is computed here that a
test cannot reach elsewhere). Figures:

* :func:`fig1_trajectory_and_wind`, :func:`fig1_velocity_projections` -- Fig 1 a/b;
* :func:`fig2_flowcharts` -- Fig 2 a/b, the system flow charts;
* :func:`fig3_loop` -- Fig 3 a/b, one loop's trajectories and 50 loop scores;
* :func:`score_per_loop` -- Figs 4 and 8 (score vs loop number, max and mean);
* :func:`score_vs_parameter` -- Figs 5, 6, 7 (max and mean vs a swept parameter);
* :func:`fig9_cem` -- Fig 9 (CEM max and mean per iteration);
* :func:`dryden_spectrum` -- the Dryden check on the model page;
* :func:`paper_vs_replication` -- reported vs regenerated values;
* :func:`silhouette_vs_ratio`, :func:`predicted_vs_paper` -- what the paper's numbers reveal
  (the inference page);
* :func:`stamp`, :func:`panel_grid`, :func:`integer_ticks` -- provenance and layout.

The figures beyond the paper (noise, observations, the baseline, the multirotor, the future
work, the closed loop, the real flights) are
:mod:`uavwind.report.beyond_figures`' (imported from there, not from here).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.tables import provenance
from ..core.stats import summarise
from ..sim.mil_dryden import dryden_psd
from ._drawing import GROUP_COLOURS, _errors, _legend_above, _mark_zero_bars, _plt

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike

    from ..sim.dryden import DrydenWind
    from ..sim.flight import Flight

__all__ = ["fig1_trajectory_and_wind", "fig1_velocity_projections", "fig2_flowcharts",
           "fig3_loop", "score_per_loop", "score_vs_parameter", "fig9_cem", "dryden_spectrum",
           "paper_vs_replication", "panel_grid", "silhouette_vs_ratio", "predicted_vs_paper",
           "stamp", "integer_ticks", "cem_lines"]


def stamp(fig: Figure, results: pd.DataFrame, note: str = "") -> Figure:
    """Write how ``fig`` was made under it: experiment, reading, profile, seed, engine,
    rows, library version and commit of ``results`` (an experiment's table), as
    :func:`uavwind.analysis.tables.provenance` says it. Returns ``fig``."""

    text = provenance(results) + (f" {note}" if note else "")
    fig.text(0.005, -0.01, text, fontsize=6, color="0.35", ha="left", va="top", wrap=True)
    return fig


def panel_grid(n: int, ncols: int = 2,
               size: tuple[float, float] = (4.2, 3.0)) -> tuple[Figure, np.ndarray]:
    """Figure with ``n`` axes on a grid of ``ncols`` columns (extra axes hidden)."""
    plt = _plt()
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(size[0] * ncols, size[1] * nrows),
                             squeeze=False, constrained_layout=True)
    axes = axes.ravel()
    for ax in axes[n:]:
        ax.set_visible(False)
    return fig, axes[:n]


# --------------------------------------------------------------------------- #
# Fig 1: one flight
# --------------------------------------------------------------------------- #
def fig1_trajectory_and_wind(flight: Flight, envs: Sequence[int] = (0, -1), arrow_env: int = 0,
                             every: int = 10, labels: Sequence[str] | None = None) -> Figure:
    """Fig 1a: 3-D trajectories of two environments (left) and the wind met along one path (right).

    Parameters
    ----------
    flight : Flight
        From :func:`uavwind.simulate_flight`.
    envs : pair of int
        Environments to draw.
    arrow_env : int
        Environment whose path carries the wind arrows.
    every : int
        One arrow every ``every`` steps.
    """
    plt = _plt()
    fig = plt.figure(figsize=(10, 4.5), constrained_layout=True)
    ax1 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2, projection="3d")
    labels = labels or [f"environment {e % flight.n_env}" for e in envs]
    for e, c, lab in zip(envs, GROUP_COLOURS, labels):
        p = flight.positions[e]
        ax1.plot(p[:, 0], p[:, 1], p[:, 2], color=c, label=lab)
    ax1.scatter(*flight.start, color="k", s=15, label="start")
    ax1.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="UAV trajectories")
    ax1.legend(fontsize=8)
    p = flight.positions[arrow_env]
    w = flight.winds[arrow_env]
    ax2.plot(p[:, 0], p[:, 1], p[:, 2], color="0.6")
    idx = np.arange(0, p.shape[0], every)
    span = np.ptp(p, axis=0).max() or 1.0
    wmax = np.abs(w).max() or 1.0
    ax2.quiver(p[idx, 0], p[idx, 1], p[idx, 2], w[idx, 0], w[idx, 1], w[idx, 2],
               length=0.15 * span / wmax, color="tab:green", normalize=False)
    ax2.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)",
            title=f"wind along the path (max {np.linalg.norm(w, axis=1).max():.2f} m/s)")
    return fig


def fig1_velocity_projections(flight: Flight, env: int = 0, every: int = 10) -> Figure:
    """Fig 1b: UAV ground velocity (top) and wind (bottom) along the path in XY, XZ, YZ."""
    plt = _plt()
    # near the text column's width (12 in put its labels at about 6 px on the page)
    fig, axes = plt.subplots(2, 3, figsize=(8.4, 5.4), constrained_layout=True)
    p, v, w = flight.positions[env], flight.ground_velocities[env], flight.winds[env]
    idx = np.arange(0, p.shape[0], every)
    for row, (vec, name, colour) in enumerate(((v, "UAV velocity", "tab:blue"),
                                               (w, "wind", "tab:green"))):
        for col, (i, j, lab) in enumerate(((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ"))):
            ax = axes[row, col]
            ax.plot(p[:, i], p[:, j], color="0.7", lw=1)
            ax.quiver(p[idx, i], p[idx, j], vec[idx, i], vec[idx, j], color=colour,
                      angles="xy", width=0.006)
            ax.set(xlabel=f"{'xyz'[i]} (m)", ylabel=f"{'xyz'[j]} (m)", title=f"{name}, {lab}")
    return fig


# --------------------------------------------------------------------------- #
# Fig 2: flow charts
# --------------------------------------------------------------------------- #
def _flow(ax, boxes, loop_back, title):
    ax.set_axis_off()
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    n = len(boxes)
    ys = np.linspace(0.9, 0.1, n)
    for k, (text, y) in enumerate(zip(boxes, ys)):
        ax.text(0.5, y, text, ha="center", va="center", fontsize=9.5, wrap=True,
                bbox=dict(boxstyle="round,pad=0.4", fc="#eef3fb", ec="#355c9a"))
        if k < n - 1:
            ax.annotate("", xy=(0.5, ys[k + 1] + 0.045), xytext=(0.5, y - 0.045),
                        arrowprops=dict(arrowstyle="->", color="#355c9a"))
    ax.annotate(loop_back, xy=(0.9, ys[0]), xytext=(0.9, ys[-1]), fontsize=9, ha="center",
                rotation=90, va="bottom",
                arrowprops=dict(arrowstyle="->", color="0.4", connectionstyle="arc3,rad=0"))
    ax.set_title(title, fontsize=10)


def fig2_flowcharts() -> Figure:
    """Fig 2: the system with random exploration (a) and with CEM (b)."""
    plt = _plt()
    # about the text column's width (7.4 in for 690 px): at 11 in the boxes' text was about
    # 7 px on the page (issue 67)
    fig, (a, b) = plt.subplots(1, 2, figsize=(7.4, 5.6), constrained_layout=True)
    common = ["UAV flies one thrust sequence\nin 2 groups of wind environments",
              "position trajectories\n(environments x 120 steps x 3 axes)",
              "soft-DTW time-series k-means\n(2 clusters)",
              "silhouette score (DTW);\n0 if a trajectory is misgrouped"]
    _flow(a, ["draw a random thrust sequence\n(times, magnitudes, directions)", *common,
              "record score; report max and mean"], "next loop",
          "(a) random exploration")
    _flow(b, ["draw $N$ thrust vectors from\n$\\mathcal{N}(\\mu, \\sigma^2)$", *common,
              "keep the $N_e$ elite samples;\nrefit $\\mu$, $\\sigma$ (eqs CEM1-2)"],
          "next iteration",
          "(b) Cross-Entropy Method")
    return fig


# --------------------------------------------------------------------------- #
# loops and sweeps
# --------------------------------------------------------------------------- #
def fig3_loop(trajectories: np.ndarray, groups: ArrayLike, scores: ArrayLike,
              group_labels: Sequence[str] = ("group 0", "group 1"),
              title: str | None = None) -> Figure:
    """Fig 3: (a) one loop's trajectories by group, (b) scores over the loops."""
    plt = _plt()
    fig = plt.figure(figsize=(8.4, 3.9), constrained_layout=True)  # near the column's width
    # the 3-D panel's z label reaches past its box: a gap so it stays clear of the scores' axis
    fig.get_layout_engine().set(wspace=0.12)
    ax1 = fig.add_subplot(1, 2, 1, projection="3d")
    for g, (c, lab) in enumerate(zip(GROUP_COLOURS, group_labels)):
        for k, tr in enumerate(trajectories[np.asarray(groups) == g]):
            ax1.plot(tr[:, 0], tr[:, 1], tr[:, 2], color=c, lw=1, label=lab if k == 0 else None)
    ax1.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=title or "one loop")
    ax1.legend(fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    _score_axes(ax2, np.asarray(scores, dtype=float))
    return fig


def integer_ticks(ax, axis: str = "x") -> None:
    """Ticks at whole numbers only on ``axis`` ("x" or "y") of ``ax``: a loop or an iteration
    is counted, so 1.0, 1.2, ... 2.0 would show values it cannot take."""
    from matplotlib.ticker import MaxNLocator

    if axis not in ("x", "y"):
        raise ValueError(f"axis must be 'x' or 'y', got {axis!r}")
    (ax.xaxis if axis == "x" else ax.yaxis).set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
    lo, hi = ax.get_xlim() if axis == "x" else ax.get_ylim()
    if abs(hi - lo) < 1.0:  # one count drawn (one iteration): the view is a sliver around it,
        mid = round((lo + hi) / 2)  # where the locator would tick 0.945, 0.960, ...
        (ax.set_xlim if axis == "x" else ax.set_ylim)(mid - 0.5, mid + 0.5)


def _score_axes(ax, scores, title=None, ylim=(-2, 102), legend=True):
    """Score per loop with its maximum and mean; their values in the title. ``legend``: a
    legend inside the axes (``False``: the caller puts one beside the panels, where no data
    lies under it)."""
    loops = np.arange(1, len(scores) + 1)
    ax.plot(loops, scores, marker="o", ms=2.5, lw=0.8, color="tab:blue", label="score")
    ax.axhline(scores.max(), color="tab:red", ls="--", lw=1, label="maximum")
    ax.axhline(scores.mean(), color="tab:green", ls=":", lw=1.2, label="mean")
    ax.set(xlabel="loop", ylabel="silhouette score", ylim=ylim)
    integer_ticks(ax)
    values = f"max {scores.max():.2f}, mean {scores.mean():.2f}"
    ax.set_title(f"{title}\n{values}" if title else values, fontsize=9)
    if legend:
        ax.legend(fontsize=9, loc="best")


def score_per_loop(df: pd.DataFrame, by: str = "scenario", ncols: int = 2,
                   paper: pd.DataFrame | None = None) -> Figure:
    """Figs 4 and 8: score vs loop number, one panel per ``by`` value, with max and mean.

    ``paper`` (optional DataFrame with ``scenario, maximum, mean``) adds the
    paper's max and mean as grey lines.
    """
    keys = list(dict.fromkeys(df[by]))
    fig, axes = panel_grid(len(keys), ncols=ncols)
    for ax, key, letter in zip(axes, keys, "abcdefghijklmnop"):
        scores = df.loc[df[by] == key].sort_values("loop")["score"].to_numpy()
        _score_axes(ax, scores, title=f"({letter}) {key}", legend=False)
        if paper is not None:
            row = paper.loc[paper["scenario"] == key]
            if len(row):
                ax.axhline(row["maximum"].iloc[0], color="0.5", lw=0.8, ls="--",
                           label="paper maximum")
                ax.axhline(row["mean"].iloc[0], color="0.5", lw=0.8, ls=":", label="paper mean")
    _legend_above(fig, axes)
    return fig


def score_vs_parameter(df: pd.DataFrame, x: str, by: str = "scenario", ncols: int = 2,
                       paper: pd.DataFrame | None = None, xlabel: str | None = None) -> Figure:
    """Figs 5-7: maximum and mean score vs ``x`` (``n_env``, ``thrust_changes``), one panel per
    ``by`` value; the paper's two reported points (if given) as grey markers."""
    keys = list(dict.fromkeys(df[by]))
    fig, axes = panel_grid(len(keys), ncols=ncols)
    for ax, key, letter in zip(axes, keys, "abcdefgh"):
        sub = df.loc[df[by] == key]
        xs = np.array(sorted(sub[x].unique()))
        rows = [summarise(sub.loc[sub[x] == v]) for v in xs]
        mx = np.array([r["max"] for r in rows])
        mn = np.array([r["mean"] for r in rows])
        ci = _errors({k: np.array([r[k] for r in rows], float)  # no 95% interval, no bar
                      for k in ("mean", "ci_low", "ci_high", "n_loops")})
        ax.plot(xs, mx, marker="^", color="tab:red", label="maximum")
        ax.errorbar(xs, mn, yerr=ci, marker="o", color="tab:blue", capsize=2,
                    label="mean (95% bootstrap CI)" if np.isfinite(ci).any() else
                    "mean (too few loops for a 95% CI)")
        if paper is not None:
            p = paper.loc[paper["scenario"] == key]
            ax.scatter(p[x], p["maximum"], marker="^", color="0.5", zorder=3, label="paper max")
            ax.scatter(p[x], p["mean"], marker="o", facecolor="none", edgecolor="0.3", zorder=3,
                       label="paper mean")
        ax.set(xlabel=xlabel or x, ylabel="silhouette score", title=f"({letter}) {key}",
               ylim=(-2, 102))
        ax.set_xticks(xs)
    _legend_above(fig, axes)
    return fig


def cem_lines(ax, history: pd.DataFrame) -> None:
    """A CEM run's maximum and mean score per iteration on ``ax`` (``history``: one row per
    iteration, columns ``max`` and ``mean``, the iteration as index or column): the maximum
    with large open markers, the mean small and dashed inside them, so where they coincide
    (a run in which every draw scored 0) both stay visible."""
    it = history.index.to_numpy() if "iteration" not in history else history["iteration"]
    ax.plot(it, history["max"], marker="^", ms=8, mfc="none", mew=1.3, color="tab:red",
            label="CEM maximum")
    ax.plot(it, history["mean"], marker="o", ms=3.5, ls="--", color="tab:blue",
            label="CEM mean")


def fig9_cem(history: pd.DataFrame, random_scores: ArrayLike | None = None,
             paper: pd.DataFrame | None = None) -> Figure:
    """Fig 9: CEM maximum and mean score per iteration (and the random-search reference)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4), constrained_layout=True)
    it = history.index.to_numpy() if "iteration" not in history else history["iteration"]
    cem_lines(ax, history)
    if "elite_mean" in history:
        ax.plot(it, history["elite_mean"], ls="--", color="tab:purple", label="CEM elite mean")
    if random_scores is not None:
        rs = np.asarray(random_scores, dtype=float)
        ax.axhline(rs.max(), color="tab:red", ls=":", lw=1, label=f"random max {rs.max():.2f}")
        ax.axhline(rs.mean(), color="tab:blue", ls=":", lw=1, label=f"random mean {rs.mean():.2f}")
    if paper is not None:
        v = dict(zip(paper["quantity"], paper["value"]))
        ax.axhline(v["cem_maximum"], color="0.5", ls="--", lw=0.8, label="paper CEM max")
    ax.set(xlabel="iteration", ylabel="silhouette score", ylim=(-2, 102))
    integer_ticks(ax)
    # above the axes: inside, the search's lines pass under it wherever it is put
    fig.legend(fontsize=7, loc="outside upper center", ncol=3)
    return fig


# --------------------------------------------------------------------------- #
# model checks and comparisons
# --------------------------------------------------------------------------- #
def dryden_spectrum(wind: DrydenWind, n_samples: int = 4096, nperseg: int = 512) -> Figure:
    """Simulated gust spectra (Welch, averaged over environments) over the analytic
    MIL-F-8785C spectra, for the u, v, w axes of a :class:`~uavwind.sim.dryden.DrydenWind`
    whose environments share one W20."""
    from scipy.signal import welch

    plt = _plt()
    g = wind.gusts(n_samples)
    f, S = welch(g, fs=1.0 / wind.dt, nperseg=nperseg, axis=1)
    S = S.mean(axis=0) / (2 * np.pi)  # per rad/s
    omega = 2 * np.pi * f[1:]
    p = wind.parameters
    fig, axes = plt.subplots(1, 3, figsize=(8.4, 3.2), constrained_layout=True, sharey=True)
    for j, (ax, axis) in enumerate(zip(axes, "uvw")):
        ax.loglog(omega, S[1:, j], color="tab:blue", label="simulated (Welch)")
        ax.loglog(omega, dryden_psd(omega, p[f"sigma_{axis}"][0], p[f"L_{axis}"][0],
                                    wind.airspeed[0], axis), color="k", ls="--",
                  label="MIL-F-8785C")
        ax.axvline(np.pi / wind.dt, color="0.6", lw=0.8)
        ax.set(xlabel="omega (rad/s)", title=f"{axis} gust, sigma = {p[f'sigma_{axis}'][0]:.2f} m/s")
    axes[0].set_ylabel("PSD ((m/s)^2 / (rad/s))")
    axes[0].legend(fontsize=8)
    return fig


def paper_vs_replication(table: pd.DataFrame, ncols: int = 1,
                         title: str | None = None) -> Figure:
    """Bar chart of reported vs regenerated values: ``table`` has an index of row labels
    and columns ``paper_max, max, paper_mean, mean`` (:func:`~uavwind.analysis.tables.comparison_table`)."""
    plt = _plt()
    n = len(table)
    fig, ax = plt.subplots(figsize=(8, 0.45 * n + 1.5), constrained_layout=True)
    y = np.arange(n)
    h = 0.2
    for k, (col, c, label) in enumerate((("paper_max", "0.55", "paper maximum"),
                                         ("max", "tab:red", "replication maximum"),
                                         ("paper_mean", "0.8", "paper mean"),
                                         ("mean", "tab:blue", "replication mean"))):
        if col in table:
            _mark_zero_bars(ax, ax.barh(y + (k - 1.5) * h, table[col], height=h, color=c,
                                        label=label))
    ax.set_yticks(y, [str(i) for i in table.index], fontsize=8)
    ax.invert_yaxis()
    ax.set(xlabel="silhouette score", xlim=(0, 100), title=title)
    fig.legend(fontsize=7, loc="outside upper center", ncol=4)  # above the axes, off the bars
    return fig


# --------------------------------------------------------------------------- #
# what the paper's numbers reveal
# --------------------------------------------------------------------------- #
def silhouette_vs_ratio(curves: pd.DataFrame, fits: pd.DataFrame | None = None) -> Figure:
    """Mean score against the gap-to-spacing ratio, one line per scenario (log x axis);
    with ``fits`` (:func:`uavwind.analysis.inference.fit_layouts`) the paper's Table 4 mean as a
    horizontal line and the fitted ratio with its 95% interval as a shaded band."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    colours = dict(zip(sorted(curves["scenario_id"].unique()), plt.cm.tab10.colors))
    for k, sub in curves.groupby("scenario_id"):
        c = colours[k]
        ax.plot(sub["gap_ratio"], sub["mean"], marker="o", ms=3, color=c,
                label=f"S{k} {sub['scenario'].iloc[0]}")
        if fits is not None and k in fits.index:
            f = fits.loc[k]
            ax.axhline(f["paper_mean"], color=c, ls=":", lw=0.9)
            if np.isfinite(f["ratio"]):
                hi = f["ci_high"] if np.isfinite(f["ci_high"]) else sub["gap_ratio"].max()
                ax.axvspan(f["ci_low"], hi, color=c, alpha=0.15)
                ax.axvline(f["ratio"], color=c, lw=0.8)
    ax.set_xscale("log")
    ax.set(xlabel="gap between the groups / spacing inside a group", ylabel="mean score",
           ylim=(-2, 102), title="Silhouette against layout geometry (dotted: paper, Table 4)")
    ax.legend(fontsize=7, loc="lower right")
    return fig


def predicted_vs_paper(table: pd.DataFrame) -> Figure:
    """Out-of-sample check: the paper's mean against the predicted mean (95% CI), one
    point per row of ``table`` (:func:`uavwind.analysis.inference.out_of_sample`), by table."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(5.2, 5), constrained_layout=True)
    for k, ((label, sub), m) in enumerate(zip(table.groupby(level="table", sort=False),
                                              "osD^v")):
        err = np.clip(np.vstack([sub["mean"] - sub["ci_low"],
                                 sub["ci_high"] - sub["mean"]]), 0, None)
        # the earlier tables on top, a lone row's marker larger: Table 4's one 500-loop row
        # sat hidden under a Table 6 marker at the same point (issue 44)
        ax.errorbar(sub["paper_mean"], sub["mean"], yerr=err, fmt=m,
                    ms=9 if len(sub) == 1 else 5, mfc="none" if len(sub) == 1 else None,
                    mew=1.5, capsize=2, label=label, zorder=10 - k)
    lims = (min(table["paper_mean"].min(), table["ci_low"].min()) - 3, 101)
    ax.plot(lims, lims, color="0.5", lw=0.8, ls="--", label="prediction = paper")
    ax.set(xlim=lims, ylim=lims, xlabel="paper's mean score", ylabel="predicted mean score",
           title="Rows the fit never saw")
    ax.legend(fontsize=7, loc="upper left")
    return fig
