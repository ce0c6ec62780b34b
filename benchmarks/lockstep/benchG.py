"""objgrad (value + gradient of the barycentre objective), scalar _objgrad_batch_serial vs
lockstep lockG, interleaved, thread CPU time, pinned.  Batches: each loop's two clusters
of 10 series (realistic: 10 series -> 2 groups of 8 lanes, 6 lanes idle), and 'full' =
16 series per centre (no idle lanes)."""
import numpy as np, time, os, sys
from data import loop_data
import lockG
from lockV import N
from uavwind.method.softdtw._kernels import _objgrad_batch_serial, _objgrad_range
R = int(sys.argv[1]) if len(sys.argv) > 1 else 4
fwd, og, _ = lockG.make(R)
fwd2, og_nojac, _ = lockG.make(R, False)
_, og_jv, _ = lockG.make(R, True, True)
loops = [loop_data(i) for i in range(6)]
def batches(mode):
    out = []
    for X, C in loops:
        if mode == "clusters":
            for c in range(2):
                out.append((C[c], np.ascontiguousarray(X[c * 10:(c + 1) * 10])))
        else:
            out.append((C[0], np.ascontiguousarray(X[:16])))
    return out
for mode in ("clusters", "full16"):
    B = [(Z, Xs) + lockG.prep(Z, Xs) for Z, Xs in batches(mode)]
    cells = sum(len(Xs) for _, Xs, _, _ in B) * 120 * 120
    def scalar():
        for Z, Xs, _, _ in B:
            _objgrad_batch_serial(Z, Xs, 0.5, True)
    bufs = [(np.empty(len(Xs)), np.empty((len(Xs),) + Z.shape)) for Z, Xs, _, _ in B]
    WS = lockG.workspace(120, 120, R)
    def lock(f=og):
        for (Z, Xs, ZL, XG), (v, G) in zip(B, bufs):
            f(Z, Xs, ZL, XG, 0.5, v, G, *WS)
    scalar(); lock(); lock(og_nojac); lock(og_jv)
    ok = 0; tot = 0; okv = 0
    bufs2 = [(np.empty(len(Xs)), np.empty((len(Xs),) + Z.shape)) for Z, Xs, _, _ in B]
    for (Z, Xs, ZL, XG), (v, G) in zip(B, bufs2):
        og_jv(Z, Xs, ZL, XG, 0.5, v, G, *WS)
        rv = np.empty(len(Xs)); rG = np.empty_like(G)
        _objgrad_range(Z, Xs, 0.5, True, 0, len(Xs), 1, rv, rG)
        okv += sum(bool(v[s] == rv[s] and (G[s] == rG[s]).all()) for s in range(len(Xs)))
    for (Z, Xs, ZL, XG), (v, G) in zip(B, bufs):
        rv = np.empty(len(Xs)); rG = np.empty_like(G)
        _objgrad_range(Z, Xs, 0.5, True, 0, len(Xs), 1, rv, rG)
        ok += sum(bool(v[s] == rv[s] and (G[s] == rG[s]).all()) for s in range(len(Xs))); tot += len(Xs)
    T = {"scalar": [], "lock": [], "lock_nojac": [], "lock_jacvec": []}
    for rep in range(int(os.environ.get("REPS", "11"))):
        t0 = time.thread_time(); scalar(); T["scalar"].append(time.thread_time() - t0)
        t0 = time.thread_time(); lock(); T["lock"].append(time.thread_time() - t0)
        t0 = time.thread_time(); lock(og_nojac); T["lock_nojac"].append(time.thread_time() - t0)
        t0 = time.thread_time(); lock(og_jv); T["lock_jacvec"].append(time.thread_time() - t0)
    print(f"[{mode}] N={N} R={R}: exact (value and all of G) {ok}/{tot} series (per-lane scalar Jacobian), {okv}/{tot} (lockstep Jacobian)")
    for k, v in T.items():
        v = np.array(v) / cells * 1e9
        print(f"   {k:>11}: {np.median(v):.3f} ns per (series x 120 x 120) cell  (p10 {np.percentile(v, 10):.3f}, p90 {np.percentile(v, 90):.3f})")
    for kk in ("lock", "lock_jacvec"):
        r = np.array(T["scalar"]) / np.array(T[kk])
        print(f"   ratio scalar/{kk}: median {np.median(r):.2f}x  p10-p90 {np.percentile(r, 10):.2f}-{np.percentile(r, 90):.2f}")
    continue
    print(f"   ratio scalar/lock: median {np.median(r):.2f}x  p10-p90 {np.percentile(r, 10):.2f}-{np.percentile(r, 90):.2f}")
