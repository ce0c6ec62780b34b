"""Lockstep soft-DTW value + gradient (barycentre objective), explicit SIMD vectors.

Lanes = N series X_l against one centre Z (tslearn _softdtw_func(Z, X_l, 1, gamma, ...)):
 forward : lockW's register wavefront, D = cdist(Z, X_l)**2 ((sqrt(.))**2), storing full
           R and D ([row][col][lane]) for the backward pass;
 backward: tslearn's _njit_soft_dtw_grad recursion, columns right to left, rows bottom to
           top, on the union over lanes of the non-zero band (same band logic as the scalar
           _sdtw_backward, with "any lane" tests):
             p_k = e_k * nan->0(exp(((R_next - R[r,c]) - D_next) / gamma))   (k = 1, 2, 3)
             E[r,c] = (p1 + p2) + p3
           a factor whose e_k is 0 in every lane is not evaluated (all its products are +0);
           otherwise it is evaluated for all lanes (0 * finite = +0 in the others, as tslearn).
 jacobian: per lane, the scalar kernel's _jacobian_product_sq_euc (fastmath, as tslearn) on
           that lane's E band (its FMA/reassociation pattern is whatever LLVM gives the same
           source; reproducing it across lanes is left for later).
"""
import numpy as np
from numba import njit
from vec import (N, vload, vstore, vmax, vmin, vsub, vadd, vmul, vlt, veq, mnot, mor,
                 many, splat, lane, sel, vfma)
from vmath import vexp
from vmath2 import vexp2
from lockV import FAST
from lockV import _cellv, cost_rows3, to_lanes, NEG
from uavwind.method.softdtw._kernels import _jacobian_product_sq_euc

_TEMPLATE = '''
def forward(x, y, m, n, d, gamma, sqrtsq, S, D, Rf):
    ng = -gamma
    inv = 1.0 / ng
    pow2 = True
    W = (n + 1) * N
    cost_rows3(x, y, 0, m, n, d, sqrtsq, D)
    for q in range(W):
        S[q] = -np.inf
    for l in range(N):
        S[l] = 0.0 * inv
    i0 = 0
    while i0 < m:
        rb = min(RR, m - i0)
        for r in range(rb):
            for l in range(N):
                S[(r + 1) * W + l] = -np.inf
        if rb < RR or n <= RR:
            for t in range(n + rb - 1):
                for r in range(rb):
                    j = t - r
                    if j >= 0 and j < n:
                        mstepf(S, D, Rf, W, n, i0, r, j, ng, inv)
        else:
            for t in range(RR - 1):
                for r in range(t + 1):
                    mstepf(S, D, Rf, W, n, i0, r, t - r, ng, inv)
            t = RR - 1
            while t < n:
{LOADS}
                while t < n:
{STEADY}
                if t < n:
                    for r in range(RR):
                        mstepf(S, D, Rf, W, n, i0, r, t - r, ng, inv)
                    t += 1
            for t in range(n, n + RR - 1):
                for r in range(t - n + 1, RR):
                    mstepf(S, D, Rf, W, n, i0, r, t - r, ng, inv)
        for q in range(W):
            S[q] = S[rb * W + q]
        i0 += rb
'''


def _gen(R):
    loads = []
    for r in range(R):
        loads.append(f"                cs{r} = vload(S, {r + 1} * W + (t - {r}) * N)")
        if r < R - 1:
            loads.append(f"                ps{r} = vload(S, {r + 1} * W + (t - {r} - 1) * N)")
    st = ["                    a0 = vload(S, (t + 1) * N)", "                    c0 = vload(S, t * N)"]
    for r in range(R):
        a, b, c = ("a0", "cs0", "c0") if r == 0 else (f"cs{r - 1}", f"cs{r}", f"ps{r - 1}")
        st += [f"                    m{r} = vmax({a}, {b})", f"                    x{r} = vmax(m{r}, {c})",
               f"                    q{r} = vmax(vmin({a}, {b}), vmin(m{r}, {c}))"]
    acc = "mnot(vlt(vsub(q0, x0), NEG))"
    for r in range(1, R):
        acc = f"mor({acc}, mnot(vlt(vsub(q{r}, x{r}), NEG)))"
    st += [f"                    if many({acc}):", "                        break"]
    for r in range(R):
        st += [f"                    k{r} = (i0 + {r}) * n * N + (t - {r}) * N",
               f"                    r{r} = vadd(vload(D, k{r}), vmul(ng, vadd(0.0, x{r})))",
               f"                    vstore(Rf, k{r}, r{r})",
               f"                    s{r} = vmul(r{r}, inv)",
               f"                    vstore(S, {r + 1} * W + (t - {r} + 1) * N, s{r})"]
    st += [f"                    ps{r} = cs{r}" for r in range(R - 1)]
    st += [f"                    cs{r} = s{r}" for r in range(R)]
    st.append("                    t += 1")
    return "\n".join(loads), "\n".join(st)


@njit(nogil=True, error_model="numpy", boundscheck=False)
def mstepf(S, D, Rf, W, n, i0, r, j, ng, inv):
    ub = r * W + (j + 1) * N
    cb = (r + 1) * W + j * N
    k = (i0 + r) * n * N + j * N
    rv, sv, f = _cellv(vload(S, ub), vload(S, cb), vload(S, ub - N), vload(D, k), ng, inv, True)
    vstore(S, cb + N, sv)
    vstore(Rf, k, rv)


@njit(nogil=True, error_model="numpy", inline="always")
def _factor(e, care, rn, r11, dn, inv_gamma):
    t = vmul(vsub(vsub(rn, r11), dn), inv_gamma)
    if FAST:
        # exp exact on the lanes with e != 0; the others get e * a = +0 as in tslearn
        a = vexp2(t, care)
        a = sel(veq(a, a), a, 0.0)          # tslearn: if isnan(a): a = 0
        return sel(care, vmul(e, a), 0.0)
    a = vexp(t)
    a = sel(veq(a, a), a, 0.0)
    return vmul(e, a)


@njit(nogil=True, error_model="numpy", boundscheck=False)
def backward(Rf, D, m, n, gamma, E, clo, chi):
    """E (m*n*N, zero on entry) <- tslearn's gradient matrix per lane, on the union band;
    clo/chi receive the computed row range of each column (for clearing)."""
    inv_gamma = 1.0 / gamma
    nN = n * N
    zero = splat(0.0)
    one = splat(1.0)
    vstore(E, (m - 1) * nN + (n - 1) * N, one)
    nxt_lo = m
    nxt_hi = -1
    for c in range(n - 1, -1, -1):
        if c == n - 1:
            r = m - 2
            prev = one
            cur_lo = m - 1
            cur_hi = m - 1
            comp_hi = m - 1
            comp_lo = m - 1
        else:
            r = min(m - 1, nxt_hi)
            prev = zero
            cur_lo = m
            cur_hi = -1
            comp_hi = r
            comp_lo = r + 1
        while r >= 0:
            e1 = prev
            e2 = vload(E, r * nN + (c + 1) * N) if c + 1 < n else zero
            e3 = vload(E, (r + 1) * nN + (c + 1) * N) if (c + 1 < n and r + 1 < m) else zero
            n1 = mnot(veq(e1, 0.0))
            n2 = mnot(veq(e2, 0.0))
            n3 = mnot(veq(e3, 0.0))
            if not many(mor(mor(n1, n2), n3)):
                if r < nxt_lo - 1:
                    break
                v = zero
            else:
                k = r * nN + c * N
                r11 = vload(Rf, k)
                p1 = zero
                p2 = zero
                p3 = zero
                if many(n1):
                    p1 = _factor(e1, n1, vload(Rf, k + nN), r11, vload(D, k + nN), inv_gamma)
                if many(n2):
                    p2 = _factor(e2, n2, vload(Rf, k + N), r11, vload(D, k + N), inv_gamma)
                if many(n3):
                    p3 = _factor(e3, n3, vload(Rf, k + nN + N), r11, vload(D, k + nN + N), inv_gamma)
                v = vadd(vadd(p1, p2), p3)
            vstore(E, r * nN + c * N, v)
            comp_lo = r
            if many(mnot(veq(v, 0.0))):
                if cur_hi < 0:
                    cur_hi = r
                cur_lo = r
            prev = v
            r -= 1
        clo[c] = comp_lo
        chi[c] = comp_hi
        nxt_lo = cur_lo
        nxt_hi = cur_hi


@njit(nogil=True, error_model="numpy", boundscheck=False)
def jacobian_lanes(Z, Xs, g0, E, m, n, clo, chi, El, jlo, jhi, Gs):
    """Per lane l: scatter its E band into the scalar matrix El, per-row first/last
    non-zero column (as _sdtw_backward's jlo/jhi), then the scalar kernel's Jacobian."""
    nN = n * N
    for l in range(N):
        s = g0 + l
        if s >= Xs.shape[0]:
            break
        for i in range(m):
            jlo[i] = n
            jhi[i] = -1
        for c in range(n - 1, -1, -1):
            for r in range(clo[c], chi[c] + 1):
                v = E[r * nN + c * N + l]
                El[r, c] = v
                if v != 0.0:
                    if jhi[r] < 0:
                        jhi[r] = c
                    jlo[r] = c
        G = Gs[s]
        for i in range(m):
            for k in range(Z.shape[1]):
                G[i, k] = 0.0
        _jacobian_product_sq_euc(Z, Xs[s], El, jlo, jhi, G)
        for c in range(n):
            for r in range(clo[c], chi[c] + 1):
                El[r, c] = 0.0


@njit(nogil=True, error_model="numpy", boundscheck=False)
def clear_band(E, n, clo, chi):
    nN = n * N
    zero = splat(0.0)
    for c in range(n):
        for r in range(clo[c], chi[c] + 1):
            vstore(E, r * nN + c * N, zero)


_cache = {}


def make(R=4, with_jac=True, jac_vec=False):
    key = (R, with_jac, jac_vec)
    if key in _cache:
        return _cache[key]
    loads, steady = _gen(R)
    src = _TEMPLATE.replace("{LOADS}", loads).replace("{STEADY}", steady).replace("RR", str(R))
    ns = dict(np=np, N=N, vload=vload, vstore=vstore, vmax=vmax, vmin=vmin, vsub=vsub,
              vadd=vadd, vmul=vmul, vlt=vlt, mnot=mnot, mor=mor, many=many, cost_rows3=cost_rows3,
              mstepf=mstepf, NEG=NEG)
    exec(compile(src, f"<lockG fwd R={R}>", "exec"), ns)
    fwd = njit(nogil=True, error_model="numpy", boundscheck=False)(ns["forward"])

    @njit(nogil=True, error_model="numpy", boundscheck=False)
    def objgrad_lanes(Z, Xs, ZL, XG, gamma, vals, Gs, S, D, Rf, E, clo, chi, El, jlo, jhi):
        """vals[s], Gs[s] for every series s of Xs (padded to groups of N lanes in XG).
        Workspaces (see workspace()) are allocated once by the caller: fresh multi-100 KB
        numpy buffers per call are mmap'd and page-faulted every time."""
        m, d = Z.shape
        n = Xs.shape[1]
        GLw = np.empty(m * d * N)
        for g in range(XG.shape[0]):
            fwd(ZL, XG[g], m, n, d, gamma, True, S, D, Rf)
            backward(Rf, D, m, n, gamma, E, clo, chi)
            last = vload(Rf, (m - 1) * n * N + (n - 1) * N)
            for l in range(N):
                if g * N + l < Xs.shape[0]:
                    vals[g * N + l] = lane(last, l)
            if with_jac and jac_vec:
                jacobian_vec(ZL, XG[g], E, m, n, d, clo, chi, jlo, jhi, GLw)
                for l in range(N):
                    s = g * N + l
                    if s < Xs.shape[0]:
                        for i in range(m):
                            for k in range(d):
                                Gs[s, i, k] = GLw[(i * d + k) * N + l]
            elif with_jac:
                jacobian_lanes(Z, Xs, g * N, E, m, n, clo, chi, El, jlo, jhi, Gs)
            clear_band(E, n, clo, chi)
    _cache[key] = (fwd, objgrad_lanes, src)
    return _cache[key]


def prep(Z, Xs):
    """ZL: Z broadcast to N lanes; XG: Xs padded (repeat last) to a multiple of N lanes."""
    ns = Xs.shape[0]
    G = -(-ns // N)
    pad = np.concatenate([Xs, np.repeat(Xs[-1:], G * N - ns, axis=0)]) if G * N > ns else Xs
    ZL = to_lanes(np.repeat(Z[None], N, axis=0))[0]
    return ZL, to_lanes(pad)


def workspace(m, n, R=4):
    return (np.empty((R + 1) * (n + 1) * N), np.empty(m * n * N), np.empty(m * n * N),
            np.zeros(m * n * N), np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64),
            np.zeros((m, n)), np.empty(m, dtype=np.int64), np.empty(m, dtype=np.int64))


@njit(nogil=True, error_model="numpy", boundscheck=False)
def jacobian_vec(ZL, XL, E, m, n, d, clo, chi, jlo, jhi, GL):
    """GL[i, k, lane] = sum over j (in order) of fma(E[i,j]*2, Z[i,k] - X[j,k], G), i.e. the
    scalar kernel's fastmath _jacobian_product_sq_euc as LLVM compiles it (d = 3 < the
    vector width, so its k loop runs the scalar FMA epilogue, sequential in j), on the
    union band of the lanes (E is exactly 0 elsewhere: fma(0, x, G) == G)."""
    nN = n * N
    for i in range(m):
        jlo[i] = n
        jhi[i] = -1
    for c in range(n):
        for r in range(clo[c], chi[c] + 1):
            if c < jlo[r]:
                jlo[r] = c
            if c > jhi[r]:
                jhi[r] = c
    zero = splat(0.0)
    for i in range(m):
        for k in range(d):
            g = zero
            zk = vload(ZL, (i * d + k) * N)
            for j in range(jlo[i], jhi[i] + 1):
                e2 = vmul(vload(E, i * nN + j * N), 2.0)
                g = vfma(e2, vsub(zk, vload(XL, (j * d + k) * N)), g)
            vstore(GL, (i * d + k) * N, g)
