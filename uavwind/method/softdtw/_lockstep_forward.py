"""The lockstep forward engine: soft-DTW's forward recursion on ``N`` pairs per vector.

This module owns what the lockstep kernels of :mod:`._lockstep` (values, value + gradient)
start from, as :mod:`._scalar_forward` is the scalar kernels' start: one cell on every lane
(``_cellv``: tslearn's softmin3 on the lanes that need the sum, exactly ``0.0 + mx`` on the
others), the squared-Euclidean cost of lane-interleaved series by rows, by cell and by column
(the gradient's next block of costs, computed inside this block's wavefront), the exact
cell through memory (``_mstep``) and the forward pass (``_forward``): blocks of :data:`R`
rows walking a staggered wavefront in registers. :mod:`._lockstep`'s text gives the
arithmetic, the skip rule as a lane mask, the schedule and the layout.
"""

import numpy as np
from numba import njit

from ._consts import _EXP_NEGLIGIBLE
from ._scalar_forward import _is_pow2
from ._simd import (N, many, mand, mnot, mor, sel, splat, vadd, vdiv, veq, vload, vlt, vmax,
                    vmin, vmul, vsqrt, vstore, vsub)
from ._vlibm import vexp_care, vlog_care

#: Rows per block of the register wavefront.
R = 4


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cellv(a, b, c, dv, ng, inv, pow2):
    """``(r, s)`` of one cell on every lane: r = dv + softmin3 (tslearn's arithmetic on the
    lanes that need the sum, exactly 0.0 + mx on the others) and s = r / -gamma."""
    mab = vmax(a, b)
    mx = vmax(mab, c)
    mib = vmin(a, b)
    second = vmax(mib, vmin(mab, c))
    full = mnot(vlt(vsub(second, mx), _EXP_NEGLIGIBLE))
    if many(full):
        if many(mand(full, mnot(veq(vsub(mx, mx), 0.0)))):  # a lane's max is not finite
            ea = vexp_care(vsub(a, mx), full)
            eb = vexp_care(vsub(b, mx), full)
            ec = vexp_care(vsub(c, mx), full)
        else:  # two exps: the max's own term is exp(+0.0) == 1.0
            e2 = vexp_care(vsub(second, mx), full)
            e3 = vexp_care(vsub(vmin(mib, c), mx), full)
            ea = sel(veq(a, mx), 1.0, sel(veq(a, second), e2, e3))
            eb = sel(veq(b, mx), 1.0, sel(veq(b, second), e2, e3))
            ec = sel(veq(c, mx), 1.0, sel(veq(c, second), e2, e3))
        tmp = vadd(vadd(vadd(0.0, ea), eb), ec)
        lg = sel(full, vlog_care(tmp, full), 0.0)
    else:
        lg = splat(0.0)
    r = vadd(dv, vmul(ng, vadd(lg, mx)))
    if pow2:
        return r, vmul(r, inv)
    return r, vdiv(r, ng)


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _cost_rows(x, y, i0, rb, n, d, sqrtsq, D):
    """Squared Euclidean costs of rows i0 .. i0 + rb - 1 on every lane, into D's rows
    0 .. rb - 1: D[(r * n + j) * N + l] = sum_k (x[i0 + r, k] - y[j, k]) ** 2,
    accumulated from 0.0 in k order as the scalar kernel (and tslearn, and scipy's cdist) do;
    with ``sqrtsq``, ``sqrt(.) ** 2`` of it (the barycentre objective's ``cdist(Z, X) ** 2``).
    For d == 3 the row's x vectors are held in registers (LLVM cannot prove the stores to D
    leave x alone)."""
    if d == 3:
        for r in range(rb):
            base = r * n * N
            xb = (i0 + r) * 3 * N
            x0 = vload(x, xb)
            x1 = vload(x, xb + N)
            x2 = vload(x, xb + 2 * N)
            for j in range(n):
                yb = j * 3 * N
                diff = vsub(x0, vload(y, yb))
                dist = vadd(0.0, vmul(diff, diff))
                diff = vsub(x1, vload(y, yb + N))
                dist = vadd(dist, vmul(diff, diff))
                diff = vsub(x2, vload(y, yb + 2 * N))
                dist = vadd(dist, vmul(diff, diff))
                if sqrtsq:
                    q = vsqrt(dist)
                    dist = vmul(q, q)
                vstore(D, base + j * N, dist)
        return
    for r in range(rb):
        base = r * n * N
        for j in range(n):
            vstore(D, base + j * N, _cost_at(x, y, i0 + r, j, d, sqrtsq))


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _all_cost_rows(x, y, m, n, d, sqrtsq, D):
    """:func:`_cost_rows` of every block of :data:`R` rows of the ``m`` x ``n`` matrix, each
    block into D's rows over the last: the costs alone, as the benchmarks time them."""
    for i0 in range(0, m, R):
        _cost_rows(x, y, i0, min(R, m - i0), n, d, sqrtsq, D)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _cost_at(x, y, i, j, d, sqrtsq):
    """The cost of cell (i, j) on every lane, as :func:`_cost_rows` stores it (whose
    d != 3 rows are made of it, and whose d == 3 rows do the same operations in the same
    order): the squared distance accumulated from 0.0 in k order, with ``sqrtsq``
    ``sqrt(.) ** 2`` of it."""
    dist = splat(0.0)
    for k in range(d):
        diff = vsub(vload(x, (i * d + k) * N), vload(y, (j * d + k) * N))
        dist = vadd(dist, vmul(diff, diff))
    if sqrtsq:
        q = vsqrt(dist)
        dist = vmul(q, q)
    return dist


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False, inline="always")
def _mstep(S, D, W, n, r, j, ng, inv, pow2):
    """The exact cell (row r of the block, column j) through memory, D being the block's
    rows; returns its r vector (the caller stores it in the block's Rf rows, at
    ``(r * n + j) * N``, where it keeps them).
    Inlined: as a call it cost the forward pass 10-20% (the arguments and the array
    references each call), measured on a loop's barycentre inputs on an Intel Xeon. It
    takes no Rf: an array stored to under a condition inside an inlined function is
    reference-counted on every cell (an atomic increment and decrement, calls across which
    every vector register is spilled)."""
    ub = r * W + (j + 1) * N
    cb = (r + 1) * W + j * N
    rv, sv = _cellv(vload(S, ub), vload(S, cb), vload(S, ub - N), vload(D, (r * n + j) * N),
                    ng, inv, pow2)
    vstore(S, cb + N, sv)
    return rv


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _mstep_call(S, D, Rf, W, n, r, j, ng, inv, pow2, keep):
    """:func:`_mstep` as a call, for the wavefront's corners: the prologue and epilogue
    triangles and short blocks (12 of a block's 4 * 120 cells on a 120-column block).
    Inlined at those four sites too, the five copies of the exact cell (each with its
    inlined vector exp and log) made every forward pass a long compile; the hot site, the
    steady state's slow step, keeps it inlined. The same operations on the same doubles."""
    rv = _mstep(S, D, W, n, r, j, ng, inv, pow2)
    if keep:
        vstore(Rf, (r * n + j) * N, rv)
    return rv


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False, inline="always")
def _cost_column(x, y, i0, nb, j, n, d, D):
    """The costs of column j of rows i0 .. i0 + nb - 1 into D's rows 0 .. nb - 1, as
    :func:`_cost_rows` (with ``sqrtsq``) stores them: the same operations in the same order."""
    for r in range(nb):
        vstore(D, (r * n + j) * N, _cost_at(x, y, i0 + r, j, d, True))


@njit(cache=True, nogil=True, error_model="numpy", boundscheck=False)
def _forward(x, y, m, n, d, gamma, S, D, Rf):
    """The soft-DTW recursion of the N lane-interleaved pairs (x: m steps, y: n steps, d
    features); returns the vector of R[m - 1, n - 1], the soft-DTW values.

    Values (an empty Rf): D holds the :data:`R` rows of costs of a block (R * n * N
    doubles). For the gradient (``keep``: Rf of m * n * N doubles): the costs are
    ``sqrt(.) ** 2`` as in tslearn's barycentre objective, D receives the whole cost matrix
    and Rf the whole accumulated matrix (m * n * N doubles each), which the backward pass
    reads: each block's rows are written where they belong instead of over the last block's,
    so the forward pass does no more work, and the backward pass no longer computes the
    costs of its band again (three square roots a cell). S: (R + 1) * (n + 1) * N doubles.

    ``keep`` is read from Rf, not passed: as a literal ``True`` or ``False`` argument it made
    numba compile this pass, and the cell calls of its corners, once for each (two copies of
    the longest compile of the engine); its branches are the same each cell of a pass."""
    keep = Rf.size > 0
    ng = -gamma
    inv = 1.0 / ng
    pow2 = _is_pow2(gamma)
    W = (n + 1) * N
    for q in range(W):
        S[q] = -np.inf
    for l in range(N):
        S[l] = 0.0 * inv if pow2 else 0.0 / ng
    last = splat(0.0)
    i0 = np.int64(0)
    ahead = False  # this block's costs were computed during the last block's steps
    while i0 < m:
        rb = min(R, m - i0)
        # the block's rows: of the whole matrices (keep), else the block buffer and no Rf
        roff = i0 * n * N if keep else 0
        Db = D[roff:]
        Rb = Rf[roff:]
        if not ahead:
            _cost_rows(x, y, i0, rb, n, d, keep, Db)
        # keep: the next block's costs (a square root each) column by column, one column a
        # step of this block's wavefront, whose dependent chain leaves the square-root unit
        # idle (computed before the block, as for the first, they cost a third of the pass)
        nb = min(R, m - i0 - rb) if keep else 0
        ahead = nb > 0 and not (rb < R or n <= R)
        Dn = D[roff + rb * n * N:]
        for r in range(rb):
            for l in range(N):
                S[(r + 1) * W + l] = -np.inf
        if rb < R or n <= R:
            for t in range(n + rb - 1):
                for r in range(rb):
                    j = t - r
                    if j >= 0 and j < n:
                        last = _mstep_call(S, Db, Rb, W, n, r, j, ng, inv, pow2, keep)
        else:
            for t in range(R - 1):  # prologue triangle
                if ahead:
                    _cost_column(x, y, i0 + rb, nb, t, n, d, Dn)
                for r in range(t + 1):
                    _mstep_call(S, Db, Rb, W, n, r, t - r, ng, inv, pow2, keep)
            t = R - 1
            while t < n:
                cs0 = vload(S, 1 * W + t * N)
                ps0 = vload(S, 1 * W + (t - 1) * N)
                cs1 = vload(S, 2 * W + (t - 1) * N)
                ps1 = vload(S, 2 * W + (t - 2) * N)
                cs2 = vload(S, 3 * W + (t - 2) * N)
                ps2 = vload(S, 3 * W + (t - 3) * N)
                cs3 = vload(S, 4 * W + (t - 3) * N)
                while t < n:  # steady state: 4 cells per step, all cheap on every lane
                    if ahead:
                        _cost_column(x, y, i0 + rb, nb, t, n, d, Dn)
                    a0 = vload(S, (t + 1) * N)
                    c0 = vload(S, t * N)
                    m0 = vmax(a0, cs0)
                    x0 = vmax(m0, c0)
                    q0 = vmax(vmin(a0, cs0), vmin(m0, c0))
                    m1 = vmax(cs0, cs1)
                    x1 = vmax(m1, ps0)
                    q1 = vmax(vmin(cs0, cs1), vmin(m1, ps0))
                    m2 = vmax(cs1, cs2)
                    x2 = vmax(m2, ps1)
                    q2 = vmax(vmin(cs1, cs2), vmin(m2, ps1))
                    m3 = vmax(cs2, cs3)
                    x3 = vmax(m3, ps2)
                    q3 = vmax(vmin(cs2, cs3), vmin(m3, ps2))
                    if many(mor(mor(mnot(vlt(vsub(q0, x0), _EXP_NEGLIGIBLE)),
                                    mnot(vlt(vsub(q1, x1), _EXP_NEGLIGIBLE))),
                                mor(mnot(vlt(vsub(q2, x2), _EXP_NEGLIGIBLE)),
                                    mnot(vlt(vsub(q3, x3), _EXP_NEGLIGIBLE))))):
                        break
                    k0 = t * N
                    k1 = (n + t - 1) * N
                    k2 = (2 * n + t - 2) * N
                    k3 = (3 * n + t - 3) * N
                    r0 = vadd(vload(Db, k0), vmul(ng, vadd(0.0, x0)))
                    s0 = vmul(r0, inv) if pow2 else vdiv(r0, ng)
                    vstore(S, 1 * W + (t + 1) * N, s0)
                    r1 = vadd(vload(Db, k1), vmul(ng, vadd(0.0, x1)))
                    s1 = vmul(r1, inv) if pow2 else vdiv(r1, ng)
                    vstore(S, 2 * W + t * N, s1)
                    r2 = vadd(vload(Db, k2), vmul(ng, vadd(0.0, x2)))
                    s2 = vmul(r2, inv) if pow2 else vdiv(r2, ng)
                    vstore(S, 3 * W + (t - 1) * N, s2)
                    r3 = vadd(vload(Db, k3), vmul(ng, vadd(0.0, x3)))
                    s3 = vmul(r3, inv) if pow2 else vdiv(r3, ng)
                    vstore(S, 4 * W + (t - 2) * N, s3)
                    if keep:
                        vstore(Rb, k0, r0)
                        vstore(Rb, k1, r1)
                        vstore(Rb, k2, r2)
                        vstore(Rb, k3, r3)
                    ps0 = cs0
                    ps1 = cs1
                    ps2 = cs2
                    cs0 = s0
                    cs1 = s1
                    cs2 = s2
                    cs3 = s3
                    t += 1
                if t < n:  # some lane needs the full sum: this step through memory
                    for r in range(R):
                        rv = _mstep(S, Db, W, n, r, t - r, ng, inv, pow2)
                        if keep:
                            vstore(Rb, (r * n + t - r) * N, rv)
                    t += 1
            for t in range(n, n + R - 1):  # epilogue triangle (holds the block's last cell)
                for r in range(t - n + 1, R):
                    last = _mstep_call(S, Db, Rb, W, n, r, t - r, ng, inv, pow2, keep)
        for q in range(W):
            S[q] = S[rb * W + q]
        i0 += rb
    return last
