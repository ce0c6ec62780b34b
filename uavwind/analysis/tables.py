"""Summary tables of experiment results, in the paper's layout, and where they came from.

This module owns :func:`summary_table` (the replication's version of the paper's table for
an experiment, by the summary its :class:`~uavwind.study.registry.Experiment` names in
:data:`SUMMARIES`), :func:`comparison_table` (paper beside replication, row by row, by the
reference it names in :data:`REFERENCES`) and :func:`provenance` (the line every table and
figure carries: experiment, reading, profile, seed, engine, rows, version and commit). Every
max/mean row is :func:`uavwind.core.stats.summarise`, the project's one summary with its one
confidence interval.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import pandas as pd

from .._version import __version__
from ..core.checks import check_instance
from ..core.stats import MIN_DECIDE, ci_halfwidth, loops_needed, summarise
from ..study.paper import load_paper_values
from ..study.profiles import PROFILES
from ..study.registry import EXPERIMENTS, get_experiment
from ..study.runner import case_loops
from ..study.sizing import SIZINGS, Sizing
from .beyond import baseline_table, future_table, loop_differences, vehicle_table
from .closed_loop import accuracy_table
from .manoeuvres import flyable_table

__all__ = ["profile_note", "case_counts", "loops_needed", "sizing_note", "fewer_loops_note", "paired_spread", "summary_table", "comparison_table", "provenance", "source_commit", "SUMMARIES",
           "REFERENCES", "maxmean_table", "cem_table"]


def maxmean_table(df: pd.DataFrame, by: Iterable[str]) -> pd.DataFrame:
    """One row per ``by`` group: ``max``, ``mean`` with its 95% bootstrap ``ci_low`` and
    ``ci_high``, ``correct_rate`` and ``n_loops`` (:func:`~uavwind.core.stats.summarise`)."""
    by = list(by)
    rows = {}
    for key, sub in df.groupby(by, sort=False):
        s = summarise(sub.sort_values("loop"))
        rows[key] = {k: s[k] for k in ("max", "mean", "ci_low", "ci_high", "correct_rate",
                                       "n_loops")}
    out = pd.DataFrame.from_dict(rows, orient="index")
    out.index = (pd.MultiIndex.from_tuples(out.index, names=by) if len(by) > 1
                 else pd.Index([k[0] if isinstance(k, tuple) else k for k in out.index],
                               name=by[0]))
    return out


def cem_table(df: pd.DataFrame, by=()) -> pd.DataFrame:
    """CEM per iteration (and per ``by`` columns, one CEM run each): ``max``, ``mean``,
    ``elite_mean`` and ``best_so_far`` of the scores."""
    by = [b for b in by if b in df.columns]
    if by:
        parts = {k: cem_table(sub) for k, sub in df.groupby(by, sort=False)}
        return pd.concat(parts, names=by)
    g = df.groupby("iteration")["score"]
    elite = df[df["elite"]].groupby("iteration")["score"].mean()
    return pd.DataFrame({"max": g.max(), "mean": g.mean(), "elite_mean": elite,
                         "best_so_far": g.max().cummax()})


#: Summary name (``Experiment.summary``) -> ``(experiment, df) -> table``.
SUMMARIES = {
    "maxmean": lambda exp, df: maxmean_table(df, exp.group_by),
    "cem": lambda exp, df: cem_table(df, [k for k in exp.group_by if k != "scenario"]),
    "baseline": lambda exp, df: baseline_table(df),
    "vehicle": lambda exp, df: vehicle_table(df),
    "future": lambda exp, df: future_table(df),
    "closed_loop": lambda exp, df: accuracy_table(df),
    "flyable": lambda exp, df: flyable_table(df),
}


def _paper_reference(exp, df):
    return load_paper_values(exp.id)


def _example_reference(exp, df):
    ref = load_paper_values("example")
    score = float(ref.loc[ref["quantity"] == "score", "value"].iloc[0])
    return pd.DataFrame({"scenario": [df["scenario"].iloc[0]], "maximum": [score],
                         "mean": [float("nan")]})


#: Reference name (``Experiment.reference``) -> ``(experiment, df) -> the paper's rows``
#: (``paper_keys``, ``scenario``, ``maximum``, ``mean``).
REFERENCES = {"paper": _paper_reference, "example": _example_reference}


def _record(df):
    """The :class:`~uavwind.study.registry.Experiment` whose tables ``df`` is laid out as."""
    exp = get_experiment(df["experiment"].iloc[0])
    return EXPERIMENTS[exp.tables_as] if exp.tables_as else exp


def summary_table(df: pd.DataFrame) -> pd.DataFrame:
    """The replication's version of the paper's table for ``df`` (an experiment's results):
    ``max``, ``mean`` (with its 95% bootstrap ``ci_low``/``ci_high``), ``correct_rate``
    and ``n_loops`` per the experiment's ``group_by`` columns, or its own summary
    (CEM: ``max``, ``mean``, ``elite_mean``, ``best_so_far`` per iteration)."""
    exp = _record(df)
    return SUMMARIES[exp.summary](exp, df)


def comparison_table(df: pd.DataFrame) -> pd.DataFrame:
    """Paper vs replication, side by side, for the rows the paper reports.

    Columns: ``paper_max, max, paper_mean, mean``, ``ci_low``, ``ci_high`` (95%
    bootstrap interval of the mean over loops), ``correct_rate``, ``n_loops`` and the
    ``case``; index: the
    paper's row labels. Reads the paper's values through :mod:`uavwind.study.paper`.
    """
    exp = _record(df)
    if not exp.paper_keys:
        raise ValueError(f"no paper table to compare for {exp.id!r}")
    ref = REFERENCES[exp.reference](exp, df)
    keys = exp.paper_keys
    rows = []
    for _, p in ref.iterrows():
        sub = df
        for k in keys:
            sub = sub.loc[sub[k] == p[k]]
        if not len(sub):
            continue
        units = {"n_env": "environments", "thrust_changes": "thrust changes"}
        label = p["scenario"] + "".join(f", {p[k]} {units[k]}" for k in keys if k in units)
        s = summarise(sub)
        rows.append({"row": label, "case": int(sub["case"].iloc[0]), "paper_max": p["maximum"],
                     "max": s["max"], "paper_mean": p["mean"], "mean": s["mean"],
                     "ci_low": s["ci_low"], "ci_high": s["ci_high"],
                     "correct_rate": s["correct_rate"], "n_loops": s["n_loops"]})
    return pd.DataFrame(rows).set_index("row")


def provenance(df: pd.DataFrame) -> str:
    """One line saying how a result table was made: experiment, reading, profile, seed,
    engine, loops, library version and commit (for captions)."""
    a = df.attrs
    return (f"Made by experiment {a.get('experiment', '?')} under the {a.get('reading', '?')!r} "
            f"reading, profile {a.get('profile', '?')}, seed {a.get('seed', '?')}, engine "
            f"{a.get('engine', '?')}, {len(df)} rows; uavwind {__version__}, commit {source_commit()}.")


def profile_note(df: pd.DataFrame) -> str:
    """A sentence for a page (Markdown): the profile its results were made under and how
    many loops, CEM samples or episodes each case ran, against the paper profile's counts;
    under any profile but ``"paper"`` it says, in bold, that the page's verdicts are
    provisional."""
    a = df.attrs
    exp = get_experiment(a["experiment"])
    prof = a.get("profile", "?")
    paper = PROFILES["paper"]
    if exp.search == "closed_loop":
        ref = [paper.episodes]
    elif exp.search == "cem":
        ref = [paper.cem.n_samples * paper.cem.max_iter]
    else:
        ref = sorted({case_loops(paper, c, exp.id) for c in exp.cases()})
    n_cases = df["case"].nunique()
    text = (f"**This page shows the *{prof}* profile:** {case_counts(df)} "
            f"per case over {n_cases} case{'' if n_cases == 1 else 's'}.")
    if prof != "paper":
        col, unit = _COUNTED[exp.search]
        fewest = int((df.groupby("case").size() if col is None
                      else df.groupby("case")[col].nunique()).min())
        text += (f" **Its verdicts are provisional**: the paper profile runs {_span(ref)} "
                 f"{unit} per case (`make book`)"
                 + (f", and a verdict needs at least {MIN_DECIDE} (`stats.decide`, the one rule "
                    f"of every verdict): with {fewest} per case, a verdict on this page that "
                    f"reads a case's {unit} says *cannot decide*, which the paper profile's "
                    f"build decides."
                    if fewest < MIN_DECIDE else
                    ", and a CI from this few cannot decide most questions."))
    return text


#: Per search: the column whose distinct values count a case's runs (None: its rows), and
#: what they are called.
_COUNTED = {"closed_loop": ("episode", "held-out episodes"), "cem": (None, "CEM samples"),
            "random": ("loop", "loops")}


def _span(values) -> str:
    """``"50"`` for one count, ``"50-500"`` for several."""
    v = sorted(set(int(x) for x in values))
    return f"{v[0]}" if len(v) == 1 else f"{v[0]}-{v[-1]}"


def case_counts(df: pd.DataFrame) -> str:
    """How many loops, CEM samples or held-out episodes each case of an experiment's results
    ran (``df.attrs["experiment"]`` says which): ``"50 loops"``, ``"50-500 loops"``,
    ``"1 loop"``, ``"600 CEM samples"``."""
    col, unit = _COUNTED[get_experiment(df.attrs["experiment"]).search]
    n = df.groupby("case").size() if col is None else df.groupby("case")[col].nunique()
    one = {int(x) for x in n} == {1}  # "1 loop per case", not "1 loops"
    return f"{_span(n)} {unit[:-1] if one else unit}"


def fewer_loops_note(fewer: pd.DataFrame, runs: str, reading: str = "halves") -> str:
    """The claims page's sizing of a reading's count: what it runs (``runs``: "50 loops a case
    (Exp 1's long run 500)"), and how many verdicts a smaller count would have changed
    (``fewer``: :func:`uavwind.analysis.claims.verdicts_at_fewer_loops`), count by count."""
    paper = PROFILES["paper"].loops
    head = (f"*Sizing ({reading} reading):* its rows of Exps 1-7 are read only by this page's "
            f"*verdict ({reading})* column and Exp 1's side-by-side table; it runs {runs}.")
    if fewer.empty:
        return (head + " This build runs too few loops a case for a smaller count to be "
                "tried: the paper profile's build says what a cut would change.")
    parts = [f"{int(r['changed'])}" + (f" of {int(r['of'])} verdicts" if i == 0 else "")
             + f" change at {n} loops" + ("" if r["which"] == "none" else f" ({r['which']})")
             for i, (n, r) in enumerate(fewer.iterrows())]
    return (head + " Judged on each case's first loops only (the same loops: a loop's seed is "
            "its address), " + ", ".join(parts[:-1]) + (" and " if len(parts) > 1 else "")
            + parts[-1] + f". The count stays at the paper's {paper}: these rows are set "
            f"against the paper's Tables, whose maxima are over {paper} loops, and a maximum "
            "over fewer loops is biased low.")


def sizing_note(df: pd.DataFrame, sizing: Sizing | None = None) -> str:
    """A sentence for a page: the question its verdicts decide and the 95% CI half-width it
    needs, how the paper profile's count was chosen from it (:data:`~uavwind.study.sizing.SIZINGS`:
    the spread measured in a paper build, the loops that spread needs, the floor), and the
    same computation on ``df`` itself: one loop's spread here (the most variable group), the
    loops that needs, the loops run and the half-width they give, and whether they suffice.

    ``sizing`` defaults to the record of ``df.attrs["experiment"]``."""
    if sizing is None:
        exp_id = df.attrs.get("experiment")
        if exp_id not in SIZINGS:
            raise ValueError(f"sizing_note: no sizing for experiment {exp_id!r} (sized: "
                             f"{sorted(SIZINGS)}); pass sizing=")
        sizing = SIZINGS[exp_id]
    s = check_instance(sizing, "sizing", Sizing)
    if s.last_time:
        df = df[df["time"] == df["time"].max()]
    unit = ("episodes" if get_experiment(s.experiment).search == "closed_loop" else "loops")
    one = unit[:-1]
    if s.compared:
        sd, n_run = paired_spread(df, s)
        what = (f"one {one}'s paired difference (the best case against its runner-up and "
                f"against the reference)")
    else:
        g = df.groupby(list(s.by))[s.value]
        sd = float((g.std(ddof=1) * s.scale).max())
        n_run = int(g.size().min())
        what = f"one {one}'s value"
    need = loops_needed(sd, s.halfwidth) if np.isfinite(sd) else None
    got = ci_halfwidth(sd, n_run)
    chosen = (f"{s.needed}" if s.count == s.needed else
              f"{s.needed}, fewer than the {s.floor} it runs at the least ({s.floor_reason})")
    text = (f"*Sizing.* {s.question} needs 95% CIs of about +-{s.halfwidth:g} {s.unit}"
            f"{' on that difference' if s.compared else ''}. The "
            f"paper profile runs **{s.count} {unit} per case**, chosen from that: {what} "
            f"varied with a standard deviation of up to {s.sd:.1f} {s.unit} in the paper "
            f"build at {s.measured_at} ({s.measured_with} {unit} per case), which takes "
            f"{chosen}.")
    if need is None:
        return text + (f" This build ran {n_run} {one if n_run == 1 else unit} per case: too "
                       "few to measure a spread.")
    verdict = ("enough" if n_run >= need else
               "too few to decide differences of that size; a verdict whose CI spans both "
               "answers cannot decide")
    return text + (f" In this build {what} varies by up to {sd:.1f} {s.unit}, "
                   f"which takes {need}; it ran {n_run} (+-{got:.1f} {s.unit}): {verdict}.")


def paired_spread(df: pd.DataFrame, sizing: Sizing) -> tuple[float, int]:
    """The spread a loop-by-loop question (``sizing.compared``) is sized on, measured on
    ``df``: in every ``sizing.by`` group, the standard deviation over loops of the
    difference between the case with the highest mean and its runner-up, and between it and
    ``sizing.reference`` (where run); the largest of them [``sizing.unit``], and the fewest
    loops any of those differences has (NaN and that count when below 2)."""
    s = check_instance(sizing, "sizing", Sizing)
    if not s.compared:
        raise ValueError(f"sizing {s.experiment!r} compares no cases loop by loop "
                         "(its compared is empty)")
    cols = list(s.compared)
    refs = {"reference": tuple(s.reference)} if s.reference else None
    sds, ns = [], []
    for _, g in df.groupby(list(s.by), sort=False):
        sub = g.groupby(cols, sort=False)[s.value].mean().rename("mean").reset_index()
        best, _, diffs = loop_differences(sub, g, s.compared, refs, value=s.value)
        for label, d in diffs.items():
            if label == "reference" and tuple(best[c] for c in cols) == tuple(s.reference):
                continue  # the best is the reference itself
            sds.append(float(d.std(ddof=1)) * s.scale if d.size > 1 else float("nan"))
            ns.append(int(d.size))
    if not ns:
        raise ValueError(f"no two cases of {s.experiment!r} share a {s.by} group to compare")
    n = min(ns)
    return (max(sds) if n > 1 else float("nan")), n


#: The benchmark's record, relative to the repository (written by ``make bench``).
RECORDS_FILE = "benchmarks/benchmark.json"


def source_commit(mark_changes: bool = False) -> str:
    """The short commit id of the checkout uavwind runs from (``"unknown"`` outside a git
    checkout); with ``mark_changes``, ``"+changes"`` appended when tracked files differ
    from that commit (for figures measured from a working tree), the benchmark's own
    record (:data:`RECORDS_FILE`, which every section rewrites) aside: a second section
    of one ``make bench`` is still of the commit."""
    import subprocess

    def git(*args):
        return subprocess.run(["git", *args], capture_output=True, text=True,
                              cwd=Path(__file__).resolve().parent, timeout=5).stdout.strip()

    try:
        head = git("rev-parse", "--short", "HEAD") or "unknown"
        changed = [line for line in git("status", "--porcelain",
                                         "--untracked-files=no").splitlines()
                   if line.split(None, 1)[-1] != RECORDS_FILE] if mark_changes else []
        if head != "unknown" and changed:
            head += "+changes"
        return head
    except (OSError, subprocess.SubprocessError):
        return "unknown"

