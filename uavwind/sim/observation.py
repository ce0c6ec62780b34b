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
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_scalar
from ..core.seeding import child_seed

if TYPE_CHECKING:
    from .flight import Flight

__all__ = ["OBSERVATIONS", "Noise", "CONSUMER_NOISE", "gauss_markov", "observe",
           "check_observation", "noise_seed"]

#: The channels a loop can cluster on.
OBSERVATIONS = ("position", "velocity", "acceleration", "position+velocity")


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
        White noise on specific forces [m/s^2], in [0, 100].

    >>> Noise(position=0.3).is_zero
    False
    """

    position: float = 0.0
    bias: float = 0.0
    bias_time: float = 300.0
    velocity: float = 0.0
    acceleration: float = 0.0

    def __post_init__(self):
        for name, high in (("position", 1e3), ("bias", 1e3), ("velocity", 1e2),
                           ("acceleration", 1e2)):
            object.__setattr__(self, name, check_scalar(getattr(self, name), name, low=0.0,
                                                        high=high))
        object.__setattr__(self, "bias_time", check_scalar(
            self.bias_time, "bias_time", low=0.0, low_inclusive=False, high=1e7))

    @property
    def is_zero(self) -> bool:
        return not (self.position or self.bias or self.velocity or self.acceleration)


#: Consumer-grade levels (u-blox NEO-M8 receiver, MPU-6000 IMU; see the module text).
CONSUMER_NOISE = Noise(position=2.5 / 1.1774, velocity=0.05, acceleration=400e-6 * 9.81 * 5 ** 0.5)


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
    dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False)
    sigma = check_scalar(sigma, "sigma", low=0.0)
    tau = check_scalar(tau, "tau", low=0.0, low_inclusive=False)
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


def observe(flight: Flight, observation: str = "position", noise: Noise | None = None,
            seed: int | np.random.SeedSequence | None = None,
            gravity: float = 9.81) -> np.ndarray:
    """The channel ``observation`` of ``flight`` with ``noise`` added.

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
    ndarray, shape (n_env, n_steps, 3) (6 for ``"position+velocity"``)
        Position [m], ground velocity [m/s] or specific force [m/s^2].
    """
    check_observation(observation)
    gravity = check_scalar(gravity, "gravity", low=0.0, high=1e3)
    if noise is not None and not isinstance(noise, Noise):
        raise TypeError(f"noise must be a Noise or None, got {type(noise).__name__}")
    noise = noise or Noise()
    rng = np.random.default_rng(seed if isinstance(seed, np.random.SeedSequence)
                                else np.random.SeedSequence(seed))
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
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=2)
