"""Experiment registry, profiles, cache keys, resume, paper values, claims."""
from pathlib import Path
import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind import study as ex
from uavwind.analysis import tables
from uavwind.study import cache, registry
from uavwind.study import fill
from uavwind.analysis.claims import bootstrap_ci, evaluate_claims, paired_difference
from uavwind.study.paper import PAPER_FILES, load_paper_values

TINY = {"loops": 2, "long_loops": 3, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


def test_registry_matches_the_paper():
    assert list(ex.EXPERIMENTS) == ["example", "exp1", "exp2", "exp3", "exp4", "exp5", "exp6",
                                    "exp6_raw", "exp7", "exp8", "exp9", "fit_layout",
                                    "fit_turbulence"]
    sizes = {k: len(e.cases()) for k, e in ex.EXPERIMENTS.items()}
    n_ratios = len(registry.FIT_RATIOS)
    assert sizes == {"example": 1, "exp1": 8, "exp2": 32, "exp3": 32, "exp4": 28, "exp5": 2,
                     "exp6": 1, "exp6_raw": 1, "exp7": 3 * 11, "exp8": 3 * 4 * 2, "exp9": 3 * 11,
                     "fit_layout": 4 * n_ratios, "fit_turbulence": 6}
    # Exp 9 is Exp 7's loops seen by the baseline: the same settings, so one cache
    assert [c.setting.key() for c in ex.EXPERIMENTS["exp9"].cases()] == \
        [c.setting.key() for c in ex.EXPERIMENTS["exp7"].cases()]
    # the layout fit: Exp 1's same-strength scenarios, every ratio of the grid
    fit = ex.EXPERIMENTS["fit_layout"].cases()
    assert sorted({c.labels["scenario_id"] for c in fit}) == [1, 3, 4, 6]
    for c in fit:
        a, b = c.setting.group_a.speeds, c.setting.group_b.speeds
        assert (b.min() - a.max()) / (a[1] - a[0]) == pytest.approx(c.labels["gap_ratio"])
    exp1 = ex.EXPERIMENTS["exp1"].cases()
    assert [c.long for c in exp1] == [False] * 7 + [True]
    assert all(c.setting.n_env == 10 for c in exp1[:7]) and exp1[7].setting.n_env == 20
    exp4 = ex.EXPERIMENTS["exp4"].cases()
    assert sorted({c.labels["thrust_changes"] for c in exp4}) == [0, 2, 4, 6, 8, 10, 12]
    assert {c.setting.n_changes for c in exp4} == {0, 2, 4, 6, 8, 10, 11}
    # Exp 6 flies Exp 5's similar-direction environments
    assert ex.EXPERIMENTS["exp6"].cases()[0].setting.key() == ex.EXPERIMENTS["exp5"].cases()[0].setting.key()
    for e in ex.EXPERIMENTS.values():
        assert (Path(__file__).parents[1] / "notebooks" / e.notebook).exists()


def test_profiles_and_loop_counts():
    assert ex.PROFILES["paper"].loops == 50 and ex.PROFILES["paper"].long_loops == 500
    assert ex.PROFILES["paper"].cem.to_dict() == {"n_samples": 30, "n_elite": 4, "max_iter": 20}
    # example 50, exp1 7x50 + 500, exp2/exp3 32x50 each, exp4 28x50, exp5 2x50,
    # exp6 and exp6_raw 30x20 each, exp7/exp9 33x50 each, exp8 24x50,
    # fit_layout 4 scenarios x 16 ratios x 20, fit_turbulence 6 x 50
    assert ex.n_loops_total("paper") == (50 + 850 + 1600 + 1600 + 1400 + 100 + 2 * 600
                                         + 2 * 33 * 50 + 24 * 50 + 4 * 16 * 20 + 6 * 50)
    with pytest.raises(ValueError, match="profile"):
        ex.run_experiment("exp5", profile="huge")
    with pytest.raises(ValueError, match="unknown experiment 'exp99'"):
        ex.run_experiment("exp99")
    with pytest.raises(TypeError, match="experiment id"):
        ex.get_experiment(5)


def test_cache_key_depends_on_what_matters():
    s = uw.make_setting("light constant", "strong shear")
    base = cache.cache_key(s, 1, 0, 50, "fast", {})
    assert base == cache.cache_key(s, 1, 0, 50, "fast", {})
    assert base == cache.cache_key(s, 1, 0, 50, "fast", {"gamma": 0.5})  # the default, spelled out
    assert base == cache.cache_key(uw.make_setting("light constant", "strong shear", name="x"),
                                1, 0, 50, "fast", {})  # names do not change results
    for other in (cache.cache_key(s, 2, 0, 50, "fast", {}), cache.cache_key(s, 1, 0, 49, "fast", {}),
                  cache.cache_key(s, 1, 0, 50, "tslearn", {}), cache.cache_key(s, 1, 0, 50, "fast", {"gamma": 1.0}),
                  cache.cache_key(uw.make_setting("light constant", "strong shear", n_changes=5), 1, 0, 50, "fast", {})):
        assert other != base


def test_run_resume_and_reuse(tmp_path, monkeypatch):
    import uavwind.study.runner as mod

    calls = []
    real = mod.random_search

    def counting(setting, **kw):
        calls.append(setting.key())
        if interrupt["after"] is not None and len(calls) > interrupt["after"]:
            raise KeyboardInterrupt
        return real(setting, **kw)

    interrupt = {"after": 1}
    monkeypatch.setattr(mod, "random_search", counting)
    with pytest.raises(KeyboardInterrupt):
        mod.run_experiment("exp5", profile=TINY, results=tmp_path, n_jobs=1, progress=False)
    assert len(list((tmp_path / "loops").glob("*.parquet"))) == 1  # the finished setting only
    assert not list((tmp_path / "loops").glob("*.tmp*"))  # nothing partial
    interrupt["after"], calls[:] = None, []
    resumed = mod.run_experiment("exp5", profile=TINY, results=tmp_path, n_jobs=1, progress=False)
    assert len(calls) == 1 and resumed.attrs["cached"] == 1  # only the unfinished setting ran
    calls[:] = []
    again = mod.run_experiment("exp5", profile=TINY, results=tmp_path, n_jobs=1, progress=False)
    assert calls == [] and again.attrs["cached"] == 2
    fresh = mod.run_experiment("exp5", profile=TINY, results=tmp_path / "fresh", n_jobs=1,
                               progress=False)
    pd.testing.assert_frame_equal(resumed, fresh)
    pd.testing.assert_frame_equal(again, fresh)
    assert set(fresh["direction"]) == {"similar", "opposite"}
    assert {"setting_key", "seed", "engine", "uavwind_version", "results_version"} <= set(fresh.columns)
    table = tables.summary_table(fresh)
    assert list(table.columns) == ["max", "mean", "ci_low", "ci_high", "correct_rate",
                                   "n_loops"] and len(table) == 2
    cmp = tables.comparison_table(fresh)
    assert cmp["paper_mean"].tolist() == [21.58, 90.33]


def test_changed_setting_recomputes_only_itself(tmp_path):
    a = ex.run_experiment("exp1", profile=TINY, results=tmp_path, cases=[1, 2], n_jobs=1,
                          progress=False)
    b = ex.run_experiment("exp1", profile=TINY, results=tmp_path, cases=[1, 2], n_jobs=1,
                          progress=False, gamma=1.0)
    assert b.attrs["cached"] == 0
    c = ex.run_experiment("exp1", profile=TINY, results=tmp_path, cases=[1, 2, 3], n_jobs=1,
                          progress=False)
    assert c.attrs["cached"] == 2 and c.attrs["chunks"] == 3
    pd.testing.assert_frame_equal(c[c["case"] < 3].reset_index(drop=True), a)


def test_settings_shared_by_experiments_are_computed_once(tmp_path):
    ex.run_experiment("exp2", profile=TINY, results=tmp_path, cases=[0], n_jobs=1, progress=False)
    again = ex.run_experiment("exp3", profile=TINY, results=tmp_path, cases=[0], n_jobs=1,
                              progress=False)
    assert again.attrs["cached"] == 1  # exp3's 20-environment setting is exp2's


def test_cem_experiment_and_worker_independence(tmp_path):
    one = ex.run_experiment("exp6", profile=TINY, results=tmp_path / "a", n_jobs=1, progress=False)
    two = ex.run_experiment("exp6", profile=TINY, results=tmp_path / "b", n_jobs=2, progress=False)
    pd.testing.assert_frame_equal(one, two)
    assert len(one) == 6 and one["iteration"].tolist() == [1, 1, 1, 2, 2, 2]
    hist = tables.summary_table(one)
    assert list(hist.index) == [1, 2] and np.all(np.diff(hist["best_so_far"]) >= 0)


def _py(v):
    v = v.tolist() if hasattr(v, "tolist") else v
    return [_py(x) for x in v] if isinstance(v, (list, tuple)) else v


def _exact(df):
    """Every cell as the repr of its Python value (a list read back from Parquet is an
    array): equal texts mean equal doubles."""
    return {c: [repr(_py(v)) for v in df[c]] for c in df.columns}


def test_fill_cache_stores_what_run_experiment_computes(tmp_path):
    from uavwind.study.readings import READINGS

    ids = ["exp5", "exp6"]
    done = fill.fill_cache(ids, profile=TINY, results=tmp_path / "pool", n_jobs=2,
                         readings="all", progress=False)
    assert done["entries"] > 0 and done["cached"] == 0 and done["computed"] == done["entries"]
    # every computed entry is timed, by the worker that computed it
    times = done["times"]
    assert len(times) == done["computed"] and all(t["cpu_seconds"] > 0 for t in times)
    assert sum(t["rows"] for t in times) == done["rows_computed"]
    by_exp = fill.time_by_experiment(times)
    assert set(by_exp.index.get_level_values("experiment")) <= set(ids)
    assert by_exp["entries"].sum() == done["computed"]
    assert by_exp["share"].sum() == pytest.approx(100.0)
    assert fill.fill_cache(ids, profile=TINY, results=tmp_path / "pool", n_jobs=2,
                         readings="all", progress=False) == {
        "entries": done["entries"], "cached": done["entries"], "computed": 0,
        "rows_computed": 0, "times": []}
    for reading in READINGS:
        for eid in ids:
            pooled = ex.run_experiment(eid, profile=TINY, results=tmp_path / "pool", n_jobs=1,
                                       progress=False, reading=reading)
            assert pooled.attrs["cached"] == pooled.attrs["chunks"]  # nothing left to compute
            alone = ex.run_experiment(eid, profile=TINY, results=tmp_path / "alone", n_jobs=1,
                                      progress=False, reading=reading)
            assert _exact(pooled) == _exact(alone)


def test_a_first_run_returns_what_a_cached_run_returns(tmp_path):
    first = ex.run_experiment("exp4", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                              cases=[0])
    again = ex.run_experiment("exp4", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                              cases=[0])
    assert first.attrs["cached"] == 0 and again.attrs["cached"] == again.attrs["chunks"]
    assert list(first.columns) == list(again.columns)
    assert (first.dtypes == again.dtypes).all()
    for col in first.columns:  # e.g. thrust sequences: arrays both times, not lists then arrays
        assert [type(v) for v in first[col]] == [type(v) for v in again[col]], col
    assert _exact(first) == _exact(again)


def _record_fills(monkeypatch):
    """Replace the work of fill_cache by a record of the entries it hands out, in order."""
    order = []

    def record(entry, pin=True, n_jobs=1):
        order.append(entry)
        return entry.path, entry.n_rows, False, 0.5
    monkeypatch.setattr(fill, "_fill_one", record)
    return order


def test_fill_cache_runs_each_entry_once_longest_first(tmp_path, monkeypatch):
    order = _record_fills(monkeypatch)
    done = fill.fill_cache(["exp2", "exp3", "exp6"], profile=TINY, results=tmp_path, n_jobs=1,
                         progress=False)
    n_cases = sum(len(ex.get_experiment(i).cases()) for i in ("exp2", "exp3", "exp6"))
    assert len(order) == done["entries"] == done["computed"] < n_cases  # shared settings once
    assert len({e.path for e in order}) == len(order)
    costs = [e.cost for e in order]
    assert costs == sorted(costs, reverse=True) and order[0].search == "cem"
    assert done["rows_computed"] == sum(e.n_rows for e in order)
    assert [t["rows"] for t in done["times"]] == [e.n_rows for e in order]
    assert [(t["experiment"], t["case"]) for t in done["times"]] == \
        [(e.labels["experiment"], e.labels["case"]) for e in order]


def test_times_say_which_readings_and_experiments_share_an_entry(tmp_path, monkeypatch):
    order = _record_fills(monkeypatch)
    done = fill.fill_cache("all", profile=TINY, results=tmp_path, n_jobs=1, readings="all",
                         progress=False)
    users = {e.path: pairs for e, pairs in
             fill._needed("all", TINY, "all", ex.DEFAULT_SEED, None, tmp_path).items()}
    assert len(done["times"]) == len(users) == len(order)
    for t, e in zip(done["times"], order):
        pairs = users[e.path]
        assert t["experiment"] == pairs[0][0] and t["case"] == e.labels["case"]
        assert (t["reading"] == "both") == (len({r for _, r in pairs}) == 2)
        assert t["shared_with"] == sorted({x for x, _ in pairs} - {pairs[0][0]})
    assert {"inferred", "halves", "both"} <= {t["reading"] for t in done["times"]}
    # Exp 2, 3 and 4 share their 20-environment settings: one entry, counted under exp2
    assert any(t["experiment"] == "exp2" and "exp3" in t["shared_with"] for t in done["times"])
    # a single experiment id given as a string is that experiment, not its letters
    assert [e.path for e in fill.needed_entries("exp5", TINY)] == \
        [e.path for e in fill.needed_entries(["exp5"], TINY)]


def test_a_lone_missing_entry_gets_every_worker_and_their_cpu_time(tmp_path):
    done = fill.fill_cache(["exp6"], profile=TINY, results=tmp_path, n_jobs=2, progress=False)
    assert done["computed"] == 1 and done["times"][0]["search"] == "cem"
    assert done["times"][0]["cpu_seconds"] > 0
    alone = ex.run_experiment("exp6", profile=TINY, results=tmp_path / "b", n_jobs=1,
                              progress=False)
    pooled = ex.run_experiment("exp6", profile=TINY, results=tmp_path, n_jobs=1, progress=False)
    assert _exact(pooled) == _exact(alone)


def test_time_by_experiment_sums_per_experiment_in_registry_order():
    rec = [{"experiment": e, "reading": r, "case": 0, "search": "random", "n_env": 6, "rows": n,
            "cpu_seconds": c}
           for e, r, n, c in [("exp6", "inferred", 10, 6.0), ("exp1", "halves", 50, 1.0),
                              ("exp1", "inferred", 50, 2.0), ("exp1", "inferred", 20, 1.0)]]
    t = fill.time_by_experiment(rec)
    assert list(t.index) == [("exp1", "halves"), ("exp1", "inferred"), ("exp6", "inferred")]
    assert t["rows"].tolist() == [50, 70, 10] and t["entries"].tolist() == [1, 2, 1]
    assert t["share"].tolist() == [10.0, 30.0, 60.0]
    assert fill.time_by_experiment([]).empty


@pytest.mark.parametrize("kwargs, word", [
    ({"exp_ids": ["exp99"]}, "exp99"), ({"readings": "upside-down"}, "reading"),
    ({"profile": "slow"}, "profile"), ({"n_jobs": 0}, "n_jobs"), ({"engine": "x"}, "engine"),
])
def test_fill_cache_refuses_bad_input_before_any_work(tmp_path, kwargs, word):
    with pytest.raises(ValueError, match=word):
        fill.fill_cache(**{"exp_ids": ["exp5"], "profile": TINY, "results": tmp_path / "r",
                         "progress": False, **kwargs})
    assert not (tmp_path / "r").exists()


def test_both_readings_are_tabulated_and_compared_as_exp1(tmp_path):
    t4 = load_paper_values("exp1").set_index("scenario")
    for reading in ("inferred", "halves"):
        df = ex.run_experiment("exp1", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                               cases=[0, 2, 3], reading=reading)
        assert (df["reading"] == reading).all()
        assert len(tables.summary_table(df)) == 3
        cmp = tables.comparison_table(df)
        assert list(cmp.index) == [t4.index[k] for k in (0, 2, 3)]
        assert cmp["paper_mean"].tolist() == [t4.iloc[k]["mean"] for k in (0, 2, 3)]
        assert "'" + reading + "' reading" in tables.provenance(df)
    with pytest.raises(ValueError, match="no paper table"):
        tables.comparison_table(df.assign(experiment="exp6"))


def test_paper_values_load_with_sources():
    for exp_id in PAPER_FILES:
        df = load_paper_values(exp_id)
        assert "source" in df.columns and len(df) >= 2
    t4 = load_paper_values("exp1")
    assert t4.set_index("scenario_id").loc[4, "maximum"] == 79.83
    assert t4.set_index(["scenario_id", "long_run"]).loc[(1, True), "mean"] == 79.30
    assert set(load_paper_values("exp2")["n_env"]) == {6, 20}
    with pytest.raises(ValueError, match="unknown experiment"):
        load_paper_values("exp9")


def test_bootstrap_and_paired_difference():
    rng = np.random.default_rng(0)
    x = rng.normal(5, 1, size=400)
    est, lo, hi = bootstrap_ci(x)
    assert lo < 5 < hi and hi - lo < 0.3 and est == pytest.approx(x.mean())
    y = x - 1 + rng.normal(0, 0.01, size=400)
    d = paired_difference(x, y)
    assert d[1] > 0.99 and d[2] < 1.01  # pairing removes the shared noise


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
