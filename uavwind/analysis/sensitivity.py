"""Were the simulated chapters' verdicts the simulator's steadiness? Exps 10, 11 and 14 flown
again with the variability Experiment 13's twin fits on real flights (issue 66, item 3).

This module owns :data:`FITTED` (the twin's fitted sources of variability, with
:data:`FITTED_BY`, where they come from), :data:`SOURCES` (which of them act on each chapter's
vehicle and flights, and why the others do not), :func:`chapter_variability` (the
:class:`~uavwind.sim.variability.FlightVariability` a chapter flies), :data:`HEADLINES` (each
chapter's headline cases) and :func:`sensitivity_table` (each headline case's verdict without
and with the sources: one row each, cached; registered as ``exp10_sensitivity``,
``exp11_sensitivity`` and ``exp14_sensitivity``, which the fill runs once the chapter's own
loops are stored).

*Without* is the chapter's own cached loops (read, not flown again); *with* flies the same
cases with the same loop seeds -- the same actions, the same winds, the same sensor noise --
plus the variability, drawn from each loop's wind seed (:mod:`uavwind.sim.variability`), so
the two columns are paired loop by loop. The verdict is the chapters' one rule on the share of
loops grouped correctly (:func:`uavwind.core.stats.decide`, threshold one half: "separates",
"does not separate" or "cannot decide", fewer than :data:`~uavwind.core.stats.MIN_DECIDE`
loops deciding nothing); a reference loop the vehicle could not fly is counted apart, as the
chapter counts it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from ..core.stats import (MIN_DECIDE, MIN_INTERVAL, UNDECIDED, decide, paired_difference,
                          summarise)
from ..sim.variability import FlightVariability
from ..study.cache import results_dir
from ..study.profiles import DEFAULT_SEED, get_profile
from ..study.readings import get_reading
from ..study.registry import EXPERIMENTS, computes
from ..study.runner import check_seed_engine, experiment_entries, run_experiment
from .memo import memo

__all__ = ["FITTED", "FITTED_BY", "SOURCES", "SOURCE_NAMES", "HEADLINES", "CHAPTERS",
           "chapter_variability", "sources_table", "sources_shown", "headline_cases", "sensitivity_table",
           "SENSITIVITY_VERSION", "FITTED_DECIMALS", "shown", "verdict_sentence"]

#: The twin's sources of variability as :func:`uavwind.analysis.figure8.calibrate_twin` fits
#: them (the :class:`~uavwind.analysis.figure8.TwinCalibration` fields of the same names;
#: ``battery`` is ``hover_throttle_sd / hover_throttle``, the battery's spread relative to
#: its mean, which carries to a vehicle of another thrust-to-weight ratio). See
#: :data:`FITTED_BY`; ``tests/test_sensitivity.py`` holds them to a new fit when the flights
#: are there.
FITTED = {"attitude_error": 0.3542, "thrust_error": 0.0, "velocity_error": 0.0392,
          "vertical_velocity_error": 0.0263, "hover_throttle": 0.4817, "hover_throttle_sd": 0.0183, "gain_spread": 0.2509,
          "integral_spread": 0.2509, "gust_scale": 0.0875, "error_time": 0.2592}
#: Where :data:`FITTED` comes from.
FITTED_BY = ("uavwind.analysis.figure8.calibrate_twin(real_flights.real_flight_rows("
             "profile='quick'), STUDIES['quick']): fitted on the four training controllers "
             "(L1, NF-C, NF-T, baseline; indi held out) of the 25 Neural-Fly flights "
             "($UAVWIND_NEURALFLY), their still-air lap-to-lap spreads of pitch, force along x "
             "and vertical tracking (the state errors) and position (the errors' correlation "
             "time, error_time [s]), their still-air tracking error (the controller), their "
             "hover throttle (the battery) and their spread of force along x at 12.1 m/s (the "
             "gusts); figure8.py with the drag fitted at every wind and the still-air vertical "
             "error's share fitted on the position spread at 12.1 m/s (SIM_VERSION 8: it "
             "takes the bound, the vertical velocity estimate's error alone, so the thrust "
             "error is 0 and the vertical velocity error carries the wander), "
             "the quick profile's fit (the paper profile's correlation time is 0.232 s)")
#: The decimals :data:`FITTED` keeps: a new fit rounds to them.
FITTED_DECIMALS = 4

#: Display names of the sources.
SOURCE_NAMES = {"attitude_error": "attitude-estimate tilt [deg]",
                "thrust_error": "thrust error [share]",
                "velocity_error": "velocity-estimate error along x [m/s]",
                "vertical_velocity_error": "velocity-estimate error along z [m/s]",
                "battery": "battery (hover throttle, relative SD)",
                "gain_spread": "controller bandwidth (log-SD)",
                "integral_spread": "controller integral gain (log-SD)",
                "gust_scale": "gusts (Dryden W20 / mean speed)"}

_OPEN_LOOP = {
    "attitude_error": "yes: the attitude loop flies on an estimate",
    "thrust_error": "yes: the rotors' thrust off the commanded (the twin fits it at 0)",
    "velocity_error": "no: flown open loop, nothing reads a velocity",
    "vertical_velocity_error": "no: flown open loop, nothing reads a velocity",
    "battery": "yes: the rotors' top speed (where they saturate)",
    "gain_spread": "no: no position controller flies (thrust or attitude flown open loop)",
    "integral_spread": "no: no position controller",
    "gust_scale": "yes: gusts on each environment's mean wind"}
#: Per chapter, per source: whether it acts on the chapter's vehicle and flights, and why.
SOURCES = {
    "exp10": _OPEN_LOOP,
    "exp11": _OPEN_LOOP,
    "exp14": {
        "attitude_error": "yes: the position controller reads an attitude estimate",
        "thrust_error": "yes: the rotors' thrust off the commanded (the twin fits it at 0)",
        "velocity_error": "yes: it reads a velocity estimate",
        "vertical_velocity_error": "yes: it holds its height on a velocity estimate",
        "battery": "yes: the rotors' top speed and the thrust cone",
        "gain_spread": "yes: a position controller flies the references",
        "integral_spread": "yes: its integral term",
        "gust_scale": "yes: gusts on each environment's mean wind"}}
#: The chapters with a sensitivity row.
CHAPTERS = tuple(SOURCES)

#: Each chapter's headline cases, as label filters on its cases: Exp 10 the hovering
#: multirotor (RotorPy's drag) on light vs light without and with GNSS noise and on light vs
#: strong with it; Exp 11 light vs light with consumer sensors, thrust actions, through the
#: position, the attitude and the IMU; Exp 14 the same three channels under flyable
#: references.
HEADLINES = {
    "exp10": [{"vehicle": "multirotor, RotorPy drag, hover", "scenario_id": k, "noise": n}
              for k, n in ((1, "none"), (1, "consumer"), (2, "consumer"))],
    "exp11": [{"scenario": "Light constant vs light constant", "action": "thrust",
               "observation": o, "noise": "consumer"} for o in ("position", "attitude", "imu")],
    "exp14": [{"scenario_id": 1, "action": "waypoints", "observation": o}
              for o in ("position", "attitude", "imu")]}
#: Bump when a change alters the sensitivity rows.
#: 3: FITTED from the twin of SIM_VERSION 8 (no thrust error, larger gusts and tilt).
#: 4: the vertical velocity estimate's error, the twin's fit of the still-air height wander,
#: flown where a position controller flies (Exp 14).
SENSITIVITY_VERSION = "4"


def _check_chapter(chapter):
    if chapter not in SOURCES:
        raise ValueError(f"chapter must be one of {list(CHAPTERS)}, got {chapter!r}")
    return chapter


def chapter_variability(chapter: str, scale: float = 1.0) -> FlightVariability:
    """The :class:`~uavwind.sim.variability.FlightVariability` ``chapter`` flies: the
    :data:`FITTED` sources that act on its vehicle (:data:`SOURCES`), each size times
    ``scale`` (0: none; 1: as fitted)."""
    _check_chapter(chapter)
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not 0 <= scale <= 10:
        raise ValueError(f"scale must be a number in [0, 10], got {scale!r}")
    values = dict(FITTED, battery=FITTED["hover_throttle_sd"] / FITTED["hover_throttle"])
    acts = {k: scale * values[k] for k, why in SOURCES[chapter].items() if why.startswith("yes")}
    return FlightVariability(**acts, error_time=FITTED["error_time"])  # a time, not a size


def sources_table(chapter: str) -> pd.DataFrame:
    """One row per source: its fitted size (:data:`FITTED`) and whether it acts on
    ``chapter``'s flights, and why."""
    _check_chapter(chapter)
    var = chapter_variability(chapter)
    fitted = dict(FITTED, battery=FITTED["hover_throttle_sd"] / FITTED["hover_throttle"])
    rows = [{"source": SOURCE_NAMES[k], "fitted": fitted[k],
             "flown": getattr(var, k), "applies": why} for k, why in SOURCES[chapter].items()]
    return pd.DataFrame(rows).set_index("source")


def sources_shown(chapter: str) -> pd.DataFrame:
    """:func:`sources_table` as a page shows it: each size at three significant figures, 0
    where the source does not act."""
    table = sources_table(chapter)
    return table.assign(**{c: table[c].map(lambda v: f"{v:.3g}") for c in ("fitted", "flown")})


def headline_cases(chapter: str) -> list[int]:
    """The indices of ``chapter``'s headline cases (:data:`HEADLINES`), in that order."""
    exp = EXPERIMENTS[_check_chapter(chapter)]
    cases = exp.cases(get_reading(exp.readings[0]))
    out = []
    for want in HEADLINES[chapter]:
        hits = [i for i, c in enumerate(cases)
                if all(c.labels.get(k) == v for k, v in want.items())]
        if len(hits) != 1:
            raise ValueError(f"{chapter}: headline {want} matches {len(hits)} cases, not one")
        out.append(hits[0])
    return out


def _summary(rows):
    """The verdict and summary of one case's loops (crashed reference loops apart)."""
    crashed = (rows["crashed"].fillna(0).to_numpy() > 0 if "crashed" in rows.columns
               else np.zeros(len(rows), bool))
    flown = rows[~crashed]
    s = summarise(flown)
    d = decide(s["correct_rate"], s["correct_low"], s["correct_high"], s["n_loops"],
               threshold=0.5, above="separates", below="does not separate")
    return {"mean": s["mean"], "ci_low": s["ci_low"], "ci_high": s["ci_high"],
            "correct_rate": s["correct_rate"], "correct_low": s["correct_low"],
            "correct_high": s["correct_high"], "n_loops": s["n_loops"],
            "crashed": int(crashed.sum()), "verdict": d.word}


def sensitivity_table(chapter: str, profile="quick", seed: int = DEFAULT_SEED, results=None,
                      n_jobs: int | None = 1, scale: float = 1.0) -> pd.DataFrame:
    """One row per headline case of ``chapter`` (:func:`headline_cases`): its labels, then
    ``without_*`` (the chapter's own loops, read from the cache or computed as the chapter
    computes them) and ``with_*`` (the same loops flown with :func:`chapter_variability`
    ``(chapter, scale)``) of ``mean``, ``ci_low``, ``ci_high``, ``correct_rate``,
    ``correct_low``, ``correct_high``, ``n_loops``, ``crashed`` and ``verdict``; ``change``,
    ``change_low``, ``change_high``: the mean paired change of the score (with minus
    without) with its 95% CI; ``survives``: the verdict word unchanged. Cached
    (:func:`uavwind.analysis.memo.memo`) under the chapter, the profile, the seed, the
    variability and the cases' setting keys."""
    _check_chapter(chapter)
    prof = get_profile(profile)
    seed, engine = check_seed_engine(seed, None)
    var = chapter_variability(chapter, scale)
    exp = EXPERIMENTS[chapter]
    rd = get_reading(exp.readings[0])
    chosen = headline_cases(chapter)
    cases = exp.cases(rd)

    def compute():
        own = run_experiment(chapter, profile=prof, seed=seed, n_jobs=n_jobs, results=results,
                             progress=False, cases=chosen, reading=rd.name)
        entries = experiment_entries(exp, prof, rd, seed, engine, results_dir(results), {},
                                     chosen)
        out = []
        for ci in chosen:
            mine = [e for e in entries if e.labels["case"] == ci]
            varied = pd.concat([replace(e, setting=replace(e.setting, variability=var))
                                .compute(n_jobs=n_jobs) for e in mine], ignore_index=True)
            before = own[own["case"] == ci]
            row = {k: v for k, v in cases[ci].labels.items()}
            row.update({f"without_{k}": v for k, v in _summary(before).items()})
            row.update({f"with_{k}": v for k, v in _summary(varied).items()})
            a = varied.sort_values("loop")["score"].to_numpy()
            b = before.sort_values("loop")["score"].to_numpy()
            row["change"], row["change_low"], row["change_high"] = paired_difference(a, b)
            row["survives"] = row["with_verdict"] == row["without_verdict"]
            out.append(row)
        df = pd.DataFrame(out)
        df.attrs.update(chapter=chapter, profile=str(prof), seed=seed,
                        variability=str(var.to_dict()))
        return df

    return memo(f"{chapter}_sensitivity", {
        "profile": str(prof), "seed": seed, "engine": engine, "variability": var.to_dict(),
        "cases": [cases[i].setting.key() for i in chosen], "version": SENSITIVITY_VERSION},
        compute, results)


def _case_name(row, chapter):
    if chapter == "exp10":
        return f"S{row['scenario_id']}, {'GNSS noise' if row['noise'] == 'consumer' else 'no noise'}"
    if chapter == "exp11":
        return f"{row['action']} actions, {_channel(row['observation'])}"
    return f"{row['action']}, {_channel(row['observation'])}"


def _channel(name):
    return {"imu": "IMU"}.get(name, name.replace("_", " "))


def _cell(r, side):
    n = int(r[f"{side}_n_loops"])
    mean = f"{r[f'{side}_mean']:.1f}"
    if n >= 3 and r[f"{side}_ci_low"] < r[f"{side}_ci_high"]:
        mean += f" [{r[f'{side}_ci_low']:.1f}, {r[f'{side}_ci_high']:.1f}]"
    return mean


def _change(r) -> str:
    """The paired change of the score with its 95% CI; none on fewer than
    :data:`~uavwind.core.stats.MIN_INTERVAL` loops, and where every loop moved alike (a
    zero-width interval is no interval) that, in words."""
    n = int(r["with_n_loops"])
    text = f"{r['change']:+.1f}"
    if n < MIN_INTERVAL:
        return text
    if r["change_low"] == r["change_high"]:
        return f"{text} (the same on all {n} loops)"
    return f"{text} [{r['change_low']:+.1f}, {r['change_high']:+.1f}]"


def shown(table: pd.DataFrame, chapter: str) -> pd.DataFrame:
    """:func:`sensitivity_table`'s rows as a page shows them: per headline case the mean
    score [95% CI] and the share grouped correctly without and with the variability, the
    verdicts, the paired change and whether the verdict survives."""
    _check_chapter(chapter)
    rows = {}
    for _, r in table.iterrows():
        crashed = int(r["with_crashed"])
        rows[f"{r['scenario']}: {_case_name(r, chapter)}"] = {
            "score without": _cell(r, "without"),
            "grouped without": f"{100 * r['without_correct_rate']:.0f}%",
            "verdict without": r["without_verdict"],
            "score with": _cell(r, "with"),
            "grouped with": f"{100 * r['with_correct_rate']:.0f}%"
                            + (f" ({crashed} crashed)" if crashed else ""),
            "verdict with": r["with_verdict"],
            "change [95% CI]": _change(r),
            "loops": f"{int(r['with_n_loops'])}",
            "survives": ("no verdict to keep" if r["without_verdict"] == UNDECIDED
                         else "yes" if r["survives"] else "no")}
    return pd.DataFrame(rows).T


def verdict_sentence(table: pd.DataFrame, chapter: str) -> str:
    """What the rows say, in words: how many verdicts survive, each change named (the case,
    from what to what), or that too few loops decide either side."""
    _check_chapter(chapter)
    n = len(table)
    decided = table[table["without_verdict"] != UNDECIDED]  # a verdict to keep or lose
    kept = int(decided["survives"].sum())
    changed = decided[~decided["survives"].astype(bool)]
    undecided = (table["without_verdict"] == UNDECIDED) & (table["with_verdict"] == UNDECIDED)
    if undecided.all():
        n_loops = int(table["with_n_loops"].min())
        return (f"On {n_loops} loop{'' if n_loops == 1 else 's'} a case neither side decides "
                f"a verdict (one needs {MIN_DECIDE}): the rows show the scores only; the paper "
                f"profile's count decides.")
    parts = [f"{kept} of {len(decided)} headline verdicts survive the real vehicle's "
             f"variability" + (f" ({n - len(decided)} of the {n} cases decide nothing without "
                               f"it, so have no verdict to keep)" if len(decided) < n else "")]
    for _, r in changed.iterrows():
        parts.append(f"**{r['scenario'].lower()}, {_case_name(r, chapter)}: "
                     f"{r['without_verdict']} without it, {r['with_verdict']} with it** "
                     f"(grouped correctly in {100 * r['without_correct_rate']:.0f}% and "
                     f"{100 * r['with_correct_rate']:.0f}% of the loops)")
    moved = table[((table["change_high"] < 0) | (table["change_low"] > 0))
                  & (table["with_n_loops"] >= MIN_INTERVAL)]
    text = "; ".join(parts) + "."
    text += (" Each verdict that changes was the simulator's steadiness: the chapter's verdict "
             "on that case holds for the steady simulator only." if len(changed) else
             " None was the simulator's steadiness.")
    if len(moved):
        big = moved.loc[moved["change"].abs().idxmax()]
        text += (f" The score moves decidedly in {len(moved)} of {n} cases, most on "
                 f"{big['scenario'].lower()}, {_case_name(big, chapter)} "
                 f"({big['change']:+.1f} points, 95% CI {big['change_low']:+.1f} to "
                 f"{big['change_high']:+.1f}).")
    return text


def _register(chapter):
    exp = EXPERIMENTS[chapter]

    @computes(f"{chapter}_sensitivity", reads=(chapter,),
              title=f"{exp.title}: verdicts with the real vehicle's variability",
              notebook=exp.notebook)
    def fill(profile, seed, results):
        return sensitivity_table(chapter, profile, seed, results)

    fill.__name__ = f"{chapter}_sensitivity"
    return fill


for _chapter in CHAPTERS:
    _register(_chapter)
