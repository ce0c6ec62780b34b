"""The lockstep kernels (N pairs per SIMD vector: soft-DTW value, value + gradient, DTW) against
tslearn and the scalar kernels, with ``==``: on loops of every Table 2 scenario (the two
readings alternating) and both vehicles, and on crafted inputs that force every rare path
of the vector exp/log (the lane masks)."""
import numpy as np
import pytest
from numba import njit
from tslearn.barycenters.softdtw import _softdtw_func
from tslearn.metrics import cdist_soft_dtw

import uavwind as uw
from uavwind.method import softdtw as fk
from uavwind.method.clustering import score_loop
from uavwind.method.softdtw import _consts, _dispatch, _kernels
from uavwind.method.softdtw._kernels import (_objgrad_batch_serial, _sdtw_cross_serial,
                                             _sdtw_forward)
from uavwind.method.softdtw._libm import _exp_glibc, _libm_selfcheck, _log_glibc
from uavwind.method.softdtw._lockstep import _objgrad_lockstep, _sdtw_cross_lockstep
from uavwind.method.softdtw._simd import N, vload, vlt, vstore
from uavwind.method.softdtw._vlibm import vexp, vexp_care, vlog, vlog_care
from uavwind.study.conditions import PAPER_SCENARIOS

pytestmark = pytest.mark.skipif(not _libm_selfcheck(),
                                reason="the glibc replicas (and so the lockstep kernel) are off")


def _same(a, b):
    """Bit-identical doubles (NaN payloads aside)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all((a == b) | (np.isnan(a) & np.isnan(b))))


def _one_centre(Z, X, gamma, nw=1):
    """The lockstep barycentre objective and gradient of one centre (K = 1)."""
    Zs = np.ascontiguousarray(Z[None])
    cid = np.zeros(len(X), dtype=np.int64)
    starts = np.array([0, len(X)], dtype=np.int64)
    objs, G = _objgrad_lockstep(Zs, cid, starts, X, gamma, nw)
    return objs[0], G[0]


def _check_kernels(X, centres, gamma, tslearn=True):
    """Values and barycentre objective/gradient: lockstep (serial and threaded) == scalar (==
    tslearn when asked)."""
    X = np.ascontiguousarray(X, dtype=float)
    centres = np.ascontiguousarray(centres, dtype=float)
    lock = np.empty((len(X), len(centres)))
    lock2 = np.empty_like(lock)
    scal = np.empty_like(lock)
    _sdtw_cross_lockstep(X, centres, gamma, lock)
    _sdtw_cross_lockstep(X, centres, gamma, lock2, nw=2)
    _sdtw_cross_serial(X, centres, gamma, True, scal)
    assert _same(lock, scal) and _same(lock2, scal)
    if tslearn:
        assert _same(lock, cdist_soft_dtw(X, centres, gamma=gamma))
    for Z in centres:
        v, G = _one_centre(Z, X, gamma)
        v2, G2 = _one_centre(Z, X, gamma, nw=2)
        rv, rG = _objgrad_batch_serial(Z, X, gamma, True)
        assert v == rv and v2 == rv and _same(G, rG) and _same(G2, rG)
    # every centre at once, each with its own series (k-means' clusters sharing the
    # vectors, a lane's neighbours belonging to another centre): each centre's value and
    # gradient are its own, scalar kernel's
    K = min(len(centres), len(X))
    starts = np.linspace(0, len(X), K + 1).astype(np.int64)
    Zs = np.ascontiguousarray(centres[:K])
    cid = np.repeat(np.arange(len(Zs), dtype=np.int64), np.diff(starts))
    for nw in (1, 2):
        objs, G = _objgrad_lockstep(Zs, cid, starts, X, gamma, nw)
        for j, Z in enumerate(Zs):
            rv, rG = _objgrad_batch_serial(Z, X[starts[j]:starts[j + 1]], gamma, True)
            assert objs[j] == rv and _same(G[j], rG)
    if tslearn:  # per series, tslearn's own value and gradient (a cluster of one)
        for s in range(min(3, len(X))):
            v, G = _one_centre(centres[0], X[s:s + 1], gamma)
            tv, tG = _softdtw_func(centres[0], X[s], 1.0, gamma, 0, None, None)
            assert v == tv and _same(G.ravel(), np.ravel(tG))


def _loop(scenario, reading, seed, n_per_group=5, vehicle="point mass"):
    a, b = PAPER_SCENARIOS[scenario]
    kwargs = dict(uw.get_reading(reading).builder_kwargs)
    if vehicle == "multirotor":
        kwargs.update(uav=uw.Multirotor(), observation="attitude")
    s = uw.make_setting(a, b, n_per_group, **kwargs)
    thrust = s.sample_thrust(np.random.default_rng(seed))
    if s.plain and vehicle == "point mass":
        return s.simulate(thrust, seed=seed), s.groups
    return np.asarray(s.observe(thrust, seed=seed)[0]), s.groups


# every Table 2 scenario once, the readings alternating (both readings fly the same kernels
# on other winds); light constant vs light constant under the inferred reading is the
# longest k-means run of the set (tslearn: 20 s of the 64 s all 14 pairs took)
LOOPS = [(1, "inferred"), (2, "halves"), (3, "inferred"), (4, "halves"), (5, "inferred"),
         (6, "halves"), (7, "inferred")]


def test_the_loops_cover_every_scenario_and_both_readings():
    assert sorted(s for s, _ in LOOPS) == sorted(PAPER_SCENARIOS)
    assert {r for _, r in LOOPS} == {"inferred", "halves"}


# `make test` checks the scenario of the fewest iterations (3, inferred; 2.5 s here); the rest
# are slow (`make check`, what CI runs)
@pytest.mark.parametrize("scenario, reading", [
    pytest.param(s, r, marks=() if (s, r) == (3, "inferred") else pytest.mark.slow)
    for s, r in LOOPS])
def test_lockstep_loops_equal_tslearn_on_every_scenario(scenario, reading):
    """A whole loop through the engine (lockstep by default) == tslearn's loop, and its
    kernels == tslearn's and the scalar kernels' on the loop's series and centres."""
    X, g = _loop(scenario, reading, seed=100 + scenario)
    assert _dispatch._use_lockstep(True)
    fast = score_loop(X, g, engine="fast")
    ref = score_loop(X, g, engine="tslearn")
    assert np.array_equal(fast.labels, ref.labels) and fast.n_iter == ref.n_iter
    assert fast.score == ref.score
    assert fast.silhouette == ref.silhouette or (np.isnan(fast.silhouette)
                                                 and np.isnan(ref.silhouette))
    km = fk.SoftDTWKMeans(n_clusters=2, gamma=0.5, random_state=0, parallel=False).fit(X)
    _check_kernels(X, km.cluster_centers_, 0.5)


@pytest.mark.parametrize("scenario", [1, 4, 7])
def test_lockstep_equals_tslearn_on_the_multirotor_with_six_features(scenario):
    """RotorPy's quadrotor observed through its attitude (6 features, not 3): the general
    cost loop, not the 3-feature one."""
    X, g = _loop(scenario, "inferred", seed=7, n_per_group=3, vehicle="multirotor")
    assert X.shape[2] == 6
    km = fk.SoftDTWKMeans(n_clusters=2, gamma=0.5, random_state=0, parallel=False,
                          max_iter=5).fit(X)
    _check_kernels(X, km.cluster_centers_, 0.5)


@pytest.mark.parametrize("gamma", [0.5, 1.0, 0.1, 2.0, 0.3])
def test_lockstep_equals_the_scalar_kernel_on_odd_shapes_and_gammas(gamma):
    """Lengths shorter than a block, unequal lengths, pair counts that leave lanes idle, 1-6
    features, gamma a power of two (product with the reciprocal) or not (division)."""
    rng = np.random.default_rng(int(gamma * 10))
    for na, nb, m, n, d in [(7, 3, 50, 40, 3), (5, 2, 3, 7, 1), (1, 1, 1, 1, 2),
                            (3, 3, 4, 4, 3), (6, 2, 5, 9, 3), (2, 5, 13, 2, 4), (9, 2, 30, 30, 6)]:
        for scale in (1.0, 1e-3, 30.0):
            A = rng.normal(size=(na, m, d)).cumsum(1) * scale
            B = rng.normal(size=(nb, n, d)).cumsum(1) * scale
            _check_kernels(A, B, gamma, tslearn=False)
            if m == n:  # the objective needs Z and X of one length only per call
                _check_kernels(B, A[:2], gamma, tslearn=False)


def test_lockstep_is_exact_where_a_cells_three_terms_tie():
    """The forward cell takes two exps, not three, choosing each term's by equality with
    the max, the second or the smallest; series on a coarse integer grid make many cells
    whose terms tie (two or three equal, or equal to the max), with gammas of both kinds."""
    rng = np.random.default_rng(11)
    for gamma in (0.5, 0.3, 4.0):
        A = rng.integers(0, 2, size=(9, 12, 2)).astype(float)
        B = rng.integers(0, 2, size=(3, 12, 2)).astype(float)
        _check_kernels(A, B, gamma, tslearn=True)
        _check_kernels(np.zeros((5, 6, 1)), np.zeros((2, 6, 1)), gamma, tslearn=True)


def test_the_gradient_runs_on_the_scalar_kernels_where_the_jacobian_does_not_contract(
        monkeypatch):
    """The lockstep gradient adds each term with one fused multiply-add, the operation the
    scalar Jacobian (tslearn's expression under fastmath) compiles to on this host; the check
    reads the scalar kernel's own answer, and where it did not fuse, the barycentres run on
    the scalar kernels, with the same doubles."""
    from fractions import Fraction

    e, v = 1.0 / 3.0, 1.0 / 7.0
    G = np.array([[-(2 * e * v)]])
    _kernels._jacobian_product_sq_euc(np.array([[v]]), np.zeros((1, 1)), np.array([[e]]),
                                      np.zeros(1, np.int64), np.zeros(1, np.int64), G)
    fused = float(Fraction(2 * e) * Fraction(v) + Fraction(-(2 * e * v)))
    assert fused != 0.0 and G[0, 0] in (0.0, fused)
    assert _dispatch.jacobian_contracts() == (G[0, 0] == fused)
    X, g = _loop(3, "inferred", seed=5)
    lock = fk.fit(X, parallel=False)

    def refuse(*args):
        raise AssertionError("the lockstep gradient ran")

    monkeypatch.setattr(_dispatch, "_CONTRACTS", [False])
    monkeypatch.setattr(_dispatch, "_objgrad_lockstep", refuse)
    scal = fk.fit(X, parallel=False)
    assert np.array_equal(lock.labels, scal.labels) and lock.inertia == scal.inertia
    assert np.array_equal(lock.cluster_centers, scal.cluster_centers)


def _walk(rng, n, scale, T=120, d=3):
    v = np.cumsum(rng.normal(size=(n, T, d)), axis=1)
    v = v / np.maximum(np.abs(v).max(axis=1, keepdims=True), 1e-300)
    return scale * v + scale * 0.2 * rng.normal(size=(n, 1, d))


def _rare_paths(x, y, gamma=0.5):
    """How often the cells whose exp/log results are used (the non-trivial cells of the
    scalar kernel) reach each rare path of glibc's exp and log."""
    m, n = len(x), len(y)
    S = np.empty((m, n))
    _sdtw_forward(x, y, gamma, False, True, np.empty((x.shape[1], n)), np.empty((m, n)),
                  np.empty((m, n)), S)
    a, b, c = S[:-1, 1:], S[1:, :-1], S[:-1, :-1]
    mx = np.maximum(np.maximum(a, b), c)
    second = np.maximum(np.minimum(a, b), np.minimum(np.maximum(a, b), c))
    used = ~(second - mx < -38.0)
    args = np.stack([a - mx, b - mx, c - mx])[:, used]
    with np.errstate(all="ignore"):
        e = np.exp(args)
    tmp = e.sum(axis=0)
    return dict(exp_special=int(((np.abs(args) >= 512) & (args >= -746)).sum()),
                exp_subnormal=int(((e > 0) & (e < 2.2250738585072014e-308)).sum()),
                exp_below_746=int((args < -746).sum()),
                log_near_1=int(((tmp >= 0.9375) & (tmp < 1.0644) & (tmp != 1.0)).sum()),
                log_of_1=int((tmp == 1.0).sum()))


def test_lockstep_is_exact_where_the_rare_exp_and_log_paths_are_taken():
    """Small-scale and near-identical series put the used exp arguments into glibc's special
    case (subnormal results), below -746 (exactly 0), and the log's argument into its near-1
    polynomial and exactly 1; every path is hit, and every lane still equals the scalar
    kernel and tslearn."""
    rng = np.random.default_rng(2024)
    sets = [(_walk(rng, 8, s), _walk(rng, 2, s)) for s in (0.3, 3.0, 10.0, 30.0)]
    b = _walk(rng, 8, 5.0)
    sets.append((np.where(rng.random((8, 1, 1)) < 0.5, b, b + 1e-9), b[:2]))
    a = _walk(rng, 8, 1.0)
    sets.append((a * 1e-160, (a[:2] + 0.01 * rng.normal(size=a[:2].shape)) * 1e-160))
    hits = dict.fromkeys(_rare_paths(sets[0][0][0], sets[0][1][0]), 0)
    for X, C in sets:
        _check_kernels(X, C, 0.5)
        for x in X:
            for k, v in _rare_paths(x, C[0]).items():
                hits[k] += v
    assert all(v > 0 for v in hits.values()), hits


@njit
def _apply(x, care, full_e, full_l, care_e, care_l):
    """Every path (vexp, vlog) and the cared-for paths (vexp_care, vlog_care) over x, N lanes
    at a time; care > 0.5 marks a cared-for lane."""
    for q in range(0, x.shape[0] - N + 1, N):
        v = vload(x, q)
        mask = vlt(0.5, vload(care, q))
        vstore(full_e, q, vexp(v))
        vstore(full_l, q, vlog(v))
        vstore(care_e, q, vexp_care(v, mask))
        vstore(care_l, q, vlog_care(v, mask))


def test_vector_exp_and_log_equal_the_scalar_replica_on_every_path():
    """vexp/vlog (every path, selected) and vexp_care/vlog_care (the rare paths only when a
    cared-for lane needs them) == glibc's replicas bit for bit on the cared-for lanes:
    subnormal and underflowing exp, |x| < 2**-54, overflow, the near-1 and subnormal log,
    zero, negative, inf and NaN, mixed in one vector with ordinary lanes."""
    rng = np.random.default_rng(5)
    special = [0.0, -0.0, 1e-300, -1e-300, 2.0 ** -60, -745.0, -745.2, -746.5, -800.0, -708.5,
               -720.0, 709.0, 709.8, 710.0, np.inf, -np.inf, np.nan, 1.0, 1.0 + 2.0 ** -52,
               1.0 - 2.0 ** -53, 0.95, 1.05, 5e-324, 2.2e-308, -1.0, 1e308, 0.5, 3.0]
    x = np.concatenate([np.repeat(special, 3), rng.uniform(-760, 10, 4000),
                        rng.uniform(0.93, 1.07, 4000), 10.0 ** rng.uniform(-320, 300, 4000)])
    rng.shuffle(x)
    x = x[: len(x) // N * N]
    care = rng.random(len(x)) < 0.7
    ref_e = np.array([_exp_glibc(v) for v in x])
    with np.errstate(all="ignore"):
        ref_l = np.array([_log_glibc(v) for v in x])
    full_e, full_l, care_e, care_l = (np.empty_like(x) for _ in range(4))
    _apply(x, care.astype(np.float64), full_e, full_l, care_e, care_l)
    assert _same(full_e, ref_e) and _same(full_l, ref_l)
    assert _same(care_e[care], ref_e[care]) and _same(care_l[care], ref_l[care])


def test_the_scalar_reference_stays_selectable(monkeypatch):
    """UAVWIND_SOFTDTW_LOCKSTEP=0 (here: the switch it sets) runs the scalar kernels, and the
    answers are the same doubles."""
    X, g = _loop(2, "inferred", seed=3)
    lock = fk.fit(X, parallel=False)
    sil = fk.silhouette_score(X, lock.labels)

    def refuse(*args):
        raise AssertionError("the lockstep kernel ran")

    monkeypatch.setattr(_consts, "LOCKSTEP", False)
    monkeypatch.setattr(_dispatch, "_sdtw_cross_lockstep", refuse)
    monkeypatch.setattr(_dispatch, "_objgrad_lockstep", refuse)
    monkeypatch.setattr(_dispatch, "_dtw_upper_lockstep", refuse)
    scal = fk.fit(X, parallel=False)
    assert fk.silhouette_score(X, scal.labels) == sil
    assert np.array_equal(lock.labels, scal.labels) and lock.inertia == scal.inertia
    assert np.array_equal(lock.cluster_centers, scal.cluster_centers)
    assert not _dispatch._use_lockstep(True) and not _dispatch._use_lockstep(False, True)


@pytest.mark.parametrize("shape", [(2, 1, 1), (5, 7, 3), (7, 40, 3), (9, 30, 6), (10, 120, 3)])
def test_lockstep_dtw_matrix_equals_the_scalar_kernel_and_tslearn(shape):
    """The silhouette's DTW matrix, N pairs per vector (serial and threaded) == the scalar
    kernel == tslearn's cdist_dtw, pair counts that fill the lanes and ones that leave some
    idle, on random walks and on a loop's own series."""
    from tslearn.metrics import cdist_dtw

    from uavwind.method.softdtw._kernels import _dtw_upper_range
    from uavwind.method.softdtw._lockstep import _dtw_upper_lockstep

    nts, n, d = shape
    rng = np.random.default_rng(nts * n)
    sets = [rng.normal(size=shape).cumsum(1) * s for s in (1e-3, 1.0, 50.0)]
    if shape == (10, 120, 3):
        sets.append(np.ascontiguousarray(_loop(7, "inferred", seed=1)[0]))
    for X in sets:
        lock, lock2, scal = (np.zeros((nts, nts)) for _ in range(3))
        _dtw_upper_lockstep(X, lock)
        _dtw_upper_lockstep(X, lock2, nw=2)
        _dtw_upper_range(X, 0, nts * (nts - 1) // 2, 1, scal)
        assert _same(lock, scal) and _same(lock2, scal)
        assert _same(lock, cdist_dtw(X))
        assert _same(fk.dtw_pdist(X), scal)


def test_the_barycentre_workspace_is_per_thread_and_never_reused_dirty(monkeypatch):
    """The barycentre kernel keeps its workspace (whole accumulated and gradient matrices,
    zeroed once) from call to call, per thread. Calls of other shapes in between, threads
    calling at once, and a call that fails half-way with its gradient matrix dirty all leave
    the next call's answer the scalar kernel's, to the double."""
    from concurrent.futures import ThreadPoolExecutor

    from uavwind.method.softdtw import _lockstep

    rng = np.random.default_rng(5)
    cases = [(rng.standard_normal((9, 30, 3)).cumsum(1), rng.standard_normal((30, 3))),
             (rng.standard_normal((11, 25, 3)).cumsum(1), rng.standard_normal((25, 3))),
             (rng.standard_normal((4, 30, 2)).cumsum(1), rng.standard_normal((30, 2)))]
    cases = [(np.ascontiguousarray(X), np.ascontiguousarray(Z)) for X, Z in cases]
    refs = [_objgrad_batch_serial(Z, X, 0.5, True) for X, Z in cases]

    def check(i):
        v, G = _one_centre(cases[i][1], cases[i][0], 0.5)
        return v == refs[i][0] and _same(G, refs[i][1])

    assert all(check(i) for i in (0, 0, 1, 0, 2, 2, 0))  # reused, remade, reused
    with ThreadPoolExecutor(3) as pool:  # nogil kernels: the threads really overlap
        assert all(pool.map(check, [0, 1, 2] * 8))

    X, Z = cases[0]
    check(0)  # this thread's workspace is now cases[0]'s shape

    def fail_half_way(Zs, cid, starts, Xs, gamma, *ws):
        ws[5][:] = 1.0  # E dirty, as a kernel stopped half-way would leave it
        raise MemoryError("stopped half-way")
    real = _lockstep._objgrad_serial
    monkeypatch.setattr(_lockstep, "_objgrad_serial", fail_half_way)
    with pytest.raises(MemoryError):
        _one_centre(Z, X, 0.5)
    monkeypatch.setattr(_lockstep, "_objgrad_serial", real)
    assert check(0)


@pytest.mark.slow
def test_the_lanes_follow_the_features_numba_compiles_for(tmp_path):
    """N is 8 where the compiled code may use AVX-512F and 4 otherwise, read from
    NUMBA_CPU_FEATURES where it is set (numba's cache keys on those features, so a kernel of
    one lane count is never loaded under the other): a child process compiled for Haswell
    with AVX-512 off runs 4 lanes and gives the same soft-DTW values as this process."""
    import json
    import os
    import subprocess
    import sys

    from uavwind.method.softdtw._simd import lanes_for
    assert lanes_for("+avx2,+fma,+avx512f,+avx512bw") == 8
    assert lanes_for("+avx2,+avx512f,-avx512f") == 4  # the last mention decides
    assert lanes_for("+avx2,+fma,-avx512f") == 4 and lanes_for("") == 4
    assert lanes_for("+avx2, +avx512f") == 8
    code = ("import json, numpy as np; from uavwind.method.softdtw._simd import N; "
            "from uavwind.method.softdtw._lockstep import _sdtw_cross_lockstep; "
            "A = np.random.default_rng(3).normal(size=(5, 30, 3)).cumsum(1); "
            "o = np.empty((5, 5)); _sdtw_cross_lockstep(A, A, 0.5, o); "
            "print(json.dumps([N, o.tolist()]))")
    env = {**os.environ, "NUMBA_CPU_NAME": "haswell",
           "NUMBA_CPU_FEATURES": "+avx,+avx2,+fma,+sse4.2,-avx512f",
           "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, timeout=600, check=True)
    lanes, values = json.loads(out.stdout.strip().splitlines()[-1])
    assert lanes == 4
    A = np.random.default_rng(3).normal(size=(5, 30, 3)).cumsum(1)
    here = np.empty((5, 5))
    _sdtw_cross_lockstep(A, A, 0.5, here)
    assert np.array(values).tolist() == here.tolist()


def test_work_arrays_start_on_a_cache_line():
    """The kernels' work arrays start on a 64-byte boundary (numba aligns its arrays to 32
    bytes and numpy to 16, where every other or every 8-lane load and store would straddle
    two cache lines), whatever offset the allocator returns."""
    from uavwind.method.softdtw._lockstep import ALIGN, _aligned_empty, _objgrad_workspace
    assert ALIGN == 64
    for k in (1, 7, 8, 100, 960, 115200):
        a = _aligned_empty(k)
        assert a.shape == (k,) and a.ctypes.data % ALIGN == 0 and a.flags.c_contiguous
    ws = _objgrad_workspace(120, 120, 3)
    for arr in ws[:6]:
        assert arr.ctypes.data % ALIGN == 0
    assert ws[5].shape == (120 * 120 * N,) and not ws[5].any()  # E starts all zero


def test_the_engines_measured_names_are_public():
    """What the benchmarks time, through public names only: the lanes, the threads, the
    kernel switch (restored on leaving, the same doubles either way), the clusters'
    objectives in one call (= one call per centre) and the pair costs alone."""
    import numba

    assert fk.LANES == N
    assert fk.n_threads() == (numba.get_num_threads() if _consts.PARALLEL else 1)
    X, _ = _loop(1, "inferred", seed=4)
    centres = [X[:5].mean(0), X[5:].mean(0)]
    before = _consts.LOCKSTEP
    values = {}
    for on in (True, False):
        with fk.use_lockstep(on):
            assert _consts.LOCKSTEP is on
            values[on] = fk.soft_dtw_objgrad_many(centres, [X[:5], X[5:]], 0.5, parallel=False)
        assert _consts.LOCKSTEP is before
    for (v1, g1), (v2, g2), Z, Xs in zip(values[True], values[False], centres, [X[:5], X[5:]]):
        v, g = fk.soft_dtw_objgrad(Z, Xs, 0.5, parallel=False)
        assert v1 == v2 == v and np.array_equal(g1, g) and np.array_equal(g2, g)
    with pytest.raises(ValueError, match="one length"):
        fk.soft_dtw_objgrad_many(centres, [X], 0.5)
    fill, cells = fk.lockstep_costs(centres[0], X, sqrtsq=True)
    assert cells == N * X.shape[1] * X.shape[1]
    fill()  # fills the costs, returns nothing
    with pytest.raises(ValueError, match="features"):
        fk.lockstep_costs(centres[0][:, :2], X)
