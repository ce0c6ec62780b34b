"""Wind models behind one contract: ``velocity(t, positions) -> (n_env, 3)`` [m/s].

This module owns every wind field the UAV can fly through (paper section
"System model", eqs 9-12):

* :class:`ConstantWind` -- the same velocity everywhere, all the time;
* :class:`ShearWind` -- the power-law shear profile of eq 9;
* :class:`DrydenWind` -- Dryden turbulence (eqs 10-12), as MIL-F-8785C specifies it
  (``variant="mil-f-8785c"``) or as the implementation the paper cites computes it
  (``variant="cited"``, every quirk a field of :class:`CitedDryden`); defined in
  :mod:`uavwind.sim.dryden` (and exported as ``uavwind.DrydenWind``);
* :class:`WindGroups` (old name :class:`CombinedWind`) -- several models *side by side*,
  one group of environments each, so one :func:`uavwind.simulate` call flies a whole loop.
  It never adds winds: ``WindGroups(mean, gusts)`` is two groups of environments, the mean
  wind in one and the gusts alone in the other;
* :class:`SumWind` (also ``a + b``) -- the superposition of models over the *same*
  environments, e.g. gusts on a mean wind; a sum of sums is one flat sum (each distinct
  model once, with how many times it is added), so any nesting is evaluated in one loop;
* :class:`RampedWind` -- a model faded in from still air over a ramp (a flight that starts
  hovering in still air, then meets the wind).

``with_seed(seed)`` redraws the gusts of every model inside a sum, a ramp or groups (each
distinct model from its own child of ``seed``; a ramp passes ``seed`` on as it is).

A wind model describes ``n_env`` *environments* at once. ``velocity(t,
positions)`` takes the time ``t`` [s] and the UAV positions ``(n_env, 3)`` [m]
(one per environment) and returns the velocity of the air mass at those points
``(n_env, 3)`` [m/s], axes (x, y, z) with z up. Models are immutable apart from
the lazily generated, seeded gust history of :class:`DrydenWind`.
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import check_array, check_scalar

if TYPE_CHECKING:
    from numpy.typing import ArrayLike


__all__ = ["WindModel", "ConstantWind", "ShearWind", "WindGroups", "CombinedWind", "SumWind",
           "RampedWind", "SinusoidalWind", "MAX_WIND", "libm_pow"]


def libm_pow(base: ArrayLike, exponent: ArrayLike) -> np.ndarray:
    """``base ** exponent`` element by element through the C library's ``pow``
    (:func:`math.pow`), for positive finite bases: the same double on every x86-64 CPU.

    ``np.power`` is not machine-independent: on a host with AVX-512 numpy dispatches float64
    ``power`` (like ``exp``, ``log`` and ``arctan2``) to its own vector code, whose last bit
    differs from libm's in a few percent of calls, while an AVX2 host calls libm. Through the
    shear profile that made a loop's trajectories, and so its silhouette, depend on the
    machine (tests/test_wind.py and tests/test_pins.py). The profile has one power per
    environment and step, so the scalar calls cost microseconds per step.
    """
    b, e = np.asarray(base, dtype=float), np.asarray(exponent, dtype=float)
    if e.ndim == 0:  # the shear profile's alpha, once per step: no broadcast copy of it
        exponents = itertools.repeat(float(e))
    else:
        b, e = np.broadcast_arrays(b, e)
        exponents = e.ravel().tolist()
    return np.fromiter(map(math.pow, b.ravel().tolist(), exponents), dtype=float,
                       count=b.size).reshape(b.shape)


class WindModel(ABC):
    """The contract every wind model honours.

    Attributes
    ----------
    n_env : int
        Number of environments the model describes.
    """

    n_env: int

    def velocity(self, t: float, positions: ArrayLike) -> np.ndarray:
        """Wind velocity of each environment at time ``t`` and its UAV position.

        Parameters
        ----------
        t : float
            Time since the start of the flight [s], >= 0.
        positions : array_like, shape (n_env, 3)
            Position of the UAV in each environment [m] (z up).

        Returns
        -------
        ndarray, shape (n_env, 3)
            Velocity of the air mass [m/s].
        """
        t = check_scalar(t, "t", low=0)
        positions = check_array(positions, "positions", shape=(self.n_env, 3))
        return self._velocity(t, positions)

    @abstractmethod
    def _velocity(self, t: float, positions: np.ndarray) -> np.ndarray:
        """Unchecked :meth:`velocity` used on the hot path of the integrator."""

    #: Whether the wind depends on the time alone, never on where the UAV is: then a
    #: flight's winds are known before it is flown (:meth:`_velocities`), and a position
    #: controlled flight runs whole in its kernel (``Multirotor.fly_reference``).
    position_free = False

    def _velocities(self, times: np.ndarray) -> np.ndarray:
        """The winds (len(times), n_env, 3) [m/s] at ``times`` [s] of a :attr:`position_free`
        wind, each exactly :meth:`_velocity` at that time; a model overrides it to compute
        them at once."""
        nowhere = np.zeros((self.n_env, 3))
        return np.stack([self._velocity(t, nowhere) for t in times])

    def __len__(self):
        return self.n_env

    def with_seed(self, seed: int | np.random.SeedSequence | None) -> WindModel:
        """This model with its gusts drawn from ``seed``: the model itself when it draws
        none (a constant or shear wind); :class:`~uavwind.sim.dryden.DrydenWind` redraws its
        gusts, and a sum, a ramp or groups reseed the models inside them. A setting builds
        and checks each group's model once and reseeds it for every loop."""
        return self

    def __add__(self, other):
        """``a + b``: the :class:`SumWind` of both (the same environments, winds added)."""
        if not isinstance(other, WindModel):
            return NotImplemented
        return SumWind(self, other)


#: Largest wind speed component accepted [m/s] (far beyond any wind; keeps float64 finite).
MAX_WIND = 1000.0


def _check_velocities(value, name):
    arr = check_array(value, name, shape=(None, 3))
    if arr.shape[0] == 0:
        raise ValueError(f"{name} must describe at least one environment, got shape {arr.shape}")
    if np.any(np.abs(arr) > MAX_WIND):
        raise ValueError(f"{name} must have every component in [-{MAX_WIND:g}, {MAX_WIND:g}] m/s, "
                         f"got {np.abs(arr).max():g}")
    arr = arr.copy()
    arr.setflags(write=False)
    return arr


class ConstantWind(WindModel):
    """Uniform, steady wind: ``v_wind(t, r) = velocities`` [m/s].

    Parameters
    ----------
    velocities : array_like, shape (n_env, 3)
        Wind velocity of each environment [m/s].

    Examples
    --------
    >>> w = ConstantWind([[1.1, 1.1, 0.0], [1.2, 1.2, 0.0]])
    >>> w.velocity(0.0, [[0, 0, 10], [0, 0, 10]])[1]
    array([1.2, 1.2, 0. ])
    """

    def __init__(self, velocities):
        self.velocities = _check_velocities(velocities, "velocities")
        self.n_env = self.velocities.shape[0]

    position_free = True

    def _velocity(self, t, positions):
        return self.velocities

    def _velocities(self, times):
        return np.broadcast_to(self.velocities, (len(times), *self.velocities.shape))

    def __repr__(self):
        return f"ConstantWind(n_env={self.n_env})"


class SinusoidalWind(WindModel):
    """Uniform wind whose speed swings about a mean:
    ``v_wind(t, r) = mean + amplitude sin(2 pi t / period)`` [m/s] (Neural-Fly's
    ``70p20sint`` condition is 8.5 + 2.4 sin t m/s: ``period = 2 pi``).

    Parameters
    ----------
    mean, amplitude : array_like, shape (n_env, 3)
        [m/s], each component in [-1000, 1000].
    period : float
        [s], in (0, 1e6].

    Examples
    --------
    >>> w = SinusoidalWind([[-8.5, 0, 0]], [[-2.4, 0, 0]], period=2 * np.pi)
    >>> w.velocity(np.pi / 2, [[0, 0, 2]])[0].round(6).tolist()
    [-10.9, 0.0, 0.0]
    """

    def __init__(self, mean, amplitude, period=2 * np.pi):
        self.mean = _check_velocities(mean, "mean")
        self.amplitude = _check_velocities(amplitude, "amplitude")
        if self.amplitude.shape != self.mean.shape:
            raise ValueError(f"amplitude must have the shape of mean {self.mean.shape}, got "
                             f"{self.amplitude.shape}")
        self.period = check_scalar(period, "period", low=0.0, low_inclusive=False, high=1e6)
        self.n_env = self.mean.shape[0]

    position_free = True

    def _velocity(self, t, positions):
        return self.mean + self.amplitude * np.sin(2 * np.pi * t / self.period)

    def _velocities(self, times):
        phase = np.sin(2 * np.pi * np.asarray(times, dtype=float) / self.period)
        return self.mean + self.amplitude * phase[:, None, None]

    def __repr__(self):
        return f"SinusoidalWind(n_env={self.n_env}, period={self.period:g})"


class ShearWind(WindModel):
    """Power-law wind shear (paper eq 9).

    ``U(z) = U_ref * (max(z, floor) / reference_height) ** alpha``, applied to
    every component of the reference vector (the paper's shear is horizontal,
    so the z component is normally 0).

    Parameters
    ----------
    reference_velocities : array_like, shape (n_env, 3)
        Wind velocity at ``reference_height`` [m/s].
    reference_height : float
        Height z_r where the wind equals the reference [m], > 0. Default 10 m,
        the start altitude, so tabulated speeds are those where the flight
        starts (the paper's ``z_r = 0`` is degenerate; replication notes, decision 3).
    alpha : float
        Power-law exponent [-], in [0, 1]. Default 0.143 (1/7, open terrain).
    floor : float
        Height below which the wind is held at its value at ``floor`` [m], > 0.
        Keeps the profile finite near and below the ground. Default 0.5 m.

    Examples
    --------
    >>> w = ShearWind([[2.0, 0.0, 0.0]], reference_height=10.0, alpha=0.143)
    >>> float(w.velocity(0.0, [[0, 0, 20.0]])[0, 0]) == 2.0 * 2 ** 0.143
    True
    """

    def __init__(self, reference_velocities, reference_height=10.0, alpha=0.143, floor=0.5):
        self.reference_velocities = _check_velocities(reference_velocities, "reference_velocities")
        self.reference_height = check_scalar(reference_height, "reference_height",
                                             low=0, low_inclusive=False)
        self.alpha = check_scalar(alpha, "alpha", low=0, high=1)
        self.floor = check_scalar(floor, "floor", low=0, low_inclusive=False)
        self.n_env = self.reference_velocities.shape[0]

    def factor(self, z: ArrayLike) -> np.ndarray:
        """Profile factor ``(max(z, floor)/z_ref)**alpha`` [-] for heights ``z`` [m]."""
        z = np.maximum(np.asarray(z, dtype=float), self.floor)
        return libm_pow(z / self.reference_height, self.alpha)  # not np.power: see libm_pow

    def _velocity(self, t, positions):
        return self.reference_velocities * self.factor(positions[:, 2])[:, None]

    def __repr__(self):
        return (f"ShearWind(n_env={self.n_env}, reference_height={self.reference_height}, "
                f"alpha={self.alpha}, floor={self.floor})")


# --------------------------------------------------------------------------- #
# models added over the same environments, and faded in
# --------------------------------------------------------------------------- #
def _check_models(models, name):
    if len(models) == 1 and isinstance(models[0], (list, tuple)):
        models = tuple(models[0])
    if not models:
        raise ValueError(f"{name} must hold at least one WindModel, got none")
    for i, m in enumerate(models):
        if not isinstance(m, WindModel):
            raise TypeError(f"{name}[{i}] must be a WindModel, got {type(m).__name__}")
    return tuple(models)


def _child_seeds(seed, n):
    """``n`` independent children of ``seed`` (an int >= 0, a SeedSequence or None), the
    ones ``SeedSequence(seed).spawn(n)`` gives, without changing a SeedSequence passed in:
    reseeding twice with one seed gives the same gusts."""
    if isinstance(seed, bool) or (seed is not None and not isinstance(
            seed, (int, np.integer, np.random.SeedSequence))):
        raise TypeError(f"seed must be an int, a numpy.random.SeedSequence or None, got "
                        f"{type(seed).__name__}")
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return [np.random.SeedSequence(ss.entropy, spawn_key=(*ss.spawn_key, i),
                                   pool_size=ss.pool_size) for i in range(n)]


#: Most times one model may be added into a sum (counts are exact in float64 up to 2^53).
MAX_TERM_COUNT = 2 ** 53


class SumWind(WindModel):
    """The superposition of wind models over the same environments: ``v_wind(t, r) =
    sum_i models[i].velocity(t, r)`` [m/s] (``a + b`` builds one).

    Every model describes the same ``n_env`` environments (a mean wind and its gusts, say);
    to put models side by side as groups of environments, use :class:`WindGroups`.

    A sum is flat: a :class:`SumWind` among ``models`` gives its terms, and one model added
    more than once is one term with a count (:attr:`terms`), so ``w = w + w`` forty times is
    one term of count 2^40 (at most :data:`MAX_TERM_COUNT`) and a sum of thousands of terms,
    however nested, is evaluated in one loop.

    Parameters
    ----------
    *models : WindModel
        At least one, each with the same ``n_env``.

    Attributes
    ----------
    terms : tuple of (WindModel, int)
        Each distinct model (none a sum), in the order first met, and how many times it is
        added.
    models : tuple of WindModel
        The distinct models of :attr:`terms`.

    Examples
    --------
    >>> w = ConstantWind([[5.0, 0, 0]]) + ConstantWind([[0.5, 1.0, 0]])
    >>> w.n_env, w.velocity(0.0, [[0, 0, 10]])[0].tolist()
    (1, [5.5, 1.0, 0.0])
    """

    def __init__(self, *models):
        models = _check_models(models, "models")
        sizes = {m.n_env for m in models}
        if len(sizes) != 1:
            raise ValueError(f"models must describe the same environments (one n_env), got "
                             f"n_env {[m.n_env for m in models]}; WindGroups puts models "
                             f"side by side")
        leaves, counts = {}, {}  # id(model) -> model, count: flat, built without recursion
        for m in models:
            if isinstance(m, SumWind):
                if not counts:  # the common w = w + x: copy the left sum's terms at C speed
                    leaves, counts = dict(m._leaves), dict(m._counts)
                    continue
                pairs = m.terms
            else:
                pairs = ((m, 1),)
            for leaf, k in pairs:
                leaves[id(leaf)] = leaf
                counts[id(leaf)] = counts.get(id(leaf), 0) + k
        self._set_terms(leaves, counts)

    def _set_terms(self, leaves, counts):
        worst = max(counts.values())
        if worst > MAX_TERM_COUNT:
            raise ValueError(f"models must add one model at most 2^53 times, got {worst}")
        self._leaves, self._counts = leaves, counts
        self.n_env = next(iter(leaves.values())).n_env

    @property
    def terms(self) -> tuple:
        """``(model, count)`` of each distinct model, in the order first met."""
        terms = self.__dict__.get("_terms")
        if terms is None:
            terms = self._terms = tuple((m, self._counts[i]) for i, m in self._leaves.items())
        return terms

    @property
    def models(self) -> tuple:
        """The distinct models of :attr:`terms`."""
        return tuple(self._leaves.values())

    def _velocity(self, t, positions):
        out = np.zeros((self.n_env, 3))
        for m, k in self.terms:
            v = m._velocity(t, positions)
            out += v if k == 1 else float(k) * v
        return out

    @property
    def position_free(self):
        return all(m.position_free for m in self.models)

    def _velocities(self, times):
        out = np.zeros((len(times), self.n_env, 3))
        for m, k in self.terms:
            v = m._velocities(times)
            out += v if k == 1 else float(k) * v
        return out

    def with_seed(self, seed: int | np.random.SeedSequence | None) -> SumWind:
        """This sum with each distinct model reseeded from its own child of ``seed``."""
        kids = _child_seeds(seed, len(self.terms))
        new = [(m.with_seed(c), k) for (m, k), c in zip(self.terms, kids)]
        if all(a is m for (a, _), (m, _) in zip(new, self.terms)):
            return self
        out = object.__new__(SumWind)
        counts = {}
        for m, k in new:  # two models reseeded into one object stay one term
            counts[id(m)] = counts.get(id(m), 0) + k
        out._set_terms({id(m): m for m, _ in new}, counts)
        return out

    def __repr__(self):
        return "SumWind(" + ", ".join(repr(m) if k == 1 else f"{k} * {m!r}"
                                      for m, k in self.terms) + ")"


class RampedWind(WindModel):
    """``model``'s wind times a smooth ramp from 0 at t = 0 to 1 at ``ramp`` [s] (the
    smoothstep ``3 u^2 - 2 u^3``, ``u = t / ramp``): a vehicle that starts hovering in still
    air meets the wind gradually instead of as a step.

    Parameters
    ----------
    model : WindModel
    ramp : float
        [s], in (0, 1e6].

    Examples
    --------
    >>> w = RampedWind(ConstantWind([[4.0, 0, 0]]), ramp=2.0)
    >>> [float(w.velocity(t, [[0, 0, 1]])[0, 0]) for t in (0.0, 1.0, 2.0, 5.0)]
    [0.0, 2.0, 4.0, 4.0]
    """

    def __init__(self, model, ramp):
        if not isinstance(model, WindModel):
            raise TypeError(f"model must be a WindModel, got {type(model).__name__}")
        self.model = model
        self.ramp = check_scalar(ramp, "ramp", low=0.0, low_inclusive=False, high=1e6)
        self.n_env = model.n_env

    def _velocity(self, t, positions):
        u = min(t / self.ramp, 1.0)
        return self.model._velocity(t, positions) * (u * u * (3.0 - 2.0 * u))

    @property
    def position_free(self):
        return self.model.position_free

    def _velocities(self, times):
        u = np.minimum(np.asarray(times, dtype=float) / self.ramp, 1.0)
        return self.model._velocities(times) * (u * u * (3.0 - 2.0 * u))[:, None, None]

    def with_seed(self, seed: int | np.random.SeedSequence | None) -> RampedWind:
        """This ramp over its model reseeded with ``seed`` (the same gusts as
        ``model.with_seed(seed)``, faded in)."""
        model = self.model.with_seed(seed)
        return self if model is self.model else RampedWind(model, self.ramp)

    def __repr__(self):
        return f"RampedWind({self.model!r}, ramp={self.ramp:g})"


# --------------------------------------------------------------------------- #
# several models side by side
# --------------------------------------------------------------------------- #
class WindGroups(WindModel):
    """Several wind models side by side, one group of environments each (old name
    :class:`CombinedWind`, kept working).

    Environments are numbered model by model: the first ``models[0].n_env``
    belong to group 0, the next to group 1, and so on. This never adds winds: gusts on a
    mean wind are a :class:`SumWind` (``mean + gusts``).

    Parameters
    ----------
    *models : WindModel
        The groups, in order.

    Examples
    --------
    >>> w = WindGroups(ConstantWind([[1, 1, 0]] * 2), ShearWind([[10, 10, 0]] * 3))
    >>> w.n_env, w.groups.tolist()
    (5, [0, 0, 1, 1, 1])
    """

    def __init__(self, *models):
        models = _check_models(models, "models")
        self.models = models
        sizes = [m.n_env for m in models]
        self.n_env = int(sum(sizes))
        self._bounds = np.concatenate([[0], np.cumsum(sizes)])
        self.groups = np.repeat(np.arange(len(models)), sizes)

    def _velocity(self, t, positions):
        out = np.empty((self.n_env, 3))
        b = self._bounds
        for i, m in enumerate(self.models):
            out[b[i]:b[i + 1]] = m._velocity(t, positions[b[i]:b[i + 1]])
        return out

    def with_seed(self, seed: int | np.random.SeedSequence | None) -> WindGroups:
        """These groups, group ``i`` reseeded from child ``i`` of ``seed`` (as
        :meth:`uavwind.sim.setting.Setting.wind` seeds its two groups)."""
        new = [m.with_seed(c) for m, c in zip(self.models, _child_seeds(seed, len(self.models)))]
        return self if all(a is m for a, m in zip(new, self.models)) else WindGroups(*new)

    def __repr__(self):
        return "WindGroups(" + ", ".join(map(repr, self.models)) + ")"


#: The old name of :class:`WindGroups` (groups side by side, never a sum).
CombinedWind = WindGroups
