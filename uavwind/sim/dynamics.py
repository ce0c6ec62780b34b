"""Point-mass flight through wind: the integrator of paper eqs 2-8.

This module owns :func:`simulate` (positions only, the input of clustering) and
:func:`simulate_flight` (positions plus the velocities and winds along the path,
for figures). Both fly one open-loop :class:`~uavwind.sim.actions.ThrustSequence`
through every environment of a :class:`~uavwind.sim.wind.WindModel` at once: the
only Python loop is over time steps; environments are a NumPy axis.

One step of length ``dt`` from time ``t_k = k dt`` (replication notes, decision 1)::

    F      = F_thrust(t_k) - 1/2 rho C_D S |v_air| v_air + (0, 0, -m g)
    v_air += F / m * dt
    v_gnd  = v_air + v_wind(t_k, r)
    r     += v_gnd * dt                 -> recorded as sample k (time t_k + dt)

with ``v_air = 0`` and ``r = (0, 0, z0)`` at t = 0. There is no ground: the
altitude may become negative, as in the paper.
"""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

from .actions import AttitudeSequence, ThrustSequence
from .flight import Flight
from .multirotor import Multirotor
from .references import Reference
from ..core.checks import check_array, check_scalar
from .vehicle import UAV, n_steps as _n_steps
from .wind import WindModel

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["simulate", "simulate_flight", "max_stable_dt"]  # Flight: uavwind.sim.flight


def _check_time_grid(dt, duration):
    """``(dt, duration, n)`` checked: both positive, at most :data:`MAX_STEPS` samples."""
    dt = check_scalar(dt, "dt", low=0, low_inclusive=False)
    duration = check_scalar(duration, "duration", low=0, low_inclusive=False, high=1e6)
    if duration / dt > MAX_STEPS:
        raise ValueError(f"dt = {dt:g} s over duration = {duration:g} s asks for "
                         f"{duration / dt:.3g} steps per environment; at most {MAX_STEPS:,} are "
                         f"allowed: use dt >= {duration / MAX_STEPS:g} s")
    return dt, duration, _n_steps(dt, duration)


def _prepare_reference(reference, wind, uav, dt, duration, start_position):
    """Checks of a reference flight: ``n`` samples."""
    if not isinstance(wind, WindModel):
        raise TypeError(f"wind must be a WindModel, got {type(wind).__name__}")
    if not isinstance(uav, Multirotor):
        raise TypeError(f"a reference needs a multirotor: a {type(reference).__name__} is "
                        f"tracked by a position controller, which the point mass "
                        f"({type(uav).__name__}) does not have; fly it with uav=Multirotor()")
    if start_position is not None:
        raise ValueError("start_position: a reference flight starts hovering at the reference's "
                         "position at t = 0; move the reference instead")
    dt, duration, n = _check_time_grid(dt, duration)
    uav.check_grid(dt)
    return n, float(dt)


def _prepare(thrust, wind, uav, dt, duration, start_altitude, start_position):
    if not isinstance(thrust, (ThrustSequence, AttitudeSequence)):
        raise TypeError(f"thrust must be a ThrustSequence, an AttitudeSequence or a Reference, "
                        f"got {type(thrust).__name__}")
    if not isinstance(wind, WindModel):
        raise TypeError(f"wind must be a WindModel, got {type(wind).__name__}")
    if not isinstance(uav, (UAV, Multirotor)):
        raise TypeError(f"uav must be a UAV or a Multirotor, got {type(uav).__name__}")
    if isinstance(thrust, AttitudeSequence) and not isinstance(uav, Multirotor):
        raise ValueError("thrust: an AttitudeSequence commands an attitude, which the point "
                         "mass does not have: fly it with uav=Multirotor()")
    dt, duration, n = _check_time_grid(dt, duration)
    thrust.check_within(duration)
    _check_thrust_grid(thrust, dt, n)
    if isinstance(uav, Multirotor):
        uav.check_grid(dt)
        uav.check_thrust(thrust)
    else:
        _check_drag_stability(thrust, uav, dt, duration)
    if start_position is None:
        start = np.array([0.0, 0.0, check_scalar(start_altitude, "start_altitude")])
    else:
        start = check_array(start_position, "start_position", shape=(3,))
    t_start = np.arange(n) * dt
    forces = thrust.thrust(t_start) if isinstance(thrust, ThrustSequence) else None
    return n, t_start, forces, start


#: Most time steps one simulation may take (memory: n_env x steps x 3 doubles).
MAX_STEPS = 1_000_000


def _check_thrust_grid(thrust, dt, n):
    """Warn where a thrust change does not fall on a step start: it takes effect at the
    next step start, or never if it comes after the last one."""
    last = (n - 1) * dt
    for t in thrust.times[1:]:
        k = t / dt
        if t > last + 1e-9 * dt:
            warnings.warn(f"the thrust change at t = {t:g} s comes after the last step start "
                          f"({last:g} s with dt = {dt:g} s): it is never applied", UserWarning,
                          stacklevel=4)
        elif abs(k - round(k)) > 1e-9 * max(1.0, k):
            warnings.warn(f"the thrust change at t = {t:g} s falls between steps of dt = {dt:g} s: "
                          f"it takes effect at {math.ceil(k - 1e-9) * dt:g} s", UserWarning,
                          stacklevel=4)


def max_stable_dt(thrust: ThrustSequence, uav: UAV) -> float:
    """Largest time step [s] for which the explicit drag update is well resolved.

    The air-relative speed approaches the terminal speed ``v_t = sqrt(a_max / c)``
    (``c = k / m`` [1/m], ``a_max`` the largest thrust-plus-gravity acceleration of
    the sequence); the linearised update ``v += -c |v| v dt`` then multiplies
    deviations by ``1 - 2 c v_t dt``, which must stay in [0, 1) for a smooth,
    stable approach: ``dt < 1 / (2 sqrt(c a_max))``. ``inf`` without drag.
    """
    c = uav.drag_factor / uav.mass
    acc = thrust.vectors / uav.mass
    acc[:, 2] -= uav.gravity
    a_max = float(np.max(np.linalg.norm(acc, axis=1)))
    if c == 0 or a_max == 0:
        return math.inf
    return 1.0 / (2.0 * math.sqrt(c * a_max))


def _round_step(most, duration):
    """The largest of 1, 2, 5 x 10^k not above ``most`` that divides ``duration`` (else
    ``duration / ceil(duration / most)``)."""
    k = math.floor(math.log10(most))
    for exp in (k, k - 1, k - 2):
        for m in (5, 2, 1):
            step = m * 10.0 ** exp
            n = duration / step
            if step <= most and abs(n - round(n)) < 1e-9 * n:
                return float(f"{step:.12g}")
    return duration / math.ceil(duration / most)


def _check_drag_stability(thrust, uav, dt, duration):
    limit = max_stable_dt(thrust, uav)
    if dt >= limit:
        works = _round_step(0.5 * limit, duration)
        raise ValueError(
            f"dt = {dt:g} s is too long for this UAV's drag (mass = {uav.mass:g} kg, "
            f"drag_coefficient = {uav.drag_coefficient:g}, area = {uav.area:g} m^2, "
            f"air_density = {uav.air_density:g} kg/m^3) under this thrust: the explicit "
            f"update would oscillate or diverge; use dt < {limit:.3g} s, e.g. dt = "
            f"{works!r} s for duration = {duration:g} s")


def _integrate(wind, uav, dt, n, t_start, forces, start, record_all):
    n_env = wind.n_env
    m, kd = uav.mass, uav.drag_factor
    accel = forces / m  # (n, 3)
    accel[:, 2] -= uav.gravity
    r = np.broadcast_to(start, (n_env, 3)).copy()
    v_air = np.zeros((n_env, 3))
    positions = np.empty((n_env, n, 3))
    if record_all:
        v_gnd_all = np.empty((n_env, n, 3))
        v_air_all = np.empty((n_env, n, 3))
        wind_all = np.empty((n_env, n, 3))
    drag = kd / m
    for k in range(n):
        if drag:
            speed = np.sqrt(np.einsum("ij,ij->i", v_air, v_air))
            v_air = v_air + (accel[k] - drag * speed[:, None] * v_air) * dt
        else:
            v_air = v_air + accel[k] * dt
        w = wind._velocity(t_start[k], r)
        v_gnd = v_air + w
        r = r + v_gnd * dt
        positions[:, k] = r
        if record_all:
            v_gnd_all[:, k] = v_gnd
            v_air_all[:, k] = v_air
            wind_all[:, k] = w
    if not np.all(np.isfinite(positions)):
        raise ValueError("the simulation produced non-finite positions (winds or forces too "
                         "large for float64); check the wind speeds and the UAV parameters")
    if record_all:
        return positions, v_gnd_all, v_air_all, wind_all
    return positions


def _vehicle(uav, vehicle):
    if vehicle is not None:
        if uav is not None:
            raise TypeError("give the vehicle once: uav= or vehicle=, not both")
        return vehicle
    return UAV() if uav is None else uav


def simulate(thrust: ThrustSequence | AttitudeSequence | Reference, wind: WindModel,
             uav: UAV | Multirotor | None = None,
             dt: float = 0.1, duration: float = 12.0, start_altitude: float = 10.0,
             start_position: ArrayLike | None = None,
             vehicle: UAV | Multirotor | None = None) -> np.ndarray:
    """Fly one thrust sequence through every environment of ``wind``.

    Parameters
    ----------
    thrust : ThrustSequence, AttitudeSequence or Reference
        The open-loop action, shared by all environments; or a position reference
        (:mod:`uavwind.sim.references`) a multirotor tracks with RotorPy's SE3 controller,
        starting hovering at the reference's position at t = 0 (``start_altitude`` is then
        unused and ``start_position`` refused); a reference flight that would go below the
        ground (z = 0) is refused with a ``ValueError``.
    wind : WindModel
        ``n_env`` environments (e.g. a :class:`~uavwind.sim.wind.WindGroups`).
    uav : UAV or Multirotor, optional
        The vehicle; default ``UAV()`` (paper Table 4a). A
        :class:`~uavwind.sim.multirotor.Multirotor` flies the same commands with RotorPy's
        physics. ``vehicle=`` is the same argument under its other name.
    dt : float
        Time step [s], > 0. Default 0.1 s.
    duration : float
        Flight time [s], a whole multiple of ``dt``. Default 12 s.
    start_altitude : float
        Initial height z0 [m] (start at (0, 0, z0)). Default 10 m.
    start_position : array_like, shape (3,), optional
        Initial position [m]; overrides ``start_altitude``.

    Returns
    -------
    ndarray, shape (n_env, n_steps, 3)
        Positions [m] after each step, ``n_steps = duration / dt`` (120).

    Examples
    --------
    >>> from uavwind import ConstantWind, PAPER_EXAMPLE
    >>> simulate(PAPER_EXAMPLE, ConstantWind([[1.0, 1.0, 0.0]])).shape
    (1, 120, 3)
    """
    uav = _vehicle(uav, vehicle)
    if isinstance(thrust, Reference):
        n, dt = _prepare_reference(thrust, wind, uav, dt, duration, start_position)
        return uav.fly_reference(thrust, wind, dt, n)
    n, t_start, forces, start = _prepare(thrust, wind, uav, dt, duration, start_altitude,
                                         start_position)
    if isinstance(uav, Multirotor):
        return uav.fly(thrust, wind, float(dt), n, start)
    return _integrate(wind, uav, float(dt), n, t_start, forces, start, record_all=False)


def simulate_flight(thrust: ThrustSequence | AttitudeSequence | Reference, wind: WindModel,
                    uav: UAV | Multirotor | None = None, dt: float = 0.1,
                    duration: float = 12.0, start_altitude: float = 10.0,
                    start_position: ArrayLike | None = None,
                    vehicle: UAV | Multirotor | None = None,
                    state_errors: ArrayLike | None = None) -> Flight:
    """As :func:`simulate`, but return a :class:`Flight` with velocities and winds too (and,
    for a multirotor, its attitudes, body rates, rotor speeds and specific forces; for a
    reference flight, the reference positions, the commanded thrusts and the aerodynamic
    forces). ``state_errors``: a multirotor's imperfect attitude estimate and thrust (and, under
    a position control, velocity estimate): a reference flight's
    (:meth:`~uavwind.sim.multirotor.Multirotor.fly_reference`, a position control only) or an
    open-loop one's (:meth:`~uavwind.sim.multirotor.Multirotor.fly`)."""
    uav = _vehicle(uav, vehicle)
    if isinstance(thrust, Reference):
        n, dt = _prepare_reference(thrust, wind, uav, dt, duration, start_position)
        return uav.fly_reference(thrust, wind, dt, n, record_all=True,
                                 state_errors=state_errors)
    if state_errors is not None and not isinstance(uav, Multirotor):
        raise ValueError("state_errors applies to a multirotor (an attitude loop reads an "
                         "estimate, rotors make the thrust); the point mass has neither")
    n, t_start, forces, start = _prepare(thrust, wind, uav, dt, duration, start_altitude,
                                         start_position)
    if isinstance(uav, Multirotor):
        return uav.fly(thrust, wind, float(dt), n, start, record_all=True,
                       state_errors=state_errors)
    pos, vg, va, w = _integrate(wind, uav, float(dt), n, t_start, forces, start, record_all=True)
    return Flight(times=t_start + dt, positions=pos, ground_velocities=vg, air_velocities=va,
                  winds=w, thrust=forces, start=start)
