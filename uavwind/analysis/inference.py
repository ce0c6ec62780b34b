"""What the paper's own numbers reveal: its unstated setup, recovered and tested.

This module owns the inference behind the ``"inferred"`` reading
(:data:`uavwind.study.readings.READINGS`) and the book page "What the paper's numbers
reveal":

* :func:`fit_layouts` -- for each same-strength scenario of Table 2, the gap between
  the two groups (in within-group spacings, the lattice of Table 3) that gives
  Table 4's mean score, fitted by simulation with the real clustering on a grid of
  ratios (the ``fit_layout`` experiment), with a bootstrap over loops;
* :func:`compare_turbulence` -- which reading of the cited Dryden implementation
  (:data:`TURBULENCE_CANDIDATES`) gives Table 4's light constant vs strong turbulence
  row (the ``fit_turbulence`` experiment);
* :func:`out_of_sample` -- Tables 5, 6, 7 and the 500-loop row, which the fit never
  saw, predicted under the inferred reading and set beside the paper;
* :func:`scale_invariance` -- the fact the fit rests on: under eqs 2-8 a constant
  wind adds ``w t`` to the still-air trajectory, so scaling every wind of a constant
  layout leaves the silhouette (nearly) unchanged.

Why a one-number fit can work: under a constant wind the trajectory is the
still-air trajectory plus ``w t``, and under a shear wind it is the still-air
trajectory plus ``U_ref F(t)`` with ``F`` set by the thrust alone (the wind is
horizontal and the air-relative motion does not depend on it). The differences
between the trajectories of a pair of groups are then proportional to the
differences of their wind vectors, so the silhouette depends on the layout's
geometry -- here the gap-to-spacing ratio -- and hardly on the wind strength.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core.checks import check_instance, check_scalar
from ..core.stats import N_BOOT, SEED, correct_share, summarise
from ..method.search import random_search
from ..sim.setting import Setting
from ..study.conditions import PAPER_SCENARIOS
from ..study.layouts import INFERRED_GAP_RATIOS
from ..study.paper import load_paper_values
from ..study.readings import INFERRED_TURBULENCE, TURBULENCE_CANDIDATES
from ..study.registry import EXPERIMENTS
from .tables import comparison_table

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["TURBULENCE_CANDIDATES", "fit_ratio", "fit_layouts", "check_fits", "score_matrix",
           "silhouette_curves", "compare_turbulence", "check_turbulence", "rival", "out_of_sample",
           "miss_reasons", "CLOSE", "compare_mixed", "closer_mixed", "scale_invariance", "scaled_setting", "line_silhouette"]


def _paper_table4():
    """Table 4's rows by scenario id (the 500-loop row left out)."""
    t4 = load_paper_values("exp1")
    return t4[~t4["long_run"]].set_index("scenario_id")


def fit_ratio(ratios: ArrayLike, scores: ArrayLike, target: float) -> float:
    """The gap ratio at which the mean score reaches ``target``.

    Parameters
    ----------
    ratios : array_like, shape (n_ratio,)
        Increasing gap ratios of the grid (> 0).
    scores : array_like, shape (n_ratio, n_loops)
        Scores of the same loops (thrust sequences) at every ratio.
    target : float
        The paper's mean score.

    Returns
    -------
    float
        Interpolated in log-ratio on the mean curve made non-decreasing (a running
        maximum: a wider gap never makes separation harder); ``inf`` when the target
        lies above the curve, the first ratio when it lies below.

    >>> fit_ratio([1, 4], [[50.0], [70.0]], 60.0)
    2.0
    """
    r = np.asarray(ratios, dtype=float)
    sc = np.asarray(scores, dtype=float)
    if (r.ndim != 1 or sc.shape[0] != r.size or r.size < 2 or not np.all(np.isfinite(r))
            or np.any(np.diff(r) <= 0) or r[0] <= 0):
        raise ValueError("ratios must be an increasing 1-D grid of finite values > 0 with one "
                         f"row of scores each; got ratios {r.shape}, scores {sc.shape}")
    if sc.size == 0 or not np.all(np.isfinite(sc)):
        raise ValueError("scores must be finite (a NaN or inf score has no place on the "
                         "curve), with at least one loop per ratio")
    target = check_scalar(target, "target")
    curve = np.maximum.accumulate(sc.reshape(r.size, -1).mean(axis=1))
    if target > curve[-1]:
        return float("inf")
    if target <= curve[0]:
        return float(r[0])
    j = int(np.argmax(curve >= target))
    lo, hi = np.log(r[j - 1]), np.log(r[j])
    c0, c1 = curve[j - 1], curve[j]
    w = 0.0 if c1 == c0 else (target - c0) / (c1 - c0)
    return float(np.exp(lo + w * (hi - lo)))


def silhouette_curves(fit_results: pd.DataFrame) -> pd.DataFrame:
    """Mean, max and correct share of the score per scenario and gap ratio."""
    keys = ["scenario_id", "scenario", "gap_ratio"]
    g = fit_results.groupby(keys)["score"]
    rate = fit_results.groupby(keys)[["score", "correct"]].apply(correct_share)
    return pd.DataFrame({"mean": g.mean(), "max": g.max(), "correct_rate": rate,
                         "n_loops": g.size()}).reset_index()


def score_matrix(sub: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """``(ratios, scores)`` of one scenario's fit results: the gap ratios in increasing
    order, shape (n_ratio,), and the score of every loop at every ratio, shape
    (n_ratio, n_loops) (the input of :func:`fit_ratio`)."""
    wide = sub.pivot_table(index="gap_ratio", columns="loop", values="score")
    return wide.index.to_numpy(dtype=float), wide.to_numpy()


def fit_layouts(fit_results: pd.DataFrame, n_boot: int = N_BOOT,
                seed: int = SEED) -> pd.DataFrame:
    """Fitted gap ratio of each same-strength scenario, from Table 4's mean alone.

    Parameters
    ----------
    fit_results : pandas.DataFrame
        ``run_experiment("fit_layout", ...)``: one row per loop and gap ratio.

    Returns
    -------
    pandas.DataFrame
        One row per scenario: ``paper_mean``, ``ratio`` (fitted), ``ci_low``,
        ``ci_high`` (95% percentile bootstrap over loops; ``inf`` = above the grid),
        ``in_use`` (:data:`~uavwind.study.layouts.INFERRED_GAP_RATIOS`), ``in_ci`` and
        ``n_loops``.
    """
    paper = _paper_table4()
    rows = []
    for k, sub in fit_results.groupby("scenario_id", sort=True):
        rng = np.random.default_rng([seed, int(k)])  # one stream per scenario
        ratios, sc = score_matrix(sub)
        target = float(paper.loc[k, "mean"])
        est = fit_ratio(ratios, sc, target)
        boots = [fit_ratio(ratios, sc[:, rng.integers(0, sc.shape[1], sc.shape[1])], target)
                 for _ in range(n_boot)]
        # no interpolation between bootstrap values: some may be inf (above the grid)
        lo, hi = np.quantile(boots, [0.025, 0.975], method="inverted_cdf")
        a, _ = PAPER_SCENARIOS[int(k)]
        in_use = INFERRED_GAP_RATIOS[a.label]
        rows.append({"scenario_id": int(k), "scenario": sub["scenario"].iloc[0],
                     "paper_mean": target, "paper_max": float(paper.loc[k, "maximum"]),
                     "ratio": est, "ci_low": float(lo), "ci_high": float(hi),
                     "in_use": in_use, "in_ci": bool(lo <= in_use <= hi),
                     "n_loops": sc.shape[1]})
    return pd.DataFrame(rows).set_index("scenario_id")


def check_fits(fits: pd.DataFrame) -> pd.DataFrame:
    """``fits`` (:func:`fit_layouts`) if every gap ratio in use lies inside its refit's 95%
    interval, else a ``ValueError`` naming the scenarios whose constant left it: the
    inferred reading's constants (:data:`~uavwind.study.layouts.INFERRED_GAP_RATIOS`) must
    agree with the fit they came from."""
    bad = fits[~fits["in_ci"]]
    if len(bad):
        rows = "; ".join(f"scenario {k} ({r['scenario']}): in use {r['in_use']:g}, refit "
                         f"{r['ratio']:.3g} [{r['ci_low']:.3g}, {r['ci_high']:.3g}]"
                         for k, r in bad.iterrows())
        raise ValueError(f"INFERRED_GAP_RATIOS left their fit's 95% interval: {rows}")
    return fits


def compare_turbulence(turb_results: pd.DataFrame) -> pd.DataFrame:
    """Each turbulence candidate's score on scenario 7 beside Table 4 (93.59 / 92.44).

    Returns one row per candidate with ``mean`` (and its bootstrap ``ci_low``,
    ``ci_high``), ``max``, ``correct_rate``, the paper's values, ``distance`` (the
    larger of the distances to the paper's mean and max) and ``in_use`` (the
    candidate the inferred reading uses), sorted by distance.
    """
    paper = _paper_table4().loc[7]
    rows = []
    for name, sub in turb_results.groupby("candidate", sort=False):
        s = summarise(sub)
        rows.append({"candidate": name, "mean": s["mean"], "ci_low": s["ci_low"],
                     "ci_high": s["ci_high"], "max": s["max"], "correct_rate": s["correct_rate"],
                     "paper_mean": float(paper["mean"]), "paper_max": float(paper["maximum"]),
                     "distance": max(abs(s["mean"] - paper["mean"]),
                                     abs(s["max"] - paper["maximum"])),
                     "in_use": TURBULENCE_CANDIDATES.get(name) == INFERRED_TURBULENCE,
                     "n_loops": s["n_loops"]})
    return pd.DataFrame(rows).sort_values("distance").set_index("candidate")


def check_turbulence(turbulence: pd.DataFrame) -> str:
    """The candidate the inferred reading uses (:data:`~uavwind.study.readings.INFERRED_TURBULENCE`),
    if it is the closest of ``turbulence`` (:func:`compare_turbulence`) to Table 4 or
    indistinguishable from the closest (its mean inside the closest candidate's 95%
    interval); else a ``ValueError`` naming both."""
    best = turbulence.index[0]
    used = turbulence.index[turbulence["in_use"]]
    if len(used) != 1:
        raise ValueError(f"exactly one candidate must be in use, got {list(used)}")
    u = turbulence.loc[used[0]]
    b = turbulence.loc[best]
    if used[0] != best and not b["ci_low"] <= u["mean"] <= b["ci_high"]:
        raise ValueError(f"the inferred reading uses {used[0]!r} (mean {u['mean']:.2f}), but the "
                         f"closest candidate to Table 4 is {best!r} (mean {b['mean']:.2f}, 95% "
                         f"interval [{b['ci_low']:.2f}, {b['ci_high']:.2f}])")
    return used[0]


def rival(turbulence: pd.DataFrame) -> str:
    """The candidate the one in use is measured against: the closest of ``turbulence``
    (:func:`compare_turbulence`, sorted by distance) other than the one in use. That is the
    closest candidate when the reading flies another one, and the runner-up when it flies the
    closest; never the candidate in use itself, so a page cannot name a reading its own
    runner-up."""
    others = turbulence.index[~turbulence["in_use"].astype(bool)]
    if len(others) == 0:
        raise ValueError("no candidate besides the one in use to compare it with")
    return str(others[0])


def compare_mixed(mixed_results: pd.DataFrame) -> pd.DataFrame:
    """Table 4's mixed-strength rows (S2, S5) under each spacing and placement of
    ``fit_mixed``: ``mean`` (CI), ``max``, ``correct_rate``, the paper's values and
    ``distance`` (the larger of the distances to the paper's mean and max); indexed by
    scenario id, spacing and placement."""
    paper = _paper_table4()
    rows = []
    keys = ["scenario_id", "spacing", "placement"]
    for (k, spacing, place), sub in mixed_results.groupby(keys, sort=False):
        s = summarise(sub)
        p = paper.loc[int(k)]
        rows.append({"scenario_id": int(k), "spacing": spacing, "placement": place,
                     "scenario": sub["scenario"].iloc[0], "mean": s["mean"],
                     "ci_low": s["ci_low"], "ci_high": s["ci_high"], "max": s["max"],
                     "correct_rate": s["correct_rate"], "paper_mean": float(p["mean"]),
                     "paper_max": float(p["maximum"]),
                     "distance": max(abs(s["mean"] - p["mean"]), abs(s["max"] - p["maximum"])),
                     "n_loops": s["n_loops"]})
    return pd.DataFrame(rows).set_index(keys)


def closer_mixed(mixed: pd.DataFrame) -> tuple[str, pd.Series]:
    """``(spacing, totals)``: which reading of Table 3's spacing lands closer to Table 4 at
    the centre placement, by ``distance`` summed over S2 and S5, and both sums. The inferred
    reading uses :data:`~uavwind.study.layouts.TABLE3_SPACING` (``"per axis"``), chosen at
    the paper profile's 20 loops per setting; with far fewer loops the two sums differ by
    less than their noise and either can come out closer."""
    centre = mixed.xs("centre", level="placement")
    total = centre.groupby(level="spacing")["distance"].sum()
    return str(total.idxmin()), total


#: Out-of-sample rows within this many score points of the paper's mean count as close.
CLOSE = 3.0


def miss_reasons(oos: pd.DataFrame, close: float = CLOSE) -> pd.DataFrame:
    """The rows of ``oos`` (:func:`out_of_sample`) further than ``close`` points from the
    paper's mean, with ``why``: the rule that explains them. A row whose loops are mostly
    grouped wrongly (``correct_rate`` < 0.5) is the clustering's doing, not the geometry's
    (inside each group the environments spread wider than the gap between the groups, and
    the k-means++ start falls into another partition); otherwise it is a residual of the
    layout, and ``geometry_alone`` says how much the speeds as points on a line predict."""
    misses = oos[(oos["mean_difference"].abs() > close)].copy()
    why = []
    for _, m in misses.iterrows():
        if m["correct_rate"] < 0.5:
            why.append("the clustering, not the geometry: the layout's speeds as points on a "
                       f"line score {m['geometry_alone']:.1f}, but soft-DTW k-means groups "
                       f"{100 * m['correct_rate']:.0f}% of the loops correctly, because inside "
                       "each group the environments now spread wider than the gap between the "
                       "groups and the k-means++ start falls into another partition")
        else:
            why.append(f"a residual of the layout: geometry alone gives "
                       f"{m['geometry_alone']:.1f}")
    misses["why"] = why
    return misses


def out_of_sample(results: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """The rows the fit never saw, predicted under the inferred reading, beside the paper.

    Parameters
    ----------
    results : dict
        Experiment id -> results under the inferred reading, with ``"exp1"``
        (for its 500-loop row), ``"exp2"``, ``"exp3"``, ``"exp4"``.

    Returns
    -------
    pandas.DataFrame
        One row per paper row: ``paper_mean``, ``mean`` (predicted) with
        ``ci_low``/``ci_high``, ``paper_max``, ``max``, ``mean_difference`` (predicted
        minus paper mean), ``max_difference`` (predicted minus paper maximum: each beside
        the quantity it is the difference of), ``paper_in_ci`` (the paper's mean inside the
        prediction's 95% interval), ``correct_rate``, ``pair`` (``"mixed"`` strengths or
        ``"same strength"``) and ``geometry_alone``
        (:func:`line_silhouette` x 100: the score the layout's speeds would get as
        points on a line).
    """
    tables = {"exp1": "Table 4 (500 loops)", "exp2": "Table 5", "exp3": "Table 6",
              "exp4": "Table 7"}
    frames = []
    for exp, label in tables.items():
        if exp not in results:
            continue
        df = results[exp]
        if exp == "exp1":
            df = df[df["long_run"]]
        c = comparison_table(df).reset_index()
        cases = EXPERIMENTS[exp].cases(df["reading"].iloc[0])
        geometry = [line_silhouette(cases[int(k)].setting) for k in c["case"]]
        mixed = [_strength(cases[int(k)].setting.group_a) != _strength(
            cases[int(k)].setting.group_b) for k in c["case"]]
        frames.append(pd.DataFrame({
            "table": label, "row": c["row"], "paper_mean": c["paper_mean"], "mean": c["mean"],
            "ci_low": c["ci_low"], "ci_high": c["ci_high"], "paper_max": c["paper_max"],
            "max": c["max"], "mean_difference": c["mean"] - c["paper_mean"],
            "max_difference": c["max"] - c["paper_max"],
            "paper_in_ci": (c["ci_low"] <= c["paper_mean"]) & (c["paper_mean"] <= c["ci_high"]),
            "correct_rate": c["correct_rate"],
            "geometry_alone": [100 * g for g in geometry],
            "pair": ["mixed" if m else "same strength" for m in mixed],
            "n_loops": c["n_loops"]}))
    return pd.concat(frames, ignore_index=True).set_index(["table", "row"])


def _strength(group):
    return group.label.split()[0] if group.label else ""


def line_silhouette(setting: Setting) -> float:
    """Silhouette of the setting's wind speeds as points on a line, grouped as the setting
    groups them: what the layout's geometry alone predicts for a constant pair (NaN for
    turbulence, whose environments are not points on a line)."""
    from sklearn.metrics import silhouette_score

    if setting.has_turbulence:
        return float("nan")
    v = np.concatenate([np.array(setting.group_a.values), np.array(setting.group_b.values)])
    d = np.array(setting.group_a.values).sum(axis=0)  # one axis for both groups
    d = d / np.linalg.norm(d) if np.linalg.norm(d) > 0 else np.array([1.0, 0.0, 0.0])
    return float(silhouette_score((v @ d)[:, None], setting.groups))


def scaled_setting(setting: Setting, factor: float) -> Setting:
    """``setting`` with every constant and shear wind velocity multiplied by ``factor``."""
    from dataclasses import replace

    def scale(g):
        if g.kind == "turbulence":
            raise ValueError("scaled_setting scales constant and shear groups only")
        return replace(g, values=tuple(tuple(factor * x for x in v) for v in g.values))
    check_instance(setting, "setting", Setting)
    return replace(setting, group_a=scale(setting.group_a), group_b=scale(setting.group_b))


def scale_invariance(setting: Setting, factor: float = 10.0, n_loops: int = 20,
                     seed: int | np.random.SeedSequence | None = 0, engine: str | None = None,
                     n_jobs: int | None = 1) -> pd.DataFrame:
    """Silhouettes of the same loops on ``setting`` and on its winds scaled by ``factor``.

    Returns a DataFrame with one row per loop: ``silhouette``, ``scaled`` and their
    ``difference`` (raw silhouettes in [-1, 1], not floored by the grouping rule).
    """
    kw = dict(n_loops=n_loops, seed=seed, engine=engine, n_jobs=n_jobs, progress=False)
    base = random_search(setting, **kw)
    big = random_search(scaled_setting(setting, factor), **kw)
    return pd.DataFrame({"loop": base["loop"], "silhouette": base["silhouette"],
                         "scaled": big["silhouette"],
                         "difference": big["silhouette"] - base["silhouette"]})
