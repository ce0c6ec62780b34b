"""Which kernel a batch runs on: serial, or threaded over numba workers (same arithmetic,
same result, see the replication notes)."""

from ._kernels import (_n_workers, _objgrad_batch_par, _objgrad_batch_serial,
                       _sdtw_cross_par_inner, _sdtw_cross_serial)

def _sdtw_cross(A, B, gamma, out, par, fx):
    npairs = A.shape[0] * B.shape[0]
    nw = _n_workers(par, npairs)
    if nw > 1:
        _sdtw_cross_par_inner(A, B, gamma, fx, nw, out)
    else:
        _sdtw_cross_serial(A, B, gamma, fx, out)

def _objgrad(Z, Xs, gamma, par, fx):
    nw = _n_workers(par, Xs.shape[0])
    if nw > 1:
        return _objgrad_batch_par(Z, Xs, gamma, fx, nw)
    return _objgrad_batch_serial(Z, Xs, gamma, fx)
