"""The lockstep kernels (soft-DTW value, value + gradient, DTW): ``N`` pairs per vector, one
per lane.

Every lane runs tslearn 0.10.0's arithmetic, operation for operation and in its order, on its
own pair, so its result is the same double as the scalar kernel's
(:func:`._kernels._sdtw_forward`) and tslearn's; what changes is that one instruction serves
``N`` pairs (:mod:`._simd`). Per cell (i, j) and lane, with a = up, b = left, c = diagonal,
all already divided by -gamma as the scalar kernel keeps them::

    mx = max(max(a, b), c);  second = max(min(a, b), min(max(a, b), c))
    if second - mx < -38 on every lane:  lg = 0.0          (tmp == 1.0 exactly, log(1) == 0)
    else, tslearn's sum on the lanes that need it:
        lg = log(((0.0 + exp(a - mx)) + exp(b - mx)) + exp(c - mx))
    with two exps, not three: each of a, b, c equals mx, the second largest or the smallest
    of the three, so its exp is exp(+0.0) == 1.0 (mx finite), exp(second - mx) or
    exp(smallest - mx), the same doubles; a lane whose mx is not finite takes all three
    r = D + (-gamma) * (lg + mx);   S = r * (1 / -gamma)  if gamma = 2**k  else r / -gamma

The scalar kernel's skip rule (a cell whose two smaller terms are negligible needs no
``exp``/``log``) becomes a lane mask: a cell is cheap only when it is cheap on every lane, and
a lane that is cheap inside an expensive vector keeps ``lg = 0.0``, which is exact for it.

Schedule: blocks of :data:`R` rows walk a staggered wavefront (row r computes column t - r at
step t) and keep their last two S vectors in registers. A step in which some lane of some row
needs the full ``exp``/``log`` sum leaves the register loop and runs :func:`_mstep` (the exact
cell through memory) for all rows, as the scalar kernel's ``_slow_step`` does. Prologue and
epilogue triangles and short blocks use :func:`_mstep` too, so the last cell always does.

Layout: series are lane-interleaved, ``x[(i * d + k) * N + l]`` = feature k of step i of lane
l's series; the S buffer is padded like tslearn's accumulated matrix (row -1 is -inf but for
the corner (-1, -1) = 0 / -gamma, column -1 is -inf), so the borders run the same code.
The same lanes serve the barycentre objective (N series, each against its own centre, so
k-means' clusters share the vectors: value, gradient matrix by the backward recursion over
the union of the lanes' bands, row by row, and the Jacobian product on every lane with the
fused multiply-add the scalar kernel compiles to, where it does) and DTW (N pairs of the
silhouette's matrix; min and add only, no exp/log). Only :mod:`._dispatch` calls the entry points;
:mod:`._kernels` stays the scalar reference.

The forward engine (the lane cells, the cost rows, the exact cell through memory and the
register wavefront, blocks of :data:`R` rows) is :mod:`._lockstep_forward`'s; this module
owns the entry points built on it: the values of many pairs, the barycentre objective's
value and gradient, and DTW.
"""

import threading

import numpy as np
from numba import njit

from ._kernels import _reduce_objgrad_into, _unrank_upper
from ._lockstep_forward import R, _forward
from ._scalar_forward import _is_pow2
from ._share import NO_MAILBOX, announce, fetch_add, share
from ._simd import (N, lane, many, mnot, mor, sel, splat, vadd, vdiv, veq, vfma, vload, vmin,
                    vmul, vsqrt, vstore, vsub)
from ._vlibm import vexp_care


#: Bytes every work array of the lockstep kernels starts on: a cache line, which an
#: 8-lane (64-byte) vector then never straddles.
ALIGN = 64


@njit(cache=True, nogil=True, error_model="numpy")
def _aligned_empty(k):
    """``np.empty(k)`` starting on an :data:`ALIGN`-byte boundary. numba aligns its arrays
    to 32 bytes and numpy to 16, so half or all of the 8-lane loads and stores on them would
    straddle two cache lines; measured on the captured barycentre inputs on an Intel Xeon,
    that made the forward pass's stores to the accumulated matrix cost more than its cells."""
    buf = np.empty(k + ALIGN // 8)
    off = ((-buf.ctypes.data) % ALIGN) // 8
    return buf[off:off + k]


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _pack_pairs(A, B, g, x, y):
    """Lane-interleave the pairs g * N .. g * N + N - 1 of A x B (pair p = (p // nb, p % nb));
    lanes past the last pair repeat it (their results are dropped)."""
    nb = B.shape[0]
    last = A.shape[0] * nb - 1
    m, d = A.shape[1], A.shape[2]
    n = B.shape[1]
    for l in range(N):
        p = min(g * N + l, last)
        i = p // nb
        j = p - i * nb
        for s in range(m):
            for k in range(d):
                x[(s * d + k) * N + l] = A[i, s, k]
        for s in range(n):
            for k in range(d):
                y[(s * d + k) * N + l] = B[j, s, k]


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _cross_groups(A, B, gamma, claim, enter, out):
    """out[i, j] = soft-DTW(A[i], B[j]) for the pairs of the lane groups this thread claims
    (``claim``: the call's group counter, :func:`._share.fetch_add`), until none is left;
    ``enter``: see :func:`._share.announce`."""
    announce(enter)
    nb = B.shape[0]
    npairs = A.shape[0] * nb
    ngroups = (npairs + N - 1) // N
    m, d = A.shape[1], A.shape[2]
    n = B.shape[1]
    x = _aligned_empty(m * d * N)
    y = _aligned_empty(n * d * N)
    S = _aligned_empty((R + 1) * (n + 1) * N)
    D = _aligned_empty(R * n * N)
    Rf = np.empty(0)
    while True:
        g = fetch_add(claim, 1)
        if g >= ngroups:
            return
        _pack_pairs(A, B, g, x, y)
        last = _forward(x, y, m, n, d, gamma, S, D, Rf)
        for l in range(N):
            p = g * N + l
            if p < npairs:
                i = p // nb
                out[i, p - i * nb] = lane(last, l)


def _sdtw_cross_lockstep(A, B, gamma, out, nw=1):
    """out[i, j] = soft-DTW(A[i], B[j]) = the scalar ``_sdtw_cross_serial``, N pairs at once;
    with ``nw > 1`` the lane groups are shared with up to ``nw - 1`` helper threads
    (:func:`._share.share`)."""
    claim = np.zeros(1, dtype=np.int64)
    share(lambda enter: _cross_groups(A, B, gamma, claim, enter, out), nw)


# ------------------------- value and gradient ------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _factor(e, care, rn, r11, dn, gamma, inv_gamma, pow2):
    """e * exp(((rn - r11) - dn) / gamma) with tslearn's NaN -> 0 on the ``care`` lanes (where
    e != 0); +0.0 on the others, which is tslearn's e * a = 0 * finite there."""
    t = vsub(vsub(rn, r11), dn)
    t = vmul(t, inv_gamma) if pow2 else vdiv(t, gamma)
    a = vexp_care(t, care)
    a = sel(veq(a, a), a, 0.0)
    return sel(care, vmul(e, a), 0.0)


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _backward(Rf, D, m, n, gamma, E, rlo, rhi):
    """tslearn's gradient matrix (``_njit_soft_dtw_grad``) of every lane into E (m * n * N,
    all zero on entry), on the union over lanes of the band where E can be non-zero, from
    the accumulated matrix Rf and the cost matrix D the forward pass kept (each m * n * N);
    a factor whose e is 0 on every lane is not evaluated, and a cell inside the union band
    but outside a lane's own band gets exactly +0.0 on that lane, as in tslearn.

    Rows bottom to top, columns right to left in a row (tslearn walks columns). A cell
    depends on the cells below, to its right and below-right only, so any order that visits
    those first gives every cell the same doubles (each still ``(p1 + p2) + p3`` with p1
    the cell below, p2 the one to the right, p3 the diagonal, as tslearn adds them). Rows
    are walked because the Jacobian product sums row by row: ``rlo[r] .. rhi[r]`` receive
    the columns computed in row r (what :func:`_clear_rows` resets and
    :func:`_jacobian_vec` sums over)."""
    pow2 = _is_pow2(gamma)
    inv_gamma = 1.0 / gamma
    nN = n * N
    zero = splat(0.0)
    one = splat(1.0)
    vstore(E, (m - 1) * nN + (n - 1) * N, one)
    nxt_lo = n
    nxt_hi = -1
    for r in range(m - 1, -1, -1):
        if r == m - 1:
            c = n - 2
            prev = one
            cur_lo = n - 1
            cur_hi = n - 1
            comp_hi = n - 1
            comp_lo = n - 1
        else:
            c = min(n - 1, nxt_hi)
            prev = zero
            cur_lo = n
            cur_hi = -1
            comp_hi = c
            comp_lo = c + 1
        below = r + 1 < m
        while c >= 0:
            e1 = vload(E, (r + 1) * nN + c * N) if below else zero
            e2 = prev
            e3 = vload(E, (r + 1) * nN + (c + 1) * N) if (below and c + 1 < n) else zero
            n1 = mnot(veq(e1, 0.0))
            n2 = mnot(veq(e2, 0.0))
            n3 = mnot(veq(e3, 0.0))
            if not many(mor(mor(n1, n2), n3)):
                if c < nxt_lo - 1:
                    break
                v = zero
            else:
                k = r * nN + c * N
                r11 = vload(Rf, k)
                p1 = zero
                p2 = zero
                p3 = zero
                if many(n1):
                    p1 = _factor(e1, n1, vload(Rf, k + nN), r11, vload(D, k + nN),
                                 gamma, inv_gamma, pow2)
                if many(n2):
                    p2 = _factor(e2, n2, vload(Rf, k + N), r11, vload(D, k + N),
                                 gamma, inv_gamma, pow2)
                if many(n3):
                    p3 = _factor(e3, n3, vload(Rf, k + nN + N), r11, vload(D, k + nN + N),
                                 gamma, inv_gamma, pow2)
                v = vadd(vadd(p1, p2), p3)
            vstore(E, r * nN + c * N, v)
            comp_lo = c
            if many(mnot(veq(v, 0.0))):
                if cur_hi < 0:
                    cur_hi = c
                cur_lo = c
            prev = v
            c -= 1
        rlo[r] = comp_lo
        rhi[r] = comp_hi
        nxt_lo = cur_lo
        nxt_hi = cur_hi


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _jacobian_vec(zl, x, E, m, n, d, rlo, rhi, s0, ns, Gs):
    """Every lane's Jacobian product at once: Gs[s0 + l][i, k] = the sum over j, in j
    order, of fma(E[i, j] + E[i, j], zl[i, k] - x[j, k], .), from 0.0 -- the operations the
    scalar :func:`._kernels._jacobian_product_sq_euc` (tslearn's expression, compiled with
    its ``fastmath``) performs on this host, where LLVM contracts ``G + (E * 2) * (Z - X)``
    into one fused multiply-add (:func:`jacobian_contracts` checks it; elsewhere the
    lockstep kernel is not used). Row i sums over the columns computed in it
    (``rlo[i] .. rhi[i]``): outside a lane's own band its E is +0.0, and fma(+0.0, finite,
    G) is G, so the extra terms change no lane."""
    nN = n * N
    for i in range(m):
        lo = rlo[i]
        hi = rhi[i]
        for k in range(d):
            zk = vload(zl, (i * d + k) * N)
            acc = splat(0.0)
            for j in range(lo, hi + 1):
                e = vload(E, i * nN + j * N)
                acc = vfma(vadd(e, e), vsub(zk, vload(x, (j * d + k) * N)), acc)
            for l in range(N):
                if s0 + l < ns:
                    Gs[s0 + l, i, k] = lane(acc, l)


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _clear_rows(E, m, n, rlo, rhi):
    """Restore the all-zero invariant of E after :func:`_backward_rows`."""
    nN = n * N
    zero = splat(0.0)
    for r in range(m):
        for c in range(rlo[r], rhi[r] + 1):
            vstore(E, r * nN + c * N, zero)


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _pack_series(Xs, g, x):
    """Lane-interleave the series g * N .. g * N + N - 1 of Xs (past the last: the last)."""
    last = Xs.shape[0] - 1
    n, d = Xs.shape[1], Xs.shape[2]
    for l in range(N):
        s = min(g * N + l, last)
        for t in range(n):
            for k in range(d):
                x[(t * d + k) * N + l] = Xs[s, t, k]


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _pack_centres(Zs, cid, g, zl):
    """Lane-interleave the centres of the series g * N .. g * N + N - 1 (Zs[cid[s]]; past
    the last series: the last one's)."""
    last = cid.shape[0] - 1
    m, d = Zs.shape[1], Zs.shape[2]
    for l in range(N):
        z = Zs[cid[min(g * N + l, last)]]
        for t in range(m):
            for k in range(d):
                zl[(t * d + k) * N + l] = z[t, k]


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _objgrad_groups(Zs, cid, Xs, gamma, claim, enter, vals, Gs, zl, x, S, D, Rf, E, rlo, rhi):
    """vals[s], Gs[s] = tslearn's ``_softdtw_func(Zs[cid[s]], Xs[s], 1, gamma, ..)`` for the
    series of the lane groups this thread claims (``claim``: the call's group counter,
    :func:`._share.fetch_add`), until none is left, on this thread's workspace (zl .. rhi,
    as :func:`_objgrad_workspace` makes them; E all zero on entry, and again on return;
    ``enter``: see :func:`._share.announce`).
    A lane's centre is its series' own (``cid``), so one vector can serve series of several
    barycentres; a lane's arithmetic does not depend on its neighbours."""
    m, d = Zs.shape[1], Zs.shape[2]
    n = Xs.shape[1]
    announce(enter)
    ns = Xs.shape[0]
    ngroups = (ns + N - 1) // N
    one = Zs.shape[0] == 1
    if one:  # one centre: packed once
        _pack_centres(Zs, cid, np.int64(0), zl)
    while True:
        g = fetch_add(claim, 1)
        if g >= ngroups:
            return
        if not one:
            _pack_centres(Zs, cid, g, zl)
        _pack_series(Xs, g, x)
        last = _forward(zl, x, m, n, d, gamma, S, D, Rf)
        _backward(Rf, D, m, n, gamma, E, rlo, rhi)
        for l in range(N):
            if g * N + l < ns:
                vals[g * N + l] = lane(last, l)
        _jacobian_vec(zl, x, E, m, n, d, rlo, rhi, g * N, ns, Gs)
        _clear_rows(E, m, n, rlo, rhi)


@njit(cache=True, nogil=True, error_model="numpy")
def _reduce_many(vals, Gs, starts):
    """Per barycentre j (its series starts[j] .. starts[j + 1] - 1): the scalar kernel's
    reduction in series order; (objectives, gradients)."""
    K = starts.shape[0] - 1
    objs = np.empty(K)
    G = np.zeros((K, Gs.shape[1], Gs.shape[2]))
    for j in range(K):
        objs[j] = _reduce_objgrad_into(vals[starts[j]:starts[j + 1]],
                                       Gs[starts[j]:starts[j + 1]], G[j])
    return objs, G


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_serial(Zs, cid, starts, Xs, gamma, zl, x, S, D, Rf, E, rlo, rhi):
    """Every lane group on this thread, then the reductions (:func:`_reduce_many`)."""
    ns = Xs.shape[0]
    m, d = Zs.shape[1], Zs.shape[2]
    vals = np.empty(ns)
    Gs = np.empty((ns, m, d))
    _objgrad_groups(Zs, cid, Xs, gamma, np.zeros(1, dtype=np.int64), NO_MAILBOX, vals, Gs, zl,
                    x, S, D, Rf, E, rlo, rhi)
    return _reduce_many(vals, Gs, starts)


#: Per thread, the last workspace of the barycentre kernel: ``((m, n, d), arrays)``.
_WORKSPACE = threading.local()


def _objgrad_workspace(m, n, d):
    """The arrays :func:`_objgrad_groups` works in on one thread: packed centres and series,
    the wavefront's S rows, the whole cost, accumulated and gradient matrices of N lanes (E
    all zero) and the band's columns per row; about ``3 * m * n * N`` doubles (2.8 MB for
    120 x 120 and 8 lanes), kept for the life of the thread.

    Taken from this thread's cache when its last call had the same shape, else made (made at
    every call, the pages of these megabytes can be faulted in and zeroed again each time).
    The thread puts them back (:func:`_with_workspace`) only after the kernel returned, so a
    call that failed half-way never leaves a dirty E to the next; each thread (the caller and
    each helper of :func:`._share.share`) has its own."""
    key = (m, n, d)
    got = getattr(_WORKSPACE, "last", None)
    _WORKSPACE.last = None
    if got is not None and got[0] == key:
        return got[1]
    nN = m * n * N
    E = _aligned_empty(nN)
    E[:] = 0.0
    return (_aligned_empty(m * d * N), _aligned_empty(n * d * N),
            _aligned_empty((R + 1) * (n + 1) * N), _aligned_empty(nN), _aligned_empty(nN), E,
            np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64))


def _with_workspace(m, n, d, kernel):
    """``kernel(*workspace)`` on this thread's workspace, put back once it has returned."""
    ws = _objgrad_workspace(m, n, d)
    out = kernel(*ws)
    _WORKSPACE.last = ((m, n, d), ws)  # E is all zero again
    return out


def _objgrad_lockstep(Zs, cid, starts, Xs, gamma, nw=1):
    """The barycentre objectives and gradients of ``K = len(Zs)`` centres at once, each =
    the scalar ``_objgrad_batch_serial(Zs[j], Xs[starts[j]:starts[j + 1]], ..)``: N series
    per vector (of any centres: k-means' clusters share the vectors), then each centre's
    reduction in its series' order; with ``nw > 1`` the lane groups are shared with up to
    ``nw - 1`` helper threads (:func:`._share.share`), each on its own workspace, and the
    reductions run once they are all done."""
    m, d = Zs.shape[1], Zs.shape[2]
    n = Xs.shape[1]
    if nw <= 1:
        return _with_workspace(m, n, d, lambda *ws: _objgrad_serial(Zs, cid, starts, Xs, gamma,
                                                                   *ws))
    ns = Xs.shape[0]
    vals = np.empty(ns)
    Gs = np.empty((ns, m, d))
    claim = np.zeros(1, dtype=np.int64)
    share(lambda enter: _with_workspace(m, n, d, lambda *ws: _objgrad_groups(
        Zs, cid, Xs, gamma, claim, enter, vals, Gs, *ws)), nw)
    return _reduce_many(vals, Gs, starts)


# ---------------------------------- DTW ------------------------------------
@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _dtw_lanes(x, y, m, n, d, P, C):
    """DTW of the N lane-interleaved pairs, tslearn's ``_njit_dtw`` (no mask) on every lane:
    A[i, j] = cost + min(up, left, diagonal) with the padded predecessors +inf but the
    corner (-1, -1) = 0, and the result sqrt(A[m - 1, n - 1]). Costs and accumulated values
    are finite and >= 0, so the order of the three-way min cannot change the double. P and
    C: two rows of (n + 1) * N doubles."""
    W = (n + 1) * N
    for q in range(W):
        P[q] = np.inf
    for l in range(N):
        P[l] = 0.0
    for i in range(m):
        for l in range(N):
            C[l] = np.inf
        for j in range(n):
            dist = splat(0.0)
            for k in range(d):
                diff = vsub(vload(x, (i * d + k) * N), vload(y, (j * d + k) * N))
                dist = vadd(dist, vmul(diff, diff))
            best = vmin(vmin(vload(P, (j + 1) * N), vload(C, j * N)), vload(P, j * N))
            vstore(C, (j + 1) * N, vadd(dist, best))
        P, C = C, P
    return vsqrt(vload(P, n * N))


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _dtw_upper_groups(X, claim, enter, out):
    """out[i, j] = out[j, i] = DTW(X[i], X[j]) for the pairs i < j of the lane groups this
    thread claims (``claim``: the call's group counter, :func:`._share.fetch_add`), until
    none is left (pair p is the p-th of the row-major upper triangle); ``enter``: see
    :func:`._share.announce`."""
    announce(enter)
    nts, n, d = X.shape
    npairs = nts * (nts - 1) // 2
    x = _aligned_empty(n * d * N)
    y = _aligned_empty(n * d * N)
    P = _aligned_empty((n + 1) * N)
    C = _aligned_empty((n + 1) * N)
    ngroups = (npairs + N - 1) // N
    while True:
        g = fetch_add(claim, 1)
        if g >= ngroups:
            return
        for l in range(N):
            i, j = _unrank_upper(min(g * N + l, npairs - 1), nts, np.int64(1))
            for s in range(n):
                for k in range(d):
                    x[(s * d + k) * N + l] = X[i, s, k]
                    y[(s * d + k) * N + l] = X[j, s, k]
        v = _dtw_lanes(x, y, n, n, d, P, C)
        for l in range(N):
            p = g * N + l
            if p < npairs:
                i, j = _unrank_upper(p, nts, np.int64(1))
                out[i, j] = lane(v, l)
                out[j, i] = lane(v, l)


def _dtw_upper_lockstep(X, out, nw=1):
    """The DTW matrix's upper triangle (and its mirror) = the scalar ``_dtw_upper_range``;
    with ``nw > 1`` the lane groups are shared with up to ``nw - 1`` helper threads."""
    claim = np.zeros(1, dtype=np.int64)
    share(lambda enter: _dtw_upper_groups(X, claim, enter, out), nw)
