"""The result cache: keys, verified reads, atomic writes and per-chunk locks.

This module owns every rule that makes a cached result trustworthy:

* :func:`cache_key` -- a digest of everything that determines a chunk of results
  (setting, seed, loop range, engine, clustering parameters, results version);
* :func:`results_dir` -- the folder a caller names, else ``$UAVWIND_RESULTS``, else the
  user's cache folder (``$XDG_CACHE_HOME/uavwind/results``, by default
  ``~/.cache/uavwind/results``), never a folder inside the installed package (``~``
  expanded; ``make`` names the checkout's ``data/results``);
* :func:`check_writable` -- before any work starts, so a run never computes what it
  cannot keep;
* :func:`read_verified` -- a chunk is trusted only if it parses, its content matches the
  checksum stored with it, it has every column, its stamps (setting key, seed, engine, row
  count) are what the caller expects and its rows are consistent; anything else is moved
  aside as ``*.corrupt`` (never over earlier evidence) with one warning line, and
  recomputed; a file that cannot be *read* is left in place and the run stops;
* :func:`atomic_write` -- a chunk written through :func:`uavwind.core.io.atomic_write`: a
  temporary file with a unique name in the same folder renamed over the target, removed
  again if writing fails (a full disk leaves no orphan);
* :func:`cached` -- all of the above around one chunk, under an exclusive per-chunk lock
  (``fcntl.flock``), so two processes on one results folder compute a chunk once: the
  second waits, then reads the first one's result.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core.io import atomic_write as _write_atomically
from ..core.io import refuse_to_compute
from ..method.baseline import BASELINE_VERSION
from ..method.clustering import DEFAULT_PARAMS

if TYPE_CHECKING:
    from ..sim.setting import Setting

__all__ = ["RESULTS_VERSION", "EPISODE_REQUIRED", "cache_key", "results_dir", "check_writable", "Expected",
           "read_verified", "atomic_write", "chunk_lock", "cached", "CorruptChunkWarning",
           "TransientReadError", "content_digest"]

#: Bump when a change to the library alters results; it is part of every cache key.
#: 2: Dryden filters built with python-control by default (equal to 1e-12, not bit for bit).
RESULTS_VERSION = "2"


class CorruptChunkWarning(UserWarning):
    """A cached chunk failed verification and was moved aside to be recomputed."""


def results_dir(folder: str | os.PathLike | None = None) -> Path:
    """The results folder, by one rule: ``folder`` if given; else ``$UAVWIND_RESULTS`` if set
    and not empty; else the user's cache folder, ``$XDG_CACHE_HOME/uavwind/results`` (by
    default ``~/.cache/uavwind/results``). ``~`` is expanded; an empty ``folder`` is a
    ``ValueError`` (name ``"."`` for the working folder)."""
    if folder is not None:
        if not isinstance(folder, (str, os.PathLike)):
            raise TypeError(f"results must be a path or None, got {type(folder).__name__}")
        if str(folder) == "":
            raise ValueError("results must name a folder, got an empty string (use '.' for "
                             "the working folder, or None for the default)")
        return Path(folder).expanduser()
    env = os.environ.get("UAVWIND_RESULTS")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join("~", ".cache")
    return Path(base).expanduser() / "uavwind" / "results"


def cache_key(setting: Setting, seed: int, start: int, stop: int, engine: str, params: dict,
              extra: dict | None = None) -> str:
    """Digest of everything that determines a chunk of results."""
    fields = {"setting": setting.key(), "seed": seed, "loops": [start, stop], "engine": engine,
              "params": {**DEFAULT_PARAMS, **params}, "version": RESULTS_VERSION,
              "extra": extra}
    if getattr(setting, "baseline", False):  # loops that also run the physics baseline
        fields["baseline"] = BASELINE_VERSION
    blob = json.dumps(fields, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def check_writable(folder) -> Path:
    """Create ``folder`` if needed and prove a file can be written there.

    Raises
    ------
    ValueError
        Naming the folder and the reason (a file in the way, read-only, full disk).
    """
    folder = Path(folder).expanduser()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / f".write-test-{os.getpid()}"
        with open(probe, "wb") as fh:
            fh.write(b"\0" * 4096)
            fh.flush()
            os.fsync(fh.fileno())
        probe.unlink()
    except OSError as exc:
        raise ValueError(f"results folder {str(folder)!r} cannot be written "
                         f"({exc.strerror or exc}); choose another with results= or "
                         f"$UAVWIND_RESULTS") from None
    return folder


@dataclass(frozen=True)
class Expected:
    """What a chunk must hold to be trusted.

    Attributes
    ----------
    setting_key, seed, engine : str, int, str
        The stamps every row carries.
    n_rows : int
        Loops, or CEM samples.
    groups : tuple of int, optional
        The true group (0/1) of each environment: each row's ``labels`` must have this
        length, hold only 0 and 1, and say ``correct`` exactly when they reproduce the groups
        up to a label swap.
    kind : {"loops", "episodes"}
        What a row is: a loop (or CEM sample) of the clustering, or a reported belief of a
        closed-loop episode (:data:`EPISODE_REQUIRED`, and its own consistency rules).
    """

    setting_key: str
    seed: int
    engine: str
    n_rows: int
    groups: tuple = ()
    kind: str = "loops"


#: Columns every chunk holds, with the kinds of their dtypes (numpy ``dtype.kind``).
REQUIRED = {"score": "f", "silhouette": "f", "correct": "b", "n_iter": "iu", "labels": "O",
            "setting_key": "O", "seed": "iu", "engine": "O"}
#: Columns every closed-loop chunk holds (:data:`uavwind.method.closed_loop.EPISODE_COLUMNS`).
EPISODE_REQUIRED = {"episode": "iu", "policy": "O", "test_group": "iu", "time": "f",
                    "p_group_b": "f", "p_true": "f", "predicted": "iu", "correct": "b",
                    "log_loss": "f", "setting_key": "O", "seed": "iu", "engine": "O"}
#: Parquet metadata key of the content digest written with every chunk.
CHECKSUM_KEY = b"uavwind.sha256"


class TransientReadError(OSError):
    """A cached chunk could not be *read* (permission, out of file descriptors, an I/O error):
    the file is left where it is, since it may be sound, and the run stops."""


#: numpy dtype kinds whose ``tolist()`` is Python scalars already (floats, ints, flags): the
#: content digest takes them as they come.
_SCALAR_KINDS = "fiub"


def _plain(v):
    if isinstance(v, np.ndarray):
        if v.dtype.kind in _SCALAR_KINDS:  # nested lists of Python scalars already
            return v.tolist()
        return [_plain(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, (np.generic,)):
        return v.item()
    return v


def _bare(df: pd.DataFrame) -> pd.DataFrame:
    """``df``'s columns without its ``attrs``: pandas deep-copies a frame's ``attrs`` into
    every column it hands out, which was a fifth of the time a cached chunk took to verify."""
    if not df.attrs:
        return df
    out = df.copy(deep=False)
    out.attrs = {}
    return out


def content_digest(df: pd.DataFrame) -> str:
    """SHA-256 of a chunk's content: every column's name, dtype and values, in order (list
    columns as lists, floats by their shortest round-trip repr)."""
    h = hashlib.sha256()
    for col, column in _bare(df).items():
        values = column.tolist()
        if column.dtype.kind not in _SCALAR_KINDS:
            values = [_plain(v) for v in values]
        h.update(json.dumps([str(col), str(column.dtype), values], default=str,
                            allow_nan=True).encode())
    return h.hexdigest()


def _episode_problem(df):
    """Why closed-loop rows are inconsistent (empty string: they are not)."""
    p_b = df["p_group_b"].to_numpy(dtype=float)
    p_true = df["p_true"].to_numpy(dtype=float)
    group = df["test_group"].to_numpy()
    time = df["time"].to_numpy(dtype=float)
    if not (np.all(np.isfinite(time)) and np.all(time > 0)):
        return "report times that are not finite and > 0"
    if np.any(df["episode"].to_numpy() < 0):
        return "a negative episode"
    if not (np.all(np.isfinite(p_b)) and np.all((p_b >= 0) & (p_b <= 1))):
        return "probabilities outside [0, 1]"
    if np.any(np.abs(np.where(group == 1, p_b, 1.0 - p_b) - p_true) > 1e-12):
        return "p_true is not the test group's probability"
    if not np.all(np.isin(group, (0, 1))) or np.any(group != df["episode"].to_numpy() % 2):
        return "a test group other than episode % 2"
    pred = df["predicted"].to_numpy()
    if not np.all(np.isin(pred, (0, 1))):
        return "a predicted group other than 0 or 1"
    if np.any((p_b > 0.5) & (pred != 1)) or np.any((p_b < 0.5) & (pred != 0)):
        return "a predicted group that is not the more probable one"
    if np.any(df["correct"].to_numpy(dtype=bool) != (pred == group)):
        return "a correct flag that contradicts the predicted group"
    loss = df["log_loss"].to_numpy(dtype=float)
    if not np.all(np.isfinite(loss)) or np.any(loss < 0):
        return "log-losses that are negative or not finite"
    sure = p_true > 1e-300
    if np.any(np.abs(loss[sure] + np.log(p_true[sure])) > 1e-9 * np.maximum(1.0, loss[sure])):
        return "log-losses that are not -log(p_true)"
    # p_true at or below 1e-300 (0 where it underflows): -log(p_true) is at least 690.8 nats
    if np.any(loss[~sure] < -math.log(1e-300) * (1 - 1e-9)):
        return "a log-loss below -log(1e-300) for a p_true of at most 1e-300"
    return ""


def _problem(df, expect):
    """Why ``df`` cannot be trusted as ``expect`` (empty string: it can)."""
    df = _bare(df)
    if len(df) != expect.n_rows:
        return f"{len(df)} rows, expected {expect.n_rows}"
    required = EPISODE_REQUIRED if expect.kind == "episodes" else REQUIRED
    for col, kinds in required.items():
        if col not in df.columns:
            return f"no {col} column"
        if df[col].dtype.kind not in kinds:
            return f"column {col} has dtype {df[col].dtype}"
    for col, want in (("setting_key", expect.setting_key), ("seed", expect.seed),
                      ("engine", expect.engine)):
        if not (df[col] == want).all():
            return f"{col} is not {want!r}"
    if expect.kind == "episodes":
        return _episode_problem(df)
    score = df["score"].to_numpy(dtype=float)
    # 100 x silhouette where the loop is grouped correctly (a silhouette may be <= 0), 0 else
    if not np.all(np.isfinite(score)) or score.min() < -100 or score.max() > 100:
        return "scores outside [-100, 100]"
    ok = df["correct"].to_numpy(dtype=bool)
    if np.any(score[~ok] != 0):
        return "a misgrouped loop with a non-zero score"
    sil = df["silhouette"].to_numpy(dtype=float)
    if np.any(np.abs(sil[np.isfinite(sil)]) > 1 + 1e-9):
        return "silhouettes outside [-1, 1]"
    if np.any(np.abs(score[ok] - 100 * sil[ok]) > 1e-6):
        return "scores that are not 100 x silhouette"
    if expect.groups:
        g = np.asarray(expect.groups)
        for i, (labels, correct) in enumerate(zip(df["labels"], ok)):
            lab = np.asarray(_plain(labels))
            if lab.shape != g.shape or not np.all(np.isin(lab, (0, 1))):
                return f"row {i} has labels {lab.tolist()} for {g.size} environments"
            if correct != bool(np.array_equal(lab, g) or np.array_equal(lab, 1 - g)):
                return f"row {i}: its labels contradict its correct flag"
    return ""


def _read_bytes(path):
    """The file's bytes; a failure to read them is a :class:`TransientReadError`."""
    try:
        return path.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # not there (or a file where a folder is)
        return None
    except OSError as exc:
        raise TransientReadError(exc.errno, f"cached chunk {path.name} could not be read "
                                 f"({exc.strerror or exc}); it is left in place: fix the cause "
                                 f"(permissions, open files, the disk) and rerun",
                                 str(path)) from exc


def _parse(blob):
    """``(df, stored digest or None)`` from a chunk's bytes; any failure means damaged."""
    import io

    import pyarrow.parquet as pq

    table = pq.read_table(io.BytesIO(blob))
    meta = table.schema.metadata or {}
    stored = meta.get(CHECKSUM_KEY)
    return table.to_pandas(), (stored.decode() if stored else None)


def _move_aside(path):
    """Rename ``path`` to ``<name>.corrupt`` (``.corrupt.1``, ``.corrupt.2``, ... if taken):
    evidence is never overwritten. Returns the new name."""
    for i in range(10_000):
        aside = path.with_name(path.name + (".corrupt" if i == 0 else f".corrupt.{i}"))
        try:
            os.link(path, aside)  # fails if aside exists: never replaces earlier evidence
        except FileExistsError:
            continue
        except OSError:  # no hard links here: rename if the name is free
            if aside.exists():
                continue
            os.replace(path, aside)
            return aside
        path.unlink()
        return aside
    raise RuntimeError(f"10,000 corrupt copies of {path.name}: clean the folder")


def _legacy(df):
    """True for a chunk written by uavwind 0.1, before chunks carried a checksum."""
    v = df["uavwind_version"].iloc[0] if "uavwind_version" in df.columns and len(df) else ""
    return isinstance(v, str) and v.startswith("0.1.")


def read_verified(path, expect: Expected) -> pd.DataFrame | None:
    """The chunk at ``path`` if it exists and can be trusted, else ``None``.

    Trusted means: it parses, its content matches the SHA-256 stored in its metadata (a
    chunk stamped by uavwind 0.1, before checksums were stored, is checked by the rules
    alone and given its checksum in place; any later chunk without one is untrusted), it has every column with its dtype, its stamps are what
    :class:`Expected` says, and its rows are consistent (scores, silhouettes, labels against
    the correct flag). A damaged or untrusted chunk is renamed ``<name>.corrupt`` (never
    deleted, never overwriting an earlier one: it may be evidence) with one
    :class:`CorruptChunkWarning`, so the caller recomputes it. A chunk that cannot be
    *read* (permissions, file descriptors, I/O) raises :class:`TransientReadError` and is
    left where it is.
    """
    path = Path(path)
    blob = _read_bytes(path)
    if blob is None:
        return None
    try:
        df, stored = _parse(blob)
        if stored is not None and stored != content_digest(df):
            why = "its content does not match its checksum"
        elif stored is None and not _legacy(df):
            why = "no checksum"
        else:
            why = _problem(df, expect)
    except Exception as exc:  # pyarrow raises many types for damaged files
        why = f"unreadable ({type(exc).__name__})"
    if not why:
        if stored is None:  # a sound chunk of 0.1: give it its checksum now, if we may
            with contextlib.suppress(OSError):
                atomic_write(df, path)
        return df
    aside = _move_aside(path)
    warnings.warn(f"cached chunk {path.name} failed verification ({why}): moved to "
                  f"{aside.name} and recomputed", CorruptChunkWarning, stacklevel=3)
    return None


def atomic_write(df: pd.DataFrame, path) -> Path:
    """Write ``df`` to ``path`` (Parquet) all at once, or not at all, with the SHA-256 of
    its content (as it reads back) in the file's metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    digest = content_digest(table.to_pandas())
    meta = {**(table.schema.metadata or {}), CHECKSUM_KEY: digest.encode()}
    table = table.replace_schema_metadata(meta)
    return _write_atomically(path, lambda tmp: pq.write_table(table, tmp))


@contextlib.contextmanager
def chunk_lock(path) -> Iterator[None]:
    """Exclusive lock on ``path``'s chunk for as long as the block runs (``<path>.lock``)."""
    import fcntl

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lock = path.with_name(path.name + ".lock")
    with open(lock, "a") as fh:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


def cached(path, compute: Callable[[], pd.DataFrame], meta: dict,
           expect: Expected) -> tuple[pd.DataFrame, bool]:
    """``(df, from_cache)``: the verified chunk at ``path``, or ``compute()`` stamped with
    ``meta`` and written atomically, all under the chunk's lock. Either way ``df`` is the
    chunk as read from disk, so a first run and a cached run return the same values of the
    same types (a list column comes back as arrays, as Parquet stores it)."""
    with chunk_lock(path):
        df = read_verified(path, expect)
        if df is not None:
            return df, True
        refuse_to_compute(f"the cache entry {Path(path).parent.name}/{Path(path).name}")
        df = compute()
        for k, v in meta.items():
            df[k] = v
        why = _problem(df, expect)
        if why:  # never store what would not be trusted on reading
            raise RuntimeError(f"computed chunk {Path(path).name} is inconsistent: {why}")
        atomic_write(df, path)
        back, _ = _parse(_read_bytes(Path(path)))
        return back, False
