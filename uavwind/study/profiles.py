"""Profiles: how much work an experiment does (loops per case, CEM sizes).

This module owns :class:`Profile` and :data:`PROFILES`: ``"paper"`` (the paper's counts: 50
loops per case, 500 for Exp 1's long run, CEM with N = 30, Ne = 4 for 20 iterations; the
experiments beyond the paper sized to their questions by :data:`uavwind.study.sizing.SIZINGS`)
and ``"quick"`` (a few loops per case, for CI and first looks), with :func:`get_profile`, which
also takes a custom profile as a :class:`Profile` or a dict of the same fields; and
:data:`DEFAULT_SEED`, the root seed of every experiment, and :data:`CHUNK`, the loops per
cache entry.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from types import MappingProxyType
from typing import Any

from ..core.checks import Range, check_fields, check_instance, check_scalar
from .registry import EXPERIMENTS
from .sizing import SIZINGS

__all__ = ["CEMSize", "Profile", "PROFILES", "get_profile", "DEFAULT_SEED", "CHUNK",
           "EPISODE_CHUNK"]

#: Default seed of every experiment (its SeedSequence root).
DEFAULT_SEED = 20240101
#: Loops per cached chunk.
CHUNK = 50
#: Closed-loop episodes per cached chunk (each flown by every policy of the experiment).
EPISODE_CHUNK = 25


@dataclass(frozen=True, kw_only=True)
class CEMSize:
    """The size of a CEM run: ``n_samples`` (N) draws per iteration, the ``n_elite`` (N_e)
    best refit the distribution, at most ``max_iter`` iterations."""

    n_samples: int
    n_elite: int
    max_iter: int

    def __post_init__(self):
        check_fields(self, {"n_samples": Range(1, 10 ** 5, integer=True),
                            "n_elite": lambda s: Range(1, s.n_samples, integer=True),
                            "max_iter": Range(1, 10 ** 4, integer=True)}, "profile['cem'][{!r}]")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True, kw_only=True)
class Profile:
    """Loop counts of a run.

    Attributes
    ----------
    loops : int
        Loops per case.
    long_loops : int
        Loops of a case marked ``long`` (Exp 1's 500-loop light-vs-light case).
    fit_loops : int
        Loops per case of the inference fits.
    cem : CEMSize
    side_loops : int
        Loops per case of the wide sweeps beyond the paper (Exp 11's channels x actions x
        scenarios x noise); default ``fit_loops``.
    episodes : int
        Closed-loop flights (held-out test environments) per case of Exp 12; default 200
        (the paper profile's count).
    flyable_loops : int
        Loops per case of Exp 14's flyable manoeuvres; default ``side_loops`` (the quick
        profile: 1).
    sized_loops : mapping of str to int
        Loops per plain case of the named experiments, instead of ``loops`` (the paper
        profile: the counts :data:`~uavwind.study.sizing.SIZINGS` chose for Exps 7-10); an
        experiment's fit, long, side and flyable cases keep their own counts.
    name : str
        ``"paper"``, ``"quick"``, or a name of your own (``"custom"`` by default).
    """

    loops: int
    long_loops: int
    fit_loops: int
    cem: CEMSize
    side_loops: int | None = None
    episodes: int = 200
    flyable_loops: int | None = None
    sized_loops: Mapping[str, int] = field(default_factory=dict, hash=False)
    name: str = field(default="custom", compare=False)

    def __post_init__(self):
        if self.side_loops is None:
            object.__setattr__(self, "side_loops", self.fit_loops)
        if self.flyable_loops is None:
            object.__setattr__(self, "flyable_loops", self.side_loops)
        counts = ("loops", "long_loops", "fit_loops", "side_loops", "episodes", "flyable_loops")
        check_fields(self, dict.fromkeys(counts, Range(1, 10 ** 6, integer=True)),
                     "profile[{!r}]")
        sized = check_instance(self.sized_loops, "profile['sized_loops']", Mapping)
        for exp_id, n in sized.items():
            if exp_id not in EXPERIMENTS:
                raise ValueError("profile['sized_loops'] maps experiment ids to loops per case; "
                                 f"got the key {exp_id!r}, not one of {sorted(EXPERIMENTS)}")
            check_scalar(n, f"profile['sized_loops'][{exp_id!r}]", low=1, high=10 ** 6,
                         integer=True)
        object.__setattr__(self, "sized_loops", MappingProxyType(
            {k: int(sized[k]) for k in sorted(sized)}))
        cem = self.cem
        if isinstance(cem, Mapping):
            if set(cem) != {"n_samples", "n_elite", "max_iter"}:
                raise ValueError("profile['cem'] must be a dict with n_samples, n_elite, "
                                 f"max_iter, got keys {sorted(cem)}")
            cem = CEMSize(**cem)
        object.__setattr__(self, "cem", check_instance(cem, "profile['cem']", CEMSize))
        check_instance(self.name, "profile name", str)

    def __str__(self):
        return self.name

    def loops_of(self, experiment: str) -> int:
        """Loops per plain case of ``experiment`` (its ``sized_loops`` entry, else ``loops``)."""
        return self.sized_loops.get(experiment, self.loops)


PROFILES = {
    # Exps 7-10 run their sized loops per case (the paper's 50 at the least), Exp 11 its
    # sweep (side cases: also Exp 14's copies of them, which read its cache) and Exp 12 its
    # episodes as sized; Exp 14's own flyable sweep stays at the fits' 20
    "paper": Profile(name="paper", loops=50, long_loops=500, fit_loops=20,
                     side_loops=SIZINGS["exp11"].count, flyable_loops=20,
                     episodes=SIZINGS["exp12"].count,
                     sized_loops={e: SIZINGS[e].count for e in ("exp7", "exp8", "exp9", "exp10")},
                     cem=CEMSize(n_samples=30, n_elite=4, max_iter=20)),
    # quick: a first look at every page, and what `make check` (CI) builds beside the suite. Two
    # loops a case (the fewest that give a spread), one a case of the wide multirotor sweeps
    # (Exp 11's 80 cases, Exp 14's flyable ones: their cells show single loops), six Exp 12
    # episodes, a CEM of two iterations of four draws
    "quick": Profile(name="quick", loops=2, long_loops=4, fit_loops=2, side_loops=1, episodes=6,
                     flyable_loops=1, cem=CEMSize(n_samples=4, n_elite=2, max_iter=2)),
}


def get_profile(profile: str | Profile | Mapping[str, Any]) -> Profile:
    """A :class:`Profile` by name (:data:`PROFILES`), itself, or from a dict with the keys
    ``loops``, ``long_loops``, ``fit_loops`` and ``cem`` (``n_samples``, ``n_elite``,
    ``max_iter``)."""
    if isinstance(profile, Profile):
        return profile
    if isinstance(profile, Mapping):
        need = {"loops", "long_loops", "fit_loops", "cem"}
        missing, extra = (need - set(profile),
                          set(profile) - need - {"name", "side_loops", "episodes", "flyable_loops",
                                                  "sized_loops"})
        if missing or extra:
            raise ValueError(f"profile dict must have exactly the keys {sorted(need)}; "
                             f"missing {sorted(missing)}, unknown {sorted(extra)}")
        return Profile(**profile)
    if isinstance(profile, str) and profile in PROFILES:
        return PROFILES[profile]
    raise ValueError(f"profile must be one of {sorted(PROFILES)}, a Profile or a dict, "
                     f"got {profile!r}")
