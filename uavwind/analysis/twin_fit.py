"""The real-flight twin's calibration: a :class:`~uavwind.analysis.twin.TwinCalibration`
fitted on the training controllers' flight rows.

This module owns :func:`calibrate_twin` (the whole fit, in order), :func:`held_out_controller`
(the controller the twin is not fitted on, the one it is checked on),
:func:`real_force_targets` (the training controllers' mean forces, lean and spread the first
twin meets), the two winds the first twin is fitted at (:data:`FIT_CONDITION`,
:data:`SPREAD_CONDITION`), :func:`variability_table` (each fitted source of variability, its
value and what fixes it), :func:`check_vertical_share` and :func:`check_integral_spread` (the
two arguments given or fitted, checked the same way here and by
:func:`~uavwind.analysis.figure8.sim_rows`, whose cache key they enter), and the fits
themselves, one private function each: the drag, rotor drag and lift on the forces (at every
wind, ``_fit_forces_per_wind``, or at one, ``_fit_forces``), the gusts on the force's
lap-to-lap spread at 12.1 m/s (``_fit_gusts``), the battery and the controller's bandwidth
(``_fit_variability``), the state errors' sizes (``_fit_errors``) and their correlation time
(``_fit_error_time``) on the still-air spreads, the vertical error's share
(``_fit_vertical_share``) and the integral gain's spread (``_fit_integral_spread``) on the
position's spread at 12.1 m/s, the attitude estimate's error in wind
(``_fit_turbulence_tilt``) and the recorded noise (``_fit_noise``).

Every fit flies the twin (:func:`~uavwind.analysis.twin.simulated_flight`) and reads its
flight rows as the real ones are read (:func:`~uavwind.analysis.real_flights.flight_summaries`);
only the training controllers' flights enter. What the twin is and how it flies is
:mod:`uavwind.analysis.twin`'s; its cached rows and its validation are
:mod:`uavwind.analysis.figure8`'s.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from ..core.checks import check_scalar
from ..data.neuralfly import CONDITIONS
from .real_flights import STUDIES, flight_summaries, noise_columns
from .twin import ERROR_TIME, N_SEEDS, TwinCalibration, flight_duration, simulated_flight

__all__ = ["FIT_CONDITION", "SPREAD_CONDITION", "calibrate_twin", "held_out_controller",
           "real_force_targets", "variability_table", "check_vertical_share",
           "check_integral_spread"]

#: The one wind the forces (drag and lift) are fitted on: 8.5 m/s, where both are well above
#: the still-air residual; 4.2 and 12.1 m/s are predictions.
FIT_CONDITION = "70wind"
#: The one wind the gust intensity is fitted on (the largest spread, the most signal).
SPREAD_CONDITION = "100wind"
#: Laps a calibration flight keeps (the twin's laps differ only by its gusts: three give
#: its means and its lap-to-lap spread; the real targets average every lap they keep).
_FIT_LAPS = 3
#: Most Newton-Broyden steps of the joint drag and lift fit (three to five suffice: the forces
#: are close to linear in the two factors on the twin's closed-loop laps).
_STEPS = 12
#: Reference sizes of the state errors the fit starts from: attitude [deg], thrust [-],
#: velocity [m/s].
_ERROR_START = (0.5, 0.01, 0.02)


def held_out_controller(controllers) -> str:
    """The controller the twin is checked on: the last in name order (``"indi"`` among
    Neural-Fly's five); the others are the training controllers."""
    controllers = sorted(controllers)
    if len(controllers) < 2:
        raise ValueError(f"controllers must hold at least two (one to fit on, one to check), "
                         f"got {controllers}")
    return controllers[-1]


def real_force_targets(real_rows: pd.DataFrame, controllers, condition: str = FIT_CONDITION
                       ) -> dict[str, float]:
    """The training ``controllers``' mean force along x and along z at ``condition`` minus
    each one's at 0 m/s [N], their mean lean at 0 m/s [deg] and their mean lap-to-lap spread
    of the force along x at :data:`SPREAD_CONDITION` [N]."""
    fl = real_rows[real_rows["kind"] == "flight"].set_index(["controller", "condition"])
    ctl = sorted(controllers)
    need = [(c, cond) for c in ctl for cond in ("nowind", condition, SPREAD_CONDITION)]
    missing = [k for k in need if k not in fl.index]
    if missing:  # e.g. a data folder without the 70 or 100 wind flights
        raise ValueError(
            "the twin's calibration needs each training controller's flight at 0 m/s "
            f"('nowind'), at {condition!r} and at {SPREAD_CONDITION!r}; real_rows has no "
            "flight row for (controller, condition) "
            + ", ".join(f"({c!r}, {cond!r})" for c, cond in missing[:6])
            + (f" and {len(missing) - 6} more" if len(missing) > 6 else ""))

    def mean(col, cond, minus=None):
        return float(np.mean([fl.loc[(c, cond), col] - (fl.loc[(c, minus), col] if minus else 0.0)
                              for c in ctl]))

    return {"force_x": mean("aero_force_x", condition, "nowind"),
            "force_z": mean("aero_force_z", condition, "nowind"),
            "offset": mean("pitch_deg", "nowind"),
            "spread": mean("fa_x_spread", SPREAD_CONDITION)}


def _twin_row(cal, condition, study, seed=0):
    """One twin flight's flight row (:func:`uavwind.analysis.real_flights.compute_rows`' kind
    ``"flight"``) over the laps ``study`` keeps."""
    f = simulated_flight(cal.vehicle(), condition, seed, flight_duration(study), cal)
    return flight_summaries([f], study)[0]


def _secant(measure, target, x0, x1, low, high, tol, what):
    """``x`` in [low, high] with ``measure(x) = target`` to ``tol`` (absolute), by secant
    steps from ``x0`` and ``x1``."""
    f0 = measure(x0)
    for _ in range(10):
        f1 = measure(x1)
        if abs(f1 - target) <= tol:
            return float(x1)
        if f1 == f0:
            break
        x0, f0, x1 = x1, f1, min(max(x1 + (target - f1) * (x1 - x0) / (f1 - f0), low), high)
    raise ValueError(f"the twin's {what} fit did not converge (last {x1:g}, measured {f1:g}, "
                     f"target {target:g})")


def calibrate_twin(real_rows: pd.DataFrame, study=STUDIES["paper"],
                   controllers=None, variability: bool = True,
                   per_wind: bool = True, pitch_turbulence: bool = False,
                   fit_noise: bool = False, vertical_share: float | str = "fit",
                   integral_spread: float | str = "fit") -> TwinCalibration:
    """Fit the twin on ``controllers``' flights (default: all but
    :func:`held_out_controller`), from their flight rows in ``real_rows``
    (:func:`uavwind.analysis.real_flights.compute_rows`).

    In order: the sensor axis offset (their mean lean at 0 m/s) and the noise (their mean
    per wind and channel), read off the rows; then on twin flights of gust seed 0 (over at
    most three of the laps ``study`` keeps for the forces, over all of them for the spread):
    the drag and lift scales together (:func:`_fit_forces`: the force along x at
    :data:`FIT_CONDITION` minus at 0 m/s to 0.5%, the same along z to 0.02 N), then the gust
    scale by secant steps (lap-to-lap spread at :data:`SPREAD_CONDITION`, to 2%).

    With ``variability`` (the default) the replicates are controllers and flights drawn from
    the training controllers' spread (:func:`_fit_variability`), and the gust scale is fitted
    on the mean spread over :data:`~uavwind.analysis.twin.N_SEEDS` such replicates, with
    their noise; without it, the twin of gusts and noise alone, its gusts fitted on seed 0
    without noise.

    With ``per_wind`` (the default) the fit uses every wind the training flights have,
    not one: the drag, the rotor drag and the lift on the mean forces at every wind
    (:func:`_fit_forces_per_wind`), and with ``variability`` the errors' correlation time on
    the still-air position spread (:func:`_fit_error_time`), and with ``pitch_turbulence``
    the attitude estimate's error in wind on the pitch spread at every wind
    (:func:`_fit_turbulence_tilt`), before the gusts. ``per_wind`` False: the first twin
    (forces at :data:`FIT_CONDITION` alone, the correlation time
    :data:`~uavwind.analysis.twin.ERROR_TIME` assumed), to the double.

    ``pitch_turbulence`` is off by default: on the Neural-Fly flights it brings the pitch's
    spread at 12.1 m/s into the real range but not at 8.5 m/s, and it raises the force's
    spread at 4.2 m/s and in the sinusoidal wind beyond the real ones (the estimate's error
    enters ``fa``), so the twin's mean scaled error grows (paper profile, 1.27 without it,
    1.39 with it; on SIM_VERSION 8's twin 1.155 without, 1.331 with, quick 0.805 and 0.801;
    ``benchmarks/twin_score.py``).

    With ``fit_noise`` the recorded noise is fitted last, on the finished twin
    (:func:`_fit_noise`): what it adds to each channel is what the training controllers'
    noise leaves once the twin's own motion above the cutoff is counted. Off by default: the
    twin's attitude noise then equals the training mean wherever it can, which is the trivial
    model's error there, and the held-out controller is noisier than the training mean in
    wind, where the twin's excess had been closer to it. On the twin of SIM_VERSION 7 it
    worsened the mean scaled error (paper profile 1.27 -> 1.30, quick 0.88 -> 0.90); on
    SIM_VERSION 8's it moves it by less than a hundredth (paper 1.155 -> 1.147, quick 0.805
    -> 0.807): no gain worth a further fit.

    ``vertical_share`` (in [0, 1]; 0: the thrust error alone, the twin of SIM_VERSION 7, to
    the double) is the share of the still-air vertical error's variance carried by an error
    of the vertical velocity estimate instead of the thrust (:func:`_vertical_fields`): both
    make the height wander in still air, where the fit cannot tell them apart, but leaning
    into a strong wind a relative thrust error pushes along x too (``T sin(tilt)``, about
    half of it at 12.1 m/s) and enters ``fa`` (computed from the commanded thrust), where a
    velocity error stays vertical. ``"fit"`` (the default) fits it, with ``per_wind`` and
    ``variability``, on the training controllers' position spread at 12.1 m/s
    (:func:`_fit_vertical_share`; else 0). On the Neural-Fly flights the fit takes the
    bound 1 (the twin's spread there stays above theirs at every share) and the mean scaled
    error falls (paper profile 1.27 -> 1.16, trivial 1.23; quick 0.88 -> 0.80, trivial 0.85;
    ``benchmarks/twin_score.py``): the thrust error had also widened the force's spread in
    wind and biased the vertical force at 12.1 m/s.

    ``integral_spread`` (a log-SD in [0, 2]; ``"bandwidth"``: the bandwidth's own, the twin
    of SIM_VERSION 8, to the double) is the spread of a replicate's integral gain beyond its
    bandwidth's; ``"fit"`` (the default) fits it, with ``per_wind`` and ``variability``, on
    the training controllers' position spread at 12.1 m/s after the vertical share, the
    gusts refitted at each value (:func:`_fit_integral_spread`; else the bandwidth's). On
    the Neural-Fly flights it takes the bound 0 (the twin's spread there stays above theirs):
    a replicate drawn with a slow integral no longer drags its start-up transient into the
    kept laps, the position's spread at 12.1 m/s falls (paper profile 0.039 -> 0.033 m,
    training mean 0.026) and so does the mean scaled error (paper 1.155 -> 1.136, trivial
    1.232; quick 0.805 -> 0.775, trivial 0.854; ``benchmarks/twin_score.py``). The pitch's
    spread in wind does not move (0.71 deg at 8.5 m/s, paper; real 0.91-1.50):
    ``benchmarks/twin_pitch_spectrum.py`` shows why."""
    for name, flag in (("per_wind", per_wind), ("pitch_turbulence", pitch_turbulence),
                       ("fit_noise", fit_noise)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    vertical_share = check_vertical_share(vertical_share)
    integral_spread = check_integral_spread(integral_spread)
    if study.max_laps == 1:
        raise ValueError("study must keep at least two laps a flight (max_laps 0 or >= 2): the "
                         "gust fit matches a lap-to-lap spread")
    fl = real_rows[real_rows["kind"] == "flight"]
    if controllers is None:
        everyone = sorted(set(fl["controller"]))
        controllers = [c for c in everyone if c != held_out_controller(everyone)]
    controllers = tuple(sorted(controllers))
    target = real_force_targets(real_rows, controllers)
    train = fl[fl["controller"].isin(controllers)]
    noise = tuple((c, col, float(g[col].mean())) for c, g in train.groupby("condition", sort=False)
                  for col in noise_columns())
    cal = TwinCalibration(axis_offset=target["offset"], noise=noise, controllers=controllers)
    quiet = replace(cal, noise=())  # the forces and the spread are fitted without noise
    # the forces are means: the twin's laps repeat, a few give them; the spread about the mean
    # lap depends on how many laps it is taken over, so the gusts fly the study's own laps
    few = (replace(study, max_laps=_FIT_LAPS) if study.max_laps == 0
           or study.max_laps > _FIT_LAPS else study)

    if per_wind:
        drag, lift, rotor = _fit_forces_per_wind(quiet, _force_targets(train), few)
        windy = tuple(c for c in CONDITIONS if c in set(train["condition"]) and c != "nowind")
        cal = replace(cal, rotor_drag_scale=rotor, fitted_on=tuple(
            (q, c) for q in ("force along x", "force along z") for c in windy))
        quiet = replace(quiet, rotor_drag_scale=rotor)
    else:
        drag, lift = _fit_forces(quiet, target, few)
    quiet = replace(quiet, drag_scale=drag, lift_scale=lift)
    if variability:
        fixed = integral_spread if isinstance(integral_spread, float) else None

        def build(share):
            c = _fit_variability(replace(cal, drag_scale=drag, lift_scale=lift), train, study,
                                 per_wind, pitch_turbulence and per_wind, share, fixed)
            return replace(c, gust_scale=_fit_gusts(c, target["spread"], study))

        if vertical_share == "fit":
            cal = _fit_vertical_share(build, train, study) if per_wind else build(0.0)
        else:
            cal = build(vertical_share)
        if integral_spread == "fit" and per_wind:
            done = cal

            def regust(x):  # the same twin with the integral's spread x, its gusts refitted
                c = replace(done, integral_spread=float(x), gust_scale=0.0)
                return replace(c, gust_scale=_fit_gusts(c, target["spread"], study))

            cal = _fit_integral_spread(regust, train, study, done.gain_spread)
        return _fit_noise(cal, study) if fit_noise else cal

    def spread(g):
        return _twin_row(replace(quiet, gust_scale=g), SPREAD_CONDITION, study)["fa_x_spread"]

    gust = _secant(spread, target["spread"], 0.1, 0.3, 0.0, 10.0, 0.02 * target["spread"],
                   "gust")
    cal = replace(cal, drag_scale=drag, lift_scale=lift, gust_scale=gust)
    return _fit_noise(cal, study) if fit_noise else cal


def _fit_noise(cal, study):
    """``cal`` with the recorded noise refitted: each channel's and wind's added white noise
    the SD whose square is the target's (``cal.noise``, the training controllers' mean noise
    there) minus the twin's own content above the noise cutoff (mean square over
    :data:`N_SEEDS` replicates of ``cal`` flown without noise), 0 where the twin's own
    content already reaches the target.

    Why: a channel's noise (:func:`uavwind.analysis.real_flights.noise_columns`) is all its
    content above the 2 Hz cutoff, and the twin has some of its own before any noise is
    added: the controller answers its velocity estimate's error (a second-order Gauss-Markov
    process, a few per cent of whose variance lies above 2 Hz) with attitude commands the
    attitude loop follows well above 2 Hz, and the gusts shake it in wind. In still air that
    content alone (0.0017 in the attitude's x at the quick profile) is above the training
    controllers' mean noise (0.0010), so adding their mean on top put the twin's attitude
    noise above every real controller's. Independent sources' variances add, so the
    subtraction is exact up to the replicates' sampling. Only the training controllers'
    noise enters (``cal.noise``)."""
    quiet = replace(cal, noise=())
    out = []
    for cond in dict.fromkeys(c for c, _, _ in cal.noise):
        rows = [_twin_row(quiet, cond, study, seed) for seed in range(N_SEEDS)]
        for c, col, std in cal.noise:
            if c == cond:
                own = float(np.mean([r[col] ** 2 for r in rows]))
                out.append((c, col, float(np.sqrt(max(std ** 2 - own, 0.0)))))
    return replace(cal, noise=tuple(out))


def check_vertical_share(vertical_share) -> float | str:
    """``vertical_share`` (:func:`calibrate_twin`'s, :func:`~uavwind.analysis.figure8.sim_rows`')
    checked: ``"fit"`` or a number in [0, 1] (as a float); else a ``ValueError`` or
    ``TypeError`` naming it."""
    if isinstance(vertical_share, str):
        if vertical_share != "fit":
            raise ValueError(f"vertical_share must be a number in [0, 1] or 'fit', got "
                             f"{vertical_share!r}")
        return vertical_share
    return check_scalar(vertical_share, "vertical_share", low=0.0, high=1.0)


def check_integral_spread(integral_spread) -> float | str:
    """``integral_spread`` (:func:`calibrate_twin`'s, :func:`~uavwind.analysis.figure8.sim_rows`')
    checked: ``"fit"``, ``"bandwidth"`` (the bandwidth's own spread, the twin of SIM_VERSION
    8) or a log-SD in [0, 2] (as a float); else a ``ValueError`` or ``TypeError`` naming it."""
    if isinstance(integral_spread, str):
        if integral_spread not in ("fit", "bandwidth"):
            raise ValueError(f"integral_spread must be a number in [0, 2], 'fit' or "
                             f"'bandwidth', got {integral_spread!r}")
        return integral_spread
    return check_scalar(integral_spread, "integral_spread", low=0.0, high=2.0)


def _fit_integral_spread(build, train, study, high):
    """The twin ``build(x)`` (its integral gain's log-SD ``x``, the rest fitted,
    :func:`calibrate_twin`) whose lap-to-lap spread of position at :data:`SPREAD_CONDITION`
    (mean over :data:`N_SEEDS` replicates) is the training controllers' mean there
    (``train``), to 5%, by secant steps on ``x`` within [0, ``high``] (``high``: the
    bandwidth's spread, what SIM_VERSION 8 assumed); at a bound when the twin's spread stays
    on one side of it. Tried from ``high`` first, then 0.

    Why: the integral's spread was assumed equal to the bandwidth's, the flight rows telling
    the two apart nowhere but here. A replicate whose integral gain is drawn low absorbs the
    mean drag slowly: at 12.1 m/s (16 N of it) its start-up transient runs on over the laps
    the record keeps (the slowest of SIM_VERSION 8's five, its integral gain 0.45 times the
    preset's, flown without any other error flew its first kept lap 105 mm off its laps'
    mean x; no real controller's lap is more than 15 mm off theirs), which only the
    position's spread in a strong wind shows. Only the training
    controllers' flights fix it; it is fitted after the vertical share, on the same target,
    so where both take a bound the twin's spread there stays above theirs either way."""
    return _fit_on_position_spread(build, train, study, first=high, other=0.0, falls=False,
                                   what="integral spread",
                                   instead="integral_spread='bandwidth'")


def _fit_vertical_share(build, train, study):
    """The twin ``build(share)`` (fitted at a vertical share, :func:`calibrate_twin`) whose
    lap-to-lap spread of position at :data:`SPREAD_CONDITION` (mean over :data:`N_SEEDS`
    replicates) is the training controllers' mean there (``train``), to 5%, by secant steps
    on the share within [0, 1]; at a bound when the twin's spread stays on one side of it.
    Tried from 1 (the velocity estimate alone) first: on the Neural-Fly flights the twin's
    spread there (0.035 m at the quick profile) is still above theirs (0.025 m), so the fit
    takes the bound after one twin.

    Why the position at 12.1 m/s: the still-air spreads fix the vertical error's size but not
    where it sits; leaning 29 deg into that wind, a thrust error's share of the thrust
    pushes along x, a vertical velocity error does not, so only the position spread in a
    strong wind tells them apart. Only the training controllers' flights fix it."""
    return _fit_on_position_spread(build, train, study, first=1.0, other=0.0, falls=True,
                                   what="vertical share", instead="vertical_share=0.0")


def _fit_on_position_spread(build, train, study, *, first, other, falls, what, instead):
    """The twin ``build(x)`` whose lap-to-lap spread of position at :data:`SPREAD_CONDITION`
    (mean over :data:`N_SEEDS` replicates) is the training controllers' mean there
    (``train``), to 5%, by secant steps on ``x`` between the bounds ``first`` and ``other``:
    ``first`` tried first and kept when even it leaves the twin's spread on the far side
    (``falls``: the spread falls from ``other`` to ``first``), then ``other`` likewise. The
    fits of :func:`_fit_vertical_share` and :func:`_fit_integral_spread`; ``what`` names the
    fit and ``instead`` the ``calibrate_twin`` argument that does without it."""
    at = train[train["condition"] == SPREAD_CONDITION]
    target = float(at["position_spread"].mean()) if "position_spread" in at else np.nan
    if not np.isfinite(target):
        raise ValueError(f"the {what}'s fit needs the training flights' position spread at "
                         f"{SPREAD_CONDITION!r} (or calibrate_twin(..., {instead}))")
    tried, got = {}, {}

    def measure(x):
        if x not in tried:  # a twin per value: the secant starts from the bounds tried
            tried[x] = build(float(x))
            got[x] = float(_replicate_mean(tried[x], SPREAD_CONDITION, study,
                                           ("position_spread",))[0])
        return got[x]

    def done(c):
        key = ("lap-to-lap spread of position", SPREAD_CONDITION)
        return c if key in c.fitted_on else replace(c, fitted_on=c.fitted_on + (key,))

    sign = 1.0 if falls else -1.0  # beyond: the twin's spread on the far side of the target
    if sign * (measure(first) - target) >= 0:
        return done(tried[first])
    if sign * (measure(other) - target) <= 0:
        return done(tried[other])
    low, high = min(first, other), max(first, other)
    x0, x1 = (other, first) if falls else (first, other)
    return done(tried[_secant(measure, target, x0, x1, low, high, 0.05 * target, what)])


def _replicate_mean(cal, condition, study, columns):
    """The mean over :data:`N_SEEDS` replicates of the twin ``cal`` at ``condition`` of each
    flight-row column of ``columns``."""
    rows = [_twin_row(cal, condition, study, seed) for seed in range(N_SEEDS)]
    return np.array([np.mean([r[c] for r in rows]) for c in columns])


#: What the within-flight errors are fitted on: the training controllers' mean of these
#: flight-row columns in still air, where the twin has no gusts.
_ERROR_TARGETS = ("pitch_spread", "fa_x_spread", "z_tracking_spread")


def _fit_variability(cal, train, study, per_wind=False, pitch_turbulence=False,
                     vertical_share=0.0, integral_spread=None):
    """``cal`` with the variability fitted on the training controllers' flight rows
    ``train``:

    * the battery: the mean and SD of their flights' hover throttle;
    * the controller: the bandwidth's log-SD so that the twin's tracking error in still air
      spreads (log-SD) as theirs does, through the twin's own sensitivity of the log
      tracking error to the log bandwidth (two flights); the integral gain's log-SD set to
      the same here (``integral_spread`` None; a number sets it), :func:`calibrate_twin`
      fitting it last (:func:`_fit_integral_spread`);
    * within the flight: the SDs of the attitude, thrust and velocity errors so that the
      twin's lap-to-lap spreads of pitch, force along x and vertical tracking in still air
      (mean over :data:`N_SEEDS` replicates, with their noise) match the training mean:
      the spreads' squares are close to linear in the errors' variances (independent
      sources add), so one flight set per error at a reference size gives the map, a
      non-negative least-squares solve the variances, and up to three rounds correct it on
      the combined twin (:func:`_fit_errors`);
    * with ``per_wind``: the errors' correlation time so that the twin's lap-to-lap spread
      of position in still air matches theirs, the errors refitted at each
      (:func:`_fit_error_time`); with ``pitch_turbulence`` too, the attitude estimate's
      error in wind on their pitch spread at every wind (:func:`_fit_turbulence_tilt`)."""
    need = ["hover_throttle", "tracking_rms", *_ERROR_TARGETS]
    missing = [c for c in need if c not in train.columns or train[c].isna().any()]
    if missing:
        raise ValueError(f"real_rows must hold the training flights' {missing} to fit the "
                         f"twin's variability (real_flights.compute_rows gives them), or call "
                         f"calibrate_twin(..., variability=False)")
    still = train[train["condition"] == "nowind"]
    cal = replace(cal, hover_throttle=float(train["hover_throttle"].mean()),
                  hover_throttle_sd=float(train["hover_throttle"].std(ddof=1)))
    base = replace(cal, noise=())
    log_track = np.log(still["tracking_rms"].to_numpy())
    step = 0.25
    t0, t1 = (_sensitivity_row(base, 0.0, study)["tracking_rms"],
              _sensitivity_row(base, step, study)["tracking_rms"])
    slope = -(np.log(t1) - np.log(t0)) / step
    if not slope > 0:
        raise ValueError(f"the twin's tracking error does not fall as its bandwidth grows "
                         f"(slope {slope:g}): no gain spread can be fitted from it")
    spread = float(np.std(log_track, ddof=1) / slope)
    cal = replace(cal, gain_spread=spread,
                  integral_spread=spread if integral_spread is None else integral_spread)
    if not per_wind:
        return _fit_errors(cal, still, study, vertical_share)
    cal = _fit_error_time(cal, still, study, vertical_share)
    return _fit_turbulence_tilt(cal, train, study) if pitch_turbulence else cal


def _vertical_fields(size, share):
    """The thrust error [-] and the vertical velocity-estimate error [m/s] of a vertical error
    of SD ``size``, ``share`` of its variance carried by the velocity (one share of thrust
    counted as one metre per second: in still air the twin's height wanders about as much
    for either, 0.009-0.010 m lap to lap at 0.03). ``share`` 0 is the thrust error alone,
    ``size`` itself, to the double."""
    if share == 0.0:
        return {"thrust_error": size}
    return {"thrust_error": size * float(np.sqrt(1.0 - share)),
            "vertical_velocity_error": size * float(np.sqrt(share))}


def _fit_errors(cal, still, study, vertical_share=0.0):
    """``cal`` with the SDs of the attitude, thrust and velocity errors fitted on the
    training controllers' still-air flight rows ``still`` (:func:`_fit_variability`), at
    ``cal.error_time``; the vertical one split between the thrust and the vertical velocity
    estimate by ``vertical_share`` (:func:`_vertical_fields`)."""
    from scipy.optimize import nnls

    cal = replace(cal, attitude_error=0.0, thrust_error=0.0, velocity_error=0.0,
                  vertical_velocity_error=0.0)

    def sizes(values):
        out = {"attitude_error": values[0], "velocity_error": values[2]}
        return out | _vertical_fields(values[1], vertical_share)
    goal = still[list(_ERROR_TARGETS)].mean().to_numpy() ** 2
    zero = _replicate_mean(cal, "nowind", study, _ERROR_TARGETS) ** 2
    C = np.empty((3, 3))
    for j, ref in enumerate(_ERROR_START):
        one = [0.0, 0.0, 0.0]
        one[j] = ref
        m = _replicate_mean(replace(cal, **sizes(one)), "nowind", study, _ERROR_TARGETS) ** 2
        C[:, j] = (m - zero) / ref ** 2
    C = np.maximum(C, 0.0)
    for _ in range(4):
        var, _ = nnls(C, np.maximum(goal - zero, 0.0))
        fitted = replace(cal, **sizes([float(np.sqrt(v)) for v in var]))
        got = _replicate_mean(fitted, "nowind", study, _ERROR_TARGETS) ** 2
        if np.all(np.abs(np.sqrt(got) - np.sqrt(goal)) <= 0.05 * np.sqrt(goal)):
            break
        pred = C @ var
        C = C * np.where(pred > 0, (got - zero) / np.where(pred > 0, pred, 1.0), 1.0)[:, None]
        C = np.maximum(C, 0.0)
    return fitted


def _fit_error_time(cal, still, study, vertical_share=0.0):
    """``cal`` with the errors' correlation time fitted on the training controllers'
    still-air lap-to-lap spread of position (``still``'s mean, to 3%), their SDs refitted
    (:func:`_fit_errors`) at each time tried, by secant steps on its logarithm from
    :data:`~uavwind.analysis.twin.ERROR_TIME`, within [0.02, 2] s.

    Why the position: the errors' sizes are fitted on the spreads of pitch, force and vertical
    tracking, which a slow error and a fast one of another size can both meet; the position
    integrates the errors twice, so its spread grows with their correlation time (from 0.015
    to 0.024 m as the time goes from 0.1 to 0.4 s, the errors' sizes held) and tells the two
    apart. Only the training controllers' still-air flights fix it (the held-out
    controller's and the windy flights' position spreads stay predictions)."""
    target = float(still["position_spread"].mean())
    tried = {}

    def measure(log_tau):
        fitted = _fit_errors(replace(cal, error_time=float(np.exp(log_tau))), still, study,
                             vertical_share)
        got = float(_replicate_mean(fitted, "nowind", study, ("position_spread",))[0])
        tried[log_tau] = fitted
        return got

    x0 = float(np.log(ERROR_TIME))
    best = _secant(measure, target, x0, x0 + np.log(1.5), np.log(0.02), np.log(2.0),
                   0.03 * target, "error time")
    return replace(tried[best], fitted_on=cal.fitted_on + (
        ("lap-to-lap spread of position", "nowind"),))


def _fit_turbulence_tilt(cal, train, study):
    """``cal`` with the turbulence's tilt (:attr:`TwinCalibration.turbulence_tilt`) fitted on
    the training controllers' mean lap-to-lap spread of pitch at every wind their rows
    hold (``train``), each wind's miss scaled by their SD there, least squares.

    The twin's squared spread is close to linear in the tilt's variance (independent sources
    add): ``p_w^2 = p0_w^2 + S_w k^2`` with ``p0`` the twin without it and ``S`` measured at a
    reference size; the scaled misses are minimised over ``k`` on that map, and up to three
    rounds remeasure ``S`` at the value found until it moves by less than 3%. Without gusts
    (fitted after it, on the force)."""
    from scipy.optimize import minimize_scalar

    windy = [c for c in CONDITIONS if c != "nowind" and c in set(train["condition"])]
    if not windy:
        return cal
    by = train.groupby("condition")["pitch_spread"]
    goal = by.mean().reindex(windy).to_numpy()
    sd = by.std(ddof=1).reindex(windy).to_numpy()
    if not np.all(sd > 0):
        raise ValueError("the turbulence tilt's fit needs at least two training controllers "
                         "with different pitch spreads at every wind")

    def pitch(k):
        c = replace(cal, turbulence_tilt=float(k))
        return np.array([_replicate_mean(c, w, study, ("pitch_spread",))[0] for w in windy])

    p0 = pitch(0.0)
    k, got = 0.05, None
    for _ in range(4):  # a measurement, then up to three corrections
        got = pitch(k)
        S = np.maximum((got ** 2 - p0 ** 2) / k ** 2, 0.0)
        res = minimize_scalar(lambda x: float((((np.sqrt(p0 ** 2 + S * x * x) - goal) / sd)
                                               ** 2).sum()), bounds=(0.0, 1.0),
                              method="bounded", options={"xatol": 1e-5})
        new = float(res.x)
        if new <= 1e-4:
            return cal
        if abs(new - k) <= 0.03 * k:
            k = new
            break
        k = new
    return replace(cal, turbulence_tilt=k, fitted_on=cal.fitted_on + tuple(
        ("lap-to-lap spread of pitch", w) for w in windy))


def _sensitivity_row(base, step, study):
    """The still-air flight row of the twin ``base`` (no variability) with its controller's
    bandwidth ``exp(step)`` times as fast."""
    v = replace(base.vehicle(), position_control=base.vehicle().position_control.scaled(
        float(np.exp(step))))
    f = simulated_flight(v, "nowind", 0, flight_duration(study), replace(
        base, hover_throttle=0.0, variability=0.0))
    return flight_summaries([f], study)[0]


def _fit_gusts(cal, target, study):
    """The gust scale with which the mean over :data:`N_SEEDS` replicates of the twin
    ``cal``'s lap-to-lap spread of the force along x at :data:`SPREAD_CONDITION` is
    ``target`` (to 2%), by secant steps; 0 when the twin's other sources already reach it."""
    def spread(g):
        return float(_replicate_mean(replace(cal, gust_scale=g), SPREAD_CONDITION, study,
                                     ("fa_x_spread",))[0])

    if spread(0.0) >= target:
        return 0.0
    return _secant(spread, target, 0.05, 0.15, 0.0, 10.0, 0.02 * target, "gust")


def _force_targets(train):
    """{condition: (mean, SD) of the force along x, (mean, SD) along z} over the training
    flight rows ``train`` at every wind they hold, each controller's still-air force
    subtracted [N]."""
    fl = train.set_index(["controller", "condition"])
    out = {}
    for cond in CONDITIONS:
        if cond == "nowind" or cond not in set(train["condition"]):
            continue
        ctl = [c for c in sorted(set(train["controller"])) if (c, cond) in fl.index]
        d = np.array([[fl.loc[(c, cond), f"aero_force_{a}"] - fl.loc[(c, "nowind"),
                                                                    f"aero_force_{a}"]
                       for a in "xz"] for c in ctl])
        sd = d.std(axis=0, ddof=1) if len(ctl) > 1 else np.zeros(2)
        if not np.all(sd > 0):
            raise ValueError(f"the twin's per-wind force fit needs at least two training "
                             f"controllers with different forces at {cond!r}, got {ctl}")
        out[cond] = (float(d[:, 0].mean()), float(sd[0]), float(d[:, 1].mean()), float(sd[1]))
    if not out:
        raise ValueError("the twin's per-wind force fit needs training flights in wind")
    return out


def _fit_forces_per_wind(quiet, targets, study, start=(1.0, 1.0, 1.0)):
    """``(drag, lift, rotor)``: the drag scale, lift scale and rotor drag scale with which the
    twin ``quiet`` (no gusts, no noise, no variability) meets the training controllers' mean
    forces along x and z at every wind of ``targets`` (:func:`_force_targets`; 0 m/s
    subtracted, over the laps ``study`` keeps), each miss scaled by their SD there: least
    squares by Levenberg-Marquardt steps on a Jacobian of forward differences (the drag and
    the rotor drag overlap, so a Jacobian kept by Broyden's update stalled in their valley),
    until a step moves every factor by at most 0.2% or lowers the squared misses by at most
    0.01%.

    Why a second drag factor: RotorPy's drag has two parts, the rotors' H-force and induced
    inflow (``k_d``, ``k_z``: linear in the airspeed at a rotor speed) and the frame's
    parasitic drag (``c_D``: quadratic); the Neural-Fly preset scales both from a 0.5 kg
    hummingbird by mass similarity, which fixes their ratio, and one factor on both fitted
    at 8.5 m/s left the force too weak at 4.2 and 12.1 m/s. The linear and the quadratic
    parts weigh differently at each speed, so the forces at several winds set them apart;
    the lift (``k_h``, the thrust the rotors gain in an edgewise flow) is fitted beside them
    on the vertical force, which both drags move too."""
    conds = list(targets)
    T = np.array([targets[c] for c in conds])

    def measure(x):
        c = replace(quiet, drag_scale=float(x[0]), lift_scale=float(x[1]),
                    rotor_drag_scale=float(x[2]))
        still = _twin_row(c, "nowind", study)
        rows = [_twin_row(c, w, study) for w in conds]
        fx = np.array([r["aero_force_x"] - still["aero_force_x"] for r in rows])
        fz = np.array([r["aero_force_z"] - still["aero_force_z"] for r in rows])
        return np.concatenate([(fx - T[:, 0]) / T[:, 1], (fz - T[:, 2]) / T[:, 3]])

    low, high = np.array([1e-3, 0.0, 1e-3]), np.array([100.0, 100.0, 100.0])
    x = np.array(start, dtype=float)
    r = measure(x)
    lam = 1e-3
    for _ in range(_STEPS):
        J = np.empty((len(r), 3))
        for i in range(3):  # forward differences, 2% of each factor
            xi = x.copy()
            xi[i] += 0.02 * x[i] + (0.01 if i == 1 else 0.0)
            J[:, i] = (measure(xi) - r) / (xi[i] - x[i])
        A, g = J.T @ J, J.T @ r
        for _ in range(8):  # Levenberg-Marquardt: damp until a step lowers the misses
            x_new = np.clip(x + np.linalg.solve(A + lam * np.diag(np.diag(A)), -g), low, high)
            r_new = measure(x_new)
            if r_new @ r_new < r @ r:
                lam = max(lam / 3, 1e-6)
                break
            lam *= 4
        else:  # no step lowers them: the least squares' foot
            return float(x[0]), float(x[1]), float(x[2])
        step, gain = x_new - x, r @ r - r_new @ r_new
        x, r = x_new, r_new
        if np.all(np.abs(step) <= 2e-3 * np.abs(x)) or gain <= 1e-4 * (r @ r):
            return float(x[0]), float(x[1]), float(x[2])
    raise ValueError(f"the twin's per-wind force fit did not converge (last drag {x[0]:g}, "
                     f"lift {x[1]:g}, rotor drag {x[2]:g}: scaled misses {np.round(r, 3)})")


def _fit_forces(quiet, target, study, start=(1.0, 1.0)):
    """``(drag, lift)``: the factors with which the twin ``quiet`` (no gusts, no noise) meets
    ``target``'s forces along x and z at :data:`FIT_CONDITION` (0 m/s subtracted) over the
    laps ``study`` keeps, to 0.5% along x and 0.02 N along z.

    Both at once, from ``start`` (the preset's own drag and lift): the drag moves the vertical
    force too (induced inflow, the tilted frame) and the lift the lean, so the two forces are
    one map of the two factors. Its Jacobian is measured by one step in each factor, then
    Newton steps with Broyden's update of it: on the Neural-Fly targets six measurements
    (twelve flights), where fitting each factor in turn by secant steps took twenty-two."""
    goal = np.array([target["force_x"], target["force_z"]])
    tol = np.array([0.005 * abs(target["force_x"]), 0.02])
    low, high = np.array([1e-3, 0.0]), np.array([100.0, 100.0])

    def measure(x):
        c = replace(quiet, drag_scale=float(x[0]), lift_scale=float(x[1]))
        fit, still = _twin_row(c, FIT_CONDITION, study), _twin_row(c, "nowind", study)
        return np.array([fit[f"aero_force_{a}"] - still[f"aero_force_{a}"] for a in "xz"])

    x = np.array(start, dtype=float)
    f = measure(x)
    J = np.empty((2, 2))
    for i, step in enumerate((-0.1 * x[0], -0.3 * x[1] + 0.05)):  # the secant's first steps
        xi = x.copy()
        xi[i] += step
        J[:, i] = (measure(xi) - f) / step
    for _ in range(_STEPS):
        if np.all(np.abs(f - goal) <= tol):
            return float(x[0]), float(x[1])
        x_new = np.clip(x + np.linalg.solve(J, goal - f), low, high)
        f_new = measure(x_new)
        s, y = x_new - x, f_new - f
        if not s.any():  # pinned at a bound: no step left to take
            break
        J += np.outer(y - J @ s, s) / (s @ s)  # Broyden's ("good") update
        x, f = x_new, f_new
    raise ValueError(f"the twin's drag and lift fit did not converge (last drag {x[0]:g}, lift "
                     f"{x[1]:g}: forces {f[0]:g}, {f[1]:g} N against {goal[0]:g}, {goal[1]:g})")


def variability_table(calibration: TwinCalibration) -> pd.DataFrame:
    """The twin's sources of variability, one row each: ``source``, ``value`` (as fitted,
    with its unit), ``fitted on`` (what of the training controllers' flights fixes it, or
    that it is assumed) and ``acts``: between flights or within one."""
    c = calibration
    rows = [
        ("controller bandwidth (log-SD)", f"{c.gain_spread:.3f}",
         "log-SD of the tracking error in still air, through the twin's sensitivity to it",
         "per seed (one controller at every wind)"),
        ("integral gain (log-SD)", f"{c.integral_spread:.3f}",
         "lap-to-lap spread of position at 12.1 m/s (at most the bandwidth's), after the "
         "vertical share"
         if ("lap-to-lap spread of position", SPREAD_CONDITION) in c.fitted_on else
         "assumed equal to the bandwidth's (the flight rows do not tell them apart)",
         "per seed"),
        ("hover throttle (battery)", f"{c.hover_throttle:.3f} +- {c.hover_throttle_sd:.3f}",
         "mean and SD of the flights' hover throttle", "per flight"),
        ("attitude-estimate tilt error, per axis [deg]", f"{c.attitude_error:.3f}",
         "lap-to-lap spreads of pitch, force x and vertical tracking in still air (jointly)",
         f"within the flight (Gauss-Markov, {c.error_time:.3g} s)"),
        ("velocity-estimate error along x [m/s]", f"{c.velocity_error:.4f}", "(the same fit)",
         "within the flight"),
        ("thrust error [share of the commanded]", f"{c.thrust_error:.4f}", "(the same fit)",
         "within the flight"),
        ("vertical velocity-estimate error [m/s]", f"{c.vertical_velocity_error:.4f}",
         "(the same fit); its share of the vertical error beside the thrust's on the "
         "lap-to-lap spread of position at 12.1 m/s"
         if ("lap-to-lap spread of position", SPREAD_CONDITION) in c.fitted_on else
         "not modelled (the vertical error is the thrust's)", "within the flight"),
        ("the errors' correlation time [s]", f"{c.error_time:.3f}",
         "lap-to-lap spread of position in still air (the errors refitted at each time)"
         if ("lap-to-lap spread of position", "nowind") in c.fitted_on else
         "assumed (slower than the 2 Hz noise cutoff, faster than a lap)",
         "within the flight"),
        ("attitude-estimate tilt error in wind [deg per m/s]", f"{c.turbulence_tilt:.4f}",
         "lap-to-lap spread of pitch at every wind (least squares, scaled by their SD)"
         if any(q == "lap-to-lap spread of pitch" for q, _ in c.fitted_on) else "not modelled",
         "within the flight, grows with the mean wind"),
        ("gust W20 / mean speed (the fan's turbulence)", f"{c.gust_scale:.3f}",
         "lap-to-lap spread of force x at 12.1 m/s, mean over the replicates",
         "within the flight"),
        ("motor dynamics", "RotorPy's first-order lag", "not fitted (modelled, not varied)",
         "within the flight"),
    ]
    return pd.DataFrame(rows, columns=["source", "value", "fitted on (training controllers)",
                                       "acts"]).set_index("source")
