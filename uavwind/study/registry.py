"""THE registry: everything the book computes, by id, each registered where it is defined.

This module owns :data:`REGISTRY` (id -> entry, in the order they register) and the two kinds
of entry, both small frozen dataclasses:

* :class:`Experiment` -- loops flown in simulation, case by case (id, title, question,
  notebook, the paper's table it regenerates, how its loops are searched, how it is
  summarised); its cache entries are the runner's. The experiments are the list below
  (:data:`EXPERIMENTS` is the registry's view of them);
* :class:`Analysis` -- anything else a page reads: a summary of results (the claims'
  verdicts), a measurement of its own (Exp 10's saturation split), Exp 11's filter table,
  the explorer's grid, Exp 13 on Neural-Fly's real flights. Its ``fill`` computes it into the
  result cache; ``reads`` names the experiments it reads (a fill completes them first);
  ``data`` the environment variable naming the data it needs, if any. An analysis joins
  the registry where its function is defined, with the decorator :func:`computes`
  (:data:`ANALYSES` is the registry's view of them).

Adding an experiment is one entry in the list below and its builder (in
:mod:`uavwind.study.cases`), one notebook and one line in the book's ``_toc.yml``; adding
anything else the book computes is ``@computes("id", reads=(...))`` on the function that
computes it. ``python -m uavwind list`` prints the registry, ``python -m uavwind run ID``
runs any entry, and :func:`uavwind.study.fill.fill_cache` (``make results``) fills them all
in one pool.

Layers: the analyses are defined above this layer (:mod:`uavwind.analysis`,
:mod:`uavwind.report`), which imports this module and registers them here; this layer never
imports them. The package's face imports the modules that register, so the registry is
complete in every process that imports uavwind (``tests/test_registry.py`` checks that every
module calling :func:`computes` is among them).

What each experiment flies -- :class:`Case` (one row of an experiment: a
:class:`~uavwind.sim.setting.Setting` and its labels in the paper's table), the case
builders and the constants they use (the vehicles, channels and noise levels of the
experiments beyond the paper) -- is :mod:`uavwind.study.cases`' (import them from there).
Running an experiment is :mod:`uavwind.study.runner`'s; summarising it,
:mod:`uavwind.analysis.tables`'.

Every experiment is built under a *reading* (:data:`~uavwind.study.readings.READINGS`),
which fixes the group layout and the turbulence variant. Common random numbers: every case
of an experiment uses the experiment's seed, so loop ``i`` flies the same thrust sequence in
every case (for Exp 4 the number of changes differs, so the sequences share their random
stream, not their shape); cases are compared pairwise, loop by loop.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..core.checks import check_choice, check_kwargs
from .cases import (CLOSED_LOOP_POLICIES, FLYABLE_CEM_SCALE, FUTURE_CEM_SCALE, Case, example_cases,
                    exp1_cases, exp2_cases, exp3_cases, exp4_cases, exp5_cases, exp6_cases,
                    exp7_cases, exp8_cases, exp10_cases, exp11_cases, exp11_cem_cases, exp12_cases,
                    exp14_cases, exp14_cem_cases, fit_layout_cases, fit_mixed_cases,
                    fit_turbulence_cases)
from .readings import DEFAULT_READING, get_reading

if TYPE_CHECKING:
    from .readings import Reading

__all__ = ["REGISTRY", "Experiment", "Analysis", "register", "computes", "get_experiment",
           "EXPERIMENTS", "ANALYSES", "label_columns", "column_names"]


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

    #: What kind of registry entry it is (an :class:`Analysis`'s is ``"analysis"``).
    kind = "experiment"
    #: An experiment reads no other entry: it flies its cases.
    reads = ()

    def cases(self, reading: str | Reading | None = None) -> list[Case]:
        """The cases under ``reading`` (a name or a :class:`~uavwind.study.readings.Reading`)."""
        return self.build(get_reading(DEFAULT_READING if reading is None else reading))


#: The arguments an analysis's function may take, by name: the fill passes those it names.
FILL_ARGS = ("profile", "seed", "results", "n_jobs")


@dataclass(frozen=True, kw_only=True)
class Analysis:
    """Something the book computes that is not an experiment's loops, as data: a page's
    summary of results, a measurement of its own, an exercise's small run, Exp 11's filter
    table, the explorer's grid, Exp 13's real flights.

    :func:`computes` makes one from the function that computes it, where that function is
    defined, and registers it.

    Attributes
    ----------
    id : str
        Its id in :data:`REGISTRY` (an identifier; ``python -m uavwind run ID``).
    fill : callable
        Computes it into the result cache (and only reads it when it is there), called with
        those of ``(profile, seed, results, n_jobs)`` it takes, by name (:attr:`takes`):
        ``profile`` a profile's name, ``seed`` the root seed, ``results`` the result folder,
        ``n_jobs`` its workers (1 in a fill's pool). It must take ``results``. What it
        returns is what :func:`~uavwind.study.runner.run_experiment` returns for it (Exp 13:
        its real-flight rows).
    reads : tuple of str
        The experiments whose results it reads: a fill completes their entries (under the
        readings the book shows each under) before it starts this.
    long : bool
        A long task: a fill puts it ahead of the experiments' chunks (a long task started
        last would leave a core idle at the end).
    title, notebook : str
        For ``python -m uavwind list``: what it is, and the page that shows it.
    data : str
        The environment variable naming the folder of the data it reads (Exp 13:
        ``UAVWIND_NEURALFLY``), or ``""``. Without it, ``run all`` (and ``fill_cache("all")``)
        leaves it out, saying so, and asking for it by id is a ``ValueError`` before any
        work (:meth:`check_data`).
    show : callable, optional
        ``show(profile, seed, results) -> str``: what ``python -m uavwind run`` prints for it
        once it is computed (read back from the cache).
    takes : tuple of str
        Set from ``fill``'s signature: the arguments of :data:`FILL_ARGS` it takes.
    """

    id: str
    fill: Callable = field(repr=False)
    reads: tuple = ()
    long: bool = False
    title: str = ""
    notebook: str = ""
    data: str = ""
    show: Callable | None = field(default=None, repr=False, compare=False)
    takes: tuple = field(init=False, repr=False, compare=False)

    #: What kind of registry entry it is.
    kind = "analysis"

    def __post_init__(self):
        if not isinstance(self.id, str) or not self.id.isidentifier():
            raise ValueError(f"an analysis's id must be an identifier, got {self.id!r}")
        if not callable(self.fill):
            raise TypeError(f"analysis {self.id!r}: fill must be callable, got "
                            f"{type(self.fill).__name__}")
        if self.show is not None and not callable(self.show):
            raise TypeError(f"analysis {self.id!r}: show must be callable or None, got "
                            f"{type(self.show).__name__}")
        params = inspect.signature(self.fill).parameters
        takes = tuple(k for k in FILL_ARGS if k in params)
        other = [k for k, p in params.items() if k not in FILL_ARGS
                 and p.default is inspect.Parameter.empty
                 and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
        if "results" not in takes or other:
            raise TypeError(f"analysis {self.id!r}: {_name(self.fill)} must take 'results' and "
                            f"no other argument without a default than "
                            f"{', '.join(repr(k) for k in FILL_ARGS if k != 'results')}, got "
                            f"{list(params)}")
        object.__setattr__(self, "reads", tuple(self.reads))
        object.__setattr__(self, "takes", takes)

    @property
    def available(self) -> bool:
        """Whether the data it needs is named (always, for an analysis of results)."""
        return not self.data or bool(os.environ.get(self.data))

    def check_data(self) -> None:
        """``ValueError`` naming :attr:`data` if that variable is not set, or does not name an
        existing folder (before any work: a run asked for it computes nothing first)."""
        if not self.data:
            return
        folder = os.environ.get(self.data)
        what = f"{self.id!r}, {self.title}," if self.title else f"{self.id!r}"
        if not folder:
            raise ValueError(f"{what} reads the folder ${self.data} names, and ${self.data} is "
                             f"not set: set it to the folder of the data")
        if not os.path.isdir(os.path.expanduser(folder)):
            raise ValueError(f"{what} reads the folder ${self.data} names, and ${self.data} = "
                             f"{folder!r} is not an existing folder: set it to the folder of "
                             f"the data")

    def run(self, profile: str, seed: int, results: Any = None, n_jobs: int | None = 1):
        """Compute it (or read it) into ``results``: :attr:`fill` called with the arguments
        it takes; returns what it returns."""
        given = {"profile": profile, "seed": seed, "results": results, "n_jobs": n_jobs}
        return self.fill(**{k: given[k] for k in self.takes})


def _name(f) -> str:
    return f"{getattr(f, '__module__', '?')}.{getattr(f, '__qualname__', repr(f))}"


#: THE registry: every computed thing of the book by id, in the order it registered (the
#: experiments of this module first, then the analyses as their modules are imported).
REGISTRY: dict[str, Experiment | Analysis] = {}


class _Kind(Mapping):
    """A live, read-only view of the :data:`REGISTRY` entries of one kind."""

    def __init__(self, cls):
        self._cls = cls

    def __getitem__(self, key):
        item = REGISTRY[key]
        if not isinstance(item, self._cls):
            raise KeyError(key)
        return item

    def __iter__(self) -> Iterator[str]:
        return iter([k for k, v in REGISTRY.items() if isinstance(v, self._cls)])

    def __len__(self) -> int:
        return sum(isinstance(v, self._cls) for v in REGISTRY.values())

    def __repr__(self) -> str:
        return f"<{self._cls.__name__} entries of the registry: {', '.join(self)}>"


#: The experiments of :data:`REGISTRY`, by id (a live view).
EXPERIMENTS: Mapping[str, Experiment] = _Kind(Experiment)
#: The analyses of :data:`REGISTRY`, by id (a live view).
ANALYSES: Mapping[str, Analysis] = _Kind(Analysis)


def _where(item) -> str:
    return (_name(item.fill) if isinstance(item, Analysis)
            else f"the experiments of {__name__}")


def register(item: Experiment | Analysis) -> Experiment | Analysis:
    """Add ``item`` to :data:`REGISTRY` and return it. ``ValueError`` for an id registered
    already (naming both) or an analysis reading an id that is not an experiment of the
    registry (it would start before what it reads is stored); ``TypeError`` for anything
    but an :class:`Experiment` or :class:`Analysis`."""
    if not isinstance(item, (Experiment, Analysis)):
        raise TypeError(f"the registry holds Experiment and Analysis entries, got "
                        f"{type(item).__name__}")
    if item.id in REGISTRY:
        raise ValueError(f"{item.id!r} is registered twice: by {_where(REGISTRY[item.id])} and "
                         f"by {_where(item)}")
    unknown = [r for r in item.reads if r not in EXPERIMENTS]
    if unknown:
        raise ValueError(f"analysis {item.id!r} reads experiments not in the registry: "
                         f"{unknown}")
    REGISTRY[item.id] = item
    return item


def computes(id: str, reads: Iterable[str] = (), *, long: bool = False, title: str = "",
             notebook: str = "", data: str = "", show: Callable | None = None):
    """Register the decorated function as the :class:`Analysis` ``id`` (see its attributes
    for the arguments) and return the function unchanged::

        @computes("exp10_drift_offsets", title="Exp 10: drift offsets")
        def drift_offsets(seed, results=None):
            return memo("exp10_drift_offsets", {"seed": seed}, lambda: ..., results)

    ``ValueError`` for an id that is not an identifier or is registered already, or for
    ``reads`` naming something that is not an experiment of the registry; ``TypeError`` for
    a function a fill cannot call (:class:`Analysis`)."""
    if not isinstance(id, str) or not id.isidentifier():
        raise ValueError(f"an analysis's id must be an identifier, got {id!r}")
    reads = tuple(reads)
    unknown = [r for r in reads if r not in EXPERIMENTS]
    if unknown:
        raise ValueError(f"analysis {id!r} reads experiments not in the registry: {unknown}")

    def decorate(f):
        register(Analysis(id=id, fill=f, reads=reads, long=long, title=title,
                          notebook=notebook, data=data, show=show))
        return f
    return decorate


for _exp in [
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
]:
    register(_exp)
del _exp


def get_experiment(exp_id: str) -> Experiment | Analysis:
    """The registry's entry called ``exp_id`` (an :class:`Experiment` or an
    :class:`Analysis`, ``.kind`` says which); ``ValueError`` naming the valid ids."""
    if not isinstance(exp_id, str):
        raise TypeError(f"experiment id must be a string, got {type(exp_id).__name__}")
    if exp_id not in REGISTRY:
        raise ValueError(f"unknown experiment {exp_id!r} (no id of the registry); valid: "
                         f"experiments {', '.join(EXPERIMENTS)}; analyses {', '.join(ANALYSES)}")
    return REGISTRY[exp_id]


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
