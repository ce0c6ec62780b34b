"""exp_bf/log_bf vs libm (numba np.exp/np.log, i.e. what tslearn calls), bitwise."""
import numpy as np
from bf import exp_arr, log_arr, np_exp_arr, np_log_arr
rng = np.random.RandomState(1)
n = 2_000_000
sub = np.array([5e-324, 2.2250738585072014e-308 / 3, 1e-310])
xe = np.concatenate([
    rng.uniform(-746.0, 0.0, n), rng.uniform(-40.0, 0.0, n), rng.uniform(-760, -500, n),
    -np.exp(rng.uniform(-60.0, 6.62, n)), rng.uniform(-1.0, 1.0, n // 4),
    rng.uniform(-1100, 1100, n // 4), rng.uniform(700, 710, n // 4),
    np.array([0.0, -0.0, 1e-20, -1e-17, -2.0**-54, -2.0**-55, -745.1332191019411, -745.14,
              -708.3964185322641, -708.4, -512.0, -511.99999, -1024.0, -1023.9, 5.0, 700.0,
              709.78, 710.0, -1000.0, 1000.0, np.inf, -np.inf, np.nan])])
xl = np.concatenate([
    rng.uniform(1.0, 3.5, n), 1.0 + np.exp(rng.uniform(-50.0, 0.0, n)),
    rng.uniform(0.9, 1.1, n), np.exp(rng.uniform(-700, 700, n // 4)),
    rng.uniform(0.9375 - 1e-6, 0.9375 + 1e-6, n // 8), rng.uniform(1.0644 - 1e-6, 1.0645, n // 8),
    np.exp(rng.uniform(-744, -709, n // 8)), -rng.uniform(0, 10, 1000), sub,
    np.array([1.0, 1.0 + 2.0 ** -52, 1.0 - 2.0**-53, 0.9375, 1.0 + float.fromhex("0x1.09p-4"),
              1.0 + float.fromhex("0x1.08p-4"), 3.0, 2.0, 0.0, -0.0, -1.0, np.inf, -np.inf,
              np.nan, 5e-324, 1.7976931348623157e308])])
def same(a, b):
    return (a.view(np.uint64) == b.view(np.uint64)) | (np.isnan(a) & np.isnan(b))
for name, f, g, x in (("exp", exp_arr, np_exp_arr, xe), ("log", log_arr, np_log_arr, xl)):
    a = np.empty_like(x); b = np.empty_like(x)
    f(x, a); g(x, b)
    ok = same(a, b)
    print(f"{name}: {ok.sum()} / {len(x)} bit-identical to libm", "" if ok.all() else x[~ok][:10])
from vmath import vexp_arr, vlog_arr, N
for name, f, g, x in (("vexp", vexp_arr, np_exp_arr, xe), ("vlog", vlog_arr, np_log_arr, xl)):
    x = np.concatenate([x[-40:], x]); x = x[: len(x) // N * N]
    a = np.empty_like(x); b = np.empty_like(x)
    f(x, a); g(x, b)
    ok = same(a, b)
    print(f"{name} (N={N}): {ok.sum()} / {len(x)} bit-identical to libm", "" if ok.all() else x[~ok][:10])
from vmath2 import vexp2_arr, vlog2_arr
for name, f, g, x in (("vexp2", vexp2_arr, np_exp_arr, xe), ("vlog2", vlog2_arr, np_log_arr, xl)):
    x = np.concatenate([x[-40:], x]); x = x[: len(x) // N * N]
    a = np.empty_like(x); b = np.empty_like(x)
    f(x, a); g(x, b)
    ok = same(a, b)
    print(f"{name} (N={N}): {ok.sum()} / {len(x)} bit-identical to libm", "" if ok.all() else x[~ok][:10])
