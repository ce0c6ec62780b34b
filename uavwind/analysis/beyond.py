"""Beyond the paper: the tables behind Exps 7-9 (noise, observations, a physics baseline).

This module owns the summaries the "Beyond the paper" pages and claim C9 read:

* :func:`noise_table` and :func:`breaking_level` -- score and share of correctly
  grouped loops against the position noise, and the level at which correct
  grouping drops below one half (Exp 7);
* :func:`observation_table` and :func:`best_observation` -- which channel separates
  which pair (Exp 8);
* :func:`future_table` and :func:`best_future` -- which action and observation of the
  multirotor separate which pair (Exp 11);
* :func:`baseline_table` -- the model-based wind estimate beside causal curiosity on
  the same loops, with a mis-specified UAV too (Exp 9).

Every summary row is :func:`uavwind.core.stats.summarise` (95% bootstrap intervals over
loops), the one summary and confidence-interval function of the project.
A "best" channel is set against its runner-up on the same loops (every case of a scenario
flies the same loops): paired differences with a bootstrap CI, and a verdict that says
"cannot decide" when that CI spans 0. Every verdict here (*best*, *drops below* half) is
the one rule's, :func:`uavwind.core.stats.decide`: none on fewer than
:data:`~uavwind.core.stats.MIN_DECIDE` loops.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ..core.checks import check_instance
from ..core.stats import (MIN_DECIDE, UNDECIDED, Decision, bootstrap_ci, decide,
                          paired_difference, summarise)

__all__ = ["noise_table", "breaking_level", "breaking_sentences", "at_noise",
           "observation_table", "best_observation", "baseline_table", "vehicle_table",
           "future_table", "best_future", "loop_differences", "baseline_advantage"]


_COLUMNS = ("mean", "ci_low", "ci_high", "max", "correct_rate", "correct_low", "correct_high",
            "n_loops")


def _summary(df, by):
    rows = []
    for key, sub in df.groupby(list(by), sort=False):
        key = key if isinstance(key, tuple) else (key,)
        s = summarise(sub)
        rows.append({**dict(zip(by, key)), **{k: s[k] for k in _COLUMNS}})
    return pd.DataFrame(rows)


def noise_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 7: per scenario, white noise sigma [m] and bias [m]: score and correct share
    with 95% intervals."""
    return _summary(df, ("scenario", "noise_sigma", "noise_bias"))


def breaking_level(df: pd.DataFrame, threshold: float = 0.5) -> pd.DataFrame:
    """Per scenario, the white-noise level [m] at which the share of correctly grouped
    loops first falls below ``threshold``: ``last_ok`` (the largest level before it),
    ``first_broken`` (NaN: never within the levels run), the shares at both, and ``decided``:
    whether the share's 95% interval lies at or above the threshold at ``last_ok`` and below
    it at ``first_broken`` by the one rule (:func:`~uavwind.core.stats.decide`: at least
    :data:`~uavwind.core.stats.MIN_DECIDE` loops a level; else these loops cannot place the
    break), and ``n_loops``, the fewest loops of the two levels."""
    t = noise_table(df)
    t = t[t["noise_bias"] == 0].sort_values(["scenario", "noise_sigma"])
    rows = []
    for scen, sub in t.groupby("scenario", sort=False):
        below = sub[sub["correct_rate"] < threshold]
        first = below["noise_sigma"].min() if len(below) else float("nan")
        ok = sub[sub["noise_sigma"] < first] if len(below) else sub
        at_ok = ok.iloc[-1] if len(ok) else None  # the rows of the two levels
        at_broken = below.iloc[0] if len(below) else None
        # does the share's 95% interval put each of the two levels on its side of the
        # threshold? (with a few loops it spans it, and the break cannot be placed)
        sides = [decide(r["correct_rate"], r["correct_low"], r["correct_high"],
                        int(r["n_loops"]), threshold=threshold, above="above", below="below")
                 for r in (at_ok, at_broken) if r is not None]
        decided = ((at_ok is None or sides[0].word == "above")
                   and (at_broken is None or sides[-1].word == "below"))
        nan = float("nan")
        rows.append({"scenario": scen,
                     "last_ok": nan if at_ok is None else float(at_ok["noise_sigma"]),
                     "first_broken": float(first),
                     "correct_rate_at_last_ok":
                         nan if at_ok is None else float(at_ok["correct_rate"]),
                     "correct_rate_at_first_broken":
                         nan if at_broken is None else float(at_broken["correct_rate"]),
                     "decided": bool(decided), "n_loops": min(int(d.n) for d in sides)})
    return pd.DataFrame(rows).set_index("scenario")


def breaking_sentences(levels: pd.DataFrame) -> dict:
    """Per scenario of ``levels`` (:func:`breaking_level`), where correct grouping breaks, in
    words: between which noise levels it drops below the threshold, or that it still holds at
    the largest level run -- a verdict only where ``decided`` (the one rule); otherwise the
    shares, and that these loops cannot place the break."""
    out = {}
    for scen, row in levels.iterrows():
        decided = bool(row.get("decided", True))
        n = int(row.get("n_loops", MIN_DECIDE))
        ok = f"{100 * row['correct_rate_at_last_ok']:.0f}%"
        if np.isnan(row["first_broken"]):
            out[scen] = (f"still groups {ok} of the loops correctly at {row['last_ok']:g} m, "
                         "the largest level run")
        elif decided:
            out[scen] = (f"drops below half between {row['last_ok']:g} m ({ok} correct) and "
                         f"{row['first_broken']:g} m "
                         f"({100 * row['correct_rate_at_first_broken']:.0f}%)")
        else:
            out[scen] = (f"groups {ok} of the loops correctly at {row['last_ok']:g} m and "
                         f"{100 * row['correct_rate_at_first_broken']:.0f}% at "
                         f"{row['first_broken']:g} m")
        if not decided:
            where = ("whether it still holds there" if np.isnan(row["first_broken"])
                     else "where it breaks")
            out[scen] += (f"{',' if np.isnan(row['first_broken']) else ''} on {n} loops a "
                          f"level: **cannot decide** {where} ("
                          + (f"a verdict needs {MIN_DECIDE} loops a level; the paper profile's "
                             "build, `make book`, runs enough to place it)" if n < MIN_DECIDE
                             else "the shares' 95% intervals reach across one half)"))
    return out


def at_noise(table: pd.DataFrame, sigma: float = 0.0, bias: float = 0.0) -> pd.DataFrame:
    """The rows of a noise table (:func:`noise_table`, :func:`baseline_table`) at white noise
    ``sigma`` [m] and bias ``bias`` [m], indexed by scenario; ``ValueError`` if none."""
    rows = table[(table["noise_sigma"] == sigma) & (table["noise_bias"] == bias)]
    if not len(rows):
        raise ValueError(f"no rows at noise_sigma = {sigma:g} m, noise_bias = {bias:g} m; the "
                         f"table has sigma {sorted(set(table['noise_sigma']))}, bias "
                         f"{sorted(set(table['noise_bias']))}")
    return rows.set_index("scenario")


def observation_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 8: per scenario, observation and noise (``none``/``consumer``)."""
    return _summary(df, ("scenario", "observation", "noise"))


def loop_differences(sub: pd.DataFrame, rows: pd.DataFrame, keys: tuple[str, ...],
                     references: Mapping[str, tuple] | None = None, value: str = "score"):
    """The case of ``sub`` (one row per value of ``keys`` with its ``mean``: the cases of one
    scenario and noise level) with the highest mean, the runner-up, and the loop-by-loop
    differences of ``value`` in ``rows`` between the best and each of them: every case of a
    scenario flies the same loops (common random numbers), so they are compared by paired
    differences.

    Returns ``(best, runner_up, differences)``: the two rows of ``sub`` (``runner_up`` None
    when ``sub`` has one case) and a dict from ``"runner_up"`` and each label of
    ``references`` (label -> the reference's values of ``keys``, a tuple) to the differences
    over the loops both ran; a reference that was not run has no entry. Ties keep the order
    of ``sub``. Exps 8 and 11 decide their best channel on it
    (:func:`best_observation`, :func:`best_future`) and Exp 11 is sized on it
    (:func:`uavwind.analysis.tables.paired_spread`)."""
    ranked = sub.sort_values("mean", ascending=False, kind="stable")
    best = ranked.iloc[0]
    if len(ranked) < 2:
        return best, None, {}
    second = ranked.iloc[1]
    several = len(keys) > 1
    loops = rows.pivot_table(index="loop", columns=list(keys) if several else keys[0],
                             values=value)
    mine, other = (tuple(r[k] for k in keys) if several else r[keys[0]] for r in (best, second))
    others = {"runner_up": other} | {label: ref if several else ref[0]
                                     for label, ref in (references or {}).items()}
    return best, second, {label: (loops[mine] - loops[o]).dropna()
                          for label, o in others.items() if o in loops}


def _decide_best(sub: pd.DataFrame, rows: pd.DataFrame, keys: tuple[str, ...],
                 references: Mapping[str, tuple] | None = None) -> dict:
    """The case of ``sub`` with the highest mean, set against the runner-up (``runner_up_*``)
    and each of ``references`` (``<label>_*``) by the mean of their loop-by-loop differences
    with a 95% bootstrap CI (:func:`loop_differences`; NaN for a reference not run).
    ``verdict`` (the one rule, :func:`~uavwind.core.stats.decide`): ``"best"`` when the CI
    against the runner-up lies above 0, ``"tied"`` when the two score the same on every loop,
    ``"cannot decide"`` otherwise or with fewer than :data:`~uavwind.core.stats.MIN_DECIDE`
    loops."""
    best, second, diffs = loop_differences(sub, rows, keys, references)
    out = {k: best[k] for k in keys}
    out.update({c: best[c] for c in ("mean", "ci_low", "ci_high", "correct_rate")})
    if second is None:
        return out
    out.update({"runner_up": ", ".join(str(second[k]).replace("_", " ") for k in keys),
                "runner_up_mean": second["mean"]})
    for label in ("runner_up", *(references or {})):
        d = diffs.get(label, pd.Series(dtype=float)).to_numpy()
        est = paired_difference(d, np.zeros_like(d)) if d.size else (np.nan,) * 3
        out.update(dict(zip((f"{label}_diff", f"{label}_low", f"{label}_high"), est)))
    d = diffs["runner_up"]
    out["n_loops"] = int(d.size)
    out["verdict"] = decide(out["runner_up_diff"], out["runner_up_low"], out["runner_up_high"],
                            int(d.size), above="best", below=UNDECIDED, within="tied").word
    return out


def _check_rows(results, columns) -> pd.DataFrame:
    results = check_instance(results, "results", pd.DataFrame)
    missing = set(columns) - set(results)
    if missing:
        raise ValueError(f"results must hold one row per loop; missing columns {sorted(missing)}")
    return results


def best_observation(df: pd.DataFrame, noise: str = "none") -> pd.DataFrame:
    """Per scenario, the observation with the highest mean score under ``noise``, set
    against the runner-up on the same loops (``runner_up``, ``runner_up_diff`` with its 95%
    CI ``runner_up_low``/``runner_up_high``, ``n_loops`` and ``verdict``: ``"best"``,
    ``"tied"`` or ``"cannot decide"``, see :func:`best_future`)."""
    df = _check_rows(df, ("scenario", "observation", "noise", "loop", "score"))
    t = observation_table(df)
    t = t[t["noise"] == noise]
    if t.empty:
        raise ValueError(f"noise must be one of {sorted(df['noise'].unique())}, got {noise!r}")
    rows = df[df["noise"] == noise]
    out = [{"scenario": scen, **_decide_best(sub, rows[rows["scenario"] == scen],
                                             ("observation",))}
           for scen, sub in t.groupby("scenario", sort=False)]
    return pd.DataFrame(out).set_index("scenario")


def vehicle_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 10: per scenario, vehicle (and noise), score and correct share with 95% intervals, and for
    the multirotor the mean share of control steps in which its tilt limit and its motor
    limits bound (``tilt_limited``, ``motor_limited``; NaN for the point mass)."""
    keys = [k for k in ("scenario_id", "scenario", "vehicle", "noise") if k in df.columns]
    out = _summary(df, tuple(keys))
    for col in ("tilt_limited", "motor_limited"):
        if col in df.columns:
            means = df.groupby(keys, sort=False)[col].mean()
            out[col] = [means.get(tuple(k), np.nan) for k in
                        out[keys].itertuples(index=False)]
    return out


def future_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 11: per scenario, action, observation and noise, score and correct share with 95%
    intervals."""
    return _summary(df, ("scenario", "action", "observation", "noise"))


def best_future(table: pd.DataFrame, noise: str = "none",
                results: pd.DataFrame | None = None) -> pd.DataFrame:
    """Per scenario, the action and observation with the highest mean score under ``noise``
    (from :func:`future_table`), and the paper's choice (thrust actions, position) beside it.

    With ``results`` (Exp 11's rows), each ranking is also decided on the loops: every case
    of a scenario flies the same loops (common random numbers), so the best is set against
    the runner-up and against the paper's choice by the mean of their loop-by-loop score
    differences with a 95% bootstrap CI (``runner_up_*`` and ``position_thrust_*``:
    ``_diff``, ``_low``, ``_high``; :func:`uavwind.core.stats.paired_difference`), and
    ``verdict`` says ``"best"`` when the CI against the runner-up lies above 0, ``"tied"``
    when the two score the same on every loop, and ``"cannot decide"`` otherwise (or with
    fewer than two loops)."""
    t = table[table["noise"] == noise]
    if t.empty:
        raise ValueError(f"noise must be one of {sorted(table['noise'].unique())}, got {noise!r}")
    if results is not None:
        results = _check_rows(results, ("scenario", "action", "observation", "noise", "loop",
                                        "score"))
        results = results[results["noise"] == noise]
    out = []
    for scen, sub in t.groupby("scenario", sort=False):
        pos = sub[(sub["observation"] == "position") & (sub["action"] == "thrust")]
        if results is None:
            top = sub.sort_values("mean", ascending=False, kind="stable").iloc[0]
            row = {k: top[k] for k in ("action", "observation", "mean", "ci_low", "ci_high",
                                       "correct_rate")}
        else:
            row = _decide_best(sub, results[results["scenario"] == scen],
                               ("action", "observation"),
                               references={"position_thrust": ("thrust", "position")})
        row["position_thrust_mean"] = float(pos["mean"].iloc[0]) if len(pos) else np.nan
        out.append({"scenario": scen, **row})
    return pd.DataFrame(out).set_index("scenario")


def baseline_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 9: per scenario and noise, the baseline's wind RMSE [m/s] and grouping
    accuracy beside the causal-curiosity score and correct share on the same loops,
    and the baseline with 20% too much mass or drag coefficient."""
    rows = []
    for key, sub in df.groupby(["scenario", "noise_sigma", "noise_bias"], sort=False):
        rmse, rlo, rhi = bootstrap_ci(sub["baseline_rmse"].to_numpy())
        row = dict(zip(("scenario", "noise_sigma", "noise_bias"), key))
        row.update({"rmse": rmse, "rmse_low": rlo, "rmse_high": rhi,
                    "baseline_correct_rate": float(sub["baseline_correct"].mean()),
                    "cc_correct_rate": float(sub["correct"].mean()),
                    "cc_mean": float(sub["score"].mean()),
                    "rmse_mass+20%": float(sub["baseline_rmse_mass"].mean()),
                    "correct_rate_mass+20%": float(sub["baseline_correct_mass"].mean()),
                    "rmse_drag+20%": float(sub["baseline_rmse_drag"].mean()),
                    "correct_rate_drag+20%": float(sub["baseline_correct_drag"].mean()),
                    "n_loops": len(sub)})
        rows.append(row)
    return pd.DataFrame(rows)


def baseline_advantage(df: pd.DataFrame, scenario: str, sigma: float = 0.0,
                       bias: float = 0.0) -> Decision:
    """Exp 9: does the model-based baseline group more loops correctly than causal curiosity
    on ``scenario`` at white noise ``sigma`` [m] and bias ``bias`` [m]? Both read the same
    loops, so the per-loop difference ``baseline_correct - correct`` (in percentage points)
    is decided by the one rule (:func:`~uavwind.core.stats.decide`): ``"more"``, ``"fewer"``,
    ``"as many"`` (every loop alike) or ``"cannot decide"``."""
    df = _check_rows(df, ("scenario", "noise_sigma", "noise_bias", "loop", "correct",
                          "baseline_correct"))
    sub = df[(df["scenario"] == scenario) & (df["noise_sigma"] == sigma)
             & (df["noise_bias"] == bias)].sort_values("loop")
    if not len(sub):
        raise ValueError(f"no loops of {scenario!r} at noise_sigma = {sigma:g} m, "
                         f"noise_bias = {bias:g} m")
    d = 100 * (sub["baseline_correct"].to_numpy(float) - sub["correct"].to_numpy(float))
    return decide(*bootstrap_ci(d), d.size, above="more", below="fewer", within="as many")
