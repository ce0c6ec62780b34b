"""Flyable manoeuvres: waypoint references a real multirotor can fly, as causal curiosity's
actions.

The paper's actions are raw world-frame forces that do not compensate gravity: flown from a
hover they take a multirotor tens of metres below the ground and through segments of zero
thrust in which it tumbles. This module owns the other action family, for a multirotor under
its position controller (RotorPy's ``SE3Control``): a smooth
:class:`~uavwind.sim.references.WaypointSpline` that starts at the hover point and stays
within :class:`FlyableLimits`:

* every waypoint inside a box around the start (``half_width`` horizontally, ``half_height``
  vertically) and above a ``floor`` [m] (the minimum-jerk segments never leave the box the
  waypoints span);
* the reference speed at most ``max_speed`` [m/s];
* the tilt the reference asks for at most ``max_tilt`` [deg]: a reference acceleration ``a``
  needs the thrust along ``g e_z + a``, a tilt of ``atan(|a_h| / (g + a_z))``
  (:func:`required_tilt`); with a ``thrust_margin`` (:data:`FLYABLE_IN_WIND`) the strongest
  wind's force is added in the direction that tilts the thrust most, and the thrust must stay
  within that share of the vehicle's full thrust: a vehicle that leans 40 degrees into a
  strong wind has that much less room to manoeuvre (:meth:`FlyableLimits.in_wind`).

:func:`sample_waypoints` is the setting sampler ``"waypoints"`` (beside ``"paper"``,
``"continuous"`` and ``"attitude"`` of :data:`~uavwind.sim.actions.SAMPLERS`): change times
evenly spaced, each next waypoint uniform in the part of the box within reach of the last.
The reach keeps both limits *by construction*: a minimum-jerk segment of length d over T
peaks at ``1.875 d / T`` in speed and ``5.77 d / T^2`` in acceleration, and an acceleration of
magnitude ``A <= g sin(max_tilt)`` tilts ``g e_z + a`` at most ``asin(A / g) <= max_tilt``
from up, whatever its direction. Every draw is then checked on a 1 ms grid
(:func:`check_flyable`) and, should the check ever fail, redrawn (at most
:data:`MAX_REDRAWS` times; with the conservative reach it never has). The same bound keeps
the reference's collective thrust at least ``m g (1 - sin max_tilt)``: no zero-thrust
segments.

:func:`waypoints_to_vector` and :func:`waypoints_from_vector` are the flat form the
Cross-Entropy Method searches: the waypoints after the first, as offsets from the start
[m]; decoding projects a Gaussian draw onto the limits (each target clipped into the box,
then each step shortened to the reach), so every CEM sample is flyable too.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_array, check_instance, check_scalar
from .actions import SAMPLERS
from .references import Reference, WaypointSpline

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["FlyableLimits", "FLYABLE", "FLYABLE_IN_WIND", "required_tilt", "check_flyable", "sample_waypoints",
           "waypoints_to_vector", "waypoints_from_vector", "WAYPOINT_CEM_STD", "MAX_REDRAWS",
           "GRAVITY", "MAX_WAYPOINT_DURATION"]

#: Gravity of the tilt bound [m/s^2] (RotorPy's).
GRAVITY = 9.81
#: Most redraws of :func:`sample_waypoints` before it gives up (it never needs one).
MAX_REDRAWS = 100
#: CEM's starting standard deviation of each waypoint offset (x, y, z) [m]; its mean is 0
#: (hover at the start).
WAYPOINT_CEM_STD = (1.5, 1.5, 1.0)
#: Peak speed and acceleration of a minimum-jerk segment over a distance d in a time T:
#: ``1.875 d / T`` and ``(10 / sqrt 3) d / T^2`` (as :class:`WaypointSpline` states them).
_PEAK_SPEED = 1.875
_PEAK_ACC = 10.0 / math.sqrt(3.0)
#: Grid of the flyability check [s] (RotorPy's control period is 10 ms).
_CHECK_STEP = 1e-3


@dataclass(frozen=True)
class FlyableLimits:
    """What a flyable waypoint reference keeps to.

    Parameters
    ----------
    half_width : float
        Largest horizontal offset from the start, on x and on y [m], in (0, 1000].
    half_height : float
        Largest vertical offset from the start [m], in (0, 1000].
    floor : float
        Lowest height above the ground [m], in [0, 1000].
    max_speed : float
        Largest reference speed [m/s], in (0, 100].
    max_tilt : float
        Largest tilt of the thrust the reference asks for [deg], in (0, 60].
    thrust_margin : float, optional
        None (default): the still-air budget, the reference's acceleration alone. A share of
        the vehicle's full thrust in (0, 1]: the budget of a vehicle holding against the
        wind too (:meth:`in_wind`): the thrust the reference and the strongest wind ask for
        together also stays within ``max_total_tilt`` of up and within this share of the
        full thrust.
    max_total_tilt : float
        With a ``thrust_margin``: the largest tilt of the thrust, the wind's lean included
        [deg], in (0, 89]; default 55.
    wind_lean : float
        The tilt [deg] that holds the vehicle still in the strongest wind, in [0, 89] (set by
        :meth:`in_wind`).
    hold_acceleration : float
        The thrust per mass [m/s^2] that holds it still there, in [0, 1e4] (set by
        :meth:`in_wind`; 0 with the still-air budget).
    thrust_acceleration : float
        ``thrust_margin`` x the full thrust per mass [m/s^2] (set by :meth:`in_wind`; 0 with
        the still-air budget).

    >>> FlyableLimits().box((0.0, 0.0, 10.0)).tolist()
    [[-3.0, 3.0], [-3.0, 3.0], [8.0, 12.0]]
    """

    half_width: float = 3.0
    half_height: float = 2.0
    floor: float = 2.0
    max_speed: float = 3.0
    max_tilt: float = 30.0
    thrust_margin: float | None = None
    max_total_tilt: float = 55.0
    wind_lean: float = 0.0
    hold_acceleration: float = 0.0
    thrust_acceleration: float = 0.0

    def __post_init__(self):
        for name, low, high, incl in (("half_width", 0.0, 1e3, False),
                                      ("half_height", 0.0, 1e3, False),
                                      ("floor", 0.0, 1e3, True), ("max_speed", 0.0, 1e2, False),
                                      ("max_tilt", 0.0, 60.0, False),
                                      ("max_total_tilt", 0.0, 89.0, False),
                                      ("wind_lean", 0.0, 89.0, True),
                                      ("hold_acceleration", 0.0, 1e4, True),
                                      ("thrust_acceleration", 0.0, 1e4, True)):
            object.__setattr__(self, name, float(check_scalar(
                getattr(self, name), name, low=low, low_inclusive=incl, high=high)))
        if self.thrust_margin is not None:
            object.__setattr__(self, "thrust_margin", float(check_scalar(
                self.thrust_margin, "thrust_margin", low=0.0, low_inclusive=False, high=1.0)))
        if self.thrust_margin is not None and self.hold_acceleration > 0 \
                and self.max_acceleration <= 0:
            raise ValueError(
                f"the strongest wind leaves no budget: holding still in it takes a tilt of "
                f"{self.wind_lean:.1f} degrees (max_total_tilt {self.max_total_tilt:g}) and a "
                f"thrust of {self.hold_acceleration:.3g} m/s^2 per mass (thrust_margin "
                f"{self.thrust_margin:g} allows {self.thrust_acceleration:.3g}): the vehicle "
                f"cannot hold this wind with room to manoeuvre")

    def in_wind(self, vehicle, wind_speed: float) -> FlyableLimits:
        """These limits for ``vehicle`` (a :class:`~uavwind.sim.multirotor.Multirotor`)
        holding against a horizontal wind of up to ``wind_speed`` [m/s]: the horizontal
        thrust per mass that holds it still there
        (:meth:`~uavwind.sim.multirotor.Multirotor.hover_trim`: its lean and thrust, so the
        extra drag of a tilted frame and the translational lift are counted) and
        ``thrust_margin`` of its full thrust per mass. The
        still-air budget (``thrust_margin`` None) comes back unchanged. ``ValueError`` when
        the wind alone exceeds the budget."""
        if self.thrust_margin is None:
            return self
        wind_speed = check_scalar(wind_speed, "wind_speed", low=0.0, high=1e3)
        control = getattr(vehicle, "position_control", None)
        if control is not None and self.max_total_tilt > control.max_tilt:
            raise ValueError(f"max_total_tilt = {self.max_total_tilt:g} degrees exceeds the "
                             f"vehicle's thrust cone ({control.max_tilt:g} degrees)")
        tilt, thrust = vehicle.hover_trim(wind_speed)
        return replace(self, wind_lean=tilt, hold_acceleration=thrust / vehicle.mass,
                       thrust_acceleration=self.thrust_margin * vehicle.max_thrust / vehicle.mass)

    def box(self, start: ArrayLike) -> np.ndarray:
        """``[[x_lo, x_hi], [y_lo, y_hi], [z_lo, z_hi]]`` [m] around ``start`` (3,) [m];
        ``ValueError`` if the start is below the floor."""
        p = check_array(start, "start", shape=(3,))
        if p[2] < self.floor:
            raise ValueError(f"start must lie at or above the floor ({self.floor:g} m), got "
                             f"z = {p[2]:g} m")
        lo = p - np.array([self.half_width, self.half_width, self.half_height])
        hi = p + np.array([self.half_width, self.half_width, self.half_height])
        lo[2] = max(lo[2], self.floor)
        return np.column_stack([lo, hi])

    @property
    def max_acceleration(self) -> float:
        """The largest reference acceleration [m/s^2] that keeps the thrust within the limits
        in any direction. Still air: ``g sin(max_tilt)``. In wind (:meth:`in_wind`), the thrust
        per mass ``c + a``, with ``c`` the thrust per mass that holds the vehicle still in the
        wind (tilted by the wind's lean), lies in a ball of radius ``|a|`` about ``c``, whose
        largest tilt is ``lean + asin(|a| / |c|)`` and largest norm ``|c| + |a|``: so
        ``min(|c| sin(max_total_tilt - lean), T - |c|)`` with ``T`` the thrust allowed, never
        above the still-air ``g sin(max_tilt)``; at most 0 when the wind alone exceeds the
        budget."""
        still = GRAVITY * math.sin(math.radians(self.max_tilt))
        if self.thrust_margin is None or self.hold_acceleration == 0:
            return still
        c = self.hold_acceleration
        return min(still, c * math.sin(math.radians(self.max_total_tilt - self.wind_lean)),
                   self.thrust_acceleration - c)

    def reach(self, segment_time: float) -> float:
        """Longest segment [m] a minimum-jerk step of ``segment_time`` [s] may take within the
        speed and tilt limits."""
        T = check_scalar(segment_time, "segment_time", low=0.0, low_inclusive=False)
        return min(self.max_speed * T / _PEAK_SPEED, self.max_acceleration * T * T / _PEAK_ACC)

    def to_dict(self) -> dict:
        """The fields; the wind budget's only where it is used (the still-air limits keep
        the dict, and so the cache keys, they had before it)."""
        d = asdict(self)
        if self.thrust_margin is None:
            for k in ("thrust_margin", "max_total_tilt", "wind_lean", "hold_acceleration",
                      "thrust_acceleration"):
                d.pop(k)
        return d


#: The limits of the ``"waypoints"`` sampler: +-3 m horizontally and +-2 m vertically around
#: the start, at least 2 m above the ground, 3 m/s, 30 degrees (the attitude actions' tilt,
#: :data:`~uavwind.sim.actions.MAX_TILT`).
FLYABLE = FlyableLimits()
#: The same for a vehicle holding against the wind (Exp 14): also the reference and the
#: strongest wind together within 55 degrees of up (5 below the 60 degree thrust cone of
#: :data:`~uavwind.sim.rotor_params.NEURAL_FLY_CONTROL`) and 80% of the full thrust.
FLYABLE_IN_WIND = FlyableLimits(thrust_margin=0.8)


def required_tilt(reference: Reference, times: ArrayLike, gravity: float = GRAVITY
                  ) -> np.ndarray:
    """The tilt of the thrust [deg] that ``reference``'s acceleration asks for at ``times``
    [s]: ``atan2(|a_h|, g + a_z)`` (90 or more when ``g + a_z <= 0``: a reference falling
    faster than gravity cannot be flown with thrust).

    >>> ref = WaypointSpline([[0, 0, 10], [1, 0, 10]], [0.0, 2.0])
    >>> round(float(required_tilt(ref, [2 / 2 * (1 - 1 / 3 ** 0.5)])[0]), 1)
    8.4
    """
    check_instance(reference, "reference", Reference, "Reference")
    gravity = check_scalar(gravity, "gravity", low=0.0, low_inclusive=False, high=1e3)
    a = reference.flat_output(times)["x_ddot"]
    return np.degrees(np.arctan2(np.hypot(a[:, 0], a[:, 1]), gravity + a[:, 2]))


def check_flyable(reference: WaypointSpline, limits: FlyableLimits = FLYABLE,
                  start: ArrayLike | None = None) -> WaypointSpline:
    """``reference`` if it keeps ``limits`` around ``start`` (default its first waypoint),
    else a ``ValueError`` naming the limit and by how much: waypoints outside the box or
    below the floor, a speed above ``max_speed`` or a required tilt (:func:`required_tilt`)
    above ``max_tilt``, both checked on a 1 ms grid over ``[0, reference.duration]``."""
    check_instance(reference, "reference", WaypointSpline, "WaypointSpline")
    check_instance(limits, "limits", FlyableLimits, "FlyableLimits")
    start = reference.waypoints[0] if start is None else check_array(start, "start", shape=(3,))
    box = limits.box(start)
    wp = reference.waypoints
    out = (wp < box[:, 0] - 1e-9) | (wp > box[:, 1] + 1e-9)
    if out.any():
        i = int(np.argmax(out.any(axis=1)))
        raise ValueError(f"reference: waypoint {i} {wp[i].round(4).tolist()} lies outside the "
                         f"box {box.round(4).tolist()} [m] (limits: half_width "
                         f"{limits.half_width:g} m, half_height {limits.half_height:g} m, "
                         f"floor {limits.floor:g} m)")
    t = np.linspace(0.0, reference.duration, int(math.ceil(reference.duration / _CHECK_STEP)) + 1)
    speed = np.linalg.norm(reference.flat_output(t)["x_dot"], axis=1)
    if speed.max() > limits.max_speed * (1 + 1e-9):
        raise ValueError(f"reference: its speed reaches {speed.max():.4g} m/s at t = "
                         f"{t[np.argmax(speed)]:.3f} s, above max_speed = "
                         f"{limits.max_speed:g} m/s")
    tilt = required_tilt(reference, t)
    if tilt.max() > limits.max_tilt * (1 + 1e-9):
        raise ValueError(f"reference: it asks for a tilt of {tilt.max():.4g} degrees at t = "
                         f"{t[np.argmax(tilt)]:.3f} s, above max_tilt = {limits.max_tilt:g} "
                         f"degrees")
    if limits.thrust_margin is not None and limits.hold_acceleration > 0:
        # the thrust that holds it still, turned by the reference's acceleration in the
        # direction that tilts it most: the lean plus the angle the acceleration adds
        acc = np.linalg.norm(reference.flat_output(t)["x_ddot"], axis=1)
        c = limits.hold_acceleration
        tilt = limits.wind_lean + np.degrees(np.arcsin(np.clip(acc / c, 0.0, 1.0)))
        thrust = c + acc
        if thrust.max() > limits.thrust_acceleration * (1 + 1e-9):
            raise ValueError(f"reference: with the strongest wind it may ask for a thrust of "
                             f"{thrust.max():.4g} m/s^2 at t = {t[np.argmax(thrust)]:.3f} s, "
                             f"above {limits.thrust_acceleration:.4g} (thrust_margin "
                             f"{limits.thrust_margin:g} of the full thrust)")
        if tilt.max() > limits.max_total_tilt * (1 + 1e-9):
            raise ValueError(f"reference: with the strongest wind it may ask for a tilt of "
                             f"{tilt.max():.4g} degrees at t = {t[np.argmax(tilt)]:.3f} s, "
                             f"above max_total_tilt = {limits.max_total_tilt:g} degrees")
    return reference


#: Longest flight [s] :func:`sample_waypoints` draws: its flyability check samples the
#: reference every millisecond (:func:`check_flyable`), about 0.3 GB of arrays at this
#: length (a million seconds asked for 7.45 GiB).
MAX_WAYPOINT_DURATION = 600.0


def _times(n_changes, duration):
    n = check_scalar(n_changes, "n_changes", low=0, high=1000, integer=True)
    duration = check_scalar(duration, "duration", low=0.0, low_inclusive=False,
                            high=MAX_WAYPOINT_DURATION)
    return np.linspace(0.0, duration, n + 2)


def sample_waypoints(rng: np.random.Generator, n_changes: int = 6, duration: float = 12.0,
                     start_altitude: float = 10.0, limits: FlyableLimits = FLYABLE
                     ) -> WaypointSpline:
    """A flyable waypoint reference (the setting sampler ``"waypoints"``; see the module).

    ``n_changes + 2`` waypoints at evenly spaced times from 0 to ``duration`` [s] (the path
    changes direction ``n_changes`` times, as the paper's thrust does), the first at the hover
    start ``(0, 0, start_altitude)`` [m], each next one uniform in the box within the reach
    of the last (:meth:`FlyableLimits.reach`); checked with :func:`check_flyable` and redrawn
    if it fails (never, so far).

    Parameters
    ----------
    rng : numpy.random.Generator
    n_changes : int
        Waypoints after the start, less one, in [0, 1000]. Default 6.
    duration : float
        Flight time [s], in (0, :data:`MAX_WAYPOINT_DURATION`] = (0, 600]. Default 12.
    start_altitude : float
        Height of the hover start [m], at or above ``limits.floor``. Default 10.
    limits : FlyableLimits

    >>> ref = sample_waypoints(np.random.default_rng(0))
    >>> ref.waypoints.shape, ref.waypoints[0].tolist()
    ((8, 3), [0.0, 0.0, 10.0])
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    check_instance(limits, "limits", FlyableLimits, "FlyableLimits")
    times = _times(n_changes, duration)
    start = np.array([0.0, 0.0, check_scalar(start_altitude, "start_altitude", low=0.0,
                                             high=1e5)])
    box = limits.box(start)
    T = float(times[1] - times[0])
    for _ in range(MAX_REDRAWS):
        ref = WaypointSpline.sample(rng, len(times), float(times[-1]), box=box,
                                    max_speed=limits.max_speed,
                                    max_acceleration=limits.max_acceleration, start=start)
        try:
            return check_flyable(ref, limits, start)
        except ValueError:  # pragma: no cover - the reach is conservative
            continue
    raise RuntimeError(f"no flyable waypoint reference in {MAX_REDRAWS} draws "  # pragma: no cover
                       f"(segments of {T:g} s)")


SAMPLERS["waypoints"] = sample_waypoints


def waypoints_to_vector(reference: WaypointSpline) -> np.ndarray:
    """The CEM vector of ``reference``: its waypoints after the first, as offsets from the
    first [m], flattened, shape ``(3 (k - 1),)``."""
    check_instance(reference, "reference", WaypointSpline, "WaypointSpline")
    return (reference.waypoints[1:] - reference.waypoints[0]).ravel()


def waypoints_from_vector(vector: ArrayLike, times: ArrayLike, start: ArrayLike,
                          limits: FlyableLimits = FLYABLE) -> WaypointSpline:
    """A flyable reference from a CEM draw: waypoint ``i`` aims at ``start + vector[i]``,
    clipped into the box, and the step from the previous waypoint is shortened to the reach
    when longer. A vector that already keeps the limits comes back unchanged (up to
    rounding): ``waypoints_from_vector(waypoints_to_vector(r), r.times, r.waypoints[0])``
    is ``r``.

    Parameters
    ----------
    vector : (3 (k - 1),) array
        Offsets from the start [m].
    times : (k,) array
        Waypoint times [s], evenly spaced from 0 (as :func:`sample_waypoints` draws them).
    start : (3,) array
        The hover start [m].
    limits : FlyableLimits
    """
    check_instance(limits, "limits", FlyableLimits, "FlyableLimits")
    times = check_array(times, "times", ndim=1)
    k = times.shape[0]
    if k < 2:
        raise ValueError(f"times must hold at least 2 waypoint times [s], got {k}")
    steps = np.diff(times)
    if times[0] != 0.0 or np.any(steps <= 0):
        raise ValueError(f"times must start at 0 s and increase strictly, got {times.tolist()}")
    vector = check_array(vector, "vector", shape=(3 * (k - 1),))
    start = check_array(start, "start", shape=(3,))
    box = limits.box(start)
    points = [start]
    p = start
    for i, target in enumerate(vector.reshape(-1, 3)):
        q = np.clip(start + target, box[:, 0], box[:, 1])
        step = q - p
        d = float(np.linalg.norm(step))
        reach = limits.reach(float(steps[i]))
        if d > reach:
            q = p + step * (reach / d)
        points.append(q)
        p = q
    return WaypointSpline(np.array(points), times)
