"""The Dryden filters and MIL-F-8785C's low-altitude turbulence (paper eqs 10-12).

This module owns the standard model behind :class:`uavwind.sim.dryden.DrydenWind`'s default
variant (replication notes, decision 4): the gain of the three Dryden shaping filters,
written once for both models (:func:`dryden_gain`), MIL-F-8785C's intensities and scale
lengths (:func:`dryden_parameters`, feet inside and m/s outside), its filters as
``control.TransferFunction`` (:func:`dryden_transfer_functions`) and analytic spectrum
(:func:`dryden_psd`), their zero-order-hold discretisation with ``control.sample_system``
(cached per parameter set), and :class:`MilDryden`, whose gust source draws each
environment's white noise and starts every filter in its stationary state.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, ClassVar

import numpy as np

if TYPE_CHECKING:
    from control import TransferFunction
    from numpy.typing import ArrayLike

FEET = 0.3048  # [m] per foot


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

    def at_times(self, times):
        """:meth:`at` of each of ``times`` (m,) [s], shape (m, n_env, 3)."""
        k = np.floor(times / self.dt + 1e-9).astype(np.int64)
        if k.size and k.max() >= self._history.shape[1]:
            self._extend(int(k.max()) + 1)
        return self._history[:, k].transpose(1, 0, 2)
