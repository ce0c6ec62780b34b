"""The figures beyond the paper: noise, observations, the baseline, the multirotor, the
future work, flyable manoeuvres, the closed loop and the real flights.

This module owns the drawing of what the book adds to the paper (Exps 7-14), as
:mod:`uavwind.report.plotting` owns the paper's own figures: each function takes a result or
summary table (or flights) and returns a ``matplotlib.figure.Figure``, computing nothing a
test cannot reach elsewhere.

* :func:`noise_curves`, :func:`observation_bars`, :func:`baseline_vs_clustering` -- Exps
  7-9;
* :func:`vehicle_trajectories`, :func:`vehicle_scores` -- the multirotor (Exp 10);
* :func:`future_grid` -- the paper's future work (Exp 11); :func:`flyable_scores` -- flyable
  manoeuvres (Exp 14);
* :func:`closed_loop_curves`, :func:`reliability_diagram`, :func:`manoeuvre_plot` -- the
  closed loop (Exp 12), each policy drawn as :data:`POLICY_STYLES` and
  :data:`POLICY_MARKERS` say;
* :func:`twin_validation`, :func:`wind_estimates`, :func:`wind_estimate_series`,
  :func:`channel_pair_heatmap` -- the real
  flights (Exp 13).

Import them from here: :mod:`uavwind.report.plotting` has the paper's figures only.
"""

from __future__ import annotations

import math
import textwrap
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.closed_loop import POLICY_NAMES
from ..core.stats import MIN_INTERVAL
from ..data.neuralfly import condition_label
from ..analysis.wind_estimates import BASELINE, PROTOCOL_NAMES, estimates
from ._drawing import GROUP_COLOURS, _errors, _legend_above, _mark_zero_bars, _plt
from .display import channel_name

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["noise_curves", "observation_bars", "baseline_vs_clustering", "vehicle_trajectories",
           "vehicle_scores", "future_grid", "flyable_scores", "POLICY_STYLES", "POLICY_MARKERS",
           "closed_loop_curves", "reliability_diagram", "manoeuvre_plot", "twin_validation",
           "wind_estimates", "wind_estimate_series", "channel_pair_heatmap"]


def noise_curves(table: pd.DataFrame) -> Figure:
    """Exp 7: mean score and share of correctly grouped loops against the white position
    noise (log x; 0 drawn at 0.01 m), one line per scenario, 95% bands."""
    plt = _plt()
    t = table[table["noise_bias"] == 0]
    # near the text column's width (10 in put its labels and legend at about 6 px, issue 67)
    fig, axes = plt.subplots(1, 2, figsize=(7.6, 3.6), constrained_layout=True)
    for scen, sub in t.groupby("scenario", sort=False):
        x = np.maximum(sub["noise_sigma"].to_numpy(), 0.01)
        for ax, (y, lo, hi, scale) in zip(axes, [("mean", "ci_low", "ci_high", 1),
                                                  ("correct_rate", "correct_low",
                                                   "correct_high", 100)]):
            line, = ax.plot(x, scale * sub[y], marker="o", ms=3, label=scen)
            if (sub["n_loops"] >= MIN_INTERVAL).all():  # two loops' range is no 95% band
                ax.fill_between(x, scale * sub[lo], scale * sub[hi], color=line.get_color(),
                                alpha=0.15)
    for ax, label in zip(axes, ["mean score", "correctly grouped loops (%)"]):
        ax.set_xscale("log")
        ax.axvline(1.0, color="0.5", ls=":", lw=0.8)
        ax.set(xlabel="position noise $\\sigma$ [m] (0 drawn at 0.01)", ylabel=label,
               ylim=(-2, 102))
    axes[1].axhline(50, color="0.5", ls="--", lw=0.8)
    axes[0].legend(fontsize=8, loc="lower left")
    return fig


def observation_bars(table: pd.DataFrame) -> Figure:
    """Exp 8: mean score (95% CI) per observation, one panel per scenario, without and
    with consumer-grade noise."""
    plt = _plt()
    scen = list(dict.fromkeys(table["scenario"]))
    fig, axes = plt.subplots(1, len(scen), figsize=(3.1 * len(scen), 3.4), sharey=True,
                             constrained_layout=True)
    axes = np.atleast_1d(axes)
    for ax, sc in zip(axes, scen):
        sub = table[table["scenario"] == sc]
        obs = list(dict.fromkeys(sub["observation"]))
        x = np.arange(len(obs))
        for j, (noise, colour) in enumerate((("none", "tab:blue"), ("consumer", "tab:orange"))):
            s = sub[sub["noise"] == noise].set_index("observation").reindex(obs)
            err = _errors(s)  # no bar where there is no 95% interval
            _mark_zero_bars(ax, ax.bar(x + (j - 0.5) * 0.38, s["mean"], 0.38, yerr=err,
                                       capsize=2, color=colour, label=f"noise: {noise}"),
                            fontsize=9)
        # slanted: "velocity" and "acceleration" ran into each other at this width
        ax.set_xticks(x, [o.replace("+", "+\n") for o in obs], fontsize=9, rotation=30,
                      ha="right", rotation_mode="anchor")
        ax.set(title=sc, ylim=(0, 102))
        ax.title.set_fontsize(10)
    axes[0].set_ylabel("mean score", fontsize=10)
    _legend_above(fig, axes[:1], fontsize=9)  # inside the first panel it covered bars
    return fig


def baseline_vs_clustering(table: pd.DataFrame) -> Figure:
    """Exp 9: the baseline's wind RMSE and both methods' correct shares against the
    white position noise, one line per scenario."""
    plt = _plt()
    t = table[table["noise_bias"] == 0]
    fig, axes = plt.subplots(1, 2, figsize=(7.6, 3.8), constrained_layout=True)  # column's width
    # lines that coincide (the worked example: 100% at every level for both methods) stay
    # visible: concentric markers, the first scenario's largest and open, the last's
    # smallest, filled and on top
    groups = list(t.groupby("scenario", sort=False))
    for k, (scen, sub) in enumerate(groups):
        ms, last = 3.5 + 2.5 * (len(groups) - 1 - k), k == len(groups) - 1
        x = np.maximum(sub["noise_sigma"].to_numpy(), 0.01)
        line, = axes[0].plot(x, sub["rmse"], marker="o", ms=ms, label=scen, zorder=3 + k,
                             mfc=None if last else "none", mew=1.3)
        c = line.get_color()
        axes[1].plot(x, 100 * sub["baseline_correct_rate"], marker="s", ms=ms, color=c,
                     zorder=3 + k, mfc=c if last else "none", mew=1.3)
        axes[1].plot(x, 100 * sub["cc_correct_rate"], marker="o", ms=ms, ls="--", color=c,
                     zorder=3 + k, mfc=c if last else "none", mew=1.3)
    axes[0].set(xscale="log", yscale="log",
                xlabel="position noise $\\sigma$ [m] (0 drawn at 0.01)",
                ylabel="baseline wind RMSE [m/s]")
    axes[1].set(xscale="log", xlabel="position noise $\\sigma$ [m] (0 drawn at 0.01)",
                ylabel="correctly grouped loops (%)", ylim=(-2, 102))
    # one legend above both panels: the scenarios' colours, and the two methods' line styles
    from matplotlib.lines import Line2D
    handles, labels = axes[0].get_legend_handles_labels()
    handles += [Line2D([], [], color="0.3", marker="s", ls="-"),
                Line2D([], [], color="0.3", marker="o", ls="--")]
    labels += ["baseline (right)", "causal curiosity (right)"]
    fig.legend(handles, labels, fontsize=9, loc="outside upper center", ncol=3)
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
    # about the text column's width (7 in for 690 px), so 9-10 pt reads as 12-14 px: at 10 in
    # wide and 15 in tall the labels were about 7 px and the legend 6 px (issue 67)
    fig, ax = plt.subplots(figsize=(7, 0.2 * len(scen) * len(vehicles) + 1.8),
                           constrained_layout=True)
    h = 0.8 / len(vehicles)
    y = np.arange(len(scen))
    for j, v in enumerate(vehicles):
        s = table[table["vehicle"] == v].set_index("scenario").reindex(scen)
        err = _errors(s)  # no bar where there is no 95% interval
        _mark_zero_bars(ax, ax.barh(y + (j - (len(vehicles) - 1) / 2) * h, s["mean"], h,
                                    xerr=err, capsize=2, label=v))
    ax.set_yticks(y, [textwrap.fill(s, 20) for s in scen], fontsize=10)
    ax.invert_yaxis()
    ax.set(xlabel="mean score", xlim=(0, 100), title="Mean score by vehicle and start")
    fig.legend(fontsize=9, loc="outside upper center", ncol=2)  # above the axes, off the bars
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
                             figsize=(3.8 * len(actions) + 0.8, 2.9 * len(noises) + 1.0),
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
            # wrapped narrower than a column: "light constant vs light shear" and "vs strong
            # turbulence" ran into each other on one line each (issue 44); at 7.5 pt they
            # were about 6 px on the page (issue 67): a figure nearer the page's width (about
            # 8.4 in for 690 px of text column: 9 pt is about 10 px there), larger
            ax.set_xticks(range(len(scen)),
                          [textwrap.fill(s, 9, break_long_words=False) for s in scen],
                          fontsize=9)
            ax.set_yticks(range(len(obs)), [channel_name(o) for o in obs], fontsize=10)
            ax.set_title(f"{action} actions, noise: {noise}", fontsize=10)
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
                             # near the text column's width (13 in wide put 8 pt at about
                             # 6 px on the page, issue 67); scenario names wrapped
                             figsize=(2.4 * len(obs) + 1.8, 0.55 * len(scen) + 1.6),
                             constrained_layout=True)
    h = 0.8 / len(actions)
    y = np.arange(len(scen))
    for ax, o in zip(axes[0], obs):
        for j, a in enumerate(actions):
            s = table[(table["observation"] == o) & (table["action"] == a)]
            s = s.set_index("scenario").reindex(scen)
            err = _errors(s)  # fewer than 3 loops, or zero width: no 95% interval, no bar
            # a "0" beside a case that scored 0; a pair not run stays blank
            _mark_zero_bars(ax, ax.barh(y + (j - (len(actions) - 1) / 2) * h, s["mean"], h,
                                        xerr=err, capsize=2, label=a))
        ax.set(title=channel_name(o), xlabel="mean score", xlim=(0, 100))
    axes[0, 0].set_yticks(y, [textwrap.fill(s, 20) for s in scen], fontsize=9)
    axes[0, 0].invert_yaxis()
    # above the panels: inside the last one it covered the bottom scenario's bars
    fig.legend(*axes[0, -1].get_legend_handles_labels(), fontsize=9,
               title="no bar and no 0: not run", title_fontsize=9,
               loc="outside upper center", ncol=len(actions))
    return fig


# --------------------------------------------------------------------------- #
# closed loop (Exp 12)
# --------------------------------------------------------------------------- #
#: Exp 12: each policy's colour and line style.
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
                             # near the text column's width (10 in put the titles and the
                             # legend at about 7 px on the page, issue 67)
                             figsize=(3.7 * len(veh) + 0.3, 2.3 * len(scen) + 0.9),
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
            ax.set_title(f"{s}\n{v}", fontsize=9)
            if value == "accuracy":
                ax.axhline(50, color="0.8", lw=0.8, zorder=0)
                # from 40% unless some curve or band goes lower (early reports of a few
                # episodes can): then from 0, so nothing falls off a panel (axes shared)
                low = min(curves[f"{value}_low"].min(), curves[value].min()) * scale
                ax.set_ylim(40 if low >= 40 else -2, 101)
            if i == len(scen) - 1:
                ax.set_xlabel("flight time (s)")
            if j == 0:
                ax.set_ylabel("accuracy (%)" if value == "accuracy" else "log-loss (nats)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=9, loc="outside upper center",
               ncol=min(len(labels), 2))
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
        pols = list(dict.fromkeys(sub["policy"]))
        for i, (pol, d) in enumerate(sub.groupby("policy", sort=False)):
            colour, ls = POLICY_STYLES.get(pol, ("k", "-"))
            marker, z = POLICY_MARKERS.get(pol, ("o", 2))
            # policies whose beliefs fall in the same bins coincide point for point: each is
            # shifted a little along the reported axis and drawn open, the lower-drawn ones
            # larger, so a policy under another still shows (issue 67: receding CEM vanished
            # under open-loop best)
            dodge = (i - (len(pols) - 1) / 2) * 0.012
            ax.plot(d["predicted"] + dodge, d["observed"], color=colour, ls=ls, marker=marker,
                    ms=4 + 1.5 * (max(POLICY_MARKERS.values(), key=lambda m: m[1])[1] - z),
                    mfc="none", mew=1.2, lw=1.2, zorder=z, label=POLICY_NAMES.get(pol, pol))
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
    _legend_above(fig, axes[0, :1])  # inside, it covered the first bin's bar (issue 44)
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
    :data:`uavwind.analysis.twin.VALIDATION` against wind speed: the five real
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
    panel per drag-model method and protocol, the model as fitted (``rows``: the real rows'
    kind ``"estimate"``; the sinusoidal wind's flights drawn beside the steady 8.5 m/s), the
    identity dashed."""
    plt = _plt()
    est = estimates(rows)
    est = est[~est["method"].isin(["clusters", BASELINE])  # the drag models as fitted
              & (est["variant"] == "default")]
    panels = list(dict.fromkeys(zip(est["method"], est["protocol"])))
    fig, axes = plt.subplots(1, len(panels), figsize=(3.3 * len(panels), 3.6),
                             constrained_layout=True, sharey=True, squeeze=False)
    for ax, (m, p) in zip(axes[0], panels):
        g = est[(est["method"] == m) & (est["protocol"] == p)]
        for ctl, d in g.groupby("controller"):
            x = d["wind_speed"].to_numpy(float) + np.where(d["condition"] == "70p20sint",
                                                           0.35, 0.0)
            ax.plot(x, d["estimate"], "o", ms=5, alpha=0.8, label=ctl)
        ax.plot([0, 13], [0, 13], "--", color="0.5", lw=1)
        ax.set(title=f"{m}: {PROTOCOL_NAMES.get(p, p)}", xlabel="tunnel wind [m/s]",
               xticks=[0, 4.2, 8.5, 12.1])
        ax.title.set_fontsize(10)
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("estimated mean wind [m/s]")
    axes[0, 0].legend(title="held out", fontsize=8, loc="upper left")
    return fig


def wind_estimate_series(rows) -> Figure:
    """Exp 13: the estimated wind speed with its 95% band against the tunnel's wind over
    time, one flight per wind (columns) and one drag-model method per row (``rows``: the real
    rows' kind ``"series"``, one held-out controller)."""
    plt = _plt()
    ser = rows[rows["kind"] == "series"]
    methods = list(dict.fromkeys(ser["method"]))
    conds = list(dict.fromkeys(ser["condition"]))
    fig, axes = plt.subplots(len(methods), len(conds), figsize=(2.9 * len(conds),
                             2.5 * len(methods) + 0.6), constrained_layout=True,
                             sharex=True, squeeze=False)
    for i, m in enumerate(methods):
        for j, c in enumerate(conds):
            ax = axes[i, j]
            d = ser[(ser["method"] == m) & (ser["condition"] == c)]
            t, y, sd = (d[k].to_numpy(float) for k in ("t", "estimate", "std"))
            ax.fill_between(t, y - 1.96 * sd, y + 1.96 * sd, color="C0", alpha=0.25, lw=0,
                            label="95% interval")
            ax.plot(t, y, color="C0", lw=1, label="estimate")
            ax.plot(t, d["truth"], color="k", lw=1, ls="--", label="tunnel")
            lo, hi = np.nanmin(d["truth"]), np.nanmax(d["truth"])
            ax.set_ylim(lo - 3.0, hi + 3.0)
            ax.grid(alpha=0.3)
            if i == 0:
                ax.set_title(("8.5 + 2.4 sin t" if c == "70p20sint" else
                              f"{d['wind_speed'].iloc[0]:g}") + " m/s", fontsize=10)
            if j == 0:
                ax.set_ylabel(f"{m}: wind [m/s]")
            if i == len(methods) - 1:
                ax.set_xlabel("time [s]")
    axes[0, -1].legend(fontsize=8, loc="upper right")
    who = ", ".join(dict.fromkeys(ser["controller"]))
    fig.suptitle(f"Held-out controller {who}, fitted on the others' flights", fontsize=11)
    return fig


def channel_pair_heatmap(pairs, title: str = "") -> Figure:
    """Exp 13: mean score over controllers of every pair of wind conditions (rows) in every
    channel (columns) (``pairs``: :func:`uavwind.analysis.real_flights.pair_table`)."""
    plt = _plt()
    pairs = pairs.assign(pair=pairs["condition_a"].map(condition_label) + " vs "
                         + pairs["condition_b"].map(condition_label))
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
