"""The real-flight twin: a simulated Neural-Fly quadrotor flying Neural-Fly's figure-8, recorded
as the real flights are.

This module owns :class:`TwinCalibration` (what the twin takes from the real flights; the
bare twin, :data:`BARE`, takes nothing), :func:`simulated_flight` (one twin flight in the
real flights' format, a :class:`~uavwind.data.RealFlight`, so the real flights' analysis
runs on it unchanged), :func:`simulated_flights` (every condition x replicate),
:func:`replicate_vehicle` (the vehicle one replicate flies), :func:`flight_duration`, the
constants a twin flight is flown with (:data:`FIGURE8`, :data:`SIM_SEED`, :data:`N_SEEDS`,
:data:`DURATION`, :data:`DT`, :data:`RAMP`, :data:`ERROR_TIME`) and :data:`VALIDATION`, the
quantities the twin and the real flights are compared on (a calibration's ``fitted_on`` names
them). Fitting a calibration on the real flights is :mod:`uavwind.analysis.twin_fit`'s; the
twin's cached flight rows and its validation against a held-out controller, Experiment 13's
simulated half, are :mod:`uavwind.analysis.figure8`'s.

The twin (each choice stated on the page):

* *Vehicle.* :meth:`~uavwind.sim.multirotor.Multirotor.neural_fly` (2.6 kg, thrust-to-weight
  2.2), its drag (frame, rotor drag, induced inflow) and its translational lift each scaled
  by one factor (``drag_scale``, ``lift_scale``), and the rotor drag (linear in the
  airspeed) by a second (``rotor_drag_scale``), fitted on the training controllers' mean
  force along x and along z at every wind (each controller's still-air force subtracted:
  the authors' ``fa`` holds about a newton in still air); ``per_wind`` False: the first
  twin's two factors at :data:`~uavwind.analysis.twin_fit.FIT_CONDITION` alone, the other
  winds predictions.
* *Controller.* RotorPy's SE3 law with an integral term and a thrust cone with vertical
  priority (:data:`~uavwind.sim.rotor_params.NEURAL_FLY_CONTROL`): the real controllers hold
  the path in steady wind, which a PD law cannot (it leaves a steady error of ``F / (m kp)``).
* *Wind.* Along -x, uniform, constant or 8.5 + 2.4 sin t m/s (``70p20sint``), ramped in over
  the first lap from a hover in still air, PLUS (:class:`~uavwind.sim.wind.SumWind`)
  MIL-F-8785C Dryden gusts at the flight's altitude with ``W20`` = ``gust_scale`` x the mean
  speed; ``gust_scale`` is fitted so that the twin's lap-to-lap spread of the slow part of
  the force along x matches the training controllers' at
  :data:`~uavwind.analysis.twin_fit.SPREAD_CONDITION`.
* *Sensors.* The real vehicle's attitude is measured about a body axis ``axis_offset``
  degrees from its thrust axis (in still air every controller pitches -2.4 to -3.5 deg while
  ``fa`` reads +1.0 to +1.4 N along x, ``T sin(offset)``); the twin records its attitude
  about the same offset axis and its ``fa`` as the authors compute it from that attitude.
  Every recorded channel gets white noise whose content above 2 Hz matches the training
  controllers' at the same wind.
* *Replicates.* Five seeds per condition, labelled ``seed 0`` ... ``seed 4``, as the real
  flights have five controllers. A seed is a controller and a flight
  (:func:`~uavwind.analysis.twin_fit.calibrate_twin` fits every spread on the training
  controllers; ``variability`` 0 turns them all off): the controller's bandwidth (``kp``,
  ``kd``, ``ki`` scaled together, the loop's shape kept) and its integral gain each times a
  log-normal factor (the integral's spread fitted on the position spread at 12.1 m/s,
  ``twin_fit._fit_integral_spread``), drawn once per seed (seed ``k`` is one controller at
  every wind, as a real controller is); per flight, the battery (the hover throttle, so the
  rotors' full thrust, drawn from the training flights'); and within the flight, the state
  the controller acts on: an attitude estimate tilted off the true attitude, a velocity
  estimate off the true velocity (along x, and vertically) and a thrust off the commanded,
  each a second-order Gauss-Markov process (correlation time ``error_time``) that the
  controller flies on in the kernel
  (:meth:`~uavwind.sim.multirotor.Multirotor.fly_reference`'s ``state_errors``) and that the
  record carries as a real log does (the estimated attitude and velocity, ``fa`` computed
  from them and the commanded thrust). The still-air vertical error is split between the
  thrust and the vertical velocity estimate on the position spread at 12.1 m/s
  (``twin_fit._fit_vertical_share``: on the Neural-Fly flights all of it the velocity's).
  Its own gusts and noise.
* *Held out.* The twin is fitted on every controller but one
  (:func:`~uavwind.analysis.twin_fit.held_out_controller`) and checked on that one
  (:func:`~uavwind.analysis.figure8.validation_table`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from ..core.checks import Range, check_fields, check_instance, check_scalar
from ..core.seeding import child_rng, child_seed, root_seed
from ..data.neuralfly import CONDITIONS, NOISE_CUTOFF, RealFlight
from ..sim.dryden import DrydenWind
from ..sim.dynamics import simulate_flight
from ..sim.multirotor import Multirotor
from ..sim.references import Lemniscate
from ..sim.rotor_params import NEURAL_FLY_CONTROL
from ..sim.variability import burn_in, gauss_markov
from ..sim.wind import ConstantWind, RampedWind, SinusoidalWind
from .real_flights import STUDIES, noise_columns

__all__ = ["FIGURE8", "SIM_SEED", "N_SEEDS", "DURATION", "DT", "RAMP", "ERROR_TIME",
           "VALIDATION", "TwinCalibration", "BARE", "simulated_flight", "simulated_flights",
           "replicate_vehicle", "flight_duration"]

#: Neural-Fly's reference: (1.25 sin t, 0, 0.75 sin 2t) about the real flights' centre [m].
FIGURE8 = Lemniscate(center=(0.25, 0.0, 2.15), amplitude=(1.25, 0.0, 0.75), period=2 * np.pi)
#: The root seed of the simulated gusts and sensor noise.
SIM_SEED = 13
#: Replicates (gust seeds) per condition: as many as the real flights' controllers.
N_SEEDS = 5
#: Flight length [s] and recording step [s] (the real flights': about 50 s at 50 Hz).
DURATION, DT = 50.0, 0.02
#: The wind ramps in over the first lap [s] (dropped from every analysis).
RAMP = 2 * np.pi
#: Share of a white noise's variance above the noise cutoff at the recording step.
_ABOVE_CUTOFF = 1.0 - 2.0 * NOISE_CUTOFF * DT
#: Correlation time [s] of the state-estimate and thrust errors (second-order Gauss-Markov) of
#: the first twin, and where its fit starts (``twin_fit._fit_error_time``, on the training
#: controllers' still-air position spread): slower than the 2 Hz noise cutoff, so the errors
#: move a lap's slow part, faster than a lap (6.3 s), so they differ from lap to lap.
ERROR_TIME = 0.2
#: Seed addresses (under :data:`SIM_SEED` and the seed): the controller drawn once per seed,
#: then per condition ``k`` the gusts ``(k,)``, the noise ``(k, 1)``, the battery ``(k, 2)``
#: and the state errors ``(k, 3)``.
_CONTROLLER_KEY = 1000
#: What :func:`~uavwind.analysis.figure8.validation_table` compares: name -> (flight-row
#: column, subtract 0 m/s, unit); a :class:`TwinCalibration`'s ``fitted_on`` names these
#: quantities, so they are defined with the twin, below its fit and its validation.
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


@dataclass(frozen=True, kw_only=True)
class TwinCalibration:
    """What the twin takes from the real flights
    (:func:`~uavwind.analysis.twin_fit.calibrate_twin` fits it).

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
        :func:`~uavwind.analysis.twin_fit.calibrate_twin` with ``vertical_share``).
    rotor_drag_scale : float
        Further factor on the rotor drag (linear in the airspeed) beside ``drag_scale``
        (:attr:`~uavwind.sim.multirotor.Multirotor.rotor_drag_scale`) [-] (1: the preset's
        ratio of rotor to frame drag, what one wind fixes).
    error_time : float
        Correlation time of the state-estimate and thrust errors [s] (default
        :data:`ERROR_TIME`, assumed; :func:`~uavwind.analysis.twin_fit.calibrate_twin` fits
        it).
    turbulence_tilt : float
        SD of the turbulence's tilt of the attitude per metre per second of mean wind
        [deg/(m/s)], about each world horizontal axis (0: none; :func:`simulated_flight`).
    fitted_on : tuple of (quantity, condition)
        The rows of :func:`~uavwind.analysis.figure8.validation_table` beyond the first
        twin's that the fit used (the training controllers' mean there): only the
        held-out column checks them.
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
    fitted twin (:func:`~uavwind.analysis.twin_fit.calibrate_twin`,
    :func:`~uavwind.analysis.figure8.calibration_of`), or :data:`BARE` to fly the
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


def simulated_flights(calibration: TwinCalibration, n_seeds: int = N_SEEDS,
                      conditions=tuple(CONDITIONS), duration: float = DURATION) -> list[RealFlight]:
    """Every condition x seed flown by the calibrated twin for ``duration`` [s] (the order
    of :func:`uavwind.load_neuralfly`)."""
    v = calibration.vehicle()
    return [simulated_flight(v, c, s, duration=duration, calibration=calibration)
            for s in range(n_seeds) for c in conditions]
