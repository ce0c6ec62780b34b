"""Compile every numba kernel once, into numba's on-disk cache: what ``make venv`` runs.

This module owns :func:`warm` and the command ``python -m uavwind.warmup PART``. A kernel
compiled here is loaded from the cache by every later process (a page, a test, a script
after ``make venv``) instead of compiled again: the first loop of a new process on an AMD
EPYC took 33.9 s on an empty cache and 4-5 s after this. Two parts, so that ``make venv``
can compile them side by side on two cores:

* ``"engine"`` -- the soft-DTW engine (:func:`uavwind.method.softdtw.warmup`): k-means, the
  barycentres, the silhouettes, serial and threaded (about a minute on one core);
* ``"sim"`` -- the multirotor (RotorPy's physics in :mod:`uavwind.sim._rotor_kernels`): an
  open-loop flight, a rollout's segment (the closed loops') and a figure-8 flown under the
  position controller (the real-flight twin);
* ``"reference"`` -- tslearn's own kernels, the ``"tslearn"`` engine the fast one is checked
  against (:func:`uavwind.method.clustering.cache_tslearn_kernels` lets them use numba's cache;
  a few of its kernels, made inside factory functions, are compiled again by every process).
"""

from __future__ import annotations

import sys
import time

import numpy as np

from . import PAPER_EXAMPLE, ConstantWind, Multirotor, make_setting, simulate
from .analysis import twin
from .method.clustering import score_loop
from .method.softdtw import warmup as engine_warmup
from .sim.rollout import Rollout

__all__ = ["warm", "PARTS"]

#: What :func:`warm` compiles, by part.
PARTS = ("engine", "sim", "reference")


def warm(part: str) -> float:
    """Compile (or load from the cache) the kernels of ``part`` (:data:`PARTS`); returns the
    wall time [s] it took."""
    if part not in PARTS:
        raise ValueError(f"part must be one of {list(PARTS)}, got {part!r}")
    t0 = time.perf_counter()
    if part == "engine":
        engine_warmup(parallel=True, every=True)
    elif part == "reference":
        s = make_setting("light constant", "strong shear", 3, dt=0.2, duration=4.0, n_changes=3)
        score_loop(s.simulate(s.sample_thrust(np.random.default_rng(0))), s.groups,
                   engine="tslearn")
    else:
        uav, wind = Multirotor(preset="rotorpy", start="hover"), ConstantWind([[1.0, 1.0, 0.0]])
        simulate(PAPER_EXAMPLE, wind, uav=uav)
        # a rollout's segment (Exps 10-12 and 14's closed loops, their sensitivities)
        ro = Rollout.for_flight(uav, wind, 0.1, 1.0)
        env = np.zeros(1, dtype=int)
        ro.advance(ro.start(env, [0.0, 0.0, 10.0]), env, [[0.0, 0.0, uav.weight]], 0, 2)
        bare = twin.BARE  # the position controller's kernels; > 4 pi, whole 0.02 s steps
        twin.simulated_flight(bare.vehicle(), "35wind", 0, 13.0, bare)
    return time.perf_counter() - t0


def main(argv=None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    parts = args or list(PARTS)
    for part in parts:
        if part not in PARTS:
            print(f"python -m uavwind.warmup: part must be one of {list(PARTS)}, got {part!r}",
                  file=sys.stderr)
            return 2
    for part in parts:
        print(f"warmup {part}: {warm(part):.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
