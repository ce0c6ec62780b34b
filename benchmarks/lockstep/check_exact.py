"""Step 3: exactness of the lockstep prototypes, every lane, vs the scalar kernel (snapshot
of uavwind's) and vs tslearn 0.10.  Value: lockW (R=4).  Value+gradient: lockG (forward,
backward E, lockstep Jacobian).  Also counts how often the rare exp/log paths were hit in
cells/factors whose result is used, so the crafted sets are known to exercise them."""
import time
import numpy as np
from scipy.spatial.distance import cdist
import tslearn.metrics as tm
from tslearn.metrics._soft_dtw import _njit_soft_dtw_grad, _njit_accumulated_matrix_from_distance_matrix
from tslearn.metrics._masks import _njit_compute_mask
from tslearn.barycenters.softdtw import _softdtw_func
import lockW, lockG
from lockV import N, to_lanes
from data import loop_data
from uavwind.method.softdtw._kernels import _sdtw_value, _objgrad_range, _sdtw_forward

G = 0.5
rng = np.random.RandomState(2024)
T = 120


def walk(n, scale, d=3):
    """UAV-like: smooth random walk, positions around +-100 m at scale 100."""
    v = np.cumsum(rng.randn(n, T, d), axis=1)
    v = v / np.maximum(np.abs(v).max(axis=1, keepdims=True), 1e-300)
    return scale * v + scale * 0.2 * rng.randn(n, 1, d)


def sets():
    out = {}
    out["uav_random_pm100"] = (rng.uniform(-100, 100, (1600, T, 3)), rng.uniform(-100, 100, (1600, T, 3)))
    out["uav_walk_pm100"] = (walk(1600, 100.0), walk(1600, 100.0))
    X = np.concatenate([loop_data(i)[0] for i in range(12)])      # 240 simulated trajectories
    C = np.concatenate([loop_data(i)[1] for i in range(12)])
    out["uav_simulated_vs_centres"] = (X, np.repeat(C, 10, axis=0))
    # crafted: small scales put exp arguments of used terms into [-746, -512] (specialcase,
    # subnormal results), below -746, and tmp into the log's near-1 window
    for sc in (0.3, 1.0, 3.0, 10.0):
        out[f"crafted_scale_{sc}"] = (walk(400, sc), walk(400, sc))
    # tiny values: D subnormal / zero, exp arguments |x| < 2**-54 (1 + x path), tmp == 1
    a = walk(200, 1.0); out["crafted_subnormal_D"] = (a * 1e-160, (a + 0.01 * rng.randn(*a.shape)) * 1e-160)
    b = walk(200, 5.0); out["crafted_identical_or_shifted"] = (b, np.where(rng.rand(200, 1, 1) < 0.5, b, b + 1e-9))
    return out


def special_counts(x, y):
    """From the scalar kernel's S matrix (S = R / -gamma): for cells that are NOT
    trivial (their exp/log results are used), count exp args by glibc path and
    log args in the near-1 window."""
    m = x.shape[0]; n = y.shape[0]
    yT = np.empty((3, n)); D = np.empty((m, n)); R = np.empty((m, n)); S = np.empty((m, n))
    _sdtw_forward(x, y, G, False, True, yT, D, R, S)
    a = S[:-1, 1:]; b = S[1:, :-1]; c = S[:-1, :-1]
    mx = np.maximum(np.maximum(a, b), c)
    sec = np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))
    nt = ~(sec - mx < -38.0)
    args = np.stack([a - mx, b - mx, c - mx])[:, nt]
    with np.errstate(all="ignore"):
        e = np.exp(args); tmp = e.sum(axis=0)
    ab = np.abs(args)
    return dict(nontrivial_cells=int(nt.sum()),
                exp_specialcase=int(((ab >= 512) & (args >= -746)).sum()),
                exp_subnormal_result=int(((e > 0) & (e < 2.2250738585072014e-308)).sum()),
                exp_below_m746=int((args < -746).sum()),
                exp_tiny_1px=int((ab < 2.0 ** -54).sum() - nt.sum()),   # minus the max term itself (x = 0)
                log_near1=int(((tmp >= 0.9375) & (tmp < 1.0644) & (tmp != 1.0)).sum()),
                log_exactly_1=int((tmp == 1.0).sum()))


def check_value(P, Q):
    gv, batch = lockW.make_batch(N, 4)
    ng = len(P) // N * N
    XG, YG = to_lanes(P[:ng]), to_lanes(Q[:ng])
    out = np.empty((XG.shape[0], N))
    batch(XG, YG, T, T, 3, G, out)
    lock = out.ravel()
    scal = np.array([_sdtw_value(p, q, G, True) for p, q in zip(P[:ng], Q[:ng])])
    ts = np.array([tm.soft_dtw(p, q, gamma=G) for p, q in zip(P[:ng], Q[:ng])])
    return ng, int((lock == scal).sum()), int((lock == ts).sum()), int((scal == ts).sum())


def check_grad(Zs, Xs, per=16):
    """Zs[g] centre for series Xs[g*per:(g+1)*per]; compares value, G, and E."""
    fwd, og, _ = lockG.make(4, True, True)
    WS = lockG.workspace(T, T)
    n_ok = n_ok_ts = n_E = n_E_ok = tot = 0
    mask = _njit_compute_mask(T, T, 0, None, None)
    for g in range(len(Zs)):
        Z = np.ascontiguousarray(Zs[g]); X = np.ascontiguousarray(Xs[g * per:(g + 1) * per])
        ZL, XG = lockG.prep(Z, X)
        v = np.empty(len(X)); Gr = np.empty((len(X),) + Z.shape)
        og(Z, X, ZL, XG, G, v, Gr, *WS)
        rv = np.empty(len(X)); rG = np.empty_like(Gr)
        _objgrad_range(Z, X, G, True, 0, len(X), 1, rv, rG)
        for s in range(len(X)):
            tot += 1
            n_ok += bool(v[s] == rv[s] and (Gr[s] == rG[s]).all())
            if s < 3:      # tslearn is slow-ish: 3 series per group
                tv, tg = _softdtw_func(Z, X[s], 1.0, G, 0, None, None)
                n_ok_ts += bool(v[s] == tv and (Gr[s] == tg).all())
        # E of the first group-of-N lanes vs tslearn's _njit_soft_dtw_grad
        S_, D_, Rf, E_, clo, chi = WS[0], WS[1], WS[2], WS[3], WS[4], WS[5]
        fwd(ZL, XG[0], T, T, 3, G, True, S_, D_, Rf)
        lockG.backward(Rf, D_, T, T, G, E_, clo, chi)
        El = E_.reshape(T, T, N)
        for l in range(min(N, len(X))):
            D = cdist(Z, X[l]) ** 2
            R = _njit_accumulated_matrix_from_distance_matrix(D, mask, G)
            Et = _njit_soft_dtw_grad(D, R, G)
            n_E += 1
            n_E_ok += bool((El[:, :, l] == Et).all())
        lockG.clear_band(E_, T, clo, chi)
    return tot, n_ok, n_ok_ts, n_E, n_E_ok


if __name__ == "__main__":
    t0 = time.time()
    allc = {}
    for name, (P, Q) in sets().items():
        P = np.ascontiguousarray(P); Q = np.ascontiguousarray(Q)
        ng, ok_s, ok_t, st = check_value(P, Q)
        sc = {}
        for p, q in zip(P[:200], Q[:200]):
            for k, v in special_counts(p, q).items():
                sc[k] = sc.get(k, 0) + v
        print(f"[value] {name}: lanes {ng}: lock==scalar {ok_s}, lock==tslearn {ok_t} (scalar==tslearn {st}); "
              f"rare paths in used cells (first 200 pairs): {sc}", flush=True)
        # gradient: centres = first series of each block of 16, series = Q
        nG = min(len(P) // 16, 12)
        tot, ok, okts, nE, okE = check_grad(P[:nG], Q[:nG * 16])
        print(f"[grad]  {name}: series {tot}: (value, G) == scalar {ok}; == tslearn _softdtw_func {okts}/{min(3, 16) * nG}; "
              f"E matrix == tslearn _njit_soft_dtw_grad {okE}/{nE}", flush=True)
    print("elapsed %.0f s" % (time.time() - t0))
