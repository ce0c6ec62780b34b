"""Realistic inputs: loops of UAV trajectories from uavwind's simulator (20 series x 120
steps x 3, positions in m) and centre-like series (group means).  Cached in data_cache.npz
(generated once with uavwind, loop i = seed i, setting "light constant" vs "light constant",
10 + 10 environments) so the benchmarks do not need uavwind importable."""
import os
import numpy as np

_F = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data_cache.npz")
NLOOPS = 12


def _generate():
    import uavwind as uw
    Xs = []
    for i in range(NLOOPS):
        s = uw.make_setting("light constant", "light constant", 10)
        Xs.append(np.asarray(s.simulate(s.sample_thrust(np.random.default_rng(i)), seed=i), dtype=np.float64))
    np.savez(_F, X=np.array(Xs))


def loop_data(i=3, n=10):
    if not os.path.exists(_F):
        _generate()
    X = np.ascontiguousarray(np.load(_F)["X"][i])
    C = np.ascontiguousarray(np.stack([X[:n].mean(0), X[n:].mean(0)]))
    return X, C
