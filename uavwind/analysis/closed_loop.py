"""Experiment 12's tables: how fast, how surely, and with which manoeuvres one vehicle
identifies its wind.

This module owns the summaries of closed-loop episodes (rows of
:func:`uavwind.method.closed_loop.run_episodes`, one per episode, policy and reported
belief):

* :func:`accuracy_over_time` -- accuracy and mean log-loss against flight time, with 95%
  bootstrap intervals over episodes;
* :func:`accuracy_table` -- the accuracy at a few flight times, one row per scenario,
  vehicle and policy (the page's headline table);
* :func:`time_to_confidence` -- when the belief first reaches 95% on some group, how often
  it does within the flight, and how often it is then right;
* :func:`reliability` and :func:`calibration_error` -- the reliability diagram: reported
  probability against observed frequency;
* :func:`closing_the_loop` -- paired differences between policies at each time (every
  policy met the same test environments under the same noise draws);
* :func:`manoeuvres` -- what each policy flew, segment by segment.

Intervals are :func:`uavwind.core.stats.bootstrap_ci` and
:func:`~uavwind.core.stats.paired_difference`, the project's one interval.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from ..core.stats import bootstrap_ci, paired_difference

__all__ = ["accuracy_over_time", "accuracy_table", "time_to_confidence", "reliability",
           "calibration_error", "closing_the_loop", "manoeuvres", "POLICY_NAMES", "CASE"]

#: The policies' display names, in the order the pages show them.
POLICY_NAMES = {"random": "open-loop random", "best": "open-loop best",
                "greedy": "closed-loop greedy", "receding": "closed-loop receding CEM"}
#: The labels that name one case of Exp 12.
CASE = ("scenario", "vehicle")


def _by(df, extra=()):
    return [c for c in (*CASE, "policy", *extra) if c in df.columns]


def _ordered(out):
    if "policy" in out.columns:
        order = {k: i for i, k in enumerate(POLICY_NAMES)}
        out = out.sort_values([c for c in (*CASE,) if c in out.columns] + ["policy"],
                              key=lambda s: s.map(order) if s.name == "policy" else s,
                              kind="stable")
    return out.reset_index(drop=True)


def accuracy_over_time(df: pd.DataFrame) -> pd.DataFrame:
    """Per case, policy and reported time [s]: ``accuracy`` (share of episodes whose more
    probable group is the true one) and ``log_loss`` (mean ``-log P(true group)`` [nats]),
    each with its 95% bootstrap interval over episodes, and ``n_episodes``."""
    rows = []
    for key, sub in df.groupby(_by(df, ("time",)), sort=False):
        sub = sub.sort_values("episode", kind="stable")
        acc = bootstrap_ci(sub["correct"].to_numpy(dtype=float))
        ll = bootstrap_ci(sub["log_loss"].to_numpy(dtype=float))
        rows.append({**dict(zip(_by(df, ("time",)), key)), "accuracy": acc[0],
                     "accuracy_low": acc[1], "accuracy_high": acc[2], "log_loss": ll[0],
                     "log_loss_low": ll[1], "log_loss_high": ll[2], "n_episodes": len(sub)})
    return _ordered(pd.DataFrame(rows))


def accuracy_table(df: pd.DataFrame, times: Sequence[float] = (1.0, 2.0, 4.0, 8.0, 12.0),
                   ) -> pd.DataFrame:
    """Accuracy [%] at each of ``times`` [s], one row per case and policy (the display
    name of the policy), with the number of episodes."""
    t = accuracy_over_time(df[df["time"].isin(times)])
    wide = t.pivot_table(index=_by(t), columns="time", values="accuracy", sort=False) * 100
    wide.columns = [f"{c:g} s" for c in wide.columns]
    wide["episodes"] = t.groupby(_by(t), sort=False)["n_episodes"].first()
    wide = _ordered(wide.reset_index())
    wide["policy"] = wide["policy"].map(POLICY_NAMES)
    return wide


def _first_confident(sub, level):
    sure = np.maximum(sub["p_group_b"], 1.0 - sub["p_group_b"]) >= level
    hits = sub[sure.to_numpy()]
    if hits.empty:
        return np.inf, False
    first = hits.iloc[0]
    return float(first["time"]), bool(first["correct"])


def time_to_confidence(df: pd.DataFrame, level: float = 0.95) -> pd.DataFrame:
    """Per case and policy: ``median_time`` [s] at which the belief first gives one group
    ``level`` (episodes that never do count as later than the flight: ``inf`` if half of
    them never do), ``reached`` (share of episodes that do within the flight), and
    ``right_when_reached`` (share of those whose confident group was the true one)."""
    rows = []
    for key, sub in df.groupby(_by(df), sort=False):
        firsts = [_first_confident(e.sort_values("time"), level)
                  for _, e in sub.groupby("episode", sort=True)]
        t = np.array([f[0] for f in firsts])
        ok = np.array([f[1] for f in firsts])
        reached = np.isfinite(t)
        rows.append({**dict(zip(_by(df), key)), "median_time": float(np.median(t)),
                     "reached": float(reached.mean()),
                     "right_when_reached": float(ok[reached].mean()) if reached.any()
                     else float("nan"), "n_episodes": len(firsts)})
    return _ordered(pd.DataFrame(rows))


def reliability(df: pd.DataFrame, bins: int = 10, by: Sequence[str] = ()) -> pd.DataFrame:
    """The reliability diagram: reported ``P(group 1)`` in ``bins`` equal bins, per
    ``by``: ``predicted`` (mean reported probability), ``observed`` (share of those
    reports made in group 1's environments) and ``count`` (reports, over every time)."""
    p = df["p_group_b"].to_numpy(dtype=float)
    b = np.clip((p * bins).astype(int), 0, bins - 1)
    d = df.assign(bin=b, is_b=(df["test_group"] == 1).astype(float))
    g = d.groupby([*by, "bin"], sort=True)
    out = g.agg(predicted=("p_group_b", "mean"), observed=("is_b", "mean"),
                count=("p_group_b", "size")).reset_index()
    out["bin_low"] = out["bin"] / bins
    out["bin_high"] = (out["bin"] + 1) / bins
    return out


def calibration_error(df: pd.DataFrame, bins: int = 10) -> float:
    """Expected calibration error: the count-weighted mean ``|observed - predicted|`` of
    :func:`reliability` (0: perfectly calibrated)."""
    r = reliability(df, bins)
    return float(np.sum(r["count"] * np.abs(r["observed"] - r["predicted"])) / r["count"].sum())


def closing_the_loop(df: pd.DataFrame, pairs: Sequence[tuple[str, str]] = (
        ("best", "random"), ("greedy", "best"), ("receding", "best")),
        times: Sequence[float] = (1.0, 2.0, 4.0, 8.0, 12.0)) -> pd.DataFrame:
    """Per case, pair ``(a, b)`` of policies and time: the mean difference ``a - b`` of
    accuracy [points] and of log-loss [nats] over episodes flown by both (the same test
    environment, the same noise draws), with 95% bootstrap intervals."""
    rows = []
    for key, sub in df[df["time"].isin(times)].groupby([*CASE, "time"], sort=False):
        for a, b in pairs:
            xa = sub[sub["policy"] == a].sort_values("episode", kind="stable")
            xb = sub[sub["policy"] == b].sort_values("episode", kind="stable")
            if xa.empty or xb.empty:
                continue
            if not np.array_equal(xa["episode"].to_numpy(), xb["episode"].to_numpy()):
                raise ValueError(f"policies {a!r} and {b!r} flew different episodes")
            acc = paired_difference(xa["correct"].to_numpy(dtype=float) * 100,
                                    xb["correct"].to_numpy(dtype=float) * 100)
            ll = paired_difference(xa["log_loss"].to_numpy(dtype=float),
                                   xb["log_loss"].to_numpy(dtype=float))
            rows.append({**dict(zip((*CASE, "time"), key)), "comparison": f"{a} - {b}",
                         "accuracy_diff": acc[0], "accuracy_low": acc[1],
                         "accuracy_high": acc[2], "log_loss_diff": ll[0], "log_loss_low": ll[1],
                         "log_loss_high": ll[2]})
    return pd.DataFrame(rows)


def manoeuvres(df: pd.DataFrame) -> pd.DataFrame:
    """What each policy flew: per case, policy and segment, the mean thrust [N] along x,
    y and z over episodes, and ``climb`` (share of episodes whose thrust that segment
    exceeds the point mass's weight along z, 2 kg x 9.81 m/s^2: the vehicle climbs)."""
    seg = df.groupby([*_by(df), "episode", "segment"], sort=False)["thrust"].apply(
        lambda t: np.mean(np.stack([np.asarray(x, dtype=float) for x in t]), axis=0))
    seg = seg.reset_index()
    f = np.stack(seg["thrust"].to_numpy())
    seg = seg.assign(thrust_x=f[:, 0], thrust_y=f[:, 1], thrust_z=f[:, 2],
                     climb=(f[:, 2] > 2.0 * 9.81).astype(float))
    out = seg.groupby([*_by(df), "segment"], sort=False)[
        ["thrust_x", "thrust_y", "thrust_z", "climb"]].mean().reset_index()
    return _ordered(out)
