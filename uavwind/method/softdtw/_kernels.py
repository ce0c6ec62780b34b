"""The numba kernels: soft-DTW value, gradient and barycentre objective, and DTW.

Each kernel computes tslearn 0.10.0's arithmetic operation for operation (cells of
``softmin3``, the backward recursion of the gradient, the squared-Euclidean Jacobian
product, DTW's cost recursion), so its results are the same doubles; what differs is
the schedule: cells that cannot change a rounded sum skip their ``exp``/``log``, the
gradient visits only its non-zero band, and batches run serially or over numba threads
(``prange``) in a fixed order. Only :mod:`uavwind.method.softdtw.metrics` calls them.
"""

import math

import numpy as np
from numba import njit, prange

from ._libm import _xexp, _xlog
from ._consts import _EXP_NEGLIGIBLE, _EXP_ZERO, _INF


# ---------------------------------------------------------------------------
# Reference (verbatim) primitives -- used only by the tests / as documentation
# ---------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _softmin3_ref(a, b, c, gamma):
    """Verbatim copy of tslearn.metrics.soft_dtw_fast._njit_softmin3."""
    a /= -gamma
    b /= -gamma
    c /= -gamma
    max_val = max(max(a, b), c)
    tmp = 0
    tmp += np.exp(a - max_val)
    tmp += np.exp(b - max_val)
    tmp += np.exp(c - max_val)
    softmin_value = -gamma * (np.log(tmp) + max_val)
    return softmin_value


# ---------------------------------------------------------------------------
# Exact fast primitives
# ---------------------------------------------------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _exp_exact(x, fx):
    """np.exp(x) bit-for-bit, skipping the evaluation where the result is
    known exactly (exp(+-0) = 1, exp(x < -745.14) = +0)."""
    if x == 0.0:
        return 1.0
    if x < _EXP_ZERO:
        return 0.0
    return _xexp(x, fx)


@njit(cache=True, nogil=True, error_model="numpy")
def _softmin_log(da, db, dc, sa, sb, sc, fx):
    """log(tmp) of tslearn's softmin3 for the non-trivial cells.

    Kept out of line (a real call, not ``inline="always"``): the hot loop stays
    small, and the inlined exp/log replicas are compiled once here instead of
    once per call site of ``_cell``. Inlining it everywhere made the cold numba
    compile of ``fit`` take 209 s instead of 16 s, for a 6% faster loop."""
    if da == 0.0:
        ea = 1.0
    elif sa:
        ea = 0.0 if db == 0.0 else _exp_exact(da, fx)
    else:
        ea = _xexp(da, fx)
    if db == 0.0:
        eb = 1.0
    elif sb:
        eb = 0.0 if da == 0.0 else _exp_exact(db, fx)
    else:
        eb = _xexp(db, fx)
    if dc == 0.0:
        ec = 1.0
    elif sc:
        ec = 0.0
    else:
        ec = _xexp(dc, fx)
    tmp = 0.0
    tmp += ea
    tmp += eb
    tmp += ec
    if tmp == 1.0:
        return 0.0
    return _xlog(tmp, fx)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cell(a, b, c, dval, gamma, fx):
    """dval + softmin3 for *already scaled* predecessors a = up/-gamma,
    b = left/-gamma, c = diag/-gamma; bit-identical to
    ``dval + _njit_softmin3(up, left, diag, gamma)`` where tslearn evaluates
    tmp = ((0 + exp(a - mx)) + exp(b - mx)) + exp(c - mx).

    A term with exponent d < -38 has exp(d) < 2**-54.  It cannot change the
    (rounded) sum when it is added to a partial sum >= 0.5; this is the case
    for the c-term (the max, 1.0, is already in the sum), for the a-term when
    b is the max and for the b-term when a is the max.  Two such terms
    (the third being the max) give tmp == 1.0 exactly.  In the remaining
    cases the term is evaluated exactly.  exp(0) == 1 and log(1) == 0."""
    mab = max(a, b)
    max_val = max(mab, c)
    # second largest of (a, b, c); rounding is monotonic, so its exponent
    # fl(second - max) bounds the two non-maximal ones from above
    second = max(min(a, b), min(mab, c))
    if second - max_val < _EXP_NEGLIGIBLE:
        lg = 0.0
    else:
        da = a - max_val
        db = b - max_val
        dc = c - max_val
        lg = _softmin_log(da, db, dc, da < _EXP_NEGLIGIBLE,
                          db < _EXP_NEGLIGIBLE, dc < _EXP_NEGLIGIBLE, fx)
    return dval + (-gamma * (lg + max_val))


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _scale(r, neg_gamma, inv_neg_gamma, pow2):
    # r / -gamma ; for gamma = 2**k the product with the (exact) reciprocal
    # is bit-identical and much cheaper than a division.
    if pow2:
        return r * inv_neg_gamma
    return r / neg_gamma


@njit(cache=True, nogil=True, error_model="numpy")
def _is_pow2(gamma):
    m, e = math.frexp(gamma)
    return m == 0.5


# ----------------------------- forward pass --------------------------------
@njit(cache=True, nogil=True, error_model="numpy")
def _cost_matrix(x, y, sqrtsq, yT, D):
    """D[i, j] = sum_k (x[i,k] - y[j,k])**2, accumulated from 0.0 in k order
    (tslearn's inline loop and scipy's cdist both do exactly this), then
    optionally (sqrt(.))**2 = cdist(x, y) ** 2.  Vectorised over j; every
    element sees the same operations in the same order."""
    m = x.shape[0]
    n = y.shape[0]
    d = x.shape[1]
    for k in range(d):
        for j in range(n):
            yT[k, j] = y[j, k]
    for i in range(m):
        row = D[i]
        for j in range(n):
            row[j] = 0.0
        for k in range(d):
            xik = x[i, k]
            yk = yT[k]
            for j in range(n):
                diff = xik - yk[j]
                row[j] += diff * diff
        if sqrtsq:
            for j in range(n):
                q = math.sqrt(row[j])
                row[j] = q * q


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _int_cell(i, j, D, R, S, gamma, neg_gamma, inv_neg_gamma, pow2, fx):
    r = _cell(S[i - 1, j], S[i, j - 1], S[i - 1, j - 1], D[i, j], gamma, fx)
    R[i, j] = r
    S[i, j] = _scale(r, neg_gamma, inv_neg_gamma, pow2)


@njit(cache=True, nogil=True, error_model="numpy")
def _slow_step(i0, t, D, R, S, gamma, fx):
    """One wavefront step (cells (i0 + l, t - l), l = 0..3) through memory;
    kept out of line so that the fast loop of _sdtw_forward has no calls."""
    neg_gamma = -gamma
    inv_neg_gamma = 1.0 / neg_gamma
    pow2 = _is_pow2(gamma)
    for l in range(4):
        _int_cell(i0 + l, t - l, D, R, S, gamma, neg_gamma, inv_neg_gamma,
                  pow2, fx)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_forward(x, y, gamma, sqrtsq, fx, yT, D, R, S):
    """Fill D (costs), R (accumulated soft-DTW matrix, unpadded) and
    S = R / -gamma; return R[-1, -1].

    Equals tslearn's _njit_accumulated_matrix (sqrtsq=False, padded, inline
    cost) and _njit_accumulated_matrix_from_distance_matrix on
    D = cdist(x, y) ** 2 (sqrtsq=True): both compute, for every cell,
    R[i,j] = D[i,j] + softmin3(R[i-1,j], R[i,j-1], R[i-1,j-1]) with inf
    outside the matrix, and R[0,0] = D[0,0] (padded: D + softmin3(inf, inf,
    0) = D + -0.0).  Interior rows are processed in blocks of 4 with a
    staggered (wavefront) schedule so that four independent dependency
    chains are in flight; each cell performs the same floating-point
    operations as tslearn's sequential loop, so the result is identical."""
    m = x.shape[0]
    n = y.shape[0]
    neg_gamma = -gamma
    inv_neg_gamma = 1.0 / neg_gamma
    pow2 = _is_pow2(gamma)
    ninf = -_INF
    _cost_matrix(x, y, sqrtsq, yT, D)
    # row 0 and column 0
    r = D[0, 0]
    R[0, 0] = r
    S[0, 0] = _scale(r, neg_gamma, inv_neg_gamma, pow2)
    for j in range(1, n):
        r = _cell(ninf, S[0, j - 1], ninf, D[0, j], gamma, fx)
        R[0, j] = r
        S[0, j] = _scale(r, neg_gamma, inv_neg_gamma, pow2)
    for i in range(1, m):
        r = _cell(S[i - 1, 0], ninf, ninf, D[i, 0], gamma, fx)
        R[i, 0] = r
        S[i, 0] = _scale(r, neg_gamma, inv_neg_gamma, pow2)
    i0 = 1
    while i0 + 4 <= m and n >= 5:
        # prologue (generic, through memory)
        for t in range(1, 4):
            for l in range(t):
                _int_cell(i0 + l, t - l, D, R, S, gamma, neg_gamma,
                          inv_neg_gamma, pow2, fx)
        # steady state: lane l computes cell (i0 + l, t - l) at step t and
        # keeps its last two S values in registers.  Steps where all four
        # cells are "trivial" (tmp == 1, no exp/log) run in a tight loop
        # without calls; other steps go through _slow_step (memory based).
        Sa = S[i0 - 1]
        D0 = D[i0]
        D1 = D[i0 + 1]
        D2 = D[i0 + 2]
        D3 = D[i0 + 3]
        R0 = R[i0]
        R1 = R[i0 + 1]
        R2 = R[i0 + 2]
        R3 = R[i0 + 3]
        S0 = S[i0]
        S1 = S[i0 + 1]
        S2 = S[i0 + 2]
        S3 = S[i0 + 3]
        mg = -gamma
        t = 4
        while t < n:
            cs0 = S0[t - 1]
            cs1 = S1[t - 2]
            cs2 = S2[t - 3]
            cs3 = S3[t - 4]
            ps0 = S0[t - 2]
            ps1 = S1[t - 3]
            ps2 = S2[t - 4]
            while t < n:
                a0 = Sa[t]
                c0 = Sa[t - 1]
                m0 = max(a0, cs0)
                x0 = max(m0, c0)
                q0 = max(min(a0, cs0), min(m0, c0))
                m1 = max(cs0, cs1)
                x1 = max(m1, ps0)
                q1 = max(min(cs0, cs1), min(m1, ps0))
                m2 = max(cs1, cs2)
                x2 = max(m2, ps1)
                q2 = max(min(cs1, cs2), min(m2, ps1))
                m3 = max(cs2, cs3)
                x3 = max(m3, ps2)
                q3 = max(min(cs2, cs3), min(m3, ps2))
                if not ((q0 - x0 < _EXP_NEGLIGIBLE) & (q1 - x1 < _EXP_NEGLIGIBLE)
                        & (q2 - x2 < _EXP_NEGLIGIBLE) & (q3 - x3 < _EXP_NEGLIGIBLE)):
                    break
                r0 = D0[t] + mg * (0.0 + x0)
                r1 = D1[t - 1] + mg * (0.0 + x1)
                r2 = D2[t - 2] + mg * (0.0 + x2)
                r3 = D3[t - 3] + mg * (0.0 + x3)
                s0 = _scale(r0, neg_gamma, inv_neg_gamma, pow2)
                s1 = _scale(r1, neg_gamma, inv_neg_gamma, pow2)
                s2 = _scale(r2, neg_gamma, inv_neg_gamma, pow2)
                s3 = _scale(r3, neg_gamma, inv_neg_gamma, pow2)
                R0[t] = r0
                R1[t - 1] = r1
                R2[t - 2] = r2
                R3[t - 3] = r3
                S0[t] = s0
                S1[t - 1] = s1
                S2[t - 2] = s2
                S3[t - 3] = s3
                ps0 = cs0
                ps1 = cs1
                ps2 = cs2
                cs0 = s0
                cs1 = s1
                cs2 = s2
                cs3 = s3
                t += 1
            if t < n:
                _slow_step(i0, t, D, R, S, gamma, fx)
                t += 1
        # epilogue
        for t in range(n, n + 3):
            for l in range(t - n + 1, 4):
                _int_cell(i0 + l, t - l, D, R, S, gamma, neg_gamma,
                          inv_neg_gamma, pow2, fx)
        i0 += 4
    while i0 < m:
        for j in range(1, n):
            _int_cell(i0, j, D, R, S, gamma, neg_gamma, inv_neg_gamma, pow2,
                      fx)
        i0 += 1
    return R[m - 1, n - 1]


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
    v = _sdtw_forward(Z, X, gamma, True, fx, yT, D, R, S)
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
    n_ts, m, d = Gs.shape
    G = np.zeros((m, d))
    obj = 0.0
    for s in range(n_ts):
        obj += vals[s]
        for i in range(m):
            for k in range(d):
                G[i, k] += Gs[s, i, k]
    return obj, G


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_batch_serial(Z, Xs, gamma, fx):
    n_ts = Xs.shape[0]
    m, d = Z.shape
    vals = np.empty(n_ts)
    Gs = np.empty((n_ts, m, d))
    _objgrad_range(Z, Xs, gamma, fx, 0, n_ts, 1, vals, Gs)
    return _reduce_objgrad(vals, Gs)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _objgrad_par_inner(Z, Xs, gamma, fx, nw, vals, Gs):
    n_ts = Xs.shape[0]
    for w in prange(nw):
        _objgrad_range(Z, Xs, gamma, fx, w, n_ts, nw, vals, Gs)


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
    return _sdtw_forward(x, y, gamma, False, fx, yT, D, R, S)


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
        out[i, j] = _sdtw_forward(A[i], B[j], gamma, False, fx, yT, D, R, S)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_cross_serial(A, B, gamma, fx, out):
    _sdtw_cross_range(A, B, gamma, fx, 0, A.shape[0] * B.shape[0], 1, out)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_cross_par_inner(A, B, gamma, fx, nw, out):
    npairs = A.shape[0] * B.shape[0]
    for w in prange(nw):
        _sdtw_cross_range(A, B, gamma, fx, w, npairs, nw, out)


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
        i, j = _unrank_upper(p, nts, 0)
        v = _sdtw_forward(X[i], X[j], gamma, False, fx, yT, D, R, S)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_upper_par_inner(X, gamma, fx, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts + 1) // 2
    for w in prange(nw):
        _sdtw_upper_range(X, gamma, fx, w, npairs, nw, out)


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
    _cost_matrix(x, y, False, yT, D)
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
        i, j = _unrank_upper(p, nts, 1)
        v = _dtw_forward(X[i], X[j], yT, D, A)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _dtw_upper_par_inner(X, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts - 1) // 2
    for w in prange(nw):
        _dtw_upper_range(X, w, npairs, nw, out)


def _n_workers(parallel, n_tasks):
    if not parallel:
        return 1
    import numba
    return max(1, min(numba.get_num_threads(), n_tasks))
