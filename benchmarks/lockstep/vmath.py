"""exp / log of glibc 2.36 (__exp_fma / __log_fma) on explicit vectors (vec.py):
the branch-free bf.py code, op for op, with selects for every special path."""
import numpy as np
from numba import njit
from vec import (N, vadd, vsub, vmul, vfma, vlt, veq, sel, f2u, u2f, i2f_i32, iadd, isub,
                 iand, ishl, ilshr, iashr, iult, iuge, iugt, ieq, ine, mand, mor, gather,
                 vload, vstore)
from bf import ETAIL, ESBIT, LINVC, LLOGC
from uavwind.method.softdtw._libm import (
    _E_INVLN2N, _E_NEGLN2HIN, _E_NEGLN2LON, _E_C2, _E_C3, _E_C4, _E_C5, _E_SHIFT,
    _TWO_M1022, _TWO_P1009, _TWO_P52, _L_LN2HI, _L_LN2LO, _L_A0, _L_A1, _L_A2, _L_A3,
    _L_A4, _L_B0, _L_B1, _L_B2, _L_B3, _L_B4, _L_B5, _L_B6, _L_B7, _L_B8, _L_B9, _L_B10,
    _TWO27)

U = np.uint64
INF = np.inf
NAN = np.nan


@njit(nogil=True, error_model="numpy", inline="always")
def vexp(x):
    ix = f2u(x)
    abstop = iand(ilshr(ix, U(52)), U(0x7ff))
    z = vfma(x, _E_INVLN2N, _E_SHIFT)
    ki = f2u(z)
    kd = vsub(z, _E_SHIFT)
    r = vfma(kd, _E_NEGLN2HIN, x)
    r = vfma(kd, _E_NEGLN2LON, r)
    p23 = vfma(r, _E_C3, _E_C2)
    j = iand(ki, U(0x7f))
    t1 = vadd(r, gather(ETAIL, j))
    sbits = iadd(gather(ESBIT, j), ishl(ki, U(45)))
    r2 = vmul(r, r)
    p45 = vfma(r, _E_C5, _E_C4)
    tmp = vfma(p23, r2, t1)
    r4 = vmul(r2, r2)
    tmp = vfma(r4, p45, tmp)
    scale = u2f(sbits)
    res = vfma(scale, tmp, scale)
    # specialcase k < 0
    sc = u2f(iadd(sbits, U(0x3fe0000000000000)))
    st = vmul(tmp, sc)
    y = vadd(sc, st)
    hi = vadd(y, 1.0)
    lo = vadd(vsub(sc, y), st)
    lo = vadd(vadd(vsub(1.0, hi), y), lo)
    y2 = vsub(vadd(lo, hi), 1.0)
    y2 = sel(veq(y2, 0.0), 0.0, y2)
    yn = sel(vlt(y, 1.0), y2, y)
    sneg = vmul(yn, _TWO_M1022)
    # specialcase k > 0
    scp = u2f(isub(sbits, U(0x3f10000000000000)))
    spos = vmul(vfma(scp, tmp, scp), _TWO_P1009)
    spec = sel(ieq(iand(ki, U(0x80000000)), U(0)), spos, sneg)
    res = sel(ieq(abstop, U(0x408)), spec, res)
    res = sel(iult(abstop, U(0x3c9)), vadd(1.0, x), res)
    hv = sel(vlt(x, 0.0), 0.0, INF)
    hv = sel(mand(ieq(abstop, U(0x7ff)), ine(ix, U(0xfff0000000000000))), vadd(1.0, x), hv)
    return sel(iuge(abstop, U(0x409)), hv, res)


@njit(nogil=True, error_model="numpy", inline="always")
def vlog(x):
    ix = f2u(x)
    near = iult(isub(ix, U(0x3fee000000000000)), U(0x3090000000000))
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
    vnear = vadd(hi, y)
    vnear = sel(ieq(ix, U(0x3ff0000000000000)), 0.0, vnear)
    top = ilshr(ix, U(48))
    bad = iugt(isub(top, U(0x10)), U(0x7fdf))
    ixs = isub(f2u(vmul(x, _TWO_P52)), U(0x0340000000000000))
    ixm = sel(bad, ixs, ix)
    tmp = isub(ixm, U(0x3fe6000000000000))
    i = iand(ilshr(tmp, U(45)), U(0x7f))
    k = iashr(tmp, U(52))
    iz = isub(ixm, iand(tmp, U(0xfff0000000000000)))
    invc = gather(LINVC, i)
    logc = gather(LLOGC, i)
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
    vmain = vadd(yy, h)
    zero = ieq(ishl(ix, U(1)), U(0))
    sv = sel(ieq(ix, U(0x7ff0000000000000)), x, NAN)
    sv = sel(zero, -INF, sv)
    isspec = mand(bad, mor(mor(ine(iand(top, U(0x8000)), U(0)),
                               ieq(iand(top, U(0x7ff0)), U(0x7ff0))), zero))
    vmain = sel(isspec, sv, vmain)
    return sel(near, vnear, vmain)


@njit(nogil=True, error_model="numpy")
def vexp_arr(x, out):
    for q in range(0, x.shape[0] - N + 1, N):
        vstore(out, q, vexp(vload(x, q)))


@njit(nogil=True, error_model="numpy")
def vlog_arr(x, out):
    for q in range(0, x.shape[0] - N + 1, N):
        vstore(out, q, vlog(vload(x, q)))
