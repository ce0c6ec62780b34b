"""The interactive "Explore" page: one loop, live, from a few sliders.

This module owns :func:`explore_loop` (build a setting from plain choices, fly
one random thrust sequence, score it, draw it) and :func:`explorer` (the
ipywidgets interface around it). The static book shows the default state.
"""

from __future__ import annotations

import numpy as np

from .clustering import score_loop
from .plotting import fig3_loop
from .scenarios import make_setting

__all__ = ["explore_loop", "explorer"]


def explore_loop(condition_a="light constant", condition_b="strong shear", n_per_group=5,
                 thrust_seed=0, n_changes=6, engine=None):
    """Fly one random thrust sequence through two generated groups and score it.

    Returns ``(figure, LoopResult, setting, thrust)``.
    """
    setting = make_setting(condition_a, condition_b, n_per_group, n_changes=n_changes)
    thrust = setting.sample_thrust(np.random.default_rng(thrust_seed))
    traj = setting.simulate(thrust, seed=thrust_seed)
    res = score_loop(traj, setting.groups, engine=engine)
    fig = fig3_loop(traj, setting.groups, [res.score],
                    group_labels=(condition_a, condition_b),
                    title=f"score {res.score:.2f} ({'correct' if res.correct else 'misgrouped'})")
    fig.axes[1].set_visible(False)
    return fig, res, setting, thrust


def explorer():
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
