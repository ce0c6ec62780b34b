"""The experiments -- the paper's six, three beyond it, and the fits of the inferred reading --
declared as data, run with cached, resumable results.

This module owns the registry :data:`EXPERIMENTS` (id, title, notebook, cases,
loop counts per profile), :func:`run_experiment` (one tidy ``pandas`` table per
experiment: one row per loop, or per CEM sample), the result cache under
``data/results/`` and the paper-style summary tables (:func:`summary_table`).
Filling the cache for many experiments at once, in one pool of workers, is
:mod:`uavwind.fill`'s; its tasks are this module's cache entries (:class:`Entry`).

A *case* is one row of an experiment: a :class:`~uavwind.scenarios.Setting`
plus the labels that place it in the paper's table (scenario, number of
environments, thrust changes, direction). Every experiment is built under a
*reading* (:data:`~uavwind.scenarios.READINGS`: ``"inferred"``, the default, or
``"halves"``), which fixes the group layout and the turbulence variant; every
result row says which. Profiles scale the work:

* ``paper`` -- the paper's counts (50 loops per case, 500 for the Exp 1
  light/light case, CEM with N = 30, Ne = 4 for 20 iterations);
* ``quick`` -- a few loops per case, for CI and first looks.

Common random numbers: every case of an experiment uses the experiment's seed,
so loop ``i`` flies the same thrust sequence in every case (for Exp 4 the number
of changes differs, so the sequences share their random stream, not their
shape). Cases are therefore compared pairwise, loop by loop.

Caching (:mod:`uavwind.cache`): results are stored per *chunk* (one case, a
range of at most ``CHUNK`` loops) as Parquet files named by a digest of everything
that determines them (setting, seed, loop range, engine, clustering parameters,
:data:`RESULTS_VERSION`). A finished chunk is never recomputed; an interrupted
run resumes at the first missing chunk; changing a setting recomputes only
that setting's chunks. Files are written atomically, verified on reading (a
damaged chunk is moved aside and recomputed) and locked while computed.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import pandas as pd

from .cache import (RESULTS_VERSION, Expected, cache_key, cached, check_writable, read_verified,
                    results_dir)
from ..method.clustering import check_engine
from ..sim.vehicle import check_scalar
from ..sim.observation import CONSUMER_NOISE, OBSERVATIONS, Noise
from .conditions import (PAPER_SCENARIOS, TURBULENCE_CANDIDATES, Layout, Setting, WindCondition,
                        direction_settings, environment_count_settings, get_reading,
                        make_setting, range_similarity_settings, table3_setting)
from ..method.search import cem, random_search

__all__ = ["EXPERIMENTS", "PROFILES", "Case", "Experiment", "get_experiment", "run_experiment",
           "summary_table", "paper_table", "results_dir", "RESULTS_VERSION", "CHUNK",
           "FIT_RATIOS", "DEFAULT_READING", "provenance", "NOISE_LEVELS", "BIAS_LEVELS",
           "Entry"]

#: The reading experiments run under unless told otherwise.
DEFAULT_READING = "inferred"
#: Loops per cached chunk.
CHUNK = 50
#: Profiles: loop counts and CEM sizes.
PROFILES = {
    "paper": {"loops": 50, "long_loops": 500, "fit_loops": 20,
              "cem": {"n_samples": 30, "n_elite": 4, "max_iter": 20}},
    "quick": {"loops": 4, "long_loops": 8, "fit_loops": 2,
              "cem": {"n_samples": 6, "n_elite": 2, "max_iter": 3}},
}
#: Default seed of every experiment (its SeedSequence root).
DEFAULT_SEED = 20240101


@dataclass(frozen=True)
class Case:
    """One row of an experiment: a setting and its labels in the paper's table."""

    setting: Setting
    labels: dict = field(hash=False, compare=False)
    long: bool = False  # uses the profile's long loop count (Exp 1's 500-loop case)
    fit: bool = False  # uses the profile's fit loop count (the inference experiments)


@dataclass(frozen=True)
class Experiment:
    """An experiment of the paper, as data.

    Attributes
    ----------
    id : str
        ``"example"`` (the worked example), ``"exp1"`` ... ``"exp6"``, and the
        inference experiments ``"fit_layout"`` and ``"fit_turbulence"``.
    title : str
    question : str
    notebook : str
        Notebook file (under ``notebooks/``) that presents it.
    paper_table : str
        The paper's table (or figure) it regenerates.
    kind : {"random", "cem"}
    build : callable
        ``(reading) -> list[Case]``.
    tables_as : str
        Id of the experiment whose table layout and paper values this one shares
        (empty: its own).
    search : dict
        Extra arguments of the search (e.g. CEM's ``rank_by``); part of the cache key.
    group_by : tuple of str
        Label columns of :func:`summary_table`'s rows (max and mean per group).
    paper_keys : tuple of str
        Columns that join a result row to the paper's row in :func:`comparison_table`
        (empty: the paper reports nothing to compare with).
    summary : callable, optional
        ``df -> DataFrame`` replacing the max/mean summary (CEM, the fits).
    reference : callable, optional
        ``df -> DataFrame`` of the paper's rows (``paper_keys``, ``scenario``,
        ``maximum``, ``mean``); default: :func:`uavwind.paper.load_paper_values`.
    """

    id: str
    title: str
    question: str
    notebook: str
    paper_table: str
    kind: str
    build: object = field(repr=False)
    tables_as: str = ""
    search: dict = field(default_factory=dict, hash=False, compare=False)
    group_by: tuple = ("scenario",)
    paper_keys: tuple = ()
    summary: object = field(default=None, repr=False)
    reference: object = field(default=None, repr=False)

    def cases(self, reading=None):
        """The cases under ``reading`` (a name or :class:`~uavwind.scenarios.Reading`)."""
        return self.build(get_reading(DEFAULT_READING if reading is None else reading))


# --------------------------------------------------------------------------- #
# the six experiments
# --------------------------------------------------------------------------- #
def _scenario_label(a, b):
    return f"{a.label.capitalize()} vs {b.label}"


def _make(reading, a, b, n, **kwargs):
    return make_setting(a, b, n, **reading.builder_kwargs, **kwargs)


def _exp1(reading):
    cases = []
    for k, (a, b) in PAPER_SCENARIOS.items():
        cases.append(Case(_make(reading, a, b, 5),
                          {"scenario": _scenario_label(a, b), "scenario_id": k, "long_run": False}))
    a, b = PAPER_SCENARIOS[1]
    cases.append(Case(_make(reading, a, b, reading.long_run_per_group),
                      {"scenario": _scenario_label(a, b) + " (long run)", "scenario_id": 1,
                       "long_run": True}, long=True))
    return cases


def _sweep(builder, label_key):
    def build(reading):
        cases = []
        for k in (1, 2, 3, 4):
            a, b = PAPER_SCENARIOS[k]
            for s in builder(a, b, **reading.builder_kwargs):
                cases.append(Case(s, {"scenario": _scenario_label(a, b), "scenario_id": k,
                                      label_key: s.n_env}))
        return cases
    return build


#: Exp 4's thrust-change counts: the paper's labels and the change times they mean
#: (its "12 changes, a change every second" is 11 changes after t = 0 on the
#: whole-second grid: a new thrust every second, 12 segments).
THRUST_CHANGES = {0: 0, 2: 2, 4: 4, 6: 6, 8: 8, 10: 10, 12: 11}


def _exp4(reading):
    cases = []
    for k in (1, 2, 3, 4):
        a, b = PAPER_SCENARIOS[k]
        for label, n in THRUST_CHANGES.items():
            cases.append(Case(_make(reading, a, b, 10, n_changes=n),
                              {"scenario": _scenario_label(a, b), "scenario_id": k,
                               "thrust_changes": label}))
    return cases


def _direction(reading):
    return direction_settings("light constant", "light shear", 10, **reading.builder_kwargs)


def _exp5(reading):
    same, opposite = _direction(reading)
    base = "Light constant vs light shear"
    return [Case(same, {"scenario": f"{base} - similar direction", "direction": "similar"}),
            Case(opposite, {"scenario": f"{base} - opposite direction", "direction": "opposite"})]


def _exp6(reading):
    # the same setting as Exp 5's similar-direction case, so CEM and random search
    # are compared on identical environments (as the paper compares Fig 9 with Fig 8)
    same, _ = _direction(reading)
    return [Case(same, {"scenario": "Light constant vs light shear"})]


def _example(reading):
    return [Case(table3_setting(), {"scenario": "Strong shear vs light constant (Table 3)"})]


#: Gap-to-spacing ratios on which ``fit_layout`` measures the silhouette curve.
FIT_RATIOS = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0, 15.0, 20.0, 28.0, 40.0, 56.0, 80.0, 112.0,
              160.0, 224.0)


def _fit_layout(reading):
    """Table 4's same-strength pairs (5 per group) on the lattice, gap ratio by gap ratio."""
    cases = []
    for k, (a, b) in PAPER_SCENARIOS.items():
        if a.strength != b.strength:
            continue
        for rho in FIT_RATIOS:
            s = make_setting(a, b, 5, layout=Layout("fit", gap_ratio=rho))
            cases.append(Case(s, {"scenario": _scenario_label(a, b), "scenario_id": k,
                                  "gap_ratio": rho}, fit=True))
    return cases


def _fit_turbulence(reading):
    """Table 4's light constant vs strong turbulence under each turbulence candidate."""
    a, b = PAPER_SCENARIOS[7]
    return [Case(make_setting(a, b, 5, layout=reading.layout, turbulence=t),
                 {"scenario": _scenario_label(a, b), "scenario_id": 7, "candidate": name})
            for name, t in TURBULENCE_CANDIDATES.items()]


#: Exp 7's white position-noise levels [m] (0.02: RTK) and bias levels [m] (on 0.1 m white).
NOISE_LEVELS = (0.0, 0.02, 0.1, 0.3, 0.5, 1.0, 2.0, 5.0)
BIAS_LEVELS = (0.5, 1.0, 2.0)
#: Correlation time of Exp 7's Gauss-Markov bias [s].
BIAS_TIME = 300.0


def _beyond_scenarios(reading):
    """The three scenarios of Exps 7-9: the worked example, light vs light constant, and
    light constant vs light shear (5 environments per group)."""
    out = [("Strong shear vs light constant (Table 3)", table3_setting())]
    for a, b in (("light constant", "light constant"), ("light constant", "light shear")):
        s = _make(reading, a, b, 5)
        out.append((_scenario_label(WindCondition.parse(a), WindCondition.parse(b)), s))
    return out


def _exp7(reading):
    cases = []
    for label, s in _beyond_scenarios(reading):
        levels = [(sig, 0.0) for sig in NOISE_LEVELS] + [(0.1, b) for b in BIAS_LEVELS]
        for sig, bias in levels:
            noise = Noise(position=sig, bias=bias, bias_time=BIAS_TIME)
            cases.append(Case(replace(s, noise=noise, baseline=True),
                              {"scenario": label, "noise_sigma": sig, "noise_bias": bias}))
    return cases


def _exp8(reading):
    cases = []
    for label, s in _beyond_scenarios(reading):
        for obs in OBSERVATIONS:
            for name, noise in (("none", None), ("consumer", CONSUMER_NOISE)):
                cases.append(Case(replace(s, observation=obs, noise=noise),
                                  {"scenario": label, "observation": obs, "noise": name}))
    return cases


def _baseline_summary(df):
    from ..analysis.beyond import baseline_table
    return baseline_table(df)


def _cem_summary(df):
    g = df.groupby("iteration")["score"]
    elite = df[df["elite"]].groupby("iteration")["score"].mean()
    return pd.DataFrame({"max": g.max(), "mean": g.mean(), "elite_mean": elite,
                         "best_so_far": g.max().cummax()})


def _example_reference(df):
    from .paper import load_paper_values
    ref = load_paper_values("example")
    score = float(ref.loc[ref["quantity"] == "score", "value"].iloc[0])
    return pd.DataFrame({"scenario": [df["scenario"].iloc[0]], "maximum": [score],
                         "mean": [float("nan")]})


EXPERIMENTS = {e.id: e for e in [
    Experiment("example", "Worked example", "How does one loop look, and how do 50 random "
               "loops score, for strong shear vs light constant?", "model.md",
               "Table 3, Figure 3", "random", _example, paper_keys=("scenario",),
               reference=_example_reference),
    Experiment("exp1", "Wind speed", "How does the wind speed of the two conditions affect "
               "the classification?", "exp1_wind_speed.md", "Table 4, Figure 4", "random", _exp1,
               paper_keys=("scenario_id", "long_run")),
    Experiment("exp2", "Range similarity", "Does a wider gap between the groups' speed ranges "
               "raise the score?", "exp2_range_similarity.md", "Table 5, Figure 5", "random",
               _sweep(range_similarity_settings, "n_env"), group_by=("scenario", "n_env"),
               paper_keys=("scenario_id", "n_env")),
    Experiment("exp3", "Number of environments", "Do more environments per group raise the "
               "score, with the gap fixed?", "exp3_environment_count.md", "Table 6, Figure 6",
               "random", _sweep(environment_count_settings, "n_env"),
               group_by=("scenario", "n_env"), paper_keys=("scenario_id", "n_env")),
    Experiment("exp4", "Thrust changes", "Does the number of thrust changes matter?",
               "exp4_thrust_changes.md", "Table 7, Figure 7", "random", _exp4,
               group_by=("scenario", "thrust_changes"), paper_keys=("scenario_id", "thrust_changes")),
    Experiment("exp5", "Wind direction", "Do opposite wind directions remove the "
               "misclassifications?", "exp5_wind_direction.md", "Table 8, Figure 8", "random",
               _exp5, paper_keys=("direction",)),
    Experiment("exp6", "Cross-Entropy Method", "Does CEM find better thrust sequences than "
               "random search?", "exp6_cem.md", "Figure 9", "cem", _exp6,
               summary=_cem_summary),
    Experiment("exp6_raw", "Cross-Entropy Method, raw silhouette", "Does CEM find a signal "
               "when its elites are ranked by the raw silhouette instead of the floored score?",
               "exp6_cem.md", "Figure 9 (alternative objective)", "cem", _exp6,
               tables_as="exp6", search={"rank_by": "silhouette"}, summary=_cem_summary),
    Experiment("exp7", "Position noise", "How much GNSS-like position noise can the method "
               "take (the paper's sub-metre claim)?", "exp7_noise.md", "beyond the paper",
               "random", _exp7, group_by=("scenario", "noise_sigma", "noise_bias")),
    Experiment("exp8", "What to observe", "Which observation separates which wind conditions: "
               "position, velocity, acceleration or position and velocity?",
               "exp8_observation.md", "beyond the paper", "random", _exp8,
               group_by=("scenario", "observation", "noise")),
    Experiment("exp9", "A physics baseline", "What does a model-based wind estimate from the "
               "same positions achieve, beside causal curiosity?", "exp9_baseline.md",
               "beyond the paper", "random", _exp7, summary=_baseline_summary),
    Experiment("fit_layout", "Layout fit", "Which gap between same-strength groups gives "
               "Table 4's scores?", "inference.md", "Table 4 (fit)", "random", _fit_layout,
               group_by=("scenario_id", "scenario", "gap_ratio")),
    Experiment("fit_turbulence", "Turbulence reading", "Which reading of the cited Dryden "
               "implementation gives Table 4's turbulence row?", "inference.md",
               "Table 4 (scenario 7)", "random", _fit_turbulence, group_by=("candidate",)),
]}


def get_experiment(exp_id):
    """The :class:`Experiment` called ``exp_id``; ``ValueError`` naming the valid ids."""
    if not isinstance(exp_id, str):
        raise TypeError(f"experiment id must be a string, got {type(exp_id).__name__}")
    if exp_id not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {exp_id!r}; valid: {', '.join(EXPERIMENTS)}")
    return EXPERIMENTS[exp_id]


def _check_profile(profile):
    """A profile by name, or a dict with the same keys as :data:`PROFILES` entries."""
    if isinstance(profile, dict):
        missing = {"loops", "long_loops", "fit_loops", "cem"} - set(profile)
        if missing:
            raise ValueError(f"profile dict is missing {sorted(missing)}")
        for k in ("loops", "long_loops", "fit_loops"):
            check_scalar(profile[k], f"profile[{k!r}]", low=1, high=10 ** 6, integer=True)
        cem_cfg = profile["cem"]
        if not isinstance(cem_cfg, dict) or set(cem_cfg) != {"n_samples", "n_elite", "max_iter"}:
            raise ValueError("profile['cem'] must be a dict with n_samples, n_elite, max_iter")
        n = check_scalar(cem_cfg["n_samples"], "profile['cem']['n_samples']", low=1,
                         high=10 ** 5, integer=True)
        check_scalar(cem_cfg["n_elite"], "profile['cem']['n_elite']", low=1, high=n, integer=True)
        check_scalar(cem_cfg["max_iter"], "profile['cem']['max_iter']", low=1, high=10 ** 4,
                     integer=True)
        return profile
    if profile not in PROFILES:
        raise ValueError(f"profile must be one of {sorted(PROFILES)} (or a dict), got {profile!r}")
    return PROFILES[profile]


def _check_seed_engine(seed, engine):
    """``(seed, engine)`` checked, the engine defaulted."""
    return check_scalar(seed, "seed", low=0, high=2 ** 63 - 1, integer=True), check_engine(engine)


# --------------------------------------------------------------------------- #
# running
# --------------------------------------------------------------------------- #
def run_experiment(exp_id, profile="quick", seed=DEFAULT_SEED, n_jobs=None, engine=None,
                   results=None, progress=True, cases=None, reading=None, **params):
    """Run (or load from the cache) one experiment.

    Parameters
    ----------
    exp_id : str
        An id of :data:`EXPERIMENTS`: ``"example"``, ``"exp1"`` ... ``"exp9"``,
        ``"exp6_raw"``, ``"fit_layout"``, ``"fit_turbulence"``.
    profile : {"quick", "paper"}
    seed : int
        Root seed (one SeedSequence for the experiment).
    n_jobs : int, optional
        Worker processes (-1/None = all cores); results do not depend on it.
    engine : str, optional
        Clustering engine (default: fast when available).
    results : path-like, optional
        Cache folder (default :func:`results_dir`).
    cases : list of int, optional
        Run only these case indices (for partial runs and tests).
    reading : str or Reading, optional
        The reading of the paper (default :data:`DEFAULT_READING`, ``"inferred"``).
    **params
        Clustering parameters (see :func:`uavwind.clustering.score_loop`).

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
    prof = _check_profile(profile)
    seed, engine = _check_seed_engine(seed, engine)
    rd = get_reading(DEFAULT_READING if reading is None else reading)
    all_cases = exp.cases(rd)
    chosen = _check_cases(cases, len(all_cases))
    # before any work: a run must never compute what it cannot keep
    folder = check_writable(results_dir(results))
    frames, n_cached = [], 0
    entries = _entries(exp, prof, rd, seed, engine, folder, params, chosen)
    for entry in entries:
        df, hit = entry.fill(n_jobs=n_jobs, progress=progress)
        n_cached += hit
        frames.append(df.assign(**entry.labels))
    out = pd.concat(frames, ignore_index=True)
    first = ["experiment", "reading", "case", *[k for k in out.columns if k in _LABEL_KEYS]]
    out = out[first + [c for c in out.columns if c not in first]]
    out.attrs.update(experiment=exp.id, profile=str(profile), seed=seed, cached=n_cached,
                     chunks=len(entries), reading=rd.name, engine=engine)
    return out


@dataclass(frozen=True, eq=False)
class Entry:
    """One cache entry an experiment needs: a chunk of loops of one case (``kind="loops"``,
    loops ``start .. stop-1``) or one whole CEM run (``kind="cem"``).

    :func:`run_experiment` fills its entries one after the other, each over ``n_jobs``
    workers; :func:`uavwind.fill.fill_cache` fills the missing entries of many experiments at once, one
    entry per worker, longest first. Either way an entry is computed under its lock,
    verified and written atomically by :func:`uavwind.cache.cached`, and its rows do not
    depend on the number of workers.
    """

    path: Path
    kind: str
    setting: Setting
    seed: int
    engine: str
    params: dict
    start: int = 0
    stop: int = 0
    search: dict = field(default_factory=dict)  # CEM: n_samples, n_elite, max_iter, rank_by
    labels: dict = field(default_factory=dict)

    @property
    def n_rows(self):
        """Rows the entry holds: loops, or CEM samples."""
        if self.kind == "cem":
            return self.search["n_samples"] * self.search["max_iter"]
        return self.stop - self.start

    @property
    def cost(self):
        """A rough cost, for ordering only: rows x environments^2 x observed channels (a
        soft-DTW k-means loop grows with the square of the number of series)."""
        s = self.setting
        channels = 6 if s.observation == "position+velocity" else 3
        return self.n_rows * s.n_env ** 2 * channels

    def compute(self, n_jobs=None, progress=False):
        """The entry's rows, computed (no cache)."""
        s = self.setting
        if self.kind == "cem":
            res = cem(s, seed=self.seed, n_jobs=n_jobs, engine=self.engine, progress=progress,
                      **self.search, clustering=self.params)
            return res.samples
        return random_search(s, n_loops=self.stop - self.start, seed=self.seed,
                             loop_offset=self.start, n_jobs=n_jobs, engine=self.engine,
                             progress=progress, **self.params)

    def fill(self, n_jobs=None, progress=False):
        """``(rows, from_cache)``: the verified cached rows, or computed and stored."""
        from .. import __version__
        meta = {"setting_key": self.setting.key(), "seed": self.seed, "engine": self.engine,
                "uavwind_version": __version__, "results_version": RESULTS_VERSION}
        return cached(self.path, lambda: self.compute(n_jobs, progress), meta, self._expected)

    def present(self):
        """True if a trusted copy is cached (a damaged one is moved aside, with a warning)."""
        return read_verified(self.path, self._expected) is not None

    @property
    def _expected(self):
        """What a cached copy must hold to be trusted."""
        return Expected(self.setting.key(), self.seed, self.engine, self.n_rows)


def _entries(exp, prof, rd, seed, engine, folder, params, chosen):
    """The cache entries of ``exp``'s cases ``chosen`` under reading ``rd``, in case order."""
    cases = exp.cases(rd)
    out = []
    for ci in chosen:
        case = cases[ci]
        s = case.setting
        labels = {"experiment": exp.id, "reading": rd.name, "case": ci, **case.labels}
        if exp.kind == "cem":
            cfg = prof["cem"]
            # the key spells the cap "n_iter", its name when these results were first
            # cached: the name changed, the results did not
            extra = {"n_samples": cfg["n_samples"], "n_elite": cfg["n_elite"],
                     "n_iter": cfg["max_iter"], **exp.search}
            key = cache_key(s, seed, 0, cfg["max_iter"], engine, params, extra=extra)
            out.append(Entry(folder / exp.id / f"cem-{key}.parquet", "cem", s, seed, engine,
                             params, search={**cfg, **exp.search}, labels=labels))
            continue
        n_loops = _n_loops(prof, case)
        for start in range(0, n_loops, CHUNK):
            stop = min(start + CHUNK, n_loops)
            key = cache_key(s, seed, start, stop, engine, params)
            # one folder for every experiment: a setting that two experiments share
            # (e.g. Exp 2, 3 and 4 at 20 environments) is computed once
            path = folder / "loops" / f"{s.key()}-{start:04d}-{stop:04d}-{key}.parquet"
            out.append(Entry(path, "loops", s, seed, engine, params, start, stop,
                             labels=labels))
    return out


_LABEL_KEYS = ("scenario", "scenario_id", "long_run", "n_env", "thrust_changes", "direction",
               "gap_ratio", "candidate", "noise_sigma", "noise_bias", "observation", "noise")


def _check_cases(cases, n):
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


def _n_loops(prof, case):
    return prof["fit_loops"] if case.fit else prof["long_loops"] if case.long else prof["loops"]


# --------------------------------------------------------------------------- #
# summaries in the paper's layout
# --------------------------------------------------------------------------- #
def _maxmean(df, by):
    from ..core.stats import bootstrap_ci, correct_share

    rows = {}
    for key, sub in df.groupby(list(by), sort=False):
        s = sub.sort_values("loop")["score"].to_numpy()
        mean, lo, hi = bootstrap_ci(s)
        rows[key] = {"max": float(s.max()), "mean": mean, "ci_low": lo, "ci_high": hi,
                     "correct_rate": correct_share(sub), "n_loops": s.size}
    out = pd.DataFrame.from_dict(rows, orient="index")
    out.index = (pd.MultiIndex.from_tuples(out.index, names=list(by)) if len(by) > 1
                 else pd.Index([k[0] if isinstance(k, tuple) else k for k in out.index],
                               name=by[0]))
    return out


def _record(df):
    """The :class:`Experiment` whose tables ``df`` (an experiment's results) is laid out as."""
    exp = get_experiment(df["experiment"].iloc[0])
    return EXPERIMENTS[exp.tables_as] if exp.tables_as else exp


def summary_table(df):
    """The replication's version of the paper's table for ``df`` (an experiment's results):
    ``max``, ``mean`` (with its 95% bootstrap ``ci_low``/``ci_high``), ``correct_rate``
    and ``n_loops`` per the experiment's ``group_by`` columns, or its own ``summary``
    (CEM: ``max``, ``mean``, ``elite_mean``, ``best_so_far`` per iteration)."""
    exp = _record(df)
    return exp.summary(df) if exp.summary is not None else _maxmean(df, exp.group_by)


def paper_table(exp_id):
    """The paper's reported values for ``exp_id`` (see :mod:`uavwind.paper`)."""
    from .paper import load_paper_values
    return load_paper_values(exp_id)


def provenance(df):
    """One line saying how a result table was made: experiment, reading, profile, seed,
    engine, loops, library version and commit (for captions)."""
    from .. import __version__
    a = df.attrs
    return (f"Made by experiment {a.get('experiment', '?')} under the {a.get('reading', '?')!r} "
            f"reading, profile {a.get('profile', '?')}, seed {a.get('seed', '?')}, engine "
            f"{a.get('engine', '?')}, {len(df)} rows; uavwind {__version__}, commit {_commit()}.")


def _commit():
    import subprocess
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, cwd=Path(__file__).resolve().parent, timeout=5)
        return out.stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def n_loops_total(profile):
    """Total loops (or CEM samples) of every experiment in ``profile``."""
    prof = _check_profile(profile)
    total = 0
    for exp in EXPERIMENTS.values():
        if exp.kind == "cem":
            total += prof["cem"]["n_samples"] * prof["cem"]["max_iter"]
        else:
            total += sum(_n_loops(prof, c) for c in exp.cases())
    return total


def comparison_table(df):
    """Paper vs replication, side by side, for the rows the paper reports.

    Columns: ``paper_max, max, paper_mean, mean``, ``ci_low``, ``ci_high`` (95%
    bootstrap interval of the mean over loops), ``correct_rate``, ``n_loops`` and the
    ``case``; index: the
    paper's row labels. Reads the paper's values through :mod:`uavwind.paper`.
    """
    from .paper import load_paper_values
    from ..core.stats import bootstrap_ci, correct_share

    exp = _record(df)
    if not exp.paper_keys:
        raise ValueError(f"no paper table to compare for {exp.id!r}")
    ref = exp.reference(df) if exp.reference is not None else load_paper_values(exp.id)
    keys = exp.paper_keys
    rows = []
    for _, p in ref.iterrows():
        sub = df
        for k in keys:
            sub = sub.loc[sub[k] == p[k]]
        if not len(sub):
            continue
        est, lo, hi = bootstrap_ci(sub["score"].to_numpy())
        units = {"n_env": "environments", "thrust_changes": "thrust changes"}
        label = p["scenario"] + "".join(f", {p[k]} {units[k]}" for k in keys if k in units)
        rows.append({"row": label, "case": int(sub["case"].iloc[0]), "paper_max": p["maximum"],
                     "max": sub["score"].max(), "paper_mean": p["mean"], "mean": est,
                     "ci_low": lo, "ci_high": hi,
                     "correct_rate": correct_share(sub), "n_loops": len(sub)})
    return pd.DataFrame(rows).set_index("row")
