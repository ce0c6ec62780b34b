"""The soft-DTW forward recursion, exactly: tslearn's cell arithmetic in a faster schedule.

This module owns what every soft-DTW kernel starts from: the reference ``softmin3``
(tslearn's, verbatim), the exact fast primitives (``exp`` skipped where its result is known
exactly, the out-of-line ``log`` of the non-trivial cells, one cell, the ``1 / -gamma`` scale
of a power-of-two gamma), the squared-Euclidean cost matrix and the forward pass
(``_sdtw_forward``), which fills tslearn's accumulated matrix cell for cell with the same
doubles, skipping the ``exp``/``log`` of cells that cannot change a rounded sum. The
gradient, the values of many pairs and DTW are built on it in :mod:`._kernels`.
"""

import math

import numpy as np
from numba import njit

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
    i0 = np.int64(1)
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
        t = np.int64(4)
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
