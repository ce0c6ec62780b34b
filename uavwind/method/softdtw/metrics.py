"""Soft-DTW and DTW as functions of series and batches (the kernels' checked entry points).

Equal to tslearn's ``soft_dtw``, ``cdist_soft_dtw``, the barycentre objective and its
gradient, ``dtw`` and the DTW distance matrix, for series without NaN (a dataset's series
share one length; two datasets compared may have different lengths). Every function checks
its input before a kernel runs: a ``ValueError`` or ``TypeError`` names the argument for an
empty series, mismatched feature counts, NaN, inf, complex or sparse input, a non-positive
``gamma`` or values whose squared distances would overflow.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._checks import _as_dataset, _as_series, _check_gamma, _same_features, _use_parallel
from ._dispatch import _dtw_upper, _objgrad, _objgrad_many, _sdtw_cross
from ._kernels import (_dtw_value, _n_workers, _objgrad_range, _sdtw_upper_par_inner,
                       _sdtw_upper_range, _sdtw_value)
from ._libm import _libm_selfcheck


def soft_dtw(x: ArrayLike, y: ArrayLike, gamma: float = 1.0) -> float:
    """= tslearn.metrics.soft_dtw(x, y, gamma) (no constraint)."""
    x = _as_series(x, "x")
    y = _as_series(y, "y")
    _same_features(x, y, "x", "y")
    gamma = _check_gamma(gamma)
    return float(_sdtw_value(x, y, gamma, _libm_selfcheck()))


def soft_dtw_cross(A: ArrayLike, B: ArrayLike, gamma: float = 1.0,
                   parallel: bool | None = None) -> np.ndarray:
    """out[i, j] = soft_dtw(A[i], B[j]) (= tslearn _cdist_soft_dtw(A, B))."""
    A = _as_dataset(A, "A")
    B = _as_dataset(B, "B")
    _same_features(A, B, "A", "B")
    gamma = _check_gamma(gamma)
    out = np.empty((A.shape[0], B.shape[0]))
    _sdtw_cross(A, B, gamma, out, _use_parallel(parallel), _libm_selfcheck())
    return out


def soft_dtw_grad(Z: ArrayLike, X: ArrayLike, gamma: float = 1.0) -> tuple[float, np.ndarray]:
    """(value, gradient w.r.t. Z) of soft_dtw(Z, X) computed exactly like
    tslearn.barycenters.softdtw._softdtw_func(Z, X, 1., gamma, 0, None, None)
    (cost matrix D = cdist(Z, X) ** 2)."""
    Z = _as_series(Z, "Z")
    X = _as_series(X, "X")
    _same_features(Z, X, "Z", "X")
    gamma = _check_gamma(gamma)
    vals = np.empty(1)
    Gs = np.empty((1,) + Z.shape)
    _objgrad_range(Z, X[None], gamma, _libm_selfcheck(), 0, 1, 1, vals, Gs)
    return float(vals[0]), Gs[0]


def soft_dtw_objgrad(Z: ArrayLike, Xs: ArrayLike, gamma: float = 1.0,
                     parallel: bool | None = None) -> tuple[float, np.ndarray]:
    """Barycentre objective of tslearn (_acc_softdtw_func, unit weights):
    (sum_i soft_dtw(Z, Xs[i]), gradient w.r.t. Z of shape Z.shape).
    All series of Xs must have the same length (any length, != len(Z) ok)."""
    Z = _as_series(Z, "Z")
    Xs = _as_dataset(Xs, "Xs")
    _same_features(Z, Xs, "Z", "Xs")
    gamma = _check_gamma(gamma)
    return _objgrad(Z, Xs, gamma, _use_parallel(parallel), _libm_selfcheck())


def soft_dtw_objgrad_many(Zs: list[ArrayLike], Xss: list[ArrayLike], gamma: float = 1.0,
                          parallel: bool | None = None) -> list[tuple[float, np.ndarray]]:
    """:func:`soft_dtw_objgrad` of ``Zs[j]`` over ``Xss[j]`` for every j (one k-means round's
    clusters), in one call: the lockstep kernel takes every cluster's series ``N`` per
    vector whichever centre they belong to. The same doubles as one call per centre."""
    if len(Zs) != len(Xss) or not len(Zs):
        raise ValueError(f"Zs and Xss must be non-empty and of one length, got {len(Zs)} "
                         f"and {len(Xss)}")
    Zs = [_as_series(Z, f"Zs[{j}]") for j, Z in enumerate(Zs)]
    Xss = [_as_dataset(Xs, f"Xss[{j}]") for j, Xs in enumerate(Xss)]
    for j, (Z, Xs) in enumerate(zip(Zs, Xss)):
        _same_features(Z, Xs, f"Zs[{j}]", f"Xss[{j}]")
    gamma = _check_gamma(gamma)
    return _objgrad_many(Zs, Xss, gamma, _use_parallel(parallel), _libm_selfcheck())


def dtw(x: ArrayLike, y: ArrayLike) -> float:
    """= tslearn.metrics.dtw(x, y) (no constraint)."""
    x = _as_series(x, "x")
    y = _as_series(y, "y")
    _same_features(x, y, "x", "y")
    return float(_dtw_value(x, y))


def dtw_pdist(X: ArrayLike, parallel: bool | None = None) -> np.ndarray:
    """Full symmetric DTW matrix (= tslearn _cdist_dtw(X)), zero diagonal."""
    X = _as_dataset(X, "X")
    _same_features(X, X, "X", "X")
    out = np.zeros((X.shape[0], X.shape[0]))
    _dtw_upper(X, out, _use_parallel(parallel))
    return out


def soft_dtw_normalized_pdist(X: ArrayLike, gamma: float = 1.0,
                              parallel: bool | None = None) -> np.ndarray:
    """= tslearn _cdist_soft_dtw_normalized(X, gamma=gamma)."""
    X = _as_dataset(X, "X")
    _same_features(X, X, "X", "X")
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
