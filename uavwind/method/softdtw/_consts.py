"""Constants shared by the soft-DTW kernels, and the engine's environment switches.

Switches (environment variables, read once at import): ``UAVWIND_SOFTDTW_PARALLEL=1`` runs the
batched kernels on helper threads (serial by default), ``UAVWIND_SOFTDTW_GLIBC_REPLICA=0`` calls libm instead of the inlined
exp/log replicas, ``UAVWIND_SOFTDTW_LIMIT_BLAS=0`` leaves scipy's BLAS threads alone,
``UAVWIND_SOFTDTW_LOCKSTEP=0`` computes soft-DTW values one pair at a time (the scalar
reference) instead of N pairs per vector (the lockstep kernel; same doubles). The names
of 0.1 (``FASTKMEANS_PARALLEL``, ...) still work, with a ``DeprecationWarning``.
"""

import os
import warnings

import numpy as np


def env_flag(name, default=True):
    """The switch ``UAVWIND_SOFTDTW_<name>`` (or its 0.1 name ``FASTKMEANS_<name>``): False for
    ``0``, ``false`` or an empty value, True otherwise; ``default`` when unset."""
    value = os.environ.get(f"UAVWIND_SOFTDTW_{name}")
    if value is None and f"FASTKMEANS_{name}" in os.environ:
        warnings.warn(f"FASTKMEANS_{name} is deprecated: set UAVWIND_SOFTDTW_{name}",
                      DeprecationWarning, stacklevel=2)
        value = os.environ[f"FASTKMEANS_{name}"]
    if value is None:
        return default
    return value not in ("0", "false", "False", "")


# Run the batched kernels on the process's threads (UAVWIND_SOFTDTW_PARALLEL=1, or
# parallel=True): the lockstep kernels share a call's lane groups with helper threads
# (._share), the scalar ones use numba's prange. Off by default: on an idle AMD EPYC the
# helpers took 6 held-out loops from 0.65 to 0.56 s at 1.6 times the CPU, beside one busy
# core from 0.76 to 0.85 s (`ONLY=threads make bench`), and a user's machine is rarely
# idle. (Leave it off, too, when fit() is itself called from several Python threads:
# numba's default "workqueue" threading layer is not thread-safe.)
PARALLEL = env_flag("PARALLEL", default=False)

# Soft-DTW values (the assignment step) N pairs per SIMD vector; the scalar kernel with
# UAVWIND_SOFTDTW_LOCKSTEP=0.  Both give the same doubles (tests/test_lockstep.py).
LOCKSTEP = env_flag("LOCKSTEP")

_INF = np.inf
# exp(x) == 0.0 exactly (round-to-nearest) for every x < -745.14; we use a
# safety margin.
_EXP_ZERO = -746.0
# exp(x) < 2**-54 for x < -37.43; a softmin3 whose two non-maximal terms are
# both below this threshold has tmp == 1.0 exactly (see NOTES.md).
_EXP_NEGLIGIBLE = -38.0
