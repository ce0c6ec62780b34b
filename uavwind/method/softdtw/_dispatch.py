"""Which kernel a batch runs on: one pair at a time (the scalar kernels, serial or threaded
over numba's workers) or N pairs per SIMD vector (the lockstep kernels, their lane groups
shared with helper threads, :mod:`._share`). Every choice does the same arithmetic and gives
the same doubles (see the replication notes)."""

import itertools

import numpy as np

from . import _consts
from ._kernels import (_dtw_upper_par_inner, _dtw_upper_range, _jacobian_product_sq_euc,
                       _n_workers, _objgrad_batch_par, _objgrad_batch_serial,
                       _sdtw_cross_par_inner, _sdtw_cross_serial)
from ._lockstep import _dtw_upper_lockstep, _objgrad_lockstep, _sdtw_cross_lockstep
from ._simd import N


def _use_lockstep(fx, lockstep=None):
    """The lockstep kernel runs where the glibc replicas are exact on this platform (``fx``;
    its vector exp/log are the same replicas) and unless ``UAVWIND_SOFTDTW_LOCKSTEP=0``."""
    return bool(fx) and (_consts.LOCKSTEP if lockstep is None else bool(lockstep))


_CONTRACTS = []


def jacobian_contracts():
    """Whether the scalar Jacobian product (tslearn's expression under its ``fastmath``)
    compiles on this host to one fused multiply-add per term, ``G = fma(E + E, Z - X, G)``,
    the operation the lockstep gradient performs on every lane; checked once, on a term
    where a fused and a separate multiply and add round differently (with G = -(2e * v)
    rounded, the separate pair gives exactly 0.0 and the fused one the product's rounding
    error). Where it does not, the gradient runs on the scalar kernels."""
    if not _CONTRACTS:
        e, v = 1.0 / 3.0, 1.0 / 7.0
        G = np.array([[-(2 * e * v)]])
        _jacobian_product_sq_euc(np.array([[v]]), np.zeros((1, 1)), np.array([[e]]),
                                 np.zeros(1, np.int64), np.zeros(1, np.int64), G)
        _CONTRACTS.append(G[0, 0] != 0.0)
    return _CONTRACTS[0]


def _sdtw_cross(A, B, gamma, out, par, fx, lockstep=None):
    npairs = A.shape[0] * B.shape[0]
    if _use_lockstep(fx, lockstep):
        _sdtw_cross_lockstep(A, B, gamma, out, _n_workers(par, (npairs + N - 1) // N))
        return
    nw = _n_workers(par, npairs)
    if nw > 1:
        _sdtw_cross_par_inner(A, B, gamma, fx, nw, out)
    else:
        _sdtw_cross_serial(A, B, gamma, fx, out)


def _objgrad(Z, Xs, gamma, par, fx, lockstep=None):
    """The barycentre objective and gradient of centre Z over the series Xs."""
    return _objgrad_many([Z], [Xs], gamma, par, fx, lockstep)[0]


def _objgrad_many(Zs, Xss, gamma, par, fx, lockstep=None):
    """``[(objective, gradient) of Zs[j] over Xss[j]]``: :class:`ObjgradBatch` of ``Xss``
    evaluated once, at every centre."""
    return ObjgradBatch(Xss, gamma, par, fx, lockstep)(Zs, range(len(Xss)))


class ObjgradBatch:
    """The barycentre objectives and gradients of one k-means round's clusters, evaluated
    at centres again and again (one L-BFGS-B step of each cluster a call): the clusters'
    series ``Xss`` stay the same for the batch's life, so the lockstep kernel's stacked
    series, centre ids and offsets are made once for each set of clusters asked
    (on the k-means loop's inputs, 24 us of each call's Python at 1,049 calls).

    ``batch(Zs, ks)``: ``[(objective, gradient) of Zs[i] over Xss[ks[i]]]``. The lockstep
    kernel evaluates every asked cluster's series in one call, N per vector whichever
    centre they belong to (two clusters of 10 series fill 3 vectors of 8 lanes instead of
    4); the scalar kernels one centre at a time. Each pair is the same doubles either
    way. The arrays of ``Xss`` must not change while the batch is used."""

    __slots__ = ("_Xss", "_gamma", "_par", "_fx", "_lockstep", "_packed")

    def __init__(self, Xss, gamma, par, fx, lockstep=None):
        self._Xss = list(Xss)
        self._gamma = gamma
        self._par = par
        self._fx = fx
        self._lockstep = _use_lockstep(fx, lockstep) and jacobian_contracts()
        self._packed = {}

    def _pack(self, ks):
        """(stacked series, centre id of each, offsets of each centre's series) of the
        clusters ``ks``, made the first time they are asked together."""
        got = self._packed.get(ks)
        if got is None:
            Xss = [self._Xss[k] for k in ks]
            sizes = [X.shape[0] for X in Xss]
            starts = np.array([0, *itertools.accumulate(sizes)], dtype=np.int64)
            Xs = Xss[0] if len(Xss) == 1 else np.concatenate(Xss)
            cid = np.repeat(np.arange(len(Xss), dtype=np.int64), sizes)
            got = self._packed[ks] = (Xs, cid, starts,
                                      _n_workers(self._par, (Xs.shape[0] + N - 1) // N))
        return got

    def __call__(self, Zs, ks):
        ks = tuple(ks)
        if self._lockstep:
            Xs, cid, starts, nw = self._pack(ks)
            Zb = np.empty((len(Zs),) + Zs[0].shape)
            for i, Z in enumerate(Zs):  # np.stack, without its checks (5 us a call)
                Zb[i] = Z
            objs, G = _objgrad_lockstep(Zb, cid, starts, Xs, self._gamma, nw)
            return list(zip(objs, G))
        out = []
        for Z, k in zip(Zs, ks):
            Xs = self._Xss[k]
            nw = _n_workers(self._par, Xs.shape[0])
            out.append(_objgrad_batch_par(Z, Xs, self._gamma, self._fx, nw) if nw > 1
                       else _objgrad_batch_serial(Z, Xs, self._gamma, self._fx))
        return out


def _dtw_upper(X, out, par, lockstep=None):
    """The DTW matrix of X into ``out`` (zero diagonal on entry). DTW needs no exp/log, so
    only ``UAVWIND_SOFTDTW_LOCKSTEP`` (or ``lockstep``) decides the kernel."""
    npairs = X.shape[0] * (X.shape[0] - 1) // 2
    if _use_lockstep(True, lockstep):
        _dtw_upper_lockstep(X, out, _n_workers(par, (npairs + N - 1) // N))
        return
    nw = _n_workers(par, npairs)
    if nw > 1:
        _dtw_upper_par_inner(X, nw, out)
    else:
        _dtw_upper_range(X, 0, npairs, 1, out)
