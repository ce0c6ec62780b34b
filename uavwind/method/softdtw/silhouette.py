"""The silhouette of a clustering under DTW (or normalised soft-DTW), as tslearn scores it.

``tslearn.clustering.silhouette_score(X, labels, metric="dtw")`` is scikit-learn's
silhouette on the DTW distance matrix; :func:`silhouette_score` computes that matrix
once with the DTW kernel and then does scikit-learn's arithmetic.
"""


from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._checks import _as_dataset
from .metrics import dtw_pdist, soft_dtw_normalized_pdist


# ---------------------------------------------------------------------------
# silhouette
# ---------------------------------------------------------------------------
def _silhouette_precomputed(D, labels):
    """sklearn.metrics.silhouette_score(D, labels, metric="precomputed"),
    same arithmetic (bincount sums, same divisions, nan_to_num, mean)."""
    D = np.asarray(D, dtype=np.float64)
    labels = np.asarray(labels)
    atol = np.finfo(D.dtype).eps * 100
    if np.any(np.abs(D.diagonal()) > atol):
        raise ValueError("The precomputed distance matrix contains non-zero "
                         "elements on the diagonal. Use np.fill_diagonal(X, 0).")
    classes, labels = np.unique(labels, return_inverse=True)
    n_samples = len(labels)
    n_labels = len(classes)
    if not 1 < n_labels < n_samples:
        raise ValueError("Number of labels is %d. Valid values are 2 to "
                         "n_samples - 1 (inclusive)" % n_labels)
    label_freqs = np.bincount(labels)
    cluster_distances = np.zeros((n_samples, len(label_freqs)), dtype=D.dtype)
    for i in range(n_samples):
        cluster_distances[i] += np.bincount(labels, weights=D[i],
                                            minlength=len(label_freqs))
    intra_index = (np.arange(n_samples), labels)
    intra = cluster_distances[intra_index]
    cluster_distances[intra_index] = np.inf
    cluster_distances /= label_freqs
    inter = cluster_distances.min(axis=1)
    denom = (label_freqs - 1).take(labels, mode="clip")
    with np.errstate(divide="ignore", invalid="ignore"):
        intra /= denom
    sil_samples = inter - intra
    with np.errstate(divide="ignore", invalid="ignore"):
        sil_samples /= np.maximum(intra, inter)
    sil_samples = np.nan_to_num(sil_samples)
    return float(np.mean(sil_samples))


def _check_labels(labels, n_ts):
    labels = np.asarray(labels)
    if labels.ndim != 1 or labels.shape[0] != n_ts:
        raise ValueError(f"labels must have shape ({n_ts},) (one per series), got "
                         f"{labels.shape}")
    if not (np.issubdtype(labels.dtype, np.integer) or labels.dtype == bool):
        raise TypeError(f"labels must be integers, got dtype {labels.dtype}")
    return labels


def silhouette(X: ArrayLike, labels: ArrayLike, metric: str | None = "dtw",
               gamma: float | None = None, parallel: bool | None = None) -> float:
    """= tslearn.clustering.silhouette_score(X, labels, metric=metric,
    metric_params={"gamma": gamma} if gamma is not None else None).
    metric: "dtw" (or None) or "softdtw" (normalised soft-DTW, gamma
    default 1.0 as in tslearn) or "precomputed"."""
    if metric not in ("dtw", None, "softdtw", "precomputed"):
        raise ValueError(f"metric must be 'dtw', 'softdtw' or 'precomputed', got {metric!r}")
    if metric == "precomputed":
        D = np.asarray(X, dtype=np.float64)
        if D.ndim != 2 or D.shape[0] != D.shape[1] or not np.all(np.isfinite(D)):
            raise ValueError(f"X must be a finite square distance matrix for "
                             f"metric='precomputed', got shape {D.shape}")
        return _silhouette_precomputed(D, _check_labels(labels, D.shape[0]))
    X = _as_dataset(X, "X")
    labels = _check_labels(labels, X.shape[0])
    if metric == "dtw" or metric is None:
        D = dtw_pdist(X, parallel=parallel)
    elif metric == "softdtw":
        D = soft_dtw_normalized_pdist(X, 1.0 if gamma is None else gamma,
                                      parallel=parallel)
    else:
        raise ValueError("metric must be 'dtw', 'softdtw' or 'precomputed'")
    return _silhouette_precomputed(D, labels)
