"""The result cache: keys, verified reads, atomic writes, locks."""
import os
import shutil
import threading
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind import study as ex
from uavwind.core import store
from uavwind.study import cache, runner
from helpers import exact_cells


TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


RUN = dict(profile=TINY, n_jobs=1, progress=False, cases=[0])


def _chunks(folder):
    return sorted((folder / "loops").glob("*.parquet"))


@pytest.fixture(scope="module")
def exp5_computed(tmp_path_factory):
    """Exp 5 at TINY, computed once: {"case0": (folder, rows of run_experiment(**RUN))} and
    {"all": folder with both cases' chunks}. Tests copy a folder, never write into it."""
    one = tmp_path_factory.mktemp("exp5_case0")
    first = ex.run_experiment("exp5", results=one, **RUN)
    both = tmp_path_factory.mktemp("exp5_all")
    shutil.copytree(one, both, dirs_exist_ok=True)
    ex.run_experiment("exp5", results=both, profile=TINY, n_jobs=1, progress=False)
    return {"case0": (one, first), "all": both}


def _copy_of(folder, dest):
    shutil.copytree(folder, dest, dirs_exist_ok=True, ignore=shutil.ignore_patterns("*.lock"))


@pytest.mark.parametrize("damage", [
    lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]),  # truncated
    lambda p: p.write_bytes(b""),                                        # empty
    lambda p: p.write_bytes(np.random.default_rng(0).bytes(3000)),       # random bytes
    lambda p: pd.read_parquet(p).iloc[:-1].to_parquet(p),                # a dropped row
    lambda p: pd.read_parquet(p).assign(score=999.0).to_parquet(p),      # impossible score
    lambda p: pd.read_parquet(p).assign(seed=7).to_parquet(p),           # another seed
])
def test_a_damaged_chunk_is_moved_aside_and_recomputed(tmp_path, damage, exp5_computed):
    folder, first = exp5_computed["case0"]
    _copy_of(folder, tmp_path)
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


def test_a_chunk_copied_over_another_is_detected(tmp_path, exp5_computed):
    _copy_of(exp5_computed["all"], tmp_path)
    a, b = _chunks(tmp_path)
    b.write_bytes(a.read_bytes())
    with pytest.warns(cache.CorruptChunkWarning, match="another entry"):
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
    import pyarrow.parquet as pq

    def full(table, path, **kw):
        with open(path, "wb") as fh:
            fh.write(b"PAR1 partial")
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(pq, "write_table", full)
    with pytest.raises(OSError, match="No space"):
        store.atomic_write(tmp_path / "x.parquet", pd.DataFrame({"score": [1.0]}), key="k")
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
    expect = cache.Expected("k", 1, "fast", 1, key="chunk k")
    meta = {"setting_key": "k", "seed": 1, "engine": "fast"}
    calls = []

    def compute():
        calls.append(threading.get_ident())
        time.sleep(0.5)
        return pd.DataFrame({"score": [50.0], "silhouette": [0.5], "correct": [True],
                             "n_iter": [3], "labels": [[0, 0, 1]]})
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


def test_a_correct_loop_with_a_negative_silhouette_is_cached(tmp_path):
    path = tmp_path / "loops" / "c.parquet"
    expect = cache.Expected("k", 1, "fast", 2, key="chunk k")
    rows = pd.DataFrame({"score": [-12.5, 0.0], "silhouette": [-0.125, 0.4],
                         "correct": [True, False], "n_iter": [3, 4],
                         "labels": [[0, 0, 1], [0, 1, 1]]})
    df, hit = cache.cached(path, lambda: rows.copy(), {"setting_key": "k", "seed": 1,
                                                       "engine": "fast"}, expect)
    assert not hit and cache.read_verified(path, expect) is not None
    from uavwind.core.stats import correct_share
    assert correct_share(df) == 0.5  # the correct column, not score > 0


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
    assert exact_cells(first) == exact_cells(again)


# --------------------------------------------------------------------------- #
# nothing lost, nothing trusted that should not be
# --------------------------------------------------------------------------- #
def _one_chunk(tmp_path, computed):
    _copy_of(computed["case0"][0], tmp_path)
    (path,) = _chunks(tmp_path)
    return path


@pytest.mark.parametrize("edit, keep, why", [
    # score and silhouette edited consistently: only the checksum can tell
    (lambda d: d.assign(score=d["score"] * 0.5, silhouette=d["silhouette"] * 0.5), True,
     "checksum"),
    (lambda d: d.drop(columns=["n_iter"]), True, "checksum"),
    (lambda d: d.drop(columns=["n_iter"]), False, "no checksum"),
    # issue 68: a chunk claiming uavwind 0.1 skipped the digest (rewritten with plain pandas,
    # one score changed to 99.9: trusted); there is no path without a digest now
    (lambda d: d.assign(uavwind_version="0.1.0",
                        score=[99.9] + d["score"].tolist()[1:],
                        silhouette=[0.999] + d["silhouette"].tolist()[1:],
                        correct=[True] + d["correct"].tolist()[1:]), False, "no checksum"),
    (lambda d: d.assign(uavwind_version="0.1.0"), False, "no checksum"),
])
def test_an_edited_chunk_is_caught(tmp_path, edit, keep, why, exp5_computed, rewrite_parquet):
    path = _one_chunk(tmp_path, exp5_computed)
    rewrite_parquet(path, edit, keep)
    with pytest.warns(cache.CorruptChunkWarning, match=why):
        df = ex.run_experiment("exp5", results=tmp_path, **RUN)
    assert df.attrs["cached"] == 0  # recomputed
    assert path.with_name(path.name + ".corrupt").exists()


def test_a_chunk_copied_over_another_loop_range_is_refused_and_recomputed(tmp_path):
    """Issue 68: a chunk of loops 0-49 copied over loops 50-99 was trusted (same setting,
    seed and engine stamps, same row count): the chunk holds its loop range in its key."""
    prof = {**TINY, "loops": 4}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runner, "CHUNK", 2)
        first = ex.run_experiment("exp5", results=tmp_path, **{**RUN, "profile": prof})
        low, high = sorted(_chunks(tmp_path))  # loops 0-1 and 2-3 of case 0
        assert "-0000-0002-" in low.name and "-0002-0004-" in high.name
        shutil.copyfile(low, high)
        with pytest.warns(cache.CorruptChunkWarning, match=f"{high.name}.*another entry"):
            again = ex.run_experiment("exp5", results=tmp_path, **{**RUN, "profile": prof})
    assert again.attrs["cached"] == 1 and exact_cells(again) == exact_cells(first)
    assert high.with_name(high.name + ".corrupt").exists()


def test_a_second_corrupt_copy_keeps_the_first(tmp_path, exp5_computed):
    path = _one_chunk(tmp_path, exp5_computed)
    for _ in range(2):
        path.write_bytes(b"PAR1 damaged")
        with pytest.warns(cache.CorruptChunkWarning):
            ex.run_experiment("exp5", results=tmp_path, **RUN)
    kept = sorted(p.name for p in path.parent.iterdir() if ".corrupt" in p.name)
    assert kept == [path.name + ".corrupt", path.name + ".corrupt.1"]


def test_a_chunk_that_cannot_be_read_is_left_in_place_and_nothing_is_recomputed(
        tmp_path, monkeypatch, exp5_computed):
    import errno
    from pathlib import Path

    path = _one_chunk(tmp_path, exp5_computed)
    good = path.read_bytes()
    real = os.open

    def no_fds(file, *args, **kwargs):
        if Path(file) == path:
            raise OSError(errno.EMFILE, "Too many open files")
        return real(file, *args, **kwargs)
    monkeypatch.setattr(os, "open", no_fds)
    monkeypatch.setattr(runner, "random_search", lambda *a, **k: pytest.fail("recomputed"))
    with pytest.raises(cache.TransientReadError, match="left in place"):
        ex.run_experiment("exp5", results=tmp_path, **RUN)
    monkeypatch.setattr(os, "open", real)
    assert path.read_bytes() == good and not any(".corrupt" in p.name
                                                 for p in path.parent.iterdir())


@pytest.mark.parametrize("what", ["fifo", "folder", "link to fifo"])
def test_a_chunk_that_is_not_a_regular_file_is_moved_aside_unopened_and_recomputed(
        tmp_path, what, exp5_computed, deadline, not_a_regular_file):
    """A named pipe in place of a chunk hung the read for ever (issue 45): it, a folder, or a
    symlink to a pipe is damaged, renamed aside (kept, never opened) and recomputed."""
    import stat

    path = _one_chunk(tmp_path, exp5_computed)
    not_a_regular_file(path, what)
    with deadline(60), pytest.warns(cache.CorruptChunkWarning, match=path.name):
        df = ex.run_experiment("exp5", results=tmp_path, **RUN)
    assert df.attrs["cached"] == 0
    pd.testing.assert_frame_equal(exp5_computed["case0"][1], df)
    aside = path.with_name(path.name + ".corrupt")
    mode = os.lstat(aside).st_mode
    assert {"fifo": stat.S_ISFIFO, "folder": stat.S_ISDIR, "link to fifo": stat.S_ISLNK}[what](mode)
    assert path.is_file() and not path.is_symlink()  # the recomputed chunk, a regular file


def test_a_complete_cache_in_a_read_only_folder_is_read(tmp_path, monkeypatch, exp5_computed):
    _copy_of(exp5_computed["all"], tmp_path)
    monkeypatch.setattr(cache, "check_writable", lambda f: pytest.fail("checked writability"))
    monkeypatch.setattr(runner, "check_writable", lambda f: pytest.fail("checked writability"))
    df = ex.run_experiment("exp5", results=tmp_path, **RUN)
    assert df.attrs["cached"] == 1
    done = ex.fill_cache("exp5", profile=RUN["profile"], results=tmp_path, n_jobs=1,
                         progress=False, readings="inferred")
    assert done["computed"] == 0


@pytest.mark.parametrize("results", ["", 3])
def test_an_empty_or_wrong_results_folder_is_refused(results):
    with pytest.raises((ValueError, TypeError), match="results"):
        cache.results_dir(results)


def test_the_default_results_folder_is_the_user_cache_never_the_package(tmp_path,
                                                                       monkeypatch):
    monkeypatch.delenv("UAVWIND_RESULTS", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.results_dir() == tmp_path / "xdg" / "uavwind" / "results"
    for empty in ("", "  "):  # issue 68: silently the user's cache folder; now a mistake named
        monkeypatch.setenv("UAVWIND_RESULTS", empty)
        with pytest.raises(ValueError, match="UAVWIND_RESULTS must name a folder"):
            cache.results_dir()
    assert cache.results_dir(tmp_path) == tmp_path  # a named folder needs no variable
    monkeypatch.delenv("UAVWIND_RESULTS")
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert cache.results_dir() == tmp_path / ".cache" / "uavwind" / "results"
    import uavwind
    assert Path(uavwind.__file__).parent not in cache.results_dir().parents


# --------------------------------------------------------------------------- #
# closed-loop chunks forged with a recomputed checksum (issue 33)
# --------------------------------------------------------------------------- #
def _episode_rows():
    from uavwind.method.closed_loop.belief import Belief

    rows = []
    for episode, d in enumerate([0.3, -2.0, 800.0, -800.0]):
        group = episode % 2
        p0 = float(1 / (1 + np.exp(min(d, 700.0)))) if d < 700 else 0.0
        b = Belief(p=np.array([p0, 1 - p0]), log_odds=d, weights=np.ones(4) / 4, spread=1.0)
        rows.append({"episode": episode, "policy": "greedy", "test_group": group,
                     "time": 1.0, "p_group_b": float(b.p[1]), "p_true": float(b.p[group]),
                     "predicted": b.predicted, "correct": b.predicted == group,
                     "log_loss": b.log_loss(group), "setting_key": "k", "seed": 0,
                     "engine": "none"})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("forgery", ["p_true 0, log_loss 0", "time NaN", "time 0",
                                     "predicted the less probable", "negative episode"])
def test_a_forged_closed_loop_chunk_is_moved_aside_and_recomputed(tmp_path, forgery):
    good = _episode_rows()
    expect = cache.Expected("k", 0, "none", len(good), kind="episodes", key="chunk k")
    assert cache._problem(good, expect) == ""
    bad = good.copy()
    if forgery == "p_true 0, log_loss 0":
        row = int(np.flatnonzero(bad["p_true"] == 0.0)[0])
        bad.loc[row, "log_loss"] = 0.0
    elif forgery == "time NaN":
        bad.loc[1, "time"] = np.nan
    elif forgery == "time 0":
        bad.loc[1, "time"] = 0.0
    elif forgery == "predicted the less probable":
        bad.loc[0, "predicted"] = 1 - bad.loc[0, "predicted"]
        bad.loc[0, "correct"] = bad.loc[0, "predicted"] == bad.loc[0, "test_group"]
    else:
        bad["episode"] = bad["episode"] - 2
        bad["test_group"] = bad["episode"] % 2
        bad["p_true"] = np.where(bad["test_group"] == 1, bad["p_group_b"], 1 - bad["p_group_b"])
        bad["correct"] = bad["predicted"] == bad["test_group"]
    path = tmp_path / "chunk.parquet"
    store.atomic_write(path, bad, key=expect.key)  # a forgery: its key and checksum right
    with pytest.warns(cache.CorruptChunkWarning):
        assert cache.read_verified(path, expect) is None
    assert not path.exists() and (tmp_path / "chunk.parquet.corrupt").exists()
    df, hit = cache.cached(path, lambda: good.drop(columns=["setting_key", "seed", "engine"]),
                           {"setting_key": "k", "seed": 0, "engine": "none"}, expect)
    assert not hit and len(df) == len(good)


def test_the_content_digest_of_numbers_is_what_it_was_before_its_fast_path():
    # numeric and flag columns skip the per-value conversion (they come out of tolist() as
    # Python scalars already): every cached chunk's stored checksum must still match
    import hashlib
    import json

    def reference(df):  # the digest as first written
        h = hashlib.sha256()
        for col in df.columns:
            values = [store.plain(v) for v in df[col].tolist()]
            h.update(json.dumps([str(col), str(df[col].dtype), values], default=str,
                                allow_nan=True).encode())
        return h.hexdigest()

    df = pd.DataFrame({"f": [0.1, np.nan, np.inf, -0.0, 1e-310], "i": np.arange(5),
                       "u": np.arange(5, dtype=np.uint8), "b": [True, False] * 2 + [True],
                       "s": list("abcde"), "a": [np.arange(3.0) / 7] * 5,
                       "f32": np.linspace(0, 1, 5, dtype=np.float32)})
    nested = np.empty(5, dtype=object)  # a list<list<float>> column as pyarrow returns it
    for i in range(5):
        rows = np.empty(2, dtype=object)
        rows[0], rows[1] = np.arange(3.0) * i, np.array([np.nan, 1e-310, -0.0])
        nested[i] = rows
    df["nested"] = nested
    df["ints2d"] = [np.arange(6).reshape(2, 3)] * 5
    assert cache.content_digest(df) == reference(df)


def test_a_chunks_digest_and_checks_ignore_its_attrs_and_leave_them(exp5_computed):
    """Verification reads columns without the frame's attrs (pandas deep-copies them into
    every column): same digest with or without them, and the frame keeps its own."""
    (path,) = _chunks(exp5_computed["case0"][0])
    df = pd.read_parquet(path)
    assert df.attrs  # the chunks carry their summary in attrs
    attrs = dict(df.attrs)
    plain = df.copy()
    plain.attrs = {}
    assert cache.content_digest(df) == cache.content_digest(plain)
    assert df.attrs == attrs
    edited = df.copy()
    edited.loc[0, "score"] = edited.loc[0, "score"] + 1
    assert cache.content_digest(edited) != cache.content_digest(df)
