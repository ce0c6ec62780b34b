"""Which kernel a batch runs on: serial, or threaded over numba workers; one pair at a time
(the scalar kernels) or N pairs per SIMD vector (the lockstep kernel). Every choice does the
same arithmetic and gives the same doubles (see the replication notes)."""

from . import _consts
from ._kernels import (_dtw_upper_par_inner, _dtw_upper_range, _n_workers, _objgrad_batch_par,
                       _objgrad_batch_serial, _sdtw_cross_par_inner, _sdtw_cross_serial)
from ._lockstep import (N, _dtw_upper_lockstep, _dtw_upper_lockstep_par, _objgrad_lockstep,
                        _objgrad_lockstep_par, _sdtw_cross_lockstep, _sdtw_cross_lockstep_par)


def _use_lockstep(fx, lockstep=None):
    """The lockstep kernel runs where the glibc replicas are exact on this platform (``fx``;
    its vector exp/log are the same replicas) and unless ``UAVWIND_SOFTDTW_LOCKSTEP=0``."""
    return bool(fx) and (_consts.LOCKSTEP if lockstep is None else bool(lockstep))


def _sdtw_cross(A, B, gamma, out, par, fx, lockstep=None):
    npairs = A.shape[0] * B.shape[0]
    if _use_lockstep(fx, lockstep):
        nw = _n_workers(par, (npairs + N - 1) // N)
        if nw > 1:
            _sdtw_cross_lockstep_par(A, B, gamma, nw, out)
        else:
            _sdtw_cross_lockstep(A, B, gamma, out)
        return
    nw = _n_workers(par, npairs)
    if nw > 1:
        _sdtw_cross_par_inner(A, B, gamma, fx, nw, out)
    else:
        _sdtw_cross_serial(A, B, gamma, fx, out)


def _objgrad(Z, Xs, gamma, par, fx, lockstep=None):
    if _use_lockstep(fx, lockstep):
        nw = _n_workers(par, (Xs.shape[0] + N - 1) // N)
        if nw > 1:
            return _objgrad_lockstep_par(Z, Xs, gamma, nw)
        return _objgrad_lockstep(Z, Xs, gamma)
    nw = _n_workers(par, Xs.shape[0])
    if nw > 1:
        return _objgrad_batch_par(Z, Xs, gamma, fx, nw)
    return _objgrad_batch_serial(Z, Xs, gamma, fx)


def _dtw_upper(X, out, par, lockstep=None):
    """The DTW matrix of X into ``out`` (zero diagonal on entry). DTW needs no exp/log, so
    only ``UAVWIND_SOFTDTW_LOCKSTEP`` (or ``lockstep``) decides the kernel."""
    npairs = X.shape[0] * (X.shape[0] - 1) // 2
    if _use_lockstep(True, lockstep):
        nw = _n_workers(par, (npairs + N - 1) // N)
        if nw > 1:
            _dtw_upper_lockstep_par(X, nw, out)
        else:
            _dtw_upper_lockstep(X, out)
        return
    nw = _n_workers(par, npairs)
    if nw > 1:
        _dtw_upper_par_inner(X, nw, out)
    else:
        _dtw_upper_range(X, 0, npairs, 1, out)
