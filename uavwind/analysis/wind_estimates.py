"""Experiment 13, the wind estimated: :class:`~uavwind.method.wind_estimator.WindEstimator`
judged on flights it was not fitted on, under one protocol.

This module owns :func:`estimation_rows` (for every method: leave one controller out -- fit on
the other controllers' flights, predict each of the held-out controller's -- and leave one
wind out -- fit on the other controllers' flights at the other winds, predict the held-out
controller's flight at the held-out wind; one row per prediction, plus a decimated time
series of one controller's flights for the figure), :func:`estimation_table` (per method,
protocol and wind) and :func:`summary_table` (per method and protocol, with intervals over
the controllers), :func:`error_decomposition` (where a held-out flight's per-sample error
comes from: its mean's bias, the scatter about it, the lap-locked share of that scatter) and
:func:`choose_filter` (the ekf's noise chosen by leave one controller out on the flights it
is given: the inner loop of a nested protocol). ``"clusters"`` is a classifier: it is scored by the share of laps that name
the right wind (``accuracy``), under leave one controller out only (a wind it was not trained
on it cannot name: its accuracy there is 0 by construction), never by an RMSE.

*Per sample* means after :data:`SETTLE` s (the start-up lap and the filters' start); the
vector RMSE is over the horizontal and vertical error; *coverage* is the share of those
samples whose 95% interval (mean +- 1.96 std along the wind's direction) holds the tunnel's
wind.

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
from ..core.stats import bootstrap_ci, t_ci, wilson_ci
from ..data.neuralfly import CONDITIONS, RealFlight, flight_laps
from ..method.wind_estimator import ESTIMATORS, UNRECORDED, WindEstimator

__all__ = ["estimation_rows", "estimation_table", "summary_table", "force_phase", "SINUSOID",
           "TARGETS", "PROTOCOLS", "PROTOCOL_NAMES", "SETTLE", "SERIES_STEP", "VARIANTS", "VARIANT_METHODS", "BASELINE", "estimates",
           "error_decomposition", "choose_filter", "FILTER_GRID"]

#: The sinusoidal condition and its amplitude [m/s] and angular frequency [rad/s].
SINUSOID = ("70p20sint", 2.4, 1.0)
#: What the estimator aims at (the project's targets): RMSE of each held-out flight's mean
#: speed [m/s] (leave one wind out; goal 0.4), per-sample vector RMSE [m/s] (goal 0.3), the
#: 95% interval's coverage, and the sinusoid's amplitude error [m/s].
TARGETS = {"mean_speed_rmse": 0.6, "sample_rmse": 0.4, "coverage": (0.85, 0.99),
           "amplitude_error": 0.5}
#: The two ways a flight is held out -- its controller, or its controller and its wind --
#: and their names on a page.
PROTOCOL_NAMES = {"controller": "controller held out", "wind": "controller and wind held out"}
PROTOCOLS = tuple(PROTOCOL_NAMES)
#: Per-sample scores count from this time [s].
SETTLE = 10.0
#: The series rows keep every this many samples (50 Hz: one per 0.2 s).
SERIES_STEP = 10
#: The drag model's variants scored beside the default (``"drag"`` only unless
#: :data:`VARIANT_METHODS` says otherwise): why the model is what it is, on the page.
VARIANTS = {"no jet": {"jet": False}, "parasitic": {"parasitic": True},
            "no own offset": {"tilt": False}}
#: The methods a variant is scored with, where not ``"drag"`` alone.
VARIANT_METHODS = {"no own offset": ("drag", "ekf")}
#: The trivial baseline's method name: the training flights' mean wind, whatever the flight.
BASELINE = "training mean"


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


def _truth(f, ref, t):
    """The tunnel's wind speed [m/s] at times ``t`` of flight ``f`` (the sinusoid at the
    force's phase ``ref``)."""
    truth = np.full_like(t, f.wind_speed, dtype=float)
    if f.condition == SINUSOID[0]:
        truth = truth + SINUSOID[1] * np.sin(SINUSOID[2] * t + (ref if np.isfinite(ref) else 0.0))
    return truth


def _score(est, f, d, ref, base):
    """One row of kind ``"estimate"`` for a drag or filter prediction of flight ``f``."""
    mean, std = est.predict(f, return_std=True)
    t = f.arrays["t"]
    keep, late = t >= est.skip, t >= SETTLE
    speed = mean @ d
    sd = np.sqrt((std ** 2) @ (d ** 2))
    truth = _truth(f, ref, t)
    W = truth[:, None] * d
    _, a, phi = _harmonic(t[keep], speed[keep], SINUSOID[2])
    name = SINUSOID[0]
    # a lag only where the estimate swings
    lag = (float(_wrap(ref - phi) / SINUSOID[2])
           if f.condition == name and a >= 0.1 * SINUSOID[1] and np.isfinite(ref) else np.nan)
    return {**base, "estimate": float(speed[keep].mean()),
            **_late_scores(np.sum((mean[late] - W[late]) ** 2, axis=1),
                           np.abs(speed[late] - truth[late]), sd[late]),
            "amplitude": a, "phase": phi, "phase_ref": ref if f.condition == name else np.nan,
            "lag": lag}, (t, speed, sd, truth)


def _late_scores(sq_err, abs_err, sd):
    """The per-sample scores after :data:`SETTLE`: ``sample_rmse`` of the squared vector
    errors ``sq_err``, ``coverage`` (the along-wind errors ``abs_err`` within 1.96 ``sd``)
    and the RMS ``std``."""
    return {"sample_rmse": float(np.sqrt(np.mean(sq_err))),
            "coverage": float(np.mean(abs_err <= 1.96 * sd)),
            "std": float(np.sqrt(np.mean(np.square(sd))))}


def _cases(flights, held, protocol, winds):
    """``[(train, test), ...]`` of one held-out controller under ``protocol`` (module text)."""
    if protocol == "controller":
        return [([f for f in flights if f.controller != held],
                 [f for f in flights if f.controller == held])]
    return [([f for f in flights if f.controller != held and f.wind_speed != w],
             [f for f in flights if f.controller == held and f.wind_speed == w
              and f.condition not in UNRECORDED]) for w in winds]


def _baseline_row(train, f, ref, base):
    """The trivial baseline's row: every sample of ``f`` named the mean wind of the training
    flights, with their spread as its std (the same scores as :func:`_score`)."""
    speeds = np.array([g.wind_speed for g in train], dtype=float)
    guess, sd = float(speeds.mean()), float(speeds.std(ddof=1))
    t = f.arrays["t"]
    err = np.abs(_truth(f, ref, t)[t >= SETTLE] - guess)  # along the wind: the whole error
    return {**base, "estimate": guess,
            **_late_scores(err ** 2, err, np.full_like(err, sd)), "amplitude": 0.0, "phase": np.nan, "phase_ref": np.nan, "lag": np.nan}


def _accuracy(est, f):
    """The share of ``f``'s laps (after the first) whose named wind is its own."""
    starts = flight_laps(f, ("position",), 8, 1)["starts"]
    t = f.arrays["t"]
    idx = np.clip(np.searchsorted(t, starts), 0, len(t) - 1)
    named = est.predict(f)[idx] @ est.direction
    return float(np.mean(np.abs(named - f.wind_speed) < 1e-6))


def estimation_rows(flights: list[RealFlight], methods=ESTIMATORS,
                    direction=(-1.0, 0.0, 0.0), protocols=PROTOCOLS,
                    series_controller: str | None = None, variants: bool = True,
                    baseline: bool = True) -> list[dict]:
    """Every prediction of the protocol (module text): one row per held-out flight, method
    and protocol (kind ``"estimate"``): the flight's mean estimated speed along ``direction``
    after the start-up lap (``estimate``), the per-sample vector RMSE (``sample_rmse``), the
    95% interval's ``coverage`` and RMS ``std`` [m/s], the harmonic fitted to the estimated
    speed (``amplitude``, ``phase``) with the force's phase (``phase_ref``) and the ``lag``
    [s]; for ``"clusters"`` the ``accuracy`` only. Plus kind ``"series"`` rows: the leave-one-
    controller-out estimate of ``series_controller``'s flights (default the first in name
    order) every :data:`SERIES_STEP` samples (``t``, ``estimate``, ``std``, ``truth``)."""
    for f in flights:
        check_instance(f, "flights[i]", RealFlight)
    for p in protocols:
        if p not in PROTOCOLS:
            raise ValueError(f"protocols must be among {list(PROTOCOLS)}, got {p!r}")
    controllers = sorted({f.controller for f in flights})
    if len(controllers) < 2:
        return []
    series_controller = controllers[0] if series_controller is None else series_controller
    by = {(f.controller, f.condition): f for f in flights}
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    winds = sorted({f.wind_speed for f in flights if f.condition not in UNRECORDED})
    ref = {c: (force_phase(by[(c, SINUSOID[0])], by[(c, "70wind")])
               if (c, SINUSOID[0]) in by and (c, "70wind") in by else np.nan)
           for c in controllers}
    specs = [(m, "default", {}) for m in methods]
    if variants:
        specs += [(m, name, kw) for name, kw in VARIANTS.items()
                  for m in VARIANT_METHODS.get(name, ("drag",)) if m in methods]
    if baseline:
        specs.append((BASELINE, "default", {}))
    rows = []
    for method, variant, kw in specs:
        for protocol in protocols:
            if method == "clusters" and protocol == "wind":
                continue  # a classifier cannot name a wind it was not trained on
            for held in controllers:
                for train, test in _cases(flights, held, protocol, winds):
                    if not test or len({f.wind_speed for f in train}) < 2:
                        continue
                    est = (None if method == BASELINE else
                           WindEstimator(method, direction=d, **kw).fit(train))
                    for f in test:
                        base = {"kind": "estimate", "method": method, "variant": variant,
                                "protocol": protocol, "controller": held,
                                "condition": f.condition, "wind_speed": f.wind_speed}
                        if method == "clusters":
                            rows.append({**base, "accuracy": _accuracy(est, f)})
                            continue
                        if method == BASELINE:
                            rows.append(_baseline_row(train, f, ref[held], base))
                            continue
                        row, (t, speed, sd, truth) = _score(est, f, d, ref[held], base)
                        rows.append(row)
                        if (protocol == "controller" and held == series_controller
                                and variant == "default"):
                            s = slice(None, None, SERIES_STEP)
                            rows += [{**base, "kind": "series", "t": float(a), "estimate": float(b),
                                      "std": float(c), "truth": float(e)}
                                     for a, b, c, e in zip(t[s], speed[s], sd[s], truth[s])]
    return rows


def _named(g):
    """``"clusters"``' score over held-out flights ``g``: ``accuracy`` (the mean share of
    laps naming the flight's wind), ``named`` (flights whose laps mostly name it), and the
    share named with its Wilson interval (``named_share``, ``named_low``, ``named_high``)."""
    k = int(np.sum(g["accuracy"].to_numpy(float) > 0.5))
    share, lo, hi = wilson_ci(k, len(g))
    return {"accuracy": float(g["accuracy"].mean()), "named": k, "named_share": share,
            "named_low": lo, "named_high": hi}


def _rms(x):
    return np.sqrt(np.mean(np.square(np.asarray(x, dtype=float)), axis=-1))


def estimation_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per method, protocol and wind: the RMSE over held-out controllers of each flight's mean
    estimated speed against the tunnel's (``rmse``), the mean signed error (``bias``, with a
    95% t interval over controllers), the per-sample vector RMSE (RMS over controllers), the
    coverage and RMS std, the harmonic's amplitude (mean over controllers, and its RMSE
    against 2.4 m/s for the sinusoid) and the mean lag [s]; ``"clusters"``' ``accuracy``
    and the flights it names (:func:`_named`, a Wilson interval). ``meets``: the mean-speed RMSE, the
    per-sample RMSE and the coverage within :data:`TARGETS` (and the amplitude, for the
    sinusoid); for ``"clusters"`` empty."""
    est = estimates(rows)
    out = []
    for (method, variant, protocol, cond), g in est.groupby(
            ["method", "variant", "protocol", "condition"], sort=False):
        row = {"method": method, "variant": variant, "protocol": protocol, "condition": cond,
               "wind_speed": CONDITIONS.get(cond, np.nan), "n_controllers": len(g)}
        if method == "clusters":
            out.append({**row, **_named(g), "meets": None})
            continue
        err = g["estimate"] - g["wind_speed"]
        b, lo, hi = t_ci(err.to_numpy())
        row.update({"rmse": float(_rms(err)), "bias": b, "bias_low": lo, "bias_high": hi,
                    "sample_rmse": float(_rms(g["sample_rmse"])),
                    "coverage": float(g["coverage"].mean()), "std": float(_rms(g["std"])),
                    "amplitude": float(g["amplitude"].mean()),
                    "amplitude_rmse": (float(_rms(g["amplitude"] - SINUSOID[1]))
                                       if cond == SINUSOID[0] else np.nan),
                    "lag": float(g["lag"].mean()) if g["lag"].notna().all() else np.nan})
        lowc, highc = TARGETS["coverage"]
        row["meets"] = bool(row["rmse"] <= TARGETS["mean_speed_rmse"]
                            and row["sample_rmse"] <= TARGETS["sample_rmse"]
                            and lowc <= row["coverage"] <= highc
                            and (cond != SINUSOID[0] or abs(row["amplitude"] - SINUSOID[1])
                                 <= TARGETS["amplitude_error"]))
        out.append(row)
    df = pd.DataFrame(out)
    if not len(df):
        return df
    return df.sort_values(["method", "variant", "protocol", "condition"], key=_rank,
                          ignore_index=True)


def estimates(rows: pd.DataFrame) -> pd.DataFrame:
    """The rows of kind ``"estimate"``, with ``protocol`` and ``variant`` filled in for rows
    of an earlier version (leave one controller out, the default model)."""
    est = rows[rows["kind"] == "estimate"]
    for col, value in (("protocol", "controller"), ("variant", "default")):
        est = est.assign(**{col: est[col].fillna(value) if col in est else value})
    return est


def _rank(col):
    """Sort key: methods, variants, protocols and conditions in their defined order."""
    order = {**{m: i for i, m in enumerate((*ESTIMATORS, BASELINE))},
             **{v: i for i, v in enumerate(["default", *VARIANTS])},
             **{p: i for i, p in enumerate(PROTOCOLS)}, **{c: i for i, c in enumerate(CONDITIONS)}}
    return col.map(order)


def summary_table(rows: pd.DataFrame) -> pd.DataFrame:
    """Per method and protocol, over the steady winds' held-out flights: the RMSE of the mean
    speed, the per-sample vector RMSE and the coverage, each with a 95% bootstrap interval
    over the held-out controllers (each controller's flights resampled together); for
    ``"clusters"`` the accuracy and the flights named (:func:`_named`). ``n_flights``,
    ``n_controllers``."""
    est = estimates(rows)
    est = est[~est["condition"].isin(UNRECORDED)]
    out = []
    for (method, variant, protocol), g in est.groupby(["method", "variant", "protocol"],
                                                      sort=False):
        per = g.groupby("controller")
        row = {"method": method, "variant": variant, "protocol": protocol, "n_flights": len(g),
               "n_controllers": per.ngroups}
        if method == "clusters":
            out.append({**row, **_named(g)})
            continue
        # per controller: its flights' squared errors summed and counted, so a resample of
        # controllers gives the RMSE over their flights
        sq = per.apply(lambda x: pd.Series({
            "se": float(np.sum((x["estimate"] - x["wind_speed"]) ** 2)),
            "ss": float(np.sum(x["sample_rmse"] ** 2)), "cov": float(np.sum(x["coverage"])),
            "n": len(x)}), include_groups=False).to_numpy(float)

        for name, col, root in (("rmse", 0, True), ("sample_rmse", 1, True),
                                ("coverage", 2, False)):
            def stat(x, col=col, root=root):
                x = np.asarray(x)
                r = np.sum(x[..., col], axis=-1) / np.sum(x[..., 3], axis=-1)
                return np.sqrt(r) if root else r
            # resample the controllers: bootstrap over their row numbers
            v, lo, hi = bootstrap_ci(np.arange(len(sq)),
                                     lambda ix, axis=None, stat=stat: stat(sq[ix.astype(int)]))
            if len(sq) < 3:  # no interval from fewer controllers
                lo = hi = np.nan
            row[name], row[f"{name}_low"], row[f"{name}_high"] = v, lo, hi
        out.append(row)
    df = pd.DataFrame(out)
    if not len(df):
        return df
    return df.sort_values(["method", "variant", "protocol"], key=_rank, ignore_index=True)


#: The ekf's noise settings :func:`choose_filter` compares: (``sigma_wind_rate`` [m/s per
#: sqrt(s)], ``update_period`` [s]).
FILTER_GRID = tuple((s, p) for s in (0.03, 0.1, 0.3, 1.0) for p in (0.25, 0.5, 1.0, 2.0))


def _lap_harmonics(t):
    """Columns of a lap-locked fit: a constant and the first three harmonics of the
    figure-8's period (2 pi s)."""
    return np.column_stack([np.ones_like(t)] + [fn(k * t) for k in (1, 2, 3)
                                                 for fn in (np.sin, np.cos)])


def error_decomposition(flights: list[RealFlight], method: str = "ekf",
                        direction=(-1.0, 0.0, 0.0), **params) -> pd.DataFrame:
    """Where the per-sample error of ``method`` comes from, with each controller held out in
    turn (fitted on the others, ``params`` passed to :class:`WindEstimator`): one row per
    held-out steady flight (``controller``, ``condition``, ``wind_speed``) with, after
    :data:`SETTLE`, its vector ``sample_rmse`` [m/s], the norm of its mean error ``bias``
    and the RMS ``scatter`` about that mean (``sample_rmse**2 = bias**2 + scatter**2``:
    the vertical wind is 0 in the labels and in the estimate, so it adds nothing), and
    ``lap_share``, the share of the scatter's mean square a fit of the lap's first three
    harmonics removes (fitted on the flight itself: an upper bound on what a lap-locked term
    could remove)."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    WindEstimator(method, direction=d, **params)  # an unknown keyword fails here, before work
    controllers = sorted({f.controller for f in flights})
    if len(controllers) < 2:
        raise ValueError(f"flights must come from at least two controllers to hold one out, "
                         f"got {controllers}")
    rows = []
    for held in controllers:
        est = WindEstimator(method, direction=d, **params).fit(
            [f for f in flights if f.controller != held])
        for f in flights:
            if f.controller != held or f.condition in UNRECORDED:
                continue
            t = f.arrays["t"]
            late = t >= SETTLE
            e = (est.predict(f) - f.wind_speed * d)[late]
            mu = e.mean(axis=0)
            r = e - mu
            fit = _lap_harmonics(t[late])
            resid = r - fit @ np.linalg.lstsq(fit, r, rcond=None)[0]
            scatter2 = float(np.mean(np.sum(r ** 2, axis=1)))
            rows.append({"controller": held, "condition": f.condition,
                         "wind_speed": f.wind_speed,
                         "sample_rmse": float(np.sqrt(np.mean(np.sum(e ** 2, axis=1)))),
                         "bias": float(np.linalg.norm(mu)), "scatter": float(np.sqrt(scatter2)),
                         "lap_share": (1.0 - float(np.mean(np.sum(resid ** 2, axis=1)))
                                       / scatter2 if scatter2 > 0 else 0.0)})
    return pd.DataFrame(rows)


def choose_filter(flights: list[RealFlight], grid=FILTER_GRID, direction=(-1.0, 0.0, 0.0),
                  steady: bool = True) -> tuple[dict, pd.DataFrame]:
    """The ekf's noise (``sigma_wind_rate``, ``update_period``) chosen by leave one
    controller out on ``flights`` alone (each of their controllers held out in turn, the
    estimator fitted on the others): the setting of ``grid`` with the least per-sample
    vector RMSE after :data:`SETTLE` over the held-out flights -- the steady ones with
    ``steady`` (the target's), else the sinusoid's too (scored against the sinusoid at the
    force's phase, :func:`force_phase`). Returns ``(params, scores)``: the chosen keyword
    arguments of :class:`WindEstimator` and one row per setting (``sample_rmse``). Called on
    the training controllers only, it is the inner loop of a nested protocol: the flight it
    will predict has no say."""
    grid = [tuple(g) for g in grid]
    if not grid:
        raise ValueError("grid must hold at least one (sigma_wind_rate, update_period)")
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    controllers = sorted({f.controller for f in flights})
    if len(controllers) < 3:
        raise ValueError(f"flights must come from at least three controllers (each fit "
                         f"holding one out needs two), got {controllers}")
    by = {(f.controller, f.condition): f for f in flights}
    ref = {c: (force_phase(by[(c, SINUSOID[0])], by[(c, "70wind")])
               if (c, SINUSOID[0]) in by and (c, "70wind") in by else np.nan)
           for c in controllers}
    scores = []
    for sigma, period in grid:
        se = []
        for held in controllers:
            est = WindEstimator("ekf", direction=d, sigma_wind_rate=sigma,
                                update_period=period).fit(
                [f for f in flights if f.controller != held])
            for f in flights:
                if f.controller != held or (steady and f.condition in UNRECORDED):
                    continue
                t = f.arrays["t"]
                late = t >= SETTLE
                truth = _truth(f, ref[held], t)[late, None] * d
                se.append(float(np.mean(np.sum((est.predict(f)[late] - truth) ** 2, axis=1))))
        scores.append({"sigma_wind_rate": sigma, "update_period": period,
                       "sample_rmse": float(np.sqrt(np.mean(se)))})
    scores = pd.DataFrame(scores)
    best = scores.iloc[int(np.argmin(scores["sample_rmse"].to_numpy()))]
    return ({"sigma_wind_rate": float(best["sigma_wind_rate"]),
             "update_period": float(best["update_period"])}, scores)
