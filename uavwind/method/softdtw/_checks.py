"""Input checks of the engine's entry points (every public function checks its input here
before a kernel runs)."""

import math

import numpy as np

from ._consts import PARALLEL

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
