"""Experiment 13, simulated: Neural-Fly's figure-8 flown by a twin of the Neural-Fly
quadrotor, calibrated on the real flights, side by side with them.

This module owns :func:`sim_rows` (the twin's flight rows, cached as the real rows are, under
:data:`SIM_VERSION`), :func:`calibration_of` (the calibration they were flown with),
:func:`validation_table` (the twin against a held-out controller's flights, per wind and
quantity of :data:`~uavwind.analysis.twin.VALIDATION`, beside the trivial model),
:func:`validation_score` (over its :data:`PHYSICAL` rows) and :func:`ranking_verdict` (does
the twin order the channels as the real flights do?).

The twin itself is two modules below this one: :mod:`uavwind.analysis.twin`, what it is and
how it flies (:class:`~uavwind.analysis.twin.TwinCalibration`, :data:`~uavwind.analysis.twin.BARE`,
:func:`~uavwind.analysis.twin.simulated_flight`, :func:`~uavwind.analysis.twin.simulated_flights`,
the constants it flies with), and :mod:`uavwind.analysis.twin_fit`, its calibration on the
training controllers' flights (:func:`~uavwind.analysis.twin_fit.calibrate_twin` and its fits).
This module held all three until issue 66 split it; the public names it held are re-exported
here and keep working as before (the same objects; ``tests/test_twin_split.py`` holds them):
from :mod:`~uavwind.analysis.twin` ``TwinCalibration``, ``BARE``, ``VALIDATION``,
``simulated_flight``, ``simulated_flights``, ``replicate_vehicle``, ``flight_duration``,
``FIGURE8``, ``SIM_SEED``, ``N_SEEDS``, ``DURATION``, ``DT``, ``RAMP`` and ``ERROR_TIME``;
from :mod:`~uavwind.analysis.twin_fit` ``calibrate_twin``, ``held_out_controller``,
``real_force_targets``, ``variability_table``, ``FIT_CONDITION`` and ``SPREAD_CONDITION``;
and ``STUDIES``, ``CONDITIONS``, ``flight_summaries``, ``compute_rows``, ``decided_orders``
and ``noise_columns``, which it imported. They are not in ``__all__`` (each is documented where
it is defined); new code imports them from their own module.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict

import numpy as np
import pandas as pd

from .._version import __version__
from ..data.neuralfly import CONDITIONS
from .memo import memo
from .real_flights import (STUDIES, compute_rows, decided_orders, flight_summaries,
                           noise_columns)
# the twin's names this module uses, and those it re-exports (the module docstring)
from .twin import (BARE, DT, DURATION, ERROR_TIME, FIGURE8, N_SEEDS, RAMP, SIM_SEED, VALIDATION,
                   TwinCalibration, flight_duration, replicate_vehicle, simulated_flight,
                   simulated_flights)
from .twin_fit import (FIT_CONDITION, SPREAD_CONDITION, calibrate_twin, check_integral_spread,
                       check_vertical_share, held_out_controller, real_force_targets,
                       variability_table)

__all__ = ["SIM_VERSION", "sim_rows", "calibration_of", "validation_table", "validation_score",
           "ranking_verdict", "PHYSICAL"]

#: Bump when a change alters the simulated rows. 2: a study that keeps some laps flies only
#: as long as they need (:func:`~uavwind.analysis.twin.flight_duration`). 3: the calibrated
#: twin (gusts that reach it, lift, controller with an integral and a thrust cone, sensor
#: offset and noise). 4: the drag and lift fitted together (Broyden), to the same tolerances.
#: 6: the variability (controller, battery and state-estimate draws per replicate).
#: 7: fitted on every wind (drag, rotor drag and lift on the forces per wind, the errors'
#: correlation time on the still-air position spread).
#: 8: the still-air vertical error's share carried by the vertical velocity estimate, not the
#: thrust, fitted on the position spread at 12.1 m/s (``twin_fit._fit_vertical_share``).
#: 9: the integral gain's spread fitted on the same spread
#: (``twin_fit._fit_integral_spread``), no longer assumed equal to the bandwidth's.
SIM_VERSION = "9"


def _training_digest(real_rows, controllers):
    fl = real_rows[(real_rows["kind"] == "flight") & real_rows["controller"].isin(controllers)]
    cols = ["controller", "condition", "aero_force_x", "aero_force_z", "pitch_deg",
            "fa_x_spread", "pitch_spread", "z_tracking_spread", "tracking_rms", "hover_throttle",
            *noise_columns()] + (["position_spread"] if "position_spread" in fl else [])
    blob = fl[cols].sort_values(["controller", "condition"]).to_json(orient="values",
                                                                      double_precision=15)
    return hashlib.sha256(blob.encode()).hexdigest()


def sim_rows(real_rows: pd.DataFrame, profile: str = "paper", results=None,
             n_jobs: int | None = None, variability: bool = True,
             per_wind: bool = True, pitch_turbulence: bool = False,
             fit_noise: bool = False, vertical_share: float | str = "fit",
             integral_spread: float | str = "fit") -> pd.DataFrame:
    """Experiment 13's simulated rows (the real rows' columns; ``attrs["calibration"]`` the
    :class:`~uavwind.analysis.twin.TwinCalibration` as a dict, ``attrs["held_out"]`` the
    controller it was not fitted on), kept by :func:`uavwind.analysis.memo.memo` under a
    digest of the training controllers' flight rows, the study and the version; a damaged or
    altered copy is recomputed with a warning. ``variability`` False: the twin whose
    replicates differ by gusts and noise alone
    (:func:`~uavwind.analysis.twin_fit.calibrate_twin`'s); ``per_wind`` False: the twin
    fitted at one wind; ``pitch_turbulence``: with the attitude estimate's error in wind (both
    :func:`~uavwind.analysis.twin_fit.calibrate_twin`'s); ``fit_noise`` False: the noise set
    to the training mean, not fitted on the twin's own content; ``vertical_share``: the
    vertical error's share carried by the vertical velocity estimate; ``integral_spread``: the
    integral gain's spread (both :func:`~uavwind.analysis.twin_fit.calibrate_twin`'s)."""
    for name, flag in (("variability", variability), ("per_wind", per_wind),
                       ("pitch_turbulence", pitch_turbulence), ("fit_noise", fit_noise)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    vertical_share = check_vertical_share(vertical_share)
    integral_spread = check_integral_spread(integral_spread)
    if profile not in STUDIES:
        raise ValueError(f"profile must be one of {list(STUDIES)}, got {profile!r}")
    study = STUDIES[profile]
    everyone = sorted(set(real_rows.loc[real_rows["kind"] == "flight", "controller"]))
    held = held_out_controller(everyone)
    train = [c for c in everyone if c != held]
    conditions = tuple(c for c in CONDITIONS if not study.conditions or c in study.conditions
                       or c in (FIT_CONDITION, SPREAD_CONDITION))

    def compute():
        cal = calibrate_twin(real_rows, study, train, variability=variability,
                             per_wind=per_wind, pitch_turbulence=pitch_turbulence,
                             fit_noise=fit_noise, vertical_share=vertical_share,
                             integral_spread=integral_spread)
        flights = simulated_flights(cal, conditions=conditions, duration=flight_duration(study))
        df = compute_rows(flights, study, n_jobs=n_jobs, estimate=False)  # the page: real only
        df.attrs.update(profile=profile, calibration=json.dumps(cal.to_dict()), held_out=held,
                        uavwind_version=__version__)
        return df

    return memo("exp13_sim", {"training": _training_digest(real_rows, train), "held_out": held,
                              "study": asdict(study), "seed": SIM_SEED, "n_seeds": N_SEEDS,
                              "version": SIM_VERSION, "variability": variability,
                              "per_wind": per_wind, "pitch_turbulence": pitch_turbulence}
                | ({"fit_noise": True} if fit_noise else {})
                | ({"vertical_share": vertical_share} if vertical_share != "fit" else {})
                | ({"integral_spread": integral_spread} if integral_spread != "fit" else {}),
                compute, results)


def calibration_of(sim: pd.DataFrame) -> TwinCalibration:
    """The :class:`~uavwind.analysis.twin.TwinCalibration` :func:`sim_rows` fitted (from its
    ``attrs``)."""
    d = json.loads(sim.attrs["calibration"])
    d["noise"] = tuple(tuple(x) for x in d["noise"])
    return TwinCalibration(**d)


def validation_table(real_rows: pd.DataFrame, sim: pd.DataFrame) -> pd.DataFrame:
    """The twin against the real flights, per wind and quantity
    (:data:`~uavwind.analysis.twin.VALIDATION`): the twin's mean over its seeds (``sim``)
    with their range, the held-out controller's value
    (``held_out``), the training controllers' range, mean and spread (``train_sd``, SD),
    ``within`` (the twin inside the range of all the real controllers), ``fitted`` (the twin
    was fitted on this quantity at this wind, or on its training mean, so only the held-out
    column checks it), and against the trivial model: ``twin_error`` and ``trivial_error``
    (the twin's and the training mean's error on the held-out controller, scaled by
    ``train_sd``) and ``twin_closer``."""
    held = sim.attrs.get("held_out")
    fitted = {("force along x", FIT_CONDITION), ("force along z", FIT_CONDITION),
              ("lean", "nowind"), ("lap-to-lap spread of force x", SPREAD_CONDITION)}
    if "calibration" in sim.attrs:
        cal = calibration_of(sim)
        fitted |= set(cal.fitted_on)  # the per-wind fits' targets
        if cal.varies:  # the errors' targets
            fitted |= {("lap-to-lap spread of pitch", "nowind"),
                       ("lap-to-lap spread of force x", "nowind"),
                       ("lap-to-lap spread of vertical tracking", "nowind")}
    fitted |= {(q, c) for q in ("noise of force x", "noise of the attitude x") for c in CONDITIONS}
    out = []
    real_f = real_rows[real_rows.kind == "flight"]
    sim_f = sim[sim.kind == "flight"]

    def values(df, col, minus):
        v = df.set_index(["controller", "condition"])[col]
        if minus:
            base = v.xs("nowind", level="condition")
            v = v - base.reindex(v.index.get_level_values("controller")).to_numpy()
        return v

    for name, (col, minus, unit) in VALIDATION.items():
        rv, sv = values(real_f, col, minus), values(sim_f, col, minus)
        for cond in CONDITIONS:
            if minus and cond == "nowind":  # 0 by construction: the rows it is measured from
                continue
            if cond not in sv.index.get_level_values("condition") or \
                    cond not in rv.index.get_level_values("condition"):
                continue
            r = rv.xs(cond, level="condition")
            s = sv.xs(cond, level="condition")
            train = r.drop(held, errors="ignore")
            h = float(r.get(held, np.nan))
            sd = float(train.std(ddof=1)) if len(train) > 1 else np.nan
            scale = sd if sd > 0 else np.nan
            out.append({"condition": cond, "wind_speed": CONDITIONS[cond], "quantity": name,
                        "unit": unit, "sim": float(s.mean()), "sim_min": float(s.min()),
                        "sim_max": float(s.max()),
                        "held_out": h,
                        "train_min": float(train.min()), "train_max": float(train.max()),
                        "train_mean": float(train.mean()), "train_sd": sd,
                        "twin_error": (float(s.mean()) - h) / scale,
                        "trivial_error": (float(train.mean()) - h) / scale,
                        "real_min": float(r.min()), "real_max": float(r.max()),
                        "within": bool(r.min() <= s.mean() <= r.max()),
                        "fitted": (name, cond) in fitted})
    df = pd.DataFrame(out)
    if len(df):
        df["twin_closer"] = df["twin_error"].abs() < df["trivial_error"].abs()
    return df


#: The quantities of :data:`~uavwind.analysis.twin.VALIDATION` that are the vehicle's physics
#: (tracking error is the controller's own): what :func:`validation_score` averages.
PHYSICAL = ("force along x", "force along z", "lean", "lap-to-lap spread of force x",
            "lap-to-lap spread of pitch", "lap-to-lap spread of vertical tracking",
            "lap-to-lap spread of position", "noise of force x", "noise of the attitude x")


def validation_score(table: pd.DataFrame, predicted_only: bool = False) -> dict:
    """The twin against the trivial model (the training controllers' mean) on the held-out
    controller, over the :data:`PHYSICAL` rows of :func:`validation_table` (with
    ``predicted_only``, only those the twin was not fitted on): ``twin`` and ``trivial``, the
    mean absolute error scaled by the training controllers' spread (SD); ``wins``, the rows
    where the twin is the closer; ``n``, the rows scored."""
    t = table[table["quantity"].isin(PHYSICAL) & table["twin_error"].notna()
              & table["trivial_error"].notna()]
    if predicted_only:
        t = t[~t["fitted"]]
    return {"twin": float(t["twin_error"].abs().mean()) if len(t) else np.nan,
            "trivial": float(t["trivial_error"].abs().mean()) if len(t) else np.nan,
            "wins": int(t["twin_closer"].sum()), "n": len(t)}


def ranking_verdict(real_channels: pd.DataFrame, sim_channels: pd.DataFrame,
                    tie: float = 1.0) -> dict:
    """Does the simulation rank the channels as the real flights do?

    Every pair of channels the real flights can order (their CIs over controllers do not
    overlap) is checked in the simulation: ``agree`` (same order, means more than ``tie``
    points apart), ``disagree`` (the other order) or ``sim_tied`` (within ``tie`` points).
    ``verdict`` is ``"yes"`` if every orderable pair agrees, ``"no"`` if any disagrees, else
    ``"cannot decide"``. Spearman's rho of the two rankings, with its 95% interval
    (``spearman_low``, ``spearman_high``: Fisher's z with Fieller, Hartley and Pearson's
    standard error ``sqrt(1.06 / (n - 3))``, NaN below 4 channels), and the best channels
    are given beside it."""
    r = real_channels.set_index("channel")
    s = sim_channels.set_index("channel").reindex(r.index)
    rr, sr = r["mean"].rank(ascending=False), s["mean"].rank(ascending=False)
    n = len(rr)
    rho = float(1 - 6 * ((rr - sr) ** 2).sum() / (n * (n * n - 1))) if n > 2 else float("nan")
    if n > 3 and abs(rho) < 1:
        z, se = np.arctanh(rho), np.sqrt(1.06 / (n - 3))
        rho_ci = (float(np.tanh(z - 1.96 * se)), float(np.tanh(z + 1.96 * se)))
    else:  # too few channels, or a perfect (anti)correlation: no interval from Fisher's z
        rho_ci = (np.nan, np.nan)
    order = list(r.sort_values("mean", ascending=False).index)
    decided = set(decided_orders(real_channels))
    agree, disagree, tied, unordered = [], [], [], []
    for i, a in enumerate(order):
        for b in order[i + 1:]:  # a above b in the real flights
            if (a, b) not in decided:
                unordered.append((a, b))
                continue
            d = s.loc[a, "mean"] - s.loc[b, "mean"]
            (agree if d > tie else disagree if d < -tie else tied).append((a, b))
    verdict = "no" if disagree else "yes" if agree and not tied else "cannot decide"
    return {"verdict": verdict, "agree": agree, "disagree": disagree, "sim_tied": tied,
            "real_unordered": unordered, "spearman": rho, "spearman_low": rho_ci[0],
            "spearman_high": rho_ci[1], "top_real": order[0],
            "top_sim": s["mean"].idxmax(), "real_order": order,
            "sim_order": list(s["mean"].sort_values(ascending=False).index)}
