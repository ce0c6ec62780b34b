"""Constants shared by the soft-DTW kernels."""

import os

import numpy as np

# Run the batched kernels on all cores (numba prange).  Turn off with
# FASTKMEANS_PARALLEL=0 (e.g. when fit() is itself called from several
# Python threads: numba's default "workqueue" threading layer is not
# thread-safe).
PARALLEL = os.environ.get("FASTKMEANS_PARALLEL", "1") not in ("0", "false", "False", "")

_INF = np.inf
# exp(x) == 0.0 exactly (round-to-nearest) for every x < -745.14; we use a
# safety margin.
_EXP_ZERO = -746.0
# exp(x) < 2**-54 for x < -37.43; a softmin3 whose two non-maximal terms are
# both below this threshold has tmp == 1.0 exactly (see NOTES.md).
_EXP_NEGLIGIBLE = -38.0
