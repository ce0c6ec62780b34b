"""Experiment 13, simulated: Neural-Fly's figure-8 flown by RotorPy's SE3 position
controller on the Neural-Fly quadrotor, at the wind-tunnel's winds, side by side with the
real flights.

This module owns :func:`simulated_flight` (one simulated flight in the real flights' format,
a :class:`~uavwind.data.RealFlight`, so the real flights' analysis runs on it unchanged),
:func:`fit_drag_scale` (the vehicle's drag fitted on ONE real condition),
:func:`simulated_flights` (as long as a study's laps need: :func:`flight_duration`), :func:`sim_rows` (cached, as the real rows are) and
:func:`prediction_table` / :func:`ranking_verdict` (what the page compares).

Decisions (each stated on the page):

* *Wind.* Along -x (the real flights' aerodynamic force points to -x), uniform: constant, or
  8.5 + 2.4 sin t m/s for ``70p20sint``; plus MIL-F-8785C Dryden gusts at the flight's
  altitude with ``W20`` = the mean speed (at least 1 m/s): the fan array's turbulence is not
  given by the data, so this is an assumption, and it is what makes one flight's laps differ.
  The wind ramps in over the first lap (from a hover in still air; the real flights start on
  a ramped reference), and the first two laps are dropped as the real flights' first is.
* *Replicates.* The real flights have five controllers; the simulation has one controller
  (SE3) and five gust seeds per condition, labelled ``seed 0`` ... ``seed 4``.
* *Drag.* The Neural-Fly preset's drag scaled by one factor, fitted so that the mean
  aerodynamic force along the wind at 4.2 m/s equals the real flights' (each controller's
  force at 0 m/s subtracted: the authors' ``fa`` holds a residual of about 1 N in still
  air); 8.5 and 12.1 m/s are then predictions.
"""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
import pandas as pd

from .._version import __version__
from ..core.checks import check_instance, check_scalar
from ..core.seeding import child_seed, root_seed
from ..data.neuralfly import CONDITIONS, RealFlight, flight_laps
from ..sim.dryden import DrydenWind
from ..sim.dynamics import simulate_flight
from ..sim.multirotor import Multirotor
from ..sim.references import Lemniscate
from ..sim.wind import CombinedWind, ConstantWind, SinusoidalWind, WindModel
from .memo import memo
from .real_flights import STUDIES, compute_rows

__all__ = ["FIGURE8", "SIM_SEED", "SIM_VERSION", "FIT_CONDITION", "simulated_flight",
           "simulated_flights", "flight_duration", "fit_drag_scale", "sim_rows", "prediction_table",
           "ranking_verdict", "real_drag_target"]

#: Neural-Fly's reference: (1.25 sin t, 0, 0.75 sin 2t) about the real flights' centre [m].
FIGURE8 = Lemniscate(center=(0.25, 0.0, 2.15), amplitude=(1.25, 0.0, 0.75), period=2 * np.pi)
#: The root seed of the simulated gusts.
SIM_SEED = 13
#: Bump when a change alters the simulated rows. 2: a study that keeps some laps flies only
#: as long as they need (:func:`flight_duration`) and its drag fit averages them alone.
SIM_VERSION = "2"
#: The one condition the drag is fitted on.
FIT_CONDITION = "35wind"
#: Replicates (gust seeds) per condition: as many as the real flights' controllers.
N_SEEDS = 5
#: Flight length [s] and recording step [s] (the real flights': about 50 s at 50 Hz).
DURATION, DT = 50.0, 0.02
#: The wind ramps in over the first lap [s] (dropped from every analysis).
RAMP = 2 * np.pi


class _RampedWind(WindModel):
    """``model``'s wind times a smooth ramp from 0 at t = 0 to 1 at ``ramp`` [s] (the
    smoothstep ``3u^2 - 2u^3``): the flight starts from a hover in still air, as the real
    flights start on a ramped reference; the lap it ramps over is dropped."""

    def __init__(self, model, ramp):
        self.model, self.ramp, self.n_env = model, float(ramp), model.n_env

    def _velocity(self, t, positions):
        u = min(t / self.ramp, 1.0)
        return self.model._velocity(t, positions) * (u * u * (3.0 - 2.0 * u))


def _wind(condition, seed):
    speed = CONDITIONS[condition]
    if condition == "70p20sint":
        mean = SinusoidalWind([[-speed, 0.0, 0.0]], [[-2.4, 0.0, 0.0]], period=2 * np.pi)
    else:
        mean = ConstantWind([[-speed, 0.0, 0.0]])
    gusts = DrydenWind([max(speed, 1.0)], altitude=FIGURE8.center[2], dt=DT, seed=seed)
    return _RampedWind(CombinedWind(mean, gusts), RAMP)


def simulated_flight(vehicle: Multirotor, condition: str, seed: int = 0,
                     duration: float = DURATION) -> RealFlight:
    """The figure-8 flown by ``vehicle`` under SE3 control in ``condition``'s wind with gust
    seed ``seed``, as a :class:`~uavwind.data.RealFlight` (``controller`` ``"seed k"``):
    ``T_sp`` is the commanded thrust over the full-speed thrust (the real set-point is
    normalised the same way), ``fa`` the simulated aerodynamic force, ``pwm`` the rotor
    speeds [rad/s]."""
    check_instance(vehicle, "vehicle", Multirotor)
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {condition!r}")
    seed = check_scalar(seed, "seed", low=0, high=2 ** 32 - 1, integer=True)
    duration = check_scalar(duration, "duration", low=4 * np.pi, high=3600.0)
    wind = _wind(condition, child_seed(root_seed(SIM_SEED), seed, list(CONDITIONS).index(condition)))
    f = simulate_flight(FIGURE8, wind, uav=vehicle, dt=DT, duration=duration)
    t = f.times
    q = f.attitudes[0]
    x, y, z, w = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                  np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                  np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
                 axis=1)
    ref = FIGURE8.flat_output(t)
    arrays = {"t": t, "p": f.positions[0], "p_d": f.references[0], "v": f.ground_velocities[0],
              "v_d": ref["x_dot"], "q": q, "R": R, "w": f.body_rates[0],
              "T_sp": f.thrust_commands[0] / vehicle.max_thrust, "q_sp": np.zeros_like(q),
              "hover_throttle": np.full(len(t), vehicle.weight / vehicle.max_thrust),
              "fa": f.aero_forces[0], "pwm": f.rotor_speeds[0]}
    for a in arrays.values():
        a.setflags(write=False)
    return RealFlight(controller=f"seed {seed}", condition=condition,
                      wind_speed=CONDITIONS[condition], source=f"simulated, seed {seed}",
                      vehicle="simulated", trajectory="figure8", arrays=arrays)


def real_drag_target(real_rows: pd.DataFrame, condition: str = FIT_CONDITION) -> tuple[float, np.ndarray]:
    """The real flights' mean aerodynamic force along x at ``condition`` minus each
    controller's at 0 m/s [N], and the per-controller values."""
    fl = real_rows[real_rows["kind"] == "flight"].set_index(["controller", "condition"])
    ctl = sorted({c for c, _ in fl.index})
    per = np.array([fl.loc[(c, condition), "aero_force_x"] - fl.loc[(c, "nowind"), "aero_force_x"]
                    for c in ctl])
    return float(per.mean()), per


def flight_duration(study=STUDIES["paper"]) -> float:
    """The length [s] of a simulated flight that holds every lap ``study`` keeps: the
    real flights' :data:`DURATION` when it keeps all laps (``max_laps = 0``), else enough for
    its dropped and kept laps, one more lap (the first lap starts at t = 0 or one period
    later, by how the sampled reference crosses its centre) and 1 s, in whole seconds: 27 s
    instead of 50 at the quick profile (two laps kept), the same laps for half the CPU."""
    if study.max_laps == 0:
        return DURATION
    return min(DURATION, float(np.ceil((study.drop_first + study.max_laps + 1)
                                       * FIGURE8.period + 1.0)))


def _mean_force_x(vehicle, condition, study):
    """Mean aerodynamic force along x [N] over the laps ``study`` keeps (as the real rows'
    ``aero_force_x``, the fit's target, averages them), gust seed 0."""
    w = flight_laps(simulated_flight(vehicle, condition, 0, duration=flight_duration(study)),
                    ("aero_force",), study.n_samples, study.drop_first)
    keep = slice(None) if study.max_laps == 0 else slice(0, study.max_laps)
    return float(w["aero_force"][keep, :, 0].mean())


def fit_drag_scale(target: float, condition: str = FIT_CONDITION, study=STUDIES["paper"],
                   tol: float = 1e-3) -> float:
    """The factor on the Neural-Fly preset's drag whose simulated mean force along x at
    ``condition`` (gust seed 0, minus the same at 0 m/s) equals ``target`` [N] (secant steps
    on the factor, to ``tol`` relative)."""
    target = check_scalar(target, "target", low=-1e4, high=1e4)
    if target >= 0:
        raise ValueError(f"target must be negative (a force along the wind, -x), got {target:g}")

    def force(s):
        v = Multirotor.neural_fly(drag_scale=s)
        return _mean_force_x(v, condition, study) - _mean_force_x(v, "nowind", study)

    s0, f0 = 1.0, force(1.0)
    s1 = s0 * target / f0
    for _ in range(8):
        f1 = force(s1)
        if abs(f1 - target) <= tol * abs(target):
            return float(s1)
        s0, f0, s1 = s1, f1, s1 + (target - f1) * (s1 - s0) / (f1 - f0)
        s1 = min(max(s1, 1e-3), 100.0)
    raise ValueError(f"the drag fit did not converge (last factor {s1:g}, force {f1:g} N, "
                     f"target {target:g} N)")


def simulated_flights(vehicle: Multirotor, n_seeds: int = N_SEEDS,
                      conditions=tuple(CONDITIONS), duration: float = DURATION) -> list[RealFlight]:
    """Every condition x gust seed, flown for ``duration`` [s] (the order of
    :func:`uavwind.load_neuralfly`)."""
    return [simulated_flight(vehicle, c, s, duration=duration) for s in range(n_seeds)
            for c in conditions]


def sim_rows(real_rows: pd.DataFrame, profile: str = "paper", results=None,
             n_jobs: int | None = None) -> pd.DataFrame:
    """Experiment 13's simulated rows (the real rows' columns, plus ``drag_scale`` in
    ``attrs``), kept by :func:`uavwind.analysis.memo.memo` under a digest of the drag target,
    the study and the version; a damaged or altered copy is recomputed with a warning."""
    if profile not in STUDIES:
        raise ValueError(f"profile must be one of {list(STUDIES)}, got {profile!r}")
    study = STUDIES[profile]
    target, _ = real_drag_target(real_rows)

    def compute():
        scale = fit_drag_scale(target, study=study)
        conditions = tuple(c for c in CONDITIONS
                           if not study.conditions or c in study.conditions or c == FIT_CONDITION)
        flights = simulated_flights(Multirotor.neural_fly(drag_scale=scale), conditions=conditions,
                                    duration=flight_duration(study))
        df = compute_rows(flights, study, n_jobs=n_jobs)
        df.attrs.update(profile=profile, drag_scale=scale, drag_target=target,
                        uavwind_version=__version__)
        return df

    return memo("exp13_sim", {"target": repr(target), "study": asdict(study), "seed": SIM_SEED,
                              "n_seeds": N_SEEDS, "version": SIM_VERSION}, compute, results)


def prediction_table(real_rows: pd.DataFrame, sim: pd.DataFrame) -> pd.DataFrame:
    """Per condition: the simulated and the real mean tilt [deg], aerodynamic force along
    the wind (0 m/s subtracted) [N] and tracking error [m], the real spread over controllers
    (min, max), and the simulation's error; ``fitted`` marks the condition the drag was
    fitted on (the others are predictions)."""
    out = []
    real_f, sim_f = real_rows[real_rows.kind == "flight"], sim[sim.kind == "flight"]

    def force(df):
        base = df[df.condition == "nowind"].set_index("controller")["aero_force_x"]
        return df.assign(force=df["aero_force_x"] - df["controller"].map(base))

    real_f, sim_f = force(real_f), force(sim_f)
    for cond in CONDITIONS:
        r, s = real_f[real_f.condition == cond], sim_f[sim_f.condition == cond]
        if not len(r) or not len(s):
            continue
        row = {"condition": cond, "wind_speed": CONDITIONS[cond], "fitted": cond == FIT_CONDITION}
        for c in ("tilt_deg", "force", "tracking_rms"):
            row[f"{c}_sim"] = float(s[c].mean())
            row[f"{c}_real"] = float(r[c].mean())
            row[f"{c}_real_min"], row[f"{c}_real_max"] = float(r[c].min()), float(r[c].max())
            row[f"{c}_error"] = row[f"{c}_sim"] - row[f"{c}_real"]
        out.append(row)
    return pd.DataFrame(out)


def ranking_verdict(real_channels: pd.DataFrame, sim_channels: pd.DataFrame,
                    tie: float = 1.0) -> dict:
    """Does the simulation rank the channels as the real flights do?

    Every pair of channels the real flights can order (their CIs over controllers do not
    overlap) is checked in the simulation: ``agree`` (same order, means more than ``tie``
    points apart), ``disagree`` (the other order) or ``sim_tied`` (within ``tie`` points).
    ``verdict`` is ``"yes"`` if every orderable pair agrees, ``"no"`` if any disagrees, else
    ``"cannot decide"``. Spearman's rho of the two rankings and the best channels are given
    beside it."""
    r = real_channels.set_index("channel")
    s = sim_channels.set_index("channel").reindex(r.index)
    rr, sr = r["mean"].rank(ascending=False), s["mean"].rank(ascending=False)
    n = len(rr)
    rho = float(1 - 6 * ((rr - sr) ** 2).sum() / (n * (n * n - 1))) if n > 2 else float("nan")
    order = list(r.sort_values("mean", ascending=False).index)
    agree, disagree, tied, unordered = [], [], [], []
    for i, a in enumerate(order):
        for b in order[i + 1:]:  # a above b in the real flights
            if r.loc[a, "ci_low"] <= r.loc[b, "ci_high"]:
                unordered.append((a, b))
                continue
            d = s.loc[a, "mean"] - s.loc[b, "mean"]
            (agree if d > tie else disagree if d < -tie else tied).append((a, b))
    verdict = "no" if disagree else "yes" if agree and not tied else "cannot decide"
    return {"verdict": verdict, "agree": agree, "disagree": disagree, "sim_tied": tied,
            "real_unordered": unordered, "spearman": rho, "top_real": order[0],
            "top_sim": s["mean"].idxmax(), "real_order": order,
            "sim_order": list(s["mean"].sort_values(ascending=False).index)}
