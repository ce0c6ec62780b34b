"""The numba kernels: soft-DTW value, gradient and barycentre objective, and DTW.

Each kernel computes tslearn 0.10.0's arithmetic operation for operation (cells of
``softmin3``, the backward recursion of the gradient, the squared-Euclidean Jacobian
product, DTW's cost recursion), so its results are the same doubles; what differs is
the schedule: cells that cannot change a rounded sum skip their ``exp``/``log``, the
gradient visits only its non-zero band, and batches run serially or over numba threads
(``prange``) in a fixed order. Only :mod:`uavwind.method.softdtw.metrics` calls them.

The forward recursion they all start from (the cells, the cost matrix, ``_sdtw_forward``)
is :mod:`._scalar_forward`'s; this module owns what is built on it: the backward pass and the
barycentre objective, the values of many pairs, and DTW.
"""

import math

import numpy as np
from numba import njit, prange

from ._consts import _INF
from ._scalar_forward import _cost_matrix, _exp_exact, _is_pow2, _sdtw_forward


# ----------------------------- backward pass -------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _grad_factor(e, r_next, r11, d_next, gamma, inv_gamma, pow2, fx):
    """e * exp((r_next - r11 - d_next) / gamma) with tslearn's NaN -> 0."""
    t = (r_next - r11) - d_next
    if pow2:
        t = t * inv_gamma
    else:
        t = t / gamma
    a = _exp_exact(t, fx)
    if np.isnan(a):
        a = 0.0
    return e * a


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_backward(D, R, gamma, fx, E, jlo, jhi, clo, chi):
    """tslearn's _njit_soft_dtw_grad(D, R, gamma) restricted to the band
    where E can be non-zero.

    Same traversal (columns right-to-left, rows bottom-to-top) and same
    expression ((e1*a + e2*b) + e3*c) for every computed cell.  A cell whose
    three E-predecessors are all 0 is exactly 0 in tslearn as well
    (0 * finite = 0), so those cells are not visited.  E must be all zeros
    on entry (see _clear_E); the cells written are [clo[c], chi[c]] of each
    column c.  jlo/jhi receive, per row, the first / last non-zero column."""
    m, n = D.shape
    pow2 = _is_pow2(gamma)
    inv_gamma = 1.0 / gamma
    for i in range(m):
        jlo[i] = n
        jhi[i] = -1
    E[m - 1, n - 1] = 1.0
    jlo[m - 1] = n - 1
    jhi[m - 1] = n - 1
    nxt_lo = m        # non-zero row range of column c + 1 (empty at start)
    nxt_hi = -1
    for c in range(n - 1, -1, -1):
        if c == n - 1:
            r = m - 2
            prev_v = 1.0
            cur_lo = m - 1
            cur_hi = m - 1
            comp_hi = m - 1
            comp_lo = m - 1
        else:
            r = min(m - 1, nxt_hi)
            prev_v = 0.0
            cur_lo = m
            cur_hi = -1
            comp_hi = r
            comp_lo = r + 1
        while r >= 0:
            e1 = prev_v
            e2 = E[r, c + 1] if (r >= nxt_lo and r <= nxt_hi) else 0.0
            e3 = E[r + 1, c + 1] if (r + 1 >= nxt_lo and r + 1 <= nxt_hi) else 0.0
            if e1 == 0.0 and e2 == 0.0 and e3 == 0.0:
                if r < nxt_lo - 1:
                    break
                v = 0.0
            else:
                r11 = R[r, c]
                p1 = 0.0
                p2 = 0.0
                p3 = 0.0
                if e1 != 0.0:
                    p1 = _grad_factor(e1, R[r + 1, c], r11, D[r + 1, c],
                                      gamma, inv_gamma, pow2, fx)
                if e2 != 0.0:
                    p2 = _grad_factor(e2, R[r, c + 1], r11, D[r, c + 1],
                                      gamma, inv_gamma, pow2, fx)
                if e3 != 0.0:
                    p3 = _grad_factor(e3, R[r + 1, c + 1], r11,
                                      D[r + 1, c + 1], gamma, inv_gamma, pow2,
                                      fx)
                v = p1 + p2 + p3
            E[r, c] = v
            comp_lo = r
            if v != 0.0:
                if cur_hi < 0:
                    cur_hi = r
                cur_lo = r
                if jhi[r] < 0:
                    jhi[r] = c
                jlo[r] = c
            prev_v = v
            r -= 1
        clo[c] = comp_lo
        chi[c] = comp_hi
        nxt_lo = cur_lo
        nxt_hi = cur_hi


@njit(cache=True, nogil=True, error_model="numpy")
def _clear_E(E, clo, chi):
    """Restore the all-zero invariant of the E workspace."""
    n = E.shape[1]
    for c in range(n):
        for r in range(clo[c], chi[c] + 1):
            E[r, c] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", fastmath=True)
def _jacobian_product_sq_euc(Z, X, E, jlo, jhi, G):
    """G += Jacobian^T E, tslearn's _njit_jacobian_product_sq_euc (which is
    compiled with fastmath=True -- same flags, same expression, same loop
    order here; E entries outside [jlo, jhi] are exact zeros whose
    contribution leaves G unchanged)."""
    m = Z.shape[0]
    d = Z.shape[1]
    for i in range(m):
        for j in range(jlo[i], jhi[i] + 1):
            for k in range(d):
                G[i, k] += E[i, j] * 2 * (Z[i, k] - X[j, k])


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_one(Z, X, gamma, fx, yT, D, R, S, E, jlo, jhi, clo, chi, G):
    """tslearn.barycenters.softdtw._softdtw_func(Z, X, 1., gamma, 0, ...):
    returns R[-1, -1] and accumulates the gradient into the zeroed G."""
    v = _sdtw_forward(Z, X, gamma, np.bool_(True), fx, yT, D, R, S)
    _sdtw_backward(D, R, gamma, fx, E, jlo, jhi, clo, chi)
    _jacobian_product_sq_euc(Z, X, E, jlo, jhi, G)
    _clear_E(E, clo, chi)
    return v


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_range(Z, Xs, gamma, fx, s0, s1, step, vals, Gs):
    """vals[s], Gs[s] for s in range(s0, s1, step), one private workspace."""
    m, d = Z.shape
    n = Xs.shape[1]
    yT = np.empty((d, n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    E = np.zeros((m, n))
    jlo = np.empty(m, dtype=np.int64)
    jhi = np.empty(m, dtype=np.int64)
    clo = np.empty(n, dtype=np.int64)
    chi = np.empty(n, dtype=np.int64)
    for s in range(s0, s1, step):
        Gi = Gs[s]
        for i in range(m):
            for k in range(d):
                Gi[i, k] = 0.0
        vals[s] = _objgrad_one(Z, Xs[s], gamma, fx, yT, D, R, S, E, jlo, jhi,
                               clo, chi, Gi)


@njit(cache=True, nogil=True, error_model="numpy")
def _reduce_objgrad(vals, Gs):
    """obj = 0; G = 0; obj += v_s; G += G_s in series order (tslearn's
    _acc_softdtw_func loop, unit weights: 1.0 * x == x)."""
    G = np.zeros((Gs.shape[1], Gs.shape[2]))
    return _reduce_objgrad_into(vals, Gs, G), G


@njit(cache=True, nogil=True, error_model="numpy")
def _reduce_objgrad_into(vals, Gs, G):
    """:func:`_reduce_objgrad` into a zeroed G (m x d); returns the objective. Writing into
    a row of the caller's array, not assigning a returned one to it, spares the kernels that
    reduce many barycentres numba's broadcasting setitem, whose shape-mismatch error path
    (its message formatting) was 3.6 s of a cold compile."""
    n_ts, m, d = Gs.shape
    obj = 0.0
    for s in range(n_ts):
        obj += vals[s]
        for i in range(m):
            for k in range(d):
                G[i, k] += Gs[s, i, k]
    return obj


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_batch_serial(Z, Xs, gamma, fx):
    n_ts = Xs.shape[0]
    m, d = Z.shape
    vals = np.empty(n_ts)
    Gs = np.empty((n_ts, m, d))
    _objgrad_range(Z, Xs, gamma, fx, np.int64(0), n_ts, np.int64(1), vals, Gs)
    return _reduce_objgrad(vals, Gs)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _objgrad_par_inner(Z, Xs, gamma, fx, nw, vals, Gs):
    n_ts = Xs.shape[0]
    for w in prange(nw):
        _objgrad_range(Z, Xs, gamma, fx, np.int64(w), n_ts, nw, vals, Gs)


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_batch_par(Z, Xs, gamma, fx, nw):
    n_ts = Xs.shape[0]
    m, d = Z.shape
    vals = np.empty(n_ts)
    Gs = np.empty((n_ts, m, d))
    _objgrad_par_inner(Z, Xs, gamma, fx, nw, vals, Gs)
    return _reduce_objgrad(vals, Gs)


# --------------------------- soft-DTW values -------------------------------
@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_value(x, y, gamma, fx):
    """tslearn.metrics._soft_dtw._njit_soft_dtw(x, y, gamma) (no mask)."""
    m = x.shape[0]
    n = y.shape[0]
    yT = np.empty((x.shape[1], n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    return _sdtw_forward(x, y, gamma, np.bool_(False), fx, yT, D, R, S)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_cross_range(A, B, gamma, fx, p0, p1, step, out):
    nb = B.shape[0]
    m = A.shape[1]
    n = B.shape[1]
    yT = np.empty((A.shape[2], n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    for p in range(p0, p1, step):
        i = p // nb
        j = p - i * nb
        out[i, j] = _sdtw_forward(A[i], B[j], gamma, np.bool_(False), fx, yT, D, R, S)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_cross_serial(A, B, gamma, fx, out):
    _sdtw_cross_range(A, B, gamma, fx, np.int64(0), A.shape[0] * B.shape[0], np.int64(1),
                      out)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_cross_par_inner(A, B, gamma, fx, nw, out):
    npairs = A.shape[0] * B.shape[0]
    for w in prange(nw):
        _sdtw_cross_range(A, B, gamma, fx, np.int64(w), npairs, nw, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _unrank_upper(p, nts, k):
    """p-th pair (i, j), j >= i + k, of the row-major upper triangle."""
    i = np.int64(0)
    rem = np.int64(p)
    nts = np.int64(nts)
    k = np.int64(k)
    while rem >= nts - k - i:
        rem -= nts - k - i
        i += 1
    return i, i + k + rem


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_upper_range(X, gamma, fx, p0, p1, step, out):
    """out[i, j] = out[j, i] = soft_dtw(X[i], X[j]) for pairs i <= j."""
    nts = X.shape[0]
    n = X.shape[1]
    yT = np.empty((X.shape[2], n))
    D = np.empty((n, n))
    R = np.empty((n, n))
    S = np.empty((n, n))
    for p in range(p0, p1, step):
        i, j = _unrank_upper(p, nts, np.int64(0))
        v = _sdtw_forward(X[i], X[j], gamma, np.bool_(False), fx, yT, D, R, S)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_upper_par_inner(X, gamma, fx, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts + 1) // 2
    for w in prange(nw):
        _sdtw_upper_range(X, gamma, fx, np.int64(w), npairs, nw, out)


# --------------------------------- DTW -------------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _dtw_int_cell(i, j, D, A):
    A[i, j] = D[i, j] + min(A[i - 1, j], A[i, j - 1], A[i - 1, j - 1])


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_forward(x, y, yT, D, A):
    """tslearn.metrics._dtw._njit_dtw(x, y) (no mask) = sqrt(A[-1, -1]) with
    A[i,j] = dist + min(up, left, diag) (padded predecessors inf, (0,0): 0);
    4-row staggered schedule, same per-cell operations."""
    m = x.shape[0]
    n = y.shape[0]
    _cost_matrix(x, y, np.bool_(False), yT, D)
    A[0, 0] = D[0, 0] + min(_INF, _INF, 0.0)
    for j in range(1, n):
        A[0, j] = D[0, j] + min(_INF, A[0, j - 1], _INF)
    for i in range(1, m):
        A[i, 0] = D[i, 0] + min(A[i - 1, 0], _INF, _INF)
    i0 = 1
    while i0 + 4 <= m and n >= 5:
        for t in range(1, 4):
            for l in range(t):
                _dtw_int_cell(i0 + l, t - l, D, A)
        cs0 = A[i0, 3]
        cs1 = A[i0 + 1, 2]
        cs2 = A[i0 + 2, 1]
        cs3 = A[i0 + 3, 0]
        ps0 = A[i0, 2]
        ps1 = A[i0 + 1, 1]
        ps2 = A[i0 + 2, 0]
        Aa = A[i0 - 1]
        D0 = D[i0]
        D1 = D[i0 + 1]
        D2 = D[i0 + 2]
        D3 = D[i0 + 3]
        A0 = A[i0]
        A1 = A[i0 + 1]
        A2 = A[i0 + 2]
        A3 = A[i0 + 3]
        for t in range(4, n):
            v0 = D0[t] + min(Aa[t], cs0, Aa[t - 1])
            v1 = D1[t - 1] + min(cs0, cs1, ps0)
            v2 = D2[t - 2] + min(cs1, cs2, ps1)
            v3 = D3[t - 3] + min(cs2, cs3, ps2)
            A0[t] = v0
            A1[t - 1] = v1
            A2[t - 2] = v2
            A3[t - 3] = v3
            ps0 = cs0
            ps1 = cs1
            ps2 = cs2
            cs0 = v0
            cs1 = v1
            cs2 = v2
            cs3 = v3
        for t in range(n, n + 3):
            for l in range(t - n + 1, 4):
                _dtw_int_cell(i0 + l, t - l, D, A)
        i0 += 4
    while i0 < m:
        for j in range(1, n):
            _dtw_int_cell(i0, j, D, A)
        i0 += 1
    return math.sqrt(A[m - 1, n - 1])


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_value(x, y):
    m = x.shape[0]
    n = y.shape[0]
    yT = np.empty((x.shape[1], n))
    D = np.empty((m, n))
    A = np.empty((m, n))
    return _dtw_forward(x, y, yT, D, A)


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_upper_range(X, p0, p1, step, out):
    nts = X.shape[0]
    n = X.shape[1]
    yT = np.empty((X.shape[2], n))
    D = np.empty((n, n))
    A = np.empty((n, n))
    for p in range(p0, p1, step):
        i, j = _unrank_upper(p, nts, np.int64(1))
        v = _dtw_forward(X[i], X[j], yT, D, A)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _dtw_upper_par_inner(X, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts - 1) // 2
    for w in prange(nw):
        _dtw_upper_range(X, np.int64(w), npairs, nw, out)


def _n_workers(parallel, n_tasks):
    if not parallel:
        return 1
    import numba
    return max(1, min(numba.get_num_threads(), n_tasks))
