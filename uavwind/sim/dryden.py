"""Dryden turbulence behind the wind contract (paper eqs 10-12): two models, one wind.

This module owns the turbulence of :mod:`uavwind.sim.wind`'s contract:

* :class:`MilDryden` -- MIL-F-8785C low altitude, feet inside and m/s outside
  (replication notes, decision 4), with :func:`dryden_parameters`,
  :func:`dryden_transfer_functions` and the analytic spectrum :func:`dryden_psd`;
* :class:`CitedDryden` -- the implementation the paper cites (Abichandani et al.), quirk by
  quirk, with :func:`cited_dryden_parameters`, :func:`cited_transfer_functions` and
  :func:`cited_gusts`;
* :class:`DrydenWind` -- either model as a :class:`~uavwind.sim.wind.WindModel`.

Both models shape noise with the same three Dryden filters, whose gains are
:func:`dryden_gain` (written once), built with ``control.tf``. The MIL-F-8785C filters are
discretised with ``control.sample_system(..., "zoh")`` (cached per parameter set; the
closed-form zero-order hold is the tests' oracle); the cited series are simulated with
``control.forced_response``, as the cited code's ``scipy.signal.lsim`` does.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from functools import cached_property, lru_cache
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from .wind import WindModel

if TYPE_CHECKING:
    from control import TransferFunction
    from numpy.typing import ArrayLike

FEET = 0.3048  # [m] per foot
#: [ft] per metre as the cited code converts (``* 3.28084``).
FEET_PER_METRE = 3.28084
#: Dryden variants: the standard, and the implementation the paper cites.
VARIANTS = ("mil-f-8785c", "cited")
#: Largest W20 or airspeed accepted [m/s] (beyond any wind on Earth; keeps the filters finite).
W20_MAX = 1000.0
#: Smallest W20 accepted [m/s] (below it the filters' time constants overflow).
W20_MIN = 1e-3

__all__ = ["FEET", "VARIANTS", "MilDryden", "CitedDryden", "DrydenWind", "dryden_gain",
           "dryden_parameters", "dryden_transfer_functions", "dryden_psd",
           "cited_dryden_parameters", "cited_transfer_functions", "cited_gusts"]


def dryden_gain(sigma: float, L: float, V: float, axis: str) -> float:
    """Gain of the Dryden filter of ``axis`` from unit white noise: ``sigma sqrt(2 L/(pi V))``
    for ``"u"`` (first order), ``sigma sqrt(L/(pi V))`` for ``"v"`` and ``"w"`` (second
    order); ``sigma`` [speed], ``L`` [length] and ``V`` [speed] in any one unit system.

    >>> round(dryden_gain(2.0, 60.0, 12.0, "u"), 6)
    3.568248
    """
    if axis == "u":
        return sigma * math.sqrt(2 * L / (math.pi * V))
    if axis in ("v", "w"):
        return sigma * math.sqrt(L / (math.pi * V))
    raise ValueError(f"axis must be 'u', 'v' or 'w', got {axis!r}")


# --------------------------------------------------------------------------- #
# MIL-F-8785C
# --------------------------------------------------------------------------- #
def dryden_parameters(w20: ArrayLike, altitude: float) -> dict[str, np.ndarray | float]:
    """MIL-F-8785C low-altitude turbulence intensities and scale lengths.

    Parameters
    ----------
    w20 : float or array_like
        Wind speed at 20 ft (6.1 m) [m/s], > 0.
    altitude : float
        Height above ground [m]; clamped to [10, 1000] ft inside.

    Returns
    -------
    dict
        ``sigma_u, sigma_v, sigma_w`` [m/s] (same shape as ``w20``) and
        ``L_u, L_v, L_w`` [m] (scalars), with::

            sigma_w = 0.1 W20
            sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4
            L_w = h,   L_u = L_v = h / (0.177 + 0.000823 h)^1.2      (h in ft)
    """
    w20 = np.asarray(w20, dtype=float)
    h = min(max(float(altitude) / FEET, 10.0), 1000.0)  # [ft]
    base = 0.177 + 0.000823 * h
    sigma_w = 0.1 * w20
    sigma_u = sigma_w / base ** 0.4
    L_w = h * FEET
    L_u = h / base ** 1.2 * FEET
    return {"sigma_u": sigma_u, "sigma_v": sigma_u.copy(), "sigma_w": sigma_w,
            "L_u": L_u, "L_v": L_u, "L_w": L_w}


def dryden_transfer_functions(sigma_u: float, sigma_v: float, sigma_w: float, L_u: float,
                              L_v: float, L_w: float, airspeed: float,
                              ) -> tuple[TransferFunction, TransferFunction, TransferFunction]:
    """The three Dryden shaping filters as ``control.TransferFunction`` (eqs 10-12).

    Parameters
    ----------
    sigma_u, sigma_v, sigma_w : float
        Turbulence intensities [m/s].
    L_u, L_v, L_w : float
        Scale lengths [m].
    airspeed : float
        Airspeed V [m/s], > 0.

    Returns
    -------
    tuple of control.TransferFunction
        ``(H_u, H_v, H_w)`` from unit white noise to gust velocity [m/s].
    """
    import control

    V = float(airspeed)
    Tu = L_u / V
    H_u = control.tf([dryden_gain(sigma_u, L_u, V, "u")], [Tu, 1.0])

    def second_order(sigma, L, axis):
        T = L / V
        K = dryden_gain(sigma, L, V, axis)
        return control.tf([K * math.sqrt(3) * T, K], [T * T, 2 * T, 1.0])

    return H_u, second_order(sigma_v, L_v, "v"), second_order(sigma_w, L_w, "w")


def dryden_psd(omega: ArrayLike, sigma: float, L: float, airspeed: float,
               axis: str) -> np.ndarray:
    """Analytic one-sided Dryden spectrum ``|H(j omega)|^2`` [(m/s)^2 / (rad/s)].

    ``axis`` is ``"u"`` (longitudinal, first order) or ``"v"``/``"w"``.
    Integrated over omega in [0, inf) it equals ``sigma**2``.
    """
    omega = np.asarray(omega, dtype=float)
    LV = L / airspeed
    if axis == "u":
        return sigma ** 2 * 2 * LV / math.pi / (1 + (LV * omega) ** 2)
    if axis in ("v", "w"):
        x2 = (LV * omega) ** 2
        return sigma ** 2 * LV / math.pi * (1 + 3 * x2) / (1 + x2) ** 2
    raise ValueError(f"axis must be 'u', 'v' or 'w', got {axis!r}")


def _canonical(num, den):
    """Controllable canonical realisation (as ``scipy.signal.tf2ss``) of strictly
    proper ``num/den`` (``den[:, 0] = 1``), vectorised: ``A (n,k,k), B (n,k), C (n,k)``.

    One realisation for every discretisation path, so the stationary initial
    state drawn from the same random numbers is the same whatever built the filter.
    """
    n, k = den.shape[0], den.shape[1] - 1
    A = np.zeros((n, k, k))
    A[:, 0, :] = -den[:, 1:]
    if k > 1:
        A[:, np.arange(1, k), np.arange(k - 1)] = 1.0
    B = np.zeros((n, k))
    B[:, 0] = 1.0
    C = np.zeros((n, k))
    C[:, k - num.shape[1]:] = num
    return A, B, C


def _stationary_covariance(A, B, q):
    """Solve ``P = A P A^T + q B B^T`` for each system of the batch (shape (n, k, k))."""
    n, k, _ = A.shape
    eye = np.eye(k * k)
    kron = np.einsum("nij,nkl->nikjl", A, A).reshape(n, k * k, k * k)
    Q = (q * np.einsum("ni,nj->nij", B, B)).reshape(n, k * k, 1)
    P = np.linalg.solve(eye[None] - kron, Q).reshape(n, k, k)
    return 0.5 * (P + P.transpose(0, 2, 1))


@lru_cache(maxsize=4096)
def _zoh_filters(sigma_u, sigma_v, sigma_w, L_u, L_v, L_w, airspeed, dt):
    """ZOH filters ``((num, den) for u, v, w)`` built with ``control.tf`` and
    ``control.sample_system``, normalised (``den[0] = 1``); cached per parameter set."""
    import control

    out = []
    for H in dryden_transfer_functions(sigma_u, sigma_v, sigma_w, L_u, L_v, L_w, airspeed):
        Hd = control.sample_system(H, dt, "zoh")
        num, den = np.ravel(Hd.num[0][0]), np.ravel(Hd.den[0][0])
        num, den = num / den[0], den / den[0]
        k = len(den) - 1
        num = np.concatenate([np.zeros(k - len(num)), num])[-k:]
        num.setflags(write=False)
        den.setflags(write=False)
        out.append((num, den))
    return tuple(out)


@dataclass(frozen=True)
class MilDryden:
    """MIL-F-8785C low-altitude turbulence (replication notes, decision 4), the default model.

    Each axis is white noise of standard deviation ``sqrt(pi/dt)`` shaped by the Dryden
    filter of eqs 10-12 (x = longitudinal u, y = lateral v, z = vertical w) with the
    intensities and scale lengths of :func:`dryden_parameters`, discretised with a
    zero-order hold at ``dt``; every filter starts in a state drawn from its stationary
    distribution, so the gusts are stationary from t = 0 and have variance sigma^2.
    """

    name: ClassVar[str] = "mil-f-8785c"

    def gusts(self, w20: np.ndarray, altitude: float, airspeed: np.ndarray, dt: float,
              children: Sequence[np.random.SeedSequence]) -> "_FilteredGusts":
        """The gust source of ``len(w20)`` environments (see :class:`DrydenWind`)."""
        return _FilteredGusts(w20, altitude, airspeed, dt, children)


class _FilteredGusts:
    """MIL-F-8785C gusts of ``n_env`` environments, generated lazily in blocks, always the
    same numbers for the same seeds (environment ``i`` draws from ``children[i]``)."""

    _BLOCK = 128  # samples generated per extension

    def __init__(self, w20, altitude, airspeed, dt, children):
        self.n_env = w20.shape[0]
        self.airspeed, self.dt = airspeed, dt
        p = dryden_parameters(w20, altitude)
        self.parameters = {k: np.broadcast_to(v, (self.n_env,)).copy() for k, v in p.items()}
        self.sigmas = np.stack([p["sigma_u"], p["sigma_v"], p["sigma_w"]], axis=1)
        self.noise_std = math.sqrt(math.pi / dt)
        tfs = self._control_filters(p)
        self.transfer_functions = tfs  # axis -> (num (n, k), den (n, k+1)), discrete, in z
        self.filters = {ax: _canonical(num, den) for ax, (num, den) in tfs.items()}
        self._rngs = [np.random.Generator(np.random.PCG64(c)) for c in children]
        self._init_states()
        self._history = np.empty((self.n_env, 0, 3))

    def _control_filters(self, p):
        out = {ax: ([], []) for ax in "uvw"}
        for i in range(self.n_env):
            filters = _zoh_filters(float(p["sigma_u"][i]), float(p["sigma_v"][i]),
                                   float(p["sigma_w"][i]), float(p["L_u"]), float(p["L_v"]),
                                   float(p["L_w"]), float(self.airspeed[i]), self.dt)
            for ax, (num, den) in zip("uvw", filters):
                out[ax][0].append(num)
                out[ax][1].append(den)
        return {ax: (np.array(nums), np.array(dens)) for ax, (nums, dens) in out.items()}

    def _init_states(self):
        q = self.noise_std ** 2
        z = np.array([rng.standard_normal(5) for rng in self._rngs])  # (n_env, 5)
        self._states = {}
        col = 0
        for ax in "uvw":
            A, B, _ = self.filters[ax]
            k = A.shape[1]
            P = _stationary_covariance(A, B, q)
            L = np.linalg.cholesky(P + 1e-300 * np.eye(k))
            self._states[ax] = np.einsum("nij,nj->ni", L, z[:, col:col + k])
            col += k

    def _extend(self, n_needed):
        """Generate gust samples until the history holds ``n_needed`` of them."""
        blocks = []
        have = self._history.shape[1]
        while have < n_needed:
            m = self._BLOCK
            w = self.noise_std * np.array([rng.standard_normal((m, 3)) for rng in self._rngs])
            out = np.empty((self.n_env, m, 3))
            for j, ax in enumerate("uvw"):
                A, B, C = self.filters[ax]
                x = self._states[ax]
                for k in range(m):
                    out[:, k, j] = np.einsum("ni,ni->n", C, x)
                    x = np.einsum("nij,nj->ni", A, x) + B * w[:, k, j:j + 1]
                self._states[ax] = x
            blocks.append(out)
            have += m
        if blocks:
            self._history = np.concatenate([self._history, *blocks], axis=1)

    def first(self, n_samples):
        self._extend(n_samples)
        return self._history[:, :n_samples]

    def at(self, t):
        """The sample of the step containing ``t`` (sample and hold)."""
        k = int(math.floor(t / self.dt + 1e-9))
        if k >= self._history.shape[1]:
            self._extend(k + 1)
        return self._history[:, k]


# --------------------------------------------------------------------------- #
# the cited implementation (Abichandani et al.)
# --------------------------------------------------------------------------- #
@dataclass(frozen=True)
class CitedDryden:
    """How the Dryden implementation the paper cites computes gusts, quirk by quirk.

    The paper uses "the implementation of Abichandani et al." (public code:
    radlab-sketch/drydenModelPython, ``dryden_python_implementation.py``). It
    differs from MIL-F-8785C (:func:`dryden_parameters`) in the ways below; each
    is a field, so every reading of it is one argument away. The defaults are the
    code as published; ``turbulence_level=None`` and ``seeds=None`` give the
    packaged derivative (a ``Wind_Model`` class that takes the level as a parameter
    and draws a seed per call), and ``base_direction`` adds its ``base_wind_vec``.

    Attributes
    ----------
    turbulence_level : float or None
        W20 put into ``sigma_w = 0.1 W20`` *without unit conversion*, while the
        filters work in feet and ft/s (the code: ``turbulence_level = 15``, its
        knots-to-m/s line commented out). ``None``: each environment's ``w20``
        [m/s] as the number, as the derivative's ``turbulence`` parameter.
    length_constant, length_exponent : float
        ``L_u = L_v = h / (0.177 + length_constant h) ** length_exponent`` [ft]
        (the code: 0.000823 and 0.2; an older version has 0.00823; MIL-F-8785C: 1.2).
    noise_scale : float
        The white noise is ``noise_scale * N(0, 1)`` per sample, not scaled by the
        sample time (the code: 10).
    seeds : tuple of 3 ints or None
        Seeds of the u, v, w noise (the code: 23341, 23342, 23343, "same as the
        Simulink blockset"), so every call gets the same gusts, and so does every
        environment of equal airspeed (the airspeed defaults to each environment's W20,
        which makes the filters, and so the gusts, differ between environments). ``None``: one seed ``s`` per environment drawn from the wind's
        seed, and ``s, s+1, s+2`` for u, v, w (the derivative).
    grid_duration : float
        Length of the simulated gust series [s] (the code: ``linspace(0, 5, 1000)``).
    grid_samples : int
        Samples of that series (1000). Flights longer than ``grid_duration``
        repeat it: the sample at time ``t`` is ``int(t * rate) % grid_samples`` with
        ``rate = grid_samples / grid_duration``, as the derivative's ``get_wind_vector``.
    output_scale : float
        Factor from the filters' output to m/s (the code: 0.305, ft/s to m/s).
    base_direction : tuple of 3 floats or None
        ``None``: zero-mean gusts. A direction: add a mean wind of ``w20`` [m/s]
        along it (the derivative's ``base_wind_vec``), so a "strong turbulence"
        environment is a strong wind with gusts on top.
    """

    turbulence_level: float | None = 15.0
    length_constant: float = 0.000823
    length_exponent: float = 0.2
    noise_scale: float = 10.0
    seeds: tuple | None = (23341, 23342, 23343)
    grid_duration: float = 5.0
    grid_samples: int = 1000
    output_scale: float = 0.305
    base_direction: tuple | None = None

    def __post_init__(self):
        if self.turbulence_level is not None:
            object.__setattr__(self, "turbulence_level", check_scalar(
                self.turbulence_level, "turbulence_level", low=0, low_inclusive=False,
                high=1e3))
        check_scalar(self.length_constant, "length_constant", low=0, low_inclusive=False)
        check_scalar(self.length_exponent, "length_exponent", low=0)
        check_scalar(self.noise_scale, "noise_scale", low=0)
        check_scalar(self.grid_duration, "grid_duration", low=0, low_inclusive=False)
        object.__setattr__(self, "grid_samples", check_scalar(
            self.grid_samples, "grid_samples", low=2, high=10 ** 7, integer=True))
        check_scalar(self.output_scale, "output_scale", low=0, low_inclusive=False)
        if self.seeds is not None:
            seeds = tuple(int(x) for x in self.seeds)
            if len(seeds) != 3 or any(not 0 <= x < 2 ** 32 - 2 for x in seeds):
                raise ValueError(f"seeds must be None or three ints in [0, 2**32 - 2), "
                                 f"got {self.seeds!r}")
            object.__setattr__(self, "seeds", seeds)
        if self.base_direction is not None:
            d = np.asarray(self.base_direction, dtype=float)
            if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.linalg.norm(d) > 0:
                raise ValueError(f"base_direction must be None or a non-zero 3-vector, "
                                 f"got {self.base_direction!r}")
            object.__setattr__(self, "base_direction", tuple(float(x) for x in d))

    @property
    def rate(self) -> float:
        """Index rate of the gust series [samples/s] (``grid_samples / grid_duration``)."""
        return self.grid_samples / self.grid_duration

    def to_dict(self) -> dict:
        return asdict(self)

    def gusts(self, w20: np.ndarray, altitude: float, airspeed: np.ndarray, dt: float,
              children: Sequence[np.random.SeedSequence]) -> "_CitedGusts":
        """The gust source of ``len(w20)`` environments (see :class:`DrydenWind`)."""
        return _CitedGusts(self, w20, altitude, airspeed, children)


def cited_dryden_parameters(level: float, altitude: float, airspeed: float,
                            options: CitedDryden | None = None) -> dict:
    """Intensities and scale lengths exactly as the cited code computes them.

    Parameters
    ----------
    level : float
        The turbulence level put into ``sigma_w = 0.1 * level`` (no unit conversion).
    altitude : float
        Height [m], converted to feet with ``* 3.28084`` (not clamped).
    airspeed : float
        Airspeed [m/s], converted to ft/s the same way.
    options : CitedDryden

    Returns
    -------
    dict
        ``sigma_u, sigma_v, sigma_w`` (in the code's units, multiplied by
        ``output_scale`` on output), ``L_u, L_v, L_w`` [ft], ``h`` [ft], ``V`` [ft/s].

    >>> p = cited_dryden_parameters(15.0, 10.0, 12.0)
    >>> round(p["sigma_w"], 3), round(p["L_w"], 2)
    (1.5, 32.81)
    """
    options = CitedDryden() if options is None else options
    h = float(altitude) * FEET_PER_METRE
    V = float(airspeed) * FEET_PER_METRE
    sigma_w = 0.1 * float(level)
    sigma_u = sigma_w / (0.177 + 0.000823 * h) ** 0.4
    L_u = h / (0.177 + options.length_constant * h) ** options.length_exponent
    return {"sigma_u": sigma_u, "sigma_v": sigma_u, "sigma_w": sigma_w,
            "L_u": L_u, "L_v": L_u, "L_w": h, "h": h, "V": V}


def cited_transfer_functions(level: float, altitude: float, airspeed: float,
                             options: CitedDryden | None = None,
                             ) -> tuple[TransferFunction, TransferFunction, TransferFunction]:
    """The cited code's three filters as ``control.TransferFunction`` (ft/s in and out).

    ``H_u = sigma_u sqrt(2 L_u/(pi V)) V / (L_u s + V)``;
    ``H_v = b (sqrt(3) (L_v/V) s + 1) / ((L_v/V)^2 s^2 + 2 (L_v/V) s + 1)`` with
    ``b = sigma_v sqrt(L_v/(pi V))``, and ``H_w`` likewise with ``L_w``.
    """
    import control

    p = cited_dryden_parameters(level, altitude, airspeed, options)
    V = p["V"]
    H_u = control.tf([dryden_gain(p["sigma_u"], p["L_u"], V, "u") * V], [p["L_u"], V])

    def second_order(sigma, L, axis):
        b = dryden_gain(sigma, L, V, axis)
        T = L / V
        return control.tf([math.sqrt(3) * T * b, b], [T * T, 2 * T, 1.0])

    return H_u, second_order(p["sigma_v"], p["L_v"], "v"), second_order(p["sigma_w"], p["L_w"], "w")


@lru_cache(maxsize=512)
def _cited_series(level, altitude, airspeed, options, seeds):
    import control

    t = np.linspace(0.0, options.grid_duration, options.grid_samples)
    out = np.empty((options.grid_samples, 3))
    for j, (H, seed) in enumerate(zip(cited_transfer_functions(level, altitude, airspeed,
                                                               options), seeds)):
        # RandomState(seed).normal == np.random.seed(seed); np.random.normal, without
        # touching the global generator
        noise = options.noise_scale * np.random.RandomState(seed).normal(
            0.0, 1.0, options.grid_samples)
        # linear interpolation between samples, zero initial state: scipy's lsim
        out[:, j] = control.forced_response(H, T=t, U=noise).outputs
    out *= options.output_scale
    out.setflags(write=False)
    return out


def cited_gusts(level: float, altitude: float, airspeed: float,
                options: CitedDryden | None = None,
                seeds: Sequence[int] | None = None) -> np.ndarray:
    """One gust series of the cited code, shape (grid_samples, 3) [m/s] (u, v, w).

    Built with ``control.tf`` and simulated with ``control.forced_response`` on the
    code's time grid (the same as its ``scipy.signal.lsim`` call, tested); cached
    per parameter set, so a loop that asks again pays nothing.
    """
    options = CitedDryden() if options is None else options
    seeds = options.seeds if seeds is None else tuple(int(s) for s in seeds)
    if seeds is None:
        raise ValueError("seeds must be given when options.seeds is None")
    return _cited_series(float(level), float(altitude), float(airspeed), options, seeds)


class _CitedGusts:
    """The cited code's gust series of ``n_env`` environments, looked up as its packaged
    derivative does (``int(t * rate) % grid_samples``), with its optional mean wind."""

    def __init__(self, options, w20, altitude, airspeed, children):
        o = self.options = options
        n_env = w20.shape[0]
        levels = w20 if o.turbulence_level is None else np.full(n_env, o.turbulence_level)
        if o.seeds is None:  # the derivative: one seed s per environment, s, s+1, s+2 per axis
            base = [int(c.generate_state(1)[0] % 10 ** 8) for c in children]
            seeds = [(b, b + 1, b + 2) for b in base]
        else:
            seeds = [o.seeds] * n_env
        self._series = np.stack([cited_gusts(lv, altitude, V, o, sd)
                                 for lv, V, sd in zip(levels, airspeed, seeds)])
        self._mean = (np.zeros((n_env, 3)) if o.base_direction is None else
                      w20[:, None] * (np.array(o.base_direction)
                                      / np.linalg.norm(o.base_direction)))
        rows = [cited_dryden_parameters(lv, altitude, V, o) for lv, V in zip(levels, airspeed)]
        self.parameters = {k: np.array([r[k] for r in rows]) for k in rows[0]}
        # the filters' nominal output; the noise fed to them is not unit-variance (notes)
        self.sigmas = np.stack([self.parameters[f"sigma_{ax}"] for ax in "uvw"],
                               axis=1) * o.output_scale

    def at(self, t):
        o = self.options
        return self._mean + self._series[:, int(t * o.rate + 1e-9) % o.grid_samples]

    def first(self, n_samples, dt):
        return np.stack([self.at(k * dt) for k in range(n_samples)], axis=1)


# --------------------------------------------------------------------------- #
# the wind
# --------------------------------------------------------------------------- #
class DrydenWind(WindModel):
    """Dryden turbulence, one gust history per environment.

    ``variant="mil-f-8785c"`` (default): :class:`MilDryden`. Intensities and scale lengths
    are frozen at ``altitude``; the gusts are zero-mean and do not depend on the UAV
    position. The gust at time ``t`` is the sample of the step containing ``t`` (sample
    and hold); the history is generated lazily and extended as needed, always drawing the
    same numbers for the same seed.

    ``variant="cited"``: the implementation the paper cites, as it computes the gusts
    (:class:`CitedDryden` for each of its quirks, and :func:`cited_gusts`).

    Parameters
    ----------
    w20 : array_like, shape (n_env,)
        Wind speed at 20 ft of each environment [m/s], in [0.001, 1000].
    altitude : float
        Height at which the turbulence parameters are evaluated [m], > 0.
        Default 10 m (the start altitude).
    airspeed : array_like, shape (n_env,) or float, optional
        Airspeed V used by the filters [m/s], in [0.001, 1000]. Default: ``w20``.
    dt : float
        Sample time of the gust history [s], in [1e-4, 10]. Default 0.1 s
        (``"mil-f-8785c"`` only; the cited variant keeps its own grid).
    seed : int, numpy.random.SeedSequence or None
        Root of the randomness; environment ``i`` draws from the ``i``-th child
        of ``SeedSequence(seed)``, so adding environments never changes the
        gusts of the existing ones. The cited variant with fixed ``seeds`` ignores it.
    variant : {"mil-f-8785c", "cited"}
    cited : CitedDryden, optional
        The cited variant's options (default: the code as published).

    Attributes
    ----------
    model : MilDryden or CitedDryden
        The model the gusts come from.
    parameters : dict of ndarray, shape (n_env,)
        The model's intensities and scale lengths per environment: ``sigma_u``,
        ``sigma_v``, ``sigma_w``, ``L_u``, ``L_v``, ``L_w`` [m/s, m] (the cited model: in
        its own units, ft/s and ft, with ``h`` [ft] and ``V`` [ft/s] too).
    sigmas : ndarray, shape (n_env, 3)
        Filter intensities [m/s] (u, v, w): MIL-F-8785C, or for the cited variant its
        sigmas times ``output_scale`` (its filters' nominal output).

    Examples
    --------
    >>> w = DrydenWind([12.0, 13.0], seed=1)
    >>> w.velocity(0.0, [[0, 0, 10], [0, 0, 10]]).shape
    (2, 3)
    >>> c = DrydenWind([12.0, 13.0], airspeed=12.0, variant="cited")
    >>> bool((c.gusts(120)[0] == c.gusts(120)[1]).all())  # fixed level and seeds: same gusts
    True
    """

    def __init__(self, w20, altitude=10.0, airspeed=None, dt=0.1, seed=None,
                 variant="mil-f-8785c", cited=None):
        w20 = check_array(w20, "w20", ndim=1)
        if w20.size == 0:
            raise ValueError("w20 must describe at least one environment, got an empty array")
        if np.any(w20 < W20_MIN) or np.any(w20 > W20_MAX):
            raise ValueError(f"w20 must be in [{W20_MIN:g}, {W20_MAX:g}] m/s for every "
                             f"environment, got min {w20.min():g}, max {w20.max():g}")
        check_choice(variant, "variant", VARIANTS)
        if cited is not None:
            check_instance(cited, "cited", CitedDryden)
        self.variant = variant
        self.model = MilDryden() if variant == "mil-f-8785c" else (cited or CitedDryden())
        self.cited = self.model if variant == "cited" else None
        self.w20 = w20
        self.n_env = w20.shape[0]
        self.altitude = check_scalar(altitude, "altitude", low=0, low_inclusive=False)
        if airspeed is None:
            V = w20.copy()
        else:
            V = check_array(airspeed, "airspeed")
            if V.ndim == 0:
                V = np.full(self.n_env, float(V))
            if V.shape != (self.n_env,):
                raise ValueError(f"airspeed must be a scalar or have shape ({self.n_env},), "
                                 f"got {np.shape(airspeed)}")
            if np.any(V < W20_MIN) or np.any(V > W20_MAX):
                raise ValueError(f"airspeed must be in [{W20_MIN:g}, {W20_MAX:g}] m/s, "
                                 f"got min {V.min():g}, max {V.max():g}")
        self.airspeed = V
        self.dt = check_scalar(dt, "dt", low=1e-4, high=10.0)
        if seed is not None and not isinstance(seed, (int, np.integer, np.random.SeedSequence)):
            raise TypeError(f"seed must be an int, a numpy.random.SeedSequence or None, "
                            f"got {type(seed).__name__}")
        self.seed = seed
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        self._gusts = self.model.gusts(w20, self.altitude, V, self.dt, ss.spawn(self.n_env))

    @property
    def parameters(self) -> dict:
        return self._gusts.parameters

    @cached_property
    def sigmas(self) -> np.ndarray:
        return self._gusts.sigmas

    @property
    def filters(self) -> dict:
        """MIL-F-8785C: axis -> ``(A (n,k,k), B (n,k), C (n,k))``, the discrete filters."""
        return self._mil("filters")

    @property
    def transfer_functions(self) -> dict:
        """MIL-F-8785C: axis -> ``(num (n, k), den (n, k+1))``, discrete, in z."""
        return self._mil("transfer_functions")

    def _mil(self, name):
        if self.variant != "mil-f-8785c":
            raise AttributeError(f"{name} belong to the 'mil-f-8785c' variant; this wind is "
                                 f"{self.variant!r}")
        return getattr(self._gusts, name)

    def gusts(self, n_samples: int) -> np.ndarray:
        """The first ``n_samples`` gust samples, shape (n_env, n_samples, 3) [m/s]
        (for the cited variant: its mean wind included, at times ``k * dt``)."""
        n_samples = check_scalar(n_samples, "n_samples", low=0, high=10 ** 8, integer=True)
        if self.variant == "cited":
            return self._gusts.first(n_samples, self.dt)
        return self._gusts.first(n_samples)

    def _velocity(self, t, positions):
        return self._gusts.at(t)

    def __repr__(self):
        return (f"DrydenWind(n_env={self.n_env}, variant={self.variant!r}, "
                f"altitude={self.altitude}, dt={self.dt}, seed={self.seed!r})")
