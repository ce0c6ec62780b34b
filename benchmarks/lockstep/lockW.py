"""Lockstep soft-DTW value on explicit SIMD vectors, register wavefront (like the scalar
kernel's 4-row staggered schedule, but every scalar there is an N-lane vector here):
R rows per block; in the steady state row r computes column t - r at step t, and keeps its
last two S vectors in registers (cs_r, ps_r).  A step in which some lane of some row is
non-trivial (not(second - max < -38)) leaves the register loop and runs the exact
tslearn arithmetic for all lanes through memory (mstep), like the scalar kernel's
_slow_step.  Prologue/epilogue triangles and short blocks use mstep as well.
Exact arithmetic per cell and lane: see lockV.py.  The steady-state source is generated
for a given R (rows unrolled by hand, so values stay in registers).
"""
import numpy as np
from numba import njit
from vec import (N, vload, vstore, vmax, vmin, vsub, vadd, vmul, vdiv, vlt, mnot, mor,
                 many, splat, lane)
from lockV import _cellv, cost_rows, cost_rows3, NEG

_TEMPLATE = '''
def group_value(x, y, m, n, d, gamma, sqrtsq, S, D, out, stats):
    ng = -gamma
    inv = 1.0 / ng
    pow2 = POW2
    W = (n + 1) * N
    for q in range(W):
        S[q] = -np.inf
    for l in range(N):
        S[l] = 0.0 * inv if pow2 else 0.0 / ng
    nslow = 0
    i0 = 0
    while i0 < m:
        rb = min(R, m - i0)
        COSTFN(x, y, i0, rb, n, d, sqrtsq, D)
        for r in range(rb):
            for l in range(N):
                S[(r + 1) * W + l] = -np.inf
        if rb < R or n <= R:
            for t in range(n + rb - 1):
                for r in range(rb):
                    j = t - r
                    if j >= 0 and j < n:
                        mstep(S, D, W, n, r, j, ng, inv)
        else:
            for t in range(R - 1):
                for r in range(t + 1):
                    mstep(S, D, W, n, r, t - r, ng, inv)
            t = R - 1
            while t < n:
{LOADS}
                while t < n:
{STEADY}
                if t < n:
                    for r in range(R):
                        mstep(S, D, W, n, r, t - r, ng, inv)
                    nslow += 1
                    t += 1
            for t in range(n, n + R - 1):
                for r in range(t - n + 1, R):
                    mstep(S, D, W, n, r, t - r, ng, inv)
        for q in range(W):
            S[q] = S[rb * W + q]
        i0 += rb
    for l in range(N):
        out[l] = lane(vload(S, n * N), l) * ng if pow2 else lane(vload(S, n * N), l) * ng
    stats[0] += nslow
'''


def _gen(R):
    # padded index of column j in row-buffer k is k*W + (j+1)*N
    loads = []
    for r in range(R):
        loads.append(f"                cs{r} = vload(S, {r + 1} * W + (t - {r}) * N)")
        if r < R - 1:
            loads.append(f"                ps{r} = vload(S, {r + 1} * W + (t - {r} - 1) * N)")
    st = []
    st.append("                    a0 = vload(S, (t + 1) * N)")
    st.append("                    c0 = vload(S, t * N)")
    for r in range(R):
        a, b, c = ("a0", "cs0", "c0") if r == 0 else (f"cs{r - 1}", f"cs{r}", f"ps{r - 1}")
        st.append(f"                    m{r} = vmax({a}, {b})")
        st.append(f"                    x{r} = vmax(m{r}, {c})")
        st.append(f"                    q{r} = vmax(vmin({a}, {b}), vmin(m{r}, {c}))")
    acc = "mnot(vlt(vsub(q0, x0), NEG))"
    for r in range(1, R):
        acc = f"mor({acc}, mnot(vlt(vsub(q{r}, x{r}), NEG)))"
    st.append(f"                    if many({acc}):")
    st.append("                        break")
    for r in range(R):
        st.append(f"                    r{r} = vadd(vload(D, {r} * n * N + (t - {r}) * N), vmul(ng, vadd(0.0, x{r})))")
        st.append(f"                    s{r} = vmul(r{r}, inv) if pow2 else vdiv(r{r}, ng)")
        st.append(f"                    vstore(S, {r + 1} * W + (t - {r} + 1) * N, s{r})")
    for r in range(R - 1):
        st.append(f"                    ps{r} = cs{r}")
    for r in range(R):
        st.append(f"                    cs{r} = s{r}")
    st.append("                    t += 1")
    return "\n".join(loads), "\n".join(st)


_cache = {}


def make(R, pow2=True, neg=NEG, cost3=True, drop0=False):
    key = (R, pow2, neg, cost3, drop0)
    if key in _cache:
        return _cache[key]

    @njit(nogil=True, error_model="numpy", boundscheck=False)
    def mstep(S, D, W, n, r, j, ng, inv):
        ub = r * W + (j + 1) * N
        cb = (r + 1) * W + j * N
        rv, sv, f = _cellv(vload(S, ub), vload(S, cb), vload(S, ub - N),
                           vload(D, r * n * N + j * N), ng, inv, pow2)
        vstore(S, cb + N, sv)

    loads, steady = _gen(R)
    src = _TEMPLATE.replace("{LOADS}", loads).replace("{STEADY}", steady) \
        .replace("POW2", str(bool(pow2))).replace("COSTFN", "cost_rows3" if cost3 else "cost_rows").replace("vadd(0.0, x", "(x" if drop0 else "vadd(0.0, x").replace("R - 1", f"{R} - 1").replace("min(R,", f"min({R},") \
        .replace("rb < R", f"rb < {R}").replace("n <= R", f"n <= {R}").replace("range(R)", f"range({R})") \
        .replace(", R)", f", {R})")
    ns = dict(np=np, N=N, vload=vload, vstore=vstore, vmax=vmax, vmin=vmin, vsub=vsub,
              vadd=vadd, vmul=vmul, vdiv=vdiv, vlt=vlt, mnot=mnot, mor=mor, many=many,
              splat=splat, lane=lane, cost_rows=cost_rows, cost_rows3=cost_rows3, mstep=mstep, NEG=neg)
    exec(compile(src, f"<lockW R={R}>", "exec"), ns)
    gv = njit(nogil=True, error_model="numpy", boundscheck=False)(ns["group_value"])

    @njit(nogil=True, error_model="numpy", boundscheck=False)
    def batch(XG, YG, m, n, d, gamma, out):
        S = np.empty((R + 1) * (n + 1) * N)
        D = np.empty(R * n * N)
        st = np.zeros(1, dtype=np.int64)
        for g in range(XG.shape[0]):
            gv(XG[g], YG[g], m, n, d, gamma, False, S, D, out[g], st)
        return st[0]

    @njit(nogil=True, error_model="numpy", boundscheck=False)
    def batch_sq(XG, YG, m, n, d, gamma, out):
        S = np.empty((R + 1) * (n + 1) * N)
        D = np.empty(R * n * N)
        st = np.zeros(1, dtype=np.int64)
        for g in range(XG.shape[0]):
            gv(XG[g], YG[g], m, n, d, gamma, True, S, D, out[g], st)
        return st[0]
    _cache[key] = (gv, batch, batch_sq, src)
    return _cache[key]


def make_batch(L=N, R=4):
    gv, batch, _, _ = make(R)
    return gv, batch
