"""Soft-DTW and DTW as functions of series and batches (the kernels' checked entry points).

Equal to tslearn's ``soft_dtw``, ``cdist_soft_dtw``, the barycentre objective and its
gradient, ``dtw`` and the DTW distance matrix, for equal-length series without NaN.
"""

import math

import numpy as np

from ._kernels import _dtw_upper_par_inner, _dtw_upper_range, _dtw_value, _n_workers, _objgrad_batch_par, _objgrad_batch_serial, _objgrad_range, _sdtw_cross_par_inner, _sdtw_cross_serial, _sdtw_upper_par_inner, _sdtw_upper_range, _sdtw_value
from ._libm import _libm_selfcheck
from ._consts import PARALLEL


# ---------------------------------------------------------------------------
# Public low-level helpers
# ---------------------------------------------------------------------------
def _as_dataset(X):
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X.reshape(1, -1, 1)
    elif X.ndim == 2:
        X = X.reshape(X.shape[0], X.shape[1], 1)
    if X.ndim != 3:
        raise ValueError("X must have shape (n_ts, sz, d)")
    if not np.all(np.isfinite(X)):
        raise ValueError("X contains NaN/inf (variable-length, NaN-padded "
                         "datasets are not supported by uavwind.softdtw)")
    return np.ascontiguousarray(X)


def _as_series(x):
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    return np.ascontiguousarray(x)


def _check_gamma(gamma):
    gamma = float(gamma)
    if math.isclose(gamma, 0.0):
        raise ValueError("gamma ~ 0 (tslearn switches to hard DTW) is not "
                         "supported by uavwind.softdtw")
    return gamma


def _use_parallel(parallel):
    return PARALLEL if parallel is None else bool(parallel)


def soft_dtw(x, y, gamma=1.0):
    """= tslearn.metrics.soft_dtw(x, y, gamma) (no constraint)."""
    x = _as_series(x)
    y = _as_series(y)
    gamma = _check_gamma(gamma)
    return float(_sdtw_value(x, y, gamma, _libm_selfcheck()))


def soft_dtw_cross(A, B, gamma=1.0, parallel=None):
    """out[i, j] = soft_dtw(A[i], B[j]) (= tslearn _cdist_soft_dtw(A, B))."""
    A = _as_dataset(A)
    B = _as_dataset(B)
    gamma = _check_gamma(gamma)
    out = np.empty((A.shape[0], B.shape[0]))
    _sdtw_cross(A, B, gamma, out, _use_parallel(parallel), _libm_selfcheck())
    return out


def _sdtw_cross(A, B, gamma, out, par, fx):
    npairs = A.shape[0] * B.shape[0]
    nw = _n_workers(par, npairs)
    if nw > 1:
        _sdtw_cross_par_inner(A, B, gamma, fx, nw, out)
    else:
        _sdtw_cross_serial(A, B, gamma, fx, out)


def soft_dtw_grad(Z, X, gamma=1.0):
    """(value, gradient w.r.t. Z) of soft_dtw(Z, X) computed exactly like
    tslearn.barycenters.softdtw._softdtw_func(Z, X, 1., gamma, 0, None, None)
    (cost matrix D = cdist(Z, X) ** 2)."""
    Z = _as_series(Z)
    X = _as_series(X)
    gamma = _check_gamma(gamma)
    vals = np.empty(1)
    Gs = np.empty((1,) + Z.shape)
    _objgrad_range(Z, X[None], gamma, _libm_selfcheck(), 0, 1, 1, vals, Gs)
    return float(vals[0]), Gs[0]


def _objgrad(Z, Xs, gamma, par, fx):
    nw = _n_workers(par, Xs.shape[0])
    if nw > 1:
        return _objgrad_batch_par(Z, Xs, gamma, fx, nw)
    return _objgrad_batch_serial(Z, Xs, gamma, fx)


def soft_dtw_objgrad(Z, Xs, gamma=1.0, parallel=None):
    """Barycentre objective of tslearn (_acc_softdtw_func, unit weights):
    (sum_i soft_dtw(Z, Xs[i]), gradient w.r.t. Z of shape Z.shape).
    All series of Xs must have the same length (any length, != len(Z) ok)."""
    Z = _as_series(Z)
    Xs = _as_dataset(Xs)
    gamma = _check_gamma(gamma)
    return _objgrad(Z, Xs, gamma, _use_parallel(parallel), _libm_selfcheck())


def dtw(x, y):
    """= tslearn.metrics.dtw(x, y) (no constraint)."""
    x = _as_series(x)
    y = _as_series(y)
    return float(_dtw_value(x, y))


def dtw_pdist(X, parallel=None):
    """Full symmetric DTW matrix (= tslearn _cdist_dtw(X)), zero diagonal."""
    X = _as_dataset(X)
    nts = X.shape[0]
    out = np.zeros((nts, nts))
    npairs = nts * (nts - 1) // 2
    nw = _n_workers(_use_parallel(parallel), npairs)
    if nw > 1:
        _dtw_upper_par_inner(X, nw, out)
    else:
        _dtw_upper_range(X, 0, npairs, 1, out)
    return out


def soft_dtw_normalized_pdist(X, gamma=1.0, parallel=None):
    """= tslearn _cdist_soft_dtw_normalized(X, gamma=gamma)."""
    X = _as_dataset(X)
    gamma = _check_gamma(gamma)
    nts = X.shape[0]
    c = np.zeros((nts, nts))
    fx = _libm_selfcheck()
    npairs = nts * (nts + 1) // 2
    nw = _n_workers(_use_parallel(parallel), npairs)
    if nw > 1:
        _sdtw_upper_par_inner(X, gamma, fx, nw, c)
    else:
        _sdtw_upper_range(X, gamma, fx, 0, npairs, 1, c)
    d_ii = np.diag(c)
    normalizer = -0.5 * (d_ii.reshape((-1, 1)) + d_ii.reshape((1, -1)))
    return c + normalizer
