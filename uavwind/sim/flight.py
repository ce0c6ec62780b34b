"""What one flight records: :class:`Flight`, the same record for every vehicle.

The point mass fills positions, velocities, winds and the thrust; the multirotor adds its
attitude, body rates, rotor speeds, specific force and how often its limits bound.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Flight"]


@dataclass(frozen=True)
class Flight:
    """Everything recorded along one simulated flight.

    Attributes
    ----------
    times : ndarray, shape (n_steps,)
        Sample times [s]: ``dt, 2 dt, ..., duration``.
    positions : ndarray, shape (n_env, n_steps, 3)
        Position after each step [m].
    ground_velocities : ndarray, shape (n_env, n_steps, 3)
        Velocity over ground used during each step [m/s].
    air_velocities : ndarray, shape (n_env, n_steps, 3)
        Velocity relative to the air during each step [m/s].
    winds : ndarray, shape (n_env, n_steps, 3)
        Wind velocity met during each step, at the position where the step
        started [m/s].
    thrust : ndarray, shape (n_steps, 3)
        Thrust applied during each step [N].
    start : ndarray, shape (3,)
        Initial position [m].
    attitudes : ndarray, shape (n_env, n_steps, 4), optional
        Multirotor only: attitude quaternion [i, j, k, w] (scalar last, body -> world)
        after each step.
    body_rates : ndarray, shape (n_env, n_steps, 3), optional
        Multirotor only: body rates [rad/s], body frame.
    rotor_speeds : ndarray, shape (n_env, n_steps, 4), optional
        Multirotor only: rotor speeds [rad/s].
    specific_forces : ndarray, shape (n_env, n_steps, 3), optional
        Multirotor only: what an accelerometer at the centre of mass measures, body frame
        [m/s^2] (``R^T (dv/dt - g)``, RotorPy's IMU without noise).
    tilt_limited : float
        Multirotor only: share of the control steps whose thrust lay beyond the tilt limit.
    motor_limited : float
        Multirotor only: share of the control steps (over environments) in which a motor
        command was clipped to the motors' range.
    """

    times: np.ndarray
    positions: np.ndarray
    ground_velocities: np.ndarray
    air_velocities: np.ndarray
    winds: np.ndarray
    thrust: np.ndarray
    start: np.ndarray
    attitudes: np.ndarray | None = None
    body_rates: np.ndarray | None = None
    rotor_speeds: np.ndarray | None = None
    specific_forces: np.ndarray | None = None
    tilt_limited: float = 0.0
    motor_limited: float = 0.0

    @property
    def n_env(self) -> int:
        return self.positions.shape[0]
