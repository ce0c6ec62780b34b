"""The fill: every missing entry of many experiments in one pool, timed."""
from dataclasses import replace

import pytest

from uavwind import study as ex
from uavwind.study import fill
from helpers import exact_cells, record_fills

TINY = {"loops": 2, "long_loops": 3, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


@pytest.mark.slow
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
        "rows_computed": 0, "times": [], "skipped": []}
    for reading in READINGS:
        for eid in ids:
            pooled = ex.run_experiment(eid, profile=TINY, results=tmp_path / "pool", n_jobs=1,
                                       progress=False, reading=reading)
            assert pooled.attrs["cached"] == pooled.attrs["chunks"]  # nothing left to compute
            alone = ex.run_experiment(eid, profile=TINY, results=tmp_path / "alone", n_jobs=1,
                                      progress=False, reading=reading)
            assert exact_cells(pooled) == exact_cells(alone)


def test_fill_cache_runs_each_entry_once_longest_first(tmp_path, monkeypatch):
    order = record_fills(monkeypatch)
    done = fill.fill_cache(["exp2", "exp3", "exp6"], profile=TINY, results=tmp_path, n_jobs=1,
                           progress=False, readings="inferred")
    n_cases = sum(len(ex.get_experiment(i).cases()) for i in ("exp2", "exp3", "exp6"))
    assert len(order) == done["entries"] == done["computed"] < n_cases  # shared settings once
    assert len({e.path for e in order}) == len(order)
    costs = [e.cost for e in order]
    assert costs == sorted(costs, reverse=True) and order[0].search == "cem"
    assert done["rows_computed"] == sum(e.n_rows for e in order)
    assert [t["rows"] for t in done["times"]] == [e.n_rows for e in order]
    assert [(t["experiment"], t["case"]) for t in done["times"]] == \
        [(e.labels["experiment"], e.labels["case"]) for e in order]


@pytest.mark.slow
def test_times_say_which_readings_and_experiments_share_an_entry(tmp_path, monkeypatch):
    order = record_fills(monkeypatch)
    done = fill.fill_cache("all", profile=TINY, results=tmp_path, n_jobs=1, readings="all",
                           progress=False)
    users = {e.path: pairs for e, pairs in
             fill._needed("all", TINY, "all", ex.DEFAULT_SEED, None, tmp_path).items()}
    times = [t for t in done["times"] if t["search"] != "analysis"]
    assert len(times) == len(users) == len(order)
    for t, e in zip(times, order):
        pairs = users[e.path]
        assert t["experiment"] == pairs[0][0] and t["case"] == e.labels["case"]
        assert (t["reading"] == "both") == (len({r for _, r in pairs}) == 2)
        assert t["shared_with"] == sorted({x for x, _ in pairs} - {pairs[0][0]})
    assert {"inferred", "halves", "both"} <= {t["reading"] for t in times}
    # Exp 2, 3 and 4 share their 20-environment settings: one entry, counted under exp2
    assert any(t["experiment"] == "exp2" and "exp3" in t["shared_with"] for t in times)
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
    assert exact_cells(pooled) == exact_cells(alone)


@pytest.mark.slow
def test_a_cem_runs_samples_are_tasks_ahead_of_the_chunks(tmp_path, monkeypatch):
    """Two workers, run in this process by an executor that records what it is handed: a
    CEM iteration's samples are tasks of SAMPLES_PER_TASK (here 2: 3 samples make a task of
    2 and one of 1), a run's next iteration is handed out only after its last sample
    returned, and ahead of every chunk still waiting; the rows are run_experiment's to the
    double."""
    from concurrent.futures import Future

    handed = []

    class Recorder:
        def submit(self, fn, *args):
            if fn is fill._cem_samples:
                handed.append(("sample", args[0].key(), [w.spawn_key for w in args[2]]))
            elif not args:  # the compile, first (recorded by the test below)
                pass
            else:
                handed.append(("chunk", args[0].path))
            fut = Future()
            fut.set_result(fn(*args))
            return fut

    pool = fill._LocalPool
    monkeypatch.setattr(fill, "_LocalPool", lambda n: pool(n, executor=Recorder()))
    monkeypatch.setattr(fill, "pin_threads", lambda: None)  # this process keeps its threads
    monkeypatch.setattr(fill, "SAMPLES_PER_TASK", 2)
    ids = ["exp6", "exp5"]
    done = fill.fill_cache(ids, profile=TINY, results=tmp_path / "pool", n_jobs=2,
                           readings="all", progress=False)
    cem_entries = [e for e in fill.needed_entries(ids, TINY, "all", results=tmp_path)
                   if e.search == "cem"]
    n_samples, n_iter = TINY["cem"]["n_samples"], TINY["cem"]["max_iter"]
    samples = [h for h in handed if h[0] == "sample"]
    assert len(cem_entries) == 2 and n_samples == 3 and len(samples) == 2 * 2 * n_iter
    assert [len(h[2]) for h in samples[:2]] == [2, 1]
    # every sample before any chunk: a run's next iteration goes ahead of the waiting chunks
    assert [h[0] for h in handed] == ["sample"] * len(samples) + ["chunk"] * (
        len(handed) - len(samples))
    for run in {h[1] for h in samples}:  # one run's samples: iteration by iteration
        keys = [k for h in samples if h[1] == run for k in h[2]]
        assert sorted(keys) == [(it, j) for it in range(1, n_iter + 1)
                                for j in range(1, n_samples + 1)]
        assert [k[0] for k in keys] == sorted(k[0] for k in keys)
    cem_times = [t for t in done["times"] if t["search"] == "cem"]
    assert [t["tasks"] for t in cem_times] == [2 * n_iter] * 2
    assert all(t["tasks"] == 1 for t in done["times"] if t["search"] != "cem")
    for reading in ("inferred", "halves"):
        for eid in ids:
            pooled = ex.run_experiment(eid, profile=TINY, results=tmp_path / "pool", n_jobs=1,
                                       progress=False, reading=reading)
            assert pooled.attrs["cached"] == pooled.attrs["chunks"]
            alone = ex.run_experiment(eid, profile=TINY, results=tmp_path / "alone",
                                      n_jobs=1, progress=False, reading=reading)
            assert exact_cells(pooled) == exact_cells(alone)


def test_closed_loop_entries_fly_while_the_kernels_compile(tmp_path, monkeypatch):
    """The kernels compile on a worker, as the first task; no task that clusters is handed
    out before it returns, and meanwhile the other worker flies Experiment 12's
    closed-loop entries (no clustering); this process only waits, so it can stop at once."""
    from concurrent.futures import Future

    from uavwind.method import softdtw

    handed, compiling = [], []

    class Recorder:  # hands back each task as if computed, computing nothing
        def submit(self, fn, *args):
            fut = Future()
            if fn is softdtw.warmup:
                handed.append("warm")
                compiling.append(fut)  # returns after three closed-loop entries
                return fut
            if fn is fill._cem_samples:
                handed.append("sample")
                fut.set_result(fn(*args))
            else:
                assert fn is fill._fill_one, fn
                handed.append(args[0].search)
                fut.set_result((args[0].path, args[0].n_rows, False, 0.0))
            if handed.count("closed_loop") == 3 and not compiling[0].done():
                compiling[0].set_result(None)
            return fut

    monkeypatch.setattr(softdtw, "warmup", lambda: None)
    monkeypatch.setattr(fill, "pin_threads", lambda: None)
    pool = fill._LocalPool
    monkeypatch.setattr(fill, "_LocalPool", lambda n: pool(n, executor=Recorder()))
    done = fill.fill_cache(["exp12", "exp6"], profile={**TINY, "episodes": 1},
                           results=tmp_path, n_jobs=2, readings="all", progress=False)
    assert handed[:4] == ["warm"] + ["closed_loop"] * 3  # nothing else while compiling
    assert handed[4] == "sample"  # then the CEM samples go first
    assert handed.count("warm") == 1 and handed.count("closed_loop") > 3
    assert done["computed"] == done["entries"]


class _Batch:
    """A pool whose every task finishes at once, in this process, failed ones listed first;
    ``hold``: the first wait with a task besides the compile returns nothing and sets it (a
    stop request arriving while the tasks run), the next one returns them."""

    def __init__(self, n_workers, hold=None):
        self.n, self.tasks, self.hold = n_workers, [], hold

    def put(self, key, priority, fn, *args):
        self.tasks.append((key, fn, args))

    def start(self, key, fn, *args):
        self.tasks.append((key, fn, args))

    def busy(self):
        return bool(self.tasks)

    def wait(self, timeout, dispatch=True):
        if (self.hold is not None and not self.hold.is_set()
                and any(key is not fill._WARM for key, _, _ in self.tasks)):
            self.hold.set()
            return []
        out = []
        for key, fn, args in self.tasks:
            try:
                out.append((key, fn(*args), None))
            except Exception as exc:
                out.append((key, None, exc))
        self.tasks = []
        return sorted(out, key=lambda t: t[2] is None)

    def cancel(self):
        self.tasks = []


ONE_ITERATION = {**TINY, "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 1}}


def _cem_entry(folder):
    return next(e for e in fill.needed_entries(["exp6", "exp5"], ONE_ITERATION, results=folder)
                if e.search == "cem")


def test_a_failed_task_raises_after_what_finished_beside_it_is_stored(tmp_path, monkeypatch):
    monkeypatch.setattr(fill, "_LocalPool", _Batch)
    monkeypatch.setattr(fill, "pin_threads", lambda: None)

    def boom(entry, pin=True, n_jobs=1):
        raise RuntimeError("boom")
    monkeypatch.setattr(fill, "_fill_one", boom)
    with pytest.raises(RuntimeError, match="boom"):
        fill.fill_cache(["exp6", "exp5"], profile=ONE_ITERATION, results=tmp_path, n_jobs=2,
                        progress=False)
    # the CEM run whose last sample returned in the failed chunk's batch was stored
    assert _cem_entry(tmp_path).present()


def test_a_stop_request_keeps_what_finished_before_it_was_seen(tmp_path, monkeypatch):
    import threading

    stop = threading.Event()
    monkeypatch.setattr(fill, "_LocalPool", lambda n: _Batch(n, hold=stop))
    monkeypatch.setattr(fill, "pin_threads", lambda: None)
    with pytest.raises(KeyboardInterrupt):
        fill.fill_cache(["exp6", "exp5"], profile=ONE_ITERATION, results=tmp_path, n_jobs=2,
                        progress=False, stop=stop)
    assert _cem_entry(tmp_path).present()


def test_the_fills_workers_are_the_ones_joblib_reuses():
    import os

    from joblib import Parallel, delayed

    pool = fill._LocalPool(2)
    pool.put("a", 1, os.getpid)
    pool.put("b", 1, os.getpid)
    pids = set()
    while pool.busy():
        pids |= {res for _, res, _ in pool.wait(5)}
    # a later Parallel of this process (Exp 13 after the fill) reuses them, none started
    assert set(Parallel(n_jobs=2)(delayed(os.getpid)() for _ in range(8))) <= \
        set(pool.executor._processes)


@pytest.mark.slow
def test_another_joblib_backend_keeps_one_task_per_entry(tmp_path, monkeypatch):
    from joblib import parallel_config

    def no_pool(n):
        raise AssertionError("the task pool is loky's only")
    monkeypatch.setattr(fill, "_LocalPool", no_pool)
    monkeypatch.setattr(fill, "pin_threads", lambda: None)
    with parallel_config(backend="threading"):
        done = fill.fill_cache(["exp6", "exp5"], profile=ONE_ITERATION, results=tmp_path,
                               n_jobs=2, progress=False)
    assert done["computed"] == done["entries"] and {t["tasks"] for t in done["times"]} == {1}
    for eid in ("exp6", "exp5"):
        pooled = ex.run_experiment(eid, profile=ONE_ITERATION, results=tmp_path, n_jobs=1,
                                   progress=False)
        assert pooled.attrs["cached"] == pooled.attrs["chunks"]
        alone = ex.run_experiment(eid, profile=ONE_ITERATION, results=tmp_path / "alone",
                                  n_jobs=1, progress=False)
        assert exact_cells(pooled) == exact_cells(alone)


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


@pytest.mark.parametrize("cpu", [float("nan"), float("inf"), -1.0])
def test_time_by_experiment_refuses_impossible_records(cpu):
    rec = [{"experiment": "exp5", "reading": "inferred", "rows": 2, "cpu_seconds": 1.0},
           {"experiment": "exp1", "reading": "inferred", "rows": 2, "cpu_seconds": cpu}]
    with pytest.raises(ValueError, match="record 1 has cpu_seconds"):
        fill.time_by_experiment(rec)


def test_a_parameter_spelt_as_a_float_keys_the_same_loops():
    a = fill.needed_entries("exp5", "quick")
    b = fill.needed_entries("exp5", "quick", max_iter=100.0)
    assert [e.path for e in a] == [e.path for e in b]


def _read_exp5(profile, seed, results):
    """An analysis that reads Exp 5's results: read-only, so it fails unless they are stored."""
    import os

    from uavwind.core.io import READ_ONLY_ENV
    os.environ[READ_ONLY_ENV] = "1"
    try:
        df = ex.run_experiment("exp5", profile=TINY, seed=seed, results=results, n_jobs=1,
                               progress=False)
    finally:
        del os.environ[READ_ONLY_ENV]
    (results / "exp5_seen.txt").write_text(f"{profile} {seed} {len(df)}")


def _own_run(profile, seed, results):
    """An analysis that reads no experiment."""
    (results / "own.txt").write_text(f"{profile} {seed}")


def _failing(profile, seed, results):
    raise RuntimeError("this analysis fails")


@pytest.mark.slow
def test_analyses_run_in_the_fills_pool_once_what_they_read_is_stored(tmp_path, monkeypatch):
    """`make results` is one process and one pool: the registry's analyses are tasks of the
    fill beside the experiments' entries, each put once the entries of the experiments it
    reads are stored (here, read-only: it fails if run before them), recorded in the times
    as an analysis; with only analyses the same pool runs them, and a failing one fails
    the fill after what finished is kept. An analysis asked for brings what it reads."""
    from uavwind.study import registry

    monkeypatch.setattr(registry, "REGISTRY", dict(registry.REGISTRY))
    registry.computes("reads_exp5", reads=("exp5",))(_read_exp5)
    registry.computes("own", long=True)(_own_run)
    registry.computes("bad")(_failing)
    res = tmp_path / "pool"
    res.mkdir()
    done = fill.fill_cache(["exp6", "reads_exp5", "own"], profile=TINY, results=res, n_jobs=2,
                           progress=False, readings="inferred")
    assert (res / "exp5_seen.txt").read_text().startswith(f"custom {ex.DEFAULT_SEED} ")
    assert (res / "own.txt").exists()
    kinds = [(t["experiment"], t["search"]) for t in done["times"]]
    assert ("reads_exp5", "analysis") in kinds and ("own", "analysis") in kinds
    assert done["computed"] == len(done["times"]) - 2
    # what it reads: exp5's entries, under the readings the book shows exp5 under
    assert {t["experiment"] for t in done["times"]} == {"exp5", "exp6", "reads_exp5", "own"}
    (res / "own.txt").unlink()
    again = fill.fill_cache(["reads_exp5", "own"], profile=TINY, results=res, n_jobs=2,
                            progress=False)
    assert again["computed"] == 0 and len(again["times"]) == 2 and (res / "own.txt").exists()
    with pytest.raises(RuntimeError, match="this analysis fails"):
        fill.fill_cache(["bad", "reads_exp5", "own"], profile=TINY, results=res, n_jobs=2,
                        progress=False)


def test_every_analysis_is_a_task_that_says_what_it_reads():
    """The registry's analyses are the fill's tasks, each once, each naming experiments of
    the registry it reads (an analysis that read one unnamed would run before it is stored)."""
    from uavwind.study.registry import ANALYSES, EXPERIMENTS, REGISTRY, Analysis

    tasks = list(ANALYSES.values())
    assert len({a.id for a in tasks}) == len(tasks) and not set(ANALYSES) & set(EXPERIMENTS)
    assert list(REGISTRY) == [*EXPERIMENTS, *ANALYSES]
    for a in tasks:
        assert isinstance(a, Analysis) and set(a.reads) <= set(EXPERIMENTS), a.id
    assert {"exp1", "exp10"} <= set(ANALYSES["claims"].reads)
    assert {"exp13", "exp11_filter_table", "explore_grid"} <= set(ANALYSES)

@pytest.mark.slow
def test_chunks_that_fly_the_same_loops_are_one_task(tmp_path, monkeypatch):
    """Exp 8's cases of one scenario differ only in what is observed and how noisily: a
    local fill hands each such group to one worker as one task (which flies each loop once,
    uavwind.sim.setting keeping the flights), and stores the rows each case computes alone."""
    from uavwind.sim import setting as st
    from uavwind.study import registry

    keys = []

    class Recorder(_Batch):
        def put(self, key, priority, fn, *args):
            keys.append(key)
            super().put(key, priority, fn, *args)

    monkeypatch.setattr(fill, "_LocalPool", Recorder)
    monkeypatch.setattr(fill, "pin_threads", lambda: None)
    # two of Exp 8's scenarios (their 16 cases) say what all of them would, at a sixth of
    # the cost: each is flown twice below, pooled and alone
    exp8 = registry.EXPERIMENTS["exp8"]

    def two_scenarios(reading):
        cases = exp8.build(reading)
        kept = list(dict.fromkeys(c.labels["scenario"] for c in cases))[:2]
        return [c for c in cases if c.labels["scenario"] in kept]

    monkeypatch.setitem(registry.REGISTRY, "exp8", replace(exp8, build=two_scenarios))
    prof = {**TINY, "loops": 1}
    done = fill.fill_cache(["exp8"], profile=prof, results=tmp_path / "pool", n_jobs=2,
                           readings="inferred", progress=False)
    groups = [k for k in keys if isinstance(k, tuple) and k[0] == "siblings"]
    n_scenarios = len({c.labels["scenario"] for c in ex.get_experiment("exp8").cases()})
    assert len(groups) == len(keys) == n_scenarios < done["entries"]
    assert done["computed"] == done["entries"] == len(done["times"])
    pooled = ex.run_experiment("exp8", profile=prof, results=tmp_path / "pool", n_jobs=1,
                               progress=False)
    assert pooled.attrs["cached"] == pooled.attrs["chunks"]
    monkeypatch.setattr(st, "FLIGHTS_KEPT", 0)  # each case flies its own loops
    monkeypatch.setattr(st, "_FLIGHTS", type(st._FLIGHTS)())
    alone = ex.run_experiment("exp8", profile=prof, results=tmp_path / "alone", n_jobs=1,
                              progress=False)
    assert exact_cells(pooled) == exact_cells(alone)
