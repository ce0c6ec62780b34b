"""The result chunks of the experiments: their keys, what a trusted chunk holds, and the lock.

This module owns what is particular to a chunk of loops (or CEM samples, or closed-loop
episodes); everything else of its storage is :mod:`uavwind.core.store`'s, the one verified
cache of the project:

* :func:`cache_key` and :func:`chunk_key` -- a chunk's file name and what it was computed for,
  by the store's recipes (:func:`~uavwind.core.store.make_key`,
  :func:`~uavwind.core.store.entry_key`), from everything that determines it (setting, seed,
  loop range, engine, clustering parameters) and :data:`RESULTS_VERSION`;
* :func:`check_writable` -- before any work starts, so a run never computes what it
  cannot keep;
* :class:`Expected` and its rules -- a chunk is trusted only if, beyond the store's one rule
  (a regular file that parses, holding the key it was asked for under a digest that matches
  it and its content: a chunk copied over another's name is not), it has every column, its
  stamps (setting key, seed, engine, row count) are what the caller expects and its rows are
  consistent and in range; there is no rule of its own for chunks of before (uavwind 0.1's,
  without a digest, are recomputed);
* :func:`read_verified` and :func:`cached` -- the store's one damaged-entry rule
  (:func:`~uavwind.core.store.read_entry`: moved aside as ``*.corrupt``, never deleted, one
  warning naming the file, recomputed) and its locked read-compute-write
  (:func:`~uavwind.core.store.fill_entry`) applied to a chunk at the path the runner gives.

:func:`results_dir`, :func:`content_digest`, :data:`CHECKSUM_KEY`, :func:`chunk_lock`,
:class:`CorruptChunkWarning` and :class:`TransientReadError` are the store's, under the names
this module has always offered.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core import store
from ..core.store import DIGEST_KEY as CHECKSUM_KEY
from ..core.store import CorruptEntryWarning as CorruptChunkWarning
from ..core.store import (TransientReadError, content_digest, entry_key, make_key, plain,
                          results_dir)
from ..core.store import entry_lock as chunk_lock
from ..method.baseline import BASELINE_VERSION
from ..method.clustering import DEFAULT_PARAMS

if TYPE_CHECKING:
    from ..sim.setting import Setting

__all__ = ["RESULTS_VERSION", "EPISODE_REQUIRED", "CHECKSUM_KEY", "cache_key", "chunk_key",
           "results_dir",
           "check_writable", "Expected", "read_verified", "chunk_lock", "cached",
           "CorruptChunkWarning", "TransientReadError", "content_digest"]

#: Bump when a change to the library alters results; it is part of every cache key.
#: 2: Dryden filters built with python-control by default (equal to 1e-12, not bit for bit).
RESULTS_VERSION = "2"


def _fields(setting, seed, start, stop, engine, params, extra):
    fields = {"setting": setting.key(), "seed": seed, "loops": [start, stop], "engine": engine,
              "params": {**DEFAULT_PARAMS, **params}, "extra": extra}
    if getattr(setting, "baseline", False):  # loops that also run the physics baseline
        fields["baseline"] = BASELINE_VERSION
    return fields


def cache_key(setting: Setting, seed: int, start: int, stop: int, engine: str, params: dict,
              extra: dict | None = None) -> str:
    """Digest of everything that determines a chunk of results (its file name)."""
    # the runner files the chunk (loops/ or the experiment's folder): the kind names a folder
    # and does not enter the digest, so the chunks cached before the store keep their names
    return make_key("loops", _fields(setting, seed, start, stop, engine, params, extra),
                    RESULTS_VERSION)


def chunk_key(setting: Setting, seed: int, start: int, stop: int, engine: str, params: dict,
              extra: dict | None = None) -> str:
    """What a chunk was computed for (:func:`~uavwind.core.store.entry_key`, of the fields
    :func:`cache_key` digests): stored in the chunk and checked on every read, so a chunk of
    loops 0-49 copied over loops 50-99 (or another setting's, seed's) is refused."""
    return entry_key("loops", _fields(setting, seed, start, stop, engine, params, extra),
                     RESULTS_VERSION)


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
    key : str
        What the chunk was computed for (:func:`chunk_key`), keyword only: the chunk must hold
        exactly this key.
    """

    setting_key: str
    seed: int
    engine: str
    n_rows: int
    groups: tuple = ()
    kind: str = "loops"
    key: str = field(kw_only=True)

    def __post_init__(self):
        if not isinstance(self.key, str) or not self.key:
            raise TypeError(f"key must be what the chunk was computed for (chunk_key), a "
                            f"non-empty str, got {self.key!r}")


#: Columns every chunk holds, with the kinds of their dtypes (numpy ``dtype.kind``).
REQUIRED = {"score": "f", "silhouette": "f", "correct": "b", "n_iter": "iu", "labels": "O",
            "setting_key": "O", "seed": "iu", "engine": "O"}
#: Columns every closed-loop chunk holds (:data:`uavwind.method.closed_loop.EPISODE_COLUMNS`).
EPISODE_REQUIRED = {"episode": "iu", "policy": "O", "test_group": "iu", "time": "f",
                    "p_group_b": "f", "p_true": "f", "predicted": "iu", "correct": "b",
                    "log_loss": "f", "setting_key": "O", "seed": "iu", "engine": "O"}
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
    if not isinstance(df, pd.DataFrame):
        return f"a {type(df).__name__}, not a table"
    if df.attrs:  # pandas deep-copies attrs into every column it hands out: drop them here
        df = df.copy(deep=False)
        df.attrs = {}
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
            lab = np.asarray(plain(labels))
            if lab.shape != g.shape or not np.all(np.isin(lab, (0, 1))):
                return f"row {i} has labels {lab.tolist()} for {g.size} environments"
            if correct != bool(np.array_equal(lab, g) or np.array_equal(lab, 1 - g)):
                return f"row {i}: its labels contradict its correct flag"
    return ""


def read_verified(path, expect: Expected) -> pd.DataFrame | None:
    """The chunk at ``path`` if it exists and can be trusted, else ``None``
    (:func:`uavwind.core.store.read_entry` with the rules of :class:`Expected`).

    Trusted means: it is a regular file, it parses, it holds ``expect.key`` and a digest that
    matches that key and its content (a chunk without either, whatever version it claims, or
    one copied from another chunk's name, is untrusted), it has every column with its dtype,
    its stamps are what :class:`Expected` says, and its rows are consistent (scores,
    silhouettes, labels against the correct flag). A damaged or untrusted chunk is renamed ``<name>.corrupt`` (never deleted, never
    overwriting an earlier one: it may be evidence) with one :class:`CorruptChunkWarning`,
    so the caller recomputes it. A chunk that cannot be *read* (permissions, file
    descriptors, I/O) raises :class:`TransientReadError` and is left where it is.
    """
    if not isinstance(expect, Expected):
        raise TypeError(f"expect must be an Expected, got {type(expect).__name__}")
    return store.read_entry(path, expect.key, lambda df: _problem(df, expect),
                            what="cache entry")


def cached(path, compute: Callable[[], pd.DataFrame], meta: dict,
           expect: Expected) -> tuple[pd.DataFrame, bool]:
    """``(df, from_cache)``: the verified chunk at ``path``, or ``compute()`` stamped with
    ``meta`` and written atomically, all under the chunk's lock
    (:func:`uavwind.core.store.fill_entry`). Either way ``df`` is the chunk as read from
    disk, so a first run and a cached run return the same values of the same types (a list
    column comes back as arrays, as Parquet stores it); a computed chunk that its own rules
    would not trust is never stored (``RuntimeError``)."""
    if not isinstance(expect, Expected):
        raise TypeError(f"expect must be an Expected, got {type(expect).__name__}")

    def stamped():
        df = compute()
        if not isinstance(df, pd.DataFrame):
            raise TypeError(f"compute must return a pandas DataFrame, got {type(df).__name__}")
        df = df.reset_index(drop=True)  # chunks are numbered rows: no index is stored
        for k, v in meta.items():
            df[k] = v
        return df
    return store.fill_entry(path, expect.key, stamped, lambda df: _problem(df, expect),
                            what="cache entry")
