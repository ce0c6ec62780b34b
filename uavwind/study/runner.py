"""Running experiments: each one as cache entries, filled (or read) and put together.

This module owns :func:`run_experiment` (one tidy ``pandas`` table per experiment: one row
per loop, or per CEM sample, with the case labels and provenance in ``df.attrs``),
:class:`Entry` (one cache entry: a chunk of at most :data:`~uavwind.study.profiles.CHUNK`
random loops of one case, or one whole CEM run) and :func:`experiment_entries`, the entries
an experiment needs under a profile and a reading. Filling the entries of many experiments
at once in one pool is :mod:`uavwind.study.fill`'s; keys, verified reads and atomic writes
are :mod:`uavwind.study.cache`'s.

Caching: a chunk is filed under a digest of everything that determines it (setting, seed,
loop range, engine, clustering parameters, results version). A finished chunk is never
recomputed; an interrupted run resumes at the first missing chunk; changing a setting
recomputes only that setting's chunks. A setting two experiments share (e.g. Exp 2, 3 and 4
at 20 environments) is one entry, computed once.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

from .._version import __version__
from ..core.checks import check_scalar
from ..method.clustering import ClusteringParams, check_engine
from ..method.closed_loop import ClosedLoop, run_episodes
from ..method.search import CEMRun, random_search
from ..sim.multirotor import Multirotor
from ..sim.setting import Setting
from .cache import (RESULTS_VERSION, Expected, cache_key, cached, check_writable, chunk_key,
                    read_verified, results_dir)
from .profiles import CHUNK, DEFAULT_SEED, EPISODE_CHUNK, CEMSize, get_profile
from .readings import DEFAULT_READING, get_reading
from .registry import EXPERIMENTS, Analysis, get_experiment

if TYPE_CHECKING:
    from .profiles import Profile
    from .readings import Reading
    from .registry import Case, Experiment

#: The engine stamp of closed-loop entries (no clustering: the run's engine does not matter).
CLOSED_LOOP_ENGINE = "none"
#: Bump when a change to the closed loop (belief, policies, episodes) alters its rows.
CLOSED_LOOP_VERSION = "1"

__all__ = ["run_experiment", "Entry", "experiment_entries", "check_cases", "case_loops",
           "check_seed_engine", "n_loops_total", "cem_size"]


def cem_size(exp: Experiment, prof: Profile) -> CEMSize:
    """The CEM size ``exp`` runs under ``prof``: the profile's, or scaled down by the
    experiment's ``search_options["cem_scale"]`` (``ceil(f N)`` draws, ``ceil(g
    iterations)``, ``min(N_e, draws)`` elites)."""
    cfg = prof.cem
    scale = exp.search_options.get("cem_scale")
    if not scale:
        return cfg
    n = max(1, math.ceil(cfg.n_samples * scale.get("n_samples", 1.0) - 1e-9))
    return CEMSize(n_samples=n, n_elite=min(cfg.n_elite, n),
                   max_iter=max(1, math.ceil(cfg.max_iter * scale.get("max_iter", 1.0) - 1e-9)))


def check_seed_engine(seed: int, engine: str | None) -> tuple[int, str]:
    """``(seed, engine)`` checked, the engine defaulted."""
    return check_scalar(seed, "seed", low=0, high=2 ** 63 - 1, integer=True), check_engine(engine)


def run_experiment(exp_id: str, profile: str | Profile | Mapping[str, Any] = "quick",
                   seed: int = DEFAULT_SEED, n_jobs: int | None = None,
                   engine: str | None = None, results: os.PathLike | str | None = None,
                   progress: bool = True, cases: Iterable[int] | None = None,
                   reading: str | Reading | None = None,
                   **params: float | str) -> pd.DataFrame:
    """Run (or load from the cache) one entry of the registry: an experiment, or an analysis.

    Parameters
    ----------
    exp_id : str
        An id of :data:`~uavwind.study.registry.REGISTRY`: an experiment (``"example"``,
        ``"exp1"`` ... ``"exp14_cem"``, ``"fit_layout"``, ...), or an analysis
        (:class:`~uavwind.study.registry.Analysis`), computed into the cache or read from it
        with ``profile``, ``seed`` (if it takes one), ``n_jobs`` and ``results``, and what it
        returns returned. ``"exp13"``, Neural-Fly's real flights, read from the folder
        ``$UAVWIND_NEURALFLY`` names (a ``ValueError`` naming the variable when it is not
        set), returns the real-flight rows
        (:func:`uavwind.analysis.real_flights.real_flight_rows`), the simulated twin's
        computed and cached beside them (:func:`uavwind.analysis.figure8.sim_rows`).
    profile : {"quick", "paper"}, Profile or dict
    seed : int
        Root seed (one SeedSequence for the experiment).
    n_jobs : int, optional
        Worker processes (-1/None = all cores); results do not depend on it.
    engine : str, optional
        Clustering engine (default: fast when available).
    results : path-like, optional
        Cache folder (default :func:`~uavwind.study.cache.results_dir`).
    cases : list of int, optional
        Run only these case indices (for partial runs and tests).
    reading : str or Reading, optional
        The reading of the paper (default :data:`DEFAULT_READING`, ``"inferred"``).
    **params
        Clustering parameters (:class:`~uavwind.method.clustering.ClusteringParams`).

    Returns
    -------
    pandas.DataFrame
        Random experiments: one row per loop with the case labels (``case``,
        ``scenario``, ...), ``loop``, ``score``, ``silhouette``, ``correct``, the
        thrust sequence and provenance columns. CEM: one row per sample with
        ``iteration`` and ``sample``. ``df.attrs["cached"]`` counts the chunks
        loaded rather than computed.
    """
    exp = get_experiment(exp_id)
    if isinstance(exp, Analysis):
        return _run_analysis(exp, profile, seed, n_jobs, engine, results, cases, reading,
                             params)
    prof = get_profile(profile)
    seed, engine = check_seed_engine(seed, engine)
    params = ClusteringParams.from_kwargs(params, "clustering parameters").to_dict() if params else {}
    rd = get_reading(DEFAULT_READING if reading is None else reading)
    all_cases = exp.cases(rd)
    chosen = check_cases(cases, len(all_cases))
    folder = results_dir(results)
    entries = experiment_entries(exp, prof, rd, seed, engine, folder, params, chosen)
    # each entry read and verified once: what is cached is used as read, the rest computed
    found = [e.read() for e in entries]
    if any(df is None for df in found):
        # before any work: a run must never compute what it cannot keep
        check_writable(folder)
    frames, n_cached = [], 0
    for entry, df in zip(entries, found):
        hit = df is not None
        if not hit:  # fill() reads again under the entry's lock: another run may have written it
            df, hit = entry.fill(n_jobs=n_jobs, progress=progress)
        n_cached += hit
        frames.append(df.assign(**entry.labels))
    out = pd.concat(frames, ignore_index=True)
    labels = [k for k in entries[0].labels if k not in ("experiment", "reading", "case")]
    first = ["experiment", "reading", "case", *labels]
    out = out[first + [c for c in out.columns if c not in first]]
    out.attrs.update(experiment=exp.id, profile=str(prof), seed=seed, cached=n_cached,
                     chunks=len(entries), reading=rd.name, engine=engine)
    return out


def _run_analysis(item: Analysis, profile, seed, n_jobs, engine, results, cases, reading,
                  params):
    """:func:`run_experiment` of an analysis: computed (or read) by its function, with the
    data it needs checked first; a table it returns has ``attrs["experiment"]`` its id. It
    has no engine, cases, reading or clustering parameters to choose (nor a seed, unless its
    function takes one), and giving one is an error, not ignored."""
    checks = [("seed", seed, DEFAULT_SEED)] if "seed" not in item.takes else []
    checks += [("engine", engine, None), ("cases", cases, None), ("reading", reading, None)]
    given = [name for name, value, default in checks
             if not (value is default or (default is not None and value == default))]
    if given or params:
        what = f"{item.id!r}, {item.title}," if item.title else f"{item.id!r}"
        raise ValueError(f"{what} is an analysis: it takes no {', '.join(given + sorted(params))}")
    item.check_data()
    prof = get_profile(profile)
    seed, _ = check_seed_engine(seed, None)
    got = item.run(prof.name, seed, results, n_jobs=n_jobs)
    if not isinstance(got, pd.DataFrame):
        return got
    out = got.copy()
    out.attrs = {**got.attrs, "experiment": item.id, "profile": prof.name}
    return out


@dataclass(frozen=True, eq=False, kw_only=True)
class Entry:
    """One cache entry an experiment needs: a chunk of random loops of one case
    (``search="random"``, loops ``start .. stop-1``), one whole CEM run (``search="cem"``;
    the fill hands its samples out as tasks, :meth:`cem_run`),
    or a chunk of closed-loop episodes, each flown by every policy (``search="closed_loop"``,
    episodes ``start .. stop-1``; ``engine`` is ``"none"``: no clustering).

    :func:`run_experiment` fills its entries one after the other, each over ``n_jobs``
    workers, each computed under its lock; :func:`uavwind.study.fill.fill_cache` fills the
    missing entries of many experiments at once: a chunk per worker, longest first, under
    its lock, and a CEM run's samples as tasks of their own, the run stored under its lock
    when done (two fills on one folder may then both compute a run; the first stored is
    kept). Either way an entry is verified and written atomically by
    :func:`uavwind.study.cache.cached`, and its rows do not depend on the number of workers.
    """

    path: Path
    search: str
    setting: Setting
    seed: int
    engine: str
    params: dict
    start: int = 0
    stop: int = 0
    # CEM: n_samples, n_elite, max_iter, rank_by; closed loop: policies and the problem's grid
    options: dict = field(default_factory=dict)
    labels: dict = field(default_factory=dict)
    #: What the entry is computed for (:func:`~uavwind.study.cache.chunk_key`): stored in it and
    #: checked on every read
    key: str = ""

    @property
    def n_rows(self) -> int:
        """Rows the entry holds: loops, CEM samples, or episodes x policies x reports."""
        if self.search == "cem":
            return self.options["n_samples"] * self.options["max_iter"]
        if self.search == "closed_loop":
            prob = self.problem
            n_reports = prob.n_segments * (prob.segment_samples // prob.report_samples)
            return (self.stop - self.start) * len(self.options["policies"]) * n_reports
        return self.stop - self.start

    @property
    def problem(self) -> ClosedLoop:
        """The closed-loop problem of a ``"closed_loop"`` entry."""
        grid = {k: v for k, v in self.options.items() if k != "policies"}
        return ClosedLoop(setting=self.setting, **grid)

    @property
    def cost(self) -> int:
        """A rough cost, for ordering only: rows x environments^2 x observed channels (a
        soft-DTW k-means loop grows with the square of the number of series)."""
        s = self.setting
        if self.search == "closed_loop":  # measured: ~0.75 s a multirotor episode, 0.13 s a point mass
            return (self.stop - self.start) * (1100 if isinstance(s.uav, Multirotor) else 200)
        channels = 6 if s.observation == "position+velocity" else 3
        return self.n_rows * s.n_env ** 2 * channels

    def compute(self, n_jobs: int | None = None, progress: bool = False) -> pd.DataFrame:
        """The entry's rows, computed (no cache)."""
        s = self.setting
        if self.search == "cem":
            return self.cem_run().run(n_jobs=n_jobs, progress=progress).samples
        if self.search == "closed_loop":
            return run_episodes(self.problem, list(self.options["policies"]), self.start,
                                self.stop, seed=self.seed, n_jobs=n_jobs)
        return random_search(s, n_loops=self.stop - self.start, seed=self.seed,
                             loop_offset=self.start, n_jobs=n_jobs, engine=self.engine,
                             progress=progress, **self.params)

    def cem_run(self) -> CEMRun:
        """A ``"cem"`` entry's run: :meth:`compute` steps it in this process, the fill
        (:func:`uavwind.study.fill.fill_cache`) hands each of its samples out as a task;
        either way its result's ``samples`` are the entry's rows."""
        if self.search != "cem":
            raise ValueError(f"cem_run() needs a 'cem' entry, this one is {self.search!r}")
        return CEMRun(self.setting, seed=self.seed, engine=self.engine, params=self.params,
                      **self.options)

    def fill(self, n_jobs: int | None = None,
             progress: bool = False) -> tuple[pd.DataFrame, bool]:
        """``(rows, from_cache)``: the verified cached rows, or computed and stored."""
        return cached(self.path, lambda: self.compute(n_jobs, progress), self._meta,
                      self._expected)

    def store(self, rows: pd.DataFrame) -> tuple[pd.DataFrame, bool]:
        """``(rows, from_cache)``: ``rows`` computed elsewhere (by :meth:`compute`, on a
        cluster worker), verified and written as :meth:`fill` writes them; if a trusted copy
        appeared meanwhile, that copy, and ``rows`` are dropped."""
        if not isinstance(rows, pd.DataFrame):
            raise TypeError(f"rows must be a pandas DataFrame, got {type(rows).__name__}")
        return cached(self.path, lambda: rows.copy(), self._meta, self._expected)

    @property
    def _meta(self):
        """The provenance columns every stored row carries."""
        return {"setting_key": self.setting.key(), "seed": self.seed, "engine": self.engine,
                "uavwind_version": __version__, "results_version": RESULTS_VERSION}

    def read(self) -> pd.DataFrame | None:
        """The trusted cached copy, or ``None`` (a damaged one is moved aside, with a
        warning)."""
        return read_verified(self.path, self._expected)

    def present(self) -> bool:
        """True if a trusted copy is cached (a damaged one is moved aside, with a warning)."""
        return self.read() is not None

    @property
    def _expected(self):
        """What a cached copy must hold to be trusted."""
        if self.search == "closed_loop":
            return Expected(self.setting.key(), self.seed, self.engine, self.n_rows,
                            kind="episodes", key=self.key)
        return Expected(self.setting.key(), self.seed, self.engine, self.n_rows,
                        tuple(int(g) for g in self.setting.groups), key=self.key)


def experiment_entries(exp: Experiment, prof: Profile, rd: Reading, seed: int, engine: str,
                       folder: Path, params: dict, chosen: Iterable[int]) -> list[Entry]:
    """The cache entries of ``exp``'s cases ``chosen`` under reading ``rd``, in case order."""
    cases = exp.cases(rd)
    out = []
    for ci in chosen:
        case = cases[ci]
        s = case.setting
        labels = {"experiment": exp.id, "reading": rd.name, "case": ci, **case.labels}
        if exp.search == "cem":
            cfg = cem_size(exp, prof)
            opts = {k: v for k, v in exp.search_options.items() if k != "cem_scale"}
            # the key spells the cap "n_iter", its name when these results were first
            # cached: the name changed, the results did not (a scaled CEM's sizes are in it)
            extra = {"n_samples": cfg.n_samples, "n_elite": cfg.n_elite,
                     "n_iter": cfg.max_iter, **opts}
            key = cache_key(s, seed, 0, cfg.max_iter, engine, params, extra=extra)
            out.append(Entry(path=folder / exp.id / f"cem-{key}.parquet", search="cem",
                             setting=s, seed=seed, engine=engine, params=params,
                             options={**cfg.to_dict(), **opts}, labels=labels,
                             key=chunk_key(s, seed, 0, cfg.max_iter, engine, params,
                                           extra=extra)))
            continue
        if exp.search == "closed_loop":
            opts = dict(exp.search_options)
            for start in range(0, prof.episodes, EPISODE_CHUNK):
                stop = min(start + EPISODE_CHUNK, prof.episodes)
                extra = {**opts, "closed_loop": CLOSED_LOOP_VERSION}
                key = cache_key(s, seed, start, stop, CLOSED_LOOP_ENGINE, {}, extra=extra)
                path = (folder / exp.id /
                        f"{s.key()}-{start:04d}-{stop:04d}-{key}.parquet")
                out.append(Entry(path=path, search="closed_loop", setting=s, seed=seed,
                                 engine=CLOSED_LOOP_ENGINE, params={}, start=start, stop=stop,
                                 options=opts, labels=labels,
                                 key=chunk_key(s, seed, start, stop, CLOSED_LOOP_ENGINE, {},
                                               extra=extra)))
            continue
        n_loops = case_loops(prof, case, exp.id)
        for start in range(0, n_loops, CHUNK):
            stop = min(start + CHUNK, n_loops)
            key = cache_key(s, seed, start, stop, engine, params)
            # one folder for every experiment: a setting that two experiments share
            # (e.g. Exp 2, 3 and 4 at 20 environments) is computed once
            path = folder / "loops" / f"{s.key()}-{start:04d}-{stop:04d}-{key}.parquet"
            out.append(Entry(path=path, search="random", setting=s, seed=seed, engine=engine,
                             params=params, start=start, stop=stop, labels=labels,
                             key=chunk_key(s, seed, start, stop, engine, params)))
    return out


def check_cases(cases: Iterable[int] | None, n: int) -> list[int]:
    """Validated case indices (each in [0, n), no repeats, at least one)."""
    if cases is None:
        return list(range(n))
    if isinstance(cases, (str, bytes)) or not hasattr(cases, "__iter__"):
        raise TypeError(f"cases must be a list of case indices, got {type(cases).__name__}")
    out = [check_scalar(c, "cases", low=0, high=n - 1, integer=True) for c in cases]
    if not out:
        raise ValueError(f"cases must name at least one case index in [0, {n - 1}], got none")
    if len(set(out)) != len(out):
        raise ValueError(f"cases must not repeat an index, got {list(cases)}")
    return out


def case_loops(prof: Profile, case: Case, experiment: str | None = None) -> int:
    """Loops ``case`` runs under profile ``prof`` (its fit, long, side, flyable or plain
    count; a plain case of ``experiment`` its sized count, :meth:`Profile.loops_of`)."""
    if case.flyable:
        return prof.flyable_loops
    if case.side:
        return prof.side_loops
    if case.fit:
        return prof.fit_loops
    if case.long:
        return prof.long_loops
    return prof.loops if experiment is None else prof.loops_of(experiment)


def n_loops_total(profile: str | Profile | Mapping[str, Any]) -> int:
    """Total loops (or CEM samples, or closed-loop flights: episodes x policies) of every
    experiment in ``profile``."""
    prof = get_profile(profile)
    total = 0
    for exp in EXPERIMENTS.values():
        if exp.search == "closed_loop":
            total += prof.episodes * len(exp.search_options["policies"]) * len(exp.cases())
        elif exp.search == "cem":
            cfg = cem_size(exp, prof)
            total += cfg.n_samples * cfg.max_iter * len(exp.cases())
        else:
            total += sum(case_loops(prof, c, exp.id) for c in exp.cases())
    return total
