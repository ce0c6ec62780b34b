"""Flyable manoeuvres against the paper's raw thrust on a multirotor (Exp 14, and the Exp 10
corrections).

This module owns

* :func:`flyable_table`, :func:`flyable_verdicts` and :func:`best_channels` -- Exp 14's
  summary (score and share of correctly grouped loops with 95% intervals per scenario,
  action and channel, and what the flights asked of the vehicle), a verdict per row
  ("separates", "does not separate", "cannot decide") and the best channel per scenario and
  action;
* :func:`saturation_split` -- where the paper's raw thrust saturates the motors of a hovering
  multirotor: in zero-thrust segments, in the attitude slews after a change of thrust
  direction, or elsewhere (the Exp 10 page's first correction);
* :func:`drift_offsets` -- how far a drifting start's ground path is from the still-air
  path plus ``w t`` (exact only while no segment commands zero thrust; the second
  correction);
* :func:`wind_sensitivity` and :func:`zero_thrust_sensitivity` -- how far a tiny change of
  wind moves the end of a flight, with and without a zero-thrust segment (RotorPy's rotor speed ``sqrt(|f| / k)`` at zero
  thrust: the tumbling vehicle's path is chaotic).

Every summary row is :func:`uavwind.core.stats.summarise` (95% bootstrap intervals over loops).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from ..core.checks import check_instance, check_scalar
from ..core.seeding import child_rng, child_seed
from ..core.stats import MIN_DECIDE, decide, summarise
from ..sim.actions import ThrustSequence, sample_paper
from ..sim.dynamics import simulate, simulate_flight
from ..sim.multirotor import Multirotor
from ..sim.setting import Setting
from ..sim.vehicle import n_steps
from ..sim.wind import ConstantWind

__all__ = ["flyable_table", "flyable_verdicts", "best_channels", "MIN_VERDICT_LOOPS",
           "saturation_split", "drift_offsets", "wind_sensitivity", "zero_thrust_sensitivity",
           "SLEW_WINDOW"]

#: Fewest loops a verdict needs: the one rule's :data:`uavwind.core.stats.MIN_DECIDE` (with
#: every one of n loops grouped correctly, the exact one-sided 95% lower bound of the share,
#: ``0.05 ** (1 / n)``, first exceeds 1/2 at n = 5; a percentile bootstrap of n equal
#: outcomes is a zero-width interval at any n).
MIN_VERDICT_LOOPS = MIN_DECIDE
#: How long after a change of commanded attitude a control step counts as a slew [s].
SLEW_WINDOW = 0.5

_KEYS = ("scenario", "action", "observation", "noise")
_FLIGHT = ("max_tilt", "max_tracking_error", "min_altitude", "min_thrust", "motor_limited")


def flyable_table(df: pd.DataFrame) -> pd.DataFrame:
    """Exp 14: per scenario, action (``"waypoints"`` or ``"thrust"``), observation and noise,
    the score and the share of correctly grouped loops with 95% intervals
    (:func:`~uavwind.core.stats.summarise`), and what the flights asked of the vehicle: the
    largest tilt flown [deg] and tracking error [m], the lowest height [m] and commanded
    collective thrust [N] (waypoint references; NaN for raw thrust), the mean share of
    motor-limited control steps, ``crashed``: the loops the vehicle could not fly (it would
    have gone below the ground), counted apart: the scores, shares and ``n_loops`` are of the
    loops it flew, so a crash never reads as "does not separate"; and ``flipped``: flown
    loops in which it turned past 90 degrees."""
    keys = [k for k in _KEYS if k in df.columns]
    rows = []
    for key, sub in df.groupby(keys, sort=False):
        key = key if isinstance(key, tuple) else (key,)
        crashed = (sub["crashed"].fillna(0).to_numpy() > 0 if "crashed" in sub.columns
                   else np.zeros(len(sub), bool))
        flown = sub[~crashed]
        s = summarise(flown) if len(flown) else {k: np.nan for k in (
            "mean", "ci_low", "ci_high", "max", "correct_rate", "correct_low", "correct_high")}
        row = {**dict(zip(keys, key)), **{k: s[k] for k in (
            "mean", "ci_low", "ci_high", "max", "correct_rate", "correct_low", "correct_high")},
               "n_loops": len(flown)}
        for col in _FLIGHT:
            if col not in sub.columns or not sub[col].notna().any():
                row[col] = np.nan
            elif col == "motor_limited":
                row[col] = float(sub[col].mean())
            elif col in ("min_altitude", "min_thrust"):
                row[col] = float(sub[col].min())
            else:
                row[col] = float(sub[col].max())
        # loops the vehicle could not fly (it would have gone below the ground): counted
        # here, apart from the loops it flew (which alone are scored); flipped: flown, but
        # upside down at some point
        row["crashed"] = int(crashed.sum())
        row["flipped"] = (int((sub["flipped"].fillna(0) > 0).sum()) if "flipped" in sub.columns
                          else 0)
        rows.append(row)
    return pd.DataFrame(rows)


def _verdict(row):
    n = row["n_loops"]
    return decide(row["correct_rate"], row["correct_low"], row["correct_high"],
                  int(n) if n == n else 0, threshold=0.5, above="separates",
                  below="does not separate", min_n=MIN_VERDICT_LOOPS).word


def flyable_verdicts(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` (:func:`flyable_table`) with a ``verdict`` per row: ``"separates"`` when the
    95% interval of the share of correctly grouped loops lies above 1/2, ``"does not
    separate"`` when it lies below, ``"cannot decide"`` when it spans 1/2 or the row has
    fewer than :data:`MIN_VERDICT_LOOPS` loops."""
    out = table.copy()
    out["verdict"] = [_verdict(r) for _, r in table.iterrows()] if len(table) else []
    return out


def best_channels(table: pd.DataFrame, action: str = "waypoints") -> pd.DataFrame:
    """Per scenario, the channel with the highest mean score under ``action`` (from
    :func:`flyable_table`), its interval, its verdict and the position channel's mean beside
    it; ``ValueError`` if no row has that action."""
    t = flyable_verdicts(table)
    t = t[t["action"] == action]
    if not len(t):
        raise ValueError(f"action must be one of {sorted(set(table['action']))}, got "
                         f"{action!r}")
    rows = []
    for scen, sub in t.groupby("scenario", sort=False):
        best = sub.loc[sub["mean"].idxmax()]
        pos = sub[sub["observation"] == "position"]
        rows.append({"scenario": scen, "observation": best["observation"],
                     "mean": best["mean"], "ci_low": best["ci_low"],
                     "ci_high": best["ci_high"], "correct_rate": best["correct_rate"],
                     "verdict": best["verdict"],
                     "position_mean": float(pos["mean"].iloc[0]) if len(pos) else np.nan})
    return pd.DataFrame(rows).set_index("scenario")


# --------------------------------------------------------------------------- #
# the Exp 10 corrections: what the paper's raw thrust does to a multirotor
# --------------------------------------------------------------------------- #
def _step_kinds(uav, thrust, n_ctrl, window):
    """Per control step: 0 zero-thrust segment, 1 slew (within ``window`` s of a change of
    commanded attitude), 2 the rest."""
    h = 1.0 / uav.control_rate
    t = np.arange(n_ctrl) * h
    seg = np.maximum(thrust.segment(t), 0)
    cmds = uav.segment_commands(thrust)
    zero = np.array([c[0] == 0.0 for c in cmds])
    kind = np.full(n_ctrl, 2)
    for i in range(1, len(cmds)):
        dot = abs(float(np.dot(cmds[i][1], cmds[i - 1][1])))
        if 2 * math.degrees(math.acos(min(dot, 1.0))) > 1.0:  # the attitude changes
            kind[(t >= thrust.times[i] - 1e-9) & (t < thrust.times[i] + window - 1e-9)] = 1
    kind[zero[seg]] = 0
    return kind


def saturation_split(settings: list[Setting] | Setting, n_loops: int = 10, seed: int = 0,
                     window: float = SLEW_WINDOW) -> pd.DataFrame:
    """Where the motors of a multirotor saturate under a setting's raw-thrust actions.

    Flies loops ``0 .. n_loops - 1`` of each setting as :func:`uavwind.random_search` draws
    them with ``seed`` (the same thrust sequences and winds) and sorts every control step of
    every environment into *zero-thrust segments* (the commanded collective thrust is 0), *slews*
    (the first ``window`` seconds after a change of commanded attitude, outside zero-thrust
    segments) and *the rest*.

    Returns
    -------
    pandas.DataFrame
        Index ``kind`` (``"zero-thrust segments"``, ``"slews"``, ``"the rest"``, ``"all"``):
        ``steps`` (control steps x environments), ``limited`` (of those, steps with a motor
        command clipped), ``share_of_limited`` (of all limited steps) and ``limited_rate``
        (limited / steps).
    """
    settings = [settings] if isinstance(settings, Setting) else list(settings)
    n_loops = check_scalar(n_loops, "n_loops", low=1, high=10 ** 5, integer=True)
    window = check_scalar(window, "window", low=0.0, high=100.0)
    names = ("zero-thrust segments", "slews", "the rest")
    steps, limited = np.zeros(3), np.zeros(3)
    for s in settings:
        check_instance(s, "settings", Setting)
        if not isinstance(s.uav, Multirotor) or s.sampler not in ("paper", "continuous"):
            raise ValueError(f"settings must fly raw thrust (sampler 'paper' or 'continuous') on "
                             f"a Multirotor, got sampler {s.sampler!r} on "
                             f"{type(s.uav).__name__}")
        n = n_steps(s.dt, s.duration)
        per = s.uav.check_grid(s.dt)
        for i in range(n_loops):
            thrust = s.sample_thrust(child_rng(seed, i, 0))
            wind = s.wind(child_seed(seed, i, 1))
            log = np.zeros((wind.n_env, n * per), dtype=bool)
            s.uav.fly(thrust, wind, s.dt, n, np.array([0.0, 0.0, s.start_altitude]),
                      clip_log=log)
            kind = _step_kinds(s.uav, thrust, n * per, window)
            for k in range(3):
                steps[k] += wind.n_env * np.sum(kind == k)
                limited[k] += log[:, kind == k].sum()
    out = pd.DataFrame({"steps": np.append(steps, steps.sum()),
                        "limited": np.append(limited, limited.sum())},
                       index=pd.Index([*names, "all"], name="kind"))
    out["share_of_limited"] = out["limited"] / max(limited.sum(), 1)
    out["limited_rate"] = out["limited"] / out["steps"]
    return out


def _has_zero_thrust(uav, thrust):
    return any(c[0] == 0.0 for c in uav.segment_commands(thrust))


def drift_offsets(n_loops: int = 20, seed: int = 0, wind=(3.0, -2.0, 0.0),
                  uav: Multirotor | None = None, duration: float = 12.0,
                  dt: float = 0.1) -> pd.DataFrame:
    """How far a drifting start's ground path lies from the still-air path plus ``w t``.

    For each of ``n_loops`` of the paper's thrust sequences (drawn as
    :func:`uavwind.random_search` draws them with ``seed``), flies ``uav`` (default RotorPy's
    quadrotor from a drifting start) through the constant ``wind`` (3,) [m/s] and through still
    air, and measures the largest ``|p_w(t) - p_0(t) - w t|`` [m].

    Returns
    -------
    pandas.DataFrame
        One row per loop: ``zero_thrust`` (a segment commands no thrust),
        ``motor_limited`` (share of control steps with a motor clipped, in the wind),
        ``deviation`` [m].
    """
    uav = Multirotor(preset="rotorpy", start="drifting") if uav is None else uav
    check_instance(uav, "uav", Multirotor)
    if uav.start != "drifting":
        raise ValueError(f"uav must start 'drifting' (moving with the air), got {uav.start!r}")
    n_loops = check_scalar(n_loops, "n_loops", low=1, high=10 ** 5, integer=True)
    w = np.asarray(wind, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f"wind must be a finite (3,) velocity [m/s], got {wind!r}")
    winds = ConstantWind(np.array([w, np.zeros(3)]))
    rows = []
    for i in range(n_loops):
        thrust = sample_paper(child_rng(seed, i, 0), duration=duration)
        f = simulate_flight(thrust, winds, uav=uav, dt=dt, duration=duration)
        dev = f.positions[0] - f.positions[1] - w * f.times[:, None]
        rows.append({"loop": i, "zero_thrust": _has_zero_thrust(uav, thrust),
                     "motor_limited": f.motor_limited,
                     "deviation": float(np.linalg.norm(dev, axis=1).max())})
    return pd.DataFrame(rows)


def wind_sensitivity(thrust: ThrustSequence, wind=(0.5, 0.5, 0.0), delta: float = 1e-9,
                     uav: Multirotor | None = None, duration: float = 12.0,
                     dt: float = 0.1) -> float:
    """How far [m] the end of a flight moves when the wind changes by ``delta`` [m/s] along x:
    ``|p_end(w + delta e_x) - p_end(w)|`` for ``thrust`` flown by ``uav`` (default RotorPy's
    quadrotor from a hover) through the constant ``wind`` (3,) [m/s]. Of the order of ``delta
    t`` for a smooth flight; metres' worth of chaos when a segment commands zero thrust and
    the vehicle tumbles."""
    check_instance(thrust, "thrust", ThrustSequence)
    uav = Multirotor(preset="rotorpy", start="hover") if uav is None else uav
    check_instance(uav, "uav", Multirotor)
    delta = check_scalar(delta, "delta", low=0.0, low_inclusive=False, high=1e3)
    w = np.asarray(wind, dtype=float)
    if w.shape != (3,) or not np.all(np.isfinite(w)):
        raise ValueError(f"wind must be a finite (3,) velocity [m/s], got {wind!r}")
    pos = simulate(thrust, ConstantWind(np.array([w, w + [delta, 0.0, 0.0]])), uav=uav, dt=dt,
                   duration=duration)
    return float(np.linalg.norm(pos[0, -1] - pos[1, -1]))


def zero_thrust_sensitivity(n_loops: int = 20, seed: int = 0, wind=(0.5, 0.5, 0.0),
                            delta: float = 1e-9, uav: Multirotor | None = None
                            ) -> pd.DataFrame:
    """:func:`wind_sensitivity` of ``n_loops`` of the paper's thrust sequences (drawn as
    :func:`uavwind.random_search` draws them with ``seed``): one row per loop with
    ``zero_thrust`` (a segment commands no thrust) and ``shift``, how far [m] the end of the
    flight moves for a change of ``delta`` [m/s] in the wind."""
    uav = Multirotor(preset="rotorpy", start="hover") if uav is None else uav
    check_instance(uav, "uav", Multirotor)
    n_loops = check_scalar(n_loops, "n_loops", low=1, high=10 ** 5, integer=True)
    rows = []
    for i in range(n_loops):
        thrust = sample_paper(child_rng(seed, i, 0))
        rows.append({"loop": i, "zero_thrust": _has_zero_thrust(uav, thrust),
                     "shift": wind_sensitivity(thrust, wind, delta, uav)})
    return pd.DataFrame(rows)
