"""Experiment 13, the wind estimated: :class:`~uavwind.method.wind_estimator.WindEstimator`
held to the tunnel's winds, leaving one controller out.

This module owns :func:`estimation_rows` (for every method and controller: fit on the other
controllers' flights, predict each of that controller's flights; one row per prediction) and
:func:`estimation_table` (per method and wind: the RMSE over held-out controllers of each
flight's mean estimated speed against the tunnel's, the per-sample RMSE, and for the
sinusoidal wind the fitted amplitude, phase and lag).

*The sinusoid's phase.* Neural-Fly's ``70p20sint`` wind is 8.5 + 2.4 sin t m/s, but the
files' time is not the fan's: the phase of the sinusoid at the vehicle is read off the force
itself (:func:`force_phase`: the first harmonic of ``fa_x`` in that flight minus the same
controller's steady 8.5 m/s flight, whose figure-8 has the same period; turned by pi, more
wind pushing ``fa_x`` further negative). The estimate's phase is compared with it (the lag),
and its per-sample error is measured against the sinusoid at that phase.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..core.checks import check_instance
from ..core.stats import t_ci
from ..data.neuralfly import CONDITIONS, RealFlight
from ..method.wind_estimator import ESTIMATORS, WindEstimator

__all__ = ["estimation_rows", "estimation_table", "force_phase", "SINUSOID", "TARGETS"]

#: The sinusoidal condition and its amplitude [m/s] and angular frequency [rad/s].
SINUSOID = ("70p20sint", 2.4, 1.0)
#: What the estimator aims at: RMSE of each flight's mean speed [m/s] and the sinusoid's
#: amplitude error [m/s] (the project's targets).
TARGETS = {"mean_speed_rmse": 0.3, "amplitude_error": 0.5}


def _harmonic(t, y, omega):
    """``(mean, amplitude, phase)`` of ``y ~ a + A sin(omega t + phi)`` (least squares)."""
    X = np.column_stack([np.ones_like(t), np.sin(omega * t), np.cos(omega * t)])
    c = np.linalg.lstsq(X, y, rcond=None)[0]
    return float(c[0]), float(np.hypot(c[1], c[2])), float(np.arctan2(c[2], c[1]))


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def force_phase(sinusoid: RealFlight, steady: RealFlight, skip: float = 2 * np.pi) -> float:
    """The phase [rad] of the sinusoidal wind at the vehicle, read off the force (module text)."""
    omega = SINUSOID[2]
    z = []
    for f in (sinusoid, steady):
        keep = f.arrays["t"] >= skip
        X = np.column_stack([np.ones(keep.sum()), np.sin(omega * f.arrays["t"][keep]),
                             np.cos(omega * f.arrays["t"][keep])])
        c = np.linalg.lstsq(X, f.arrays["fa"][keep, 0], rcond=None)[0]
        z.append(c[1] + 1j * c[2])
    return float(_wrap(np.angle(z[0] - z[1]) - np.pi))


def estimation_rows(flights: list[RealFlight], methods=ESTIMATORS,
                    direction=(-1.0, 0.0, 0.0)) -> list[dict]:
    """Leave one controller out: for every method and controller, a
    :class:`~uavwind.method.wind_estimator.WindEstimator` fitted on the other controllers'
    flights predicts each of that controller's flights. One row per prediction (kind
    ``"estimate"``): the flight's mean estimated speed along ``direction`` after the start-up
    lap (``estimate``), its per-sample RMSE against the tunnel's wind (the sinusoid at the
    force's phase for ``70p20sint``, :func:`force_phase`; ``sample_rmse``) and the harmonic
    fitted to the estimated speed (``amplitude``, ``phase``; for a steady wind the amplitude
    the figure-8 alone leaves), with the force's phase (``phase_ref``) and the ``lag`` [s]."""
    for f in flights:
        check_instance(f, "flights[i]", RealFlight)
    controllers = sorted({f.controller for f in flights})
    by = {(f.controller, f.condition): f for f in flights}
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    name, amp, omega = SINUSOID
    rows = []
    if len(controllers) < 2:
        return rows
    for method in methods:
        for held in controllers:
            est = WindEstimator(method, direction=d).fit(
                [f for f in flights if f.controller != held])
            ref = (force_phase(by[(held, name)], by[(held, "70wind")])
                   if (held, name) in by and (held, "70wind") in by else np.nan)
            for f in (f for f in flights if f.controller == held):
                keep = f.arrays["t"] >= est.skip
                t = f.arrays["t"][keep]
                speed = est.predict(f)[keep] @ d
                truth = np.full_like(t, f.wind_speed)
                if f.condition == name:
                    truth = truth + amp * np.sin(omega * t + (ref if np.isfinite(ref) else 0.0))
                _, a, phi = _harmonic(t, speed, omega)
                # a lag only where the estimate swings (a piecewise-constant one has no phase)
                lag = (float(_wrap(ref - phi) / omega)
                       if f.condition == name and a >= 0.1 * amp else np.nan)
                rows.append({"kind": "estimate", "method": method, "controller": held,
                             "condition": f.condition, "wind_speed": f.wind_speed,
                             "estimate": float(speed.mean()),
                             "sample_rmse": float(np.sqrt(np.mean((speed - truth) ** 2))),
                             "amplitude": a, "phase": phi,
                             "phase_ref": ref if f.condition == name else np.nan, "lag": lag})
    return rows


def estimation_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per method and wind: the RMSE over held-out controllers of each flight's mean
    estimated speed against the tunnel's (``rmse``) and the mean signed error (``bias``,
    with a 95% t interval over controllers), the per-sample RMSE (RMS over controllers),
    the harmonic's amplitude (mean over controllers, and its RMSE against 2.4 m/s for the
    sinusoid) and the mean lag [s]; ``meets`` says whether the mean-speed RMSE is within
    :data:`TARGETS` (and the amplitude, for the sinusoid)."""
    est = rows[rows["kind"] == "estimate"]
    out = []
    for (method, cond), g in est.groupby(["method", "condition"], sort=False):
        err = g["estimate"] - g["wind_speed"]
        b, lo, hi = t_ci(err.to_numpy())
        row = {"method": method, "condition": cond, "wind_speed": CONDITIONS.get(cond, np.nan),
               "rmse": float(np.sqrt(np.mean(err ** 2))), "bias": b, "bias_low": lo,
               "bias_high": hi, "sample_rmse": float(np.sqrt(np.mean(g["sample_rmse"] ** 2))),
               "amplitude": float(g["amplitude"].mean()),
               "amplitude_rmse": (float(np.sqrt(np.mean((g["amplitude"] - SINUSOID[1]) ** 2)))
                                  if cond == SINUSOID[0] else np.nan),
               "lag": float(g["lag"].mean()) if g["lag"].notna().all() else np.nan,
               "n_controllers": len(g)}
        row["meets"] = bool(row["rmse"] <= TARGETS["mean_speed_rmse"] and (
            cond != SINUSOID[0] or abs(row["amplitude"] - SINUSOID[1])
            <= TARGETS["amplitude_error"]))
        out.append(row)
    df = pd.DataFrame(out)
    if not len(df):
        return df
    rank = {**{m: i for i, m in enumerate(ESTIMATORS)}, **{c: i for i, c in enumerate(CONDITIONS)}}
    return df.sort_values(["method", "condition"], key=lambda s: s.map(rank), ignore_index=True)
