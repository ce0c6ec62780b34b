"""glibc 2.36's ``exp`` and ``log`` (``__exp_fma``/``__log_fma``) on explicit vectors, lane
for lane bit-identical to the scalar replicas of :mod:`._libm` and so to libm.

:func:`vexp` and :func:`vlog` compute every path (main, subnormal and overflow special cases,
the near-1 ``log`` polynomial, zero, inf, NaN) for every lane and select, branch-free; they
are real calls, not inlined: they are rare, and inlined at every call site they made the
cold compile of a loop's kernels 24-26 s instead of 20-24 s (two cold runs each).
:func:`vexp_care` and :func:`vlog_care` are what the kernels call: the main path plus cheap
selects, and the rare paths only when a lane whose result is used (``care``) needs one;
lanes outside ``care`` may get any value (the caller selects them away). Table lookups are
gathers from :mod:`._libm`'s tables.
"""
import numpy as np
from numba import njit

from ._libm import (_E_C2, _E_C3, _E_C4, _E_C5, _E_INVLN2N, _E_NEGLN2HIN, _E_NEGLN2LON,
                    _E_SHIFT, _EXP_TAB, _L_A0, _L_A1, _L_A2, _L_A3, _L_A4, _L_B0, _L_B1,
                    _L_B2, _L_B3, _L_B4, _L_B5, _L_B6, _L_B7, _L_B8, _L_B9, _L_B10, _L_LN2HI,
                    _L_LN2LO, _LOG_TAB, _TWO27, _TWO_M1022, _TWO_P52, _TWO_P1009)
from ._simd import (gather, gather2, i2f_i32, iadd, iand, iashr, ieq, ilshr, ine, ishl, isub,
                    iuge, iugt, iult, many, mand, mnot, mor, sel, u2f, f2u, vadd, veq, vfma,
                    vlt, vmul, vsub)

U = np.uint64
INF = np.inf
NAN = np.nan
# exp: (tail, scale bits) of each of the 128 table entries, side by side and apart
_EXP_PAIRS = _EXP_TAB.view(np.float64).copy()
_ETAIL = np.ascontiguousarray(_EXP_TAB[0::2]).view(np.float64)
_ESBIT = np.ascontiguousarray(_EXP_TAB[1::2])
# log: (1/c, log c) of each of the 128 table entries, side by side and apart
_LOG_PAIRS = _LOG_TAB.copy()
_LINVC = np.ascontiguousarray(_LOG_TAB[0::2])
_LLOGC = np.ascontiguousarray(_LOG_TAB[1::2])

@njit(cache=True, nogil=True, error_model="numpy")
def vexp(x):
    """== glibc exp(x) on every lane, every path computed and selected."""
    ix = f2u(x)
    abstop = iand(ilshr(ix, U(52)), U(0x7ff))
    z = vfma(x, _E_INVLN2N, _E_SHIFT)
    ki = f2u(z)
    kd = vsub(z, _E_SHIFT)
    r = vfma(kd, _E_NEGLN2HIN, x)
    r = vfma(kd, _E_NEGLN2LON, r)
    p23 = vfma(r, _E_C3, _E_C2)
    j = iand(ki, U(0x7f))
    t1 = vadd(r, gather(_ETAIL, j))
    sbits = iadd(gather(_ESBIT, j), ishl(ki, U(45)))
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


@njit(cache=True, nogil=True, error_model="numpy")
def vlog(x):
    """== glibc log(x) on every lane, every path computed and selected."""
    ix = f2u(x)
    near = iult(isub(ix, U(0x3fee000000000000)), U(0x3090000000000))
    vnear = _log_near(x)
    top = ilshr(ix, U(48))
    bad = iugt(isub(top, U(0x10)), U(0x7fdf))
    ixs = isub(f2u(vmul(x, _TWO_P52)), U(0x0340000000000000))
    ixm = sel(bad, ixs, ix)
    tmp = isub(ixm, U(0x3fe6000000000000))
    i = iand(ilshr(tmp, U(45)), U(0x7f))
    k = iashr(tmp, U(52))
    iz = isub(ixm, iand(tmp, U(0xfff0000000000000)))
    invc = gather(_LINVC, i)
    logc = gather(_LLOGC, i)
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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def vexp_care(x, care):
    """== glibc exp(x) on every `care` lane."""
    ix = f2u(x)
    abstop = iand(ilshr(ix, U(52)), U(0x7ff))
    z = vfma(x, _E_INVLN2N, _E_SHIFT)
    ki = f2u(z)
    kd = vsub(z, _E_SHIFT)
    r = vfma(kd, _E_NEGLN2HIN, x)
    r = vfma(kd, _E_NEGLN2LON, r)
    p23 = vfma(r, _E_C3, _E_C2)
    tail, sb = gather2(_EXP_PAIRS, iand(ki, U(0x7f)))
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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _log_main(x):
    ix = f2u(x)
    tmp = isub(ix, U(0x3fe6000000000000))
    i = iand(ilshr(tmp, U(45)), U(0x7f))
    k = iashr(tmp, U(52))
    iz = isub(ix, iand(tmp, U(0xfff0000000000000)))
    invc, logc = gather2(_LOG_PAIRS, i)
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


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def vlog_care(x, care):
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
