"""What the UAV observes of its flight, and how noisily (Exps 7 and 8).

This module owns the observation side of a loop:

* :data:`OBSERVATIONS` -- the channels a loop can cluster: ``"position"`` (the
  paper), ``"velocity"`` (ground velocity, as a GNSS receiver reports it),
  ``"acceleration"`` (specific force, as an IMU sees it: inertial acceleration
  without gravity) and ``"position+velocity"`` (six channels side by side);
* :class:`Noise` -- a small, seeded noise model: white Gaussian noise per axis on
  each channel, plus an optional first-order Gauss-Markov bias on positions (as
  GNSS receivers show);
* :func:`gauss_markov` and :func:`observe` -- the noise and the channels applied to a
  :class:`~uavwind.sim.flight.Flight`.

Noise draws come from a ``numpy.random.SeedSequence`` that the loop derives from
its own seed (spawn key ``(..., 2)`` beside the turbulence's ``0`` and ``1``), so
results do not depend on the number of workers, and two noise levels of one loop
use the same standard-normal draws scaled differently (common random numbers).

Typical consumer levels (:data:`CONSUMER_NOISE`), with their sources:

* position: u-blox NEO-M8 data sheet, horizontal accuracy 2.5 m CEP (GPS+GLONASS),
  i.e. sigma = 2.5 / 1.1774 = 2.1 m per axis for a circular Gaussian;
* velocity: the same data sheet, velocity accuracy 0.05 m/s;
* acceleration: InvenSense MPU-6000 data sheet, accelerometer noise density
  400 ug/sqrt(Hz); sampled at 10 Hz (5 Hz bandwidth) that is
  400e-6 x 9.81 x sqrt(5) = 0.0088 m/s^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
import numpy as np

from ..core.checks import Range, check_fields, check_instance, check_scalar
from ..core.seeding import child_seed, root_seed
from .flight import Flight

__all__ = ["OBSERVATIONS", "ATTITUDE_CHANNELS", "POINT_MASS_OBSERVATIONS", "Noise",
           "CONSUMER_NOISE", "CONSUMER_SENSORS", "rotorpy_imu_noise", "gauss_markov", "observe", "check_observation",
           "noise_seed"]

#: The channels a loop can cluster on (the last three need a multirotor).
OBSERVATIONS = ("position", "velocity", "acceleration", "position+velocity", "attitude",
                "body_rates", "imu")
#: Channels only a vehicle with an attitude has.
ATTITUDE_CHANNELS = ("attitude", "body_rates", "imu")
#: The channels of the point mass (Exp 8).
POINT_MASS_OBSERVATIONS = tuple(o for o in OBSERVATIONS if o not in ATTITUDE_CHANNELS)


def check_observation(observation: str) -> str:
    """``observation`` if it names a channel of :data:`OBSERVATIONS`, else ``ValueError``."""
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation must be one of {list(OBSERVATIONS)}, got {observation!r}")
    return observation


@dataclass(frozen=True)
class Noise:
    """Observation noise, every field in its channel's units, per axis.

    Attributes
    ----------
    position : float
        White Gaussian noise on positions, standard deviation [m], in [0, 1000].
    bias : float
        Standard deviation of a first-order Gauss-Markov bias on positions [m], in
        [0, 1000] (0: none).
    bias_time : float
        Correlation time tau of that bias [s], > 0.
    velocity : float
        White noise on ground velocities [m/s], in [0, 100].
    acceleration : float
        White noise on specific forces (the accelerometer) [m/s^2], in [0, 100].
    attitude : float
        Attitude error [rad], in [0, 1]: the true attitude turned by a small random rotation
        whose axis components are white noise of this standard deviation.
    rate : float
        White noise on body rates (the gyroscope) [rad/s], in [0, 10].

    >>> Noise(position=0.3).is_zero
    False
    """

    position: float = 0.0
    bias: float = 0.0
    bias_time: float = 300.0
    velocity: float = 0.0
    acceleration: float = 0.0
    attitude: float = 0.0
    rate: float = 0.0

    def __post_init__(self):
        check_fields(self, {"position": Range(0.0, 1e3), "bias": Range(0.0, 1e3),
                            "velocity": Range(0.0, 1e2), "acceleration": Range(0.0, 1e2),
                            "attitude": Range(0.0, 1.0), "rate": Range(0.0, 10.0),
                            "bias_time": Range(0.0, 1e7, low_inclusive=False)})

    @property
    def is_zero(self) -> bool:
        return not (self.position or self.bias or self.velocity or self.acceleration
                    or self.attitude or self.rate)


#: Consumer-grade levels (u-blox NEO-M8 receiver, MPU-6000 IMU; see the module text).
CONSUMER_NOISE = Noise(position=2.5 / 1.1774, velocity=0.05, acceleration=400e-6 * 9.81 * 5 ** 0.5)
#: The same, and the attitude and gyroscope a multirotor adds: the MPU-6000's gyroscope noise
#: density, 0.005 deg/s/sqrt(Hz), at 10 Hz; an attitude error of 1 degree (an assumption: the
#: order of a consumer autopilot's fused roll and pitch error; no data sheet states it).
CONSUMER_SENSORS = Noise(position=CONSUMER_NOISE.position, velocity=CONSUMER_NOISE.velocity,
                         acceleration=CONSUMER_NOISE.acceleration, attitude=math.radians(1.0),
                         rate=math.radians(0.005) * 5 ** 0.5)


def rotorpy_imu_noise(dt: float = 0.1) -> Noise:
    """RotorPy's IMU noise (``rotorpy.sensors.imu.Imu``'s defaults: 0.038**2 m/s^2/sqrt(Hz)
    for the accelerometer, 0.01**2 rad/s/sqrt(Hz) for the gyroscope, each times
    ``sqrt(rate / 2)``, as RotorPy draws it) at a sample every ``dt`` [s], as a :class:`Noise`
    (drawn from the loop's seed, not from NumPy's global generator as RotorPy does). Needs
    RotorPy."""
    import inspect

    from rotorpy.sensors.imu import Imu

    dt = check_scalar(dt, "dt", low=1e-4, high=10.0)
    defaults = inspect.signature(Imu).parameters
    acc = float(np.max(defaults["accelerometer_params"].default["noise_density"]))
    gyr = float(np.max(defaults["gyroscope_params"].default["noise_density"]))
    scale = math.sqrt(1.0 / dt / 2)
    return Noise(acceleration=scale * acc, rate=scale * gyr)


def gauss_markov(shape: tuple[int, int, int], dt: float, sigma: float, tau: float,
                 rng: np.random.Generator) -> np.ndarray:
    """First-order Gauss-Markov series ``b[k] = phi b[k-1] + sigma sqrt(1 - phi^2) w[k]``.

    ``phi = exp(-dt / tau)``; ``b[0]`` is drawn from the stationary N(0, sigma^2), so
    the series is stationary with autocorrelation ``sigma^2 phi^|lag|``.

    Parameters
    ----------
    shape : tuple
        ``(n_series, n_steps, n_axes)``; time runs along axis 1.
    dt, sigma, tau : float
        Step [s], standard deviation and correlation time [s].
    rng : numpy.random.Generator
    """
    if (not isinstance(shape, tuple) or len(shape) != 3
            or not all(isinstance(n, (int, np.integer)) and n >= 1 for n in shape)):
        raise ValueError(f"shape must be a tuple of 3 positive integers (n_series, n_steps, "
                         f"n_axes), got {shape!r}")
    dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False)
    sigma = check_scalar(sigma, "sigma", low=0.0)
    tau = check_scalar(tau, "tau", low=0.0, low_inclusive=False)
    check_instance(rng, "rng", np.random.Generator, "numpy.random.Generator")
    phi = math.exp(-dt / tau)
    w = rng.standard_normal(shape)
    out = np.empty(shape)
    out[:, 0] = sigma * w[:, 0]
    gain = sigma * math.sqrt(1.0 - phi * phi)
    for k in range(1, shape[1]):
        out[:, k] = phi * out[:, k - 1] + gain * w[:, k]
    return out


def noise_seed(loop_seed: int | np.random.SeedSequence | None) -> np.random.SeedSequence:
    """The noise's SeedSequence of a loop: spawn key ``(..., 2)`` of the loop's seed."""
    return child_seed(loop_seed, 2)


def specific_force(flight: Flight, gravity: float) -> np.ndarray:
    """What an IMU measures: inertial (ground) acceleration without gravity, (n_env, n, 3).

    ``(v_ground[k] - v_ground[k-1]) / dt + g e_z``, with the UAV moving with the air
    before the start (``v_ground[-1] = wind[0]``).
    """
    vg = flight.ground_velocities
    dt = float(flight.times[1] - flight.times[0]) if flight.times.size > 1 else float(flight.times[0])
    prev = np.concatenate([flight.winds[:, :1], vg[:, :-1]], axis=1)
    acc = (vg - prev) / dt
    acc[..., 2] += gravity
    return acc


def _attitude_6d(q):
    """The body's x and y axes in the world frame, (..., 6): a continuous representation of
    the attitude (Euler angles wrap; a quaternion's sign flips)."""
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = (q[..., i] for i in range(4))
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w),
                     2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w)], axis=-1)


def _small_rotation(axes6, angles):
    """``axes6`` (the body x and y axes, (..., 6)) turned by the small rotations whose
    rotation vectors are ``angles`` (..., 3) [rad] (Rodrigues' formula)."""
    th = np.linalg.norm(angles, axis=-1, keepdims=True)
    k = np.divide(angles, th, out=np.zeros_like(angles), where=th > 0)
    out = []
    for v in (axes6[..., 0:3], axes6[..., 3:6]):
        kxv = np.cross(k, v)
        kdv = np.sum(k * v, axis=-1, keepdims=True)
        out.append(v * np.cos(th) + kxv * np.sin(th) + k * kdv * (1 - np.cos(th)))
    return np.concatenate(out, axis=-1)


def observe(flight: Flight, observation: str = "position", noise: Noise | None = None,
            seed: int | np.random.SeedSequence | None = None,
            gravity: float = 9.81) -> np.ndarray:
    """The channel ``observation`` of ``flight`` with ``noise`` added (``ValueError`` or
    ``TypeError`` naming a bad argument, such as a negative ``seed``).

    Parameters
    ----------
    flight : Flight
        From :func:`uavwind.simulate_flight`.
    observation : str
        One of :data:`OBSERVATIONS`.
    noise : Noise, optional
    seed : int or SeedSequence, optional
        Seeds the noise (white draws first, then the bias).
    gravity : float
        [m/s^2], removed from the acceleration as an IMU does.

    Returns
    -------
    ndarray, shape (n_env, n_steps, 3) (6 for ``"position+velocity"``, ``"attitude"`` and ``"imu"``)
        Position [m], ground velocity [m/s] or specific force [m/s^2]; for a multirotor also
        the attitude (the body's x and y axes in the world frame, a continuous
        representation), the body rates [rad/s], or the IMU (accelerometer [m/s^2] and
        gyroscope [rad/s], body frame).
    """
    check_instance(flight, "flight", Flight)
    check_observation(observation)
    gravity = check_scalar(gravity, "gravity", low=0.0, high=1e3)
    if observation in ATTITUDE_CHANNELS and flight.attitudes is None:
        raise ValueError(f"observation {observation!r} needs a vehicle with an attitude: fly "
                         f"the loop with uav=Multirotor()")
    if noise is not None and not isinstance(noise, Noise):
        raise TypeError(f"noise must be a Noise or None, got {type(noise).__name__}")
    noise = noise or Noise()
    rng = np.random.default_rng(root_seed(seed))
    shape = flight.positions.shape
    # draw every channel's standard normals in a fixed order, used or not, so a
    # channel's noise does not depend on which other channels are observed
    white = {ch: rng.standard_normal(shape) for ch in ("position", "velocity", "acceleration")}
    parts = []
    if observation in ("position", "position+velocity"):
        p = flight.positions + noise.position * white["position"]
        if noise.bias:
            dt = float(flight.times[1] - flight.times[0]) if shape[1] > 1 else 1.0
            p = p + gauss_markov(shape, dt, noise.bias, noise.bias_time, rng)
        parts.append(p)
    if observation in ("velocity", "position+velocity"):
        parts.append(flight.ground_velocities + noise.velocity * white["velocity"])
    if observation == "acceleration":
        parts.append(specific_force(flight, gravity) + noise.acceleration * white["acceleration"])
    if observation in ATTITUDE_CHANNELS:  # drawn after the others: their draws are unchanged
        att = rng.standard_normal(shape)
        gyro = rng.standard_normal(shape)
        accel = rng.standard_normal(shape)
        if observation == "attitude":
            parts.append(_small_rotation(_attitude_6d(flight.attitudes), noise.attitude * att))
        elif observation == "body_rates":
            parts.append(flight.body_rates + noise.rate * gyro)
        else:  # the IMU: accelerometer (body frame) and gyroscope
            parts += [flight.specific_forces + noise.acceleration * accel,
                      flight.body_rates + noise.rate * gyro]
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=2)
