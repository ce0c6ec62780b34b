"""What one flight records: :class:`Flight`, the same record for every vehicle.

The point mass fills positions, velocities, winds and the thrust; the multirotor adds its
attitude, body rates, rotor speeds, specific force and how often its limits bound; a flight of
a position reference adds the reference, the commanded thrust and the aerodynamic force.
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
    thrust : ndarray, shape (n_steps, 3), or (n_env, n_steps, 3) for a reference flight
        Thrust applied during each step [N], world frame (a reference flight: each
        environment's commanded collective thrust along its body z axis at the step's start).
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
    references : ndarray, shape (n_env, n_steps, 3), optional
        Reference flights only: the reference position p_d at each sample time [m].
    thrust_commands : ndarray, shape (n_env, n_steps), optional
        Reference flights only: the collective thrust the position controller commanded for
        the step ending at each sample [N] (``SE3Control``'s ``cmd_thrust``).
    aero_forces : ndarray, shape (n_env, n_steps, 3), optional
        Reference flights only: the aerodynamic force on the vehicle after each step, world
        frame [N]: ``m dv/dt - m g - R (0, 0, sum k_eta omega_i^2)``, everything but gravity and
        the rotors' nominal thrust (frame drag, rotor drag, inflow, translational lift); the
        simulated counterpart of Neural-Fly's ``fa``.
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
    references: np.ndarray | None = None
    thrust_commands: np.ndarray | None = None
    aero_forces: np.ndarray | None = None

    @property
    def n_env(self) -> int:
        return self.positions.shape[0]
