"""Experiment 13, simulated: Neural-Fly's figure-8 flown by a twin of the Neural-Fly
quadrotor, calibrated on the real flights, side by side with them.

This module owns :class:`TwinCalibration` (what the twin takes from the real flights),
:func:`calibrate_twin` (fitting it on the training controllers' flights),
:func:`simulated_flight` (one twin flight in the real flights' format, a
:class:`~uavwind.data.RealFlight`, so the real flights' analysis runs on it unchanged),
:func:`simulated_flights`, :func:`sim_rows` (cached, as the real rows are),
:func:`validation_table` (the twin against a held-out controller's flights) and
:func:`ranking_verdict` (does it order the channels as the real flights do?).

The twin (each choice stated on the page):

* *Vehicle.* :meth:`~uavwind.sim.multirotor.Multirotor.neural_fly` (2.6 kg, thrust-to-weight
  2.2), its drag (frame, rotor drag, induced inflow) and its translational lift each scaled
  by one factor (``drag_scale``, ``lift_scale``), and the rotor drag (linear in the
  airspeed) by a second (``rotor_drag_scale``), fitted on the training controllers' mean
  force along x and along z at every wind (each controller's still-air force subtracted:
  the authors' ``fa`` holds about a newton in still air); ``per_wind`` False: the first
  twin's two factors at :data:`FIT_CONDITION` alone, the other winds predictions.
* *Controller.* RotorPy's SE3 law with an integral term and a thrust cone with vertical
  priority (:data:`~uavwind.sim.rotor_params.NEURAL_FLY_CONTROL`): the real controllers hold
  the path in steady wind, which a PD law cannot (it leaves a steady error of ``F / (m kp)``).
* *Wind.* Along -x, uniform, constant or 8.5 + 2.4 sin t m/s (``70p20sint``), ramped in over
  the first lap from a hover in still air, PLUS (:class:`~uavwind.sim.wind.SumWind`)
  MIL-F-8785C Dryden gusts at the flight's altitude with ``W20`` = ``gust_scale`` x the mean
  speed; ``gust_scale`` is fitted so that the twin's lap-to-lap spread of the slow part of
  the force along x matches the training controllers' at :data:`SPREAD_CONDITION`.
* *Sensors.* The real vehicle's attitude is measured about a body axis ``axis_offset``
  degrees from its thrust axis (in still air every controller pitches -2.4 to -3.5 deg while
  ``fa`` reads +1.0 to +1.4 N along x, ``T sin(offset)``); the twin records its attitude
  about the same offset axis and its ``fa`` as the authors compute it from that attitude.
  Every recorded channel gets white noise whose content above 2 Hz matches the training
  controllers' at the same wind.
* *Replicates.* Five seeds per condition, labelled ``seed 0`` ... ``seed 4``, as the real
  flights have five controllers. A seed is a controller and a flight (:func:`calibrate_twin`
  fits every spread on the training controllers; ``variability`` 0 turns them all off):
  the controller's bandwidth (``kp``, ``kd``, ``ki`` scaled together, the loop's shape kept)
  and its integral gain each times a log-normal factor (the integral's spread fitted on the
  position spread at 12.1 m/s, :func:`_fit_integral_spread`), drawn once per seed (seed ``k`` is
  one controller at every wind, as a real controller is); per flight, the battery (the
  hover throttle, so the rotors' full thrust, drawn from the training flights'); and within
  the flight, the state the controller acts on: an attitude estimate tilted off the true
  attitude, a velocity estimate off the true velocity (along x, and vertically) and a thrust
  off the commanded, each a second-order Gauss-Markov process (correlation time
  ``error_time``) that the controller flies on in the kernel
  (:meth:`~uavwind.sim.multirotor.Multirotor.fly_reference`'s ``state_errors``) and that the
  record carries as a real log does (the estimated attitude and velocity, ``fa`` computed
  from them and the commanded thrust). The still-air vertical error is split between the
  thrust and the vertical velocity estimate on the position spread at 12.1 m/s
  (:func:`_fit_vertical_share`: on the Neural-Fly flights all of it the velocity's). Its own
  gusts and noise.
* *Held out.* The twin is fitted on every controller but one (:func:`held_out_controller`)
  and checked on that one (:func:`validation_table`).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, replace

import numpy as np
import pandas as pd

from .._version import __version__
from ..core.checks import Range, check_fields, check_instance, check_scalar
from ..core.seeding import child_rng, child_seed, root_seed
from ..data.neuralfly import CONDITIONS, NOISE_CUTOFF, RealFlight
from ..sim.dryden import DrydenWind
from ..sim.dynamics import simulate_flight
from ..sim.multirotor import Multirotor
from ..sim.references import Lemniscate
from ..sim.rotor_params import NEURAL_FLY_CONTROL, PositionControl
from ..sim.variability import burn_in, gauss_markov
from ..sim.wind import ConstantWind, RampedWind, SinusoidalWind
from .memo import memo
from .real_flights import (STUDIES, compute_rows, decided_orders, flight_summaries,
                           noise_columns)

__all__ = ["FIGURE8", "BARE", "SIM_SEED", "SIM_VERSION", "FIT_CONDITION", "SPREAD_CONDITION",
           "TwinCalibration", "calibrate_twin", "held_out_controller",
           "simulated_flight", "simulated_flights", "flight_duration", "sim_rows",
           "validation_table", "validation_score", "ranking_verdict", "real_force_targets",
           "calibration_of", "VALIDATION", "PHYSICAL", "ERROR_TIME", "variability_table"]

#: Neural-Fly's reference: (1.25 sin t, 0, 0.75 sin 2t) about the real flights' centre [m].
FIGURE8 = Lemniscate(center=(0.25, 0.0, 2.15), amplitude=(1.25, 0.0, 0.75), period=2 * np.pi)
#: The root seed of the simulated gusts and sensor noise.
SIM_SEED = 13
#: Bump when a change alters the simulated rows. 2: a study that keeps some laps flies only
#: as long as they need (:func:`flight_duration`). 3: the calibrated twin (gusts that reach
#: it, lift, controller with an integral and a thrust cone, sensor offset and noise). 4: the
#: drag and lift fitted together (Broyden), to the same tolerances.
#: 6: the variability (controller, battery and state-estimate draws per replicate).
#: 7: fitted on every wind (drag, rotor drag and lift on the forces per wind, the errors'
#: correlation time on the still-air position spread).
#: 8: the still-air vertical error's share carried by the vertical velocity estimate, not the
#: thrust, fitted on the position spread at 12.1 m/s (:func:`_fit_vertical_share`).
#: 9: the integral gain's spread fitted on the same spread (:func:`_fit_integral_spread`), no
#: longer assumed equal to the bandwidth's.
SIM_VERSION = "9"
#: The one wind the forces (drag and lift) are fitted on: 8.5 m/s, where both are well above
#: the still-air residual; 4.2 and 12.1 m/s are predictions.
FIT_CONDITION = "70wind"
#: The one wind the gust intensity is fitted on (the largest spread, the most signal).
SPREAD_CONDITION = "100wind"
#: Replicates (gust seeds) per condition: as many as the real flights' controllers.
N_SEEDS = 5
#: Flight length [s] and recording step [s] (the real flights': about 50 s at 50 Hz).
DURATION, DT = 50.0, 0.02
#: The wind ramps in over the first lap [s] (dropped from every analysis).
RAMP = 2 * np.pi
#: Laps a calibration flight keeps (the twin's laps differ only by its gusts: three give
#: its means and its lap-to-lap spread; the real targets average every lap they keep).
_FIT_LAPS = 3
#: Most Newton-Broyden steps of the joint drag and lift fit (three to five suffice: the forces
#: are close to linear in the two factors on the twin's closed-loop laps).
_STEPS = 12
#: Share of a white noise's variance above the noise cutoff at the recording step.
_ABOVE_CUTOFF = 1.0 - 2.0 * NOISE_CUTOFF * DT
#: Correlation time [s] of the state-estimate and thrust errors (second-order Gauss-Markov) of
#: the first twin, and where its fit starts (:func:`_fit_error_time`, on the training
#: controllers' still-air position spread): slower than the 2 Hz noise cutoff, so the errors
#: move a lap's slow part, faster than a lap (6.3 s), so they differ from lap to lap.
ERROR_TIME = 0.2
#: Seed addresses (under :data:`SIM_SEED` and the seed): the controller drawn once per seed,
#: then per condition ``k`` the gusts ``(k,)``, the noise ``(k, 1)``, the battery ``(k, 2)``
#: and the state errors ``(k, 3)``.
_CONTROLLER_KEY = 1000
#: Reference sizes of the state errors the fit starts from: attitude [deg], thrust [-],
#: velocity [m/s].
_ERROR_START = (0.5, 0.01, 0.02)


@dataclass(frozen=True, kw_only=True)
class TwinCalibration:
    """What the twin takes from the real flights (:func:`calibrate_twin` fits it).

    Attributes
    ----------
    drag_scale, lift_scale : float
        Factors on the Neural-Fly preset's drag and translational lift [-].
    gust_scale : float
        Dryden ``W20`` as a share of the mean wind speed [-] (0: no gusts).
    axis_offset : float
        Lean of the measured body z axis from the thrust axis towards +x [deg].
    noise : tuple of (condition, column, std)
        The standard deviation above the noise cutoff of each recorded channel and axis
        (:func:`uavwind.analysis.real_flights.noise_columns`) at each wind.
    controllers : tuple of str
        The controllers it was fitted on.
    gain_spread, integral_spread : float
        Log-SD of a replicate's controller bandwidth factor and of its integral gain's own
        factor [-] (0: every replicate flies :data:`~uavwind.sim.rotor_params.NEURAL_FLY_CONTROL`).
    hover_throttle, hover_throttle_sd : float
        Mean and SD of a flight's hover throttle (weight over full thrust) [-] (mean 0: the
        preset's, thrust-to-weight 2.2).
    attitude_error : float
        SD of the attitude estimate's tilt error about each world horizontal axis [deg].
    thrust_error : float
        SD of the thrust's relative error [-].
    velocity_error : float
        SD of the velocity estimate's error along world x [m/s].
    vertical_velocity_error : float
        SD of the velocity estimate's error along world z [m/s] (0: none, the first twin's;
        :func:`calibrate_twin` with ``vertical_share``).
    rotor_drag_scale : float
        Further factor on the rotor drag (linear in the airspeed) beside ``drag_scale``
        (:attr:`~uavwind.sim.multirotor.Multirotor.rotor_drag_scale`) [-] (1: the preset's
        ratio of rotor to frame drag, what one wind fixes).
    error_time : float
        Correlation time of the state-estimate and thrust errors [s] (default
        :data:`ERROR_TIME`, assumed; :func:`calibrate_twin` fits it).
    turbulence_tilt : float
        SD of the turbulence's tilt of the attitude per metre per second of mean wind
        [deg/(m/s)], about each world horizontal axis (0: none; :func:`simulated_flight`).
    fitted_on : tuple of (quantity, condition)
        The rows of :func:`validation_table` beyond the first twin's that the fit used (the
        training controllers' mean there): only the held-out column checks them.
    variability : float
        Factor on every spread above, and the switch of the mean hover throttle [-]: 0 flies
        the twin whose replicates differ by gusts and noise alone (exactly, to the double).

    The default is the bare twin: the preset's drag and lift, no gusts, no offset, no noise,
    no variability.
    """

    drag_scale: float = 1.0
    lift_scale: float = 1.0
    gust_scale: float = 0.0
    axis_offset: float = 0.0
    noise: tuple = ()
    controllers: tuple = ()
    gain_spread: float = 0.0
    integral_spread: float = 0.0
    hover_throttle: float = 0.0
    hover_throttle_sd: float = 0.0
    attitude_error: float = 0.0
    thrust_error: float = 0.0
    velocity_error: float = 0.0
    vertical_velocity_error: float = 0.0
    rotor_drag_scale: float = 1.0
    error_time: float = ERROR_TIME
    turbulence_tilt: float = 0.0
    fitted_on: tuple = ()
    variability: float = 1.0

    def __post_init__(self):
        check_fields(self, {"drag_scale": Range(0.0, 100.0, low_inclusive=False),
                            "lift_scale": Range(0.0, 100.0), "gust_scale": Range(0.0, 10.0),
                            "axis_offset": Range(-45.0, 45.0),
                            "gain_spread": Range(0.0, 2.0), "integral_spread": Range(0.0, 2.0),
                            "hover_throttle": Range(0.0, 0.95),
                            "hover_throttle_sd": Range(0.0, 0.2),
                            "attitude_error": Range(0.0, 10.0), "thrust_error": Range(0.0, 0.2),
                            "velocity_error": Range(0.0, 2.0),
                            "vertical_velocity_error": Range(0.0, 2.0), "variability": Range(0.0, 10.0),
                            "rotor_drag_scale": Range(0.0, 100.0, low_inclusive=False),
                            "error_time": Range(0.01, 10.0),
                            "turbulence_tilt": Range(0.0, 1.0)})
        if 0.0 < self.hover_throttle < 0.1:
            raise ValueError(f"hover_throttle must be 0 (the preset's) or in [0.1, 0.95], got "
                             f"{self.hover_throttle}")
        known = set(noise_columns())
        for c, col, std in self.noise:
            if c not in CONDITIONS or col not in known:
                raise ValueError(f"noise must hold (condition, column, std) with a condition of "
                                 f"{list(CONDITIONS)} and a column of {sorted(known)}, got "
                                 f"{(c, col)!r}")
            check_scalar(std, "noise std", low=0.0, high=1e3)
        object.__setattr__(self, "noise", tuple((c, col, float(v)) for c, col, v in self.noise))
        object.__setattr__(self, "controllers", tuple(self.controllers))
        fitted = tuple((str(q), str(c)) for q, c in self.fitted_on)
        bad = [(q, c) for q, c in fitted if q not in VALIDATION or c not in CONDITIONS]
        if bad:
            raise ValueError(f"fitted_on must hold (quantity, condition) pairs of VALIDATION's "
                             f"quantities and CONDITIONS, got {bad[0]!r}")
        object.__setattr__(self, "fitted_on", fitted)

    def vehicle(self) -> Multirotor:
        """The twin's vehicle: the Neural-Fly preset with these factors and
        :data:`~uavwind.sim.rotor_params.NEURAL_FLY_CONTROL`."""
        return Multirotor.neural_fly(drag_scale=self.drag_scale, lift_scale=self.lift_scale,
                                     rotor_drag_scale=self.rotor_drag_scale,
                                     position_control=NEURAL_FLY_CONTROL)

    @property
    def varies(self) -> bool:
        """Whether a replicate draws anything beyond its gusts and noise."""
        return self.variability > 0 and any(
            (self.gain_spread, self.integral_spread, self.hover_throttle, self.attitude_error,
             self.thrust_error, self.velocity_error, self.vertical_velocity_error,
             self.turbulence_tilt))

    def state_error_sds(self) -> np.ndarray:
        """The SDs of the six state errors a flight draws (tilt about x and y [rad], thrust
        [-], velocity x, y, z [m/s]), times ``variability``. The velocity's error is drawn
        along x only (the wind's axis and the figure-8's long one; the vertical is the
        thrust error's): along y the twin's yaw gives way (at 12.1 m/s a lateral velocity
        error of 0.04 m/s raised its motor-limited steps from 0.2% to 1% and moved its mean
        force along x by 0.6 N), a drag source, not a steadiness one."""
        a = np.radians(self.attitude_error)
        return self.variability * np.array([a, a, self.thrust_error, self.velocity_error, 0.0,
                                            self.vertical_velocity_error])

    def noise_at(self, condition: str) -> dict[str, float]:
        """{column: std} at ``condition`` (empty without noise)."""
        return {col: v for c, col, v in self.noise if c == condition}

    def to_dict(self) -> dict:
        return asdict(self)


#: The bare twin: the preset's drag and lift, no gusts, offset or noise. What
#: :func:`simulated_flight` flies only when given it by name (its ``seed`` changes nothing).
BARE = TwinCalibration()


def held_out_controller(controllers) -> str:
    """The controller the twin is checked on: the last in name order (``"indi"`` among
    Neural-Fly's five); the others are the training controllers."""
    controllers = sorted(controllers)
    if len(controllers) < 2:
        raise ValueError(f"controllers must hold at least two (one to fit on, one to check), "
                         f"got {controllers}")
    return controllers[-1]


def _wind(condition, seed, gust_scale):
    speed = CONDITIONS[condition]
    if condition == "70p20sint":
        mean = SinusoidalWind([[-speed, 0.0, 0.0]], [[-2.4, 0.0, 0.0]], period=2 * np.pi)
    else:
        mean = ConstantWind([[-speed, 0.0, 0.0]])
    if gust_scale > 0 and speed > 0:  # gusts ADDED to the mean wind, one environment
        mean = mean + DrydenWind([gust_scale * speed], altitude=FIGURE8.center[2], dt=DT,
                                 airspeed=speed, seed=seed)
    return RampedWind(mean, RAMP)


def _offset_attitude(q, offset_deg):
    """The attitude (quaternions, rotations) of a body axis leaning ``offset_deg`` towards
    +x (about body y) from the thrust axis."""
    # scipy.spatial here and below: importing this module (the command line, the package
    # face) should not pay its 0.5 s; only a simulated flight needs it
    from scipy.spatial.transform import Rotation

    rot = Rotation.from_quat(q) * Rotation.from_euler("y", offset_deg, degrees=True)
    return rot.as_quat(), rot.as_matrix()


def simulated_flight(vehicle: Multirotor, condition: str, seed: int = 0,
                     duration: float = DURATION,
                     calibration: TwinCalibration | None = None) -> RealFlight:
    """The figure-8 flown by ``vehicle`` in ``condition``'s wind with gust and noise seed
    ``seed``, as a :class:`~uavwind.data.RealFlight` (``controller`` ``"seed k"``), recorded
    as ``calibration`` says. ``calibration`` is required (a ``TypeError`` without it): the
    fitted twin (:func:`calibrate_twin`, :func:`calibration_of`), or :data:`BARE` to fly the
    bare twin on purpose (no gusts, offset or noise: its ``seed`` then changes nothing, which
    a default made easy to miss). ``T_sp`` is
    the commanded thrust over the full-speed thrust (the real set-point is normalised the
    same way), ``hover_throttle`` the weight over it, ``fa`` the aerodynamic force as the
    authors compute it from the recorded attitude, ``pwm`` the rotor speeds [rad/s]."""
    from scipy.spatial.transform import Rotation

    check_instance(vehicle, "vehicle", Multirotor)
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {list(CONDITIONS)}, got {condition!r}")
    seed = check_scalar(seed, "seed", low=0, high=2 ** 32 - 1, integer=True)
    duration = check_scalar(duration, "duration", low=4 * np.pi, high=3600.0)
    if calibration is None:
        raise TypeError("simulated_flight() requires calibration: the fitted twin "
                        "(figure8.calibrate_twin or calibration_of(sim_rows(...))), or "
                        "figure8.BARE for the bare twin on purpose (no gusts or noise: its "
                        "seed then changes nothing)")
    cal = calibration
    check_instance(cal, "calibration", TwinCalibration)
    k = list(CONDITIONS).index(condition)
    wind = _wind(condition, child_seed(root_seed(SIM_SEED), seed, k), cal.gust_scale)
    errors = None
    if cal.varies:
        vehicle = replicate_vehicle(vehicle, cal, seed, condition)
        per = vehicle.check_grid(DT)
        n_ctrl = int(round(duration / DT)) * per
        errors = _state_errors(cal, child_rng(root_seed(SIM_SEED), seed, k, 3), n_ctrl,
                               vehicle.control_rate)
        if cal.turbulence_tilt and CONDITIONS[condition] > 0:  # the estimate's error in wind
            errors[:, :2] += _turbulence_tilt(cal, child_rng(root_seed(SIM_SEED), seed, k, 4),
                                              n_ctrl, vehicle.control_rate,
                                              CONDITIONS[condition])
    f = simulate_flight(FIGURE8, wind, uav=vehicle, dt=DT, duration=duration,
                        state_errors=None if errors is None else errors[None])
    t = f.times
    # the rotors' nominal thrust
    thrust = vehicle.thrust_coefficient * np.sum(f.rotor_speeds[0] ** 2, axis=1)
    true_b3 = Rotation.from_quat(f.attitudes[0]).as_matrix()[:, :, 2]
    v = f.ground_velocities[0].copy()
    if errors is None:
        q, R = _offset_attitude(f.attitudes[0], cal.axis_offset)
        fa = f.aero_forces[0] + thrust[:, None] * (true_b3 - R[:, :, 2])
    else:  # the log holds the estimates, and fa computed from them and the commanded thrust
        e = errors[per - 1::per]  # at each sample's last control step
        tilt = np.column_stack([e[:, 0], e[:, 1], np.zeros(len(e))])
        est = Rotation.from_rotvec(tilt) * Rotation.from_quat(f.attitudes[0])
        q, R = _offset_attitude(est.as_quat(), cal.axis_offset)
        believed = thrust / (1.0 + e[:, 2])
        fa = f.aero_forces[0] + thrust[:, None] * true_b3 - believed[:, None] * R[:, :, 2]
        v = v + e[:, 3:]
    ref = FIGURE8.flat_output(t)
    hover = vehicle.weight / vehicle.max_thrust
    arrays = {"t": t, "p": f.positions[0].copy(), "p_d": f.references[0], "v": v,
              "v_d": ref["x_dot"], "q": q, "R": R, "w": f.body_rates[0],
              "T_sp": f.thrust_commands[0] / vehicle.max_thrust, "q_sp": np.zeros_like(q),
              "hover_throttle": np.full(len(t), hover), "fa": fa, "pwm": f.rotor_speeds[0]}
    noise = cal.noise_at(condition)
    if noise:
        _add_noise(arrays, noise, child_rng(root_seed(SIM_SEED), seed, k, 1), hover)
    for a in arrays.values():
        a.setflags(write=False)
    return RealFlight(controller=f"seed {seed}", condition=condition,
                      wind_speed=CONDITIONS[condition], source=f"simulated, seed {seed}",
                      vehicle="simulated", trajectory="figure8", arrays=arrays)


def replicate_vehicle(vehicle: Multirotor, calibration: TwinCalibration, seed: int,
                      condition: str) -> Multirotor:
    """The vehicle replicate ``seed`` flies at ``condition``: ``vehicle`` with its position
    control's bandwidth and integral gain each times ``exp(spread x variability x z)``, ``z``
    standard normal drawn at the seed's controller address (one controller per seed, at every
    wind), and a hover throttle drawn per flight (``hover_throttle`` +- ``hover_throttle_sd x
    variability``, kept in [0.3, 0.7]). ``vehicle`` itself when ``calibration`` draws
    nothing."""
    cal = calibration
    if not cal.varies:
        return vehicle
    root = root_seed(SIM_SEED)
    out = {}
    if cal.gain_spread or cal.integral_spread:
        if vehicle.position_control is None:
            raise ValueError("vehicle must have a position_control to draw its gains (the "
                             "calibration's gain_spread and integral_spread)")
        z = child_rng(root, seed, _CONTROLLER_KEY).standard_normal(2)
        out["position_control"] = vehicle.position_control.scaled(
            float(np.exp(cal.gain_spread * cal.variability * z[0])),
            float(np.exp(cal.integral_spread * cal.variability * z[1])))
    if cal.hover_throttle:
        k = list(CONDITIONS).index(condition)
        z = child_rng(root, seed, k, 2).standard_normal()
        out["hover_throttle"] = float(np.clip(
            cal.hover_throttle + cal.hover_throttle_sd * cal.variability * z, 0.3, 0.7))
    return replace(vehicle, **out)


def _state_errors(cal, rng, n, rate):
    """(n, 6) second-order Gauss-Markov errors at the control step (``rate`` [Hz]): white
    noise through two first-order lags of time constant ``cal.error_time`` (so almost nothing
    above the 2 Hz noise cutoff, whose level the noise fit owns), after a burn-in of ten time
    constants, each column with the SD :meth:`TwinCalibration.state_error_sds` (tilt x, y
    [rad], thrust [-], velocity x, y, z [m/s])."""
    return _gauss_markov(rng, n, rate, cal.error_time, cal.state_error_sds())


def _gauss_markov(rng, n, rate, tau, sd):
    """(n, len(sd)) second-order Gauss-Markov errors at ``rate`` [Hz], time constant ``tau``
    [s], each column of SD ``sd``, drawn from ``rng``
    (:func:`uavwind.sim.variability.gauss_markov`)."""
    z = rng.standard_normal((n + burn_in(rate, tau), len(sd)))
    return gauss_markov(z, rate, tau, sd, axis=0)


def _turbulence_tilt(cal, rng, n, rate, speed):
    """(n, 2) further tilt errors [rad] of the attitude estimate about world x and y in a
    wind of mean ``speed`` [m/s], at the control step: a second-order Gauss-Markov process
    (``cal.error_time``) of SD ``turbulence_tilt x speed x variability`` [deg], ramped in with
    the wind (:data:`RAMP`), added to the still-air tilt errors (their variances add).

    What it stands for: the real pitch's lap-to-lap spread doubles from still air to 8.5 m/s
    while the twin's, whose gusts are uniform across it, hardly moves. The attitude
    estimate's gravity reference is the accelerometer, which in a turbulent flow reads the
    drag's fluctuations and the airframe's buffeting on top of gravity, so the estimate's
    slow error grows with the flow's fluctuation, which at a fixed turbulence intensity (the
    Dryden model's ``sigma ~ U``) grows with the mean speed. Like the still-air tilt error it
    is flown by the controller and carried by the record (the estimate), so ``fa``, computed
    from the recorded attitude, carries it too, as the authors' does.

    Tried and set aside: the same tilt as a true tilt of the body that the estimate follows
    (the rotary part of a gust, MIL-F-8785C's ``q_g``): the position loop takes it back below
    its bandwidth, so it raised the pitch's spread little (0.58 to 0.86 deg at 8.5 m/s with a
    1.7 deg tilt) and the position's and the attitude noise's far beyond the real ones."""
    ramp = np.minimum(np.arange(n) / (rate * RAMP), 1.0)[:, None]
    sd = np.radians(cal.turbulence_tilt * speed) * cal.variability
    return _gauss_markov(rng, n, rate, cal.error_time, np.array([sd, sd])) * ramp


def _add_noise(arrays, noise, rng, hover):
    """White noise on the recorded channels, in place, each axis with the standard deviation
    whose part above the noise cutoff is ``noise``'s (``{column: std}``)."""
    from scipy.spatial.transform import Rotation

    n = len(arrays["t"])

    def draw(column):
        return rng.standard_normal(n) * noise.get(column, 0.0) / np.sqrt(_ABOVE_CUTOFF)

    for ch, key in (("position", "p"), ("velocity", "v"), ("aero_force", "fa")):
        arrays[key] = arrays[key] + np.column_stack([draw(f"noise_{ch}_{ax}") for ax in "xyz"])
    arrays["T_sp"] = arrays["T_sp"] + draw("noise_thrust_t") * hover
    # the attitude channel is the body z axis: a small world-frame tilt about y moves its x,
    # about x its y
    tilt = np.column_stack([draw("noise_attitude_y"), draw("noise_attitude_x"), np.zeros(n)])
    rot = Rotation.from_rotvec(tilt) * Rotation.from_quat(arrays["q"])
    arrays["q"], arrays["R"] = rot.as_quat(), rot.as_matrix()


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


# --------------------------------------------------------------------------- #
# calibration
# --------------------------------------------------------------------------- #
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
    on the mean spread over :data:`N_SEEDS` such replicates, with their noise; without it,
    the twin of gusts and noise alone, its gusts fitted on seed 0 without noise.

    With ``per_wind`` (the default) the fit uses every wind the training flights have,
    not one: the drag, the rotor drag and the lift on the mean forces at every wind
    (:func:`_fit_forces_per_wind`), and with ``variability`` the errors' correlation time on
    the still-air position spread (:func:`_fit_error_time`), and with ``pitch_turbulence``
    the attitude estimate's error in wind on the pitch spread at every wind
    (:func:`_fit_turbulence_tilt`), before the gusts. ``per_wind`` False: the first twin
    (forces at :data:`FIT_CONDITION` alone, the correlation time :data:`ERROR_TIME` assumed),
    to the double.

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
    vertical_share = _check_share(vertical_share)
    integral_spread = _check_integral(integral_spread)
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


def _check_share(vertical_share):
    """``vertical_share`` checked: ``"fit"`` or a number in [0, 1] (as a float)."""
    if isinstance(vertical_share, str):
        if vertical_share != "fit":
            raise ValueError(f"vertical_share must be a number in [0, 1] or 'fit', got "
                             f"{vertical_share!r}")
        return vertical_share
    return check_scalar(vertical_share, "vertical_share", low=0.0, high=1.0)


def _check_integral(integral_spread):
    """``integral_spread`` checked: ``"fit"``, ``"bandwidth"`` (the bandwidth's own spread,
    the twin of SIM_VERSION 8) or a log-SD in [0, 2] (as a float)."""
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
    at = train[train["condition"] == SPREAD_CONDITION]
    target = float(at["position_spread"].mean()) if "position_spread" in at else np.nan
    if not np.isfinite(target):
        raise ValueError(f"the integral spread's fit needs the training flights' position "
                         f"spread at {SPREAD_CONDITION!r} (or calibrate_twin(..., "
                         f"integral_spread='bandwidth'))")
    tried, got = {}, {}

    def measure(x):
        if x not in tried:
            tried[x] = build(float(x))
            got[x] = float(_replicate_mean(tried[x], SPREAD_CONDITION, study,
                                           ("position_spread",))[0])
        return got[x]

    def done(c):
        key = ("lap-to-lap spread of position", SPREAD_CONDITION)
        return c if key in c.fitted_on else replace(c, fitted_on=c.fitted_on + (key,))

    if measure(high) <= target:
        return done(tried[high])
    if measure(0.0) >= target:
        return done(tried[0.0])
    best = _secant(measure, target, high, 0.0, 0.0, high, 0.05 * target, "integral spread")
    return done(tried[best])


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
    at = train[train["condition"] == SPREAD_CONDITION]
    target = float(at["position_spread"].mean()) if "position_spread" in at else np.nan
    if not np.isfinite(target):
        raise ValueError(f"the vertical share's fit needs the training flights' position "
                         f"spread at {SPREAD_CONDITION!r} (or calibrate_twin(..., "
                         f"vertical_share=0.0))")
    tried, got = {}, {}

    def measure(share):
        if share not in tried:  # a twin per share: the secant starts from the bounds tried
            tried[share] = build(float(share))
            got[share] = float(_replicate_mean(tried[share], SPREAD_CONDITION, study,
                                               ("position_spread",))[0])
        return got[share]

    def done(c):
        return replace(c, fitted_on=c.fitted_on + (("lap-to-lap spread of position",
                                                    SPREAD_CONDITION),))

    if measure(1.0) >= target:
        return done(tried[1.0])
    if measure(0.0) <= target:
        return done(tried[0.0])
    best = _secant(measure, target, 0.0, 1.0, 0.0, 1.0, 0.05 * target, "vertical share")
    return done(tried[best])


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
    :data:`ERROR_TIME`, within [0.02, 2] s.

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


def simulated_flights(calibration: TwinCalibration, n_seeds: int = N_SEEDS,
                      conditions=tuple(CONDITIONS), duration: float = DURATION) -> list[RealFlight]:
    """Every condition x seed flown by the calibrated twin for ``duration`` [s] (the order
    of :func:`uavwind.load_neuralfly`)."""
    v = calibration.vehicle()
    return [simulated_flight(v, c, s, duration=duration, calibration=calibration)
            for s in range(n_seeds) for c in conditions]


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
    :class:`TwinCalibration` as a dict, ``attrs["held_out"]`` the controller it was not fitted
    on), kept by :func:`uavwind.analysis.memo.memo` under a digest of the training
    controllers' flight rows, the study and the version; a damaged or altered copy is
    recomputed with a warning. ``variability`` False: the twin whose replicates differ by
    gusts and noise alone (:func:`calibrate_twin`'s); ``per_wind`` False: the twin fitted at
    one wind; ``pitch_turbulence``: with the attitude estimate's error in wind (both
    :func:`calibrate_twin`'s); ``fit_noise`` False: the noise set to the training mean, not
    fitted on the twin's own content; ``vertical_share``: the vertical error's share carried
    by the vertical velocity estimate; ``integral_spread``: the integral gain's spread (both
    :func:`calibrate_twin`'s)."""
    for name, flag in (("variability", variability), ("per_wind", per_wind),
                       ("pitch_turbulence", pitch_turbulence), ("fit_noise", fit_noise)):
        if not isinstance(flag, bool):
            raise TypeError(f"{name} must be True or False, got {flag!r}")
    vertical_share = _check_share(vertical_share)
    integral_spread = _check_integral(integral_spread)
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
    """The :class:`TwinCalibration` :func:`sim_rows` fitted (from its ``attrs``)."""
    d = json.loads(sim.attrs["calibration"])
    d["noise"] = tuple(tuple(x) for x in d["noise"])
    return TwinCalibration(**d)


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


#: What :func:`validation_table` compares: name -> (flight-row column, subtract 0 m/s, unit).
VALIDATION = {"force along x": ("aero_force_x", True, "N"),
              "force along z": ("aero_force_z", True, "N"),
              "lean": ("pitch_deg", False, "deg"),
              "tracking error": ("tracking_rms", False, "m"),
              "lap-to-lap spread of force x": ("fa_x_spread", False, "N"),
              "lap-to-lap spread of pitch": ("pitch_spread", False, "deg"),
              "lap-to-lap spread of vertical tracking": ("z_tracking_spread", False, "m"),
              "lap-to-lap spread of position": ("position_spread", False, "m"),
              "noise of force x": ("noise_aero_force_x", False, "N"),
              "noise of the attitude x": ("noise_attitude_x", False, "1")}


def validation_table(real_rows: pd.DataFrame, sim: pd.DataFrame) -> pd.DataFrame:
    """The twin against the real flights, per wind and quantity (:data:`VALIDATION`): the
    twin's mean over its seeds (``sim``) with their range, the held-out controller's value
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


#: The quantities of :data:`VALIDATION` that are the vehicle's physics (tracking error is the
#: controller's own): what :func:`validation_score` averages.
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
