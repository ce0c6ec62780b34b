"""Flights continued from given states, each row with its own command: what a closed-loop
UAV flies and plans with.

This module owns :class:`Rollout`: many *rows* (a vehicle in one environment each) flown
forward a segment at a time, every row holding its own thrust vector [N] for the segment.
:func:`uavwind.simulate` flies one open-loop sequence through every environment from t = 0;
a closed-loop UAV instead needs to stop at a decision time, choose the next segment from
what it has seen, and ask "where would the next segment take me in each environment I
know?" from the states it has reached. A row's state is the vehicle's: ``(r, v_air)``
(6 numbers) for the point mass, RotorPy's 20 numbers for a
:class:`~uavwind.sim.multirotor.Multirotor`.

The steps are :func:`uavwind.simulate`'s own, operation for operation, so a flight chained
segment by segment through :meth:`Rollout.advance` equals the open-loop simulation of the
same thrust sequence bit for bit (the tests hold it to ``==``), with a multirotor's
``state_errors`` too (:meth:`~uavwind.sim.multirotor.Multirotor.fly`'s: the thrust the rotors
make and the attitude estimate, what a real vehicle adds; :mod:`uavwind.sim.variability`).
The wind comes from a
:class:`WindTable`: every environment of a :class:`~uavwind.sim.wind.WindModel` as arrays,
looked up per row (constant and shear winds from their parameters, winds that do not depend
on the position, such as Dryden gusts, tabulated at every step time), optionally with gusts
added to every environment's wind (``gusts``: the variability's Dryden gusts on a mean wind,
as :class:`~uavwind.sim.wind.SumWind` adds them).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_array, check_instance, check_scalar
from ._rotor_layout import _kernels
from ._slots import N_STATE, S_QUAT
from .multirotor import Multirotor, force_command, quaternion_product, rotvec_quaternions
from .vehicle import UAV, n_steps as _n_steps
from .wind import WindGroups, ConstantWind, ShearWind, WindModel, libm_pow

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["WindTable", "Rollout", "state_size"]

_CONSTANT, _SHEAR, _TABLE = 0, 1, 2


def _leaves(wind):
    """The (model, first environment) of each non-combined model inside ``wind``."""
    if isinstance(wind, WindGroups):
        out = []
        for model, start in zip(wind.models, wind._bounds[:-1]):
            out += [(m, int(start) + s) for m, s in _leaves(model)]
        return out
    return [(wind, 0)]


class WindTable:
    """Every environment of ``wind`` as arrays, for rows that each fly in one of them.

    Parameters
    ----------
    wind : WindModel
        The environments (a :class:`~uavwind.sim.wind.WindGroups` of constant, shear and
        Dryden groups, or any model whose velocity does not depend on the position).
    times : array_like, shape (n_times,)
        Every time [s] the wind will be asked for (the step starts of the whole flight); a
        position-independent model is tabulated there.
    gusts : WindModel, optional
        A wind of the same environments that does not depend on the position (Dryden
        gusts), tabulated at ``times`` and added to each environment's wind (``wind + gusts``
        as :class:`~uavwind.sim.wind.SumWind` evaluates it). Default None: none.

    Notes
    -----
    A :class:`~uavwind.sim.wind.ConstantWind` and a :class:`~uavwind.sim.wind.ShearWind`
    are evaluated from their parameters with the models' own arithmetic; any other model
    (and ``gusts``) gives its winds at every time at once (``model._velocities(times)``,
    each its velocity at that time with the positions ignored), which is exact for the
    Dryden gusts (they do not depend on the position) and refused for a model that says it
    does (a ``ShearWind`` subclass).
    """

    def __init__(self, wind: WindModel, times: ArrayLike, gusts: WindModel | None = None):
        check_instance(wind, "wind", WindModel)
        self.times = check_array(times, "times", ndim=1)
        self.n_env = wind.n_env
        self.added = None  # (n_times, n_env, 3): the gusts added to every environment
        if gusts is not None:
            check_instance(gusts, "gusts", WindModel)
            if gusts.n_env != self.n_env:
                raise ValueError(f"gusts must describe the wind's {self.n_env} environments, "
                                 f"got n_env {gusts.n_env}")
            if isinstance(gusts, (ConstantWind, ShearWind, WindGroups)):
                raise TypeError(f"gusts must be a wind that does not depend on the position "
                                f"(Dryden gusts), got {type(gusts).__name__}")
            self.added = np.ascontiguousarray(gusts._velocities(self.times), dtype=float)
        self.kind = np.empty(self.n_env, dtype=np.int8)
        self.base = np.zeros((self.n_env, 3))      # constant velocity, or shear reference
        self.shear = np.zeros((self.n_env, 3))     # alpha, reference height, floor
        self.table = np.zeros((self.times.shape[0], self.n_env, 3))
        for model, start in _leaves(wind):
            sl = slice(start, start + model.n_env)
            if type(model) is ConstantWind:
                self.kind[sl] = _CONSTANT
                self.base[sl] = model.velocities
            elif type(model) is ShearWind:
                self.kind[sl] = _SHEAR
                self.base[sl] = model.reference_velocities
                self.shear[sl] = (model.alpha, model.reference_height, model.floor)
            elif isinstance(model, (ConstantWind, ShearWind)):
                raise TypeError(f"wind: a subclass of {type(model).__mro__[1].__name__} "
                                f"({type(model).__name__}) may compute its velocity its own "
                                f"way; give the base class")
            else:
                self.kind[sl] = _TABLE
                self.table[:, sl] = model._velocities(self.times)
        self._shear_rows = np.flatnonzero(self.kind == _SHEAR)
        self._table_rows = np.flatnonzero(self.kind == _TABLE)

    def velocity(self, k: int, env: np.ndarray, positions: np.ndarray) -> np.ndarray:
        """Wind [m/s] (n_rows, 3) at time ``times[k]`` for rows flying in environments
        ``env`` (n_rows,) at ``positions`` (n_rows, 3) [m]."""
        lookup = self.lookup(env)
        k = check_scalar(k, "k", low=0, high=self.times.shape[0] - 1, integer=True)
        positions = check_array(positions, "positions", shape=(lookup.base.shape[0], 3))
        return lookup(k, positions)

    def lookup(self, env: np.ndarray) -> _Lookup:
        """The wind of rows in environments ``env`` as a function ``(k, positions) ->
        (n_rows, 3)``, its per-row arrays gathered once (for a loop over steps)."""
        return _Lookup(self, self.check_env(env))

    def check_env(self, env, n_rows: int | None = None) -> np.ndarray:
        """``env`` as an index array after checking it: integers in ``[0, n_env)``, one
        dimension (of length ``n_rows`` if given)."""
        arr = np.asarray(env)
        if arr.dtype.kind not in "iu" and not (arr.size == 0 and arr.dtype.kind == "f"):
            raise TypeError(f"env must be an array of integers (environment indices), got "
                            f"dtype {arr.dtype}")
        want = "(n_rows,)" if n_rows is None else f"({n_rows},)"
        if arr.ndim != 1 or (n_rows is not None and arr.shape[0] != n_rows):
            raise ValueError(f"env must have shape {want}, one environment per row, got "
                             f"{arr.shape}")
        if arr.size and (arr.min() < 0 or arr.max() >= self.n_env):
            raise ValueError(f"env must hold environment indices in [0, {self.n_env - 1}], "
                             f"got {arr.min()} .. {arr.max()}")
        return arr.astype(np.intp, copy=False)


class _Lookup:
    """:meth:`WindTable.lookup`: the table's arrays gathered for one set of rows (each
    C-contiguous: the rollout's kernel, ``fly_rows``, reads them as one compiled signature)."""

    def __init__(self, table, env):
        kind = table.kind[env]
        self.base = table.base[env]
        self.sh = np.flatnonzero(kind == _SHEAR)
        self.tb = np.flatnonzero(kind == _TABLE)
        p = table.shear[env[self.sh]]
        self.floor, self.height, self.alpha = (np.ascontiguousarray(p[:, i]) for i in (2, 1, 0))
        self.ref = self.base[self.sh]
        self.env_tb = env[self.tb]
        self.table = table.table
        self.added = table.added
        self.env = np.ascontiguousarray(env)

    def __call__(self, k, positions):
        out = self.base.copy()
        if self.sh.size:
            z = np.maximum(positions[self.sh, 2], self.floor)
            out[self.sh] = self.ref * libm_pow(z / self.height, self.alpha)[:, None]
        if self.tb.size:
            out[self.tb] = self.table[k, self.env_tb]
        if self.added is not None:  # as SumWind: (0 + wind) + gusts
            out = out + self.added[k, self.env]
        return out


def state_size(uav: UAV | Multirotor) -> int:
    """Numbers in one row's state: 6 for the point mass ``(r, v_air)``, 20 for a multirotor."""
    return N_STATE if isinstance(uav, Multirotor) else 6


@dataclass(frozen=True, eq=False)
class Rollout:
    """Rows of one vehicle, each in one environment of a :class:`WindTable`, flown forward
    a segment at a time from their states. Use :meth:`for_flight` to build one for a
    flight of ``duration`` seconds: it checks the vehicle, the grid and the duration once, and
    the constructor and the methods below trust what it made.

    Parameters
    ----------
    uav : UAV or Multirotor
        The vehicle (every row flies the same one).
    table : WindTable
        The environments; its times are the step starts (point mass) or control-step
        starts (multirotor) of the whole flight.
    dt : float
        Sample time [s] (positions are recorded every ``dt``); for a multirotor a whole
        number of its control steps.
    n_samples : int
        Samples of the whole flight (``duration / dt``).
    """

    uav: UAV | Multirotor
    table: WindTable
    dt: float
    n_samples: int

    @classmethod
    def for_flight(cls, uav: UAV | Multirotor, wind: WindModel, dt: float = 0.1,
                   duration: float = 12.0, gusts: WindModel | None = None) -> Rollout:
        """A rollout of ``wind``'s environments over a flight of ``duration`` [s] sampled
        every ``dt`` [s]; ``gusts`` added to every environment's wind (:class:`WindTable`)."""
        check_instance(uav, "uav", (UAV, Multirotor))
        dt = check_scalar(dt, "dt", low=0, low_inclusive=False)
        duration = check_scalar(duration, "duration", low=0, low_inclusive=False, high=1e6)
        n = _n_steps(dt, duration)
        if isinstance(uav, Multirotor):
            per = uav.check_grid(dt)
            times = np.arange(n * per) * (1.0 / uav.control_rate)
        else:
            times = np.arange(n) * dt
        return cls(uav, WindTable(wind, times, gusts), float(dt), n)

    def with_substeps(self, substeps: int) -> Rollout:
        """The same rollout with a multirotor integrated in ``substeps`` RK4 steps per
        control step (a cheaper model to plan with; the point mass is returned as is)."""
        if not isinstance(self.uav, Multirotor):
            return self
        return replace(self, uav=replace(self.uav, substeps=substeps))

    @property
    def steps_per_sample(self) -> int:
        """Integration steps per recorded sample (1, or the multirotor's control steps)."""
        # the grid was checked when the rollout was made (for_flight)
        return self.uav.steps_per_sample(self.dt) if isinstance(self.uav, Multirotor) else 1

    def start(self, env: ArrayLike, start_position: ArrayLike) -> np.ndarray:
        """States (n_rows, :func:`state_size`) at t = 0 of rows in environments ``env``,
        starting at ``start_position`` (3,) [m], as :func:`uavwind.simulate` starts them."""
        env = self.table.check_env(env)
        start = check_array(start_position, "start_position", shape=(3,))
        if isinstance(self.uav, Multirotor):
            winds0 = self.table.velocity(0, env, np.broadcast_to(start, (env.size, 3)))
            return self.uav.initial_states(start, winds0)
        s = np.zeros((env.size, 6))
        s[:, 0:3] = start
        return s

    def advance(self, states: np.ndarray, env: np.ndarray, forces: np.ndarray, sample0: int,
                n: int, state_errors: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Fly every row ``n`` samples on from sample ``sample0``, holding its thrust.

        Parameters
        ----------
        states : ndarray, shape (n_rows, state_size)
            The rows' states at ``sample0 * dt`` (not modified).
        env : ndarray of int, shape (n_rows,)
            The environment of each row.
        forces : ndarray, shape (n_rows, 3)
            The thrust vector each row holds [N] (a multirotor flies it through
            :func:`~uavwind.sim.multirotor.force_command`).
        sample0, n : int
            First sample and number of samples; ``sample0 + n <= n_samples``.
        state_errors : ndarray, shape (n_rows, n * steps_per_sample, 6), optional
            A multirotor's errors over the control steps flown, as
            :meth:`~uavwind.sim.multirotor.Multirotor.fly`'s: the attitude loop reads an
            estimate tilted by ``(e_x, e_y, 0)`` [rad] (columns 0, 1) and the rotors make
            ``1 + e_t`` times the thrust (column 2); columns 3-5 are not read. None (default):
            the thrust as held, the same code path as before the errors existed.

        Returns
        -------
        states : ndarray, shape (n_rows, state_size)
            The states at ``(sample0 + n) * dt``.
        positions : ndarray, shape (n_rows, n, 3)
            Positions [m] after each step, as :func:`uavwind.simulate` records them.
        """
        sample0 = check_scalar(sample0, "sample0", low=0, integer=True)
        n = check_scalar(n, "n", low=1, integer=True)
        if sample0 + n > self.n_samples:
            raise ValueError(f"sample0 = {sample0} and n = {n}: samples {sample0}.."
                             f"{sample0 + n} lie outside the flight's 0..{self.n_samples}")
        states, env, forces = self.check_rows(states, env, forces)
        if state_errors is not None:
            if not isinstance(self.uav, Multirotor):
                raise ValueError("state_errors needs a multirotor (the point mass flies its "
                                 "thrust exactly and has no attitude loop)")
            state_errors = check_array(state_errors, "state_errors",
                                       shape=(states.shape[0], n * self.steps_per_sample, 6))
            if not np.all(np.abs(state_errors[..., :3]) < 0.5):
                raise ValueError("state_errors must have small attitude and thrust errors: each "
                                 "|error| of columns 0-2 below 0.5 (rad, or a share of the "
                                 "thrust)")
        if isinstance(self.uav, Multirotor):
            states, positions = self._advance_multirotor(states, env, forces, sample0, n,
                                                         state_errors)
        else:
            states, positions = self._advance_point_mass(states, env, forces, sample0, n)
        if not (np.all(np.isfinite(positions)) and np.all(np.isfinite(states))):
            raise ValueError("the rollout produced non-finite states (winds, states or forces "
                             "too large for float64); check the wind speeds and the states")
        return states, positions

    def check_rows(self, states, env, forces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(states, env, forces)`` of :meth:`advance` checked before any kernel reads them:
        states (n_rows, :func:`state_size`) finite (a multirotor's attitude quaternion,
        columns 6-9, of norm near 1), ``env`` indices of the table's environments, forces
        (n_rows, 3) finite and, for a multirotor, within its rotors' thrust."""
        width = state_size(self.uav)
        what = (f"the multirotor's {N_STATE}" if isinstance(self.uav, Multirotor)
                else "the point mass's 6 (r, v_air)")
        arr = np.asarray(states) if not isinstance(states, np.ndarray) else states
        if arr.ndim != 2 or arr.shape[1] != width:
            raise ValueError(f"states must have shape (n_rows, {width}) ({what} numbers per "
                             f"row), got {np.shape(states)}")
        states = check_array(states, "states", shape=(None, width))
        rows = states.shape[0]
        env = self.table.check_env(env, rows)
        forces = check_array(forces, "forces", shape=(rows, 3))
        if isinstance(self.uav, Multirotor):
            qn = np.linalg.norm(states[:, S_QUAT], axis=1)
            if np.any((qn < 0.5) | (qn > 2.0)):
                raise ValueError(f"states: the attitude quaternions (columns "
                                 f"{S_QUAT.start}-{S_QUAT.stop - 1}) must have "
                                 f"norm near 1, got norms {qn.min():g} .. {qn.max():g}")
            top = float(np.linalg.norm(forces, axis=1).max()) if rows else 0.0
            if top > self.uav.max_thrust * (1 + 1e-12):
                raise ValueError(f"forces must be <= {self.uav.max_thrust:.1f} N for this "
                                 f"multirotor (its rotors at full speed), got {top:g} N")
        return states, env, forces

    def _advance_point_mass(self, states, env, forces, sample0, n):
        uav, dt = self.uav, self.dt
        accel = forces / uav.mass  # (rows, 3), as simulate's (steps, 3)
        accel[:, 2] -= uav.gravity
        r = states[:, 0:3].copy()
        v_air = states[:, 3:6].copy()
        positions = np.empty((states.shape[0], n, 3))
        drag = uav.drag_factor / uav.mass
        wind = self.table.lookup(env)
        for j in range(n):
            k = sample0 + j
            if drag:
                speed = np.sqrt(np.einsum("ij,ij->i", v_air, v_air))
                v_air = v_air + (accel - drag * speed[:, None] * v_air) * dt
            else:
                v_air = v_air + accel * dt
            w = wind(k, r)
            v_gnd = v_air + w
            r = r + v_gnd * dt
            positions[:, j] = r
        return np.concatenate([r, v_air], axis=1), positions

    def _advance_multirotor(self, states, env, forces, sample0, n, errors=None):
        uav = self.uav
        per = self.steps_per_sample
        h = 1.0 / uav.control_rate / uav.substeps
        S = np.ascontiguousarray(states, dtype=float).copy()
        rows = S.shape[0]
        T = np.empty(rows)
        C = np.empty((rows, 4))
        unique, inverse = np.unique(forces, axis=0, return_inverse=True)
        for u, f in enumerate(unique):  # one command per distinct force
            T_u, C_u, _ = force_command(f, uav.tilt_limit)
            rows_u = inverse.reshape(-1) == u
            T[rows_u], C[rows_u] = T_u, C_u
        clipped = np.zeros(rows, dtype=np.int64)
        positions = np.empty((rows, n, 3))
        k0 = sample0 * per
        w = self.table.lookup(env)
        if errors is not None:  # as Multirotor.fly: the rotors' thrust, the command flown
            q_err = rotvec_quaternions(-errors[..., 0], -errors[..., 1])  # E^T
            Tk = np.ascontiguousarray(T[:, None] * (1.0 + errors[..., 2]))
            Ck = np.ascontiguousarray(quaternion_product(q_err, C[:, None, :]))
        else:
            Tk, Ck = np.empty((rows, 0)), np.empty((rows, 0, 4))
        added = np.empty((0, 0, 3)) if w.added is None else w.added
        _kernels().fly_rows(uav.packed, S, T, C, Tk, Ck, uav.substeps, h, per, k0, n * per,
                            w.base, w.sh, w.ref, w.height, w.floor, w.alpha, w.tb, w.env_tb,
                            w.table, added, w.env, positions, clipped)
        return S, positions
