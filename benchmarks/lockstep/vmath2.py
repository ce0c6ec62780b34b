"""Faster exact vector exp/log: main path always, rare paths only when a lane we care
about needs them (branch on "any lane"), table pairs fetched with one 16-byte load per
lane.  `care` = lanes whose result is used; other lanes may get garbage (callers select)."""
import numpy as np
from numba import njit
from vec import (N, vadd, vsub, vmul, vfma, vlt, sel, f2u, u2f, i2f_i32, iadd, isub,
                 iand, ishl, ilshr, iashr, iult, iuge, iugt, ieq, mand, mnot, many,
                 gather2, vload, vstore, mtrue)
from vmath import vexp, vlog
from uavwind.method.softdtw._libm import (_EXP_TAB, _LOG_TAB, _E_INVLN2N, _E_NEGLN2HIN, _E_NEGLN2LON, _E_C2,
    _E_C3, _E_C4, _E_C5, _E_SHIFT, _L_LN2HI, _L_LN2LO, _L_A0, _L_A1, _L_A2, _L_A3, _L_A4,
    _L_B0, _L_B1, _L_B2, _L_B3, _L_B4, _L_B5, _L_B6, _L_B7, _L_B8, _L_B9, _L_B10, _TWO27)

EXPT = _EXP_TAB.view(np.float64).copy()      # (tail, sbits) pairs
LOGT = _LOG_TAB.copy()                        # (invc, logc) pairs
U = np.uint64


@njit(nogil=True, error_model="numpy", inline="always")
def vexp2(x, care):
    """== glibc exp(x) on every `care` lane."""
    ix = f2u(x)
    abstop = iand(ilshr(ix, U(52)), U(0x7ff))
    z = vfma(x, _E_INVLN2N, _E_SHIFT)
    ki = f2u(z)
    kd = vsub(z, _E_SHIFT)
    r = vfma(kd, _E_NEGLN2HIN, x)
    r = vfma(kd, _E_NEGLN2LON, r)
    p23 = vfma(r, _E_C3, _E_C2)
    tail, sb = gather2(EXPT, iand(ki, U(0x7f)))
    t1 = vadd(r, tail)
    sbits = iadd(f2u(sb), ishl(ki, U(45)))
    r2 = vmul(r, r)
    p45 = vfma(r, _E_C5, _E_C4)
    tmp = vfma(p23, r2, t1)
    r4 = vmul(r2, r2)
    tmp = vfma(r4, p45, tmp)
    scale = u2f(sbits)
    res = vfma(scale, tmp, scale)
    res = sel(iult(abstop, U(0x3c9)), vadd(1.0, x), res)     # |x| < 2^-54: 1 + x
    under = vlt(x, -746.0)                                     # exp(x) == +0 exactly
    res = sel(under, 0.0, res)
    if many(mand(care, mand(iuge(abstop, U(0x408)), mnot(under)))):
        return sel(under, 0.0, vexp(x))                        # specialcase / inf / nan
    return res


@njit(nogil=True, error_model="numpy", inline="always")
def _log_near(x):
    r = vsub(x, 1.0)
    r2 = vmul(r, r)
    r3 = vmul(r, r2)
    p1 = vfma(r2, _L_B3, vfma(r, _L_B2, _L_B1))
    p2 = vfma(r2, _L_B6, vfma(r, _L_B5, _L_B4))
    p3 = vfma(r3, _L_B10, vfma(r2, _L_B9, vfma(r, _L_B8, _L_B7)))
    q = vfma(vfma(p3, r3, p2), r3, p1)
    t = vfma(r, _TWO27, r)
    rhi = vfma(-_TWO27, r, t)
    rhi2 = vmul(rhi, rhi)
    rlo = vsub(r, rhi)
    hi = vfma(rhi2, _L_B0, r)
    lo = vfma(rhi2, _L_B0, vsub(r, hi))
    lo = vfma(vmul(_L_B0, rlo), vadd(r, rhi), lo)
    y = vfma(q, r3, lo)
    return sel(ieq(f2u(x), U(0x3ff0000000000000)), 0.0, vadd(hi, y))


@njit(nogil=True, error_model="numpy", inline="always")
def _log_main(x):
    ix = f2u(x)
    tmp = isub(ix, U(0x3fe6000000000000))
    i = iand(ilshr(tmp, U(45)), U(0x7f))
    k = iashr(tmp, U(52))
    iz = isub(ix, iand(tmp, U(0xfff0000000000000)))
    invc, logc = gather2(LOGT, i)
    z = u2f(iz)
    kd = i2f_i32(k)
    w = vfma(kd, _L_LN2HI, logc)
    rr = vfma(z, invc, -1.0)
    p12 = vfma(rr, _L_A2, _L_A1)
    h = vadd(rr, w)
    rr2 = vmul(rr, rr)
    l2 = vadd(vsub(w, h), rr)
    l2 = vfma(kd, _L_LN2LO, l2)
    rr3 = vmul(rr, rr2)
    p34 = vfma(rr, _L_A4, _L_A3)
    lo2 = vfma(rr2, _L_A0, l2)
    p = vfma(p34, rr2, p12)
    yy = vfma(rr3, p, lo2)
    return vadd(yy, h)


@njit(nogil=True, error_model="numpy", inline="always")
def vlog2(x, care):
    """== glibc log(x) on every `care` lane; only the paths some care lane needs run."""
    ix = f2u(x)
    top = ilshr(ix, U(48))
    bad = mand(care, iugt(isub(top, U(0x10)), U(0x7fdf)))
    if many(bad):
        return vlog(x)
    near = iult(isub(ix, U(0x3fee000000000000)), U(0x3090000000000))
    if not many(mand(care, near)):
        return _log_main(x)
    if not many(mand(care, mnot(near))):
        return _log_near(x)
    return sel(near, _log_near(x), _log_main(x))


@njit(nogil=True, error_model="numpy")
def vexp2_arr(x, out):
    for q in range(0, x.shape[0] - N + 1, N):
        vstore(out, q, vexp2(vload(x, q), mtrue()))


@njit(nogil=True, error_model="numpy")
def vlog2_arr(x, out):
    for q in range(0, x.shape[0] - N + 1, N):
        vstore(out, q, vlog2(vload(x, q), mtrue()))
