"""Lockstep soft-DTW value on explicit SIMD vectors (vec.py): N pairs per vector
(one lane per (series, centre) pair), R-row staggered wavefront through a padded
[cell][lane] buffer, scaled by 1/-gamma like the scalar kernel's S.

Per cell (i, j), every lane (a = up, b = left, c = diag, all R/-gamma):
  mx = max(max(a,b),c); sec = max(min(a,b), min(max(a,b),c))
  if no lane has not(sec - mx < -38):  lg = 0.0             (exact: tmp == 1.0)
  else, all lanes, as tslearn: lg = log(((0.0 + exp(a-mx)) + exp(b-mx)) + exp(c-mx))
  r = D + (-gamma) * (lg + mx);   S = r * (1/-gamma)   (gamma = 2**k)   [or r / -gamma]
Padded layout (tslearn's _njit_accumulated_matrix): row -1 = -inf except (-1,-1) = 0/-gamma,
column -1 = -inf, so (0,0) gets D + -gamma*(0 + -0.0) = D and borders run the same code.
"""
import numpy as np
from numba import njit
from vec import (N, vload, vstore, vmax, vmin, vsub, vadd, vmul, vdiv, vlt, mnot, many,
                 splat, lane, sel, vsqrt)
from vmath import vexp, vlog
from vmath2 import vexp2, vlog2
import os
FAST = os.environ.get('LOCK_FASTMATH_PATHS', '1') == '1'   # vexp2/vlog2 (care masks) vs vexp/vlog
from uavwind.method.softdtw._kernels import _is_pow2

NEG = -38.0


@njit(nogil=True, error_model="numpy", inline="always")
def _cellv(a, b, c, dv, ng, inv, pow2):
    mab = vmax(a, b)
    mx = vmax(mab, c)
    sec = vmax(vmin(a, b), vmin(mab, c))
    nt = mnot(vlt(vsub(sec, mx), NEG))
    if many(nt):
        if FAST:
            # exact on the non-trivial lanes; trivial lanes keep lg = 0.0 (exact for them)
            tmp = vadd(0.0, vexp2(vsub(a, mx), nt))
            tmp = vadd(tmp, vexp2(vsub(b, mx), nt))
            tmp = vadd(tmp, vexp2(vsub(c, mx), nt))
            lg = sel(nt, vlog2(tmp, nt), 0.0)
        else:
            tmp = vadd(0.0, vexp(vsub(a, mx)))
            tmp = vadd(tmp, vexp(vsub(b, mx)))
            tmp = vadd(tmp, vexp(vsub(c, mx)))
            lg = vlog(tmp)
        full = 1
    else:
        lg = splat(0.0)
        full = 0
    r = vadd(dv, vmul(ng, vadd(lg, mx)))
    if pow2:
        s = vmul(r, inv)
    else:
        s = vdiv(r, ng)
    return r, s, full


@njit(nogil=True, error_model="numpy", boundscheck=False)
def cost_rows(x, y, i0, rb, n, d, sqrtsq, D):
    """D[r*n*N + j*N + l] = sum_k (x[i0+r,k,l] - y[j,k,l])**2 accumulated from 0.0."""
    for r in range(rb):
        base = r * n * N
        for j in range(n):
            dist = splat(0.0)
            for k in range(d):
                diff = vsub(vload(x, ((i0 + r) * d + k) * N), vload(y, (j * d + k) * N))
                dist = vadd(dist, vmul(diff, diff))
            if sqrtsq:
                q = vsqrt(dist)
                dist = vmul(q, q)
            vstore(D, base + j * N, dist)


def make(R):
    @njit(nogil=True, error_model="numpy", boundscheck=False)
    def group_value(x, y, m, n, d, gamma, sqrtsq, S, D, out, stats):
        """x: (m*d*N,), y: (n*d*N,) lane-interleaved series; S: ((R+1)*(n+1)*N,),
        D: (R*n*N,) workspaces; out: (N,) receives R[m-1, n-1] per lane."""
        ng = -gamma
        inv = 1.0 / ng
        pow2 = _is_pow2(gamma)
        W = (n + 1) * N
        for q in range(W):
            S[q] = -np.inf
        for l in range(N):
            S[l] = 0.0 / ng if not pow2 else 0.0 * inv
        nfull = 0
        i0 = 0
        last = splat(0.0)
        while i0 < m:
            rb = min(R, m - i0)
            cost_rows(x, y, i0, rb, n, d, sqrtsq, D)
            for r in range(rb):
                for l in range(N):
                    S[(r + 1) * W + l] = -np.inf
            for t in range(n + rb - 1):
                for r in range(R):
                    j = t - r
                    if r < rb and j >= 0 and j < n:
                        ub = r * W + (j + 1) * N
                        cb = (r + 1) * W + j * N
                        a = vload(S, ub)
                        b = vload(S, cb)
                        c = vload(S, ub - N)
                        rv, sv, f = _cellv(a, b, c, vload(D, r * n * N + j * N), ng, inv, pow2)
                        vstore(S, cb + N, sv)
                        nfull += f
                        last = rv
            for q in range(W):
                S[q] = S[rb * W + q]
            i0 += rb
        for l in range(N):
            out[l] = lane(last, l)
        stats[0] += nfull
    return group_value


def to_lanes(P, L=N):
    """P: (G*N, m, d) -> (G, m*d*N) lane-interleaved."""
    G = P.shape[0] // N
    return np.ascontiguousarray(P[:G * N].reshape(G, N, P.shape[1], P.shape[2])
                                .transpose(0, 2, 3, 1).reshape(G, -1))


_cache = {}
def make_batch(L=N, R=4, sqrtsq=False):
    assert L == N
    key = (R, sqrtsq)
    if key not in _cache:
        gv = make(R)

        @njit(nogil=True, error_model="numpy", boundscheck=False)
        def batch(XG, YG, m, n, d, gamma, out):
            S = np.empty((R + 1) * (n + 1) * N)
            D = np.empty(R * n * N)
            st = np.zeros(1, dtype=np.int64)
            for g in range(XG.shape[0]):
                gv(XG[g], YG[g], m, n, d, gamma, sqrtsq, S, D, out[g], st)
            return st[0]
        _cache[key] = (gv, batch)
    return _cache[key]


@njit(nogil=True, error_model="numpy", boundscheck=False)
def cost_rows3(x, y, i0, rb, n, d, sqrtsq, D):
    """cost_rows for d == 3 with the row's x vectors held in registers (the vstore to D
    could alias x as far as LLVM knows, so it would reload them every j otherwise)."""
    if d != 3:
        cost_rows(x, y, i0, rb, n, d, sqrtsq, D)
        return
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
