"""The paper's claims, judged on synthetic results."""
import numpy as np
import pandas as pd

from uavwind.analysis.claims import evaluate_claims


def _fake(exp, rows):
    return pd.DataFrame([{"experiment": exp, **r} for r in rows])


def test_claims_verdicts_on_synthetic_results():
    rng = np.random.default_rng(1)
    exp1 = []
    means = {1: 60, 2: 95, 3: 94, 4: 55, 5: 96, 6: 95, 7: 85}
    for k, m in means.items():
        exp1 += [{"scenario_id": k, "long_run": False, "loop": i, "score": m + rng.normal(0, 1)}
                 for i in range(50)]
    exp1 += [{"scenario_id": 1, "long_run": True, "loop": i, "score": 60 + rng.normal(0, 1)}
             for i in range(500)]
    sweep = lambda xkey, xs, f: [{"scenario_id": k, xkey: x, "loop": i, "score": f(x) + rng.normal(0, 1)}
                                 for k in (1, 2, 3, 4) for x in xs for i in range(50)]
    results = {
        "exp1": _fake("exp1", exp1),
        "exp2": _fake("exp2", sweep("n_env", range(6, 21, 2), lambda n: 100 - n)),
        "exp3": _fake("exp3", sweep("n_env", range(6, 21, 2), lambda n: 60 + 20 * min(n, 15) / 15)),
        "exp4": _fake("exp4", sweep("thrust_changes", [0, 2, 4, 6, 8, 10, 12], lambda n: 80)),
        "exp5": _fake("exp5", [{"direction": d, "loop": i, "score": s}
                               for d, s in (("similar", 0), ("opposite", 90)) for i in range(50)]),
        "exp6": _fake("exp6", [{"iteration": t, "loop": j, "score": min(50 + 3 * t, 86) + j,
                                "elite": j < 4} for t in range(1, 21) for j in range(30)]),
    }
    results["exp5"].loc[::2, "score"] = 40.0
    v = evaluate_claims(results)["verdict"]
    assert v.to_dict() == {**{f"C{i}": "reproduced" for i in range(1, 9)}, "C9": "not run"}
    # break C7: opposite directions misgroup as often as similar ones
    results["exp5"]["score"] = 0.0
    assert evaluate_claims(results).loc["C7", "verdict"] == "not reproduced"
    assert evaluate_claims({"exp1": results["exp1"]}).loc["C4", "verdict"] == "not run"
    # C3's evidence names the long run's group size when the rows carry their labels: the
    # long run is not the five-environment row (issue 44: 81.80 read beside 86.71)
    assert "long run" not in evaluate_claims(results).loc["C3", "evidence"]
    for per, said in ((10, "(10 environments a group, not the five of Exp 1's other rows)"),
                      (5, "(5 environments a group)")):
        e1 = results["exp1"].copy()
        e1["labels"] = [[0] * per + [1] * per] * len(e1)
        ev = evaluate_claims({**results, "exp1": e1}).loc["C3", "evidence"]
        assert f"max of the first 50 loops of the long run {said}" in ev, ev


def test_c1_cannot_decide_when_both_light_pairs_score_zero():
    """Where the method separates neither light-vs-light pair (every loop 0), "lowest" is
    trivially true: the verdict says it cannot decide rather than "reproduced"."""
    import numpy as np
    import pandas as pd

    from uavwind.analysis.claims import claim_c1
    rng = np.random.default_rng(0)
    rows = [{"scenario_id": k, "loop": i, "score": 0.0 if k in (1, 4) else float(rng.uniform(20, 80)),
             "long_run": False} for k in range(1, 8) for i in range(10)]
    assert claim_c1({"exp1": pd.DataFrame(rows)}).verdict == "cannot decide"


def _c8_inputs(cem_scores, random_scores, best_shift=0.0):
    exp5 = pd.DataFrame([{"direction": "similar", "loop": i, "score": s}
                         for i, s in enumerate(random_scores)])
    exp6 = pd.DataFrame([{"iteration": t, "loop": j, "score": s + best_shift * (t == 20)}
                         for t in range(1, 21) for j, s in enumerate(cem_scores(t))])
    return {"exp5": exp5, "exp6": exp6}


def test_c8_rests_on_the_interval_of_the_mean_difference_not_on_one_runs_best():
    """Issue 44: one CEM run's best against random search's maximum (86.84 vs 86.76) is two
    numbers; the verdict word needs the last iteration's mean against random search's to
    have a 95% CI on one side of 0 -- each branch."""
    from uavwind.analysis.claims import claim_c8
    rng = np.random.default_rng(3)
    rand = rng.normal(50, 5, 50)
    better = lambda t: rng.normal(50 + min(t, 12) * 2, 3, 30)  # plateau at 12
    v = claim_c8(_c8_inputs(better, rand))
    assert v.verdict == "reproduced" and "no interval" in v.evidence
    same = lambda t: rng.normal(50, 5, 30)
    assert claim_c8(_c8_inputs(same, rand)).verdict == "cannot decide"
    worse = lambda t: rng.normal(30, 3, 30)
    assert claim_c8(_c8_inputs(worse, rand)).verdict == "not reproduced"
    late = lambda t: rng.normal(50 + t * 2, 3, 30)  # still climbing at iteration 20
    assert claim_c8(_c8_inputs(late, rand)).verdict == "partly"


def _c9_inputs(rates):
    """Exp 7 rows: per (scenario, sigma, bias) 100 loops with the given correct share."""
    rows = []
    for (scen, sigma, bias), rate in rates.items():
        k = int(round(100 * rate))
        rows += [{"scenario": scen, "noise_sigma": sigma, "noise_bias": bias, "loop": i,
                  "score": 80.0 if i < k else 0.0, "correct": i < k} for i in range(100)]
    return {"exp7": pd.DataFrame(rows)}


def test_c9_reads_bias_below_a_metre_too_and_its_intervals():
    """Sub-metre accuracy includes a 0.5 m bias (issue 44: a pair at 72% under it read as
    'reproduced'); a condition counts when its CI lies on one side of 90% -- each branch."""
    from uavwind.analysis.claims import claim_c9
    good = {(s, sig, 0.0): 1.0 for s in ("A", "B") for sig in (0.0, 0.5, 2.0)}
    good.update({(s, 0.0, 0.5): 1.0 for s in ("A", "B")})
    assert claim_c9(_c9_inputs(good)).verdict == "reproduced"
    biased = {**good, ("B", 0.0, 0.5): 0.72}
    v = claim_c9(_c9_inputs(biased))
    assert v.verdict == "partly" and "bias 0.5 m" in v.evidence
    both = {**biased, ("A", 0.0, 0.5): 0.5}
    assert claim_c9(_c9_inputs(both)).verdict == "not reproduced"
    edge = {**good, ("B", 0.0, 0.5): 0.9}  # a CI straddling 90%
    assert claim_c9(_c9_inputs(edge)).verdict == "cannot decide"


def test_too_few_loops_or_intervals_across_zero_cannot_decide():
    """A quick build's claims (issue 44): two loops a case gave 'not reproduced' from point
    means whose intervals span 0, and C3 and C7 verdicts from a maximum of one loop and from
    shares of two; each reads 'cannot decide' now, and an interval never shows -0.00."""
    from uavwind.analysis import claims as C

    exp1 = []
    for k, pair in {1: (0.0, 50.0), 2: (90, 91), 3: (0.0, 0.0), 4: (0.0, 54.0), 5: (92, 93),
                    6: (0.0, 0.0), 7: (0.0, 0.0)}.items():
        exp1 += [{"scenario_id": k, "long_run": False, "loop": i, "score": float(v)}
                 for i, v in enumerate(pair)]
    exp1 += [{"scenario_id": 1, "long_run": True, "loop": i, "score": v}
             for i, v in enumerate([50.0, 60.0, 70.0, 80.0])]
    df = _fake("exp1", exp1)
    # S1 and S4 above the lowest others on their means, with intervals reaching 0
    assert C.claim_c1({"exp1": df}).verdict == "cannot decide"
    assert C.claim_c2({"exp1": df}).verdict == "cannot decide"
    c3 = C.claim_c3({"exp1": df})  # the first tenth of 4 loops is one loop
    assert c3.verdict == "cannot decide" and "fewer than 5 loops" in c3.rule
    exp5 = _fake("exp5", [{"direction": d, "loop": i, "score": s}
                          for d, ss in (("similar", (0.0, 80.0)), ("opposite", (90.0, 91.0)))
                          for i, s in enumerate(ss)])
    c7 = C.claim_c7({"exp5": exp5})
    assert c7.verdict == "cannot decide"
    # its difference of two shares in their own whole percentage points, not nested in
    # brackets ("(difference 50.00 points (2 loops, no interval))", issue 67)
    assert "similar 50%, opposite 100%, a difference of 50 points (2 loops, no interval);" \
        in c7.evidence, c7.evidence
    # two loops on the wrong side of every other scenario still decide nothing (issue 67:
    # a 2-loop "interval" is the range of the two loops)...
    far = df.copy()
    far.loc[(far["scenario_id"].isin([1, 4])) & ~far["long_run"], "score"] = [50.0, 51.0, 54.0, 55.0]
    v = C.claim_c1({"exp1": far})
    assert v.verdict == "cannot decide" and "fewer than the 5 a verdict needs" in v.evidence
    assert "95%" not in v.evidence.split("; too few")[0].split("scenario (")[1]
    # ...while five loops a scenario, decided on the wrong side, stand
    five = _fake("exp1", [{"scenario_id": k, "long_run": False, "loop": i,
                           "score": (50.0 if k in (1, 4) else 0.0) + i}
                          for k in range(1, 8) for i in range(5)])
    assert C.claim_c1({"exp1": five}).verdict == "not reproduced"
    assert C._fmt((-1e-17, -0.001, 0.5), 5) == "0.00 [0.00, 0.50]"
    assert C._fmt((81.39, 81.39, 81.39), 5) == "81.39 (the same on all 5 loops)"


def test_first_loops_cuts_every_case_and_the_long_run_tenfold():
    import pytest
    from uavwind.analysis.claims import first_loops
    exp1 = _fake("exp1", [{"scenario_id": k, "long_run": lr, "loop": i, "score": 1.0}
                          for k in (1, 2) for lr, n in ((False, 50), (True, 500))
                          for i in range(n)])
    exp6 = _fake("exp6", [{"iteration": t, "sample": j, "score": 1.0}
                          for t in range(3) for j in range(4)])
    cut = first_loops({"exp1": exp1, "exp6": exp6}, 20)
    sizes = cut["exp1"].groupby(["scenario_id", "long_run"]).size().to_dict()
    assert sizes == {(1, False): 20, (1, True): 200, (2, False): 20, (2, True): 200}
    assert cut["exp1"]["loop"].max() == 199
    assert cut["exp6"] is exp6  # no loops: kept whole
    for bad in (0, -3, 2.5, True, "20"):
        with pytest.raises(ValueError, match="n must be an integer >= 1"):
            first_loops({"exp1": exp1}, bad)
    with pytest.raises(ValueError, match="long_run_factor must be an integer >= 1"):
        first_loops({"exp1": exp1}, 20, 0)
    short = first_loops({"exp1": exp1}, 20, long_run_factor=2)["exp1"]
    assert short.groupby("long_run").size().to_dict() == {False: 40, True: 80}


def test_verdicts_at_fewer_loops_names_what_a_cut_would_change(monkeypatch):
    from uavwind.analysis import claims
    from uavwind.analysis.tables import fewer_loops_note

    def judge(r):  # reproduced while the mean score stays above 50
        s = r["expA"]["score"]
        return claims.Verdict("CA", "", "mean > 50", f"{s.mean():.1f}",
                              "reproduced" if s.mean() > 50 else "not reproduced")
    monkeypatch.setattr(claims, "CLAIMS", {"CA": (("expA",), judge)})
    # the first 25 loops score 40, the rest 100: the whole mean (at 50 loops, 70) passes, the
    # mean of the first 25 or fewer (40) does not
    expA = _fake("expA", [{"loop": i, "score": 40.0 if i < 25 else 100.0} for i in range(50)])
    fewer = claims.verdicts_at_fewer_loops({"expA": expA}, counts=(40, 25, 60))
    assert list(fewer.index) == [40, 25]  # 60 >= the 50 loops run: nothing to cut
    assert fewer.loc[40, "changed"] == 0 and fewer.loc[40, "which"] == "none"
    assert fewer.loc[25, "changed"] == 1
    assert fewer.loc[25, "which"] == "CA: reproduced -> not reproduced"
    assert fewer["long run"].tolist() == [400, 250]  # no long run here: the paper's factor
    # the long run's factor is read off the results: 100 long loops beside 50 is twice
    expL = _fake("expL", [{"long_run": lr, "loop": i, "score": 1.0}
                          for lr, k in ((False, 50), (True, 100)) for i in range(k)])
    twice = claims.verdicts_at_fewer_loops({"expA": expA, "expL": expL}, counts=(25,))
    assert twice["long run"].tolist() == [50] and twice.loc[25, "changed"] == 1
    note = fewer_loops_note(fewer, "50 loops a case")
    assert "0 of 1 verdicts change at 40 loops and 1 change at 25 loops (CA: reproduced -> " \
           "not reproduced)" in note
    # a build of 2 loops a case has no smaller count to try, and says so
    two = claims.verdicts_at_fewer_loops({"expA": expA[expA["loop"] < 2]})
    assert two.empty
    assert "too few loops a case" in fewer_loops_note(two, "2 loops")
