"""Every figure of the book, numbered as in the paper.

This module owns the drawing: each function takes library objects or result
tables and returns a ``matplotlib.figure.Figure`` (nothing is computed here
that a test cannot reach elsewhere). Figures:

* :func:`fig1_trajectory_and_wind`, :func:`fig1_velocity_projections` -- Fig 1 a/b;
* :func:`fig2_flowcharts` -- Fig 2 a/b, the system flow charts;
* :func:`fig3_loop` -- Fig 3 a/b, one loop's trajectories and 50 loop scores;
* :func:`score_per_loop` -- Figs 4 and 8 (score vs loop number, max and mean);
* :func:`score_vs_parameter` -- Figs 5, 6, 7 (max and mean vs a swept parameter);
* :func:`fig9_cem` -- Fig 9 (CEM max and mean per iteration);
* :func:`dryden_spectrum` -- the Dryden check on the model page;
* :func:`paper_vs_replication` -- reported vs regenerated values;
* beyond the paper: the inference fits, noise, observations, the baseline, the multirotor,
  the future work (:func:`future_grid`) and the closed loop (:func:`closed_loop_curves`,
  :func:`reliability_diagram`, :func:`manoeuvre_plot`), the real flights
  (:func:`twin_validation`, :func:`wind_estimates`, :func:`channel_pair_heatmap`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.closed_loop import POLICY_NAMES
from ..analysis.tables import provenance
from ..core.stats import summarise
from ..sim.dryden import dryden_psd
from .display import channel_name

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure
    from numpy.typing import ArrayLike

    from ..sim.dryden import DrydenWind
    from ..sim.flight import Flight

__all__ = ["flyable_scores", "fig1_trajectory_and_wind", "fig1_velocity_projections", "fig2_flowcharts",
           "fig3_loop", "score_per_loop", "score_vs_parameter", "fig9_cem",
           "dryden_spectrum", "paper_vs_replication", "panel_grid", "closed_loop_curves",
           "reliability_diagram", "manoeuvre_plot", "silhouette_vs_ratio",
           "predicted_vs_paper", "noise_curves", "observation_bars", "baseline_vs_clustering",
           "vehicle_trajectories", "vehicle_scores", "future_grid", "stamp",
           "twin_validation", "wind_estimates", "channel_pair_heatmap", "integer_ticks"]

GROUP_COLOURS = ("tab:blue", "tab:orange")


def _plt():
    import matplotlib.pyplot as plt
    return plt


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
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5), constrained_layout=True)
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
        ax.text(0.5, y, text, ha="center", va="center", fontsize=8.5, wrap=True,
                bbox=dict(boxstyle="round,pad=0.4", fc="#eef3fb", ec="#355c9a"))
        if k < n - 1:
            ax.annotate("", xy=(0.5, ys[k + 1] + 0.045), xytext=(0.5, y - 0.045),
                        arrowprops=dict(arrowstyle="->", color="#355c9a"))
    ax.annotate(loop_back, xy=(0.86, ys[0]), xytext=(0.86, ys[-1]), fontsize=8, ha="center",
                rotation=90, va="bottom",
                arrowprops=dict(arrowstyle="->", color="0.4", connectionstyle="arc3,rad=0"))
    ax.set_title(title, fontsize=10)


def fig2_flowcharts() -> Figure:
    """Fig 2: the system with random exploration (a) and with CEM (b)."""
    plt = _plt()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 5.5), constrained_layout=True)
    common = ["UAV flies one thrust sequence\nin 2 groups of wind environments",
              "position trajectories\n(n_env x 120 x 3)",
              "soft-DTW time-series k-means\n(2 clusters)",
              "silhouette score (DTW);\n0 if a trajectory is misgrouped"]
    _flow(a, ["draw a random thrust sequence\n(times, magnitudes, directions)", *common,
              "record score; report max and mean"], "next loop",
          "(a) random exploration")
    _flow(b, ["draw N thrust vectors from\nN(mu, sigma^2)", *common,
              "keep the N_e elite samples;\nrefit mu, sigma (eqs CEM1-2)"], "next iteration",
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
    fig = plt.figure(figsize=(11, 4.5), constrained_layout=True)
    ax1 = fig.add_subplot(1, 2, 1, projection="3d")
    for g, (c, lab) in enumerate(zip(GROUP_COLOURS, group_labels)):
        for k, tr in enumerate(trajectories[np.asarray(groups) == g]):
            ax1.plot(tr[:, 0], tr[:, 1], tr[:, 2], color=c, lw=1, label=lab if k == 0 else None)
    ax1.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=title or "one loop")
    ax1.legend(fontsize=8)
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


def _mark_zero_bars(ax, bars) -> None:
    """A "0" beside every bar of ``bars`` (a horizontal ``BarContainer``) whose value is 0,
    so a case that ran and scored 0 does not look like a case that did not run."""
    for patch in bars.patches:
        if patch.get_width() == 0:
            ax.text(0.5, patch.get_y() + patch.get_height() / 2, "0", va="center", ha="left",
                    fontsize=7, color="0.2")


def _score_axes(ax, scores, title=None, ylim=(-2, 102)):
    loops = np.arange(1, len(scores) + 1)
    ax.plot(loops, scores, marker="o", ms=2.5, lw=0.8, color="tab:blue", label="score")
    ax.axhline(scores.max(), color="tab:red", ls="--", lw=1, label=f"max {scores.max():.2f}")
    ax.axhline(scores.mean(), color="tab:green", ls=":", lw=1.2, label=f"mean {scores.mean():.2f}")
    ax.set(xlabel="loop", ylabel="silhouette score", ylim=ylim)
    integer_ticks(ax)
    if title:
        ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7, loc="best")


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
        _score_axes(ax, scores, title=f"({letter}) {key}")
        if paper is not None:
            row = paper.loc[paper["scenario"] == key]
            if len(row):
                ax.axhline(row["maximum"].iloc[0], color="0.5", lw=0.8, ls="--")
                ax.axhline(row["mean"].iloc[0], color="0.5", lw=0.8, ls=":")
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
        ci = np.array([[r["mean"] - r["ci_low"] for r in rows],
                       [r["ci_high"] - r["mean"] for r in rows]])
        ax.plot(xs, mx, marker="^", color="tab:red", label="maximum")
        ax.errorbar(xs, mn, yerr=ci, marker="o", color="tab:blue", capsize=2,
                    label="mean (95% bootstrap CI)")
        if paper is not None:
            p = paper.loc[paper["scenario"] == key]
            ax.scatter(p[x], p["maximum"], marker="^", color="0.5", zorder=3, label="paper max")
            ax.scatter(p[x], p["mean"], marker="o", facecolor="none", edgecolor="0.3", zorder=3,
                       label="paper mean")
        ax.set(xlabel=xlabel or x, ylabel="silhouette score", title=f"({letter}) {key}",
               ylim=(-2, 102))
        ax.set_xticks(xs)
        ax.legend(fontsize=7, loc="lower left")
    return fig


def fig9_cem(history: pd.DataFrame, random_scores: ArrayLike | None = None,
             paper: pd.DataFrame | None = None) -> Figure:
    """Fig 9: CEM maximum and mean score per iteration (and the random-search reference)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4), constrained_layout=True)
    it = history.index.to_numpy() if "iteration" not in history else history["iteration"]
    ax.plot(it, history["max"], marker="^", color="tab:red", label="CEM maximum")
    ax.plot(it, history["mean"], marker="o", color="tab:blue", label="CEM mean")
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
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), constrained_layout=True, sharey=True)
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
    for (label, sub), m in zip(table.groupby(level="table", sort=False), "osD^v"):
        err = np.clip(np.vstack([sub["mean"] - sub["ci_low"],
                                 sub["ci_high"] - sub["mean"]]), 0, None)
        ax.errorbar(sub["paper_mean"], sub["mean"], yerr=err, fmt=m, ms=5, capsize=2,
                    label=label)
    lims = (min(table["paper_mean"].min(), table["ci_low"].min()) - 3, 101)
    ax.plot(lims, lims, color="0.5", lw=0.8, ls="--", label="prediction = paper")
    ax.set(xlim=lims, ylim=lims, xlabel="paper's mean score", ylabel="predicted mean score",
           title="Rows the fit never saw")
    ax.legend(fontsize=7, loc="upper left")
    return fig


# --------------------------------------------------------------------------- #
# beyond the paper
# --------------------------------------------------------------------------- #
def noise_curves(table: pd.DataFrame) -> Figure:
    """Exp 7: mean score and share of correctly grouped loops against the white position
    noise (log x; 0 drawn at 0.01 m), one line per scenario, 95% bands."""
    plt = _plt()
    t = table[table["noise_bias"] == 0]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for scen, sub in t.groupby("scenario", sort=False):
        x = np.maximum(sub["noise_sigma"].to_numpy(), 0.01)
        for ax, (y, lo, hi, scale) in zip(axes, [("mean", "ci_low", "ci_high", 1),
                                                  ("correct_rate", "correct_low",
                                                   "correct_high", 100)]):
            line, = ax.plot(x, scale * sub[y], marker="o", ms=3, label=scen)
            ax.fill_between(x, scale * sub[lo], scale * sub[hi], color=line.get_color(),
                            alpha=0.15)
    for ax, label in zip(axes, ["mean score", "correctly grouped loops (%)"]):
        ax.set_xscale("log")
        ax.axvline(1.0, color="0.5", ls=":", lw=0.8)
        ax.set(xlabel="position noise sigma [m] (0 drawn at 0.01)", ylabel=label, ylim=(-2, 102))
    axes[1].axhline(50, color="0.5", ls="--", lw=0.8)
    axes[0].legend(fontsize=7, loc="lower left")
    return fig


def observation_bars(table: pd.DataFrame) -> Figure:
    """Exp 8: mean score (95% CI) per observation, one panel per scenario, without and
    with consumer-grade noise."""
    plt = _plt()
    scen = list(dict.fromkeys(table["scenario"]))
    fig, axes = plt.subplots(1, len(scen), figsize=(4.2 * len(scen), 3.6), sharey=True,
                             constrained_layout=True)
    axes = np.atleast_1d(axes)
    for ax, sc in zip(axes, scen):
        sub = table[table["scenario"] == sc]
        obs = list(dict.fromkeys(sub["observation"]))
        x = np.arange(len(obs))
        for j, (noise, colour) in enumerate((("none", "tab:blue"), ("consumer", "tab:orange"))):
            s = sub[sub["noise"] == noise].set_index("observation").reindex(obs)
            err = np.clip(np.vstack([s["mean"] - s["ci_low"], s["ci_high"] - s["mean"]]), 0, None)
            ax.bar(x + (j - 0.5) * 0.38, s["mean"], 0.38, yerr=err, capsize=2, color=colour,
                   label=f"noise: {noise}")
        ax.set_xticks(x, [o.replace("+", "+\n") for o in obs], fontsize=8)
        ax.set(title=sc, ylim=(0, 102))
    axes[0].set_ylabel("mean score")
    axes[0].legend(fontsize=7, loc="lower left")
    return fig


def baseline_vs_clustering(table: pd.DataFrame) -> Figure:
    """Exp 9: the baseline's wind RMSE and both methods' correct shares against the
    white position noise, one line per scenario."""
    plt = _plt()
    t = table[table["noise_bias"] == 0]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), constrained_layout=True)
    for scen, sub in t.groupby("scenario", sort=False):
        x = np.maximum(sub["noise_sigma"].to_numpy(), 0.01)
        line, = axes[0].plot(x, sub["rmse"], marker="o", ms=3, label=scen)
        c = line.get_color()
        axes[1].plot(x, 100 * sub["baseline_correct_rate"], marker="s", ms=3, color=c,
                     label=f"{scen}: baseline")
        axes[1].plot(x, 100 * sub["cc_correct_rate"], marker="o", ms=3, ls="--", color=c,
                     label=f"{scen}: causal curiosity")
    axes[0].set(xscale="log", yscale="log", xlabel="position noise sigma [m] (0 drawn at 0.01)",
                ylabel="baseline wind RMSE [m/s]")
    axes[1].set(xscale="log", xlabel="position noise sigma [m] (0 drawn at 0.01)",
                ylabel="correctly grouped loops (%)", ylim=(-2, 102))
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=6, loc="lower left")
    return fig


# --------------------------------------------------------------------------- #
# on a multirotor (Exp 10)
# --------------------------------------------------------------------------- #
def vehicle_trajectories(flights: dict, groups, group_labels=("group 0", "group 1"),
                         ncols: int = 2) -> Figure:
    """One loop flown by several vehicles: a 3-D panel per vehicle (``flights``: label ->
    positions (n_env, n_steps, 3) [m] or a :class:`~uavwind.sim.flight.Flight`), the
    environments coloured by group."""
    plt = _plt()
    n = len(flights)
    ncols = min(ncols, n)
    nrows = math.ceil(n / ncols)
    fig = plt.figure(figsize=(5.6 * ncols, 5.0 * nrows), constrained_layout=True)
    g = np.asarray(groups)
    for i, (label, f) in enumerate(flights.items()):
        pos = f.positions if hasattr(f, "positions") else np.asarray(f)
        ax = fig.add_subplot(nrows, ncols, i + 1, projection="3d")
        for k, (c, lab) in enumerate(zip(GROUP_COLOURS, group_labels)):
            for j, tr in enumerate(pos[g == k]):
                ax.plot(tr[:, 0], tr[:, 1], tr[:, 2], color=c, lw=0.9,
                        label=lab if j == 0 else None)
        ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=label)
        ax.title.set_fontsize(11)
        if i == 0:
            ax.legend(fontsize=9)
    return fig


def vehicle_scores(table) -> Figure:
    """Exp 10: mean score (95% CI) per scenario, one bar per vehicle (``table``:
    :func:`uavwind.analysis.beyond.vehicle_table`)."""
    plt = _plt()
    scen = list(dict.fromkeys(table["scenario"]))
    vehicles = list(dict.fromkeys(table["vehicle"]))
    fig, ax = plt.subplots(figsize=(10, 0.55 * len(scen) * len(vehicles) / 2 + 2),
                           constrained_layout=True)
    h = 0.8 / len(vehicles)
    y = np.arange(len(scen))
    for j, v in enumerate(vehicles):
        s = table[table["vehicle"] == v].set_index("scenario").reindex(scen)
        err = np.clip(np.vstack([s["mean"] - s["ci_low"], s["ci_high"] - s["mean"]]), 0, None)
        _mark_zero_bars(ax, ax.barh(y + (j - (len(vehicles) - 1) / 2) * h, s["mean"], h,
                                    xerr=err, capsize=2, label=v))
    ax.set_yticks(y, scen, fontsize=8)
    ax.invert_yaxis()
    ax.set(xlabel="mean score", xlim=(0, 100), title="Mean score by vehicle and start")
    fig.legend(fontsize=7, loc="outside upper center", ncol=2)  # above the axes, off the bars
    return fig


def future_grid(table) -> Figure:
    """Exp 11: mean score by observation (rows) and scenario (columns), one panel per action
    and noise level (``table``: :func:`uavwind.analysis.beyond.future_table`)."""
    plt = _plt()
    actions = list(dict.fromkeys(table["action"]))
    noises = list(dict.fromkeys(table["noise"]))
    scen = list(dict.fromkeys(table["scenario"]))
    obs = list(dict.fromkeys(table["observation"]))
    fig, axes = plt.subplots(len(noises), len(actions), squeeze=False,
                             figsize=(5.2 * len(actions), 2.8 * len(noises) + 0.8),
                             constrained_layout=True)
    for i, noise in enumerate(noises):
        for j, action in enumerate(actions):
            ax = axes[i, j]
            sub = table[(table["noise"] == noise) & (table["action"] == action)]
            grid = sub.pivot_table(index="observation", columns="scenario", values="mean",
                                   sort=False).reindex(index=obs, columns=scen)
            im = ax.imshow(grid.to_numpy(), vmin=0, vmax=100, cmap="viridis", aspect="auto")
            for (r, c), v in np.ndenumerate(grid.to_numpy()):
                ax.text(c, r, f"{v:.0f}", ha="center", va="center", fontsize=10,
                        color="white" if v < 60 else "black")
            ax.set_xticks(range(len(scen)), [s.replace(" vs ", "\nvs ").replace(" (", "\n(")
                                             for s in scen], fontsize=8)
            ax.set_yticks(range(len(obs)), [channel_name(o) for o in obs], fontsize=9)
            ax.set_title(f"{action} actions, noise: {noise}", fontsize=9)
    fig.colorbar(im, ax=axes, shrink=0.6, label="mean score")
    return fig


def flyable_scores(table) -> Figure:
    """Exp 14: mean score (95% CI) per scenario, one panel per observation channel, the
    flyable waypoint references beside the paper's raw thrust (``table``:
    :func:`uavwind.analysis.manoeuvres.flyable_table`; a missing pair is left blank)."""
    plt = _plt()
    scen = list(dict.fromkeys(table["scenario"]))
    obs = list(dict.fromkeys(table["observation"]))
    actions = list(dict.fromkeys(table["action"]))
    fig, axes = plt.subplots(1, len(obs), squeeze=False, sharey=True,
                             figsize=(3.6 * len(obs) + 2.4, 0.45 * len(scen) + 1.6),
                             constrained_layout=True)
    h = 0.8 / len(actions)
    y = np.arange(len(scen))
    for ax, o in zip(axes[0], obs):
        for j, a in enumerate(actions):
            s = table[(table["observation"] == o) & (table["action"] == a)]
            s = s.set_index("scenario").reindex(scen)
            err = np.clip(np.vstack([s["mean"] - s["ci_low"], s["ci_high"] - s["mean"]]), 0,
                          None)
            ax.barh(y + (j - (len(actions) - 1) / 2) * h, s["mean"], h, xerr=err, capsize=2,
                    label=a)
        ax.set(title=o, xlabel="mean score", xlim=(0, 100))
    axes[0, 0].set_yticks(y, scen, fontsize=8)
    axes[0, 0].invert_yaxis()
    axes[0, -1].legend(fontsize=7, loc="lower right")
    return fig


# --------------------------------------------------------------------------- #
# closed loop (Exp 12)
# --------------------------------------------------------------------------- #
POLICY_STYLES = {"random": ("0.45", ":"), "best": ("tab:blue", "--"),
                 "greedy": ("tab:green", "-"), "receding": ("tab:red", "-")}
#: Exp 12: each policy's marker and drawing order (the open-loop lines on top), so a line
#: that coincides with another stays visible.
POLICY_MARKERS = {"random": ("v", 5), "best": ("s", 4), "greedy": ("o", 3), "receding": ("^", 2)}


def closed_loop_curves(curves, value: str = "accuracy") -> Figure:
    """Exp 12: ``value`` (``"accuracy"`` or ``"log_loss"``) against flight time, one panel
    per scenario (rows) and vehicle (columns), one line per policy with its 95% interval
    (``curves``: :func:`uavwind.analysis.closed_loop.accuracy_over_time`)."""
    plt = _plt()
    scale = 100 if value == "accuracy" else 1
    scen = list(dict.fromkeys(curves["scenario"]))
    veh = list(dict.fromkeys(curves["vehicle"]))
    fig, axes = plt.subplots(len(scen), len(veh), squeeze=False, sharex=True, sharey=True,
                             figsize=(5.0 * len(veh), 2.6 * len(scen) + 0.6),
                             constrained_layout=True)
    for i, s in enumerate(scen):
        for j, v in enumerate(veh):
            ax = axes[i, j]
            sub = curves[(curves["scenario"] == s) & (curves["vehicle"] == v)]
            for pol, d in sub.groupby("policy", sort=False):
                colour, ls = POLICY_STYLES.get(pol, ("k", "-"))
                marker, z = POLICY_MARKERS.get(pol, ("", 2))
                ax.plot(d["time"], d[value] * scale, color=colour, ls=ls, lw=1.4, marker=marker,
                        ms=4, markevery=(z % 4, 4), mfc="none", zorder=z,
                        label=POLICY_NAMES.get(pol, pol))
                ax.fill_between(d["time"], d[f"{value}_low"] * scale,
                                d[f"{value}_high"] * scale, color=colour, alpha=0.12, lw=0)
            ax.set_title(f"{s}\n{v}", fontsize=8)
            if value == "accuracy":
                ax.axhline(50, color="0.8", lw=0.8, zorder=0)
                ax.set_ylim(40, 101)
            if i == len(scen) - 1:
                ax.set_xlabel("flight time (s)")
            if j == 0:
                ax.set_ylabel("accuracy (%)" if value == "accuracy" else "log-loss (nats)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="outside upper center", ncol=len(labels))
    return fig


def reliability_diagram(table) -> Figure:
    """Exp 12: reported probability of group 1 against the observed share of group 1's
    environments, one panel per vehicle, one line per policy, the counts as bars
    (``table``: :func:`uavwind.analysis.closed_loop.reliability` with
    ``by=("vehicle", "policy")``)."""
    plt = _plt()
    veh = list(dict.fromkeys(table["vehicle"]))
    fig, axes = plt.subplots(1, len(veh), squeeze=False, figsize=(4.6 * len(veh), 4.2),
                             constrained_layout=True)
    for j, v in enumerate(veh):
        ax = axes[0, j]
        ax.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls="--", label="calibrated")
        sub = table[table["vehicle"] == v]
        for pol, d in sub.groupby("policy", sort=False):
            colour, ls = POLICY_STYLES.get(pol, ("k", "-"))
            ax.plot(d["predicted"], d["observed"], color=colour, ls=ls, marker="o", ms=3,
                    lw=1.2, label=POLICY_NAMES.get(pol, pol))
        counts = sub.groupby(["bin_low", "bin_high"])["count"].sum().reset_index()
        ax2 = ax.twinx()
        ax2.bar((counts["bin_low"] + counts["bin_high"]) / 2, counts["count"],
                width=0.8 * (counts["bin_high"] - counts["bin_low"]), color="0.88", zorder=0)
        ax2.set_yticks([])
        ax.set_zorder(ax2.get_zorder() + 1)
        ax.patch.set_visible(False)
        ax.set(xlim=(0, 1), ylim=(0, 1), xlabel="reported P(group 1)",
               ylabel="observed share in group 1", title=v)
        ax.title.set_fontsize(9)
        ax.legend(fontsize=7, loc="upper left")
    return fig


def manoeuvre_plot(table, scenario: str, vehicle: str) -> Figure:
    """Exp 12: the mean thrust [N] along x, y and z each policy flew, segment by segment,
    for one scenario and vehicle (``table``: :func:`uavwind.analysis.closed_loop.manoeuvres`)."""
    plt = _plt()
    sub = table[(table["scenario"] == scenario) & (table["vehicle"] == vehicle)]
    pols = list(dict.fromkeys(sub["policy"]))
    ncols = min(2, len(pols))
    fig, axes = plt.subplots(math.ceil(len(pols) / ncols), ncols, squeeze=False, sharey=True,
                             figsize=(5.5 * ncols, 3.6 * math.ceil(len(pols) / ncols)),
                             constrained_layout=True)
    for ax in axes.ravel()[len(pols):]:
        ax.set_visible(False)
    for j, pol in enumerate(pols):
        ax = axes.ravel()[j]
        d = sub[sub["policy"] == pol].sort_values("segment")
        x = d["segment"].to_numpy()
        for k, (axis, colour) in enumerate(zip("xyz", ("tab:purple", "tab:olive", "tab:cyan"))):
            ax.bar(x + (k - 1) * 0.27, d[f"thrust_{axis}"], 0.27, color=colour,
                   label=f"thrust {axis}")
        ax.axhline(2.0 * 9.81, color="0.5", lw=0.8, ls="--")
        ax.set(title=POLICY_NAMES.get(pol, pol), xlabel="segment")
        ax.title.set_fontsize(11)
        if j % ncols == 0:
            ax.set_ylabel("mean thrust (N)")
        if j == 0:
            ax.legend(fontsize=9)
    fig.suptitle(f"{scenario}, {vehicle}", fontsize=11)
    return fig


def twin_validation(table) -> Figure:
    """Exp 13: the calibrated twin against the real flights, one panel per quantity of
    :data:`uavwind.analysis.figure8.VALIDATION` against wind speed: the five real
    controllers' range (bars), the held-out controller (filled), the twin's mean over its
    seeds (open squares); where the twin was fitted, its marker is circled (``table``:
    :func:`uavwind.analysis.figure8.validation_table`)."""
    plt = _plt()
    quantities = list(dict.fromkeys(table["quantity"]))
    ncols = 3
    nrows = math.ceil((len(quantities) + 1) / ncols)  # and a panel for the legend
    fig, axes = plt.subplots(nrows, ncols, figsize=(10, 2.9 * nrows), constrained_layout=True)
    axes = np.atleast_1d(axes).ravel()
    for ax, q in zip(axes, quantities):
        t = table[table["quantity"] == q]
        x = t["wind_speed"].to_numpy(float) + np.where(t["condition"] == "70p20sint", 0.35, 0.0)
        mid = (t["real_min"] + t["real_max"]).to_numpy(float) / 2
        half = (t["real_max"] - t["real_min"]).to_numpy(float) / 2
        ax.errorbar(x, mid, yerr=half, fmt="none", color="0.55", capsize=4, lw=2,
                    label="real: 5 controllers, min-max")
        ax.plot(x, t["held_out"], "o", color="black", label="real: held-out controller")
        ax.plot(x, t["sim"], "s", color="tab:red", mfc="none", ms=7, label="twin: 5 seeds' mean")
        fit = t["fitted"].to_numpy(bool)
        ax.plot(x[fit], t["sim"].to_numpy(float)[fit], "o", ms=15, mfc="none", color="tab:blue",
                label="twin fitted here")
        ax.set_title(f"{q} [{t['unit'].iloc[0]}]", fontsize=11)
        ax.set_xlabel("wind speed [m/s]")
        ax.set_xticks([0, 4.2, 8.5, 12.1])
        ax.set_xlim(-1.0, 13.5)
        ax.grid(alpha=0.3)
    for ax in axes[len(quantities):]:
        ax.axis("off")
    handles, labels = axes[0].get_legend_handles_labels()
    axes[len(quantities)].legend(handles, labels, loc="center", fontsize=10, frameon=False)
    return fig


def wind_estimates(rows) -> Figure:
    """Exp 13: each held-out flight's mean estimated wind speed against the tunnel's, one
    panel per :class:`~uavwind.method.wind_estimator.WindEstimator` method (``rows``: the
    real rows' kind ``"estimate"``; the sinusoidal wind's flights drawn beside the steady
    8.5 m/s), the identity line dashed."""
    plt = _plt()
    est = rows[rows["kind"] == "estimate"]
    methods = list(dict.fromkeys(est["method"]))
    fig, axes = plt.subplots(1, len(methods), figsize=(3.4 * len(methods), 3.4),
                             constrained_layout=True, sharey=True, squeeze=False)
    for ax, m in zip(axes[0], methods):
        g = est[est["method"] == m]
        for ctl, d in g.groupby("controller"):
            x = d["wind_speed"].to_numpy(float) + np.where(d["condition"] == "70p20sint",
                                                           0.35, 0.0)
            ax.plot(x, d["estimate"], "o", ms=5, alpha=0.8, label=ctl)
        ax.plot([0, 13], [0, 13], "--", color="0.5", lw=1)
        ax.set(title=m, xlabel="tunnel wind [m/s]", xticks=[0, 4.2, 8.5, 12.1])
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("estimated mean wind [m/s]")
    axes[0, 0].legend(title="held out", fontsize=8, loc="upper left")
    return fig


def channel_pair_heatmap(pairs, title: str = "") -> Figure:
    """Exp 13: mean score over controllers of every pair of wind conditions (rows) in every
    channel (columns) (``pairs``: :func:`uavwind.analysis.real_flights.pair_table`)."""
    plt = _plt()
    pairs = pairs.assign(pair=pairs["condition_a"] + " vs " + pairs["condition_b"])
    grid = pairs.pivot(index="pair", columns="channel", values="mean")
    grid = grid.reindex(index=list(dict.fromkeys(pairs["pair"])),
                        columns=list(dict.fromkeys(pairs["channel"])))
    fig, ax = plt.subplots(figsize=(10, max(3.6, 0.55 * grid.shape[0] + 1.8)),
                           constrained_layout=True)
    im = ax.imshow(grid.to_numpy(float), vmin=0, vmax=100, cmap="viridis", aspect="auto")
    for i in range(grid.shape[0]):
        for j in range(grid.shape[1]):
            v = grid.iat[i, j]
            ax.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=11,
                    color="white" if v < 60 else "black")
    ax.set_xticks(range(grid.shape[1]), [c.replace("_", " ") for c in grid.columns], fontsize=10)
    ax.set_yticks(range(grid.shape[0]), grid.index, fontsize=10)
    ax.set_title(title or "Mean score over controllers")
    fig.colorbar(im, ax=ax, label="score (0-100)")
    return fig
