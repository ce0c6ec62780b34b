"""Branch-free (select-only) replicas of glibc 2.36 __exp_fma / __log_fma.

Same constants and operation sequence as uavwind's _libm._exp_glibc/_log_glibc, but every
path (main, |x|<2^-54, specialcase k<0 / k>0, |x|>=1024/inf/nan; log near-1, table path,
subnormal/zero/neg/inf/nan) is computed unconditionally and chosen with selects, so a
loop over lanes has no control flow and can be vectorised (table loads become gathers).
"""
import numpy as np
from numba import njit
from uavwind.method.softdtw._libm import (
    _fma, _f2u, _u2f, _EXP_TAB, _LOG_TAB,
    _E_INVLN2N, _E_NEGLN2HIN, _E_NEGLN2LON, _E_C2, _E_C3, _E_C4, _E_C5, _E_SHIFT,
    _TWO_M1022, _TWO_P1009, _TWO_P52, _L_LN2HI, _L_LN2LO, _L_A0, _L_A1, _L_A2, _L_A3,
    _L_A4, _L_B0, _L_B1, _L_B2, _L_B3, _L_B4, _L_B5, _L_B6, _L_B7, _L_B8, _L_B9, _L_B10,
    _TWO27)

ETAIL = np.ascontiguousarray(_EXP_TAB[0::2]).view(np.float64)   # 128 tails (as double)
ESBIT = np.ascontiguousarray(_EXP_TAB[1::2])                    # 128 scale bits (uint64)
LINVC = np.ascontiguousarray(_LOG_TAB[0::2])
LLOGC = np.ascontiguousarray(_LOG_TAB[1::2])
INF = np.inf
NAN = np.nan
U = np.uint64


@njit(nogil=True, error_model="numpy", inline="always")
def exp_bf(x):
    ix = _f2u(x)
    abstop = (ix >> U(52)) & U(0x7ff)
    z = _fma(x, _E_INVLN2N, _E_SHIFT)
    ki = _f2u(z)
    kd = z - _E_SHIFT
    r = _fma(kd, _E_NEGLN2HIN, x)
    r = _fma(kd, _E_NEGLN2LON, r)
    p23 = _fma(r, _E_C3, _E_C2)
    j = ki & U(0x7f)
    t1 = r + ETAIL[j]
    sbits = ESBIT[j] + (ki << U(45))
    r2 = r * r
    p45 = _fma(r, _E_C5, _E_C4)
    tmp = _fma(p23, r2, t1)
    r4 = r2 * r2
    tmp = _fma(r4, p45, tmp)
    scale = _u2f(sbits)
    res = _fma(scale, tmp, scale)
    # specialcase, k < 0
    sc = _u2f(sbits + U(0x3fe0000000000000))
    st = tmp * sc
    y = sc + st
    hi = y + 1.0
    lo = (sc - y) + st
    lo = ((1.0 - hi) + y) + lo
    y2 = (lo + hi) - 1.0
    y2 = 0.0 if y2 == 0.0 else y2
    yn = y2 if y < 1.0 else y
    sneg = yn * _TWO_M1022
    # specialcase, k > 0
    scp = _u2f(sbits - U(0x3f10000000000000))
    spos = _fma(scp, tmp, scp) * _TWO_P1009
    spec = spos if (ki & U(0x80000000)) == U(0) else sneg
    res = spec if abstop == U(0x408) else res
    res = (1.0 + x) if abstop < U(0x3c9) else res
    # |x| >= 1024, inf, nan
    hv = 0.0 if x < 0.0 else INF
    hv = (1.0 + x) if (abstop == U(0x7ff)) & (ix != U(0xfff0000000000000)) else hv
    res = hv if abstop >= U(0x409) else res
    return res


@njit(nogil=True, error_model="numpy", inline="always")
def log_bf(x):
    ix = _f2u(x)
    # near-1 path
    near = (ix - U(0x3fee000000000000)) < U(0x3090000000000)
    r = x - 1.0
    r2 = r * r
    r3 = r * r2
    p1 = _fma(r2, _L_B3, _fma(r, _L_B2, _L_B1))
    p2 = _fma(r2, _L_B6, _fma(r, _L_B5, _L_B4))
    p3 = _fma(r3, _L_B10, _fma(r2, _L_B9, _fma(r, _L_B8, _L_B7)))
    q = _fma(_fma(p3, r3, p2), r3, p1)
    t = _fma(r, _TWO27, r)
    rhi = _fma(-_TWO27, r, t)
    rhi2 = rhi * rhi
    rlo = r - rhi
    hi = _fma(rhi2, _L_B0, r)
    lo = _fma(rhi2, _L_B0, r - hi)
    lo = _fma(_L_B0 * rlo, r + rhi, lo)
    y = _fma(q, r3, lo)
    vnear = hi + y
    vnear = 0.0 if ix == U(0x3ff0000000000000) else vnear
    # table path (positive subnormals normalised first)
    top = ix >> U(48)
    bad = (top - U(0x10)) > U(0x7fdf)
    ixs = _f2u(x * _TWO_P52) - U(0x0340000000000000)
    ixm = ixs if bad else ix
    tmp = ixm - U(0x3fe6000000000000)
    i = (tmp >> U(45)) & U(0x7f)
    k = np.int64(tmp) >> np.int64(52)
    iz = ixm - (tmp & U(0xfff0000000000000))
    invc = LINVC[i]
    logc = LLOGC[i]
    z = _u2f(iz)
    kd = np.float64(np.int32(k))
    w = _fma(kd, _L_LN2HI, logc)
    rr = _fma(z, invc, -1.0)
    p12 = _fma(rr, _L_A2, _L_A1)
    h = rr + w
    rr2 = rr * rr
    l2 = (w - h) + rr
    l2 = _fma(kd, _L_LN2LO, l2)
    rr3 = rr * rr2
    p34 = _fma(rr, _L_A4, _L_A3)
    lo2 = _fma(rr2, _L_A0, l2)
    p = _fma(p34, rr2, p12)
    yy = _fma(rr3, p, lo2)
    vmain = yy + h
    # special inputs: zero -> -inf, +inf -> x, negative / nan -> nan
    sv = NAN
    sv = x if ix == U(0x7ff0000000000000) else sv
    sv = -INF if (ix * U(2)) == U(0) else sv
    isspec = bad & (((top & U(0x8000)) != U(0)) | ((top & U(0x7ff0)) == U(0x7ff0)) | ((ix * U(2)) == U(0)))
    vmain = sv if isspec else vmain
    return vnear if near else vmain


@njit(nogil=True, error_model="numpy")
def exp_arr(x, out):
    for i in range(x.shape[0]):
        out[i] = exp_bf(x[i])


@njit(nogil=True, error_model="numpy")
def log_arr(x, out):
    for i in range(x.shape[0]):
        out[i] = log_bf(x[i])


@njit(nogil=True, error_model="numpy")
def np_exp_arr(x, out):
    for i in range(x.shape[0]):
        out[i] = np.exp(x[i])


@njit(nogil=True, error_model="numpy")
def np_log_arr(x, out):
    for i in range(x.shape[0]):
        out[i] = np.log(x[i])
