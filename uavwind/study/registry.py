"""The experiments as data: the paper's six, three beyond it, and the two fits of the
inferred reading.

This module owns :class:`Experiment` (id, title, question, notebook, the paper's table it
regenerates, how its loops are searched, how it is summarised) and :class:`Case` (one row
of an experiment: a :class:`~uavwind.sim.setting.Setting` and its labels in the paper's
table), the case builders of every experiment and the registry :data:`EXPERIMENTS`.
Running an experiment is :mod:`uavwind.study.runner`'s; summarising it,
:mod:`uavwind.analysis.tables`'. Adding an experiment is one entry here, one notebook and
one line in the book's ``_toc.yml``.

Every experiment is built under a *reading* (:data:`~uavwind.study.readings.READINGS`),
which fixes the group layout and the turbulence variant. Common random numbers: every case
of an experiment uses the experiment's seed, so loop ``i`` flies the same thrust sequence in
every case (for Exp 4 the number of changes differs, so the sequences share their random
stream, not their shape); cases are compared pairwise, loop by loop.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

from ..core.checks import check_choice, check_kwargs
from ..sim.observation import CONSUMER_NOISE, CONSUMER_SENSORS, POINT_MASS_OBSERVATIONS, Noise
from ..sim.manoeuvres import FLYABLE_IN_WIND
from ..sim.multirotor import NEURAL_FLY_CONTROL, Multirotor
from ..sim.setting import Setting
from ..sim.vehicle import UAV
from .builders import (direction_settings, environment_count_settings, make_setting,
                       range_similarity_settings)
from .conditions import PAPER_SCENARIOS, WindCondition, table3_setting
from .layouts import PLACEMENTS, TABLE3_SPACING, Layout
from .readings import DEFAULT_READING, TURBULENCE_CANDIDATES, get_reading

if TYPE_CHECKING:
    from .readings import Reading

__all__ = ["Case", "Experiment", "EXPERIMENTS", "get_experiment", "THRUST_CHANGES",
           "FIT_RATIOS", "MIXED_SPACINGS", "VEHICLES",
           "NOISY_VEHICLES", "FUTURE_VEHICLE", "FUTURE_CHANNELS", "FUTURE_ACTIONS",
           "FUTURE_NOISE", "FLYABLE_CHANNELS", "FLYABLE_CEM_SCALE", "FLYABLE_CPU_PER_LOOP", "CLOSED_LOOP_VEHICLES", "CLOSED_LOOP_POLICIES", "NOISE_LEVELS", "BIAS_LEVELS", "BIAS_TIME", "label_columns",
           "column_names"]


@dataclass(frozen=True, kw_only=True)
class Case:
    """One row of an experiment: a setting and its labels in the paper's table."""

    setting: Setting
    labels: Mapping = field(hash=False, compare=False)
    long: bool = False  # uses the profile's long loop count (Exp 1's 500-loop case)
    fit: bool = False  # uses the profile's fit loop count (the inference experiments)
    side: bool = False  # uses the profile's side loop count (the wide sweeps beyond the paper)
    flyable: bool = False  # uses the profile's flyable loop count (Exp 14's waypoint cases)


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
        ``(reading) -> list[Case]``.
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


def _scenario_label(a, b):
    return f"{a.label.capitalize()} vs {b.label}"


def _make(reading, a, b, n, **kwargs):
    return make_setting(a, b, n, **reading.builder_kwargs, **kwargs)


def _exp1(reading):
    cases = []
    for k, (a, b) in PAPER_SCENARIOS.items():
        cases.append(Case(setting=_make(reading, a, b, 5),
                          labels={"scenario": _scenario_label(a, b), "scenario_id": k, "long_run": False}))
    a, b = PAPER_SCENARIOS[1]
    cases.append(Case(setting=_make(reading, a, b, reading.long_run_per_group),
                      labels={"scenario": _scenario_label(a, b) + " (long run)", "scenario_id": 1,
                       "long_run": True}, long=True))
    return cases


def _sweep(builder, label_key):
    def build(reading):
        cases = []
        for k in (1, 2, 3, 4):
            a, b = PAPER_SCENARIOS[k]
            for s in builder(a, b, **reading.builder_kwargs):
                cases.append(Case(setting=s, labels={"scenario": _scenario_label(a, b), "scenario_id": k,
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
            cases.append(Case(setting=_make(reading, a, b, 10, n_changes=n),
                              labels={"scenario": _scenario_label(a, b), "scenario_id": k,
                               "thrust_changes": label}))
    return cases


def _direction(reading):
    return direction_settings("light constant", "light shear", 10, **reading.builder_kwargs)


def _exp5(reading):
    same, opposite = _direction(reading)
    base = "Light constant vs light shear"
    return [Case(setting=same, labels={"scenario": f"{base} - similar direction", "direction": "similar"}),
            Case(setting=opposite, labels={"scenario": f"{base} - opposite direction", "direction": "opposite"})]


def _exp6(reading):
    # the same setting as Exp 5's similar-direction case, so CEM and random search
    # are compared on identical environments (as the paper compares Fig 9 with Fig 8)
    same, _ = _direction(reading)
    return [Case(setting=same, labels={"scenario": "Light constant vs light shear"})]


def _example(reading):
    return [Case(setting=table3_setting(), labels={"scenario": "Strong shear vs light constant (Table 3)"})]


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
            cases.append(Case(setting=s, labels={"scenario": _scenario_label(a, b), "scenario_id": k,
                                  "gap_ratio": rho}, fit=True))
    return cases


def _fit_turbulence(reading):
    """Table 4's light constant vs strong turbulence under each turbulence candidate."""
    a, b = PAPER_SCENARIOS[7]
    return [Case(setting=make_setting(a, b, 5, layout=reading.layout, turbulence=t),
                 labels={"scenario": _scenario_label(a, b), "scenario_id": 7, "candidate": name})
            for name, t in TURBULENCE_CANDIDATES.items()]


#: The vehicles Exp 10 flies: the paper's point mass, and RotorPy's quadrotor with its own
#: drag from each start and with the paper's drag from a hover (with the paper's drag from a
#: drifting start it is the point mass with attitude dynamics; tried, it scores as the point
#: mass does) (label -> vehicle).
VEHICLES = {
    "point mass": UAV(),
    "multirotor, RotorPy drag, drifting": Multirotor(preset="rotorpy", start="drifting"),
    "multirotor, RotorPy drag, hover": Multirotor(preset="rotorpy", start="hover"),
    "multirotor, paper drag, hover": Multirotor(preset="paper", start="hover"),
}
#: Exp 10's vehicles also flown with consumer-grade GNSS position noise.
NOISY_VEHICLES = ("point mass", "multirotor, RotorPy drag, hover")


def _exp10(reading):
    """The worked example and the seven Table 2 scenarios (5 per group, as Exp 1) on each
    vehicle of :data:`VEHICLES`, and those of :data:`NOISY_VEHICLES` again with
    :data:`~uavwind.sim.observation.CONSUMER_NOISE` on the positions; the noise-free
    point-mass cases are Exp 1's own settings."""
    cases = []
    pairs = [(0, None, None)] + [(k, a, b) for k, (a, b) in PAPER_SCENARIOS.items()]
    for noise_label, noise in (("none", None), ("consumer", CONSUMER_NOISE)):
        for k, a, b in pairs:
            for label, vehicle in VEHICLES.items():
                if noise is not None and label not in NOISY_VEHICLES:
                    continue
                if k == 0:
                    s = table3_setting(uav=vehicle, noise=noise)
                    scen = "Strong shear vs light constant (Table 3)"
                else:
                    s = _make(reading, a, b, 5, uav=vehicle, noise=noise)
                    scen = _scenario_label(a, b)
                cases.append(Case(setting=s, labels={
                    "scenario": scen, "scenario_id": k, "vehicle": label, "noise": noise_label,
                    "start": getattr(vehicle, "start", "drifting"),
                    "drag": getattr(vehicle, "preset", "paper")}))
    return cases


#: Exp 11's vehicle: RotorPy's quadrotor with its own drag, starting from a hover.
FUTURE_VEHICLE = Multirotor(preset="rotorpy", start="hover")
#: Exp 11's observation channels, its action families (label -> setting sampler) and its
#: noise levels (label -> Noise).
FUTURE_CHANNELS = ("position", "velocity", "attitude", "body_rates", "imu")
FUTURE_ACTIONS = {"thrust": "paper", "attitude": "attitude"}
FUTURE_NOISE = {"none": None, "consumer": CONSUMER_SENSORS}


def _future_scenarios(reading):
    """Where position alone struggles (light constant vs light constant, light constant vs
    light shear, light constant vs strong turbulence), and the worked example."""
    out = [("Strong shear vs light constant (Table 3)", table3_setting(uav=FUTURE_VEHICLE))]
    for a, b in (("light constant", "light constant"), ("light constant", "light shear"),
                 ("light constant", "strong turbulence")):
        out.append((_scenario_label(WindCondition.parse(a), WindCondition.parse(b)),
                    _make(reading, a, b, 5, uav=FUTURE_VEHICLE)))
    return out


def _exp11(reading):
    cases = []
    for scen, base in _future_scenarios(reading):
        for action, sampler in FUTURE_ACTIONS.items():
            for channel in FUTURE_CHANNELS:
                for noise_label, noise in FUTURE_NOISE.items():
                    s = replace(base, sampler=sampler, observation=channel, noise=noise)
                    cases.append(Case(setting=s, side=True, labels={
                        "scenario": scen, "action": action, "observation": channel,
                        "noise": noise_label}))
    return cases


def _exp11_cem(reading):
    """CEM on light constant vs light shear with consumer noise, each action family on the
    position channel and on the IMU."""
    scen, base = _future_scenarios(reading)[2]
    cases = []
    for action, sampler in FUTURE_ACTIONS.items():
        for channel in ("position", "imu"):
            s = replace(base, sampler=sampler, observation=channel, noise=CONSUMER_SENSORS)
            cases.append(Case(setting=s, labels={"scenario": scen, "action": action,
                                                 "observation": channel, "noise": "consumer"}))
    return cases


#: Exp 14's channels: the paper's (position), the real flights' (attitude: Exp 13) and Exp
#: 11's best without a satellite fix under raw thrust (the IMU); three of Exp 11's five, to
#: keep the cost modest (velocity and body rates cost 1.6 and 0.8 CPU-s a loop).
FLYABLE_CHANNELS = ("position", "attitude", "imu")
#: CPU seconds one Exp 14 waypoint loop costs (10 environments, 12 s, flight and clustering),
#: measured on the project's 2-core machine (Intel Xeon) with ``random_search(..., n_jobs=1)``,
#: 2 loops of each of the seven scenarios per channel (numba compiled beforehand), with the
#: vehicle and budget of issue 43 (before it: 0.61, 0.64 and 1.14 on light constant vs light
#: shear: the old vehicle's loops crashed or separated in few k-means iterations)
FLYABLE_CPU_PER_LOOP = {"position": 0.75, "attitude": 2.33, "imu": 3.19}
#: Exp 14's CEM, smaller than the profile's: a third of the draws, a quarter of the
#: iterations (paper profile: N = 10, Ne = 4, 5 iterations).
FLYABLE_CEM_SCALE = {"n_samples": 1 / 3, "max_iter": 1 / 4}


#: The Neural-Fly quadrotor's drag and lift factors as Exp 13 fits them on the real flights
#: (:func:`uavwind.analysis.figure8.calibrate_twin`, four controllers, paper profile: 0.739
#: and 0.631; tests/test_twin.py holds these to a new fit when the flights are there).
#: With the preset's own drag (factor 1) the vehicle leans 47.5 degrees and needs 91% of its
#: thrust to hold still in 13.86 m/s: no room for a manoeuvre.
NEURAL_FLY_FITTED = {"drag_scale": 0.74, "lift_scale": 0.63}
#: Exp 14's vehicle for the flyable references: the Neural-Fly quadrotor (2.6 kg,
#: thrust-to-weight 2.2, RotorPy's aerodynamics scaled to it and fitted as above) under SE3
#: with an integral term, a 60 degree thrust cone and yaw given up first, from a hover.
FLYABLE_VEHICLE = Multirotor.neural_fly(**NEURAL_FLY_FITTED, position_control=NEURAL_FLY_CONTROL)
#: Exp 14's wind fades in over its first seconds [s]: the vehicle starts at rest in still air,
#: as a real one takes off before it meets the wind (a step of 11-14 m/s at t = 0 is no start
#: a real flight has).
FLYABLE_RAMP = 3.0


def _flyable(setting, channel):
    """``setting``'s groups flown as Exp 14 flies them: flyable references on
    :data:`FLYABLE_VEHICLE`, within :data:`~uavwind.sim.manoeuvres.FLYABLE_IN_WIND`, the wind
    ramped in over :data:`FLYABLE_RAMP`, consumer sensors on ``channel``."""
    return replace(setting, uav=FLYABLE_VEHICLE, sampler="waypoints", observation=channel,
                   noise=CONSUMER_SENSORS, flyable=FLYABLE_IN_WIND, wind_ramp=FLYABLE_RAMP)


def _exp14(reading):
    """Exp 10's seven Table 2 scenarios (5 environments a group) with consumer sensors: the
    flyable waypoint references (``sampler="waypoints"``, :func:`_flyable`) on each channel
    of :data:`FLYABLE_CHANNELS`, and beside them
    the paper's raw thrust as Exps 10 and 11 flew it -- their own settings, so their cached
    loops: position with consumer GNSS noise from Exp 10 (every scenario, Exp 10's loop
    count), attitude and IMU with consumer sensors from Exp 11 (the two Table 2 scenarios it
    flies, light constant vs light constant and vs strong turbulence; Exp 11's loop count)."""
    cases = []
    future = {scen: s for scen, s in _future_scenarios(reading)}
    for k, (a, b) in PAPER_SCENARIOS.items():
        scen = _scenario_label(a, b)
        base = _make(reading, a, b, 5, uav=FUTURE_VEHICLE)
        for channel in FLYABLE_CHANNELS:
            cases.append(Case(setting=_flyable(base, channel), flyable=True, labels={
                "scenario": scen, "scenario_id": k, "action": "waypoints",
                "observation": channel, "noise": "consumer"}))
        # Exp 10's own case (its consumer noise is CONSUMER_SENSORS' position noise)
        cases.append(Case(setting=_make(reading, a, b, 5, uav=FUTURE_VEHICLE,
                                        noise=CONSUMER_NOISE),
                          labels={"scenario": scen, "scenario_id": k, "action": "thrust",
                                  "observation": "position", "noise": "consumer"}))
        if scen in future:  # Exp 11's own cases
            for channel in FLYABLE_CHANNELS[1:]:
                s = replace(future[scen], sampler=FUTURE_ACTIONS["thrust"],
                            observation=channel, noise=CONSUMER_SENSORS)
                cases.append(Case(setting=s, side=True, labels={
                    "scenario": scen, "scenario_id": k, "action": "thrust",
                    "observation": channel, "noise": "consumer"}))
    return cases


def _exp14_cem(reading):
    """CEM over flyable waypoint references on light constant vs light shear with consumer
    sensors, on the position channel and on the IMU (Exp 11's CEM cases, with waypoints)."""
    scen, base = _future_scenarios(reading)[2]
    return [Case(setting=_flyable(base, channel),
                 labels={"scenario": scen, "action": "waypoints", "observation": channel,
                         "noise": "consumer"})
            for channel in ("position", "imu")]


#: Exp 12's vehicles: the paper's point mass and RotorPy's quadrotor from a hover.
CLOSED_LOOP_VEHICLES = {"point mass": UAV(), "multirotor, RotorPy drag, hover": FUTURE_VEHICLE}
#: Exp 12's policies, in the order the pages show them.
CLOSED_LOOP_POLICIES = ("random", "best", "greedy", "receding")


def _exp12(reading):
    """Light constant vs light constant, light shear and strong turbulence (five known
    environments a group), each vehicle, consumer GNSS position noise."""
    cases = []
    for a, b in (("light constant", "light constant"), ("light constant", "light shear"),
                 ("light constant", "strong turbulence")):
        for label, vehicle in CLOSED_LOOP_VEHICLES.items():
            s = _make(reading, a, b, 5, uav=vehicle,
                      noise=Noise(position=CONSUMER_NOISE.position))
            cases.append(Case(setting=s, labels={"scenario": _scenario_label(s.group_a,
                                                                             s.group_b),
                                                 "vehicle": label}))
    return cases


#: The mixed-strength layouts ``fit_mixed`` compares: Table 3's 0.1 m/s on each of x and y
#: (0.1 sqrt(2) along x = y), and 0.1 m/s in magnitude [m/s].
MIXED_SPACINGS = {"per axis": TABLE3_SPACING, "magnitude": 0.1}


def _fit_mixed(reading):
    """Table 4's mixed-strength constant and shear pairs (S2, S5), 5 per group, under Table
    3's spacing read per axis and in magnitude, each group at the low end, the centre and the
    high end of its class range."""
    cases = []
    for k in (2, 5):
        a, b = PAPER_SCENARIOS[k]
        for label, spacing in MIXED_SPACINGS.items():
            for place in PLACEMENTS:
                lay = Layout("fit", mixed_spacing=spacing, mixed_placement=place)
                cases.append(Case(setting=make_setting(a, b, 5, layout=lay),
                                  labels={"scenario": _scenario_label(a, b), "scenario_id": k,
                                          "spacing": label, "placement": place}, fit=True))
    return cases


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
            cases.append(Case(setting=replace(s, noise=noise, baseline=True),
                              labels={"scenario": label, "noise_sigma": sig, "noise_bias": bias}))
    return cases


def _exp8(reading):
    cases = []
    for label, s in _beyond_scenarios(reading):
        for obs in POINT_MASS_OBSERVATIONS:
            for name, noise in (("none", None), ("consumer", CONSUMER_NOISE)):
                cases.append(Case(setting=replace(s, observation=obs, noise=noise),
                                  labels={"scenario": label, "observation": obs, "noise": name}))
    return cases


EXPERIMENTS = {e.id: e for e in [
    Experiment(
        id="example", title="Worked example", notebook="model.md",
        question="How does one loop look, and how do 50 random loops score, for strong shear "
                 "vs light constant?",
        paper_table="Table 3, Figure 3", build=_example, paper_keys=("scenario",),
        reference="example"),
    Experiment(
        id="exp1", title="Wind speed", notebook="exp1_wind_speed.md",
        question="How does the wind speed of the two conditions affect the classification?",
        paper_table="Table 4, Figure 4", build=_exp1, paper_keys=("scenario_id", "long_run"),
        columns={"scenario_id": "scenario", "long_run": "long run"}),
    Experiment(
        id="exp2", title="Range similarity", notebook="exp2_range_similarity.md",
        question="Does a wider gap between the groups' speed ranges raise the score?",
        paper_table="Table 5, Figure 5", build=_sweep(range_similarity_settings, "n_env"),
        group_by=("scenario", "n_env"), paper_keys=("scenario_id", "n_env"),
        columns={"n_env": "environments"}),
    Experiment(
        id="exp3", title="Number of environments", notebook="exp3_environment_count.md",
        question="Do more environments per group raise the score, with the gap fixed?",
        paper_table="Table 6, Figure 6", build=_sweep(environment_count_settings, "n_env"),
        group_by=("scenario", "n_env"), paper_keys=("scenario_id", "n_env"),
        columns={"n_env": "environments"}),
    Experiment(
        id="exp4", title="Thrust changes", notebook="exp4_thrust_changes.md",
        question="Does the number of thrust changes matter?",
        paper_table="Table 7, Figure 7", build=_exp4, group_by=("scenario", "thrust_changes"),
        paper_keys=("scenario_id", "thrust_changes"), columns={"thrust_changes": "thrust changes"}),
    Experiment(
        id="exp5", title="Wind direction", notebook="exp5_wind_direction.md",
        question="Do opposite wind directions remove the misclassifications?",
        paper_table="Table 8, Figure 8", build=_exp5, paper_keys=("direction",)),
    Experiment(
        id="exp6", title="Cross-Entropy Method", notebook="exp6_cem.md",
        question="Does CEM find better thrust sequences than random search?",
        paper_table="Figure 9", search="cem", build=_exp6, summary="cem"),
    Experiment(
        id="exp6_raw", title="Cross-Entropy Method, raw silhouette", notebook="exp6_cem.md",
        question="Does CEM find a signal when its elites are ranked by the raw silhouette "
                 "instead of the floored score?",
        paper_table="Figure 9 (alternative objective)", search="cem", build=_exp6,
        tables_as="exp6", search_options={"rank_by": "silhouette"}, summary="cem",
        readings=("inferred",)),  # the book shows it under the paper reading only
    Experiment(
        id="exp7", title="Position noise", notebook="exp7_noise.md",
        question="How much GNSS-like position noise can the method take (the paper's "
                 "sub-metre claim)?",
        paper_table="beyond the paper", build=_exp7,
        group_by=("scenario", "noise_sigma", "noise_bias"),
        columns={"noise_sigma": "noise sigma (m)", "noise_bias": "noise bias (m)"}),
    Experiment(
        id="exp8", title="What to observe", notebook="exp8_observation.md",
        question="Which observation separates which wind conditions: position, velocity, "
                 "acceleration or position and velocity?",
        paper_table="beyond the paper", build=_exp8, group_by=("scenario", "observation", "noise"),
        readings=("inferred",)),  # its page reads the paper reading; no claim reads it
    Experiment(
        id="exp9", title="A physics baseline", notebook="exp9_baseline.md",
        question="What does a model-based wind estimate from the same positions achieve, "
                 "beside causal curiosity?",
        paper_table="beyond the paper", build=_exp7, summary="baseline",
        group_by=("scenario", "noise_sigma", "noise_bias"),
        readings=("inferred",)),  # its page reads the paper reading; no claim reads it
    Experiment(
        id="exp10", title="On a multirotor", notebook="exp10_multirotor.md",
        question="Does trajectory-only wind identification work on RotorPy's quadrotor, from "
                 "a hover as well as drifting with the air?",
        paper_table="beyond the paper", build=_exp10,
        group_by=("scenario_id", "scenario", "vehicle", "noise"), readings=("inferred",),
        summary="vehicle"),
    Experiment(
        id="exp11", title="The paper's future work", notebook="exp11_future_work.md",
        question="On a hovering multirotor, which observation (position, velocity, attitude, "
                 "body rates, IMU) and which action (thrust or attitude) tell the winds apart?",
        paper_table="beyond the paper (the paper's future work)", build=_exp11,
        group_by=("scenario", "action", "observation", "noise"), readings=("inferred",),
        summary="future"),
    Experiment(
        id="exp11_cem", title="The paper's future work, CEM", notebook="exp11_future_work.md",
        question="Does CEM find better attitude or thrust actions than random search?",
        paper_table="beyond the paper (the paper's future work)", search="cem",
        build=_exp11_cem, summary="cem", readings=("inferred",),
        group_by=("action", "observation")),
    Experiment(
        id="exp12", title="Closed loop", notebook="exp12_closed_loop.md",
        question="One vehicle in one unknown wind: how many seconds of flight does it need "
                 "to know which condition it is in, and does choosing its manoeuvres as it "
                 "flies help?",
        paper_table="beyond the paper (the paper's future work)", search="closed_loop",
        build=_exp12, search_options={"policies": CLOSED_LOOP_POLICIES,
                                      "decision_interval": 2.0, "report_interval": 0.5},
        group_by=("scenario", "vehicle"), readings=("halves",), summary="closed_loop"),
    Experiment(
        id="exp14", title="Flyable manoeuvres", notebook="exp14_flyable.md",
        question="Does the method still separate the winds when the multirotor flies "
                 "manoeuvres it can fly (waypoint references under its position controller), "
                 "and through which channel?",
        paper_table="beyond the paper (issue 31)", build=_exp14,
        group_by=("scenario", "action", "observation", "noise"), readings=("inferred",),
        summary="flyable"),
    Experiment(
        id="exp14_cem", title="Flyable manoeuvres, CEM", notebook="exp14_flyable.md",
        question="Does CEM find more informative flyable manoeuvres than random search?",
        paper_table="beyond the paper (issue 31)", search="cem", build=_exp14_cem,
        summary="cem", readings=("inferred",), group_by=("action", "observation"),
        search_options={"cem_scale": FLYABLE_CEM_SCALE}),
    Experiment(
        id="fit_layout", title="Layout fit", notebook="inference.md",
        question="Which gap between same-strength groups gives Table 4's scores?",
        paper_table="Table 4 (fit)", build=_fit_layout,
        group_by=("scenario_id", "scenario", "gap_ratio"), columns={"gap_ratio": "gap / spacing"}),
    Experiment(
        id="fit_mixed", title="Mixed-strength layout", notebook="inference.md",
        question="Does Table 3's spacing, read per axis or in magnitude, give Table 4's "
                 "mixed-strength rows, wherever the groups sit in their class ranges?",
        paper_table="Table 4 (scenarios 2, 5)", build=_fit_mixed,
        group_by=("scenario_id", "scenario", "spacing", "placement")),
    Experiment(
        id="fit_turbulence", title="Turbulence reading", notebook="inference.md",
        question="Which reading of the cited Dryden implementation gives Table 4's turbulence "
                 "row?",
        paper_table="Table 4 (scenario 7)", build=_fit_turbulence, group_by=("candidate",)),
]}


def get_experiment(exp_id: str) -> Experiment:
    """The :class:`Experiment` called ``exp_id``; ``ValueError`` naming the valid ids."""
    if not isinstance(exp_id, str):
        raise TypeError(f"experiment id must be a string, got {type(exp_id).__name__}")
    if exp_id not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {exp_id!r}; valid: {', '.join(EXPERIMENTS)}")
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
