"""Explicit SIMD vectors for numba, the types and operations of the lockstep kernels.

``<N x double>`` (:data:`vf`), ``<N x i64>`` (:data:`vi`) and ``<N x i1>`` (:data:`vm`) are
numba types; the functions below are numba intrinsics that emit LLVM vector IR through
llvmlite, so a lane's arithmetic is vector code whatever LLVM's auto-vectoriser decides
(numba's auto-vectoriser left the same loops scalar). ``N`` is fixed per process from the
features numba compiles for (the host's, or ``NUMBA_CPU_FEATURES``): 8 lanes with AVX-512F,
4 otherwise (LLVM splits or widens as the target needs).

Every operation is IEEE-exact: no fast-math flags, so LLVM may not contract or reassociate.
:func:`vmax` and :func:`vmin` reproduce numba's builtin ``max``/``min`` (``max(a, b) = b if
b > a else a``), which the scalar kernels use. Only the lockstep kernels import this module.
"""
from llvmlite import binding as _llvm
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.core.extending import intrinsic, models, register_model


def lanes_for(features):
    """float64 lanes per vector for code compiled with the LLVM feature string ``features``
    (``"+avx2,-avx512f,..."``, the last mention of a feature decides): 8 with AVX-512F, else 4."""
    on = False
    for f in features.split(","):
        f = f.strip()
        if f in ("+avx512f", "-avx512f"):
            on = f[0] == "+"
    return 8 if on else 4


def _target_lanes():
    """float64 lanes of the vector unit numba compiles for: the host's, unless
    ``NUMBA_CPU_FEATURES`` names other features (``NUMBA_CPU_NAME`` alone keeps the host's
    features, AVX-512 included, where the host has it). Numba's on-disk cache keys its
    entries on the CPU name and these features, so a kernel compiled for one lane count is
    never loaded under the other."""
    from numba.core import config
    try:
        if config.CPU_FEATURES is not None:
            return lanes_for(config.CPU_FEATURES)
        return 8 if _llvm.get_host_cpu_features().get("avx512f", False) else 4
    except Exception:  # pragma: no cover - a platform llvmlite cannot query
        return 4


#: Lanes per vector: (series, centre) pairs computed in lockstep.
N = _target_lanes()


class VecF(types.Type):
    """numba type of ``<N x double>``."""

    def __init__(self):
        super().__init__(name=f"VecF{N}")


class VecI(types.Type):
    """numba type of ``<N x i64>`` (bit patterns and table indices)."""

    def __init__(self):
        super().__init__(name=f"VecI{N}")


class VecM(types.Type):
    """numba type of ``<N x i1>``, a lane mask."""

    def __init__(self):
        super().__init__(name=f"VecM{N}")


vf = VecF()
vi = VecI()
vm = VecM()
LF = ir.VectorType(ir.DoubleType(), N)
LI = ir.VectorType(ir.IntType(64), N)
LM = ir.VectorType(ir.IntType(1), N)


@register_model(VecF)
class _MF(models.PrimitiveModel):
    def __init__(self, dmm, fe):
        super().__init__(dmm, fe, LF)


@register_model(VecI)
class _MI(models.PrimitiveModel):
    def __init__(self, dmm, fe):
        super().__init__(dmm, fe, LI)


@register_model(VecM)
class _MM(models.PrimitiveModel):
    def __init__(self, dmm, fe):
        super().__init__(dmm, fe, LM)


def _splat(builder, x, vty):
    v = builder.insert_element(ir.Constant(vty, ir.Undefined), x, ir.Constant(ir.IntType(32), 0))
    return builder.shuffle_vector(v, ir.Constant(vty, ir.Undefined),
                                  ir.Constant(ir.VectorType(ir.IntType(32), N), [0] * N))


def _asf(context, builder, ty, v):
    if isinstance(ty, VecF):
        return v
    v = context.cast(builder, v, ty, types.float64)
    return _splat(builder, v, LF)


def _asi(context, builder, ty, v):
    if isinstance(ty, VecI):
        return v
    v = context.cast(builder, v, ty, types.uint64)
    return _splat(builder, v, LI)


def _isf(t):
    return isinstance(t, (VecF, types.Float, types.Integer))


def _isi(t):
    return isinstance(t, (VecI, types.Integer))


# ---- float binary ops ------------------------------------------------------
def _fbin(op):
    @intrinsic
    def f(typingctx, a, b):
        if not (_isf(a) and _isf(b) and (isinstance(a, VecF) or isinstance(b, VecF))):
            return None
        sig = vf(a, b)

        def codegen(context, builder, signature, args):
            x = _asf(context, builder, signature.args[0], args[0])
            y = _asf(context, builder, signature.args[1], args[1])
            return getattr(builder, op)(x, y)
        return sig, codegen
    return f


vadd = _fbin("fadd")
vsub = _fbin("fsub")
vmul = _fbin("fmul")
vdiv = _fbin("fdiv")


@intrinsic
def vfma(typingctx, a, b, c):
    if not (_isf(a) and _isf(b) and _isf(c)):
        return None
    sig = vf(a, b, c)

    def codegen(context, builder, signature, args):
        xs = [_asf(context, builder, t, v) for t, v in zip(signature.args, args)]
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(LF, [LF] * 3),
                                            f"llvm.fma.v{N}f64")
        return builder.call(fn, xs)
    return sig, codegen


def _fcmp(op):
    @intrinsic
    def f(typingctx, a, b):
        if not (_isf(a) and _isf(b)):
            return None
        sig = vm(a, b)

        def codegen(context, builder, signature, args):
            x = _asf(context, builder, signature.args[0], args[0])
            y = _asf(context, builder, signature.args[1], args[1])
            return builder.fcmp_ordered(op, x, y)
        return sig, codegen
    return f


vlt = _fcmp("<")
vgt = _fcmp(">")
veq = _fcmp("==")


@intrinsic
def vmax(typingctx, a, b):
    """numba max(a, b): select(b > a, b, a)."""
    sig = vf(a, b)

    def codegen(context, builder, signature, args):
        x = _asf(context, builder, signature.args[0], args[0])
        y = _asf(context, builder, signature.args[1], args[1])
        return builder.select(builder.fcmp_ordered(">", y, x), y, x)
    return sig, codegen


@intrinsic
def vmin(typingctx, a, b):
    """numba min(a, b): select(b < a, b, a)."""
    sig = vf(a, b)

    def codegen(context, builder, signature, args):
        x = _asf(context, builder, signature.args[0], args[0])
        y = _asf(context, builder, signature.args[1], args[1])
        return builder.select(builder.fcmp_ordered("<", y, x), y, x)
    return sig, codegen


# ---- integer ops -----------------------------------------------------------
def _ibin(op):
    @intrinsic
    def f(typingctx, a, b):
        if not (_isi(a) and _isi(b)):
            return None
        sig = vi(a, b)

        def codegen(context, builder, signature, args):
            x = _asi(context, builder, signature.args[0], args[0])
            y = _asi(context, builder, signature.args[1], args[1])
            return getattr(builder, op)(x, y)
        return sig, codegen
    return f


iadd = _ibin("add")
isub = _ibin("sub")
iand = _ibin("and_")
ishl = _ibin("shl")
ilshr = _ibin("lshr")
iashr = _ibin("ashr")


def _icmp(op, signed):
    @intrinsic
    def f(typingctx, a, b):
        if not (_isi(a) and _isi(b)):
            return None
        sig = vm(a, b)

        def codegen(context, builder, signature, args):
            x = _asi(context, builder, signature.args[0], args[0])
            y = _asi(context, builder, signature.args[1], args[1])
            if signed:
                return builder.icmp_signed(op, x, y)
            return builder.icmp_unsigned(op, x, y)
        return sig, codegen
    return f


iult = _icmp("<", False)
iuge = _icmp(">=", False)
iugt = _icmp(">", False)
ieq = _icmp("==", False)
ine = _icmp("!=", False)


# ---- masks ---------------------------------------------------------------
def _mbin(op):
    @intrinsic
    def f(typingctx, a, b):
        sig = vm(a, b)

        def codegen(context, builder, signature, args):
            return getattr(builder, op)(args[0], args[1])
        return sig, codegen
    return f


mand = _mbin("and_")
mor = _mbin("or_")


@intrinsic
def mnot(typingctx, a):
    sig = vm(a)

    def codegen(context, builder, signature, args):
        return builder.not_(args[0])
    return sig, codegen


@intrinsic
def many(typingctx, a):
    sig = types.boolean(a)

    def codegen(context, builder, signature, args):
        bits = builder.bitcast(args[0], ir.IntType(N))
        return builder.icmp_unsigned("!=", bits, ir.Constant(ir.IntType(N), 0))
    return sig, codegen


@intrinsic
def sel(typingctx, m, x, y):
    """m ? x : y per lane (float or int vectors; scalars are splatted)."""
    if isinstance(x, VecI) or isinstance(y, VecI):
        rt, conv = vi, _asi
    else:
        rt, conv = vf, _asf
    sig = rt(m, x, y)

    def codegen(context, builder, signature, args):
        a = conv(context, builder, signature.args[1], args[1])
        b = conv(context, builder, signature.args[2], args[2])
        return builder.select(args[0], a, b)
    return sig, codegen


@intrinsic
def f2u(typingctx, x):
    sig = vi(x)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], LI)
    return sig, codegen


@intrinsic
def u2f(typingctx, x):
    sig = vf(x)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], LF)
    return sig, codegen


@intrinsic
def i2f_i32(typingctx, x):
    """np.float64(np.int32(k)) per lane."""
    sig = vf(x)

    def codegen(context, builder, signature, args):
        t = builder.trunc(args[0], ir.VectorType(ir.IntType(32), N))
        return builder.sitofp(t, LF)
    return sig, codegen


@intrinsic
def splat(typingctx, x):
    sig = vf(x)

    def codegen(context, builder, signature, args):
        return _asf(context, builder, signature.args[0], args[0])
    return sig, codegen


# ---- memory --------------------------------------------------------------
def _ptr(context, builder, aryty, ary, idx, idxty):
    a = context.make_array(aryty)(context, builder, ary)
    idx = context.cast(builder, idx, idxty, types.intp)
    return builder.gep(a.data, [idx])


@intrinsic
def vload(typingctx, arr, idx):
    """arr[idx : idx + N] (1-D float64, contiguous) as a vector."""
    sig = vf(arr, idx)

    def codegen(context, builder, signature, args):
        p = _ptr(context, builder, signature.args[0], args[0], args[1], signature.args[1])
        p = builder.bitcast(p, LF.as_pointer())
        return builder.load(p, align=8)
    return sig, codegen


@intrinsic
def vstore(typingctx, arr, idx, v):
    sig = types.void(arr, idx, v)

    def codegen(context, builder, signature, args):
        p = _ptr(context, builder, signature.args[0], args[0], args[1], signature.args[1])
        p = builder.bitcast(p, LF.as_pointer())
        builder.store(args[2], p, align=8)
        return context.get_dummy_value()
    return sig, codegen


@intrinsic
def gather(typingctx, tab, idx):
    """tab[idx[l]] per lane; tab a 1-D float64 or uint64 array (a numba global
    array is a constant), result a float or int vector."""
    rt = vi if isinstance(tab.dtype, types.Integer) else vf
    sig = rt(tab, idx)

    def codegen(context, builder, signature, args):
        a = context.make_array(signature.args[0])(context, builder, args[0])
        res = ir.Constant(LI if rt is vi else LF, ir.Undefined)
        for l in range(N):
            k = builder.extract_element(args[1], ir.Constant(ir.IntType(32), l))
            v = builder.load(builder.gep(a.data, [k]))
            res = builder.insert_element(res, v, ir.Constant(ir.IntType(32), l))
        return res
    return sig, codegen


@intrinsic
def lane(typingctx, v, l):
    rt = types.float64 if isinstance(v, VecF) else types.uint64
    sig = rt(v, l)

    def codegen(context, builder, signature, args):
        return builder.extract_element(args[0], args[1])
    return sig, codegen


@intrinsic
def gather2(typingctx, tab, idx):
    """(tab[2*idx[l]], tab[2*idx[l] + 1]) per lane as two float vectors: one 16-byte load
    per lane and shuffles (the tables store their two entries side by side)."""
    sig = types.UniTuple(vf, 2)(tab, idx)

    def codegen(context, builder, signature, args):
        a = context.make_array(signature.args[0])(context, builder, args[0])
        v2 = ir.VectorType(ir.DoubleType(), 2)
        two = ir.Constant(ir.IntType(64), 2)
        parts = []
        for l in range(N):
            k = builder.extract_element(args[1], ir.Constant(ir.IntType(32), l))
            p = builder.gep(a.data, [builder.mul(k, two)])
            parts.append(builder.load(builder.bitcast(p, v2.as_pointer()), align=8))
        # concatenate the N pairs into one <2N x double> (t0 s0 t1 s1 ...)
        cur = parts
        w = 2
        while len(cur) > 1:
            nxt = []
            for q in range(0, len(cur), 2):
                mask = ir.Constant(ir.VectorType(ir.IntType(32), 2 * w), list(range(2 * w)))
                nxt.append(builder.shuffle_vector(cur[q], cur[q + 1], mask))
            cur = nxt
            w *= 2
        allv = cur[0]
        undef = ir.Constant(allv.type, ir.Undefined)
        ev = builder.shuffle_vector(allv, undef, ir.Constant(ir.VectorType(ir.IntType(32), N), list(range(0, 2 * N, 2))))
        od = builder.shuffle_vector(allv, undef, ir.Constant(ir.VectorType(ir.IntType(32), N), list(range(1, 2 * N, 2))))
        return context.make_tuple(builder, signature.return_type, [ev, od])
    return sig, codegen


@intrinsic
def vsqrt(typingctx, x):
    sig = vf(x)

    def codegen(context, builder, signature, args):
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(LF, [LF]),
                                            f"llvm.sqrt.v{N}f64")
        return builder.call(fn, args)
    return sig, codegen


@intrinsic
def mtrue(typingctx):
    sig = vm()

    def codegen(context, builder, signature, args):
        return ir.Constant(LM, [1] * N)
    return sig, codegen
