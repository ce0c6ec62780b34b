"""Position references a multirotor's position controller tracks.

This module owns the references: frozen values that say where the vehicle should be at every
time, as RotorPy's *flat outputs* (what ``rotorpy.controllers.quadrotor_control.SE3Control``
reads), with analytic derivatives and vectorised over times. A
:class:`~uavwind.sim.multirotor.Multirotor` flies one with RotorPy's SE3 controller through
:func:`uavwind.simulate` / :func:`uavwind.simulate_flight`.

* :class:`Hover` -- hold one point;
* :class:`Lemniscate` -- Neural-Fly's figure-8 ``(1.25 sin t, 0, 0.75 sin 2t)`` about a centre
  (O'Connell et al., Science Robotics 2022, the wind-tunnel reference);
* :class:`WaypointSpline` -- a smooth path through waypoints at given times (minimum-jerk
  quintic segments, rest at every waypoint), and :meth:`WaypointSpline.sample`, random
  waypoints inside a box above the floor within a speed (and acceleration) limit.

``flat_output(t)`` returns a dict of arrays for a 1-D array ``t`` [s] of ``n_t`` times::

    x, x_dot, x_ddot, x_dddot, x_ddddot   (n_t, 3)  position [m] and its 1st..4th derivatives
    yaw, yaw_dot                          (n_t,)    [rad], [rad/s] (0: these references
                                                    fly with a fixed heading)

The world frame is RotorPy's (z up); the ground is at z = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import Range, check_array, check_fields, check_instance, check_scalar

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["Reference", "Hover", "Lemniscate", "WaypointSpline", "FLAT_KEYS"]

#: The keys of a flat output, RotorPy's names.
FLAT_KEYS = ("x", "x_dot", "x_ddot", "x_dddot", "x_ddddot", "yaw", "yaw_dot")
#: Peak speed and peak acceleration of a minimum-jerk segment over a distance d in a time T:
#: ``1.875 d / T`` and ``(10 / sqrt 3) d / T^2``.
_PEAK_SPEED = 1.875
_PEAK_ACC = 10.0 / math.sqrt(3.0)


def _times(t) -> np.ndarray:
    t = check_array(t, "t")
    if t.ndim > 1:
        raise ValueError(f"t must be a number or a 1-D array of times [s], got shape {t.shape}")
    return np.atleast_1d(t)


def _point(value, name) -> tuple[float, float, float]:
    arr = check_array(value, name, shape=(3,))
    return tuple(float(v) for v in arr)


class Reference:
    """A position reference: :meth:`flat_output` at any times (base class; see the module)."""

    def flat_output(self, t: ArrayLike) -> dict[str, np.ndarray]:  # pragma: no cover
        """RotorPy's flat output at the times ``t`` (n_t,) [s] (see the module text)."""
        raise NotImplementedError

    def positions(self, t: ArrayLike) -> np.ndarray:
        """Reference positions (n_t, 3) [m] at the times ``t`` [s]."""
        return self.flat_output(t)["x"]

    def to_dict(self) -> dict:
        """The reference as plain data (its kind and parameters), e.g. for a cache key."""
        raise NotImplementedError  # pragma: no cover


def _flat(x, v, a, j, s) -> dict[str, np.ndarray]:
    n = x.shape[0]
    return {"x": x, "x_dot": v, "x_ddot": a, "x_dddot": j, "x_ddddot": s,
            "yaw": np.zeros(n), "yaw_dot": np.zeros(n)}


@dataclass(frozen=True)
class Hover(Reference):
    """Hold ``position`` (3,) [m], every derivative zero.

    >>> Hover((1.0, 0.0, 2.0)).flat_output([0.0, 5.0])["x"].tolist()
    [[1.0, 0.0, 2.0], [1.0, 0.0, 2.0]]
    """

    position: tuple = (0.0, 0.0, 2.0)

    def __post_init__(self):
        object.__setattr__(self, "position", _point(self.position, "position"))

    def flat_output(self, t: ArrayLike) -> dict[str, np.ndarray]:
        t = _times(t)
        z = np.zeros((t.size, 3))
        return _flat(np.broadcast_to(self.position, (t.size, 3)).copy(), z, z.copy(), z.copy(),
                     z.copy())

    def to_dict(self) -> dict:
        return {"reference": "hover", "position": list(self.position)}


@dataclass(frozen=True)
class Lemniscate(Reference):
    """A figure-8: ``center + (a_x sin wt, a_y sin wt, a_z sin 2wt)``, ``w = 2 pi / period``.

    The defaults are Neural-Fly's wind-tunnel reference ``(1.25 sin t, 0, 0.75 sin 2t)`` [m]
    (period 2 pi s, in the vertical x-z plane), centred 2 m above the ground.

    Parameters
    ----------
    center : (3,) float
        Centre of the figure [m].
    amplitude : (3,) float
        ``(a_x, a_y, a_z)`` [m], each >= 0.
    period : float
        One lap [s], in (0, 1e6].

    >>> ref = Lemniscate()
    >>> ref.flat_output([math.pi / 2])["x"].round(12).tolist()
    [[1.25, 0.0, 2.0]]
    """

    center: tuple = (0.0, 0.0, 2.0)
    amplitude: tuple = (1.25, 0.0, 0.75)
    period: float = 2 * math.pi

    def __post_init__(self):
        object.__setattr__(self, "center", _point(self.center, "center"))
        amp = _point(self.amplitude, "amplitude")
        if min(amp) < 0:
            raise ValueError(f"amplitude must be >= 0 on every axis [m], got {amp}")
        object.__setattr__(self, "amplitude", amp)
        check_fields(self, {"period": Range(0.0, 1e6, low_inclusive=False)})

    @property
    def omega(self) -> float:
        """``2 pi / period`` [rad/s]."""
        return 2 * math.pi / self.period

    def flat_output(self, t: ArrayLike) -> dict[str, np.ndarray]:
        t = _times(t)
        w = self.omega
        k = np.array([w, w, 2 * w])                       # each axis's angular frequency
        a = np.asarray(self.amplitude)
        ph = t[:, None] * k
        sn, cs = np.sin(ph), np.cos(ph)
        x = np.asarray(self.center) + a * sn
        return _flat(x, a * k * cs, -a * k ** 2 * sn, -a * k ** 3 * cs, a * k ** 4 * sn)

    def to_dict(self) -> dict:
        return {"reference": "lemniscate", "center": list(self.center),
                "amplitude": list(self.amplitude), "period": self.period}


def _min_jerk(tau):
    """The minimum-jerk blend s(tau) on [0, 1] and its first four derivatives."""
    t2 = tau * tau
    t3 = t2 * tau
    return (t3 * (10 - 15 * tau + 6 * t2), 30 * t2 - 60 * t3 + 30 * t2 * t2,
            60 * tau - 180 * t2 + 120 * t3, 60 - 360 * tau + 360 * t2, -360 + 720 * tau)


@dataclass(frozen=True, eq=False)
class WaypointSpline(Reference):
    """A smooth path through ``waypoints`` (k, 3) [m] reached at ``times`` (k,) [s].

    Each segment is the minimum-jerk quintic from one waypoint to the next, at rest (zero
    velocity and acceleration) at both: the path is C^2 (jerk and snap jump at the
    waypoints), never overshoots a segment's straight line (so it stays inside any box that
    holds the waypoints), and its speed peaks mid-segment at ``1.875 d / T`` (d the segment's
    length, T its duration; acceleration ``5.77 d / T^2``). Before ``times[0]`` it holds the
    first waypoint, after ``times[-1]`` the last.

    Parameters
    ----------
    waypoints : (k, 3) array
        k >= 2 points [m].
    times : (k,) array
        Strictly increasing times [s], ``times[0] >= 0``.

    >>> ref = WaypointSpline([[0, 0, 1], [1, 0, 1]], [0.0, 2.0])
    >>> ref.flat_output([1.0])["x"].tolist(), round(ref.max_speed, 4)
    ([[0.5, 0.0, 1.0]], 0.9375)
    """

    waypoints: np.ndarray
    times: np.ndarray

    def __post_init__(self):
        wp = check_array(self.waypoints, "waypoints", ndim=2)
        if wp.shape[1] != 3 or wp.shape[0] < 2:
            raise ValueError(f"waypoints must have shape (k, 3) with k >= 2, got {wp.shape}")
        times = check_array(self.times, "times", ndim=1)
        if times.shape != (wp.shape[0],):
            raise ValueError(f"times must have one entry per waypoint ({wp.shape[0]}), got "
                             f"shape {times.shape}")
        if times[0] < 0 or np.any(np.diff(times) <= 0):
            raise ValueError(f"times must be >= 0 and strictly increasing [s], got "
                             f"{times.tolist()}")
        wp.setflags(write=False)
        times.setflags(write=False)
        object.__setattr__(self, "waypoints", wp)
        object.__setattr__(self, "times", times)

    def __eq__(self, other):
        return (type(other) is WaypointSpline and np.array_equal(self.waypoints, other.waypoints)
                and np.array_equal(self.times, other.times))

    def __hash__(self):
        return hash((self.waypoints.tobytes(), self.times.tobytes()))

    @property
    def duration(self) -> float:
        """Time of the last waypoint [s]."""
        return float(self.times[-1])

    @property
    def max_speed(self) -> float:
        """Largest speed along the path [m/s] (``1.875 d / T`` of the fastest segment)."""
        d = np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1)
        return float(np.max(_PEAK_SPEED * d / np.diff(self.times)))

    @property
    def max_acceleration(self) -> float:
        """Largest acceleration along the path [m/s^2] (``5.77 d / T^2``)."""
        d = np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1)
        return float(np.max(_PEAK_ACC * d / np.diff(self.times) ** 2))

    def flat_output(self, t: ArrayLike) -> dict[str, np.ndarray]:
        t = _times(t)
        tk = self.times
        seg = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, len(tk) - 2)
        T = (tk[seg + 1] - tk[seg])[:, None]
        tau = np.clip((t[:, None] - tk[seg][:, None]) / T, 0.0, 1.0)
        inside = ((t >= tk[0]) & (t < tk[-1]))[:, None]          # derivatives vanish outside
        d = self.waypoints[seg + 1] - self.waypoints[seg]
        s0, s1, s2, s3, s4 = _min_jerk(tau)
        x = self.waypoints[seg] + d * s0
        return _flat(x, inside * d * s1 / T, inside * d * s2 / T ** 2, inside * d * s3 / T ** 3,
                     inside * d * s4 / T ** 4)

    def to_dict(self) -> dict:
        return {"reference": "waypoint spline", "waypoints": self.waypoints.tolist(),
                "times": self.times.tolist()}

    @classmethod
    def sample(cls, rng, n_waypoints: int, duration: float,
               box=((-2.0, 2.0), (-2.0, 2.0), (1.0, 4.0)), max_speed: float = 2.0,
               max_acceleration: float | None = None, start: ArrayLike | None = None
               ) -> WaypointSpline:
        """Random waypoints inside ``box``, reached at evenly spaced times over ``duration``.

        The first waypoint is ``start`` (else uniform in the box); each next one is uniform in
        the part of the box close enough to the previous one that the segment's peak speed
        stays below ``max_speed`` (and its peak acceleration below ``max_acceleration``), so
        the whole path keeps both limits and stays in the box.

        Parameters
        ----------
        rng : numpy.random.Generator, int or numpy.random.SeedSequence
            The randomness (an int or a SeedSequence seeds a new generator).
        n_waypoints : int
            k, in [2, 10000].
        duration : float
            Time of the last waypoint [s], in (0, 1e6].
        box : ((x_lo, x_hi), (y_lo, y_hi), (z_lo, z_hi))
            Where the waypoints lie [m]; ``lo < hi`` and ``z_lo >= 0`` (above the ground).
        max_speed : float
            Bound on the speed [m/s], in (0, 1000].
        max_acceleration : float, optional
            Bound on the acceleration [m/s^2], in (0, 1e4]; default none.
        start : (3,) array, optional
            The first waypoint [m], inside the box.

        >>> ref = WaypointSpline.sample(0, 5, 12.0, max_speed=1.5)
        >>> ref.waypoints.shape, ref.max_speed < 1.5
        ((5, 3), True)
        """
        if isinstance(rng, (int, np.integer, np.random.SeedSequence)) and not isinstance(
                rng, (bool, np.bool_)):
            rng = np.random.default_rng(rng)
        check_instance(rng, "rng", np.random.Generator,
                       "numpy Generator, an int seed or a SeedSequence")
        k = check_scalar(n_waypoints, "n_waypoints", low=2, high=10_000, integer=True)
        duration = check_scalar(duration, "duration", low=0.0, low_inclusive=False, high=1e6)
        lo_hi = check_array(box, "box", shape=(3, 2))
        if np.any(lo_hi[:, 0] >= lo_hi[:, 1]):
            raise ValueError(f"box must give lo < hi on every axis [m], got {lo_hi.tolist()}")
        if lo_hi[2, 0] < 0:
            raise ValueError(f"box must lie above the ground: its z_lo must be >= 0 [m], got "
                             f"{lo_hi[2, 0]:g}")
        max_speed = check_scalar(max_speed, "max_speed", low=0.0, low_inclusive=False, high=1e3)
        T = duration / (k - 1)
        reach = max_speed * T / _PEAK_SPEED
        if max_acceleration is not None:
            max_acceleration = check_scalar(max_acceleration, "max_acceleration", low=0.0,
                                            low_inclusive=False, high=1e4)
            reach = min(reach, max_acceleration * T * T / _PEAK_ACC)
        if start is None:
            p = rng.uniform(lo_hi[:, 0], lo_hi[:, 1])
        else:
            p = check_array(start, "start", shape=(3,))
            if np.any(p < lo_hi[:, 0]) or np.any(p > lo_hi[:, 1]):
                raise ValueError(f"start must lie inside box {lo_hi.tolist()} [m], got "
                                 f"{p.tolist()}")
        points = [p]
        for _ in range(k - 1):
            lo = np.maximum(lo_hi[:, 0], p - reach)
            hi = np.minimum(lo_hi[:, 1], p + reach)
            for _attempt in range(10_000):
                q = rng.uniform(lo, hi)
                if np.linalg.norm(q - p) < reach:
                    break
            else:  # pragma: no cover - the acceptance rate is at least pi / 6 per draw
                raise RuntimeError("could not draw a waypoint within reach")
            points.append(q)
            p = q
        return cls(np.array(points), np.linspace(0.0, duration, k))
