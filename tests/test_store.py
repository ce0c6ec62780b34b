"""The one verified cache (uavwind.core.store): one key recipe, one digest, one atomic write,
one rule for a damaged entry. Its users' own cases are in test_cache.py (result chunks),
test_future_work.py (filter tables), test_explore.py (the grid), test_real_flights.py (memo)."""
import hashlib
import json
import os
import stat
import warnings

import numpy as np
import pandas as pd
import pytest

from uavwind.core import store


def _table():
    return pd.DataFrame({"a": [1.0, np.nan], "s": ["x", "y"], "l": [[1, 2], [3]]},
                        index=pd.Index(["p", "q"], name="k"))


def test_the_key_recipe_is_the_one_the_caches_used_before_it():
    # result chunks and filter tables keep their file names: the 20 hex digits of the SHA-256
    # of the sorted JSON of their fields with the version
    params = {"setting": "abc", "seed": 1, "loops": [0, 50], "extra": None}
    old = hashlib.sha256(json.dumps({**params, "version": "2"}, sort_keys=True,
                                    default=str).encode()).hexdigest()[:20]
    assert store.make_key("loops", params, "2") == old
    assert store.make_key("loops", params, "3") != old
    assert store.make_key("loops", {**params, "seed": 2}, "2") != old


@pytest.mark.parametrize("args, error, word", [
    (("", {}, "1"), ValueError, "kind"), (("a/b", {}, "1"), ValueError, "kind"),
    ((3, {}, "1"), TypeError, "kind"), (("k", [1], "1"), TypeError, "params"),
    (("k", {}, ""), ValueError, "version"), (("k", {"version": 1}, "1"), ValueError, "version")])
def test_make_key_names_what_it_cannot_use(args, error, word):
    with pytest.raises(error, match=word):
        store.make_key(*args)


def test_a_table_and_a_value_round_trip_with_their_digest(tmp_path):
    df = _table()
    df.attrs["note"] = "kept"
    key = store.entry_key("t", {"n": 1}, "1")
    path = store.atomic_write(tmp_path / "t.parquet", df, key=key)
    back = store.read_entry(path, key)
    assert back.drop(columns="l").equals(df.drop(columns="l")) and back.index.name == "k"
    assert [x.tolist() for x in back["l"]] == [[1, 2], [3]]  # Parquet hands lists as arrays
    assert back.attrs == {"note": "kept"}
    assert store.content_digest(back) == store.content_digest(df)
    other = df.copy()
    other.index = pd.Index(["p", "r"], name="k")  # the index is content
    assert store.content_digest(other) != store.content_digest(df)
    value = {"b": [1, 2.5], "a": {"c": None}}
    path = store.atomic_write(tmp_path / "v.json", value, key=key)
    assert store.read_entry(path, key) == value
    doc = json.loads(path.read_text())
    assert doc["uavwind.key"] == key and doc["uavwind.sha256"] == store.entry_digest(value, key)
    assert store.entry_digest(value, key) != store.entry_digest(value, key.replace("1", "2"))


def test_atomic_write_takes_the_path_first_and_refuses_what_it_cannot_write(tmp_path):
    store.atomic_write(tmp_path / "raw.txt", "text")
    assert (tmp_path / "raw.txt").read_text() == "text"
    with pytest.raises(TypeError, match="content"):
        store.atomic_write(tmp_path / "x.json", 3.5)
    with pytest.raises(TypeError, match="content"):
        store.atomic_write(tmp_path / "x.json", {"nan": float("nan")}, key="k")
    with pytest.raises(TypeError, match="key"):  # an entry without what it was computed for
        store.atomic_write(tmp_path / "x.json", {"a": 1})
    with pytest.raises(TypeError, match="key"):
        store.atomic_write(tmp_path / "x.txt", "text", key="k")
    os.mkfifo(tmp_path / "pipe")
    with pytest.raises(ValueError, match="out"):
        store.atomic_write(tmp_path / "pipe", "x", name="out")
    assert stat.S_ISFIFO(os.lstat(tmp_path / "pipe").st_mode)  # never replaced
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pipe", "raw.txt"]  # no orphan


def _counted(value):
    calls = []

    def compute():
        calls.append(1)
        return value.copy() if hasattr(value, "copy") else dict(value)
    return compute, calls


@pytest.mark.parametrize("fmt", ["parquet", "json"])
def test_get_or_compute_computes_once_and_recomputes_a_tampered_entry(tmp_path, fmt):
    value = _table() if fmt == "parquet" else {"controls": [1], "loops": {}}
    compute, calls = _counted(value)
    kw = dict(folder=tmp_path, version="1", fmt=fmt, name="toy", what="toy table")
    first = store.get_or_compute("things", {"n": 1}, compute, **kw)
    again = store.get_or_compute("things", {"n": 1}, compute, **kw)
    assert calls == [1] and (again.equals(first) if fmt == "parquet" else again == first)
    (path,) = (tmp_path / "things").glob(f"toy-*.{fmt}")
    if fmt == "parquet":  # a value changed, the digest kept
        import pyarrow as pa
        import pyarrow.parquet as pq
        t = pq.read_table(path)
        edited = pa.Table.from_pandas(t.to_pandas().assign(a=[9.0, 9.0]))
        pq.write_table(edited.replace_schema_metadata(
            {**edited.schema.metadata, store.DIGEST_KEY: t.schema.metadata[store.DIGEST_KEY],
             store.KEY_KEY: t.schema.metadata[store.KEY_KEY]}),
            path)
    else:
        doc = json.loads(path.read_text())
        doc["content"]["controls"] = [2]
        path.write_text(json.dumps(doc))
    with pytest.warns(store.CorruptEntryWarning, match=f"toy table things/{path.name} not "
                                                       f"trusted.*checksum.*moved to"):
        fixed = store.get_or_compute("things", {"n": 1}, compute, **kw)
    assert calls == [1, 1] and (fixed.equals(first) if fmt == "parquet" else fixed == first)
    assert path.with_name(path.name + ".corrupt").exists()


@pytest.mark.parametrize("what", ["fifo", "folder", "link to fifo"])
def test_an_entry_that_is_not_a_regular_file_is_moved_aside_unopened(
        tmp_path, what, deadline, not_a_regular_file):
    compute, calls = _counted({"v": 1})
    kw = dict(folder=tmp_path, version="1", fmt="json")
    store.get_or_compute("k", {}, compute, **kw)
    (path,) = (tmp_path / "k").glob("*.json")
    not_a_regular_file(path, what)
    with deadline(20), pytest.warns(store.CorruptEntryWarning, match=path.name):
        assert store.get_or_compute("k", {}, compute, **kw) == {"v": 1}
    assert calls == [1, 1] and path.is_file() and not path.is_symlink()
    assert os.path.lexists(path.with_name(path.name + ".corrupt"))


def test_the_callers_rule_decides_and_is_applied_to_what_is_computed(tmp_path):
    def verify(v):
        return "" if v.get("ok") else "not ok"
    with pytest.raises(RuntimeError, match="inconsistent: not ok"):
        store.get_or_compute("k", {}, lambda: {"ok": False}, verify, tmp_path, version="1",
                             fmt="json")
    assert not list((tmp_path / "k").glob("*.json"))  # never stored
    assert store.get_or_compute("k", {}, lambda: {"ok": True}, verify, tmp_path, version="1",
                                fmt="json") == {"ok": True}
    with pytest.raises(TypeError, match="must compute a pandas DataFrame"):
        store.get_or_compute("k", {"p": 1}, lambda: {"a": 1}, folder=tmp_path, version="1")


def test_an_entry_without_a_digest_or_a_key_is_never_trusted(tmp_path):
    # one trust rule: no caller can vouch for an entry of before (read_entry has no legacy=)
    path = tmp_path / "k" / "e.parquet"
    path.parent.mkdir()
    key = store.entry_key("k", {}, "1")
    pd.DataFrame({"a": [1.0]}).to_parquet(path)  # no digest
    with pytest.warns(store.CorruptEntryWarning, match="no checksum"):
        assert store.read_entry(path, key) is None
    import pyarrow as pa
    import pyarrow.parquet as pq
    df = pd.DataFrame({"a": [1.0]})  # the digest of before: of the content alone, no key
    t = pa.Table.from_pandas(df)
    pq.write_table(t.replace_schema_metadata({**t.schema.metadata, store.DIGEST_KEY:
                                              store.content_digest(df).encode()}), path)
    with pytest.warns(store.CorruptEntryWarning, match="no key"):
        assert store.read_entry(path, key) is None
    with pytest.raises(TypeError, match="legacy"):
        store.read_entry(path, key, legacy=lambda df: True)
    with pytest.raises(TypeError, match="key"):
        store.read_entry(path)


@pytest.mark.parametrize("fmt", ["parquet", "json"])
def test_two_entries_swapped_or_copied_over_each_other_are_refused_and_recomputed(
        tmp_path, fmt):
    """Issue 68: two `analyses/` entries swapped with `mv` returned each other's tables; a
    chunk of loops 0-49 copied over loops 50-99 was trusted. Each entry holds its key."""
    def table(n):
        return pd.DataFrame({"a": [float(n)]}) if fmt == "parquet" else {"a": n}
    kw = dict(folder=tmp_path, version="1", fmt=fmt, name="toy")
    first = store.get_or_compute("things", {"n": 1}, lambda: table(1), **kw)
    store.get_or_compute("things", {"n": 2}, lambda: table(2), **kw)
    p1, p2 = (tmp_path / "things" / f"toy-{store.make_key('things', {'n': n}, '1')}.{fmt}"
              for n in (1, 2))
    tmp = p1.with_name("swap")
    os.replace(p1, tmp)
    os.replace(p2, p1)
    os.replace(tmp, p2)
    for n, path in ((1, p1), (2, p2)):
        with pytest.warns(store.CorruptEntryWarning, match=f"{path.name}.*another entry"):
            back = store.get_or_compute("things", {"n": n}, lambda n=n: table(n), **kw)
        assert (back["a"].tolist() == [float(n)]) if fmt == "parquet" else back == {"a": n}
    import shutil
    shutil.copyfile(p1, p2)  # a copy over another's name
    with pytest.warns(store.CorruptEntryWarning, match="another entry"):
        assert store.read_entry(p2, store.entry_key("things", {"n": 2}, "1")) is None
    assert store.read_entry(p1, store.entry_key("things", {"n": 1}, "1")) is not None
    assert first is not None


@pytest.mark.parametrize("kw, error, word", [
    ({"fmt": "csv"}, ValueError, "fmt"), ({"name": "a b"}, ValueError, "name"),
    ({"kind": ".."}, ValueError, "kind"), ({"verify": 3}, TypeError, "verify"),
    ({"compute": None}, TypeError, "compute"), ({"folder": ""}, ValueError, "results"),
    ({"what": 3}, TypeError, "what")])
def test_get_or_compute_names_what_it_cannot_use(tmp_path, kw, error, word):
    args = {"kind": "k", "key_params": {}, "compute": lambda: pd.DataFrame({"a": [1]}),
            "folder": tmp_path, "version": "1", **kw}
    with pytest.raises(error, match=word):
        store.get_or_compute(**args)


@pytest.mark.parametrize("meanwhile", ["moved aside", "moved aside and recomputed"])
def test_readers_racing_over_one_damaged_entry_move_it_aside_once(tmp_path, monkeypatch,
                                                                  meanwhile):
    """Issue 68: four processes reading one damaged entry: three raised FileNotFoundError
    (each moved it aside after the first had). Here another reader acts between this one's
    read and its move: this one then leaves the path be (never moving a sound entry that a
    writer put there meanwhile), raises nothing and warns nothing (the first reader warned)."""
    key = store.entry_key("k", {}, "1")
    path = tmp_path / "k" / "e.json"
    path.parent.mkdir()
    path.write_text("damaged")
    real = store._parse

    def another_reader_first(blob, fmt):
        monkeypatch.setattr(store, "_parse", real)
        with pytest.warns(store.CorruptEntryWarning):
            assert store.read_entry(path, key) is None  # the other reader moves it aside
        if meanwhile == "moved aside and recomputed":
            store.atomic_write(path, {"v": 1}, key=key)
        return real(blob, fmt)
    monkeypatch.setattr(store, "_parse", another_reader_first)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert store.read_entry(path, key) is None
    assert [p.name for p in sorted(path.parent.iterdir())] == (
        ["e.json", "e.json.corrupt"] if "recomputed" in meanwhile else ["e.json.corrupt"])
    if "recomputed" in meanwhile:
        assert store.read_entry(path, key) == {"v": 1}


@pytest.mark.parametrize("what", ["fifo", "folder"])
def test_a_lock_that_is_not_a_regular_file_is_moved_aside_not_waited_on(
        tmp_path, what, deadline, not_a_regular_file):
    """Issue 68: a named pipe in place of a `.lock` hung file_lock; a folder there raised
    IsADirectoryError. Either is moved aside, with a warning, and a lock file made."""
    compute = lambda: {"v": 1}  # noqa: E731
    kw = dict(folder=tmp_path, version="1", fmt="json")
    store.get_or_compute("k", {}, compute, **kw)
    (path,) = (tmp_path / "k").glob("*.json")
    lock = path.with_name(path.name + ".lock")
    path.unlink()
    not_a_regular_file(lock, what)
    said = {"fifo": "a named pipe", "folder": "a folder"}[what]
    with deadline(10), pytest.warns(store.CorruptEntryWarning, match=f"{lock.name} is {said}"):
        assert store.get_or_compute("k", {}, compute, **kw) == {"v": 1}
    assert lock.is_file() and os.path.lexists(lock.with_name(lock.name + ".corrupt"))
    not_a_regular_file(lock, what)
    with deadline(10), pytest.warns(store.CorruptEntryWarning), store.file_lock(lock, wait=1) \
            as held:
        assert held and lock.is_file()


def test_an_empty_uavwind_results_is_a_mistake_named(monkeypatch):
    """Issue 68: UAVWIND_RESULTS='' silently meant the user's cache folder."""
    monkeypatch.setenv("UAVWIND_RESULTS", "")
    with pytest.raises(ValueError, match="UAVWIND_RESULTS"):
        store.results_dir()
    with pytest.raises(ValueError, match="UAVWIND_RESULTS"):
        store.get_or_compute("k", {}, lambda: {"v": 1}, version="1", fmt="json")
