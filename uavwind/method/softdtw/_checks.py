"""Input checks of the engine's entry points: every public function checks its input here,
before a kernel runs, so a kernel never sees an array it could read past, an empty series or
values whose squared differences overflow.

A *series* is ``(sz, d)`` (a 1-D array is one univariate series, ``(sz, 1)``); a *dataset* is
``(n_ts, sz, d)`` (a 2-D array is ``n_ts`` univariate series, ``(n_ts, sz, 1)``, as tslearn
reads it). Both are returned as C-contiguous float64 arrays.
"""

import math
import numbers

import numpy as np

from ._consts import PARALLEL

#: Largest double: sums of squared differences must stay below it.
_REALMAX = np.finfo(np.float64).max


def _as_float(X, name):
    """``X`` as a float64 array; TypeError for sparse matrices, complex, object or string
    data (never silently cast)."""
    if hasattr(X, "tocsr") or type(X).__module__.startswith("scipy.sparse"):
        raise TypeError(f"{name} is a sparse matrix: sparse input is not supported "
                        f"(time series are dense arrays)")
    try:
        arr = np.asarray(X)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a numeric array of time series: {exc}") from None
    if arr.dtype.kind == "c":
        raise ValueError(f"{name}: Complex data not supported (got a complex array)")
    if arr.dtype.kind not in "biuf":
        try:
            return arr.astype(np.float64)
        except (TypeError, ValueError) as exc:
            raise TypeError(f"{name} must be a numeric array of time series, got dtype "
                            f"{arr.dtype}: {exc}") from None
    return arr.astype(np.float64, copy=False)


def _check_finite(arr, name, what):
    if not np.all(np.isfinite(arr)):
        if np.any(np.isnan(arr)):
            raise ValueError(f"{name} contains NaN: NaN-padded variable-length {what} are not "
                             f"supported by uavwind.method.softdtw (pass series of one length; "
                             f"tslearn's to_time_series_dataset pads with NaN)")
        raise ValueError(f"{name} contains inf: every value must be finite")


def _check_magnitude(arrays, names):
    """ValueError if the squared differences of the largest values could overflow: every
    value must satisfy ``(2 |x|)^2 d (sz_a + sz_b) < realmax`` for the series compared."""
    d = max(a.shape[-1] for a in arrays)
    steps = sum(a.shape[-2] for a in arrays)
    bound = math.sqrt(_REALMAX / (4.0 * d * steps)) / 2.0
    for a, name in zip(arrays, names):
        if a.size and np.abs(a).max() > bound:
            raise ValueError(f"{name} has values up to {np.abs(a).max():.3g}: squared "
                             f"distances overflow beyond |x| = {bound:.3g} for series of "
                             f"{a.shape[-2]} steps and {d} features; rescale the data")


def _as_series(x, name="x"):
    """``x`` as a checked (sz, d) series: 1-D is univariate; sz >= 1, d >= 1, finite."""
    x = _as_float(x, name)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    if x.ndim != 2:
        raise ValueError(f"{name} must be one time series of shape (sz, d) (or (sz,)), "
                         f"got shape {x.shape}")
    if x.shape[0] == 0 or x.shape[1] == 0:
        raise ValueError(f"{name} must hold at least one time step of at least one feature, "
                         f"got shape {x.shape}")
    _check_finite(x, name, "series")
    return np.ascontiguousarray(x)


def _as_dataset(X, name="X", n_features=None):
    """``X`` as a checked (n_ts, sz, d) dataset: 2-D is univariate, 1-D refused; n_ts, sz and
    d >= 1, finite; ``n_features``: the ``d`` it must have (e.g. the fitted centres')."""
    X = _as_float(X, name)
    if X.ndim == 2:
        if X.shape[1] == 0:  # scikit-learn's words, then ours
            raise ValueError(f"{name} has 0 feature(s) (shape={X.shape}) while a minimum of 1 "
                             f"is required: each univariate series needs at least one step")
        X = X.reshape(X.shape[0], X.shape[1], 1)
    if X.ndim != 3:
        raise ValueError(f"{name} must be a dataset of time series, shape (n_ts, sz, d) (or "
                         f"(n_ts, sz) for univariate series); got a {X.ndim}-D array of "
                         f"shape {X.shape}. Reshape your data: X.reshape(1, -1) for a "
                         f"single univariate series")
    if 0 in X.shape:
        raise ValueError(f"{name} must hold at least one series of at least one step and one "
                         f"feature, got shape {X.shape} (empty data)")
    _check_finite(X, name, "datasets")
    if n_features is not None and X.shape[2] != n_features:
        raise ValueError(f"{name} has {X.shape[2]} features per time step, but the series it "
                         f"is compared with have {n_features}")
    return np.ascontiguousarray(X)


def _same_features(a, b, name_a, name_b):
    if a.shape[-1] != b.shape[-1]:
        raise ValueError(f"{name_a} and {name_b} must have the same number of features per "
                         f"time step (last axis), got {a.shape[-1]} and {b.shape[-1]}")
    _check_magnitude([a, b], [name_a, name_b])


def _check_gamma(gamma):
    """``gamma`` as a float in (0, 1e300]: soft-DTW smoothing."""
    if isinstance(gamma, (bool, np.bool_)) or not isinstance(gamma, numbers.Real):
        raise TypeError(f"gamma must be a real number > 0, got {type(gamma).__name__}")
    gamma = float(gamma)
    if not math.isfinite(gamma) or gamma <= 0:
        raise ValueError(f"gamma must be finite and > 0 (soft-DTW smoothing), got {gamma}")
    if math.isclose(gamma, 0.0, abs_tol=1e-300):  # pragma: no cover - below realmin
        raise ValueError("gamma ~ 0 (tslearn switches to hard DTW) is not supported")
    return gamma


def _use_parallel(parallel):
    if parallel is not None and not isinstance(parallel, (bool, np.bool_)):
        raise TypeError(f"parallel must be True, False or None, got {parallel!r}")
    return PARALLEL if parallel is None else bool(parallel)
