"""A multirotor as unsteady as a real one: the flight-to-flight and within-flight sources of
variability that Experiment 13's twin fits on real flights, as a value a loop can fly.

This module owns :class:`FlightVariability`: the sizes of the sources (an attitude estimate
tilted off the true attitude, a thrust off the commanded, a velocity estimate off the true
velocity, the battery's hover throttle, the position controller's bandwidth and integral gain,
and Dryden gusts on the mean wind, the wind tunnel's turbulence) and :meth:`FlightVariability.draw`,
which turns them into what one loop flies: its vehicle, the per-control-step errors of each
environment and the gusts. A :class:`~uavwind.sim.setting.Setting` with ``variability`` flies
every loop so (:meth:`~uavwind.sim.setting.Setting.observe`); which values apply to which
experiment, and where they were fitted, is :mod:`uavwind.analysis.sensitivity`'s.

How each source acts (the twin's reading, :mod:`uavwind.analysis.twin`):

* *within a flight*, per environment, each a second-order Gauss-Markov process (white noise
  through two first-order lags of time constant ``error_time``, after a burn-in of ten) at the
  control rate: the attitude estimate's tilt about world x and y, the thrust's relative
  error, the velocity estimate's error along world x. Under position control (a reference
  flight, the kernels' mode 4) the controller reads the estimates and the rotors make
  ``1 + e_t`` times its thrust. Flown open loop (``cmd_ctatt``, mode 0) the attitude loop
  reads the tilted estimate ``E R``, which is exactly the true attitude flying the command
  ``E^T R_d`` (the law's error ``Rd^T E R - R^T E^T Rd`` is the same), and the rotors make
  ``1 + e_t`` times the commanded thrust: both are applied to the command
  (:meth:`~uavwind.sim.multirotor.Multirotor.fly`'s ``state_errors``); no velocity is read;
* *between loops*: the vehicle that flies a loop's environments draws once per loop its
  battery (hover throttle times ``1 + battery z``: the rotors' top speed, so where they
  saturate) and, under position control, its controller's bandwidth and integral gain
  (:meth:`~uavwind.sim.rotor_params.PositionControl.scaled` by log-normal factors);
* *the wind*: MIL-F-8785C Dryden gusts added to each environment's mean wind, ``W20 =
  gust_scale x`` its mean speed (a turbulence group's mean is zero: nothing added, beyond
  the floor :data:`~uavwind.sim.dryden.W20_MIN` of its W20).

All zeros (the default) is no variability: the loop flies exactly as without it.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

import numpy as np

from ..core.checks import Range, check_fields, check_instance
from ..core.seeding import child_rng, child_seed
from .dryden import W20_MIN, DrydenWind
from .multirotor import Multirotor

__all__ = ["FlightVariability", "VARIABILITY_KEY", "gauss_markov", "burn_in"]

#: Spawn key of a loop's variability draws under its wind seed (the noise is ``2``): the
#: vehicle ``(3, 0)``, the state errors ``(3, 1)``, the gusts ``(3, 2)``.
VARIABILITY_KEY = 3

_FIELDS = {"attitude_error": Range(0.0, 10.0), "thrust_error": Range(0.0, 0.2),
           "velocity_error": Range(0.0, 2.0), "vertical_velocity_error": Range(0.0, 2.0),
           "battery": Range(0.0, 0.5),
           "gain_spread": Range(0.0, 2.0), "integral_spread": Range(0.0, 2.0),
           "gust_scale": Range(0.0, 10.0),
           "error_time": Range(0.0, 100.0, low_inclusive=False)}


def burn_in(rate: float, tau: float) -> int:
    """Samples :func:`gauss_markov` drops before its output: ten time constants ``tau`` [s]
    at ``rate`` [Hz], after which the lags have forgotten their zero start."""
    return int(np.ceil(10 * tau * rate))


def gauss_markov(white: np.ndarray, rate: float, tau: float, sd, axis: int = 0) -> np.ndarray:
    """A second-order Gauss-Markov process from white noise: ``white`` (standard normal,
    :func:`burn_in` samples longer along ``axis`` than the output) through two first-order
    lags of time constant ``tau`` [s] at ``rate`` [Hz], the burn-in dropped, each last-axis
    column scaled to its SD ``sd`` (the cascade's own SD is ``(1 - a)^2 sqrt((1 + a^2) /
    (1 - a^2)^3)``, ``a = exp(-1 / (rate tau))``). The twin's state errors
    (:mod:`uavwind.analysis.twin`) and a loop's (:meth:`FlightVariability.state_errors`)
    are both drawn through it."""
    from scipy.signal import lfilter

    a = float(np.exp(-1.0 / (rate * tau)))
    burn = burn_in(rate, tau)
    z = white
    for _ in range(2):
        z = lfilter([1.0 - a], [1.0, -a], z, axis=axis)
    unit = np.sqrt((1.0 - a) ** 4 * (1.0 + a * a) / (1.0 - a * a) ** 3)  # the cascade's SD
    return np.delete(z, np.s_[:burn], axis=axis) * (np.asarray(sd) / unit)


@dataclass(frozen=True, kw_only=True)
class FlightVariability:
    """The sources of a loop's variability (see the module text); every size 0 by default.

    Parameters
    ----------
    attitude_error : float
        SD of the attitude estimate's tilt about each world horizontal axis [deg], in [0, 10].
    thrust_error : float
        SD of the thrust's relative error [-], in [0, 0.2].
    velocity_error : float
        SD of the velocity estimate's error along world x [m/s], in [0, 2] (read by a
        position controller only).
    vertical_velocity_error : float
        SD of the velocity estimate's error along world z [m/s], in [0, 2] (read by a
        position controller only: what makes a held height wander in still air beside the
        thrust error; the twin's fit gives it all of that wander).
    battery : float
        Relative SD of the hover throttle (weight over full thrust) [-], in [0, 0.5]; drawn
        per loop, kept in [0.5, 1.5] times the vehicle's.
    gain_spread, integral_spread : float
        Log-SD of the position controller's bandwidth and of its integral gain's own factor
        [-], in [0, 2]; drawn per loop (a vehicle with a position control only).
    gust_scale : float
        Dryden ``W20`` over each environment's mean wind speed [-], in [0, 10].
    error_time : float
        Time constant of each lag of the Gauss-Markov errors [s], in (0, 100]; default 0.2
        (:data:`uavwind.analysis.twin.ERROR_TIME`).
    """

    attitude_error: float = 0.0
    thrust_error: float = 0.0
    velocity_error: float = 0.0
    vertical_velocity_error: float = 0.0
    battery: float = 0.0
    gain_spread: float = 0.0
    integral_spread: float = 0.0
    gust_scale: float = 0.0
    error_time: float = 0.2

    def __post_init__(self):
        check_fields(self, _FIELDS)

    @property
    def off(self) -> bool:
        """True when no source acts (every size 0): a loop flies as without variability."""
        return not any((self.attitude_error, self.thrust_error, self.velocity_error,
                        self.vertical_velocity_error,
                        self.battery, self.gain_spread, self.integral_spread, self.gust_scale))

    @property
    def needs_control(self) -> bool:
        """True when a source acts only through a position controller (the velocity
        estimate, the controller's gains)."""
        return bool(self.velocity_error or self.vertical_velocity_error or self.gain_spread
                    or self.integral_spread)

    @property
    def has_errors(self) -> bool:
        """True when a loop draws within-flight state errors."""
        return bool(self.attitude_error or self.thrust_error or self.velocity_error
                    or self.vertical_velocity_error)

    def to_dict(self) -> dict:
        return asdict(self)

    def sds(self) -> np.ndarray:
        """The SDs of the six errors a flight draws: tilt about world x and y [rad], thrust
        [-], velocity along x, y, z [m/s] (along x only, as the twin draws it)."""
        a = np.radians(self.attitude_error)
        return np.array([a, a, self.thrust_error, self.velocity_error, 0.0,
                         self.vertical_velocity_error])

    def vehicle(self, uav: Multirotor, seed) -> Multirotor:
        """The vehicle of one loop: ``uav`` with its battery and controller drawn from
        ``seed`` (``uav`` itself when neither is drawn)."""
        check_instance(uav, "uav", Multirotor)
        out = {}
        z = child_rng(seed, 0).standard_normal(3)
        if self.battery:
            hover = uav.weight / uav.max_thrust
            out["hover_throttle"] = float(hover * np.clip(1.0 + self.battery * z[0], 0.5, 1.5))
        if self.gain_spread or self.integral_spread:
            if uav.position_control is None:
                raise ValueError("variability: gain_spread and integral_spread draw a position "
                                 "controller's gains; this vehicle has none (position_control "
                                 "None)")
            out["position_control"] = uav.position_control.scaled(
                float(np.exp(self.gain_spread * z[1])),
                float(np.exp(self.integral_spread * z[2])))
        return replace(uav, **out) if out else uav

    def state_errors(self, n_env: int, n_ctrl: int, rate: float, seed) -> np.ndarray:
        """(n_env, n_ctrl, 6) errors at ``rate`` [Hz] control steps (columns as :meth:`sds`),
        each environment its own second-order Gauss-Markov draw from ``seed``."""
        burn = burn_in(rate, self.error_time)
        z = child_rng(seed, 1).standard_normal((n_env, n_ctrl + burn, 6))
        return gauss_markov(z, rate, self.error_time, self.sds(), axis=1)

    def gusts(self, speeds, altitude: float, dt: float, seed) -> DrydenWind | None:
        """Dryden gusts on environments of mean wind ``speeds`` (n_env,) [m/s], ``W20 =
        gust_scale x speed`` (at least :data:`~uavwind.sim.dryden.W20_MIN`), at ``altitude``
        [m], sampled every ``dt`` [s]; None without gusts."""
        if not self.gust_scale:
            return None
        speeds = np.asarray(speeds, dtype=float)
        w20 = np.maximum(self.gust_scale * speeds, W20_MIN)
        return DrydenWind(w20, altitude=altitude, airspeed=np.maximum(speeds, W20_MIN), dt=dt,
                          seed=child_seed(seed, 2))
