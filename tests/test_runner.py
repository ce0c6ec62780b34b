"""Running an experiment: resumable, shared settings once, independent of the workers."""

import numpy as np
import pandas as pd
import pytest

from uavwind import study as ex
from uavwind.analysis import tables

TINY = {"loops": 2, "long_loops": 3, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


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


@pytest.mark.slow
def test_cem_experiment_and_worker_independence(tmp_path):
    one = ex.run_experiment("exp6", profile=TINY, results=tmp_path / "a", n_jobs=1, progress=False)
    two = ex.run_experiment("exp6", profile=TINY, results=tmp_path / "b", n_jobs=2, progress=False)
    pd.testing.assert_frame_equal(one, two)
    assert len(one) == 6 and one["iteration"].tolist() == [1, 1, 1, 2, 2, 2]
    hist = tables.summary_table(one)
    assert list(hist.index) == [1, 2] and np.all(np.diff(hist["best_so_far"]) >= 0)


@pytest.mark.parametrize("cases, err, match", [
    ([99], ValueError, "cases must be in"), ([-1], ValueError, "cases must be in"),
    ([0, 0], ValueError, "repeat"), ([], ValueError, "at least one"), ("0", TypeError, "cases"),
])
def test_run_experiment_validates_cases(tmp_path, cases, err, match):
    with pytest.raises(err, match=match):
        ex.run_experiment("exp5", results=tmp_path, profile=TINY, n_jobs=1, progress=False,
                          cases=cases)


@pytest.mark.parametrize("profile, match", [
    ({}, "missing"), ({**TINY, "loops": 0}, "loops"),
    ({**TINY, "cem": {"n_samples": 2, "n_elite": 3, "max_iter": 1}}, "n_elite"),
])
def test_run_experiment_validates_profiles(tmp_path, profile, match):
    with pytest.raises(ValueError, match=match):
        ex.run_experiment("exp5", results=tmp_path, profile=profile, progress=False)


def test_a_cached_run_reads_and_verifies_each_chunk_once(tmp_path, monkeypatch):
    # a page reads hundreds of chunks: verifying each twice (is it there? then read it)
    # cost the claims page 2 s of its 3.3
    from uavwind.study import cache, runner
    first = ex.run_experiment("exp5", profile="quick", results=tmp_path, n_jobs=1, progress=False)
    reads = []
    real = cache.read_verified
    for module in (cache, runner):
        monkeypatch.setattr(module, "read_verified", lambda *a: reads.append(a[0]) or real(*a))
    again = ex.run_experiment("exp5", profile="quick", results=tmp_path, n_jobs=1, progress=False)
    assert again.equals(first) and again.attrs["cached"] == again.attrs["chunks"]
    assert len(reads) == len(set(reads)) == again.attrs["chunks"]
