"""The interactive "Explore" page: one loop, live, from a few sliders.

This module owns :func:`explore_loop` (build a setting from plain choices, fly
one random thrust sequence, score it, draw it), :func:`explorer` (the ipywidgets
interface around it, for ``make lab``), and the static explorer that works in the
built book without a kernel: :func:`explore_grid` precomputes every combination of
its controls, :func:`cached_grid` keeps it in the one verified cache
(:func:`uavwind.core.store.get_or_compute`, JSON) and :func:`explorer_html` draws it with
plotly.js in the browser.
"""

from __future__ import annotations

import html
import json
import os
import re
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.checks import check_scalar
from ..core.store import get_or_compute
from ..method.clustering import score_loop, score_loops
from ..sim.actions import PAPER_EXAMPLE, ThrustSequence, sample_paper
from ..study.builders import make_setting
from ..study.cache import RESULTS_VERSION
from ..study.readings import get_reading
from ..study.registry import computes
from .display import group_name
from .plotting import fig3_loop

if TYPE_CHECKING:
    from ipywidgets import VBox
    from matplotlib.figure import Figure

    from ..method.clustering import LoopResult
    from ..sim.setting import Setting
    from ..study.conditions import WindCondition

__all__ = ["explore_loop", "explorer", "explore_grid", "cached_grid", "fill_grid", "explorer_html",
           "explore_thrusts",
           "EXPLORE_PAIRS"]


def explore_loop(condition_a: str | WindCondition = "light constant",
                 condition_b: str | WindCondition = "strong shear", n_per_group: int = 5,
                 thrust_seed: int = 0, n_changes: int = 6, engine: str | None = None,
                 ) -> tuple[Figure, LoopResult, Setting, ThrustSequence]:
    """Fly one random thrust sequence through two generated groups and score it.

    Returns ``(figure, LoopResult, setting, thrust)``.
    """
    setting = make_setting(condition_a, condition_b, n_per_group, n_changes=n_changes)
    thrust = setting.sample_thrust(np.random.default_rng(thrust_seed))
    traj = setting.simulate(thrust, seed=thrust_seed)
    res = score_loop(traj, setting.groups, engine=engine)
    fig = fig3_loop(traj, setting.groups, [res.score],
                    group_labels=(group_name(setting, 0), group_name(setting, 1)),
                    title=f"score {res.score:.2f} ({'correct' if res.correct else 'misgrouped'})")
    fig.axes[1].set_visible(False)
    return fig, res, setting, thrust


def explorer() -> VBox:
    """An ipywidgets panel: wind conditions, environments, thrust seed and changes."""
    import ipywidgets as w
    import matplotlib.pyplot as plt
    from IPython.display import display

    conds = [f"{s} {k}" for s in ("light", "strong") for k in ("constant", "shear", "turbulence")]
    a = w.Dropdown(options=conds, value="light constant", description="group A")
    b = w.Dropdown(options=conds, value="strong shear", description="group B")
    n = w.IntSlider(value=5, min=2, max=15, description="env / group")
    seed = w.IntSlider(value=0, min=0, max=200, description="thrust seed")
    changes = w.IntSlider(value=6, min=0, max=11, description="changes")

    def show(condition_a, condition_b, n_per_group, thrust_seed, n_changes):
        fig, res, _, thrust = explore_loop(condition_a, condition_b, n_per_group, thrust_seed,
                                           n_changes)
        plt.show()
        display(res.to_table(thrust))

    out = w.interactive_output(show, {"condition_a": a, "condition_b": b, "n_per_group": n,
                                      "thrust_seed": seed, "n_changes": changes})
    return w.VBox([w.HBox([a, b]), w.HBox([n, seed, changes]), out])


# --------------------------------------------------------------------------- #
# the static explorer: a grid of precomputed loops, no kernel needed
# --------------------------------------------------------------------------- #
#: The pairs of the static explorer: Table 2's scenarios and Exp 5's pair.
EXPLORE_PAIRS = (("light constant", "light constant"), ("light constant", "strong constant"),
                 ("strong constant", "strong constant"), ("light shear", "light shear"),
                 ("light shear", "strong shear"), ("strong shear", "strong shear"),
                 ("light constant", "strong turbulence"), ("light constant", "light shear"))


def explore_thrusts() -> dict[str, ThrustSequence]:
    """The thrust sequences the static explorer offers: label -> ThrustSequence."""

    return {"the paper's example (Table 3)": PAPER_EXAMPLE,
            "climb, then push along x": ThrustSequence([0, 6], [40, 20], [[0, 0, 1], [1, 0, 0]]),
            "hover and push along x": ThrustSequence([0], [float(np.hypot(15.0, 2 * 9.81))],
                                                     [[15.0, 0.0, 2 * 9.81]]),
            "random (seed 1)": sample_paper(np.random.default_rng(1)),
            "random (seed 2)": sample_paper(np.random.default_rng(2))}


def explore_grid(pairs: Sequence[tuple[str, str]] = EXPLORE_PAIRS,
                 n_per_group: Sequence[int] = (3, 5),
                 layouts: Sequence[str] = ("inferred", "halves"), every: int = 3,
                 engine: str | None = None,
                 seed: int | np.random.SeedSequence | None = 0) -> dict:
    """Fly and score every combination of the explorer's controls.

    Returns a JSON-ready dict: ``controls`` (the options of each control) and
    ``loops`` (key ``"pair|n|thrust|layout"`` -> ``{"x", "y", "z"`` (one list per
    environment, every ``every``-th sample, cm resolution), ``"groups"``, ``"score"``,
    ``"correct"``}). Turbulence uses the loop's reading and ``seed``.
    """
    every = check_scalar(every, "every", low=1, high=10 ** 4, integer=True)
    for name, value in (("pairs", pairs), ("n_per_group", n_per_group), ("layouts", layouts)):
        if isinstance(value, str) or not len(value):
            raise ValueError(f"{name} must be a non-empty sequence, got {value!r}")
    thrusts = explore_thrusts()
    flown = [(key, j, s.groups, s.simulate(thrust, seed=seed))
             for key, s in _grid_settings(pairs, n_per_group, layouts)
             for j, thrust in enumerate(thrusts.values())]
    # scored side by side (score_loop's results): the grid's small loops share the vectors
    scored = score_loops([traj for *_, traj in flown], [g for _, _, g, _ in flown],
                         engine=engine)
    loops = {}
    for ((i, n, layout), j, groups, traj), res in zip(flown, scored):
        pts = np.round(traj[:, ::every], 2)
        loops[f"{i}|{n}|{j}|{layout}"] = {
            "x": pts[..., 0].tolist(), "y": pts[..., 1].tolist(),
            "z": pts[..., 2].tolist(), "groups": groups.tolist(),
            "score": round(res.score, 2), "correct": res.correct}
    return {"controls": {"pair": [f"{a} vs {b}" for a, b in pairs],
                         "n": list(n_per_group), "thrust": list(thrusts),
                         "layout": list(layouts)},
            "loops": loops}


def _grid_settings(pairs, n_per_group, layouts):
    """``((pair index, n, reading name), Setting)`` for every setting of the grid."""

    for i, (a, b) in enumerate(pairs):
        for n in n_per_group:
            for layout in layouts:
                yield (i, n, layout), make_setting(a, b, n, **get_reading(layout).builder_kwargs)


#: :func:`explore_grid`'s arguments, in order.
_GRID_ARGS = ("pairs", "n_per_group", "layouts", "every", "engine", "seed")


def cached_grid(folder: os.PathLike | str | None = None, **kwargs: Any) -> dict:
    """:func:`explore_grid`, cached as JSON in ``<results>/explore/`` under a key of
    everything that determines it -- its arguments with their defaults, every setting's
    key (so a refitted layout changes it), the thrust sequences and the results version;
    a damaged or altered file (not what was written, or not a grid) is moved aside, with a
    warning naming it, and recomputed."""
    unknown = sorted(set(kwargs) - set(_GRID_ARGS))
    if unknown:  # before anything is written
        raise TypeError(f"cached_grid() got unexpected keyword argument(s) {unknown}; it takes "
                        f"those of explore_grid: {list(_GRID_ARGS)}")
    args = {**dict(zip(_GRID_ARGS, explore_grid.__defaults__)), **kwargs}
    settings = [s.key() for _, s in
                _grid_settings(args["pairs"], args["n_per_group"], args["layouts"])]
    thrusts = {k: t.to_dict() for k, t in explore_thrusts().items()}
    return get_or_compute("explore", {"args": args, "settings": settings, "thrusts": thrusts},
                          lambda: explore_grid(**kwargs), _grid_problem, folder,
                          version=RESULTS_VERSION, fmt="json", name="grid",
                          what="explorer's grid")


#: The fields of each loop of a grid (:func:`explore_grid`).
_LOOP_FIELDS = {"x", "y", "z", "groups", "score", "correct"}


def _grid_problem(grid) -> str:
    """Why ``grid`` is not an explorer grid :func:`explorer_html` can draw ("" if it is): its
    loops are named by its controls, each a set of finite paths of one length per
    environment, groups 0 and 1, a score in [-100, 100] that is 0 unless the loop is
    correct."""
    if not isinstance(grid, dict) or set(grid) != {"controls", "loops"}:
        return "not an object of controls and loops"
    controls, loops = grid["controls"], grid["loops"]
    if not isinstance(controls, dict) or not isinstance(loops, dict):
        return "controls or loops is not an object"
    if any(not isinstance(v, list) for v in controls.values()):
        return "a control whose options are not a list"
    names = ("pair", "n", "thrust", "layout")
    if controls and set(controls) != set(names):
        return f"controls other than {list(names)}"
    if controls:
        want = {f"{i}|{n}|{j}|{layout}" for i in range(len(controls["pair"]))
                for n in controls["n"] for j in range(len(controls["thrust"]))
                for layout in controls["layout"]}
        if set(loops) != want:
            return "loops that are not one for each choice of the controls"
    for key, loop in loops.items():
        if not isinstance(loop, dict) or set(loop) != _LOOP_FIELDS:
            return f"loop {key!r} lacks {sorted(_LOOP_FIELDS)}"
        why = _loop_problem(loop)
        if why:
            return f"loop {key!r} has {why}"
    return ""


def _loop_problem(loop) -> str:
    """Why one loop of a grid cannot be drawn or believed ("" if it can)."""
    score, correct, groups = loop["score"], loop["correct"], loop["groups"]
    if not isinstance(correct, bool):
        return "a correct flag that is not true or false"
    if (isinstance(score, bool) or not isinstance(score, (int, float))
            or not -100 <= score <= 100):
        return f"a score outside [-100, 100] ({score!r})"
    if not correct and score != 0:
        return "a non-zero score for a misgrouped loop"
    if (not isinstance(groups, list) or not groups
            or any(g not in (0, 1) or isinstance(g, bool) for g in groups)
            or set(groups) != {0, 1}):
        return "groups that are not both of 0 and 1"
    try:
        paths = [np.asarray(loop[c], dtype=float) for c in "xyz"]
    except (TypeError, ValueError):
        return "paths that are not numbers"
    if (any(p.ndim != 2 for p in paths)
            or any(p.shape != (len(groups), paths[0].shape[1]) for p in paths)):
        return "paths that are not one per environment, all of one length"
    if not all(np.all(np.isfinite(p)) for p in paths):
        return "paths that are not finite"
    return ""


@computes("explore_grid", long=True, title="The explorer's grid", notebook="explore.md")
def fill_grid(results=None) -> None:
    """The registry's entry for this page (``python -m uavwind run explore_grid``):
    :func:`cached_grid` into ``results`` (the grid is the same at every profile and seed)."""
    cached_grid(results)


def _script_json(value) -> str:
    """``value`` as JSON that cannot end the ``<script>`` it sits in (``</script>``, ``<!--``)
    or break out of it: ``<``, ``>`` and ``&`` written as unicode escapes."""
    return (json.dumps(value, separators=(",", ":")).replace("<", "\\u003c")
            .replace(">", "\\u003e").replace("&", "\\u0026"))


def explorer_html(grid: Mapping[str, Any], plotly_src: str = "../_static/plotly/plotly.min.js",
                  element_id: str = "uw-explorer") -> str:
    """A self-contained HTML widget over ``grid`` (:func:`explore_grid`): four selects, a
    rotatable 3-D plot and the score, redrawn in the browser on every change.

    ``plotly_src`` is the plotly.js the page loads (the book serves its own copy: no CDN).
    The URL fragment can preset the controls, e.g. ``#pair=2&n=5&thrust=1&layout=halves``.
    """

    c = grid["controls"]
    if not isinstance(element_id, str) or not re.fullmatch(r"[A-Za-z][\w-]*", element_id):
        raise ValueError(f"element_id must be an HTML id (a letter, then letters, digits, _ "
                         f"or -), got {element_id!r}")
    plotly_src = html.escape(str(plotly_src), quote=True)

    def select(name, options, label):
        opts = "".join(f'<option value="{html.escape(str(v), quote=True)}">'
                       f'{html.escape(str(t))}</option>' for v, t in options)
        return (f'<label style="margin-right:1em">{label} <select data-control="{name}">'
                f"{opts}</select></label>")
    controls = "".join([
        select("pair", list(enumerate(c["pair"])), "wind conditions"),
        select("n", [(n, n) for n in c["n"]], "environments per group"),
        select("thrust", list(enumerate(c["thrust"])), "thrust sequence"),
        select("layout", [(v, v) for v in c["layout"]], "reading")])
    data = _script_json(grid["loops"])
    return f"""<div id="{element_id}" class="uw-explorer">
<div style="margin-bottom:0.5em">{controls}</div>
<div class="uw-score" style="font-weight:bold;margin:0.3em 0"></div>
<div class="uw-plot" style="width:100%;height:520px"></div>
</div>
<script src="{plotly_src}"></script>
<script>
(function() {{
  var root = document.getElementById("{element_id}");
  var loops = {data};
  var selects = root.querySelectorAll("select");
  var colours = ["#1f77b4", "#d62728"];
  var names = {_script_json(c["pair"])};
  function key() {{
    var v = {{}};
    selects.forEach(function(s) {{ v[s.dataset.control] = s.value; }});
    return [v.pair, v.n, v.thrust, v.layout].join("|");
  }}
  function draw() {{
    var k = key(), loop = loops[k];
    var groupNames = names[+k.split("|")[0]].split(" vs ");
    var traces = loop.x.map(function(x, e) {{
      var g = loop.groups[e];
      return {{type: "scatter3d", mode: "lines", x: x, y: loop.y[e], z: loop.z[e],
               line: {{color: colours[g], width: 4}}, name: "group " + g + ": " + groupNames[g],
               legendgroup: "g" + g, showlegend: e === loop.groups.indexOf(g)}};
    }});
    root.querySelector(".uw-score").textContent = "score " + loop.score.toFixed(2) +
      (loop.correct ? " (the clusters are the two groups)" : " (misgrouped: score 0)");
    Plotly.react(root.querySelector(".uw-plot"), traces, {{
      // room round the scene and the camera further out than plotly's default (1.25): with
      // no margin and the default eye the axis titles were cut at the box's edges (issue 67)
      margin: {{l: 10, r: 10, t: 10, b: 10}}, legend: {{x: 0, y: 1}},
      // a title as an object: plotly.js 3 drops a bare string, and the units went with it
      scene: {{xaxis: {{title: {{text: "x [m]"}}}}, yaxis: {{title: {{text: "y [m]"}}}},
               zaxis: {{title: {{text: "z [m]"}}}},
               camera: {{eye: {{x: 1.6, y: 1.6, z: 1.1}}}}}}
    }}, {{responsive: true}});
  }}
  var preset = new URLSearchParams(location.hash.slice(1));
  selects.forEach(function(s) {{
    if (preset.has(s.dataset.control)) s.value = preset.get(s.dataset.control);
    s.addEventListener("change", draw);
  }});
  draw();
}})();
</script>"""
