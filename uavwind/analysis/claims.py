"""The paper's claims, tested on the replication's results with uncertainty.

This module owns the statistics of the *Claims* page: bootstrap confidence
intervals over loops (:func:`bootstrap_ci`), paired comparisons between cases
that flew the same thrust sequences (:func:`paired_difference`), and one
function per claim C1-C8 that returns a :class:`Verdict` (reproduced / partly /
not reproduced) with the numbers behind it. Every threshold a verdict uses is
written in the claim's ``rule`` so a reader can disagree with it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..core.stats import bootstrap_ci, correct_share, difference_ci, paired_difference
from ..study.registry import EXPERIMENTS
from .beyond import breaking_level, noise_table
from .manoeuvres import MIN_VERDICT_LOOPS

__all__ = ["bootstrap_ci", "paired_difference", "Verdict", "CLAIMS", "evaluate_claims",
           "LESSONS", "compare_readings", "needed_experiments", "c1_by_vehicle", "first_loops",
           "verdicts_at_fewer_loops", "FEWER_LOOPS", "LONG_RUN_FACTOR"]

def _fmt(ci):
    # round(., 2) + 0.0: never "-0.00" (a bias of -1e-17 is none), as display.signed does
    est, lo, hi = (round(float(v), 2) + 0.0 for v in ci)
    return f"{est:.2f} [{lo:.2f}, {hi:.2f}]"


#: Fewer loops than this per condition: a claim read off shares or maxima cannot decide, for
#: the reason Exp 14's verdicts need them (:data:`.manoeuvres.MIN_VERDICT_LOOPS`); a maximum
#: over a tenth of the loops needs a tenth of some size too.
MIN_CLAIM_LOOPS = MIN_VERDICT_LOOPS


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


def _excludes(ci, sign):
    return ci[1] > 0 if sign > 0 else ci[2] < 0


def claim_c1(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp1"]
    d = df[~df["long_run"]] if "long_run" in df.columns else df
    means = d.groupby("scenario_id")["score"].mean()
    lowest = set(means.nsmallest(2).index)
    others = [k for k in means.index if k not in (1, 4)]
    worst_other = means[others].idxmin()
    diffs = {k: paired_difference(_by_id(df, k), _by_id(df, worst_other)) for k in (1, 4)}
    ok = [_excludes(diffs[k], -1) for k in (1, 4)]
    above = [_excludes(diffs[k], +1) for k in (1, 4)]  # decidedly above the lowest other
    verdict = ("reproduced" if lowest == {1, 4} and all(ok)
               else "partly" if lowest & {1, 4}
               else "not reproduced" if all(above) else "cannot decide")
    if means[1] == 0 and means[4] == 0:  # no loop separated them: "lowest" says nothing
        verdict = "cannot decide"
    ev = ("means by scenario: " + ", ".join(f"S{k} {m:.1f}" for k, m in means.items())
          + f"; paired difference vs the lowest other scenario (S{worst_other}): "
          + ", ".join(f"S{k} {_fmt(diffs[k])}" for k in (1, 4)))
    return Verdict("C1", "Light-vs-light cases (scenarios 1 and 4) score lowest in Exp 1.",
                   "reproduced: S1 and S4 have the two lowest means and both paired differences "
                   "to the lowest other scenario have 95% CIs below 0; partly: one of them is "
                   "among the two lowest; not reproduced: neither is, and both differences' CIs "
                   "lie above 0; cannot decide: otherwise, or S1 and S4 both score 0 on every "
                   "loop (the method separates neither, so being lowest is no finding)", ev,
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
    below = {k: paired_difference(s7, _by_id(df, k)) for k in (2, 3, 5, 6)}
    above = {k: paired_difference(s7, _by_id(df, k)) for k in (1, 4)}
    strict = all(_excludes(c, -1) for c in below.values()) and all(
        _excludes(c, +1) for c in above.values())
    direction = all(c[0] < 0 for c in below.values()) and all(c[0] > 0 for c in above.values())
    wrong = any(_excludes(c, +1) for c in below.values()) or any(
        _excludes(c, -1) for c in above.values())  # some CI on the wrong side of 0
    verdict = ("reproduced" if strict else "partly" if direction or (
        all(c[0] > 0 for c in above.values())) else "not reproduced" if wrong
        else "cannot decide")
    ev = ("S7 minus each scenario, paired mean and 95% CI: "
          + ", ".join(f"S{k} {_fmt(c)}" for k, c in {**below, **above}.items()))
    return Verdict("C2", "Light constant vs strong turbulence scores below the strong "
                   "constant/shear cases but above light-vs-light.",
                   "reproduced: S7 minus each of S2, S3, S5, S6 has a CI below 0 and minus S1, S4 "
                   "a CI above 0; partly: S7 is above both light-vs-light cases or all signs "
                   "agree without every CI excluding 0; not reproduced: some CI lies on the "
                   "wrong side of 0; cannot decide: otherwise", ev, verdict)


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
          f"{long.max():.2f} (gain {gain:.2f}); mean {_fmt(bootstrap_ci(long))}")
    return Verdict("C3", "Running 500 loops instead of 50 does not raise the light-vs-light "
                   "maximum.", "reproduced: the maximum over all loops exceeds the maximum over "
                   "the first tenth by at most 1 score point; partly: by at most 3; cannot "
                   f"decide: the first tenth is fewer than {MIN_CLAIM_LOOPS} loops (two maxima of "
                   "a handful of loops, no interval)", ev, verdict)


def _sweep_claim(df, x, lo, hi):
    out = {}
    for k in sorted(df["scenario_id"].unique()):
        sub = df[df["scenario_id"] == k]
        out[k] = paired_difference(_scores(sub, **{x: lo}), _scores(sub, **{x: hi}))
    return out


def claim_c4(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp2"]
    d = _sweep_claim(df, "n_env", 6, 20)
    pos = [_excludes(c, +1) for c in d.values()]
    verdict = "reproduced" if all(pos) else "partly" if any(pos) else "not reproduced"
    ev = "mean(6 env) - mean(20 env): " + ", ".join(f"S{k} {_fmt(c)}" for k, c in d.items())
    return Verdict("C4", "More separated speed ranges score higher (Exp 2).",
                   "reproduced: for every scenario the paired difference 6 env (widest gap) "
                   "minus 20 env has a CI above 0; partly: for some", ev, verdict)


def claim_c5(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp3"]
    d = _sweep_claim(df, "n_env", 20, 6)
    more = [_excludes(c, +1) for c in d.values()]
    plateau = {}
    for k in sorted(df["scenario_id"].unique()):
        m = df[df["scenario_id"] == k].groupby("n_env")["score"].mean()
        total = m.loc[20] - m.loc[6]
        late = m.loc[20] - m.loc[16]
        plateau[k] = (late, total)
    plat = [abs(late) <= 0.25 * abs(total) if total > 0 else False
            for late, total in plateau.values()]
    verdict = ("reproduced" if all(more) and all(plat) else
               "partly" if any(more) else "not reproduced")
    ev = ("mean(20 env) - mean(6 env): " + ", ".join(f"S{k} {_fmt(c)}" for k, c in d.items())
          + "; change 16->20 env vs gain 6->20 env: "
          + ", ".join(f"S{k} {a:.1f}/{b:.1f}" for k, (a, b) in plateau.items()))
    return Verdict("C5", "More environments score higher, plateauing near 15-20 environments "
                   "(Exp 3).", "reproduced: every scenario's paired difference 20 minus 6 env "
                   "has a CI above 0 and the change from 16 to 20 env, up or down, is at most a "
                   "quarter of the gain from 6 to 20 (a plateau, not a fall); partly: more environments help in some scenarios", ev,
                   verdict)


def claim_c6(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp4"]
    d = _sweep_claim(df, "thrust_changes", 12, 0)
    spread = {k: np.ptp(df[df["scenario_id"] == k].groupby("thrust_changes")["score"].mean())
              for k in d}
    small = [abs(c[0]) < 5 and spread[k] < 10 for k, c in d.items()]
    verdict = "reproduced" if all(small) else "partly" if any(small) else "not reproduced"
    ev = ("mean(12 ch) - mean(0 ch): " + ", ".join(f"S{k} {_fmt(c)}" for k, c in d.items())
          + "; range of means over 0-12 changes: "
          + ", ".join(f"S{k} {v:.1f}" for k, v in spread.items()))
    return Verdict("C6", "The number of thrust changes has no major effect (Exp 4).",
                   "reproduced: in every scenario |mean(12) - mean(0)| < 5 points and the means "
                   "over all change counts span < 10 points; partly: in some scenarios", ev,
                   verdict)


def claim_c7(r: Mapping[str, pd.DataFrame]) -> Verdict:
    df = r["exp5"]
    same, opp = _scores(df, direction="similar"), _scores(df, direction="opposite")
    rs = correct_share(df[df["direction"] == "similar"])
    ro = correct_share(df[df["direction"] == "opposite"])
    verdict = ("cannot decide" if min(same.size, opp.size) < MIN_CLAIM_LOOPS else
               "reproduced" if ro == 1.0 and rs < 1.0 else
               "partly" if ro > rs else "not reproduced")
    ev = (f"correctly grouped loops: similar {100 * rs:.0f}%, opposite {100 * ro:.0f}%; "
          f"mean score similar {_fmt(bootstrap_ci(same))}, opposite {_fmt(bootstrap_ci(opp))}")
    return Verdict("C7", "Opposite wind directions remove the misclassifications (Exp 5).",
                   "reproduced: every opposite-direction loop is grouped correctly while some "
                   "similar-direction loops are not; partly: fewer misclassifications; cannot "
                   f"decide: fewer than {MIN_CLAIM_LOOPS} loops a direction", ev, verdict)


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
    verdict = ("cannot decide" if lo <= 0 <= hi or last.size < 2 else
               "not reproduced" if hi < 0 else
               "reproduced" if beats and plateau_ok else "partly")
    ev = (f"last-iteration CEM mean minus random mean {gain:.2f} [{lo:.2f}, {hi:.2f}] "
          f"({last.size} and {rand.size} loops, Exp 5 similar direction); one CEM run's best "
          f"{final:.2f} vs random-search max {rand.max():.2f} (single values, no interval); "
          f"best within 1 point of its final value from iteration {reached} of {n_it}")
    return Verdict("C8", "CEM beats random search and plateaus after about 12 iterations "
                   "(Exp 6).", "reproduced: the last CEM iteration's mean score exceeds random "
                   "search's (95% CI of the difference above 0), its best exceeds the random "
                   "maximum and is within 1 point of final from an iteration in 8-16; partly: "
                   "the mean difference's CI above 0 alone; not reproduced: below 0; cannot "
                   "decide: the CI contains 0", ev, verdict)


def claim_c9(r: Mapping[str, pd.DataFrame]) -> Verdict:
    """Sub-metre accuracy is every noise condition under 1 m: white noise and bias alike (a
    0.5 m bias is sub-metre accuracy too; the verdict read white noise only, issue 44).
    A condition works when its 95% CI of the correctly grouped share lies at or above 90%,
    fails when it lies below."""
    df = r["exp7"]
    t = noise_table(df)
    sub = t[(t["noise_bias"] < 1.0) & (t["noise_sigma"] < 1.0)]
    by = sub.groupby("scenario", sort=False)
    works = by["correct_low"].min() >= 0.9          # every condition's CI at or above 90%
    fails = by["correct_high"].min() < 0.9          # some condition's CI below 90%
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
    ev = ("lowest share of correctly grouped loops below 1 m of noise (white noise or bias), "
          "95% CI: "
          + ", ".join(f"{row.scenario} {100 * row.correct_rate:.0f}% "
                      f"[{100 * row.correct_low:.0f}, {100 * row.correct_high:.0f}] "
                      f"(sigma {row.noise_sigma:g} m, bias {row.noise_bias:g} m)"
                      for row in worst.itertuples())
          + "; under white noise alone, correct grouping first below 50% at: "
          + ", ".join(f"{s} {'beyond ' + format(row.last_ok, 'g') if np.isnan(row.first_broken) else format(row.first_broken, 'g')} m"
                      for s, row in brk.iterrows()))
    return Verdict("C9", "The method works with sub-metre position accuracy (Exp 7, beyond the "
                   "paper's experiments).", "reproduced: in every scenario, at every white-noise "
                   "and bias level below 1 m, the 95% CI of the correctly grouped share lies at "
                   "or above 90%; partly: in some scenarios, the others' CI below; not "
                   "reproduced: below in every scenario; cannot decide: a CI straddles 90%",
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
