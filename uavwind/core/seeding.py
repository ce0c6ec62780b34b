"""Seeding by address: every random draw of the project comes from a child of one
``numpy.random.SeedSequence``, addressed by its spawn key.

This module owns the rule (replication notes, decision 8): loop ``i`` of a search draws its
thrust from the child ``(i, 0)`` of the experiment's root and its turbulence from ``(i, 1)``,
the loop's observation noise from ``(i, 1, 2)``, and so on. A child is computed from the root
and its key alone (:func:`child_seed`), never by spawning in order, so results do not depend
on the number of workers or the order tasks finish.
"""

from __future__ import annotations

import numpy as np

__all__ = ["root_seed", "child_seed", "child_rng"]


def root_seed(seed: int | np.random.SeedSequence | None) -> np.random.SeedSequence:
    """``seed`` as a SeedSequence: an int (>= 0), None (fresh entropy) or a SeedSequence."""
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None or isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        if seed is not None and seed < 0:
            raise ValueError(f"seed must be an int >= 0, a numpy.random.SeedSequence or None, "
                             f"got {seed}")
        return np.random.SeedSequence(seed)
    raise TypeError(f"seed must be an int, a numpy.random.SeedSequence or None, "
                    f"got {type(seed).__name__}")


def child_seed(root: int | np.random.SeedSequence | None, *key: int) -> np.random.SeedSequence:
    """The descendant of ``root`` with spawn key ``root.spawn_key + key`` (no state touched).

    >>> child_seed(np.random.SeedSequence(1), 3, 0).spawn_key
    (3, 0)
    """
    root = root_seed(root)
    return np.random.SeedSequence(root.entropy, spawn_key=tuple(root.spawn_key) + tuple(key),
                                  pool_size=root.pool_size)


def child_rng(root: int | np.random.SeedSequence | None, *key: int) -> np.random.Generator:
    """A PCG64 generator on :func:`child_seed` ``(root, *key)``."""
    return np.random.Generator(np.random.PCG64(child_seed(root, *key)))
