"""The paper's claims, tested on the replication's results with uncertainty.

This module owns the statistics of the *Claims* page: bootstrap confidence
intervals over loops (:func:`bootstrap_ci`), paired comparisons between cases
that flew the same thrust sequences (:func:`paired_difference`), and one
function per claim C1-C8 that returns a :class:`Verdict` (reproduced / partly /
not reproduced) with the numbers behind it. Every threshold a verdict uses is
written in the claim's ``rule`` so a reader can disagree with it.

Every comparison a claim reads is decided by the one rule,
:func:`uavwind.core.stats.decide`: a claim is *reproduced*, *partly* or *not reproduced* only
from comparisons that rule decides, so a build of fewer than
:data:`~uavwind.core.stats.MIN_DECIDE` loops a case says *cannot decide* and why, and every
interval in the evidence is written by :func:`~uavwind.core.stats.interval_label`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..core.stats import (MIN_DECIDE, UNDECIDED, bootstrap_ci, correct_share, decide,
                          difference_ci, interval_label, paired_difference)
from ..study.registry import EXPERIMENTS
from .beyond import breaking_level, noise_table

__all__ = ["bootstrap_ci", "paired_difference", "Verdict", "CLAIMS", "evaluate_claims",
           "LESSONS", "compare_readings", "needed_experiments", "c1_by_vehicle", "first_loops",
           "verdicts_at_fewer_loops", "FEWER_LOOPS", "LONG_RUN_FACTOR"]

def _fmt(ci, n):
    """An estimate and its interval over ``n`` loops, as :func:`interval_label` writes it."""
    return interval_label(*ci, n)


def _decide(ci, n, **words):
    """The one rule (:func:`decide`) on ``ci`` = (estimate, low, high) over ``n`` loops."""
    return decide(*ci, n, **words)


def _too_few(decisions) -> str:
    """The reason a claim cannot decide when its loops are too few ('' when they are not)."""
    few = [d for d in decisions if d.too_few]
    return (f"; too few loops to decide: {few[0].reason} (the paper profile's build, "
            "`make book`, runs enough)" if few else "")


#: Fewer loops than this per condition: no claim decides (the one rule's minimum,
#: :data:`uavwind.core.stats.MIN_DECIDE`); a maximum over a tenth of the loops needs a
#: tenth of this size too.
MIN_CLAIM_LOOPS = MIN_DECIDE


@dataclass
class Verdict:
    """A claim, the rule that judges it, the evidence and the verdict."""

    claim: str
    statement: str
    rule: str
    evidence: str
    verdict: str  # "reproduced", "partly", "not reproduced", "cannot decide", "not run"

    def to_dict(self) -> dict[str, str]:
        return {"claim": self.claim, "statement": self.statement, "verdict": self.verdict,
                "evidence": self.evidence, "rule": self.rule}


def _scores(df, **where):
    sub = df
    for k, v in where.items():
        sub = sub.loc[sub[k] == v]
    return sub.sort_values("loop")["score"].to_numpy()


def _by_id(df, scenario_id, long_run=False):
    if "long_run" in df.columns:
        return _scores(df, scenario_id=scenario_id, long_run=long_run)
    return _scores(df, scenario_id=scenario_id)


def claim_c1(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp1"]
    d = df[~df["long_run"]] if "long_run" in df.columns else df
    means = d.groupby("scenario_id")["score"].mean()
    lowest = set(means.nsmallest(2).index)
    others = [k for k in means.index if k not in (1, 4)]
    worst_other = means[others].idxmin()
    n = {k: min(_by_id(df, k).size, _by_id(df, worst_other).size) for k in (1, 4)}
    diffs = {k: paired_difference(_by_id(df, k), _by_id(df, worst_other)) for k in (1, 4)}
    dec = {k: _decide(diffs[k], n[k]) for k in (1, 4)}
    below = [dec[k].word == "lower" for k in (1, 4)]
    above = [dec[k].word == "higher" for k in (1, 4)]  # decidedly above the lowest other
    verdict = ("reproduced" if lowest == {1, 4} and all(below)
               else "partly" if any(below)
               else "not reproduced" if all(above) else UNDECIDED)
    if means[1] == 0 and means[4] == 0:  # no loop separated them: "lowest" says nothing
        verdict = UNDECIDED
    ev = ("means by scenario: " + ", ".join(f"S{k} {m:.1f}" for k, m in means.items())
          + f"; paired difference vs the lowest other scenario (S{worst_other}): "
          + ", ".join(f"S{k} {_fmt(diffs[k], n[k])}" for k in (1, 4))
          + _too_few(dec.values()))
    return Verdict("C1", "Light-vs-light cases (scenarios 1 and 4) score lowest in Exp 1.",
                   "reproduced: S1 and S4 have the two lowest means and both paired differences "
                   "to the lowest other scenario have 95% CIs below 0; partly: one of the two "
                   "differences has; not reproduced: both differences' CIs lie above 0; cannot "
                   "decide: otherwise, with fewer than 5 loops a scenario, or when S1 and S4 "
                   "both score 0 on every loop (the method separates neither, so being lowest "
                   "is no finding)", ev,
                   verdict)


def c1_by_vehicle(exp10: pd.DataFrame) -> pd.DataFrame:
    """Claim C1 judged on each vehicle of Exp 10, with and without noise (its Table 2
    scenarios; the worked example left out), with the rule of :func:`claim_c1`: one row per
    vehicle and noise with ``verdict`` and ``evidence``."""
    rows = []
    keys = [k for k in ("vehicle", "noise") if k in exp10.columns]
    for key, sub in exp10[exp10["scenario_id"] > 0].groupby(keys, sort=False):
        v = claim_c1({"exp1": sub})
        key = key if isinstance(key, tuple) else (key,)
        rows.append({**dict(zip(keys, key)), "verdict": v.verdict, "evidence": v.evidence})
    return pd.DataFrame(rows).set_index(keys)


def claim_c2(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp1"]
    s7 = _by_id(df, 7)
    want = {2: "lower", 3: "lower", 5: "lower", 6: "lower", 1: "higher", 4: "higher"}
    n = {k: min(s7.size, _by_id(df, k).size) for k in want}
    cis = {k: paired_difference(s7, _by_id(df, k)) for k in want}
    dec = {k: _decide(cis[k], n[k]) for k in want}
    right = [dec[k].word == w for k, w in want.items()]
    wrong = [dec[k].decided and dec[k].word != w for k, w in want.items()]
    verdict = ("reproduced" if all(right) else "not reproduced" if any(wrong)
               else "partly" if any(right) else UNDECIDED)
    ev = ("S7 minus each scenario, paired mean [95% CI]: "
          + ", ".join(f"S{k} {_fmt(cis[k], n[k])}" for k in want) + _too_few(dec.values()))
    return Verdict("C2", "Light constant vs strong turbulence scores below the strong "
                   "constant/shear cases but above light-vs-light.",
                   "reproduced: S7 minus each of S2, S3, S5, S6 has a CI below 0 and minus S1, S4 "
                   "a CI above 0; partly: some of them do and none lies on the wrong side of 0; "
                   "not reproduced: some CI lies on the wrong side of 0; cannot decide: no CI "
                   "excludes 0, or fewer than 5 loops a scenario", ev, verdict)


def claim_c3(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp1"]
    long = _by_id(df, 1, long_run=True)
    short = long[:min(50, max(1, long.size // 10))]
    gain = long.max() - short.max()
    verdict = ("cannot decide" if short.size < MIN_CLAIM_LOOPS else "reproduced" if gain <= 1.0
               else "partly" if gain <= 3.0 else "not reproduced")
    first = "the first loop" if short.size == 1 else f"the first {short.size} loops"
    rows = df[df["long_run"]] if "long_run" in df.columns else df.iloc[:0]
    per = len(rows["labels"].iloc[0]) // 2 if "labels" in rows.columns and len(rows) else 0
    size = (f" of the long run ({per} environments a group"
            + (", not the five of Exp 1's other rows)" if per != 5 else ")") if per else "")
    ev = (f"max of {first}{size} {short.max():.2f}; max of all {long.size} loops "
          f"{long.max():.2f} (gain {gain:.2f}); mean {_fmt(bootstrap_ci(long), long.size)}")
    return Verdict("C3", "Running 500 loops instead of 50 does not raise the light-vs-light "
                   "maximum.", "reproduced: the maximum over all loops exceeds the maximum over "
                   "the first tenth by at most 1 score point; partly: by at most 3; cannot "
                   f"decide: the first tenth is fewer than {MIN_CLAIM_LOOPS} loops (two maxima of "
                   "a handful of loops, no interval)", ev, verdict)


def _sweep_claim(df, x, lo, hi):
    """Per scenario, the paired difference of ``x == lo`` minus ``x == hi`` and its loops."""
    out = {}
    for k in sorted(df["scenario_id"].unique()):
        sub = df[df["scenario_id"] == k]
        a, b = _scores(sub, **{x: lo}), _scores(sub, **{x: hi})
        out[k] = (paired_difference(a, b), min(a.size, b.size))
    return out


def _tally(decisions, wanted):
    """reproduced / partly / not reproduced / cannot decide from ``decisions`` (one per
    scenario) whose wanted word is ``wanted``: all, some, none of the decided (with every
    one decided), else cannot decide."""
    hit = [d.word == wanted for d in decisions]
    if all(hit):
        return "reproduced"
    if any(hit):
        return "partly"
    return "not reproduced" if all(d.decided for d in decisions) else UNDECIDED


def claim_c4(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp2"]
    d = _sweep_claim(df, "n_env", 6, 20)
    dec = [_decide(c, n) for c, n in d.values()]
    verdict = _tally(dec, "higher")
    ev = ("mean(6 env) - mean(20 env): "
          + ", ".join(f"S{k} {_fmt(c, n)}" for k, (c, n) in d.items()) + _too_few(dec))
    return Verdict("C4", "More separated speed ranges score higher (Exp 2).",
                   "reproduced: for every scenario the paired difference 6 env (widest gap) "
                   "minus 20 env has a CI above 0; partly: for some; not reproduced: for none, "
                   "every CI excluding 0 (or inside it for a tie); cannot decide: otherwise, or "
                   "fewer than 5 loops a case", ev, verdict)


def claim_c5(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp3"]
    d = _sweep_claim(df, "n_env", 20, 6)
    late = _sweep_claim(df, "n_env", 20, 16)
    more = [_decide(c, n) for c, n in d.values()]
    # a plateau: the change from 16 to 20 env decidedly within a quarter of the gain 6 -> 20
    plat = [_decide(late[k][0], late[k][1], margin=0.25 * d[k][0][0], within="plateau")
            if d[k][0][0] > 0 else _decide(late[k][0], late[k][1]) for k in d]
    verdict = _tally(more, "higher")
    if verdict == "reproduced" and not all(p.word == "plateau" for p in plat):
        verdict = "partly"
    ev = ("mean(20 env) - mean(6 env): "
          + ", ".join(f"S{k} {_fmt(c, n)}" for k, (c, n) in d.items())
          + "; change 16->20 env (paired) vs gain 6->20 env: "
          + ", ".join(f"S{k} {_fmt(late[k][0], late[k][1])}/{d[k][0][0]:.1f}" for k in d)
          + _too_few(more))
    return Verdict("C5", "More environments score higher, plateauing near 15-20 environments "
                   "(Exp 3).", "reproduced: every scenario's paired difference 20 minus 6 env "
                   "has a CI above 0 and the paired change from 16 to 20 env, up or down, has "
                   "a CI within a quarter of the gain from 6 to 20 (a plateau, not a fall); "
                   "partly: more environments decidedly help in some scenarios; not "
                   "reproduced: in none, every CI excluding 0; cannot decide: otherwise, or "
                   "fewer than 5 loops a case", ev, verdict)


def claim_c6(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp4"]
    d = _sweep_claim(df, "thrust_changes", 12, 0)
    spread = {k: np.ptp(df[df["scenario_id"] == k].groupby("thrust_changes")["score"].mean())
              for k in d}
    dec = [_decide(c, n, margin=5.0, within="no major effect") for c, n in d.values()]
    small = [dc.word == "no major effect" and spread[k] < 10 for dc, k in zip(dec, d)]
    verdict = ("reproduced" if all(small) else "partly" if any(small)
               else "not reproduced" if all(dc.decided for dc in dec) else UNDECIDED)
    ev = ("mean(12 ch) - mean(0 ch): "
          + ", ".join(f"S{k} {_fmt(c, n)}" for k, (c, n) in d.items())
          + "; range of means over 0-12 changes: "
          + ", ".join(f"S{k} {v:.1f}" for k, v in spread.items()) + _too_few(dec))
    return Verdict("C6", "The number of thrust changes has no major effect (Exp 4).",
                   "reproduced: in every scenario the paired difference mean(12) - mean(0) has a "
                   "95% CI inside +-5 points and the means over all change counts span < 10 "
                   "points; partly: in some scenarios; not reproduced: in none, every CI "
                   "decided; cannot decide: otherwise, or fewer than 5 loops a case", ev,
                   verdict)


def claim_c7(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp5"]
    same, opp = _scores(df, direction="similar"), _scores(df, direction="opposite")
    sim_rows, opp_rows = df[df["direction"] == "similar"], df[df["direction"] == "opposite"]
    rs, ro = correct_share(sim_rows), correct_share(opp_rows)
    n = min(same.size, opp.size)

    def right(rows):
        return (rows.sort_values("loop")["correct"].to_numpy(float) if "correct" in rows
                else (rows.sort_values("loop")["score"].to_numpy() > 0).astype(float))
    # fewer misclassifications: the share's difference, opposite minus similar, decided
    dec = _decide(difference_ci(right(opp_rows), right(sim_rows)), n, within="the same")
    verdict = (UNDECIDED if dec.too_few else
               "reproduced" if ro == 1.0 and rs < 1.0 else
               "partly" if dec.word == "higher" else
               "not reproduced" if dec.decided else UNDECIDED)
    # the difference in the shares' own format (whole percentage points), not in brackets
    # inside a bracket ("(difference 50.00 points (2 loops, no interval))")
    ev = (f"correctly grouped loops: similar {100 * rs:.0f}%, opposite {100 * ro:.0f}%, a "
          f"difference of "
          f"{interval_label(dec.estimate, dec.low, dec.high, n, 0, 100, suffix=' points')}; "
          f"mean score similar {_fmt(bootstrap_ci(same), same.size)}, opposite "
          f"{_fmt(bootstrap_ci(opp), opp.size)}" + _too_few([dec]))
    return Verdict("C7", "Opposite wind directions remove the misclassifications (Exp 5).",
                   "reproduced: every opposite-direction loop is grouped correctly while some "
                   "similar-direction loops are not; partly: fewer misclassifications (the 95% "
                   "CI of the difference in shares above 0); not reproduced: that CI decided "
                   f"otherwise; cannot decide: it spans 0, or fewer than {MIN_CLAIM_LOOPS} loops "
                   "a direction", ev, verdict)


def claim_c8(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df6, df5 = r["exp6"], r["exp5"]
    rand = _scores(df5, direction="similar")
    g = df6.groupby("iteration")["score"]
    best = g.max().cummax()
    final = best.iloc[-1]
    reached = int(best.index[np.argmax(best.to_numpy() >= final - 1.0)])
    beats = final > rand.max()
    last = df6[df6["iteration"] == df6["iteration"].max()]["score"].to_numpy()
    gain, lo, hi = difference_ci(last, rand)
    plateau_ok = 8 <= reached <= 16
    n_it = len(best)
    # one CEM run: its best against random search's maximum is two numbers, no interval,
    # so the verdict rests on the last iteration's population against random search's,
    # whose interval can exclude 0 (issue 44: 86.84 against 86.76 read as 'beats')
    n = min(last.size, rand.size)
    dec = _decide((gain, lo, hi), n)
    verdict = ("not reproduced" if dec.word == "lower" else
               "reproduced" if dec.word == "higher" and beats and plateau_ok else
               "partly" if dec.word == "higher" else UNDECIDED)
    ev = (f"last-iteration CEM mean minus random mean {_fmt((gain, lo, hi), n)} "
          f"({last.size} and {rand.size} loops, Exp 5 similar direction); one CEM run's best "
          f"{final:.2f} vs random-search max {rand.max():.2f} (single values, no interval); "
          f"best within 1 point of its final value from iteration {reached} of {n_it}"
          + _too_few([dec]))
    return Verdict("C8", "CEM beats random search and plateaus after about 12 iterations "
                   "(Exp 6).", "reproduced: the last CEM iteration's mean score exceeds random "
                   "search's (95% CI of the difference above 0), its best exceeds the random "
                   "maximum and is within 1 point of final from an iteration in 8-16; partly: "
                   "the mean difference's CI above 0 alone; not reproduced: below 0; cannot "
                   "decide: the CI contains 0, or fewer than 5 loops", ev, verdict)


def claim_c9(r: Mapping[str, pd.DataFrame]) -> Verdict:
    """Sub-metre accuracy is every noise condition under 1 m: white noise and bias alike (a
    0.5 m bias is sub-metre accuracy too; the verdict read white noise only, issue 44).
    A condition works when its 95% CI of the correctly grouped share lies at or above 90%,
    fails when it lies below."""
    df = r["exp7"]
    t = noise_table(df)
    sub = t[(t["noise_bias"] < 1.0) & (t["noise_sigma"] < 1.0)]
    dec = [decide(r.correct_rate, r.correct_low, r.correct_high, int(r.n_loops), threshold=0.9,
                  above="works", below="fails") for r in sub.itertuples()]
    word = pd.Series([d.word for d in dec], index=sub.index)
    by = word.groupby(sub["scenario"], sort=False)
    works = by.agg(lambda w: (w == "works").all())   # every condition's CI above 90%
    fails = by.agg(lambda w: (w == "fails").any())   # some condition's CI below 90%
    brk = breaking_level(df)
    if works.all():
        verdict = "reproduced"
    elif fails.all():
        verdict = "not reproduced"
    elif fails.any() and (works | fails).all():
        verdict = "partly"
    else:
        verdict = "cannot decide"
    worst = sub.loc[sub.groupby("scenario", sort=False)["correct_rate"].idxmin()]
    ev = ("lowest share of correctly grouped loops below 1 m of noise (white noise or bias) "
          "[95% CI]: "
          + ", ".join(f"{row.scenario} "
                      f"{interval_label(row.correct_rate, row.correct_low, row.correct_high, int(row.n_loops), 0, 100, suffix='%')} "
                      f"(sigma {row.noise_sigma:g} m, bias {row.noise_bias:g} m)"
                      for row in worst.itertuples())
          + "; under white noise alone, correct grouping first below 50% at: "
          + ", ".join(f"{s} {'beyond ' + format(row.last_ok, 'g') if np.isnan(row.first_broken) else format(row.first_broken, 'g')} m"
                      for s, row in brk.iterrows())
          + _too_few(dec))
    return Verdict("C9", "The method works with sub-metre position accuracy (Exp 7, beyond the "
                   "paper's experiments).", "reproduced: in every scenario, at every white-noise "
                   "and bias level below 1 m, the 95% CI of the correctly grouped share lies "
                   "above 90%; partly: in some scenarios, the others' CI below; not "
                   "reproduced: below in every scenario; cannot decide: a CI straddles 90%, or "
                   "fewer than 5 loops a condition",
                   ev, verdict)


#: Claim id -> (experiments it needs, function).
CLAIMS = {"C1": (("exp1",), claim_c1), "C2": (("exp1",), claim_c2), "C3": (("exp1",), claim_c3),
          "C4": (("exp2",), claim_c4), "C5": (("exp3",), claim_c5), "C6": (("exp4",), claim_c6),
          "C7": (("exp5",), claim_c7), "C8": (("exp5", "exp6"), claim_c8),
          "C9": (("exp7",), claim_c9)}


#: What the difference between the two readings teaches, claim by claim (no numbers:
#: those come from the verdicts' evidence).
LESSONS = {
    "C1": "Under eqs 2-8 constant-wind separability is a matter of layout geometry, not of "
          "wind strength: the silhouette of a constant layout's speeds is unchanged when they are "
          "scaled by 10 (a test), while the loops' scores, through soft-DTW's fixed gamma, "
          "move by some points (the inference page's scale check measures how far), and "
          "shear behaves the same way for a pair of one kind. Light pairs score lowest only "
          "where their groups sit closer together, so under the inferred reading the claim "
          "holds by construction of the fit, not as an independent finding.",
    "C2": "The verdict depends on what 'strong turbulence' means: zero-mean gusts "
          "(MIL-F-8785C) leave the turbulent group among the light winds, where loops can "
          "misgroup; a strong base wind with the cited code's gusts carries the group away "
          "from them.",
    "C3": "Under eqs 2-8 a constant pair's score is mostly its layout's geometry, so more "
          "loops of random thrusts can raise the maximum only by finding the rare thrust that "
          "moves the groups apart; how much they did is the evidence's gain, per reading.",
    "C4": "Removing the closest environments widens the gap in both readings, so the trend "
          "survives; the level depends on where the groups start.",
    "C5": "With adjacent halves the median-removal keeps the groups touching; with a gap the "
          "score falls as environments go, as the paper reports.",
    "C6": "The differences between a pair's trajectories depend on the thrust only through "
          "the heights it reaches (shear) or not at all (constant wind), but soft-DTW aligns "
          "whole paths, so the still-air path the thrust draws can still move the score where "
          "the groups touch (halves); the evidence says by how much, per reading.",
    "C7": "Reversing one group's wind turns a gap of a few spacings into one of the whole "
          "speed range: separation follows geometry again.",
    "C9": "Noise acts on the gap between the groups' drifts: pairs whose winds differ by a "
          "few tenths of a m/s drift apart by a few metres in 12 s, so metre-level noise "
          "hides them, whatever the layout reading; the strong-vs-light example tolerates far more.",
    "C8": "CEM needs a signal: with the floored score, a population in which no loop groups "
          "correctly scores 0 everywhere and the elites are arbitrary; the raw-silhouette "
          "objective (exp6_raw) keeps ordering the draws.",
}


def needed_experiments() -> list[str]:
    """The experiment ids the claims read (each claim says what it needs), in registry order."""
    need = {e for needs, _ in CLAIMS.values() for e in needs}
    unknown = need - set(EXPERIMENTS)
    if unknown:  # pragma: no cover - a claim naming an experiment the registry lacks
        raise ValueError(f"claims need unknown experiments {sorted(unknown)}")
    return [e for e in EXPERIMENTS if e in need]


def compare_readings(by_reading: Mapping[str, Mapping[str, pd.DataFrame]]) -> pd.DataFrame:
    """Verdicts side by side: ``by_reading`` maps a reading name to its results dict
    (experiment id -> table). Columns ``verdict (<reading>)``, ``evidence (<reading>)``
    per reading, the statement and :data:`LESSONS`."""
    frames = {name: evaluate_claims(res) for name, res in by_reading.items()}
    first = next(iter(frames.values()))
    out = pd.DataFrame({"statement": first["statement"]})
    for name, v in frames.items():
        out[f"verdict ({name})"] = v["verdict"]
    for name, v in frames.items():
        out[f"evidence ({name})"] = v["evidence"]
    out["lesson"] = [LESSONS.get(c, "") for c in out.index]
    out["rule"] = first["rule"]
    return out


def evaluate_claims(results: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """All verdicts as a DataFrame; ``results`` maps experiment id -> its result table."""
    rows = []
    for cid, (needs, fn) in CLAIMS.items():
        if all(k in results for k in needs):
            rows.append(fn(results).to_dict())
        else:
            rows.append({"claim": cid, "statement": "", "verdict": "not run",
                         "evidence": f"needs {', '.join(needs)}", "rule": ""})
    return pd.DataFrame(rows).set_index("claim")


#: The counts a case is cut to by :func:`verdicts_at_fewer_loops` (the paper's 50 and below).
FEWER_LOOPS = (30, 25, 20)
#: Exp 1's long run flies this many times a case's loops at the paper profile (500 against
#: 50); :func:`verdicts_at_fewer_loops` reads the factor off the results it is given.
LONG_RUN_FACTOR = 10


def first_loops(results: Mapping[str, pd.DataFrame], n: int,
                long_run_factor: int = LONG_RUN_FACTOR) -> dict[str, pd.DataFrame]:
    """Every table with a ``loop`` column cut to its cases' first ``n`` loops (Exp 1's long
    run to its first ``long_run_factor * n``), as a build running ``n`` loops a case would
    have scored them: a loop's seed is its address, so its result does not depend on how many
    others ran. Tables without loops (Exp 6's CEM samples) are kept whole."""
    for name, v in (("n", n), ("long_run_factor", long_run_factor)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise ValueError(f"{name} must be an integer >= 1, got {v!r}")
    return {k: df.loc[df["loop"].to_numpy() < np.where(_long_run(df), long_run_factor * n, n)]
            if "loop" in df.columns else df for k, df in results.items()}


def _long_run(df: pd.DataFrame) -> np.ndarray:
    """Which rows are Exp 1's long run (none, in a table without the column)."""
    return (df["long_run"].to_numpy(bool) if "long_run" in df.columns
            else np.zeros(len(df), bool))


def verdicts_at_fewer_loops(results: Mapping[str, pd.DataFrame],
                            counts=FEWER_LOOPS) -> pd.DataFrame:
    """What a smaller count would have decided: the verdicts of :func:`evaluate_claims` on
    :func:`first_loops` of ``results`` for each count, against the verdicts on all of them.
    One row per count: ``loops a case``, ``changed`` (how many of the claims' verdicts
    differ) and ``which`` (``"C5: partly -> reproduced; ..."`` or ``"none"``); counts at or
    above the most loops any case ran are left out (no rows on a quick build)."""
    full = evaluate_claims(results)["verdict"]
    rows = []
    plain, long = 0, 0  # the most loops a case ran, and Exp 1's long run
    for df in results.values():
        if "loop" in df.columns and len(df):
            lr, loops = _long_run(df), df["loop"].to_numpy()
            plain = max(plain, int(loops[~lr].max()) + 1 if (~lr).any() else 0)
            long = max(long, int(loops[lr].max()) + 1 if lr.any() else 0)
    factor = max(1, round(long / plain)) if plain and long else LONG_RUN_FACTOR
    for n in (c for c in counts if c < plain):  # a cut that keeps every loop decides nothing
        cut = evaluate_claims(first_loops(results, n, factor))["verdict"]
        changed = [f"{c}: {full[c]} -> {cut[c]}" for c in full.index if cut[c] != full[c]]
        rows.append({"loops a case": int(n), "long run": factor * int(n),
                     "changed": len(changed), "of": len(full),
                     "which": "; ".join(changed) or "none"})
    return pd.DataFrame(rows, columns=["loops a case", "long run", "changed", "of", "which"]
                        ).set_index("loops a case")
