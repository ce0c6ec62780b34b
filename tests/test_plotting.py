"""Fast smoke tests of every figure function: each draws a Figure from inputs shaped as the
library's own tables make them (synthetic loops through the real summary functions), with a
title or labels that say what it shows. A new figure function must get a call here."""
import inspect

import matplotlib
import numpy as np
import pandas as pd
import pytest

matplotlib.use("agg")  # noqa: E402 -- headless; the book's notebooks keep their own backend
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import uavwind as uw  # noqa: E402
from uavwind.analysis import beyond, closed_loop, inference  # noqa: E402
from uavwind.analysis.tables import cem_table  # noqa: E402
from uavwind.report import beyond_figures, plotting  # noqa: E402


def _loops(**labels_by_case):
    """Synthetic result rows: 6 loops per combination of the label values given."""
    rng = np.random.default_rng(3)
    keys = list(labels_by_case)
    combos = pd.MultiIndex.from_product(list(labels_by_case.values()), names=keys)
    rows = []
    for combo in combos:
        for loop in range(6):
            ok = bool(rng.random() < 0.8)
            sil = float(rng.uniform(0.3, 0.9))
            rows.append({**dict(zip(keys, combo)), "loop": loop, "correct": ok,
                         "silhouette": sil, "score": 100 * sil if ok else 0.0,
                         "baseline_rmse": float(rng.uniform(0.01, 1)),
                         "baseline_correct": bool(rng.random() < 0.9),
                         "baseline_rmse_mass": 1.0, "baseline_correct_mass": True,
                         "baseline_rmse_drag": 0.5, "baseline_correct_drag": True})
    df = pd.DataFrame(rows)
    df.attrs.update(experiment="exp7", reading="inferred", profile="quick", seed=1,
                    engine="fast")
    return df


@pytest.fixture(scope="module")
def flight():
    s = uw.table3_setting()
    return uw.simulate_flight(uw.PAPER_EXAMPLE, s.wind(0))


def _oos():
    idx = pd.MultiIndex.from_tuples([("Table 5", "a"), ("Table 6", "b")], names=["table", "row"])
    return pd.DataFrame({"paper_mean": [80.0, 90.0], "mean": [78.0, 91.0], "ci_low": [75.0, 89.0],
                         "ci_high": [81.0, 93.0]}, index=idx)


def _fits_and_curves():
    df = _loops(scenario_id=[1], gap_ratio=[4.0, 8.0, 16.0]).assign(
        scenario="Light constant vs light constant")
    curves = inference.silhouette_curves(df)
    fits = pd.DataFrame({"paper_mean": [70.0], "ratio": [8.0], "ci_low": [6.0],
                         "ci_high": [10.0]}, index=pd.Index([1], name="scenario_id"))
    return curves, fits


def _cem_history():
    rows = [{"iteration": it, "sample": j, "score": float(10 * it + j), "elite": j < 2}
            for it in range(1, 4) for j in range(5)]
    return cem_table(pd.DataFrame(rows))


def _episodes():
    """Synthetic Exp 12 rows: 8 episodes per scenario, vehicle and policy, a report every
    second over 4 s, two segments of 2 s."""
    rng = np.random.default_rng(5)
    rows = []
    for scen in ("a", "b"):
        for veh in ("point mass", "multirotor"):
            for pol in ("random", "best", "greedy", "receding"):
                for ep in range(8):
                    group = ep % 2
                    for t in (1.0, 2.0, 3.0, 4.0):
                        p = float(np.clip(rng.normal(0.3 + 0.4 * group, 0.2), 0.0, 1.0))
                        p_true = p if group == 1 else 1.0 - p
                        rows.append({"scenario": scen, "vehicle": veh, "policy": pol,
                                     "episode": ep, "test_group": group, "time": t,
                                     "segment": int((t - 0.5) // 2), "p_group_b": p,
                                     "correct": p_true > 0.5,
                                     "log_loss": -np.log(max(p_true, 1e-12)),
                                     "thrust": rng.uniform(0, 30, 3)})
    return pd.DataFrame(rows)


#: figure function -> a call with inputs shaped as the library makes them
CALLS = {
    "fig1_trajectory_and_wind": lambda f: plotting.fig1_trajectory_and_wind(f),
    "fig1_velocity_projections": lambda f: plotting.fig1_velocity_projections(f),
    "fig2_flowcharts": lambda f: plotting.fig2_flowcharts(),
    "fig3_loop": lambda f: plotting.fig3_loop(f.positions, uw.table3_setting().groups,
                                              [10.0, 50.0, 80.0]),
    "score_per_loop": lambda f: plotting.score_per_loop(_loops(scenario=["a", "b", "c"])),
    "score_vs_parameter": lambda f: plotting.score_vs_parameter(
        _loops(scenario=["a", "b"], n_env=[6, 8, 10]), "n_env"),
    "fig9_cem": lambda f: plotting.fig9_cem(_cem_history(), random_scores=[1.0, 20.0]),
    "dryden_spectrum": lambda f: plotting.dryden_spectrum(uw.DrydenWind([12.0] * 4, seed=1),
                                                          n_samples=512, nperseg=128),
    "paper_vs_replication": lambda f: plotting.paper_vs_replication(pd.DataFrame(
        {"paper_max": [90.0], "max": [88.0], "paper_mean": [80.0], "mean": [79.0]},
        index=["row"])),
    "silhouette_vs_ratio": lambda f: plotting.silhouette_vs_ratio(*_fits_and_curves()),
    "predicted_vs_paper": lambda f: plotting.predicted_vs_paper(_oos()),
    "noise_curves": lambda f: beyond_figures.noise_curves(beyond.noise_table(
        _loops(scenario=["a", "b"], noise_sigma=[0.0, 0.5, 2.0], noise_bias=[0.0]))),
    "observation_bars": lambda f: beyond_figures.observation_bars(beyond.observation_table(
        _loops(scenario=["a", "b"], observation=["position", "velocity"],
               noise=["none", "consumer"]))),
    "baseline_vs_clustering": lambda f: beyond_figures.baseline_vs_clustering(beyond.baseline_table(
        _loops(scenario=["a"], noise_sigma=[0.0, 1.0], noise_bias=[0.0]))),
    "stamp": lambda f: plotting.stamp(plotting.fig2_flowcharts(), _loops(scenario=["a"])),
    "vehicle_trajectories": lambda f: beyond_figures.vehicle_trajectories(
        {"point mass": f, "multirotor": f.positions + 1.0}, uw.table3_setting().groups),
    "future_grid": lambda f: beyond_figures.future_grid(beyond.future_table(
        _loops(scenario=["a", "b"], action=["thrust", "attitude"],
               observation=["position", "imu"], noise=["none", "consumer"]))),
    "vehicle_scores": lambda f: beyond_figures.vehicle_scores(beyond.vehicle_table(
        _loops(scenario_id=[1, 2], vehicle=["point mass", "multirotor"]).assign(
            scenario=lambda d: "S" + d["scenario_id"].astype(str)))),
    "closed_loop_curves": lambda f: beyond_figures.closed_loop_curves(
        closed_loop.accuracy_over_time(_episodes())),
    "reliability_diagram": lambda f: beyond_figures.reliability_diagram(
        closed_loop.reliability(_episodes(), by=("vehicle", "policy"))),
    "twin_validation": lambda f: beyond_figures.twin_validation(pd.DataFrame({
        "condition": ["nowind", "35wind", "70p20sint"] * 2, "wind_speed": [0.0, 4.2, 8.5] * 2,
        "quantity": ["force along x"] * 3 + ["lean"] * 3, "unit": ["N"] * 3 + ["deg"] * 3,
        "fitted": [False, True, False] * 2,
        **{c: [1.0, 2.0, 3.0] * 2 for c in ("sim", "held_out", "real_min", "real_max")}})),
    "wind_estimates": lambda f: beyond_figures.wind_estimates(pd.DataFrame({
        "kind": ["estimate"] * 4, "method": ["drag", "drag", "ekf", "ekf"],
        "controller": ["a", "b", "a", "b"], "condition": ["35wind", "70p20sint"] * 2,
        "wind_speed": [4.2, 8.5] * 2, "estimate": [4.0, 8.1, 4.4, 8.9]})),
    "wind_estimate_series": lambda f: beyond_figures.wind_estimate_series(pd.DataFrame({
        "kind": ["series"] * 8, "method": ["drag"] * 4 + ["ekf"] * 4, "controller": ["a"] * 8,
        "condition": ["35wind", "35wind", "70p20sint", "70p20sint"] * 2,
        "wind_speed": [4.2, 4.2, 8.5, 8.5] * 2, "t": [0.0, 1.0] * 4,
        "estimate": [4.0, 4.3, 8.0, 9.0, 4.1, 4.2, 8.2, 8.8], "std": [0.3] * 8,
        "truth": [4.2, 4.2, 8.5, 9.3] * 2})),
    "channel_pair_heatmap": lambda f: beyond_figures.channel_pair_heatmap(pd.DataFrame({
        "condition_a": ["nowind"] * 2, "condition_b": ["35wind"] * 2,
        "channel": ["position", "attitude"], "mean": [40.0, 90.0]})),
    "flyable_scores": lambda f: beyond_figures.flyable_scores(__import__(
        "uavwind.analysis.manoeuvres", fromlist=["flyable_table"]).flyable_table(
        _loops(scenario=["a", "b"], action=["waypoints", "thrust"],
               observation=["position", "imu"], noise=["consumer"]))),
    "manoeuvre_plot": lambda f: beyond_figures.manoeuvre_plot(
        closed_loop.manoeuvres(_episodes()), "a", "multirotor"),
}


def _figure_functions():
    """Every public function of the two figure modules (the paper's, and those beyond it)."""
    return {name for mod in (plotting, beyond_figures) for name, obj in vars(mod).items()
            if inspect.isfunction(obj) and obj.__module__ == mod.__name__
            and not name.startswith("_")}


def test_every_figure_function_has_a_smoke_call():
    assert _figure_functions() == set(CALLS) | {"panel_grid", "integer_ticks",
                                                "cem_lines"}  # helpers


def test_cem_lines_keep_a_coinciding_max_and_mean_apart():
    """A CEM run in which every draw scored 0: the maximum and the mean coincide, and one
    line hid the other (Exps 11 and 14, issue 44); the maximum is drawn with large open
    markers, the mean small and dashed, both labelled."""
    fig, ax = plt.subplots()
    plotting.cem_lines(ax, pd.DataFrame({"max": [0.0, 0.0], "mean": [0.0, 0.0]}, index=[1, 2]))
    hi, lo = ax.get_lines()
    assert hi.get_label() == "CEM maximum" and lo.get_label() == "CEM mean"
    assert hi.get_markersize() > 2 * lo.get_markersize() and hi.get_markerfacecolor() == "none"
    assert lo.get_linestyle() == "--"
    plt.close(fig)


def test_panel_grid_shows_n_axes_and_hides_the_rest():
    fig, axes = plotting.panel_grid(3, ncols=2)
    try:
        assert len(axes) == 3 and sum(ax.get_visible() for ax in fig.axes) == 3
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_each_figure_draws_something_labelled(name, flight):
    fig = CALLS[name](flight)
    try:
        assert isinstance(fig, Figure)
        axes = [ax for ax in fig.axes if ax.get_visible()]
        assert axes, name
        words = [ax.get_title() + ax.get_xlabel() + ax.get_ylabel() for ax in axes]
        assert any(w.strip() for w in words) or fig.texts, f"{name}: nothing says what it shows"
        assert any(ax.has_data() or ax.patches or ax.texts for ax in axes), name
    finally:
        plt.close(fig)


def test_stamp_writes_the_provenance_under_the_figure():
    fig = plotting.stamp(plotting.fig2_flowcharts(), _loops(scenario=["a"]), note="Note.")
    try:
        text = " ".join(t.get_text() for t in fig.texts)
        assert "experiment exp7" in text and "'inferred' reading" in text and "Note." in text
    finally:
        plt.close(fig)


def test_loop_and_iteration_axes_are_ticked_at_whole_numbers():
    """Two loops or two CEM iterations: ticks at 1 and 2, never 1.2 or 1.4 (issue 44)."""
    import matplotlib.pyplot as plt
    import pandas as pd

    from uavwind.report import plotting

    for fig in (plotting.fig3_loop(np.zeros((2, 5, 3)), np.array([0, 1]), [50.0, 60.0]),
                plotting.fig9_cem(pd.DataFrame({"max": [50.0, 60.0], "mean": [40.0, 45.0]},
                                               index=[1, 2]))):
        fig.canvas.draw()
        ax = fig.axes[-1]
        ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
        assert ticks and all(float(t).is_integer() for t in ticks), ticks
        plt.close(fig)
    with pytest.raises(ValueError, match="axis must be"):
        plotting.integer_ticks(None, axis="z")
    fig, ax = plt.subplots()  # one iteration drawn (a quick CEM of Exp 14): a whole tick only
    ax.plot([1], [50.0], marker="o")
    plotting.integer_ticks(ax)
    fig.canvas.draw()
    assert [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]] == [1.0]
    plt.close(fig)


def test_bar_charts_keep_their_legend_off_the_bars_and_mark_zero_bars():
    """Table 4's bars and Exp 10's: the legend outside the axes (a figure legend), and a bar
    of 0 labelled '0' so a case that scored 0 does not look unrun (issue 44)."""
    table = pd.DataFrame({"paper_max": [90.0, 80.0], "max": [0.0, 85.0],
                          "paper_mean": [70.0, 60.0], "mean": [0.0, 65.0]}, index=["S1", "S2"])
    fig = plotting.paper_vs_replication(table)
    ax = fig.axes[0]
    assert ax.get_legend() is None and len(fig.legends) == 1
    assert [t.get_text() for t in ax.texts].count("0") == 2  # S1's replication max and mean
    plt.close(fig)


def test_the_cem_history_keeps_its_legend_off_the_lines():
    """Exp 6's raw-silhouette CEM: the search's lines crossed the legend inside the axes
    (issue 44); it sits above them, a figure legend."""
    fig = plotting.fig9_cem(_cem_history(), random_scores=[1.0, 20.0])
    assert fig.axes[0].get_legend() is None and len(fig.legends) == 1
    plt.close(fig)


def test_the_flyable_bars_keep_their_legend_off_the_bars():
    """Exp 14's panels: the legend sat in the last panel over the bottom scenario's bars
    (issue 44); it is a figure legend above them."""
    table = pd.DataFrame([{"scenario": s, "observation": o, "action": a, "mean": 90.0,
                           "ci_low": 85.0, "ci_high": 95.0}
                          for s in ("S1", "S2") for o in ("position", "imu")
                          for a in ("waypoints", "thrust")])
    fig = beyond_figures.flyable_scores(table)
    assert all(ax.get_legend() is None for ax in fig.axes) and len(fig.legends) == 1
    plt.close(fig)
    # a pair that scored 0 reads "0"; one not run stays blank
    table.loc[0, "mean"] = table.loc[0, "ci_low"] = table.loc[0, "ci_high"] = 0.0
    table = table.drop(index=1)
    fig = beyond_figures.flyable_scores(table)
    assert sum([t.get_text() for t in ax.texts].count("0") for ax in fig.axes) == 1
    plt.close(fig)


def test_exp8_bars_mark_a_zero_bar_and_keep_their_legend_above():
    """Exp 8's vertical bars: a bar of 0 reads "0" (issue 44: the zero acceleration bars were
    invisible), the legend sits above the panels."""
    table = pd.DataFrame([{"scenario": "S1", "observation": o, "noise": n, "mean": m,
                           "ci_low": m, "ci_high": m}
                          for o, n, m in (("position", "none", 90.0), ("position", "consumer", 0.0),
                                          ("velocity", "none", 80.0),
                                          ("velocity", "consumer", 70.0))])
    fig = beyond_figures.observation_bars(table)
    assert [t.get_text() for t in fig.axes[0].texts] == ["0"]
    assert fig.axes[0].get_legend() is None and len(fig.legends) == 1
    plt.close(fig)


def test_score_panels_put_one_legend_above_them():
    """Exps 1-5: a legend inside a panel sat over its data (exp3 (d), exp5 (a), issue 44);
    one figure legend above the panels names every line once, the paper's grey ones too,
    and each panel's maximum and mean are in its title."""
    df = pd.DataFrame({"scenario": ["a"] * 3 + ["b"] * 3, "loop": [0, 1, 2] * 2,
                       "score": [10.0, 20.0, 30.0, 0.0, 0.0, 90.0]})
    paper = pd.DataFrame({"scenario": ["a", "b"], "maximum": [40.0, 95.0], "mean": [30.0, 80.0]})
    fig = plotting.score_per_loop(df, paper=paper)
    assert all(ax.get_legend() is None for ax in fig.axes if ax.get_visible())
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["score", "maximum", "mean",
                                                          "paper maximum", "paper mean"]
    assert fig.axes[0].get_title().endswith("max 30.00, mean 20.00")
    plt.close(fig)
    sweep = pd.DataFrame({"scenario": "a", "n_env": [6, 6, 8, 8], "loop": [0, 1, 0, 1],
                          "score": [50.0, 60.0, 70.0, 80.0]})
    fig = plotting.score_vs_parameter(sweep, "n_env")
    assert fig.axes[0].get_legend() is None and len(fig.legends) == 1
    plt.close(fig)


def test_closed_loop_lines_stay_distinguishable():
    """Two policies with the same curve: each line keeps its own marker, the open-loop one
    drawn on top, and the legend sits outside the panels (issue 44: exp12's open-loop line hid)."""
    t = np.arange(0.5, 12.5, 0.5)
    rows = [{"scenario": "S", "vehicle": "V", "policy": p, "time": x, "accuracy": 0.9,
             "accuracy_low": 0.8, "accuracy_high": 1.0} for p in ("best", "greedy") for x in t]
    fig = beyond_figures.closed_loop_curves(pd.DataFrame(rows))
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines() if not ln.get_label().startswith("_")}
    best, greedy = lines["open-loop best"], lines["closed-loop greedy"]
    assert best.get_marker() != greedy.get_marker() and best.get_zorder() > greedy.get_zorder()
    assert fig.axes[0].get_legend() is None and len(fig.legends) == 1
    plt.close(fig)


def test_a_signed_number_never_reads_minus_zero():
    from uavwind.report.display import signed
    assert signed(-1e-17) == "+0.00" and signed(-0.0) == "+0.00" and signed(-0.004) == "+0.00"
    assert signed(-0.006) == "-0.01" and signed(0.126, 1) == "+0.1" and signed(3) == "+3.00"
    with pytest.raises(ValueError, match="digits must be an int"):
        signed(1.0, 2.5)


def test_no_error_bar_where_there_is_no_95_percent_interval():
    """Two loops' bootstrap is their range and a zero-width interval is none: the figures
    draw no bar for either (issue 67), and do for three loops or more."""
    import pandas as pd

    from uavwind.report._drawing import _errors
    t = pd.DataFrame({"mean": [50.0, 50.0, 50.0, 80.0], "ci_low": [40.0, 40.0, 50.0, 70.0],
                      "ci_high": [60.0, 60.0, 50.0, 85.0], "n_loops": [2, 3, 5, 50]})
    err = _errors(t)
    assert np.isnan(err[:, 0]).all() and np.isnan(err[:, 2]).all()
    assert err[:, 1].tolist() == [10.0, 10.0] and err[:, 3].tolist() == [10.0, 5.0]
