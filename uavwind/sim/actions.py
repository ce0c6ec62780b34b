"""Open-loop thrust sequences: the UAV's actions.

This module owns :class:`ThrustSequence` (piecewise-constant thrust: change
times [s], magnitudes [N], unit directions), :class:`AttitudeSequence` (collective thrust
and attitude, for a multirotor), the base both stand on (``_Sequence``: the change times,
immutability, comparison, pickling and printing), the two samplers of the replication notes'
decision 2 (:func:`sample_paper`, :func:`sample_continuous`), and the flat
vector form the Cross-Entropy Method searches over (:meth:`ThrustSequence.to_vector`,
:meth:`ThrustSequence.from_vector`). Every sampler takes an explicit
``numpy.random.Generator``; nothing here touches global random state.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_array, check_scalar

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["ThrustSequence", "sample_paper", "sample_continuous", "SAMPLERS",
           "MAX_THRUST", "PAPER_EXAMPLE", "AttitudeSequence", "sample_attitude", "MAX_TILT",
           "euler_to_quaternion"]

#: Upper bound of the thrust magnitude [N] (paper Table 4c).
MAX_THRUST = 50.0

_AXES = np.eye(3)


class _Sequence:
    """What every piecewise-constant action shares: ``times`` [s] (segment starts, the first
    at 0, strictly increasing) and two per-segment arrays named by ``_FIELDS``, frozen
    (read-only arrays, no attribute set after construction), compared, hashed, pickled
    bit-identically and printed by those arrays. A subclass checks its own arrays and calls
    :meth:`_freeze`; ``_KIND`` names it in errors."""

    __slots__ = ()
    _FIELDS: tuple[str, str, str]
    _KIND: str

    @staticmethod
    def _check_times(times) -> np.ndarray:
        """``times`` checked: one segment at least, the first at 0 s, strictly increasing."""
        times = check_array(times, "times", ndim=1)
        if times.shape[0] == 0:
            raise ValueError("times must hold at least one segment start (0.0)")
        if times[0] != 0.0:
            raise ValueError(f"times[0] must be 0 s (the first segment starts the flight), "
                             f"got {times[0]}")
        if np.any(np.diff(times) <= 0):
            raise ValueError(f"times must be strictly increasing, got {times.tolist()}")
        return times

    def _freeze(self, *arrays) -> None:
        """Set ``_FIELDS`` to read-only float copies of ``arrays``."""
        for name, arr in zip(self._FIELDS, arrays):
            arr = np.array(arr, dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @classmethod
    def _drawn(cls, *arrays):
        """A sequence of a sampler's draws, which keep the constructor's rules by how they
        are drawn (times from 0, increasing; values in range; unit directions): frozen
        without checking them again."""
        seq = object.__new__(cls)
        seq._freeze(*arrays)
        return seq

    def __setattr__(self, name, value):
        raise AttributeError(f"{type(self).__name__} is immutable")

    def __reduce__(self):
        # bypass the constructor's checks and normalisation: a pickled copy is bit-identical
        return (_restore, (type(self), *(getattr(self, f) for f in self._FIELDS)))

    @property
    def n_segments(self) -> int:
        """Number of constant segments."""
        return self.times.shape[0]

    @property
    def n_changes(self) -> int:
        """Number of changes after the start (segments - 1)."""
        return self.n_segments - 1

    def segment(self, t: ArrayLike) -> np.ndarray | np.intp:
        """Index of the segment active at time(s) ``t`` [s] (a change at t counts from t)."""
        t = np.asarray(t, dtype=float)
        return np.searchsorted(self.times, t + 1e-9, side="right") - 1

    def check_within(self, duration: float) -> None:
        """Raise ``ValueError`` unless every change happens inside ``[0, duration)``."""
        if self.times[-1] >= duration:
            raise ValueError(f"{self._KIND} change times must lie inside the flight "
                             f"[0, {duration}) s, got {self.times[-1]}")

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return all(np.array_equal(getattr(self, f), getattr(other, f)) for f in self._FIELDS)

    def __hash__(self):
        return hash(tuple(getattr(self, f).tobytes() for f in self._FIELDS))

    def __repr__(self):
        a, b, c = self._FIELDS
        return (f"{type(self).__name__}({a}={getattr(self, a).tolist()}, "
                f"{b}={getattr(self, b).tolist()}, "
                f"{c}={np.round(getattr(self, c), 4).tolist()})")


def _restore(cls, *arrays):
    seq = object.__new__(cls)
    for name, arr in zip(cls._FIELDS, arrays):
        object.__setattr__(seq, name, arr)
    return seq


class ThrustSequence(_Sequence):
    """Piecewise-constant thrust: segment ``i`` holds from ``times[i]`` to the next change.

    Parameters
    ----------
    times : array_like, shape (k,)
        Start time of each segment [s]; ``times[0] == 0``, strictly increasing.
    magnitudes : array_like, shape (k,)
        Thrust magnitude of each segment [N], >= 0.
    directions : array_like, shape (k, 3)
        Direction of each segment (x, y, z); any non-zero vector, normalised
        here to unit length.

    Examples
    --------
    The paper's example loop (40 N up for 4 s, 15 N along x for 6 s, 45 N along y):

    >>> seq = ThrustSequence([0, 4, 10], [40, 15, 45], [[0, 0, 1], [1, 0, 0], [0, 1, 0]])
    >>> seq.thrust(5.0)
    array([15.,  0.,  0.])
    >>> seq.n_changes
    2
    """

    __slots__ = ("times", "magnitudes", "directions")
    _FIELDS = __slots__
    _KIND = "thrust"

    def __init__(self, times, magnitudes, directions):
        times = self._check_times(times)
        k = times.shape[0]
        magnitudes = check_array(magnitudes, "magnitudes", shape=(k,))
        directions = check_array(directions, "directions", shape=(k, 3))
        if np.any(magnitudes < 0):
            raise ValueError(f"magnitudes must be >= 0 N, got {magnitudes.tolist()}")
        norms = np.linalg.norm(directions, axis=1)
        if np.any(norms == 0):
            raise ValueError("directions must be non-zero vectors, got a zero row at index "
                             f"{int(np.flatnonzero(norms == 0)[0])}")
        self._freeze(times, magnitudes, directions / norms[:, None])

    # -- evaluation ---------------------------------------------------------- #
    @property
    def vectors(self) -> np.ndarray:
        """Thrust vector of each segment, shape (k, 3) [N]."""
        return self.magnitudes[:, None] * self.directions

    def thrust(self, t: ArrayLike) -> np.ndarray:
        """Thrust vector [N] at time(s) ``t`` [s]: shape (3,) or (len(t), 3)."""
        t_arr = np.asarray(t, dtype=float)
        if np.any(t_arr < -1e-9) or not np.all(np.isfinite(t_arr)):
            raise ValueError("t must be finite and >= 0 s")
        idx = np.maximum(self.segment(t_arr), 0)
        return self.vectors[idx]

    # -- vector form for CEM ------------------------------------------------- #
    def to_vector(self) -> np.ndarray:
        """Flat vector ``[m_0, d_0x, d_0y, d_0z, m_1, ...]``, shape (4 k,)."""
        return np.column_stack([self.magnitudes, self.directions]).ravel()

    @classmethod
    def from_vector(cls, vector: ArrayLike, times: ArrayLike,
                    max_magnitude: float = MAX_THRUST) -> ThrustSequence:
        """Thrust sequence from a CEM sample (replication notes, decision 7).

        Magnitudes are clipped to ``[0, max_magnitude]`` [N] and direction
        components normalised to unit length; an all-zero direction (probability
        zero for Gaussian samples) becomes +z.

        Parameters
        ----------
        vector : array_like, shape (4 k,)
            ``[m_0, d_0x, d_0y, d_0z, m_1, ...]``.
        times : array_like, shape (k,)
            Segment start times [s].
        """
        times = check_array(times, "times", ndim=1)
        vector = check_array(vector, "vector", shape=(4 * times.shape[0],))
        max_magnitude = check_scalar(max_magnitude, "max_magnitude", low=0.0, high=1e6)
        v = vector.reshape(-1, 4)
        mags = np.clip(v[:, 0], 0.0, max_magnitude)
        dirs = v[:, 1:].copy()
        dirs[np.linalg.norm(dirs, axis=1) == 0] = (0.0, 0.0, 1.0)
        return cls(times, mags, dirs)

    def to_dict(self) -> dict[str, list]:
        """Plain lists, for tables: times [s], magnitudes [N], directions."""
        return {"times": self.times.tolist(), "magnitudes": self.magnitudes.tolist(),
                "directions": self.directions.tolist()}


def _check_rng(rng):
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")


def _change_times(rng, n_changes, duration, step):
    """Distinct change times on the grid ``step, 2 step, ... < duration``, sorted, after 0."""
    step = check_scalar(step, "time_step", low=0.0, low_inclusive=False)
    slots = np.arange(1, int(np.ceil(duration / step - 1e-9))) * step
    n_changes = check_scalar(n_changes, "n_changes", low=0, high=len(slots), integer=True)
    chosen = np.sort(rng.choice(slots, size=n_changes, replace=False)) if n_changes else []
    return np.concatenate([[0.0], chosen])


def _n_steps_within(limit, step, limit_name, step_name, high):
    """``(limit, step, k)``: both checked (``limit`` in [0, high], ``step`` in (0, limit]) and
    ``k`` the largest whole number with ``k step <= limit`` (so no draw passes the limit)."""
    limit = check_scalar(limit, limit_name, low=0.0, high=high)
    step = check_scalar(step, step_name, low=0.0, low_inclusive=False,
                        high=limit if limit > 0 else None)
    return limit, step, int(math.floor(limit / step + 1e-9))


def _check_max_magnitude(max_magnitude):
    return check_scalar(max_magnitude, "max_magnitude", low=0.0, high=1e6)


def sample_paper(rng: np.random.Generator, n_changes: int = 6, duration: float = 12.0,
                 magnitude_step: float = 5.0, max_magnitude: float = MAX_THRUST,
                 axes: str = "positive", time_step: float = 1.0) -> ThrustSequence:
    """The paper's thrust sampler (replication notes, decision 2).

    Change times are ``n_changes`` distinct whole multiples of ``time_step``
    inside (0, duration), sorted, after the first segment at t = 0; magnitudes
    are multiples of ``magnitude_step`` in [0, max_magnitude] [N]; directions
    are unit axes (``axes="positive"``: +x, +y, +z as in the paper's example;
    ``"signed"``: the six signed axes).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    n_changes : int
        Number of changes after t = 0, in [0, duration/time_step - 1]
        (11 for the paper's 12 s flight on a whole-second grid).

    Examples
    --------
    >>> seq = sample_paper(np.random.default_rng(0))
    >>> seq.n_changes, bool(np.all(seq.magnitudes % 5 == 0))
    (6, True)
    """
    _check_rng(rng)
    duration = check_scalar(duration, "duration", low=0, low_inclusive=False)
    _, magnitude_step, top = _n_steps_within(max_magnitude, magnitude_step, "max_magnitude",
                                             "magnitude_step", 1e6)
    if axes not in ("positive", "signed"):
        raise ValueError(f"axes must be 'positive' or 'signed', got {axes!r}")
    times = _change_times(rng, n_changes, duration, time_step)
    k = times.shape[0]
    n_levels = top + 1
    mags = rng.integers(0, n_levels, size=k) * float(magnitude_step)
    if axes == "positive":
        dirs = _AXES[rng.integers(0, 3, size=k)]
    elif axes == "signed":
        idx = rng.integers(0, 6, size=k)
        dirs = _AXES[idx % 3] * np.where(idx < 3, 1.0, -1.0)[:, None]
    else:
        raise ValueError(f"axes must be 'positive' or 'signed', got {axes!r}")
    return ThrustSequence._drawn(times, mags, dirs)  # unit axes: the constructor's own values


def sample_continuous(rng: np.random.Generator, n_changes: int = 6, duration: float = 12.0,
                      max_magnitude: float = MAX_THRUST,
                      time_step: float = 1.0) -> ThrustSequence:
    """Continuous variant: uniform magnitudes in [0, max_magnitude] [N], directions
    uniform on the unit sphere; change times as in :func:`sample_paper`."""
    _check_rng(rng)
    duration = check_scalar(duration, "duration", low=0, low_inclusive=False)
    max_magnitude = _check_max_magnitude(max_magnitude)
    times = _change_times(rng, n_changes, duration, time_step)
    k = times.shape[0]
    mags = rng.uniform(0.0, max_magnitude, size=k)
    dirs = rng.standard_normal((k, 3))
    dirs[np.linalg.norm(dirs, axis=1) == 0] = (0.0, 0.0, 1.0)
    return ThrustSequence(times, mags, dirs)


#: Samplers by name (settings refer to them by these names).
SAMPLERS = {"paper": sample_paper, "continuous": sample_continuous}

#: The paper's worked-example thrust (Table "Simulation parameters and outputs").
PAPER_EXAMPLE = ThrustSequence([0.0, 4.0, 10.0], [40.0, 15.0, 45.0],
                               [[0, 0, 1], [1, 0, 0], [0, 1, 0]])


# --------------------------------------------------------------------------- #
# attitude actions (the paper's future work: moments, not only forces)
# --------------------------------------------------------------------------- #
#: Largest roll or pitch an attitude action commands [rad] (30 degrees).
MAX_TILT = math.radians(30.0)


def euler_to_quaternion(angles) -> np.ndarray:
    """Quaternions [i, j, k, w] (scalar last, body -> world) of ZYX Euler ``angles`` (n, 3):
    roll about x, pitch about y, yaw about z [rad], applied yaw first (``R = Rz Ry Rx``)."""
    a = np.atleast_2d(check_array(angles, "angles"))
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"angles must have shape (3,) or (n, 3), got {np.shape(angles)}")
    cr, sr = np.cos(a[:, 0] / 2), np.sin(a[:, 0] / 2)
    cp, sp = np.cos(a[:, 1] / 2), np.sin(a[:, 1] / 2)
    cy, sy = np.cos(a[:, 2] / 2), np.sin(a[:, 2] / 2)
    return np.stack([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                     cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy], axis=1)


class AttitudeSequence(_Sequence):
    """Piecewise-constant collective thrust and attitude: segment ``i`` holds from
    ``times[i]`` to the next change, flown with RotorPy's ``cmd_ctatt`` (a multirotor only).

    Parameters
    ----------
    times : array_like, shape (k,)
        Start time of each segment [s]; ``times[0] == 0``, strictly increasing.
    thrusts : array_like, shape (k,)
        Collective thrust of each segment [N], >= 0.
    angles : array_like, shape (k, 3)
        Roll, pitch, yaw of each segment [rad] (ZYX Euler); roll and pitch in
        [-pi/2, pi/2], yaw in [-pi, pi].

    Examples
    --------
    >>> seq = AttitudeSequence([0, 4], [20.0, 25.0], [[0, 0, 0], [0.2, -0.1, 0.5]])
    >>> seq.n_changes, seq.quaternions().shape
    (1, (2, 4))
    """

    __slots__ = ("times", "thrusts", "angles")
    _FIELDS = __slots__
    _KIND = "attitude"
    #: the CEM's start: per segment (thrust [N], roll, pitch, yaw [rad]) means and stds
    CEM_MEAN = (25.0, 0.0, 0.0, 0.0)
    CEM_STD = (50.0, 0.3, 0.3, 1.0)

    def __init__(self, times, thrusts, angles):
        times = self._check_times(times)
        k = times.shape[0]
        thrusts = check_array(thrusts, "thrusts", shape=(k,))
        angles = check_array(angles, "angles", shape=(k, 3))
        if np.any(thrusts < 0):
            raise ValueError(f"thrusts must be >= 0 N, got {thrusts.tolist()}")
        if np.any(np.abs(angles[:, :2]) > math.pi / 2 + 1e-12):
            raise ValueError("angles: roll and pitch must be in [-pi/2, pi/2] rad, got "
                             f"{np.abs(angles[:, :2]).max():g}")
        if np.any(np.abs(angles[:, 2]) > math.pi + 1e-12):
            raise ValueError(f"angles: yaw must be in [-pi, pi] rad, got "
                             f"{np.abs(angles[:, 2]).max():g}")
        self._freeze(times, thrusts, angles)

    @property
    def magnitudes(self) -> np.ndarray:
        """Collective thrust of each segment [N] (the name the vehicles check limits on)."""
        return self.thrusts

    def quaternions(self) -> np.ndarray:
        """Commanded attitude of each segment, quaternions [i, j, k, w], shape (k, 4)."""
        return euler_to_quaternion(self.angles)

    def to_vector(self) -> np.ndarray:
        """Flat vector ``[T_0, roll_0, pitch_0, yaw_0, T_1, ...]``, shape (4 k,)."""
        return np.column_stack([self.thrusts, self.angles]).ravel()

    @classmethod
    def from_vector(cls, vector, times, max_magnitude: float = MAX_THRUST,
                    max_tilt: float = MAX_TILT) -> AttitudeSequence:
        """A CEM sample: thrusts clipped to [0, max_magnitude] [N], roll and pitch to
        [-max_tilt, max_tilt] [rad], yaw wrapped to [-pi, pi)."""
        times = check_array(times, "times", ndim=1)
        vector = check_array(vector, "vector", shape=(4 * times.shape[0],))
        max_magnitude = _check_max_magnitude(max_magnitude)
        max_tilt = check_scalar(max_tilt, "max_tilt", low=0.0, high=math.pi / 2)
        v = vector.reshape(-1, 4)
        angles = np.column_stack([np.clip(v[:, 1:3], -max_tilt, max_tilt),
                                  (v[:, 3] + math.pi) % (2 * math.pi) - math.pi])
        return cls(times, np.clip(v[:, 0], 0.0, max_magnitude), angles)

    def to_dict(self) -> dict:
        return {"times": self.times.tolist(), "magnitudes": self.thrusts.tolist(),
                "directions": self.angles.tolist()}


def sample_attitude(rng: np.random.Generator, n_changes: int = 6, duration: float = 12.0,
                    magnitude_step: float = 5.0, max_magnitude: float = MAX_THRUST,
                    tilt_step: float = math.radians(10.0), max_tilt: float = MAX_TILT,
                    yaw_step: float = math.radians(45.0),
                    time_step: float = 1.0) -> AttitudeSequence:
    """Attitude actions drawn like the paper's thrust sequences: the same change times,
    thrusts that are multiples of ``magnitude_step`` in [0, max_magnitude] [N], roll and
    pitch multiples of ``tilt_step`` in [-max_tilt, max_tilt] (10 and 30 degrees), yaw a
    multiple of ``yaw_step`` (45 degrees) in [-pi, pi).

    >>> seq = sample_attitude(np.random.default_rng(0))
    >>> seq.n_changes, bool(np.all(np.abs(seq.angles[:, :2]) <= MAX_TILT + 1e-12))
    (6, True)
    """
    _check_rng(rng)
    duration = check_scalar(duration, "duration", low=0, low_inclusive=False)
    _, magnitude_step, n_thrust = _n_steps_within(max_magnitude, magnitude_step,
                                                  "max_magnitude", "magnitude_step", 1e6)
    _, tilt_step, n_tilt = _n_steps_within(max_tilt, tilt_step, "max_tilt", "tilt_step",
                                           math.pi / 2)
    yaw_step = check_scalar(yaw_step, "yaw_step", low=0.0, low_inclusive=False,
                            high=2 * math.pi)
    times = _change_times(rng, n_changes, duration, time_step)
    k = times.shape[0]
    thrusts = rng.integers(0, n_thrust + 1, size=k) * float(magnitude_step)
    tilts = rng.integers(-n_tilt, n_tilt + 1, size=(k, 2)) * tilt_step
    n_yaw = int(math.floor(2 * math.pi / yaw_step + 1e-9))
    yaws = (rng.integers(0, n_yaw, size=k) * yaw_step + math.pi) % (2 * math.pi) - math.pi
    return AttitudeSequence(times, thrusts, np.column_stack([tilts, yaws]))


SAMPLERS["attitude"] = sample_attitude
