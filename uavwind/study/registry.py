"""The experiments as data: the paper's six, three beyond it, and the two fits of the
inferred reading.

This module owns :class:`Experiment` (id, title, question, notebook, the paper's table it
regenerates, how its loops are searched, how it is summarised) and the registry
:data:`EXPERIMENTS`, with the look-ups on it, and beside them the experiments on measured
flights (:class:`MeasuredExperiment`, :data:`MEASURED`: Exp 13), whose rows the analysis
layer computes and the package's face registers (:func:`register_measured`). What each
experiment flies -- :class:`Case` (one row of an experiment: a
:class:`~uavwind.sim.setting.Setting` and its labels in the paper's table), the case
builders and the constants they use (the vehicles, channels and noise levels of the
experiments beyond the paper) -- is :mod:`uavwind.study.cases`' (import them from there).
Running an experiment is :mod:`uavwind.study.runner`'s; summarising it,
:mod:`uavwind.analysis.tables`'. Adding an experiment is one entry here and
its builder, one notebook and one line in the book's ``_toc.yml``.

Every experiment is built under a *reading* (:data:`~uavwind.study.readings.READINGS`),
which fixes the group layout and the turbulence variant. Common random numbers: every case
of an experiment uses the experiment's seed, so loop ``i`` flies the same thrust sequence in
every case (for Exp 4 the number of changes differs, so the sequences share their random
stream, not their shape); cases are compared pairwise, loop by loop.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..core.checks import check_choice, check_kwargs
from ..data.neuralfly import ENV_VAR as NEURALFLY_ENV
from .cases import (CLOSED_LOOP_POLICIES, FLYABLE_CEM_SCALE, FUTURE_CEM_SCALE, Case, example_cases,
                    exp1_cases, exp2_cases, exp3_cases, exp4_cases, exp5_cases, exp6_cases,
                    exp7_cases, exp8_cases, exp10_cases, exp11_cases, exp11_cem_cases, exp12_cases,
                    exp14_cases, exp14_cem_cases, fit_layout_cases, fit_mixed_cases,
                    fit_turbulence_cases)
from .readings import DEFAULT_READING, get_reading

if TYPE_CHECKING:
    import pandas as pd

    from .readings import Reading

__all__ = ["Experiment", "EXPERIMENTS", "get_experiment", "label_columns", "column_names",
           "MeasuredExperiment", "MEASURED", "register_measured"]


@dataclass(frozen=True, kw_only=True)
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
    search : {"random", "cem", "closed_loop"}
        How its loops are chosen: random exploration, one CEM run per case, or closed-loop
        episodes (one vehicle, one held-out wind, every policy of ``search_options``).
    build : callable
        ``(reading) -> list[Case]``: its builder in :mod:`uavwind.study.cases`.
    tables_as : str
        Id of the experiment whose table layout and paper values this one shares
        (empty: its own).
    search_options : dict
        Extra arguments of the search (CEM's ``rank_by``; the closed loop's ``policies`` and
        its :class:`~uavwind.method.closed_loop.ClosedLoop` grid); part of the cache key.
        CEM's ``cem_scale`` (``{"n_samples": f, "max_iter": g}``) runs a smaller CEM than the
        profile's: ``ceil(f N)`` draws for ``ceil(g iterations)``, at most N_e elites
        (:func:`uavwind.study.runner.cem_size`).
    group_by : tuple of str
        Label columns of :func:`summary_table`'s rows (max and mean per group).
    paper_keys : tuple of str
        Columns that join a result row to the paper's row in :func:`comparison_table`
        (empty: the paper reports nothing to compare with).
    summary : str
        The name of its summary in :data:`uavwind.analysis.tables.SUMMARIES`: ``"maxmean"``
        (max, mean with its CI, correct rate per ``group_by``), ``"cem"`` (per iteration),
        ``"baseline"`` (Exp 9), ``"vehicle"`` (Exp 10), ``"future"`` (Exp 11),
        ``"closed_loop"`` (Exp 12) or ``"flyable"`` (Exp 14).
    reference : str
        Where the paper's rows come from: ``"paper"`` (the experiment's table in
        :mod:`uavwind.study.paper`) or ``"example"`` (the worked example's one loop).
    columns : dict
        Display names of its label columns (``{"noise_sigma": "noise sigma (m)"}``), for
        the pages.
    readings : tuple of str
        The readings the book runs it under (``make results``); any reading can still be
        asked for by name.
    """

    id: str
    title: str
    question: str
    notebook: str
    paper_table: str
    build: Callable = field(repr=False)
    search: str = "random"
    tables_as: str = ""
    search_options: Mapping = field(default_factory=dict, hash=False, compare=False)
    group_by: tuple = ("scenario",)
    paper_keys: tuple = ()
    summary: str = "maxmean"
    reference: str = "paper"
    columns: Mapping = field(default_factory=dict, hash=False, compare=False)
    readings: tuple = ("inferred", "halves")

    def __post_init__(self):
        check_choice(self.search, "search", ("random", "cem", "closed_loop"))
        check_choice(self.summary, "summary", ("maxmean", "cem", "baseline", "vehicle",
                                               "future", "closed_loop", "flyable"))
        check_choice(self.reference, "reference", ("paper", "example"))
        allowed = (("policies", "decision_interval", "report_interval", "magnitude_step")
                   if self.search == "closed_loop" else ("rank_by", "cem_scale"))
        check_kwargs(self.search_options, allowed, f"experiment {self.id!r} search_options")
        if self.search == "closed_loop" and not self.search_options.get("policies"):
            raise ValueError(f"experiment {self.id!r}: a closed-loop search needs "
                             f"search_options['policies']")

    def cases(self, reading: str | Reading | None = None) -> list[Case]:
        """The cases under ``reading`` (a name or a :class:`~uavwind.study.readings.Reading`)."""
        return self.build(get_reading(DEFAULT_READING if reading is None else reading))


EXPERIMENTS = {e.id: e for e in [
    Experiment(
        id="example", title="Worked example", notebook="model.md",
        question="How does one loop look, and how do 50 random loops score, for strong shear "
                 "vs light constant?",
        paper_table="Table 3, Figure 3", build=example_cases, paper_keys=("scenario",),
        reference="example"),
    Experiment(
        id="exp1", title="Wind speed", notebook="exp1_wind_speed.md",
        question="How does the wind speed of the two conditions affect the classification?",
        paper_table="Table 4, Figure 4", build=exp1_cases, paper_keys=("scenario_id", "long_run"),
        columns={"scenario_id": "scenario", "long_run": "long run"}),
    Experiment(
        id="exp2", title="Range similarity", notebook="exp2_range_similarity.md",
        question="Does a wider gap between the groups' speed ranges raise the score?",
        paper_table="Table 5, Figure 5", build=exp2_cases,
        group_by=("scenario", "n_env"), paper_keys=("scenario_id", "n_env"),
        columns={"n_env": "environments"}),
    Experiment(
        id="exp3", title="Number of environments", notebook="exp3_environment_count.md",
        question="Do more environments per group raise the score, with the gap fixed?",
        paper_table="Table 6, Figure 6", build=exp3_cases,
        group_by=("scenario", "n_env"), paper_keys=("scenario_id", "n_env"),
        columns={"n_env": "environments"}),
    Experiment(
        id="exp4", title="Thrust changes", notebook="exp4_thrust_changes.md",
        question="Does the number of thrust changes matter?",
        paper_table="Table 7, Figure 7", build=exp4_cases, group_by=("scenario", "thrust_changes"),
        paper_keys=("scenario_id", "thrust_changes"), columns={"thrust_changes": "thrust changes"}),
    Experiment(
        id="exp5", title="Wind direction", notebook="exp5_wind_direction.md",
        question="Do opposite wind directions remove the misclassifications?",
        paper_table="Table 8, Figure 8", build=exp5_cases, paper_keys=("direction",)),
    Experiment(
        id="exp6", title="Cross-Entropy Method", notebook="exp6_cem.md",
        question="Does CEM find better thrust sequences than random search?",
        paper_table="Figure 9", search="cem", build=exp6_cases, summary="cem"),
    Experiment(
        id="exp6_raw", title="Cross-Entropy Method, raw silhouette", notebook="exp6_cem.md",
        question="Does CEM find a signal when its elites are ranked by the raw silhouette "
                 "instead of the floored score?",
        paper_table="Figure 9 (alternative objective)", search="cem", build=exp6_cases,
        tables_as="exp6", search_options={"rank_by": "silhouette"}, summary="cem",
        readings=("inferred",)),  # the book shows it under the paper reading only
    Experiment(
        id="exp7", title="Position noise", notebook="exp7_noise.md",
        question="How much GNSS-like position noise can the method take (the paper's "
                 "sub-metre claim)?",
        paper_table="beyond the paper", build=exp7_cases,
        group_by=("scenario", "noise_sigma", "noise_bias"),
        columns={"noise_sigma": "noise sigma (m)", "noise_bias": "noise bias (m)"}),
    Experiment(
        id="exp8", title="What to observe", notebook="exp8_observation.md",
        question="Which observation separates which wind conditions: position, velocity, "
                 "acceleration or position and velocity?",
        paper_table="beyond the paper", build=exp8_cases, group_by=("scenario", "observation", "noise"),
        readings=("inferred",)),  # its page reads the paper reading; no claim reads it
    Experiment(
        id="exp9", title="A physics baseline", notebook="exp9_baseline.md",
        question="What does a model-based wind estimate from the same positions achieve, "
                 "beside causal curiosity?",
        paper_table="beyond the paper", build=exp7_cases, summary="baseline",
        group_by=("scenario", "noise_sigma", "noise_bias"),
        readings=("inferred",)),  # its page reads the paper reading; no claim reads it
    Experiment(
        id="exp10", title="On a multirotor", notebook="exp10_multirotor.md",
        question="Does trajectory-only wind identification work on RotorPy's quadrotor, from "
                 "a hover as well as drifting with the air?",
        paper_table="beyond the paper", build=exp10_cases,
        group_by=("scenario_id", "scenario", "vehicle", "noise"), readings=("inferred",),
        summary="vehicle"),
    Experiment(
        id="exp11", title="The paper's future work", notebook="exp11_future_work.md",
        question="On a hovering multirotor, which observation (position, velocity, attitude, "
                 "body rates, IMU) and which action (thrust or attitude) tell the winds apart?",
        paper_table="beyond the paper (the paper's future work)", build=exp11_cases,
        group_by=("scenario", "action", "observation", "noise"), readings=("inferred",),
        summary="future"),
    Experiment(
        id="exp11_cem", title="The paper's future work, CEM", notebook="exp11_future_work.md",
        question="Does CEM find better attitude or thrust actions than random search?",
        paper_table="beyond the paper (the paper's future work)", search="cem",
        build=exp11_cem_cases, summary="cem", readings=("inferred",),
        group_by=("action", "observation"), search_options={"cem_scale": FUTURE_CEM_SCALE}),
    Experiment(
        id="exp12", title="Closed loop", notebook="exp12_closed_loop.md",
        question="One vehicle in one unknown wind: how many seconds of flight does it need "
                 "to know which condition it is in, and does choosing its manoeuvres as it "
                 "flies help?",
        paper_table="beyond the paper (the paper's future work)", search="closed_loop",
        build=exp12_cases, search_options={"policies": CLOSED_LOOP_POLICIES,
                                      "decision_interval": 2.0, "report_interval": 0.5},
        group_by=("scenario", "vehicle"), readings=("halves",), summary="closed_loop"),
    Experiment(
        id="exp14", title="Flyable manoeuvres", notebook="exp14_flyable.md",
        question="Does the method still separate the winds when the multirotor flies "
                 "manoeuvres it can fly (waypoint references under its position controller), "
                 "and through which channel?",
        paper_table="beyond the paper (issue 31)", build=exp14_cases,
        group_by=("scenario", "action", "observation", "noise"), readings=("inferred",),
        summary="flyable"),
    Experiment(
        id="exp14_cem", title="Flyable manoeuvres, CEM", notebook="exp14_flyable.md",
        question="Does CEM find more informative flyable manoeuvres than random search?",
        paper_table="beyond the paper (issue 31)", search="cem", build=exp14_cem_cases,
        summary="cem", readings=("inferred",), group_by=("action", "observation"),
        search_options={"cem_scale": FLYABLE_CEM_SCALE}),
    Experiment(
        id="fit_layout", title="Layout fit", notebook="inference.md",
        question="Which gap between same-strength groups gives Table 4's scores?",
        paper_table="Table 4 (fit)", build=fit_layout_cases,
        group_by=("scenario_id", "scenario", "gap_ratio"), columns={"gap_ratio": "gap / spacing"}),
    Experiment(
        id="fit_mixed", title="Mixed-strength layout", notebook="inference.md",
        question="Does Table 3's spacing, read per axis or in magnitude, give Table 4's "
                 "mixed-strength rows, wherever the groups sit in their class ranges?",
        paper_table="Table 4 (scenarios 2, 5)", build=fit_mixed_cases,
        group_by=("scenario_id", "scenario", "spacing", "placement")),
    Experiment(
        id="fit_turbulence", title="Turbulence reading", notebook="inference.md",
        question="Which reading of the cited Dryden implementation gives Table 4's turbulence "
                 "row?",
        paper_table="Table 4 (scenario 7)", build=fit_turbulence_cases, group_by=("candidate",)),
]}


@dataclass(frozen=True, kw_only=True)
class MeasuredExperiment:
    """An experiment on measured flights instead of simulated settings, as data.

    It has no cases and no loops of its own, so no cache entries of the runner's: the fill
    of :data:`EXPERIMENTS` does not plan it, and :func:`get_experiment` does not return it.
    Its rows are an analysis of the flights in the folder the environment variable ``data``
    names, computed by the layer that reads them (:mod:`uavwind.analysis`, above this one);
    the package's face hands the registry that computation with :func:`register_measured`
    when uavwind is imported. :meth:`run` runs it, and
    :func:`~uavwind.study.runner.run_experiment` runs it by name.

    Attributes
    ----------
    id, title, question, notebook, paper_table : str
        As :class:`Experiment`'s.
    source : str
        What the flights are, for the messages.
    data : str
        The environment variable that names the folder of the flights.
    """

    id: str
    title: str
    question: str
    notebook: str
    paper_table: str
    source: str
    data: str

    def check_data(self) -> None:
        """``ValueError`` naming :attr:`data` if that variable is not set, or does not name an
        existing folder (before any work: a run asked for it computes nothing first)."""
        folder = os.environ.get(self.data)
        if not folder:
            raise ValueError(f"experiment {self.id!r}, {self.title}, reads {self.source}, and "
                             f"${self.data} is not set: set it to the folder of the flights")
        if not os.path.isdir(os.path.expanduser(folder)):
            raise ValueError(f"experiment {self.id!r}, {self.title}, reads {self.source}, and "
                             f"${self.data} = {folder!r} is not an existing folder: set it to "
                             f"the folder of the flights")

    def run(self, profile: str, results: os.PathLike | str | None = None,
            n_jobs: int | None = None) -> pd.DataFrame:
        """The experiment's rows under ``profile`` (a profile's name), read from the result
        cache ``results`` or computed there over ``n_jobs`` workers, as the function
        registered for it computes them. ``ValueError`` naming :attr:`data` when that
        variable is not set (before any work, :meth:`check_data`); ``RuntimeError`` if
        nothing registered it."""
        self.check_data()
        run = _MEASURED_RUNS.get(self.id)
        if run is None:
            raise RuntimeError(f"experiment {self.id!r}: nothing registered how its rows are "
                               f"computed (the package's face does, when uavwind is "
                               f"imported)")
        return run(profile, results=results, n_jobs=n_jobs)


#: The experiments on measured flights, by id (beside :data:`EXPERIMENTS`, the simulated
#: ones): Experiment 13, Neural-Fly's wind-tunnel flights.
MEASURED = {m.id: m for m in [
    MeasuredExperiment(
        id="exp13", title="Real flights (Neural-Fly)", notebook="exp13_real_flights.md",
        question="Does causal curiosity's clustering tell the winds apart on Neural-Fly's "
                 "wind-tunnel flights, and through which channel?",
        paper_table="beyond the paper", source="Neural-Fly's wind-tunnel flights",
        data=NEURALFLY_ENV),
]}
#: How each measured experiment's rows are computed: ``run(profile, results=, n_jobs=)``,
#: registered by the layer that reads its flights.
_MEASURED_RUNS: dict = {}


def register_measured(exp_id: str, run: Callable) -> None:
    """Register how the rows of the measured experiment ``exp_id`` (an id of
    :data:`MEASURED`) are computed: ``run(profile, results=None, n_jobs=None)`` returns them,
    read from the result cache or computed and stored there. The package's face calls this
    for the analysis layer, which this layer cannot import; a second registration replaces
    the first."""
    if exp_id not in MEASURED:
        raise ValueError(f"unknown measured experiment {exp_id!r}; valid: {', '.join(MEASURED)}")
    if not callable(run):
        raise TypeError(f"run must be callable, got {type(run).__name__}")
    _MEASURED_RUNS[exp_id] = run


def get_experiment(exp_id: str) -> Experiment:
    """The :class:`Experiment` called ``exp_id``; ``ValueError`` naming the valid ids (and
    saying so when ``exp_id`` is a :class:`MeasuredExperiment`, which has no cases)."""
    if not isinstance(exp_id, str):
        raise TypeError(f"experiment id must be a string, got {type(exp_id).__name__}")
    if exp_id in MEASURED:
        raise ValueError(f"experiment {exp_id!r} runs on measured flights: it has no cases "
                         f"or cache entries to plan (run it with run_experiment({exp_id!r}))")
    if exp_id not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {exp_id!r}; valid: {', '.join(EXPERIMENTS)}, "
                         f"and on measured flights {', '.join(MEASURED)}")
    return EXPERIMENTS[exp_id]


def column_names() -> dict:
    """Display names of the experiments' label columns (each experiment's ``columns``)."""
    out = {}
    for exp in EXPERIMENTS.values():
        for k, v in exp.columns.items():
            if out.setdefault(k, v) != v:  # pragma: no cover - one name per idea
                raise ValueError(f"label column {k!r} has two display names: {out[k]!r}, {v!r}")
    return out


def label_columns() -> tuple:
    """Every label column the experiments' cases carry, in registry order (the columns that
    place a result row in its paper table)."""
    out = []
    for exp in EXPERIMENTS.values():
        for case in exp.cases():
            out += [k for k in case.labels if k not in out]
    return tuple(out)
