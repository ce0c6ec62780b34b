"""Side by side (interleaved, thread CPU time, pinned): scalar _sdtw_cross_serial vs lockW
configs given as R:cost3:drop0 (e.g. 4:1:0).  Also checks == on all lanes."""
import numpy as np, time, sys, os
from data import loop_data
from uavwind.method.softdtw._kernels import _sdtw_cross_serial
import lockW
from lockV import N, to_lanes
cfgs = [tuple(int(v) for v in a.split(":")) for a in sys.argv[1:]] or [(4, 1, 0)]
Xs, Cs = zip(*[loop_data(i) for i in range(5)])
P = np.array([x for X, C in zip(Xs, Cs) for x in X for c in C])
Q = np.array([c for X, C in zip(Xs, Cs) for x in X for c in C])
cells = len(P) * 120 * 120
outs = [np.empty((len(X), 2)) for X in Xs]
def scalar():
    for X, C, o in zip(Xs, Cs, outs):
        _sdtw_cross_serial(X, C, 0.5, True, o)
scalar()
ref = np.concatenate([o.ravel() for o in outs])
XG, YG = to_lanes(P), to_lanes(Q)
ks = {}
for cfg in cfgs:
    R, c3, d0 = cfg
    gv, b, _, _ = lockW.make(R, True, lockW.NEG, bool(c3), bool(d0))
    out = np.empty((XG.shape[0], N))
    b(XG, YG, 120, 120, 3, 0.5, out)
    ks[cfg] = (b, out)
    print(cfg, "identical lanes:", (out.ravel() == ref[:out.size]).sum(), "/", out.size)
T = {k: [] for k in ["scalar"] + cfgs}
for rep in range(int(os.environ.get("REPS", "15"))):
    t0 = time.thread_time(); scalar(); T["scalar"].append((time.thread_time() - t0) / cells * 1e9)
    for cfg, (b, out) in ks.items():
        t0 = time.thread_time(); b(XG, YG, 120, 120, 3, 0.5, out); T[cfg].append((time.thread_time() - t0) / out.size / 14400 * 1e9)
for k, v in T.items():
    q = np.percentile(v, [10, 50, 90])
    print(f"{str(k):>12} N={N}: ns/cell median {q[1]:.3f}  (p10 {q[0]:.3f}, p90 {q[2]:.3f})")
sc = np.array(T["scalar"])
for cfg in cfgs:
    r = sc / np.array(T[cfg])
    print(f"ratio scalar/lock {cfg} N={N}: median {np.median(r):.2f}x  p10-p90 {np.percentile(r, 10):.2f}-{np.percentile(r, 90):.2f}")
