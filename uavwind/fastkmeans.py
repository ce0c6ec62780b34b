"""The ``"fast"`` clustering engine: an exact numba re-implementation of tslearn 0.10.0
``TimeSeriesKMeans(metric="softdtw")`` + ``silhouette_score`` (dtw / softdtw).

Only numpy, scipy and numba are imported.  See NOTES.md for the algorithm
walk-through and the exactness argument.
"""
import math
import os

import numpy as np
from numba import njit, prange
from numba.core import types as _nbtypes, cgutils as _cgutils
from numba.core.extending import intrinsic
from llvmlite import ir as _ir

__all__ = [
    "fit", "silhouette", "KMeansResult", "EmptyClusterError",
    "soft_dtw", "soft_dtw_cross", "soft_dtw_objgrad", "soft_dtw_grad",
    "dtw", "dtw_pdist", "soft_dtw_normalized_pdist", "warmup",
]

# Run the batched kernels on all cores (numba prange).  Turn off with
# FASTKMEANS_PARALLEL=0 (e.g. when fit() is itself called from several
# Python threads: numba's default "workqueue" threading layer is not
# thread-safe).
PARALLEL = os.environ.get("FASTKMEANS_PARALLEL", "1") not in ("0", "false", "False", "")

_INF = np.inf
# exp(x) == 0.0 exactly (round-to-nearest) for every x < -745.14; we use a
# safety margin.
_EXP_ZERO = -746.0
# exp(x) < 2**-54 for x < -37.43; a softmin3 whose two non-maximal terms are
# both below this threshold has tmp == 1.0 exactly (see NOTES.md).
_EXP_NEGLIGIBLE = -38.0



# ---------------------------------------------------------------------------
# Bit-exact replicas of glibc's exp / log
# ---------------------------------------------------------------------------
# tslearn's numba kernels call np.exp / np.log, which numba lowers to the
# libm symbols exp / log.  On x86_64 glibc 2.36 with FMA+AVX2 these resolve
# (ifunc) to __exp_fma / __log_fma.  The functions below transcribe those
# two routines instruction by instruction (same constants, same FMA / non-FMA
# operations) so that they can be inlined into the DP loops.  They are used
# only if _libm_selfcheck() finds them bit-identical to the libm functions on
# this machine; otherwise the kernels call np.exp / np.log like tslearn.
@intrinsic
def _fma(typingctx, a, b, c):
    sig = _nbtypes.float64(_nbtypes.float64, _nbtypes.float64, _nbtypes.float64)

    def codegen(context, builder, signature, args):
        fnty = _ir.FunctionType(_ir.DoubleType(), [_ir.DoubleType()] * 3)
        fn = _cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64")
        return builder.call(fn, args)
    return sig, codegen


@intrinsic
def _f2u(typingctx, x):
    sig = _nbtypes.uint64(_nbtypes.float64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], _ir.IntType(64))
    return sig, codegen


@intrinsic
def _u2f(typingctx, u):
    sig = _nbtypes.float64(_nbtypes.uint64)

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], _ir.DoubleType())
    return sig, codegen


_EXP_TAB = np.array([
    0x0000000000000000, 0x3ff0000000000000, 0x3c9b3b4f1a88bf6e, 0x3feff63da9fb3335,
    0xbc7160139cd8dc5d, 0x3fefec9a3e778061, 0xbc905e7a108766d1, 0x3fefe315e86e7f85,
    0x3c8cd2523567f613, 0x3fefd9b0d3158574, 0xbc8bce8023f98efa, 0x3fefd06b29ddf6de,
    0x3c60f74e61e6c861, 0x3fefc74518759bc8, 0x3c90a3e45b33d399, 0x3fefbe3ecac6f383,
    0x3c979aa65d837b6d, 0x3fefb5586cf9890f, 0x3c8eb51a92fdeffc, 0x3fefac922b7247f7,
    0x3c3ebe3d702f9cd1, 0x3fefa3ec32d3d1a2, 0xbc6a033489906e0b, 0x3fef9b66affed31b,
    0xbc9556522a2fbd0e, 0x3fef9301d0125b51, 0xbc5080ef8c4eea55, 0x3fef8abdc06c31cc,
    0xbc91c923b9d5f416, 0x3fef829aaea92de0, 0x3c80d3e3e95c55af, 0x3fef7a98c8a58e51,
    0xbc801b15eaa59348, 0x3fef72b83c7d517b, 0xbc8f1ff055de323d, 0x3fef6af9388c8dea,
    0x3c8b898c3f1353bf, 0x3fef635beb6fcb75, 0xbc96d99c7611eb26, 0x3fef5be084045cd4,
    0x3c9aecf73e3a2f60, 0x3fef54873168b9aa, 0xbc8fe782cb86389d, 0x3fef4d5022fcd91d,
    0x3c8a6f4144a6c38d, 0x3fef463b88628cd6, 0x3c807a05b0e4047d, 0x3fef3f49917ddc96,
    0x3c968efde3a8a894, 0x3fef387a6e756238, 0x3c875e18f274487d, 0x3fef31ce4fb2a63f,
    0x3c80472b981fe7f2, 0x3fef2b4565e27cdd, 0xbc96b87b3f71085e, 0x3fef24dfe1f56381,
    0x3c82f7e16d09ab31, 0x3fef1e9df51fdee1, 0xbc3d219b1a6fbffa, 0x3fef187fd0dad990,
    0x3c8b3782720c0ab4, 0x3fef1285a6e4030b, 0x3c6e149289cecb8f, 0x3fef0cafa93e2f56,
    0x3c834d754db0abb6, 0x3fef06fe0a31b715, 0x3c864201e2ac744c, 0x3fef0170fc4cd831,
    0x3c8fdd395dd3f84a, 0x3feefc08b26416ff, 0xbc86a3803b8e5b04, 0x3feef6c55f929ff1,
    0xbc924aedcc4b5068, 0x3feef1a7373aa9cb, 0xbc9907f81b512d8e, 0x3feeecae6d05d866,
    0xbc71d1e83e9436d2, 0x3feee7db34e59ff7, 0xbc991919b3ce1b15, 0x3feee32dc313a8e5,
    0x3c859f48a72a4c6d, 0x3feedea64c123422, 0xbc9312607a28698a, 0x3feeda4504ac801c,
    0xbc58a78f4817895b, 0x3feed60a21f72e2a, 0xbc7c2c9b67499a1b, 0x3feed1f5d950a897,
    0x3c4363ed60c2ac11, 0x3feece086061892d, 0x3c9666093b0664ef, 0x3feeca41ed1d0057,
    0x3c6ecce1daa10379, 0x3feec6a2b5c13cd0, 0x3c93ff8e3f0f1230, 0x3feec32af0d7d3de,
    0x3c7690cebb7aafb0, 0x3feebfdad5362a27, 0x3c931dbdeb54e077, 0x3feebcb299fddd0d,
    0xbc8f94340071a38e, 0x3feeb9b2769d2ca7, 0xbc87deccdc93a349, 0x3feeb6daa2cf6642,
    0xbc78dec6bd0f385f, 0x3feeb42b569d4f82, 0xbc861246ec7b5cf6, 0x3feeb1a4ca5d920f,
    0x3c93350518fdd78e, 0x3feeaf4736b527da, 0x3c7b98b72f8a9b05, 0x3feead12d497c7fd,
    0x3c9063e1e21c5409, 0x3feeab07dd485429, 0x3c34c7855019c6ea, 0x3feea9268a5946b7,
    0x3c9432e62b64c035, 0x3feea76f15ad2148, 0xbc8ce44a6199769f, 0x3feea5e1b976dc09,
    0xbc8c33c53bef4da8, 0x3feea47eb03a5585, 0xbc845378892be9ae, 0x3feea34634ccc320,
    0xbc93cedd78565858, 0x3feea23882552225, 0x3c5710aa807e1964, 0x3feea155d44ca973,
    0xbc93b3efbf5e2228, 0x3feea09e667f3bcd, 0xbc6a12ad8734b982, 0x3feea012750bdabf,
    0xbc6367efb86da9ee, 0x3fee9fb23c651a2f, 0xbc80dc3d54e08851, 0x3fee9f7df9519484,
    0xbc781f647e5a3ecf, 0x3fee9f75e8ec5f74, 0xbc86ee4ac08b7db0, 0x3fee9f9a48a58174,
    0xbc8619321e55e68a, 0x3fee9feb564267c9, 0x3c909ccb5e09d4d3, 0x3feea0694fde5d3f,
    0xbc7b32dcb94da51d, 0x3feea11473eb0187, 0x3c94ecfd5467c06b, 0x3feea1ed0130c132,
    0x3c65ebe1abd66c55, 0x3feea2f336cf4e62, 0xbc88a1c52fb3cf42, 0x3feea427543e1a12,
    0xbc9369b6f13b3734, 0x3feea589994cce13, 0xbc805e843a19ff1e, 0x3feea71a4623c7ad,
    0xbc94d450d872576e, 0x3feea8d99b4492ed, 0x3c90ad675b0e8a00, 0x3feeaac7d98a6699,
    0x3c8db72fc1f0eab4, 0x3feeace5422aa0db, 0xbc65b6609cc5e7ff, 0x3feeaf3216b5448c,
    0x3c7bf68359f35f44, 0x3feeb1ae99157736, 0xbc93091fa71e3d83, 0x3feeb45b0b91ffc6,
    0xbc5da9b88b6c1e29, 0x3feeb737b0cdc5e5, 0xbc6c23f97c90b959, 0x3feeba44cbc8520f,
    0xbc92434322f4f9aa, 0x3feebd829fde4e50, 0xbc85ca6cd7668e4b, 0x3feec0f170ca07ba,
    0x3c71affc2b91ce27, 0x3feec49182a3f090, 0x3c6dd235e10a73bb, 0x3feec86319e32323,
    0xbc87c50422622263, 0x3feecc667b5de565, 0x3c8b1c86e3e231d5, 0x3feed09bec4a2d33,
    0xbc91bbd1d3bcbb15, 0x3feed503b23e255d, 0x3c90cc319cee31d2, 0x3feed99e1330b358,
    0x3c8469846e735ab3, 0x3feede6b5579fdbf, 0xbc82dfcd978e9db4, 0x3feee36bbfd3f37a,
    0x3c8c1a7792cb3387, 0x3feee89f995ad3ad, 0xbc907b8f4ad1d9fa, 0x3feeee07298db666,
    0xbc55c3d956dcaeba, 0x3feef3a2b84f15fb, 0xbc90a40e3da6f640, 0x3feef9728de5593a,
    0xbc68d6f438ad9334, 0x3feeff76f2fb5e47, 0xbc91eee26b588a35, 0x3fef05b030a1064a,
    0x3c74ffd70a5fddcd, 0x3fef0c1e904bc1d2, 0xbc91bdfbfa9298ac, 0x3fef12c25bd71e09,
    0x3c736eae30af0cb3, 0x3fef199bdd85529c, 0x3c8ee3325c9ffd94, 0x3fef20ab5fffd07a,
    0x3c84e08fd10959ac, 0x3fef27f12e57d14b, 0x3c63cdaf384e1a67, 0x3fef2f6d9406e7b5,
    0x3c676b2c6c921968, 0x3fef3720dcef9069, 0xbc808a1883ccb5d2, 0x3fef3f0b555dc3fa,
    0xbc8fad5d3ffffa6f, 0x3fef472d4a07897c, 0xbc900dae3875a949, 0x3fef4f87080d89f2,
    0x3c74a385a63d07a7, 0x3fef5818dcfba487, 0xbc82919e2040220f, 0x3fef60e316c98398,
    0x3c8e5a50d5c192ac, 0x3fef69e603db3285, 0x3c843a59ac016b4b, 0x3fef7321f301b460,
    0xbc82d52107b43e1f, 0x3fef7c97337b9b5f, 0xbc892ab93b470dc9, 0x3fef864614f5a129,
    0x3c74b604603a88d3, 0x3fef902ee78b3ff6, 0x3c83c5ec519d7271, 0x3fef9a51fbc74c83,
    0xbc8ff7128fd391f0, 0x3fefa4afa2a490da, 0xbc8dae98e223747d, 0x3fefaf482d8e67f1,
    0x3c8ec3bc41aa2008, 0x3fefba1bee615a27, 0x3c842b94c3a9eb32, 0x3fefc52b376bba97,
    0x3c8a64a931d185ee, 0x3fefd0765b6e4540, 0xbc8e37bae43be3ed, 0x3fefdbfdad9cbe14,
    0x3c77893b4d91cd9d, 0x3fefe7c1819e90d8, 0x3c5305c14160cc89, 0x3feff3c22b8f71f1,
], dtype=np.uint64)

_LOG_TAB = np.array([
    0x3ff734f0c3e0de9f, 0xbfd7cc7f79e69000, 0x3ff713786a2ce91f, 0xbfd76feec20d0000,
    0x3ff6f26008fab5a0, 0xbfd713e31351e000, 0x3ff6d1a61f138c7d, 0xbfd6b85b38287800,
    0x3ff6b1490bc5b4d1, 0xbfd65d5590807800, 0x3ff69147332f0cba, 0xbfd602d076180000,
    0x3ff6719f18224223, 0xbfd5a8ca86909000, 0x3ff6524f99a51ed9, 0xbfd54f4356035000,
    0x3ff63356aa8f24c4, 0xbfd4f637c36b4000, 0x3ff614b36b9ddc14, 0xbfd49da7fda85000,
    0x3ff5f66452c65c4c, 0xbfd445923989a800, 0x3ff5d867b5912c4f, 0xbfd3edf439b0b800,
    0x3ff5babccb5b90de, 0xbfd396ce448f7000, 0x3ff59d61f2d91a78, 0xbfd3401e17bda000,
    0x3ff5805612465687, 0xbfd2e9e2ef468000, 0x3ff56397cee76bd3, 0xbfd2941b3830e000,
    0x3ff54725e2a77f93, 0xbfd23ec58cda8800, 0x3ff52aff42064583, 0xbfd1e9e129279000,
    0x3ff50f22dbb2bddf, 0xbfd1956d2b48f800, 0x3ff4f38f4734ded7, 0xbfd141679ab9f800,
    0x3ff4d843cfde2840, 0xbfd0edd094ef9800, 0x3ff4bd3ec078a3c8, 0xbfd09aa518db1000,
    0x3ff4a27fc3e0258a, 0xbfd047e65263b800, 0x3ff4880524d48434, 0xbfcfeb224586f000,
    0x3ff46dce1b192d0b, 0xbfcf474a7517b000, 0x3ff453d9d3391854, 0xbfcea4443d103000,
    0x3ff43a2744b4845a, 0xbfce020d44e9b000, 0x3ff420b54115f8fb, 0xbfcd60a22977f000,
    0x3ff40782da3ef4b1, 0xbfccc00104959000, 0x3ff3ee8f5d57fe8f, 0xbfcc202956891000,
    0x3ff3d5d9a00b4ce9, 0xbfcb81178d811000, 0x3ff3bd60c010c12b, 0xbfcae2c9ccd3d000,
    0x3ff3a5242b75dab8, 0xbfca45402e129000, 0x3ff38d22cd9fd002, 0xbfc9a877681df000,
    0x3ff3755bc5847a1c, 0xbfc90c6d69483000, 0x3ff35dce49ad36e2, 0xbfc87120a645c000,
    0x3ff34679984dd440, 0xbfc7d68fb4143000, 0x3ff32f5cceffcb24, 0xbfc73cb83c627000,
    0x3ff3187775a10d49, 0xbfc6a39a9b376000, 0x3ff301c8373e3990, 0xbfc60b3154b7a000,
    0x3ff2eb4ebb95f841, 0xbfc5737d76243000, 0x3ff2d50a0219a9d1, 0xbfc4dc7b8fc23000,
    0x3ff2bef9a8b7fd2a, 0xbfc4462c51d20000, 0x3ff2a91c7a0c1bab, 0xbfc3b08abc830000,
    0x3ff293726014b530, 0xbfc31b996b490000, 0x3ff27dfa5757a1f5, 0xbfc2875490a44000,
    0x3ff268b39b1d3bbf, 0xbfc1f3b9f879a000, 0x3ff2539d838ff5bd, 0xbfc160c8252ca000,
    0x3ff23eb7aac9083b, 0xbfc0ce7f57f72000, 0x3ff22a012ba940b6, 0xbfc03cdc49fea000,
    0x3ff2157996cc4132, 0xbfbf57bdbc4b8000, 0x3ff201201dd2fc9b, 0xbfbe370896404000,
    0x3ff1ecf4494d480b, 0xbfbd17983ef94000, 0x3ff1d8f5528f6569, 0xbfbbf9674ed8a000,
    0x3ff1c52311577e7c, 0xbfbadc79202f6000, 0x3ff1b17c74cb26e9, 0xbfb9c0c3e7288000,
    0x3ff19e010c2c1ab6, 0xbfb8a646b372c000, 0x3ff18ab07bb670bd, 0xbfb78d01b3ac0000,
    0x3ff1778a25efbcb6, 0xbfb674f145380000, 0x3ff1648d354c31da, 0xbfb55e0e6d878000,
    0x3ff151b990275fdd, 0xbfb4485cdea1e000, 0x3ff13f0ea432d24c, 0xbfb333d94d6aa000,
    0x3ff12c8b7210f9da, 0xbfb22079f8c56000, 0x3ff11a3028ecb531, 0xbfb10e4698622000,
    0x3ff107fbda8434af, 0xbfaffa6c6ad20000, 0x3ff0f5ee0f4e6bb3, 0xbfadda8d4a774000,
    0x3ff0e4065d2a9fce, 0xbfabbcece4850000, 0x3ff0d244632ca521, 0xbfa9a1894012c000,
    0x3ff0c0a77ce2981a, 0xbfa788583302c000, 0x3ff0af2f83c636d1, 0xbfa5715e67d68000,
    0x3ff09ddb98a01339, 0xbfa35c8a49658000, 0x3ff08cabaf52e7df, 0xbfa149e364154000,
    0x3ff07b9f2f4e28fb, 0xbf9e72c082eb8000, 0x3ff06ab58c358f19, 0xbf9a55f152528000,
    0x3ff059eea5ecf92c, 0xbf963d62cf818000, 0x3ff04949cdd12c90, 0xbf9228fb8caa0000,
    0x3ff038c6c6f0ada9, 0xbf8c317b20f90000, 0x3ff02865137932a9, 0xbf8419355daa0000,
    0x3ff0182427ea7348, 0xbf781203c2ec0000, 0x3ff008040614b195, 0xbf60040979240000,
    0x3fefe01ff726fa1a, 0x3f6feff384900000, 0x3fefa11cc261ea74, 0x3f87dc41353d0000,
    0x3fef6310b081992e, 0x3f93cea3c4c28000, 0x3fef25f63ceeadcd, 0x3f9b9fc114890000,
    0x3feee9c8039113e7, 0x3fa1b0d8ce110000, 0x3feeae8078cbb1ab, 0x3fa58a5bd001c000,
    0x3fee741aa29d0c9b, 0x3fa95c8340d88000, 0x3fee3a91830a99b5, 0x3fad276aef578000,
    0x3fee01e009609a56, 0x3fb07598e598c000, 0x3fedca01e577bb98, 0x3fb253f5e30d2000,
    0x3fed92f20b7c9103, 0x3fb42edd8b380000, 0x3fed5cac66fb5cce, 0x3fb606598757c000,
    0x3fed272caa5ede9d, 0x3fb7da76356a0000, 0x3fecf26e3e6b2ccd, 0x3fb9ab434e1c6000,
    0x3fecbe6da2a77902, 0x3fbb78c7bb0d6000, 0x3fec8b266d37086d, 0x3fbd431332e72000,
    0x3fec5894bd5d5804, 0x3fbf0a3171de6000, 0x3fec26b533bb9f8c, 0x3fc067152b914000,
    0x3febf583eeece73f, 0x3fc147858292b000, 0x3febc4fd75db96c1, 0x3fc2266ecdca3000,
    0x3feb951e0c864a28, 0x3fc303d7a6c55000, 0x3feb65e2c5ef3e2c, 0x3fc3dfc33c331000,
    0x3feb374867c9888b, 0x3fc4ba366b7a8000, 0x3feb094b211d304a, 0x3fc5933928d1f000,
    0x3feadbe885f2ef7e, 0x3fc66acd2418f000, 0x3feaaf1d31603da2, 0x3fc740f8ec669000,
    0x3fea82e63fd358a7, 0x3fc815c0f51af000, 0x3fea5740ef09738b, 0x3fc8e92954f68000,
    0x3fea2c2a90ab4b27, 0x3fc9bb3602f84000, 0x3fea01a01393f2d1, 0x3fca8bed1c2c0000,
    0x3fe9d79f24db3c1b, 0x3fcb5b515c01d000, 0x3fe9ae2505c7b190, 0x3fcc2967ccbcc000,
    0x3fe9852ef297ce2f, 0x3fccf635d5486000, 0x3fe95cbaeea44b75, 0x3fcdc1bd3446c000,
    0x3fe934c69de74838, 0x3fce8c01b8cfe000, 0x3fe90d4f2f6752e6, 0x3fcf5509c0179000,
    0x3fe8e6528effd79d, 0x3fd00e6c121fb800, 0x3fe8bfce9fcc007c, 0x3fd071b80e93d000,
    0x3fe899c0dabec30e, 0x3fd0d46b9e867000, 0x3fe87427aa2317fb, 0x3fd13687334bd000,
    0x3fe84f00acb39a08, 0x3fd1980d67234800, 0x3fe82a49e8653e55, 0x3fd1f8ffe0cc8000,
    0x3fe8060195f40260, 0x3fd2595fd7636800, 0x3fe7e22563e0a329, 0x3fd2b9300914a800,
    0x3fe7beb377dcb5ad, 0x3fd3187210436000, 0x3fe79baa679725c2, 0x3fd377266dec1800,
    0x3fe77907f2170657, 0x3fd3d54ffbaf3000, 0x3fe756cadbd6130c, 0x3fd432eee32fe000,
], dtype=np.uint64).view(np.float64)

_E_INVLN2N = float.fromhex("0x1.71547652b82fep+7")
_E_NEGLN2HIN = float.fromhex("-0x1.62e42fefa0000p-8")
_E_NEGLN2LON = float.fromhex("-0x1.cf79abc9e3b3ap-47")
_E_C2 = float.fromhex("0x1.ffffffffffdbdp-2")
_E_C3 = float.fromhex("0x1.555555555543cp-3")
_E_C4 = float.fromhex("0x1.55555cf172b91p-5")
_E_C5 = float.fromhex("0x1.1111167a4d017p-7")
_E_SHIFT = float.fromhex("0x1.8000000000000p+52")
_TWO_M1022 = float.fromhex("0x1p-1022")
_TWO_P1009 = float.fromhex("0x1p1009")
_TWO_P52 = float.fromhex("0x1p52")

_L_LN2HI = float.fromhex("0x1.62e42fefa3800p-1")
_L_LN2LO = float.fromhex("0x1.ef35793c76730p-45")
_L_A0 = float.fromhex("-0x1.0000000000001p-1")
_L_A1 = float.fromhex("0x1.555555551305bp-2")
_L_A2 = float.fromhex("-0x1.fffffffeb4590p-3")
_L_A3 = float.fromhex("0x1.999b324f10111p-3")
_L_A4 = float.fromhex("-0x1.55575e506c89fp-3")
_L_B0 = -0.5
_L_B1 = float.fromhex("0x1.5555555555577p-2")
_L_B2 = float.fromhex("-0x1.ffffffffffdcbp-3")
_L_B3 = float.fromhex("0x1.999999995dd0cp-3")
_L_B4 = float.fromhex("-0x1.55555556745a7p-3")
_L_B5 = float.fromhex("0x1.24924a344de30p-3")
_L_B6 = float.fromhex("-0x1.fffffa4423d65p-4")
_L_B7 = float.fromhex("0x1.c7184282ad6cap-4")
_L_B8 = float.fromhex("-0x1.999eb43b068ffp-4")
_L_B9 = float.fromhex("0x1.78182f7afd085p-4")
_L_B10 = float.fromhex("-0x1.5521375d145cdp-4")
_TWO27 = 134217728.0


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _exp_glibc_special_neg(tmp, sbits):
    # glibc specialcase() for k < 0 (result possibly subnormal)
    sbits = sbits + np.uint64(0x3fe0000000000000)
    scale = _u2f(sbits)
    st = tmp * scale
    y = scale + st
    if y < 1.0:
        hi = y + 1.0
        lo = (scale - y) + st
        lo = ((1.0 - hi) + y) + lo
        y = (lo + hi) - 1.0
        if y == 0.0:
            return 0.0
    return y * _TWO_M1022


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _exp_glibc(x):
    ix = _f2u(x)
    abstop = (ix >> np.uint64(52)) & np.uint64(0x7ff)
    special = False
    if abstop - np.uint64(0x3c9) >= np.uint64(0x3f):
        if abstop < np.uint64(0x3c9):
            return 1.0 + x
        if abstop >= np.uint64(0x409):
            # |x| >= 1024, inf, nan (glibc: -inf -> 0, inf/nan -> 1 + x,
            # __math_uflow(0) = +0, __math_oflow(0) = +inf)
            if ix == np.uint64(0xfff0000000000000):
                return 0.0
            if abstop >= np.uint64(0x7ff):
                return 1.0 + x
            if x < 0.0:
                return 0.0
            return _INF
        special = True
    z = _fma(x, _E_INVLN2N, _E_SHIFT)
    ki = _f2u(z)
    kd = z - _E_SHIFT
    r = _fma(kd, _E_NEGLN2HIN, x)
    r = _fma(kd, _E_NEGLN2LON, r)
    p23 = _fma(r, _E_C3, _E_C2)
    idx = np.uint64(2) * (ki & np.uint64(0x7f))
    t1 = r + _u2f(_EXP_TAB[idx])
    sbits = _EXP_TAB[idx + np.uint64(1)] + (ki << np.uint64(45))
    r2 = r * r
    p45 = _fma(r, _E_C5, _E_C4)
    tmp = _fma(p23, r2, t1)
    r4 = r2 * r2
    tmp = _fma(r4, p45, tmp)
    if special:
        if (ki & np.uint64(0x80000000)) == np.uint64(0):
            # k > 0: overflow range, glibc: 0x1p1009 * (scale + scale * tmp)
            scale = _u2f(sbits - np.uint64(0x3f10000000000000))
            return _fma(scale, tmp, scale) * _TWO_P1009
        return _exp_glibc_special_neg(tmp, sbits)
    scale = _u2f(sbits)
    return _fma(scale, tmp, scale)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _log_glibc(x):
    ix = _f2u(x)
    if ix - np.uint64(0x3fee000000000000) < np.uint64(0x3090000000000):
        if ix == np.uint64(0x3ff0000000000000):
            return 0.0
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
        return hi + y
    top = ix >> np.uint64(48)
    if top - np.uint64(0x10) > np.uint64(0x7fdf):
        # x < 0x1p-1022, inf or nan (glibc special cases, no libm call)
        if ix * np.uint64(2) == np.uint64(0):
            return -_INF
        if ix == np.uint64(0x7ff0000000000000):
            return x
        if (top & np.uint64(0x8000)) != np.uint64(0) or (top & np.uint64(0x7ff0)) == np.uint64(0x7ff0):
            return np.nan
        ix = _f2u(x * _TWO_P52) - np.uint64(0x0340000000000000)
    tmp = ix - np.uint64(0x3fe6000000000000)
    i = (tmp >> np.uint64(45)) & np.uint64(0x7f)
    k = np.int64(tmp) >> np.int64(52)
    iz = ix - (tmp & np.uint64(0xfff0000000000000))
    invc = _LOG_TAB[2 * i]
    logc = _LOG_TAB[2 * i + np.uint64(1)]
    z = _u2f(iz)
    kd = np.float64(np.int32(k))
    w = _fma(kd, _L_LN2HI, logc)
    r = _fma(z, invc, -1.0)
    p12 = _fma(r, _L_A2, _L_A1)
    hi = r + w
    r2 = r * r
    lo = (w - hi) + r
    lo = _fma(kd, _L_LN2LO, lo)
    r3 = r * r2
    p34 = _fma(r, _L_A4, _L_A3)
    lo2 = _fma(r2, _L_A0, lo)
    p = _fma(p34, r2, p12)
    y = _fma(r3, p, lo2)
    return y + hi


@njit(cache=True, nogil=True, error_model="numpy")
def _selfcheck_kernel(xe, xl):
    bad = 0
    for i in range(xe.shape[0]):
        a = _exp_glibc(xe[i])
        b = np.exp(xe[i])
        if a != b and not (np.isnan(a) and np.isnan(b)):
            bad += 1
    for i in range(xl.shape[0]):
        a = _log_glibc(xl[i])
        b = np.log(xl[i])
        if a != b and not (np.isnan(a) and np.isnan(b)):
            bad += 1
    return bad


_FASTMATH_OK = None


def _libm_selfcheck(n=200_000):
    """True iff the inlined exp/log replicas agree bit-for-bit with the libm
    exp/log that numba (hence tslearn) calls, on ~1.2M probe points covering
    the ranges the kernels use.  Disable with FASTKMEANS_GLIBC_REPLICA=0."""
    global _FASTMATH_OK
    if _FASTMATH_OK is None:
        if os.environ.get("FASTKMEANS_GLIBC_REPLICA", "1") in ("0", "false", "False"):
            _FASTMATH_OK = False
        else:
            rng = np.random.RandomState(12345)
            xe = np.concatenate([
                rng.uniform(-746.0, 0.0, n), rng.uniform(-40.0, 0.0, n),
                -np.exp(rng.uniform(-60.0, 6.62, n)), rng.uniform(-1.0, 1.0, n // 4),
                np.array([0.0, -0.0, 1e-20, -1e-17, -745.1332191019411, -745.14,
                          -708.3964185322641, -708.4, 5.0, 700.0, 710.0, -1000.0,
                          np.inf, -np.inf, np.nan])])
            xl = np.concatenate([
                rng.uniform(1.0, 3.5, n), 1.0 + np.exp(rng.uniform(-50.0, 0.0, n)),
                rng.uniform(0.9, 1.1, n // 4), np.exp(rng.uniform(-700, 700, n // 4)),
                np.array([1.0, 1.0 + 2.0 ** -52, 0.9375, 1.0 + float.fromhex("0x1.09p-4"),
                          1.0 + float.fromhex("0x1.08p-4"), 3.0, 2.0, 0.0, -1.0,
                          np.inf, np.nan, 5e-324])])
            try:
                _FASTMATH_OK = _selfcheck_kernel(xe, xl) == 0
            except Exception:  # e.g. llvm.fma unsupported
                _FASTMATH_OK = False
    return _FASTMATH_OK


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _xexp(x, fx):
    if fx:
        return _exp_glibc(x)
    return np.exp(x)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _xlog(x, fx):
    if fx:
        return _log_glibc(x)
    return np.log(x)


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
    i0 = 1
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
        t = 4
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


# ----------------------------- backward pass -------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _grad_factor(e, r_next, r11, d_next, gamma, inv_gamma, pow2, fx):
    """e * exp((r_next - r11 - d_next) / gamma) with tslearn's NaN -> 0."""
    t = (r_next - r11) - d_next
    if pow2:
        t = t * inv_gamma
    else:
        t = t / gamma
    a = _exp_exact(t, fx)
    if np.isnan(a):
        a = 0.0
    return e * a


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_backward(D, R, gamma, fx, E, jlo, jhi, clo, chi):
    """tslearn's _njit_soft_dtw_grad(D, R, gamma) restricted to the band
    where E can be non-zero.

    Same traversal (columns right-to-left, rows bottom-to-top) and same
    expression ((e1*a + e2*b) + e3*c) for every computed cell.  A cell whose
    three E-predecessors are all 0 is exactly 0 in tslearn as well
    (0 * finite = 0), so those cells are not visited.  E must be all zeros
    on entry (see _clear_E); the cells written are [clo[c], chi[c]] of each
    column c.  jlo/jhi receive, per row, the first / last non-zero column."""
    m, n = D.shape
    pow2 = _is_pow2(gamma)
    inv_gamma = 1.0 / gamma
    for i in range(m):
        jlo[i] = n
        jhi[i] = -1
    E[m - 1, n - 1] = 1.0
    jlo[m - 1] = n - 1
    jhi[m - 1] = n - 1
    nxt_lo = m        # non-zero row range of column c + 1 (empty at start)
    nxt_hi = -1
    for c in range(n - 1, -1, -1):
        if c == n - 1:
            r = m - 2
            prev_v = 1.0
            cur_lo = m - 1
            cur_hi = m - 1
            comp_hi = m - 1
            comp_lo = m - 1
        else:
            r = min(m - 1, nxt_hi)
            prev_v = 0.0
            cur_lo = m
            cur_hi = -1
            comp_hi = r
            comp_lo = r + 1
        while r >= 0:
            e1 = prev_v
            e2 = E[r, c + 1] if (r >= nxt_lo and r <= nxt_hi) else 0.0
            e3 = E[r + 1, c + 1] if (r + 1 >= nxt_lo and r + 1 <= nxt_hi) else 0.0
            if e1 == 0.0 and e2 == 0.0 and e3 == 0.0:
                if r < nxt_lo - 1:
                    break
                v = 0.0
            else:
                r11 = R[r, c]
                p1 = 0.0
                p2 = 0.0
                p3 = 0.0
                if e1 != 0.0:
                    p1 = _grad_factor(e1, R[r + 1, c], r11, D[r + 1, c],
                                      gamma, inv_gamma, pow2, fx)
                if e2 != 0.0:
                    p2 = _grad_factor(e2, R[r, c + 1], r11, D[r, c + 1],
                                      gamma, inv_gamma, pow2, fx)
                if e3 != 0.0:
                    p3 = _grad_factor(e3, R[r + 1, c + 1], r11,
                                      D[r + 1, c + 1], gamma, inv_gamma, pow2,
                                      fx)
                v = p1 + p2 + p3
            E[r, c] = v
            comp_lo = r
            if v != 0.0:
                if cur_hi < 0:
                    cur_hi = r
                cur_lo = r
                if jhi[r] < 0:
                    jhi[r] = c
                jlo[r] = c
            prev_v = v
            r -= 1
        clo[c] = comp_lo
        chi[c] = comp_hi
        nxt_lo = cur_lo
        nxt_hi = cur_hi


@njit(cache=True, nogil=True, error_model="numpy")
def _clear_E(E, clo, chi):
    """Restore the all-zero invariant of the E workspace."""
    n = E.shape[1]
    for c in range(n):
        for r in range(clo[c], chi[c] + 1):
            E[r, c] = 0.0


@njit(cache=True, nogil=True, error_model="numpy", fastmath=True)
def _jacobian_product_sq_euc(Z, X, E, jlo, jhi, G):
    """G += Jacobian^T E, tslearn's _njit_jacobian_product_sq_euc (which is
    compiled with fastmath=True -- same flags, same expression, same loop
    order here; E entries outside [jlo, jhi] are exact zeros whose
    contribution leaves G unchanged)."""
    m = Z.shape[0]
    d = Z.shape[1]
    for i in range(m):
        for j in range(jlo[i], jhi[i] + 1):
            for k in range(d):
                G[i, k] += E[i, j] * 2 * (Z[i, k] - X[j, k])


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_one(Z, X, gamma, fx, yT, D, R, S, E, jlo, jhi, clo, chi, G):
    """tslearn.barycenters.softdtw._softdtw_func(Z, X, 1., gamma, 0, ...):
    returns R[-1, -1] and accumulates the gradient into the zeroed G."""
    v = _sdtw_forward(Z, X, gamma, True, fx, yT, D, R, S)
    _sdtw_backward(D, R, gamma, fx, E, jlo, jhi, clo, chi)
    _jacobian_product_sq_euc(Z, X, E, jlo, jhi, G)
    _clear_E(E, clo, chi)
    return v


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_range(Z, Xs, gamma, fx, s0, s1, step, vals, Gs):
    """vals[s], Gs[s] for s in range(s0, s1, step), one private workspace."""
    m, d = Z.shape
    n = Xs.shape[1]
    yT = np.empty((d, n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    E = np.zeros((m, n))
    jlo = np.empty(m, dtype=np.int64)
    jhi = np.empty(m, dtype=np.int64)
    clo = np.empty(n, dtype=np.int64)
    chi = np.empty(n, dtype=np.int64)
    for s in range(s0, s1, step):
        Gi = Gs[s]
        for i in range(m):
            for k in range(d):
                Gi[i, k] = 0.0
        vals[s] = _objgrad_one(Z, Xs[s], gamma, fx, yT, D, R, S, E, jlo, jhi,
                               clo, chi, Gi)


@njit(cache=True, nogil=True, error_model="numpy")
def _reduce_objgrad(vals, Gs):
    """obj = 0; G = 0; obj += v_s; G += G_s in series order (tslearn's
    _acc_softdtw_func loop, unit weights: 1.0 * x == x)."""
    n_ts, m, d = Gs.shape
    G = np.zeros((m, d))
    obj = 0.0
    for s in range(n_ts):
        obj += vals[s]
        for i in range(m):
            for k in range(d):
                G[i, k] += Gs[s, i, k]
    return obj, G


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_batch_serial(Z, Xs, gamma, fx):
    n_ts = Xs.shape[0]
    m, d = Z.shape
    vals = np.empty(n_ts)
    Gs = np.empty((n_ts, m, d))
    _objgrad_range(Z, Xs, gamma, fx, 0, n_ts, 1, vals, Gs)
    return _reduce_objgrad(vals, Gs)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _objgrad_par_inner(Z, Xs, gamma, fx, nw, vals, Gs):
    n_ts = Xs.shape[0]
    for w in prange(nw):
        _objgrad_range(Z, Xs, gamma, fx, w, n_ts, nw, vals, Gs)


@njit(cache=True, nogil=True, error_model="numpy")
def _objgrad_batch_par(Z, Xs, gamma, fx, nw):
    n_ts = Xs.shape[0]
    m, d = Z.shape
    vals = np.empty(n_ts)
    Gs = np.empty((n_ts, m, d))
    _objgrad_par_inner(Z, Xs, gamma, fx, nw, vals, Gs)
    return _reduce_objgrad(vals, Gs)


# --------------------------- soft-DTW values -------------------------------
@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_value(x, y, gamma, fx):
    """tslearn.metrics._soft_dtw._njit_soft_dtw(x, y, gamma) (no mask)."""
    m = x.shape[0]
    n = y.shape[0]
    yT = np.empty((x.shape[1], n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    return _sdtw_forward(x, y, gamma, False, fx, yT, D, R, S)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_cross_range(A, B, gamma, fx, p0, p1, step, out):
    nb = B.shape[0]
    m = A.shape[1]
    n = B.shape[1]
    yT = np.empty((A.shape[2], n))
    D = np.empty((m, n))
    R = np.empty((m, n))
    S = np.empty((m, n))
    for p in range(p0, p1, step):
        i = p // nb
        j = p - i * nb
        out[i, j] = _sdtw_forward(A[i], B[j], gamma, False, fx, yT, D, R, S)


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_cross_serial(A, B, gamma, fx, out):
    _sdtw_cross_range(A, B, gamma, fx, 0, A.shape[0] * B.shape[0], 1, out)


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_cross_par_inner(A, B, gamma, fx, nw, out):
    npairs = A.shape[0] * B.shape[0]
    for w in prange(nw):
        _sdtw_cross_range(A, B, gamma, fx, w, npairs, nw, out)


@njit(cache=True, nogil=True, error_model="numpy")
def _unrank_upper(p, nts, k):
    """p-th pair (i, j), j >= i + k, of the row-major upper triangle."""
    i = np.int64(0)
    rem = np.int64(p)
    nts = np.int64(nts)
    k = np.int64(k)
    while rem >= nts - k - i:
        rem -= nts - k - i
        i += 1
    return i, i + k + rem


@njit(cache=True, nogil=True, error_model="numpy")
def _sdtw_upper_range(X, gamma, fx, p0, p1, step, out):
    """out[i, j] = out[j, i] = soft_dtw(X[i], X[j]) for pairs i <= j."""
    nts = X.shape[0]
    n = X.shape[1]
    yT = np.empty((X.shape[2], n))
    D = np.empty((n, n))
    R = np.empty((n, n))
    S = np.empty((n, n))
    for p in range(p0, p1, step):
        i, j = _unrank_upper(p, nts, 0)
        v = _sdtw_forward(X[i], X[j], gamma, False, fx, yT, D, R, S)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _sdtw_upper_par_inner(X, gamma, fx, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts + 1) // 2
    for w in prange(nw):
        _sdtw_upper_range(X, gamma, fx, w, npairs, nw, out)


# --------------------------------- DTW -------------------------------------
@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _dtw_int_cell(i, j, D, A):
    A[i, j] = D[i, j] + min(A[i - 1, j], A[i, j - 1], A[i - 1, j - 1])


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_forward(x, y, yT, D, A):
    """tslearn.metrics._dtw._njit_dtw(x, y) (no mask) = sqrt(A[-1, -1]) with
    A[i,j] = dist + min(up, left, diag) (padded predecessors inf, (0,0): 0);
    4-row staggered schedule, same per-cell operations."""
    m = x.shape[0]
    n = y.shape[0]
    _cost_matrix(x, y, False, yT, D)
    A[0, 0] = D[0, 0] + min(_INF, _INF, 0.0)
    for j in range(1, n):
        A[0, j] = D[0, j] + min(_INF, A[0, j - 1], _INF)
    for i in range(1, m):
        A[i, 0] = D[i, 0] + min(A[i - 1, 0], _INF, _INF)
    i0 = 1
    while i0 + 4 <= m and n >= 5:
        for t in range(1, 4):
            for l in range(t):
                _dtw_int_cell(i0 + l, t - l, D, A)
        cs0 = A[i0, 3]
        cs1 = A[i0 + 1, 2]
        cs2 = A[i0 + 2, 1]
        cs3 = A[i0 + 3, 0]
        ps0 = A[i0, 2]
        ps1 = A[i0 + 1, 1]
        ps2 = A[i0 + 2, 0]
        Aa = A[i0 - 1]
        D0 = D[i0]
        D1 = D[i0 + 1]
        D2 = D[i0 + 2]
        D3 = D[i0 + 3]
        A0 = A[i0]
        A1 = A[i0 + 1]
        A2 = A[i0 + 2]
        A3 = A[i0 + 3]
        for t in range(4, n):
            v0 = D0[t] + min(Aa[t], cs0, Aa[t - 1])
            v1 = D1[t - 1] + min(cs0, cs1, ps0)
            v2 = D2[t - 2] + min(cs1, cs2, ps1)
            v3 = D3[t - 3] + min(cs2, cs3, ps2)
            A0[t] = v0
            A1[t - 1] = v1
            A2[t - 2] = v2
            A3[t - 3] = v3
            ps0 = cs0
            ps1 = cs1
            ps2 = cs2
            cs0 = v0
            cs1 = v1
            cs2 = v2
            cs3 = v3
        for t in range(n, n + 3):
            for l in range(t - n + 1, 4):
                _dtw_int_cell(i0 + l, t - l, D, A)
        i0 += 4
    while i0 < m:
        for j in range(1, n):
            _dtw_int_cell(i0, j, D, A)
        i0 += 1
    return math.sqrt(A[m - 1, n - 1])


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_value(x, y):
    m = x.shape[0]
    n = y.shape[0]
    yT = np.empty((x.shape[1], n))
    D = np.empty((m, n))
    A = np.empty((m, n))
    return _dtw_forward(x, y, yT, D, A)


@njit(cache=True, nogil=True, error_model="numpy")
def _dtw_upper_range(X, p0, p1, step, out):
    nts = X.shape[0]
    n = X.shape[1]
    yT = np.empty((X.shape[2], n))
    D = np.empty((n, n))
    A = np.empty((n, n))
    for p in range(p0, p1, step):
        i, j = _unrank_upper(p, nts, 1)
        v = _dtw_forward(X[i], X[j], yT, D, A)
        out[i, j] = v
        out[j, i] = v


@njit(cache=True, nogil=True, error_model="numpy", parallel=True)
def _dtw_upper_par_inner(X, nw, out):
    nts = X.shape[0]
    npairs = nts * (nts - 1) // 2
    for w in prange(nw):
        _dtw_upper_range(X, w, npairs, nw, out)


def _n_workers(parallel, n_tasks):
    if not parallel:
        return 1
    import numba
    return max(1, min(numba.get_num_threads(), n_tasks))


# ---------------------------------------------------------------------------
# Public low-level helpers
# ---------------------------------------------------------------------------
def _as_dataset(X):
    X = np.asarray(X, dtype=np.float64)
    if X.ndim == 1:
        X = X.reshape(1, -1, 1)
    elif X.ndim == 2:
        X = X.reshape(X.shape[0], X.shape[1], 1)
    if X.ndim != 3:
        raise ValueError("X must have shape (n_ts, sz, d)")
    if not np.all(np.isfinite(X)):
        raise ValueError("X contains NaN/inf (variable-length, NaN-padded "
                         "datasets are not supported by fastkmeans)")
    return np.ascontiguousarray(X)


def _as_series(x):
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x.reshape(-1, 1)
    return np.ascontiguousarray(x)


def _check_gamma(gamma):
    gamma = float(gamma)
    if math.isclose(gamma, 0.0):
        raise ValueError("gamma ~ 0 (tslearn switches to hard DTW) is not "
                         "supported by fastkmeans")
    return gamma


def _use_parallel(parallel):
    return PARALLEL if parallel is None else bool(parallel)


def soft_dtw(x, y, gamma=1.0):
    """= tslearn.metrics.soft_dtw(x, y, gamma) (no constraint)."""
    x = _as_series(x)
    y = _as_series(y)
    gamma = _check_gamma(gamma)
    return float(_sdtw_value(x, y, gamma, _libm_selfcheck()))


def soft_dtw_cross(A, B, gamma=1.0, parallel=None):
    """out[i, j] = soft_dtw(A[i], B[j]) (= tslearn _cdist_soft_dtw(A, B))."""
    A = _as_dataset(A)
    B = _as_dataset(B)
    gamma = _check_gamma(gamma)
    out = np.empty((A.shape[0], B.shape[0]))
    _sdtw_cross(A, B, gamma, out, _use_parallel(parallel), _libm_selfcheck())
    return out


def _sdtw_cross(A, B, gamma, out, par, fx):
    npairs = A.shape[0] * B.shape[0]
    nw = _n_workers(par, npairs)
    if nw > 1:
        _sdtw_cross_par_inner(A, B, gamma, fx, nw, out)
    else:
        _sdtw_cross_serial(A, B, gamma, fx, out)


def soft_dtw_grad(Z, X, gamma=1.0):
    """(value, gradient w.r.t. Z) of soft_dtw(Z, X) computed exactly like
    tslearn.barycenters.softdtw._softdtw_func(Z, X, 1., gamma, 0, None, None)
    (cost matrix D = cdist(Z, X) ** 2)."""
    Z = _as_series(Z)
    X = _as_series(X)
    gamma = _check_gamma(gamma)
    vals = np.empty(1)
    Gs = np.empty((1,) + Z.shape)
    _objgrad_range(Z, X[None], gamma, _libm_selfcheck(), 0, 1, 1, vals, Gs)
    return float(vals[0]), Gs[0]


def _objgrad(Z, Xs, gamma, par, fx):
    nw = _n_workers(par, Xs.shape[0])
    if nw > 1:
        return _objgrad_batch_par(Z, Xs, gamma, fx, nw)
    return _objgrad_batch_serial(Z, Xs, gamma, fx)


def soft_dtw_objgrad(Z, Xs, gamma=1.0, parallel=None):
    """Barycentre objective of tslearn (_acc_softdtw_func, unit weights):
    (sum_i soft_dtw(Z, Xs[i]), gradient w.r.t. Z of shape Z.shape).
    All series of Xs must have the same length (any length, != len(Z) ok)."""
    Z = _as_series(Z)
    Xs = _as_dataset(Xs)
    gamma = _check_gamma(gamma)
    return _objgrad(Z, Xs, gamma, _use_parallel(parallel), _libm_selfcheck())


def dtw(x, y):
    """= tslearn.metrics.dtw(x, y) (no constraint)."""
    x = _as_series(x)
    y = _as_series(y)
    return float(_dtw_value(x, y))


def dtw_pdist(X, parallel=None):
    """Full symmetric DTW matrix (= tslearn _cdist_dtw(X)), zero diagonal."""
    X = _as_dataset(X)
    nts = X.shape[0]
    out = np.zeros((nts, nts))
    npairs = nts * (nts - 1) // 2
    nw = _n_workers(_use_parallel(parallel), npairs)
    if nw > 1:
        _dtw_upper_par_inner(X, nw, out)
    else:
        _dtw_upper_range(X, 0, npairs, 1, out)
    return out


def soft_dtw_normalized_pdist(X, gamma=1.0, parallel=None):
    """= tslearn _cdist_soft_dtw_normalized(X, gamma=gamma)."""
    X = _as_dataset(X)
    gamma = _check_gamma(gamma)
    nts = X.shape[0]
    c = np.zeros((nts, nts))
    fx = _libm_selfcheck()
    npairs = nts * (nts + 1) // 2
    nw = _n_workers(_use_parallel(parallel), npairs)
    if nw > 1:
        _sdtw_upper_par_inner(X, gamma, fx, nw, c)
    else:
        _sdtw_upper_range(X, gamma, fx, 0, npairs, 1, c)
    d_ii = np.diag(c)
    normalizer = -0.5 * (d_ii.reshape((-1, 1)) + d_ii.reshape((1, -1)))
    return c + normalizer


# ---------------------------------------------------------------------------
# k-means
# ---------------------------------------------------------------------------
class EmptyClusterError(Exception):
    pass


class KMeansResult:
    """labels, cluster_centers, inertia, n_iter as tslearn's fitted
    estimator attributes labels_, cluster_centers_, inertia_, n_iter_.
    ``success`` is False when no initialisation succeeded (tslearn then
    leaves labels_ from the last failed attempt; we do the same)."""
    __slots__ = ("labels", "cluster_centers", "inertia", "n_iter", "success",
                 "n_attempts")

    def __init__(self, labels, cluster_centers, inertia, n_iter, success,
                 n_attempts):
        self.labels = labels
        self.cluster_centers = cluster_centers
        self.inertia = inertia
        self.n_iter = n_iter
        self.success = success
        self.n_attempts = n_attempts

    def __repr__(self):
        return ("KMeansResult(labels=%r, inertia=%r, n_iter=%r, success=%r)"
                % (self.labels, self.inertia, self.n_iter, self.success))


def _check_random_state(seed):
    """sklearn.utils.check_random_state, verbatim semantics."""
    import numbers
    if seed is None or seed is np.random:
        return np.random.mtrand._rand
    if isinstance(seed, numbers.Integral):
        return np.random.RandomState(seed)
    if isinstance(seed, np.random.RandomState):
        return seed
    raise ValueError("%r cannot be used to seed a numpy.random.RandomState"
                     " instance" % seed)


def _k_init_metric(X, n_clusters, cdist_metric, random_state):
    """tslearn.clustering.kmeans._k_init_metric, verbatim."""
    n_samples, n_timestamps, n_features = X.shape
    centers = np.empty((n_clusters, n_timestamps, n_features), dtype=X.dtype)
    n_local_trials = 2 + int(np.log(n_clusters))
    center_id = random_state.randint(n_samples)
    centers[0] = X[center_id]
    closest_dist_sq = cdist_metric(centers[0, np.newaxis], X) ** 2
    current_pot = closest_dist_sq.sum()
    for c in range(1, n_clusters):
        rand_vals = random_state.random_sample(n_local_trials) * current_pot
        candidate_ids = np.searchsorted(
            np.cumsum(closest_dist_sq, dtype=np.float64), rand_vals)
        np.clip(candidate_ids, None, closest_dist_sq.size - 1,
                out=candidate_ids)
        distance_to_candidates = cdist_metric(X[candidate_ids], X) ** 2
        np.minimum(closest_dist_sq, distance_to_candidates,
                   out=distance_to_candidates)
        candidates_pot = distance_to_candidates.sum(axis=1)
        best_candidate = np.argmin(candidates_pot)
        current_pot = candidates_pot[best_candidate]
        closest_dist_sq = distance_to_candidates[best_candidate]
        best_candidate = candidate_ids[best_candidate]
        centers[c] = X[best_candidate]
    return centers


def _lbfgsb(fg, x0, maxiter, ftol, gtol, maxcor=10, maxls=20):
    """Unconstrained L-BFGS-B: the loop of scipy's ``_minimize_lbfgsb`` without
    the ``minimize`` / ``ScalarFunction`` / ``MemoizeJac`` layers around it.

    Calls the same Fortran-derived ``setulb`` with the same arguments, feeds it
    the same (f, g) at the same points (an evaluation is reused when ``setulb``
    asks again at the point it last saw, as ``ScalarFunction`` does), and so
    returns the bit-identical final ``x`` (tested against ``scipy.optimize.minimize``).
    Those layers cost about 0.7 ms per call, some 15% of a loop with barycentres
    of 10 series of 120 samples.
    """
    from scipy.optimize import _lbfgsb as lb

    n = x0.size
    m = maxcor
    factr = ftol / np.finfo(float).eps
    nbd = np.zeros(n, np.int32)
    low_bnd = np.zeros(n, np.float64)
    upper_bnd = np.zeros(n, np.float64)
    x = np.array(x0, dtype=np.float64).ravel()
    f = np.array(0.0, dtype=np.float64)
    g = np.zeros((n,), dtype=np.float64)
    wa = np.zeros(2 * m * n + 5 * n + 11 * m * m + 8 * m, np.float64)
    iwa = np.zeros(3 * n, dtype=np.int32)
    task = np.zeros(2, dtype=np.int32)
    ln_task = np.zeros(2, dtype=np.int32)
    lsave = np.zeros(4, dtype=np.int32)
    isave = np.zeros(44, dtype=np.int32)
    dsave = np.zeros(29, dtype=np.float64)
    # ScalarFunction evaluates at x0 when it is built; later evaluations happen only
    # where x has changed since the last one
    last_x = x.copy()
    last_f, last_g = fg(last_x.copy())
    n_iterations = 0
    while True:
        g = g.astype(np.float64)
        lb.setulb(m, x, low_bnd, upper_bnd, nbd, f, g, factr, gtol, wa, iwa, task,
                  lsave, isave, dsave, maxls, ln_task)
        if task[0] == 3:
            if not np.array_equal(x, last_x):
                last_x = x.copy()
                last_f, last_g = fg(last_x.copy())
            f, g = last_f, last_g
        elif task[0] == 1:
            n_iterations += 1
            if n_iterations >= maxiter:
                task[0] = 5
                task[1] = 504
        else:
            break
    return x


def _softdtw_barycenter(Xk, init, gamma, max_iter, objgrad, tol=1e-3):
    """tslearn.barycenters.softdtw_barycenter(X=Xk, gamma, max_iter,
    init=init) with unit weights and no constraint: ``scipy.optimize.minimize(
    method="L-BFGS-B", tol=tol, jac=True, options={"maxiter": max_iter})``,
    i.e. ``ftol = gtol = tol``, run by :func:`_lbfgsb`."""
    if max_iter <= 0:
        return init
    m, d = init.shape

    def f(Z):
        obj, G = objgrad(Z.reshape(m, d), Xk, gamma)
        return float(obj), G.ravel()

    return _lbfgsb(f, init.ravel(), max_iter, ftol=tol, gtol=tol).reshape(init.shape)


_TP_CONTROLLER = None


def _blas_single_thread():
    """Context manager limiting the BLAS used by scipy's L-BFGS-B to one
    thread (threadpoolctl, if installed).  The L-BFGS-B vectors are far below
    OpenBLAS' multi-threading thresholds, so results are unchanged, but an
    idle OpenBLAS pool costs ~0.5 ms per setulb call on a busy machine."""
    global _TP_CONTROLLER
    import contextlib
    if os.environ.get("FASTKMEANS_LIMIT_BLAS", "1") in ("0", "false", "False"):
        return contextlib.nullcontext()
    if _TP_CONTROLLER is None:
        try:
            from threadpoolctl import ThreadpoolController
            _TP_CONTROLLER = ThreadpoolController()
        except Exception:
            _TP_CONTROLLER = False
    if _TP_CONTROLLER is False:
        return contextlib.nullcontext()
    return _TP_CONTROLLER.limit(limits=1, user_api="blas")


def fit(X, n_clusters=2, gamma=0.5, max_iter=100, max_iter_barycenter=5,
        tol=1e-6, n_init=1, random_state=0, parallel=None):
    """Exact equivalent of

        km = tslearn.clustering.TimeSeriesKMeans(
            n_clusters=n_clusters, metric="softdtw",
            metric_params={"gamma": gamma}, max_iter=max_iter,
            max_iter_barycenter=max_iter_barycenter, tol=tol, n_init=n_init,
            random_state=random_state)          # init="k-means++"
        labels = km.fit_predict(X)

    Returns a KMeansResult (labels, cluster_centers, inertia, n_iter).
    X: (n_ts, sz, d) float array without NaN.  random_state: None, int or
    numpy RandomState (consumed exactly as tslearn does).
    Raises EmptyClusterError where tslearn raises it (final re-assignment).
    """
    X = _as_dataset(X)
    gamma = _check_gamma(gamma)
    if max_iter < 1:
        raise ValueError("max_iter must be >= 1")
    with _blas_single_thread():
        return _fit(X, n_clusters, gamma, max_iter, max_iter_barycenter, tol,
                    n_init, random_state, parallel)


def _fit(X, n_clusters, gamma, max_iter, max_iter_barycenter, tol, n_init,
         random_state, parallel):
    par = _use_parallel(parallel)

    fx = _libm_selfcheck()

    def objgrad(Z, Xk, gamma):
        return _objgrad(Z, Xk, gamma, par, fx)
    n_ts = X.shape[0]

    def cdist_sdtw(A, B):
        A = np.ascontiguousarray(A)
        out = np.empty((A.shape[0], B.shape[0]))
        _sdtw_cross(A, B, gamma, out, par, fx)
        return out

    arange = np.arange(n_ts)

    def assign(centers):
        dists = cdist_sdtw(X, centers)
        labels = dists.argmin(axis=1)
        inertia = np.sum(dists[arange, labels] ** 2) / n_ts
        return labels, inertia

    rs = _check_random_state(random_state)
    max_attempts = max(n_init, 10)

    state_labels = None
    state_centers = None
    best_centers = None
    min_inertia = np.inf
    n_iter_best = 0
    n_successful = 0
    n_attempts = 0
    while n_successful < n_init and n_attempts < max_attempts:
        n_attempts += 1
        centers = _k_init_metric(X, n_clusters, cdist_sdtw, rs)
        state_centers = centers
        old_inertia = np.inf
        failed = False
        it = 0
        for it in range(max_iter):
            labels, inertia = assign(centers)
            state_labels = labels
            if np.any(np.bincount(labels, minlength=n_clusters) == 0):
                failed = True
                break
            # _update_centroids
            for k in range(n_clusters):
                Xk = np.ascontiguousarray(X[labels == k])
                centers[k] = _softdtw_barycenter(
                    Xk, centers[k], gamma, max_iter_barycenter, objgrad)
            if np.abs(old_inertia - inertia) < tol:
                break
            old_inertia = inertia
        if failed:
            continue
        if inertia < min_inertia:
            best_centers = centers.copy()
            min_inertia = inertia
            n_iter_best = it + 1
        n_successful += 1

    if np.isfinite(min_inertia) and best_centers is not None:
        labels, _ = assign(best_centers)
        if np.any(np.bincount(labels, minlength=n_clusters) == 0):
            raise EmptyClusterError(
                "final assignment leads to an empty cluster (tslearn raises "
                "EmptyClusterError here too)")
        return KMeansResult(labels, best_centers, min_inertia, n_iter_best,
                            True, n_attempts)
    # no successful init: tslearn keeps labels_ of the last failed attempt
    return KMeansResult(state_labels, state_centers, np.inf, 0, False,
                        n_attempts)


# ---------------------------------------------------------------------------
# silhouette
# ---------------------------------------------------------------------------
def _silhouette_precomputed(D, labels):
    """sklearn.metrics.silhouette_score(D, labels, metric="precomputed"),
    same arithmetic (bincount sums, same divisions, nan_to_num, mean)."""
    D = np.asarray(D, dtype=np.float64)
    labels = np.asarray(labels)
    atol = np.finfo(D.dtype).eps * 100
    if np.any(np.abs(D.diagonal()) > atol):
        raise ValueError("The precomputed distance matrix contains non-zero "
                         "elements on the diagonal. Use np.fill_diagonal(X, 0).")
    classes, labels = np.unique(labels, return_inverse=True)
    n_samples = len(labels)
    n_labels = len(classes)
    if not 1 < n_labels < n_samples:
        raise ValueError("Number of labels is %d. Valid values are 2 to "
                         "n_samples - 1 (inclusive)" % n_labels)
    label_freqs = np.bincount(labels)
    cluster_distances = np.zeros((n_samples, len(label_freqs)), dtype=D.dtype)
    for i in range(n_samples):
        cluster_distances[i] += np.bincount(labels, weights=D[i],
                                            minlength=len(label_freqs))
    intra_index = (np.arange(n_samples), labels)
    intra = cluster_distances[intra_index]
    cluster_distances[intra_index] = np.inf
    cluster_distances /= label_freqs
    inter = cluster_distances.min(axis=1)
    denom = (label_freqs - 1).take(labels, mode="clip")
    with np.errstate(divide="ignore", invalid="ignore"):
        intra /= denom
    sil_samples = inter - intra
    with np.errstate(divide="ignore", invalid="ignore"):
        sil_samples /= np.maximum(intra, inter)
    sil_samples = np.nan_to_num(sil_samples)
    return float(np.mean(sil_samples))


def silhouette(X, labels, metric="dtw", gamma=None, parallel=None):
    """= tslearn.clustering.silhouette_score(X, labels, metric=metric,
    metric_params={"gamma": gamma} if gamma is not None else None).
    metric: "dtw" (or None) or "softdtw" (normalised soft-DTW, gamma
    default 1.0 as in tslearn) or "precomputed"."""
    if metric == "precomputed":
        return _silhouette_precomputed(X, labels)
    X = _as_dataset(X)
    if metric == "dtw" or metric is None:
        D = dtw_pdist(X, parallel=parallel)
    elif metric == "softdtw":
        D = soft_dtw_normalized_pdist(X, 1.0 if gamma is None else gamma,
                                      parallel=parallel)
    else:
        raise ValueError("metric must be 'dtw', 'softdtw' or 'precomputed'")
    return _silhouette_precomputed(D, labels)


def warmup():
    """Compile / load from cache every kernel (call once at start-up)."""
    rng = np.random.RandomState(0)
    X = rng.randn(4, 6, 3)
    for par in (True, False):
        r = fit(X, n_clusters=2, gamma=0.5, max_iter=2, max_iter_barycenter=2,
                parallel=par)
        silhouette(X, np.array([0, 0, 1, 1]), metric="dtw", parallel=par)
        silhouette(X, np.array([0, 0, 1, 1]), metric="softdtw", gamma=0.5,
                   parallel=par)
    for g in (0.5, 0.1):
        soft_dtw(X[0], X[1], g)
        soft_dtw_grad(X[0], X[1], g)
    return r
