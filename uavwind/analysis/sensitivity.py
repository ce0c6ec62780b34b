"""Were the simulated chapters' verdicts the simulator's steadiness? Exps 10, 11, 12 and 14
flown again with the variability Experiment 13's twin fits on real flights (issue 66, item 3).

This module owns :data:`FITTED` (the twin's fitted sources of variability, with
:data:`FITTED_BY`, where they come from), :data:`SOURCES` (which of them act on each chapter's
vehicle and flights, and why the others do not), :func:`chapter_variability` (the
:class:`~uavwind.sim.variability.FlightVariability` a chapter flies), :data:`HEADLINES` (each
chapter's headline cases) and :func:`sensitivity_table` (each headline case's verdict without
and with the sources: one row each, cached; registered as ``exp10_sensitivity``,
``exp11_sensitivity``, ``exp12_sensitivity`` and ``exp14_sensitivity``, which the fill runs
once the chapter's own loops are stored).

*Without* is the chapter's own cached loops (read, not flown again); *with* flies the same
cases with the same loop seeds -- the same actions, the same winds, the same sensor noise --
plus the variability, drawn from each loop's wind seed (:mod:`uavwind.sim.variability`), so
the two columns are paired loop by loop. The verdict is the chapters' one rule on the share of
loops grouped correctly (:func:`uavwind.core.stats.decide`, threshold one half: "separates",
"does not separate" or "cannot decide", fewer than :data:`~uavwind.core.stats.MIN_DECIDE`
loops deciding nothing); a reference loop the vehicle could not fly is counted apart, as the
chapter counts it.

Exp 12 (closed-loop identification) is paired episode by episode: the same test
environments, observation noise and policy draws, and the variability acts on the vehicle
that flies only (the truth), never on the replays its belief and planning predict with
(:mod:`uavwind.method.closed_loop.episode`): a belief built on the steady model, tested on a
vehicle as unsteady as the real one (a model-mismatch test). Its rows are the page's
verdicts (:data:`CLOSED_LOOP_AT`): per multirotor case and policy, whether the belief at the
flight's end identifies the condition (accuracy decidedly above one half: "identifies",
below: "misreads"), and per case whether planning and replanning help at 4 s (the paired
accuracy difference: "helps", "hurts"), each by :func:`~uavwind.core.stats.decide`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd

from ..core.stats import (MIN_DECIDE, MIN_INTERVAL, UNDECIDED, bootstrap_ci, decide,
                          paired_difference,
                          summarise)
from ..sim.variability import FlightVariability
from ..study.cache import results_dir
from ..study.profiles import DEFAULT_SEED, get_profile
from ..study.readings import get_reading
from ..study.registry import EXPERIMENTS, computes
from ..study.runner import check_seed_engine, experiment_entries, run_experiment
from .closed_loop import POLICY_NAMES
from .memo import memo

__all__ = ["FITTED", "FITTED_BY", "SOURCES", "SOURCE_NAMES", "HEADLINES", "CHAPTERS",
           "chapter_variability", "sources_table", "sources_shown", "headline_cases",
           "sensitivity_table", "SENSITIVITY_VERSION", "FITTED_DECIMALS", "shown",
           "verdict_sentence", "CLOSED_LOOP_AT", "CLOSED_LOOP_PAIRS"]

#: The twin's sources of variability as :func:`uavwind.analysis.twin_fit.calibrate_twin` fits
#: them (the :class:`~uavwind.analysis.twin.TwinCalibration` fields of the same names;
#: ``battery`` is ``hover_throttle_sd / hover_throttle``, the battery's spread relative to
#: its mean, which carries to a vehicle of another thrust-to-weight ratio). See
#: :data:`FITTED_BY`; ``tests/test_sensitivity.py`` holds them to a new fit when the flights
#: are there.
FITTED = {"attitude_error": 0.3542, "thrust_error": 0.0, "velocity_error": 0.0392,
          "vertical_velocity_error": 0.0263, "hover_throttle": 0.4817,
          "hover_throttle_sd": 0.0183, "gain_spread": 0.2509, "integral_spread": 0.0,
          "gust_scale": 0.0869, "error_time": 0.2592}
#: Where :data:`FITTED` comes from.
FITTED_BY = ("uavwind.analysis.twin_fit.calibrate_twin(real_flights.real_flight_rows("
             "profile='quick'), STUDIES['quick']): fitted on the four training controllers "
             "(L1, NF-C, NF-T, baseline; indi held out) of the 25 Neural-Fly flights "
             "($UAVWIND_NEURALFLY), their still-air lap-to-lap spreads of pitch, force along x "
             "and vertical tracking (the state errors) and position (the errors' correlation "
             "time, error_time [s]), their still-air tracking error (the controller), their "
             "hover throttle (the battery), their spread of force along x at 12.1 m/s (the "
             "gusts) and of position there (the integral gain's spread, SIM_VERSION 9: it "
             "takes the bound 0, the integral scaled with the bandwidth alone); twin_fit.py "
             "with the drag fitted at every wind and the still-air vertical error's share "
             "fitted on the position spread at 12.1 m/s (SIM_VERSION 8: it takes the bound, "
             "the vertical velocity estimate's error alone, so the thrust error is 0 and the "
             "vertical velocity error carries the wander), "
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
    "exp12": {
        "attitude_error": "yes: the flying vehicle's attitude loop flies on an estimate",
        "thrust_error": "yes: its rotors' thrust off the commanded (the twin fits it at 0)",
        "velocity_error": "no: thrust segments flown open loop, nothing reads a velocity",
        "vertical_velocity_error": "no: thrust segments flown open loop, nothing reads a "
                                   "velocity",
        "battery": "yes: its rotors' top speed (where they saturate)",
        "gain_spread": "no: no position controller flies (thrust segments open loop)",
        "integral_spread": "no: no position controller",
        "gust_scale": "yes: gusts on the test environment's mean wind"},
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
    "exp12": [{"scenario": f"Light constant vs {b}", "vehicle": "multirotor, RotorPy drag, hover"}
              for b in ("light constant", "light shear", "strong turbulence")],
    "exp14": [{"scenario_id": 1, "action": "waypoints", "observation": o}
              for o in ("position", "attitude", "imu")]}
#: Exp 12's verdicts, where its page reads them: whether each policy's belief identifies the
#: condition at the flight's end (None: the last report), and the policies' paired
#: comparisons (:data:`CLOSED_LOOP_PAIRS`) at 4 s [s].
CLOSED_LOOP_AT = {"identifies": None, "comparison": 4.0}
#: Exp 12's comparisons, as its page makes them: planning before take-off against the
#: paper's random manoeuvres, and replanning in flight against the best open-loop plan.
CLOSED_LOOP_PAIRS = (("best", "random"), ("receding", "best"), ("greedy", "best"))
#: Bump when a change alters the sensitivity rows.
#: 3: FITTED from the twin of SIM_VERSION 8 (no thrust error, larger gusts and tilt).
#: 4: the vertical velocity estimate's error, the twin's fit of the still-air height wander,
#: flown where a position controller flies (Exp 14).
#: 5: FITTED from the twin of SIM_VERSION 9 (the integral gain's spread fitted: 0).
SENSITIVITY_VERSION = "5"


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

    if exp.search == "closed_loop":
        return _closed_loop_table(chapter, prof, seed, engine, var, exp, rd, chosen, cases,
                                  results, n_jobs)

    def compute():
        entries = experiment_entries(exp, prof, rd, seed, engine, results_dir(results), {},
                                     chosen)
        out = []
        for ci, before, varied in _flown_both_ways(chapter, prof, seed, rd, chosen, entries,
                                                   var, results, n_jobs):
            row = {k: v for k, v in cases[ci].labels.items()}
            row.update({f"without_{k}": v for k, v in _summary(before).items()})
            row.update({f"with_{k}": v for k, v in _summary(varied).items()})
            out.append(_paired(row, varied.sort_values("loop")["score"].to_numpy(),
                               before.sort_values("loop")["score"].to_numpy()))
        return _frame(out, chapter, prof, seed, var)

    return memo(f"{chapter}_sensitivity", _params(prof, seed, engine, var, cases, chosen),
                compute, results)


def _params(prof, seed, engine, var, cases, chosen, **more):
    """What a chapter's sensitivity table is cached under (:func:`~.memo.memo`'s params):
    what made it, its headline cases' settings, ``more`` (the closed loop's) and
    :data:`SENSITIVITY_VERSION`."""
    return {"profile": str(prof), "seed": seed, "engine": engine, "variability": var.to_dict(),
            "cases": [cases[i].setting.key() for i in chosen], **more,
            "version": SENSITIVITY_VERSION}


def _paired(row, a, b):
    """``row`` with the paired change from the values without (``b``) to with (``a``) the
    variability, loop by loop or episode by episode (``change``, ``change_low``,
    ``change_high``), and whether its verdict survives; returned."""
    row["change"], row["change_low"], row["change_high"] = paired_difference(a, b)
    row["survives"] = row["with_verdict"] == row["without_verdict"]
    return row


def _flown_both_ways(chapter, prof, seed, rd, chosen, entries, var, results, n_jobs):
    """Per headline case ``(case index, without, with)``: the chapter's own rows of the case
    (read from the cache, or computed as the chapter computes them) and its cache entries
    flown again with the variability ``var`` (the same loops or episodes, so paired)."""
    own = run_experiment(chapter, profile=prof, seed=seed, n_jobs=n_jobs, results=results,
                         progress=False, cases=chosen, reading=rd.name)
    for ci in chosen:
        mine = [e for e in entries if e.labels["case"] == ci]
        varied = pd.concat([replace(e, setting=replace(e.setting, variability=var))
                            .compute(n_jobs=n_jobs) for e in mine], ignore_index=True)
        yield ci, own[own["case"] == ci], varied


def _frame(rows, chapter, prof, seed, var):
    """The rows as a table, with what made them in its ``attrs``."""
    df = pd.DataFrame(rows)
    df.attrs.update(chapter=chapter, profile=str(prof), seed=seed,
                    variability=str(var.to_dict()))
    return df


def _episode_verdict(values, above, below, threshold):
    """``(estimate, low, high, n, verdict word)`` of per-episode ``values``."""
    est, lo, hi = bootstrap_ci(np.asarray(values, dtype=float))
    d = decide(est, lo, hi, len(values), threshold=threshold, above=above, below=below,
               unit="episodes")
    return est, lo, hi, len(values), d.word


def _closed_loop_table(chapter, prof, seed, engine, var, exp, rd, chosen, cases, results,
                       n_jobs):
    """:func:`sensitivity_table` of a closed-loop chapter (Exp 12): one row per headline case
    and policy (``kind`` "identifies": the share of episodes whose belief is right at the
    flight's end, threshold one half) and per case and comparison (``kind`` "comparison":
    the paired accuracy difference at :data:`CLOSED_LOOP_AT` ``["comparison"]`` s,
    threshold 0), without and with the variability on the truth; ``row`` names the policy
    or the comparison, ``time`` [s] the report; ``without_``/``with_`` ``mean``, ``ci_low``,
    ``ci_high`` (accuracy or difference, percentage points), ``n_loops`` (episodes),
    ``verdict``; ``change``, ``change_low``, ``change_high``: the mean paired change (with
    minus without, points, episode by episode) with its 95% CI; ``survives``."""
    entries = experiment_entries(exp, prof, rd, seed, engine, results_dir(results), {}, chosen)
    compare_at = CLOSED_LOOP_AT["comparison"]

    def values(df):
        """key -> (episodes, per-episode values) of one case's episodes."""
        t_end = float(df["time"].max())
        t_id = t_end if CLOSED_LOOP_AT["identifies"] is None else CLOSED_LOOP_AT["identifies"]
        out = {}
        for when, kind in ((t_id, "identifies"), (compare_at, "comparison")):
            at = df[np.isclose(df["time"], when)]
            per = {pol: sub.sort_values("episode", kind="stable")
                   for pol, sub in at.groupby("policy", sort=False)}
            if kind == "identifies":
                for pol, sub in per.items():
                    out[(kind, pol, when)] = (sub["episode"].to_numpy(),
                                              100.0 * sub["correct"].to_numpy(dtype=float))
                continue
            for a, b in CLOSED_LOOP_PAIRS:
                if a not in per or b not in per:
                    continue
                xa, xb = per[a], per[b]
                if not np.array_equal(xa["episode"].to_numpy(), xb["episode"].to_numpy()):
                    raise ValueError(f"policies {a!r} and {b!r} flew different episodes")
                out[(kind, f"{a} - {b}", when)] = (
                    xa["episode"].to_numpy(),
                    100.0 * (xa["correct"].to_numpy(dtype=float)
                             - xb["correct"].to_numpy(dtype=float)))
        return out

    def compute():
        out = []
        for ci, own, varied in _flown_both_ways(chapter, prof, seed, rd, chosen, entries, var,
                                                results, n_jobs):
            before, after = values(own), values(varied)
            for key, (ep_b, b) in before.items():
                ep_a, a = after[key]
                if not np.array_equal(ep_a, ep_b):
                    raise ValueError(f"{chapter}: the varied episodes {ep_a} are not the "
                                     f"chapter's {ep_b}")
                kind, name, when = key
                row = {k: v for k, v in cases[ci].labels.items()}
                row.update(kind=kind, row=name, time=when)
                thr, words = ((50.0, ("identifies", "misreads")) if kind == "identifies"
                              else (0.0, ("helps", "hurts")))
                for side, vals in (("without", b), ("with", a)):
                    est, lo, hi, n, word = _episode_verdict(vals, *words, thr)
                    row.update({f"{side}_mean": est, f"{side}_ci_low": lo,
                                f"{side}_ci_high": hi, f"{side}_n_loops": n,
                                f"{side}_verdict": word})
                out.append(_paired(row, a, b))
        return _frame(out, chapter, prof, seed, var)

    return memo(f"{chapter}_sensitivity", _params(
        prof, seed, engine, var, cases, chosen, entries=[e.key for e in entries],
        at={k: v for k, v in CLOSED_LOOP_AT.items()},
        pairs=[list(p) for p in CLOSED_LOOP_PAIRS]), compute, results)


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


def _change(r, units: str = "loops") -> str:
    """The paired change of the score with its 95% CI; none on fewer than
    :data:`~uavwind.core.stats.MIN_INTERVAL` loops (``units``), and where every one moved
    alike (a zero-width interval is no interval) that, in words."""
    n = int(r["with_n_loops"])
    text = f"{r['change']:+.1f}"
    if n < MIN_INTERVAL:
        return text
    if r["change_low"] == r["change_high"]:
        return f"{text} (the same on all {n} {units})"
    return f"{text} [{r['change_low']:+.1f}, {r['change_high']:+.1f}]"


def _steadiness(changed, holds, units) -> str:
    """What the changed verdicts say of the simulator's steadiness. A verdict that changes
    was the steadiness only where the paired change itself is decided (its 95% interval,
    on at least :data:`~uavwind.core.stats.MIN_INTERVAL` ``units``, excludes 0): a verdict
    can flip on one loop of a few while the change is no more than noise."""
    if not len(changed):
        return " None was the simulator's steadiness."
    firm = changed[((changed["change_high"] < 0) | (changed["change_low"] > 0))
                   & (changed["with_n_loops"] >= MIN_INTERVAL)]
    if len(firm) == len(changed):
        return f" Each verdict that changes was the simulator's steadiness: {holds}."
    if not len(firm):
        return (" No change of verdict is itself decided (each paired change's 95% interval "
                f"holds 0): more {units} decide whether it was the simulator's steadiness.")
    return (f" {len(firm)} of the {len(changed)} changes of verdict are decided (their paired "
            f"change's 95% interval excludes 0): those were the simulator's steadiness, and "
            f"{holds}; the others need more {units} to say.")


def _survivors(table, count, units):
    """The opening both sentences share: ``(decided, changed, text)``: the rows decided
    without the variability, those whose verdict changed, and the count that survive (or,
    where no row decides either way, that the ``count`` (loops or episodes) decide nothing,
    ``changed`` then None)."""
    n = len(table)
    decided = table[table["without_verdict"] != UNDECIDED]  # a verdict to keep or lose
    changed = decided[~decided["survives"].astype(bool)]
    undecided = (table["without_verdict"] == UNDECIDED) & (table["with_verdict"] == UNDECIDED)
    if undecided.all():
        k = int(table["with_n_loops"].min())
        return decided, None, (
            f"On {k} {count if k == 1 else count + 's'} a {units[:-1]} neither side decides a "
            f"verdict (one needs {MIN_DECIDE}): the rows show the "
            f"{'scores' if count == 'loop' else 'numbers'} only; the paper profile's count "
            f"decides.")
    kept = int(decided["survives"].sum())
    return decided, changed, (
        f"{kept} of {len(decided)} headline verdicts survive the real vehicle's variability"
        + (f" ({n - len(decided)} of the {n} {units} decide nothing without it, so have no "
           f"verdict to keep)" if len(decided) < n else ""))


def shown(table: pd.DataFrame, chapter: str) -> pd.DataFrame:
    """:func:`sensitivity_table`'s rows as a page shows them: per headline case the mean
    score [95% CI] and the share grouped correctly without and with the variability, the
    verdicts, the paired change and whether the verdict survives."""
    _check_chapter(chapter)
    if chapter == "exp12":
        return _shown_closed_loop(table)
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
    if chapter == "exp12":
        return _closed_loop_sentence(table)
    n = len(table)
    decided, changed, opening = _survivors(table, "loop", "cases")
    if changed is None:
        return opening
    parts = [opening]
    for _, r in changed.iterrows():
        parts.append(f"**{r['scenario'].lower()}, {_case_name(r, chapter)}: "
                     f"{r['without_verdict']} without it, {r['with_verdict']} with it** "
                     f"(grouped correctly in {100 * r['without_correct_rate']:.0f}% and "
                     f"{100 * r['with_correct_rate']:.0f}% of the loops)")
    moved = table[((table["change_high"] < 0) | (table["change_low"] > 0))
                  & (table["with_n_loops"] >= MIN_INTERVAL)]
    text = "; ".join(parts) + "."
    text += _steadiness(changed, "the chapter's verdict on that case holds for the steady "
                                 "simulator only", "loops")
    if len(moved):
        big = moved.loc[moved["change"].abs().idxmax()]
        text += (f" The score moves decidedly in {len(moved)} of {n} cases, most on "
                 f"{big['scenario'].lower()}, {_case_name(big, chapter)} "
                 f"({big['change']:+.1f} points, 95% CI {big['change_low']:+.1f} to "
                 f"{big['change_high']:+.1f}).")
    return text


#: Exp 12's comparisons as its page names them.
_COMPARISONS = {"best - random": "planning before take-off (open-loop best - random)",
                "receding - best": "replanning (receding CEM - open-loop best)",
                "greedy - best": "greedy replanning (greedy - open-loop best)"}


def _closed_loop_name(r, sentence=False):
    """A row's name: the table's (``Light constant vs light shear: open-loop best, right at
    12 s``) or, in a sentence, the same in lower case (``light constant vs light shear,
    open-loop best, right at 12 s``)."""
    scen = r["scenario"].lower() + "," if sentence else r["scenario"] + ":"
    if r["kind"] == "identifies":
        return f"{scen} {POLICY_NAMES.get(r['row'], r['row'])}, right at {r['time']:g} s"
    return f"{scen} {_COMPARISONS.get(r['row'], r['row'])} at {r['time']:g} s"


def _signed(v):
    return f"{v:+.1f}"


def _closed_loop_cell(r, side):
    fmt = (lambda v: f"{v:.1f}%") if r["kind"] == "identifies" else _signed
    cell = fmt(r[f"{side}_mean"])
    if int(r[f"{side}_n_loops"]) >= MIN_INTERVAL and r[f"{side}_ci_low"] < r[f"{side}_ci_high"]:
        cell += f" [{fmt(r[f'{side}_ci_low'])}, {fmt(r[f'{side}_ci_high'])}]"
    return cell


def _shown_closed_loop(table):
    """Exp 12's rows as its page shows them: per multirotor case, each policy's accuracy at
    the flight's end and each comparison's paired difference at 4 s [points], without and
    with the variability on the flying vehicle, the verdicts, the paired change."""
    rows = {}
    for _, r in table.iterrows():
        rows[_closed_loop_name(r)] = {
            "without [95% CI]": _closed_loop_cell(r, "without"),
            "verdict without": r["without_verdict"],
            "with [95% CI]": _closed_loop_cell(r, "with"),
            "verdict with": r["with_verdict"],
            "change, points [95% CI]": _change(r, "episodes"),
            "episodes": f"{int(r['with_n_loops'])}",
            "survives": ("no verdict to keep" if r["without_verdict"] == UNDECIDED
                         else "yes" if r["survives"] else "no")}  # a DataFrame: no Markdown
    return pd.DataFrame(rows).T


def _closed_loop_sentence(table):
    """:func:`verdict_sentence` of Exp 12's rows: only a verdict decided without the
    variability can be kept or lost (a row that decides nothing without it has none)."""
    n = len(table)
    decided, changed, opening = _survivors(table, "episode", "rows")
    if changed is None:
        return opening
    parts = [opening]
    for _, r in changed.iterrows():
        unit = ((lambda v: f"{v:.0f}%") if r["kind"] == "identifies"
                else (lambda v: f"{_signed(v)} points"))
        what = ("right in" if r["kind"] == "identifies" else "a paired difference of")
        of = " of the episodes" if r["kind"] == "identifies" else ""
        parts.append(f"**{_closed_loop_name(r, True)}: {r['without_verdict']} without it, "
                     f"{r['with_verdict']} with it** ({what} {unit(r['without_mean'])} and "
                     f"{unit(r['with_mean'])}{of})")
    text = "; ".join(parts) + "."
    text += _steadiness(changed, "there the chapter's verdict holds only for a vehicle as "
                                 "steady as the model its belief predicts with", "episodes")
    moved = table[((table["change_high"] < 0) | (table["change_low"] > 0))
                  & (table["with_n_loops"] >= MIN_INTERVAL)]
    if len(moved):
        big = moved.loc[moved["change"].abs().idxmax()]
        down = int((moved["change"] < 0).sum())
        side = ("every one lower with it" if down == len(moved) else
                "every one higher with it" if down == 0 else
                f"{down} lower and {len(moved) - down} higher with it")
        text += (f" An accuracy or a difference moves decidedly in {len(moved)} of {n} rows "
                 f"({side}), most on {_closed_loop_name(big, True)} "
                 f"({_signed(big['change'])} points, 95% CI {_signed(big['change_low'])} to "
                 f"{_signed(big['change_high'])}).")
    return text


def _register(chapter):
    exp = EXPERIMENTS[chapter]

    # Exp 12's flies every episode again: ~620 CPU-s on the paper profile, a long task
    @computes(f"{chapter}_sensitivity", reads=(chapter,), long=exp.search == "closed_loop",
              title=f"{exp.title}: verdicts with the real vehicle's variability",
              notebook=exp.notebook)
    def fill(profile, seed, results):
        return sensitivity_table(chapter, profile, seed, results)

    fill.__name__ = f"{chapter}_sensitivity"
    return fill


for _chapter in CHAPTERS:
    _register(_chapter)
