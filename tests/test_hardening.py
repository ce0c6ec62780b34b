"""Hostile inputs: nothing lost, nothing silently wrong (the cache, numerics, CLI)."""
import json
import os
import threading
import time
import warnings

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.core.parallel import check_jobs
from uavwind.study import cache, runner
from uavwind import study as ex
from uavwind.study import fill
from uavwind.method import search
from uavwind.cli import main

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}
RUN = dict(profile=TINY, n_jobs=1, progress=False, cases=[0])


def _chunks(folder):
    return sorted((folder / "loops").glob("*.parquet"))


# --------------------------------------------------------------------------- #
# the cache
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("damage", [
    lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]),  # truncated
    lambda p: p.write_bytes(b""),                                        # empty
    lambda p: p.write_bytes(np.random.default_rng(0).bytes(3000)),       # random bytes
    lambda p: pd.read_parquet(p).iloc[:-1].to_parquet(p),                # a dropped row
    lambda p: pd.read_parquet(p).assign(score=999.0).to_parquet(p),      # impossible score
    lambda p: pd.read_parquet(p).assign(seed=7).to_parquet(p),           # another seed
])
def test_a_damaged_chunk_is_moved_aside_and_recomputed(tmp_path, damage):
    first = ex.run_experiment("exp5", results=tmp_path, **RUN)
    (chunk,) = _chunks(tmp_path)
    damage(chunk)
    with pytest.warns(cache.CorruptChunkWarning, match="moved to"):
        again = ex.run_experiment("exp5", results=tmp_path, **RUN)
    assert again.attrs["cached"] == 0
    assert (chunk.parent / (chunk.name + ".corrupt")).exists()
    pd.testing.assert_frame_equal(first, again)
    with warnings.catch_warnings():  # and now it is trusted again
        warnings.simplefilter("error")
        assert ex.run_experiment("exp5", results=tmp_path, **RUN).attrs["cached"] == 1


def test_a_chunk_copied_over_another_is_detected(tmp_path):
    ex.run_experiment("exp5", results=tmp_path, profile=TINY, n_jobs=1, progress=False)
    a, b = _chunks(tmp_path)
    b.write_bytes(a.read_bytes())
    with pytest.warns(cache.CorruptChunkWarning, match="setting_key"):
        df = ex.run_experiment("exp5", results=tmp_path, profile=TINY, n_jobs=1, progress=False)
    assert df.attrs["cached"] == 1


@pytest.mark.parametrize("make_bad", ["file", "readonly"])
def test_an_unwritable_results_folder_fails_before_any_work(tmp_path, monkeypatch, make_bad):
    if make_bad == "file":
        target = tmp_path / "results"
        target.write_text("not a folder")
    else:
        if os.geteuid() == 0:
            pytest.skip("root writes to read-only folders")
        target = tmp_path / "ro"
        target.mkdir()
        target.chmod(0o500)
    monkeypatch.setattr(runner, "random_search", lambda *a, **k: pytest.fail("computed anyway"))
    with pytest.raises(ValueError, match="cannot be written"):
        ex.run_experiment("exp5", results=target, **RUN)


def test_a_full_disk_leaves_no_orphan_file(tmp_path, monkeypatch):
    def full(self, path, **kw):
        with open(path, "wb") as fh:
            fh.write(b"PAR1 partial")
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(pd.DataFrame, "to_parquet", full)
    with pytest.raises(OSError, match="No space"):
        cache.atomic_write(pd.DataFrame({"score": [1.0]}), tmp_path / "x.parquet")
    assert list(tmp_path.iterdir()) == []


def test_user_paths_are_expanded(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("UAVWIND_RESULTS", "~/uw-results")
    assert cache.results_dir() == tmp_path / "uw-results"
    assert cache.results_dir("~/named") == tmp_path / "named"  # a named folder wins
    ex.run_experiment("exp5", **RUN)
    assert _chunks(tmp_path / "uw-results") and not (tmp_path / "~").exists()


def test_two_runs_on_one_chunk_compute_it_once(tmp_path):
    path = tmp_path / "loops" / "chunk.parquet"
    expect = cache.Expected("k", 1, "fast", 1)
    meta = {"setting_key": "k", "seed": 1, "engine": "fast"}
    calls = []

    def compute():
        calls.append(threading.get_ident())
        time.sleep(0.5)
        return pd.DataFrame({"score": [50.0], "silhouette": [0.5], "correct": [True]})
    out = {}

    def run(name):
        out[name] = cache.cached(path, compute, meta, expect)
    t1 = threading.Thread(target=run, args=("first",))
    t1.start()
    time.sleep(0.1)
    run("second")
    t1.join()
    assert len(calls) == 1
    assert out["first"][1] is False and out["second"][1] is True
    pd.testing.assert_frame_equal(out["first"][0], out["second"][0])


# --------------------------------------------------------------------------- #
# the numerics
# --------------------------------------------------------------------------- #
def _push(magnitude=50.0, times=(0.0,)):
    k = len(times)
    return uw.ThrustSequence(list(times), [magnitude] * k, [[0, 0, 1]] * k)


def test_unstable_drag_is_refused_with_a_step_that_works():
    light = uw.UAV(mass=0.1, drag_coefficient=1.0, area=0.1)
    wind = uw.ConstantWind([[1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"dt = 0.1 s .*mass = 0.1 kg.*use dt <") as err:
        uw.simulate(_push(), wind, uav=light, dt=0.1, duration=1.0)
    ok = float(str(err.value).split("e.g. dt = ")[1].split(" s")[0])  # the suggested step
    assert ok < uw.dynamics.max_stable_dt(_push(), light)
    pos = uw.simulate(_push(), wind, uav=light, dt=ok, duration=1.0)
    assert np.all(np.isfinite(pos))
    # the paper's UAV is far inside the stable range
    assert uw.dynamics.max_stable_dt(_push(), uw.UAV()) > 1.0


def test_off_grid_and_late_thrust_changes_warn():
    wind = uw.ConstantWind([[0.0, 0.0, 0.0]])
    with pytest.warns(UserWarning, match="falls between steps.*takes effect at 4.1 s"):
        uw.simulate(_push(20.0, (0.0, 4.05)), wind)
    with pytest.warns(UserWarning, match="11.95 s comes after the last step start"):
        uw.simulate(_push(20.0, (0.0, 11.95)), wind)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        uw.simulate(_push(20.0, (0.0, 4.0, 11.9)), wind)


@pytest.mark.parametrize("call, err, match", [
    (lambda: uw.score_loop(np.zeros((2, 5, 3)), [0, 1]), ValueError, "at least 3"),
    (lambda: uw.score_loop(np.full((4, 5, 3), 1e200), [0, 0, 1, 1]), ValueError, "within"),
    (lambda: uw.make_setting("light constant", "light constant", 1), ValueError, "at least 3"),
    (lambda: uw.DrydenWind([1e-300]), ValueError, r"w20 must be in \[0.001, 1000\]"),
    (lambda: uw.ConstantWind([[1e308, 0, 0]]), ValueError, "velocities"),
    (lambda: uw.ShearWind([[0, 2e3, 0]]), ValueError, "reference_velocities"),
    (lambda: uw.simulate(_push(), uw.ConstantWind([[0, 0, 0]]), dt=1e-12), ValueError,
     "dt = 1e-12 s"),
])
def test_tiny_huge_and_too_few_are_refused(call, err, match):
    with pytest.raises(err, match=match):
        call()


def test_cem_refuses_a_wrong_objective():
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    with pytest.raises(ValueError, match="one score per sample"):
        uw.cem(s, n_samples=4, n_elite=2, max_iter=1, objective=lambda x: np.zeros(3),
               progress=False)
    with pytest.raises(ValueError, match="NaN"):
        uw.cem(s, n_samples=4, n_elite=2, max_iter=1, progress=False,
               objective=lambda x: np.full(len(x), np.nan))


# --------------------------------------------------------------------------- #
# the CLI and run_experiment
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("argv, option", [
    (["run", "exp1", "--jobs", "0"], "--jobs"), (["run", "exp1", "--seed", "-5"], "--seed"),
    (["run", "exp1", "--engine", "bogus"], "--engine"), (["run", "exp99"], "exp99"),
])
def test_cli_usage_errors_are_one_line(argv, option, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert "error" in err and option in err and "Traceback" not in err


def test_cli_caps_jobs_and_reports_an_unwritable_folder(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "f"
    blocker.write_text("x")
    monkeypatch.setenv("UAVWIND_RESULTS", str(blocker))
    assert main(["run", "exp5", "--jobs", "999", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "using" in err and "cannot be written" in err


def test_cli_times_file_records_every_computed_entry(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(ex.PROFILES, "tiny", ex.get_profile({**TINY, "name": "tiny"}))
    monkeypatch.setenv("UAVWIND_RESULTS", str(tmp_path / "r"))
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    rec = json.loads(out.read_text())
    assert rec["profile"] == "tiny"
    assert len(rec["entries"]) == len(fill.needed_entries(["exp5"], "tiny")) > 0
    assert {e["experiment"] for e in rec["entries"]} == {"exp5"}
    assert "by experiment and reading" in capsys.readouterr().out
    # a second run computes nothing and says so in the file
    assert main(["run", "exp5", "--profile", "tiny", "--jobs", "1", "--no-progress",
                 "--no-tables", "--times", str(out)]) == 0
    assert json.loads(out.read_text())["entries"] == []
    with pytest.raises(SystemExit) as stop:
        main(["run", "exp5", "--profile", "tiny", "--times", str(tmp_path / "no" / "t.json")])
    assert stop.value.code == 2 and "--times" in capsys.readouterr().err


def test_cli_keeps_the_times_of_finished_entries_when_interrupted(tmp_path, monkeypatch):
    import uavwind.cli as cli

    def interrupted(*args, times=None, **kwargs):
        times.append({"experiment": "exp5", "reading": "inferred", "rows": 2,
                      "cpu_seconds": 1.5})
        raise KeyboardInterrupt
    monkeypatch.setattr(cli, "fill_cache", interrupted)
    out = tmp_path / "times.json"
    assert main(["run", "exp5", "--no-progress", "--times", str(out)]) == 130
    rec = json.loads(out.read_text())
    assert rec["complete"] is False and rec["entries"][0]["cpu_seconds"] == 1.5
    assert [p.name for p in tmp_path.iterdir()] == ["times.json"]  # no temporary file left


def test_n_jobs_is_capped_at_the_cores():
    cores = os.cpu_count()
    with pytest.warns(UserWarning, match="cores"):
        assert check_jobs(cores + 1000) == cores
    with pytest.raises(ValueError, match="n_jobs"):
        check_jobs(-cores - 1)


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


def test_an_interrupt_shuts_the_workers_down(monkeypatch):
    stopped = []
    monkeypatch.setattr(search, "stop_workers", lambda: stopped.append(True))

    class Interrupted:
        def __init__(self, *a, **k):
            pass

        def __call__(self, tasks):
            def gen():
                raise KeyboardInterrupt
                yield
            return gen()
    monkeypatch.setattr("joblib.Parallel", Interrupted)
    s = uw.make_setting("light constant", "strong shear", 2)
    with pytest.raises(KeyboardInterrupt):
        uw.random_search(s, n_loops=2, n_jobs=2, progress=False)
    assert stopped == [True]


# --------------------------------------------------------------------------- #
# regressions found in review
# --------------------------------------------------------------------------- #
def test_a_correct_loop_with_a_negative_silhouette_is_cached(tmp_path):
    path = tmp_path / "loops" / "c.parquet"
    expect = cache.Expected("k", 1, "fast", 2)
    rows = pd.DataFrame({"score": [-12.5, 0.0], "silhouette": [-0.125, 0.4],
                         "correct": [True, False]})
    df, hit = cache.cached(path, lambda: rows.copy(), {"setting_key": "k", "seed": 1,
                                                       "engine": "fast"}, expect)
    assert not hit and cache.read_verified(path, expect) is not None
    from uavwind.core.stats import correct_share
    assert correct_share(df) == 0.5  # the correct column, not score > 0


def test_cem_keeps_its_cap_apart_from_the_k_means_cap(tmp_path):
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    res = uw.cem(s, n_samples=3, n_elite=1, max_iter=2, seed=0, n_jobs=1, progress=False,
                 clustering={"max_iter": 1})
    assert len(res.history) == 2 and (res.samples["n_iter"] <= 1).all()
    df = ex.run_experiment("exp6", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                           max_iter=1)
    assert (df["n_iter"] <= 1).all() and df["iteration"].max() == 2


def test_cem_history_ignores_nan_scores():
    s = uw.make_setting("light constant", "strong shear", 2, n_changes=0)
    res = uw.cem(s, n_samples=4, n_elite=2, max_iter=1, progress=False,
                 objective=lambda x: np.array([1.0, np.nan, 3.0, 2.0]))
    assert res.history["max"].iloc[0] == 3.0 and res.history["mean"].iloc[0] == 2.0


def test_inferred_layout_with_a_turbulent_group_a():
    s = uw.make_setting("strong turbulence", "strong shear", 3)
    assert s.group_a.kind == "turbulence" and s.n_env == 6
    with pytest.raises(ValueError, match="no fitted gap"):
        uw.make_setting("strong turbulence", "strong turbulence", 3)


def test_the_explorer_grid_key_follows_the_fitted_layout(tmp_path, monkeypatch):
    from uavwind.report import explore
    from uavwind.study import layouts as scenarios

    calls = []
    monkeypatch.setattr(explore, "explore_grid", _stub_grid(calls))
    kw = dict(pairs=(("light constant", "light constant"),), n_per_group=(3,), layouts=("inferred",))
    explore.cached_grid(tmp_path, **kw)
    explore.cached_grid(tmp_path, **kw)
    assert len(calls) == 1  # cached
    monkeypatch.setitem(scenarios.INFERRED_GAP_RATIOS, "light constant", 20.0)
    explore.cached_grid(tmp_path, **kw)
    assert len(calls) == 2  # a refitted layout is a new grid


def _stub_grid(calls):
    def explore_grid(pairs=(), n_per_group=(), layouts=(), every=3, engine=None, seed=0):
        calls.append(1)
        return {"controls": {}, "loops": {}}
    return explore_grid
