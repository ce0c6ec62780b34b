"""The Dryden implementation the paper cites (Abichandani et al.), quirk by quirk.

This module owns the turbulence of :class:`uavwind.sim.dryden.DrydenWind`'s ``"cited"``
variant: :class:`CitedDryden`, each way the published code differs from MIL-F-8785C as a
field (so every reading of it is one argument away), its intensities and scale lengths in
its own units (:func:`cited_dryden_parameters`), its three filters
(:func:`cited_transfer_functions`, the same gains as MIL-F-8785C's,
:func:`~uavwind.sim.mil_dryden.dryden_gain`), the gust series it simulates with
``control.forced_response`` as its ``scipy.signal.lsim`` call does (:func:`cited_gusts`,
cached per parameter set) and their look-up on its own time grid.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ..core.checks import Range, check_fields, check_scalar
from .mil_dryden import dryden_gain

if TYPE_CHECKING:
    from control import TransferFunction

#: [ft] per metre as the cited code converts (``* 3.28084``).
FEET_PER_METRE = 3.28084


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
            check_fields(self, {"turbulence_level": Range(0, 1e3, low_inclusive=False)})
        check_scalar(self.length_constant, "length_constant", low=0, low_inclusive=False)
        check_scalar(self.length_exponent, "length_exponent", low=0)
        check_scalar(self.noise_scale, "noise_scale", low=0)
        check_scalar(self.grid_duration, "grid_duration", low=0, low_inclusive=False)
        check_fields(self, {"grid_samples": Range(2, 10 ** 7, integer=True)})
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

    def at_times(self, times):
        """:meth:`at` of each of ``times`` (m,) [s], shape (m, n_env, 3)."""
        o = self.options
        k = (times * o.rate + 1e-9).astype(np.int64) % o.grid_samples
        return self._mean + self._series[:, k].transpose(1, 0, 2)

    def first(self, n_samples, dt):
        return np.stack([self.at(k * dt) for k in range(n_samples)], axis=1)
