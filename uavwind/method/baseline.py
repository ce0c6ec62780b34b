"""A physics baseline: the wind estimated from the same positions with the UAV's own model.

This module owns :func:`estimate_wind` and :func:`baseline_metrics` (Exp 9).

The UAV flew a known thrust sequence, and under eqs 2-8 its air-relative velocity
does not depend on the wind. Simulating the same thrust in still air therefore gives
the still-air positions ``s[k]``, and the flown positions are ``p[k] = s[k] +
sum_{j<=k} w[j] dt``. Least squares on this discrete model gives:

* ``model="constant"``: one wind per environment, ``w = sum_k t_k (p_k - s_k) /
  sum_k t_k^2`` with ``t_k = (k + 1) dt`` (the start position is known). Exact for
  noise-free positions under a constant wind, and unbiased under zero-mean noise
  (the estimate is linear in the noise);
* ``model="path"``: the wind along the path, ``w[k] = ((p_k - p_{k-1}) - (s_k -
  s_{k-1})) / dt``; exact without noise for any wind model, noisy with it.

This is the drag-model reasoning that flight controllers use for sensorless wind
estimation (the PX4 and ArduPilot EKFs fuse a drag model with GNSS velocity to
estimate the wind), reduced to the paper's point mass. It needs the UAV's mass and
drag coefficient; :func:`baseline_metrics` also measures what a 20% error in them does.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..sim.actions import ThrustSequence
from ..core.checks import check_array, check_scalar
from ..sim.dynamics import simulate
from ..sim.vehicle import UAV
from ..sim.wind import ConstantWind

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from ..sim.flight import Flight

__all__ = ["estimate_wind", "baseline_metrics", "two_means", "WIND_MODELS", "BASELINE_VERSION"]

#: The wind models :func:`estimate_wind` fits.
WIND_MODELS = ("constant", "path")
#: Largest position coordinate accepted [m] (as :func:`~uavwind.method.clustering.score_loop`).
MAX_COORDINATE = 1e9
#: Longest step between positions accepted [s].
MAX_DT = 10.0
#: Part of the cache key of every loop that runs the baseline: bump when its numbers change.
BASELINE_VERSION = "2"


def _still_air(thrust, uav, dt, n, start):

    return simulate(thrust, ConstantWind([[0.0, 0.0, 0.0]]), uav=uav, dt=dt, duration=n * dt,
                    start_position=start)[0]


def estimate_wind(positions: ArrayLike, thrust: ThrustSequence, uav: UAV | None = None,
                  dt: float = 0.1, model: str = "constant",
                  start_position: ArrayLike | None = None, return_std: bool = False,
                  position_noise: float | None = None):
    """Estimate each environment's wind from its positions and the known thrust: the point
    mass's member of the wind estimators, whose multirotor member is
    :class:`uavwind.WindEstimator` (the same quantity, the velocity of the air mass [m/s] in
    the world frame, and the same ``return_std`` convention, scikit-learn's).

    Parameters
    ----------
    positions : array_like, shape (n_env, n_steps, 3)
        Observed positions [m] after each step (as :func:`uavwind.simulate` returns).
    thrust : ThrustSequence
        The thrust the UAV flew.
    uav : UAV, optional
        The model the estimator assumes (default ``UAV()``).
    dt : float
        Step [s] of the positions.
    model : {"constant", "path"}
    start_position : array_like, shape (3,), optional
        Known start [m]; default (0, 0, 10) as :func:`uavwind.simulate`.
    return_std : bool
        Also return the estimate's standard deviation, of the same shape [m/s].
    position_noise : float, optional
        The positions' noise [m] (white, per axis), in [0, 1e6]. With it the std is the
        noise carried through the estimate (``"constant"``: ``sigma / sqrt(sum t_k^2)``;
        ``"path"``: ``sqrt(2) sigma / dt``, the first step ``sigma / dt``); without it,
        ``"constant"``'s std is read off the fit's own residuals and ``"path"``, which has no
        residual (one position per wind sample), refuses ``return_std``.

    Returns
    -------
    ndarray, or (ndarray, ndarray) with ``return_std``
        ``"constant"``: (n_env, 3) [m/s]; ``"path"``: (n_env, n_steps, 3) [m/s].

    Examples
    --------
    >>> import uavwind as uw
    >>> pos = uw.simulate(uw.PAPER_EXAMPLE, uw.ConstantWind([[1.5, -0.5, 0.0]]))
    >>> estimate_wind(pos, uw.PAPER_EXAMPLE).round(12).tolist()
    [[1.5, -0.5, 0.0]]
    """
    p = check_array(positions, "positions", ndim=3)
    if p.shape[2] != 3 or p.shape[1] < 1 or p.shape[0] < 1:
        raise ValueError(f"positions must have shape (n_env, n_steps, 3), got {p.shape}")
    if np.abs(p).max() > MAX_COORDINATE:
        raise ValueError(f"positions must stay within +-{MAX_COORDINATE:g} m, got "
                         f"{np.abs(p).max():g}")
    if not isinstance(thrust, ThrustSequence):
        raise TypeError(f"thrust must be a ThrustSequence, got {type(thrust).__name__}")
    uav = UAV() if uav is None else uav
    if not isinstance(uav, UAV):
        raise TypeError(f"uav must be a UAV, got {type(uav).__name__}")
    dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False, high=MAX_DT)
    if model not in WIND_MODELS:
        raise ValueError(f"model must be one of {list(WIND_MODELS)}, got {model!r}")
    start = (np.array([0.0, 0.0, 10.0]) if start_position is None
             else check_array(start_position, "start_position", shape=(3,)))
    if not isinstance(return_std, (bool, np.bool_)):
        raise TypeError(f"return_std must be a bool, got {type(return_std).__name__}")
    if position_noise is not None:
        position_noise = check_scalar(position_noise, "position_noise", low=0.0, high=1e6)
    if return_std and model == "path" and position_noise is None:
        raise ValueError("return_std with model='path' needs position_noise [m]: the path "
                         "model has one position per wind sample, so no residual to read a "
                         "std from")
    n = p.shape[1]
    drift = p - _still_air(thrust, uav, dt, n, start)[None]  # (n_env, n, 3): sum of w dt
    if model == "constant":
        t = (np.arange(n) + 1.0) * dt
        w = np.einsum("k,ekx->ex", t, drift) / np.dot(t, t)
        if not return_std:
            return w
        if position_noise is None:
            resid = drift - t[None, :, None] * w[:, None, :]
            sigma = np.sqrt(np.sum(resid ** 2, axis=1) / max(n - 1, 1))
        else:
            sigma = np.full_like(w, position_noise)
        return w, sigma / np.sqrt(np.dot(t, t))
    prev = np.concatenate([np.zeros_like(drift[:, :1]), drift[:, :-1]], axis=1)
    w = (drift - prev) / dt
    if not return_std:
        return w
    std = np.full_like(w, np.sqrt(2.0) * position_noise / dt)
    std[:, 0] = position_noise / dt
    return w, std


def two_means(points: ArrayLike, max_iter: int = 100) -> np.ndarray:
    """Deterministic 2-means (Lloyd's iterations) of ``points`` (n, d), n >= 2.

    Starts from the two points farthest apart and alternates assignment and centroid
    updates until the labels stop changing; returns labels in {0, 1} (the first
    point's cluster is 0). For the few dozen estimated winds of a loop this takes
    microseconds, where ``sklearn.cluster.KMeans`` takes a tenth of a second.

    >>> two_means(np.array([[0.0], [0.1], [5.0], [5.2]])).tolist()
    [0, 0, 1, 1]
    """
    x = check_array(points, "points", ndim=2)
    if x.shape[0] < 2:
        raise ValueError(f"points must hold at least 2 rows to split in two, got {x.shape[0]}")
    max_iter = check_scalar(max_iter, "max_iter", low=1, high=10 ** 6, integer=True)
    d2 = ((x[:, None] - x[None]) ** 2).sum(axis=2)
    i, j = np.unravel_index(np.argmax(d2), d2.shape)
    centres = x[[i, j]]
    labels = None
    for _ in range(max_iter):
        new = np.argmin(((x[:, None] - centres[None]) ** 2).sum(axis=2), axis=1)
        if labels is not None and np.array_equal(new, labels):
            break
        labels = new
        if labels.min() == labels.max():  # identical points: one cluster
            break
        centres = np.array([x[labels == k].mean(axis=0) for k in (0, 1)])
    return labels if labels[0] == 0 else 1 - labels


def _grouped(estimates, groups):
    """Whether 2-means on the estimated winds reproduces ``groups`` (up to a label swap)."""
    labels = two_means(estimates)
    return bool(np.array_equal(labels, groups) or np.array_equal(labels, 1 - groups))


def baseline_metrics(flight: Flight, positions: ArrayLike, thrust: ThrustSequence, uav: UAV,
                     dt: float, groups: ArrayLike, start_position: ArrayLike | None = None,
                     model_error: float = 0.2) -> dict[str, float | bool]:
    """The baseline on one loop: wind RMSE and grouping, with the true UAV and with
    ``model_error`` (20%) too much mass or drag coefficient.

    Returns a flat dict: ``baseline_rmse`` [m/s] (root mean square over environments of
    the error of the constant-wind estimate against each environment's mean wind along
    its path), ``baseline_correct`` (2-means on the estimates reproduces the groups), and
    the same with suffixes ``_mass`` and ``_drag`` for the mis-specified models.
    """
    from dataclasses import replace

    truth = flight.winds.mean(axis=1)
    out = {}
    models = {"": uav,
              "_mass": replace(uav, mass=uav.mass * (1 + model_error)),
              "_drag": replace(uav, drag_coefficient=uav.drag_coefficient * (1 + model_error))}
    for suffix, m in models.items():
        est = estimate_wind(positions, thrust, uav=m, dt=dt, start_position=start_position)
        err = np.linalg.norm(est - truth, axis=1)
        out[f"baseline_rmse{suffix}"] = float(np.sqrt(np.mean(err ** 2)))
        out[f"baseline_correct{suffix}"] = _grouped(est, np.asarray(groups))
    return out
