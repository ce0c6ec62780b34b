"""The wind estimator's force model and its numerical kernels.

This module owns :class:`DragModel` (the fitted force model of
:mod:`uavwind.method.wind_estimator`'s text: offset, rotor-drag gain, the jet's profile and
parasitic drag, its in-plane equation, its measurement form and its inversion), what the
estimator reads of a flight (:func:`signals`, kept per flight while its columns are the same
read-only arrays; :func:`lowpass`, :func:`flight_dt`) and the fits and filters
:class:`~uavwind.method.wind_estimator.WindEstimator` runs on them: the least-squares
normal equations (:func:`normal_equations`, :func:`fit_model`), the variance curves
(:func:`variance_curve`), the block Kalman filter (:func:`block_starts`, :func:`kalman`)
and the flight's own offset read off its body z force (:data:`Z_POWERS`,
:func:`z_features`, :func:`z_terms`, :func:`fit_tilt`, :func:`tilted`). Each takes arrays and
returns arrays; checking the input and choosing among them is the estimator's (as
scikit-learn's k-means estimator beside its kernels).
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

__all__ = ["DragModel", "JET_RANGE", "Z_POWERS", "flight_dt", "lowpass", "signals",
           "normal_equations", "fit_model", "variance_curve", "block_starts", "kalman",
           "z_features", "z_terms", "fit_tilt", "tilted"]

#: The jet's speed profile is clipped to this range (a flight far off the path).
JET_RANGE = (0.5, 2.0)


def flight_dt(flight):
    return float(np.median(np.diff(flight.arrays["t"])))


def lowpass(x, dt, cutoff):
    """2nd-order Butterworth low-pass at ``cutoff`` [Hz], causal, started at the first
    value (what an on-board filter could do)."""
    from scipy import signal  # imported when used: `import uavwind` stays cheap

    b, a, zi = _butter_ba(float(cutoff), float(dt))
    return signal.lfilter(b, a, x, axis=0, zi=zi.reshape((-1,) + (1,) * (x.ndim - 1)) * x[0])[0]


@functools.lru_cache(maxsize=64)
def _butter_ba(cutoff, dt):
    """:func:`lowpass`'s filter ``(b, a, zi)`` (read-only), designed once per ``(cutoff [Hz],
    dt [s])``: the estimator low-passes every flight at one or two rates, hundreds of times
    in a leave-one-out."""
    from scipy import signal

    b, a = signal.butter(2, cutoff, fs=1.0 / dt)
    zi = signal.lfilter_zi(b, a)
    for arr in (b, a, zi):
        arr.flags.writeable = False
    return b, a, zi


#: :func:`signals` of each flight still alive, by cutoff, with the arrays they were read
#: from: a leave-one-out fits the same training flights many times (Exp 13 read them 3,510
#: times for 25 flights)
_SIGNALS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: The columns :func:`signals` reads.
_SIGNAL_SOURCES = ("t", "R", "fa", "T_sp", "hover_throttle", "p", "p_d", "v")


def signals(flight, cutoff):
    """What the model reads of a flight, low-passed at ``cutoff`` [Hz] (None: raw): the
    body-frame force over the thrust ``f`` (n, 2) [N], the body-frame ground velocity ``vb``
    (n, 3), the thrust in hovers ``tau`` (n,), ``RT`` (n, 3, 3) world -> body, ``dp`` (n, 3)
    [m] the offset from the path's centre and ``fz`` (n,) the body z force over the thrust.

    Kept per flight and cutoff (read-only arrays in a read-only mapping) when every column it
    reads is a read-only array, as a flight read from its files has; given again only while
    the flight holds those same arrays. A flight with a writable column is read each time."""
    src = tuple(flight.arrays[k] for k in _SIGNAL_SOURCES)
    if not all(isinstance(a, np.ndarray) and not a.flags.writeable for a in src):
        return _computed_signals(flight, cutoff)
    kept = _SIGNALS.setdefault(flight, {})
    key = None if cutoff is None else float(cutoff)
    hit = kept.get(key)
    if hit is not None and all(a is b for a, b in zip(hit[0], src)):
        return hit[1]
    sig = _computed_signals(flight, cutoff)
    for arr in sig.values():
        arr.flags.writeable = False
    sig = MappingProxyType(sig)
    kept[key] = (src, sig)
    return sig


def _computed_signals(flight, cutoff):
    a = flight.arrays
    R = np.asarray(a["R"], dtype=float)
    fa_b = np.einsum("nji,nj->ni", R, a["fa"])
    tau = np.asarray(a["T_sp"], dtype=float) / np.asarray(a["hover_throttle"], dtype=float)
    dp = np.asarray(a["p"], dtype=float) - np.asarray(a["p_d"], dtype=float).mean(axis=0)
    X = np.column_stack([fa_b[:, :2], np.asarray(a["v"], dtype=float), tau, R.reshape(-1, 9), dp])
    if cutoff is not None:
        X = lowpass(X, flight_dt(flight), cutoff)
    RT = np.transpose(X[:, 6:15].reshape(-1, 3, 3), (0, 2, 1))
    fz = fa_b[:, 2] if cutoff is None else lowpass(fa_b[:, 2], flight_dt(flight), cutoff)
    return {"t": np.asarray(a["t"], dtype=float), "f": X[:, :2] / X[:, 5:6], "tau": X[:, 5],
            "vb": np.einsum("nij,nj->ni", RT, X[:, 2:5]), "RT": RT, "dp": X[:, 15:18],
            "fz": fz / X[:, 5]}


@dataclass(frozen=True)
class DragModel:
    """The fitted force model (module text): ``offset`` ``delta`` (2,) [N per hover thrust],
    ``gain`` ``k`` [N s/m], ``jet`` ``g`` (3,) [1/m] and ``parasitic`` ``c`` [N s^2/m^2]
    (0 unless fitted with ``parasitic=True``)."""

    offset: tuple
    gain: float
    jet: tuple
    parasitic: float = 0.0

    def scale(self, sig):
        """The jet's speed profile ``s(p)`` (n,) at each sample, clipped to
        :data:`JET_RANGE`."""
        return np.clip(1.0 + sig["dp"] @ np.asarray(self.jet), *JET_RANGE)

    def inplane(self, sig, W):
        """The in-plane airspeed ``u`` (n, 2) [m/s] for a wind ``W`` (2,) world."""
        return (self.scale(sig)[:, None] * (sig["RT"][:, :2, :2] @ W)) - sig["vb"][:, :2]

    def measurement(self, sig, W):
        """``(z, H)``: the equation as ``z = H W_xy`` per sample, z (n, 2), H (n, 2, 2); with
        a parasitic term the gain is taken at the airspeed of ``W`` (2,), the filter's prior."""
        s = self.scale(sig)
        gain = np.full(len(s), self.gain)
        if self.parasitic:
            u = s[:, None] * (sig["RT"][:, :2, :2] @ W) - sig["vb"][:, :2]
            gain = gain + self.parasitic * np.linalg.norm(u, axis=1) / sig["tau"]
        z = sig["f"] - np.asarray(self.offset) + gain[:, None] * sig["vb"][:, :2]
        return z, (gain * s)[:, None, None] * sig["RT"][:, :2, :2]

    def airspeed(self, sig):
        """The in-plane airspeed ``u_b,xy`` (n, 2) [m/s] the force says, the model solved
        for it (closed form: ``k rho + c rho^2 / tau = |f - delta|``)."""
        g = sig["f"] - np.asarray(self.offset)
        gn = np.linalg.norm(g, axis=1)
        c = self.parasitic / sig["tau"]
        rho = 2.0 * gn / (self.gain + np.sqrt(self.gain ** 2 + 4.0 * c * gn))
        return g * (rho / np.maximum(gn, 1e-300))[:, None]

    def invert(self, sig):
        """``W_xy`` (n, 2) [m/s] solving the equation at every sample."""
        u = self.airspeed(sig) + sig["vb"][:, :2]
        H = self.scale(sig)[:, None, None] * sig["RT"][:, :2, :2]
        return np.linalg.solve(H, u[..., None])[..., 0]


def normal_equations(sig, W, keep):
    """The least-squares normal equations ``(G, h)`` (7 x 7, 7) of one flight (both body
    axes) for a wind ``W`` (3,) world; each flight weighs alike. Columns: the offsets, the
    rotor drag, the jet (3) and the parasitic drag."""
    n = int(keep.sum())
    Wb = np.einsum("nij,j->ni", sig["RT"][keep], W)
    u = Wb[:, :2] - sig["vb"][keep, :2]
    un = np.linalg.norm(u, axis=1) / sig["tau"][keep]
    G, h = np.zeros((7, 7)), np.zeros(7)
    for ax in (0, 1):
        A = np.zeros((n, 7))
        A[:, ax] = 1.0
        A[:, 2] = u[:, ax]
        A[:, 3:6] = Wb[:, ax:ax + 1] * sig["dp"][keep]
        A[:, 6] = un * u[:, ax]
        G += A.T @ A
        h += A.T @ sig["f"][keep, ax]
    return G / n, h / n


def fit_model(normals, jet, parasitic=False):
    """The :class:`DragModel` solving the summed normal equations ``normals`` (a parasitic
    coefficient fitted below 0 is dropped: the force must grow with the airspeed);
    ``ValueError`` if the flights do not determine it."""
    G, h = sum(g for g, _ in normals), sum(v for _, v in normals)
    used = [0, 1, 2] + ([3, 4, 5] if jet else []) + ([6] if parasitic else [])
    coef = np.zeros(7)
    while True:
        Gu = G[np.ix_(used, used)]
        rank = np.linalg.matrix_rank(Gu, tol=1e-10 * max(1.0, float(np.abs(Gu).max())))
        if rank < len(used):
            raise ValueError(f"flights do not determine the drag model (rank {rank} of "
                             f"{len(used)}): they need distinct winds and a path that moves")
        coef[:] = 0.0
        coef[used] = np.linalg.solve(Gu, h[used])
        if 6 in used and coef[6] < 0:
            used.remove(6)
            continue
        break
    if not coef[2] > 0:
        raise ValueError(f"flights give a rotor-drag gain k = {coef[2]:.3g} N s/m <= 0: the "
                         f"force does not grow with the airspeed across them")
    return DragModel(offset=(float(coef[0]), float(coef[1])), gain=float(coef[2]),
                     jet=tuple(float(c) for c in coef[3:6]), parasitic=float(coef[6]))


def variance_curve(speeds, sq):
    """``(a, b)`` >= 0 of ``var(W) = a + b W^2`` fitted to squared errors ``sq`` at wind
    speeds ``speeds`` (least squares, non-negative)."""
    from scipy.optimize import nnls

    speeds, sq = np.asarray(speeds, float), np.asarray(sq, float)
    A = np.column_stack([np.ones_like(speeds), speeds ** 2])
    if np.ptp(speeds) == 0:
        return float(np.mean(sq)), 0.0
    a, b = nnls(A, sq)[0]
    return float(a), float(b)


def block_starts(n, dt, period):
    """Sample index where each block of ``period`` [s] starts (the last may be shorter)."""
    size = max(1, int(round(period / dt)))
    return np.arange(0, n, size)


def kalman(model, sig, starts, q, noise, window=0):
    """The causal Kalman filter of the module text: ``(W_xy, var)`` (n, 2) each. Each block's
    measurement is ``model``'s equation averaged over the block, its gain taken at the prior
    (exact for a linear model); ``noise`` (callable of the current speed) is the block
    measurement's std in wind units, ``q`` the random walk's variance per block. The filter
    starts from the first block's own reading. ``window`` > 0 (blocks): a block's variance is
    at least the mean square of the ``window`` blocks' innovations before it (in wind units,
    less their measurement noise) -- the error the filter showed, lag included."""
    n = len(sig["t"])
    out, var = np.empty((n, 2)), np.empty((n, 2))
    ends = np.append(starts[1:], n)
    x, P = model.invert(sig)[:ends[0]].mean(axis=0), np.eye(2) * 100.0
    shown = np.zeros((len(starts), 2))  # each block's innovation^2 less its noise, wind units
    for i, (s, e) in enumerate(zip(starts, ends)):
        P = P + np.eye(2) * q
        out[s:e], var[s:e] = x, np.diag(P)  # causal: this block's samples see the blocks before
        block = {k: v[s:e] for k, v in sig.items()}
        z, H = model.measurement(block, x)
        zz, HH = z.mean(axis=0), H.mean(axis=0)
        sd = noise(float(np.linalg.norm(x)))
        r = sd ** 2 * (HH @ HH.T)
        S = HH @ P @ HH.T + r
        K = np.linalg.solve(S.T, (P @ HH.T).T).T
        nu = zz - HH @ x
        shown[i] = np.linalg.solve(HH, nu) ** 2 - sd ** 2
        if window and i:
            past = shown[max(0, i - window):i].mean(axis=0)
            var[s:e] = np.maximum(var[s:e], past)
        x = x + K @ nu
        P = (np.eye(2) - K @ HH) @ P
        P = 0.5 * (P + P.T)
    return out, var


#: The powers of the airspeed the body z force's curve may take (module text).
Z_POWERS = (2, 3, 4)


def z_features(model, sig, W, power):
    """A flight's mean of the z curve's columns ``[1, |u|^power]`` for a wind ``W`` (2,)."""
    u2 = np.sum(model.inplane(sig, W) ** 2, axis=1)
    return np.array([1.0, (u2 ** (power / 2)).mean()])


def z_terms(sig, weight):
    """A flight's mean body z force over the thrust and its mean ``gamma`` (2,): the in-plane
    force over the whole force along the body z axis (``f_xy / (f_z + m g)``), what an
    attitude offset moves the z force by per unit of the in-plane offset it makes."""
    whole = sig["fz"] + weight
    if not np.all(whole > 0):
        raise ValueError(f"mass is too small: the body z force plus the weight (mass * g = "
                         f"{weight:g} N per hover thrust) must be positive at every sample, "
                         f"got {float(np.min(whole)):g}")
    gamma = sig["f"] / whole[:, None]
    return float(sig["fz"].mean()), gamma.mean(axis=0)


def fit_tilt(model, items, wind, held, weight):
    """The z curve of the module text fitted on the training flights ``items`` ``[(flight,
    sig, keep), ...]`` (raw signals), with their winds ``wind`` (n, 2) and controllers
    ``held``: ``(coef (2,), z_var, reach, speeds, power)``. ``power``: of :data:`Z_POWERS`,
    the one whose curve errs least with each training wind speed left out of its fit in
    turn; ``z_var``: the curve's flight-level residual variance with each controller left out
    in turn; ``reach`` [N^2 s^2/m^2 per hover thrust^2]: how that variance grows with the
    square of the distance from the nearest training wind speed (the errors with each wind
    left out); ``speeds`` the training wind speeds. Nested: the flight predicted has no say.
    With fewer than three training wind speeds no curve is fitted (``coef`` None)."""
    z, rows = [], []
    for (f, sig, keep), W in zip(items, wind):
        s = {k: v[keep] for k, v in sig.items()}
        r = (s["f"] - np.asarray(model.offset) - model.gain * model.inplane(s, W)).mean(axis=0)
        fz, gamma = z_terms(s, weight)
        rows.append([z_features(model, s, W, p) for p in Z_POWERS])
        z.append(fz + gamma @ r)
    z, held, rows = np.array(z), np.asarray(held), np.array(rows)  # rows: (flight, power, 2)
    speeds = np.round(np.linalg.norm(wind, axis=1), 9)
    trained = np.unique(speeds)
    if len(trained) < 3:  # each wind left out must leave two for the curve's two parameters
        return None, math.nan, math.inf, tuple(trained.tolist()), None

    def left_out(X, groups):
        out = []
        for g in np.unique(groups):
            o = groups == g
            if len(np.unique(speeds[~o])) >= 2:
                c = np.linalg.lstsq(X[~o], z[~o], rcond=None)[0]
                out.append((o, z[o] - X[o] @ c))
        return out

    far = [left_out(rows[:, i], speeds) for i in range(len(Z_POWERS))]
    best = int(np.argmin([np.mean(np.concatenate([e for _, e in f]) ** 2) for f in far]))
    X, far = rows[:, best], far[best]
    coef = np.linalg.lstsq(X, z, rcond=None)[0]
    res = [e for _, e in left_out(X, held)]
    z_var = (float(np.mean(np.concatenate(res) ** 2)) if res
             else float(np.mean((z - X @ coef) ** 2)))
    d2 = np.concatenate([np.full(o.sum(), np.min((trained[trained != speeds[o][0]]
                                                   - speeds[o][0]) ** 2)) for o, _ in far])
    e2 = np.concatenate([e for _, e in far]) ** 2
    reach = max(float(np.sum(d2 * np.maximum(e2 - z_var, 0.0)) / np.sum(d2 ** 2)), 1e-12)
    return coef, z_var, reach, tuple(trained.tolist()), Z_POWERS[best]


def tilted(model, sig, coef, power, z_var, r_var, weight, steps=20):
    """``(offset (2,), var (2, 2))``: the flight's own offset ``r`` [N per hover thrust] (its
    posterior mean and covariance, module text) for signals ``sig``: the prior ``N(0,
    diag(r_var))``, the in-plane equation solved for the wind given ``r``, the z equation
    ``mean f_z + gamma . r = z model(W(r))`` with variance ``z_var`` (Gauss-Newton)."""
    W0 = model.invert(sig).mean(axis=0)
    H = model.gain * model.scale(sig)[:, None, None] * sig["RT"][:, :2, :2]
    Hi = np.linalg.inv(H).mean(axis=0)
    fz, gamma = z_terms(sig, weight)

    def resid(r):
        return fz + gamma @ r - z_features(model, sig, W0 - Hi @ r, power) @ coef

    r, h = np.zeros(2), 1e-4
    prec = 1.0 / np.asarray(r_var)
    for _ in range(steps):
        e = resid(r)
        J = np.array([(resid(r + h * np.eye(2)[i]) - e) / h for i in range(2)])
        A = np.outer(J, J) / z_var + np.diag(prec)
        step = np.linalg.solve(A, -(J * e / z_var + prec * r))
        r = r + step
        if np.max(np.abs(step)) < 1e-8:
            break
    return r, np.linalg.inv(A)
