"""Dryden turbulence behind the wind contract (paper eqs 10-12): two models, one wind.

This module owns :class:`DrydenWind`, the turbulence of :mod:`uavwind.sim.wind`'s contract,
whose gusts come from one of two models (:data:`VARIANTS`):

* :class:`MilDryden` -- MIL-F-8785C low altitude, feet inside and m/s outside
  (replication notes, decision 4), with :func:`dryden_parameters`,
  :func:`dryden_transfer_functions` and the analytic spectrum :func:`dryden_psd`
  (:mod:`uavwind.sim.mil_dryden`);
* :class:`CitedDryden` -- the implementation the paper cites (Abichandani et al.), quirk by
  quirk, with :func:`cited_dryden_parameters`, :func:`cited_transfer_functions` and
  :func:`cited_gusts` (:mod:`uavwind.sim.cited_dryden`).

Both models shape noise with the same three Dryden filters, whose gains are
:func:`dryden_gain` (written once), built with ``control.tf``. The MIL-F-8785C filters are
discretised with ``control.sample_system(..., "zoh")`` (cached per parameter set; the
closed-form zero-order hold is the tests' oracle); the cited series are simulated with
``control.forced_response``, as the cited code's ``scipy.signal.lsim`` does. The names of
the two models are imported from their own modules.
"""

from __future__ import annotations

import copy
from functools import cached_property

import numpy as np

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from .cited_dryden import CitedDryden
from .mil_dryden import MilDryden
from .wind import WindModel

#: Dryden variants: the standard, and the implementation the paper cites.
VARIANTS = ("mil-f-8785c", "cited")
#: Largest W20 or airspeed accepted [m/s] (beyond any wind on Earth; keeps the filters finite).
W20_MAX = 1000.0
#: Smallest W20 accepted [m/s] (below it the filters' time constants overflow).
W20_MIN = 1e-3

__all__ = ["VARIANTS", "DrydenWind"]


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
        self._draw(seed)

    def _draw(self, seed):
        """Draw this wind's gusts from ``seed`` (an int, a SeedSequence or None)."""
        if seed is not None and not isinstance(seed, (int, np.integer, np.random.SeedSequence)):
            raise TypeError(f"seed must be an int, a numpy.random.SeedSequence or None, "
                            f"got {type(seed).__name__}")
        self.seed = seed
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        self._gusts = self.model.gusts(self.w20, self.altitude, self.airspeed, self.dt,
                                       ss.spawn(self.n_env))
        self.__dict__.pop("sigmas", None)  # cached from the gusts it replaces

    def with_seed(self, seed: int | np.random.SeedSequence | None) -> DrydenWind:
        """The same turbulence (its levels, altitude, airspeed, step and variant, checked
        when this one was made) with gusts drawn from ``seed``: what
        ``DrydenWind(..., seed=seed)`` gives, without checking the rest again."""
        out = copy.copy(self)
        out._draw(seed)
        return out

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

    position_free = True  # the gusts at the altitude the wind was made for

    def _velocity(self, t, positions):
        return self._gusts.at(t)

    def _velocities(self, times):
        return self._gusts.at_times(np.asarray(times, dtype=float))

    def __repr__(self):
        return (f"DrydenWind(n_env={self.n_env}, variant={self.variant!r}, "
                f"altitude={self.altitude}, dt={self.dt}, seed={self.seed!r})")
