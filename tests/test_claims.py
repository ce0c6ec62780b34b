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
