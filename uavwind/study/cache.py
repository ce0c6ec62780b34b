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
* :func:`read_verified` -- a chunk is trusted only if it parses and its stored
  setting key, seed, engine, row count and value ranges are what the caller expects;
  anything else is moved aside as ``*.corrupt`` with one warning line, and recomputed;
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
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.io import atomic_write as _write_atomically
from ..method.baseline import BASELINE_VERSION
from ..method.clustering import DEFAULT_PARAMS

__all__ = ["RESULTS_VERSION", "cache_key", "results_dir", "check_writable", "Expected",
           "read_verified", "atomic_write", "chunk_lock", "cached", "CorruptChunkWarning"]

#: Bump when a change to the library alters results; it is part of every cache key.
#: 2: Dryden filters built with python-control by default (equal to 1e-12, not bit for bit).
RESULTS_VERSION = "2"


class CorruptChunkWarning(UserWarning):
    """A cached chunk failed verification and was moved aside to be recomputed."""


def results_dir(folder=None) -> Path:
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


def cache_key(setting, seed, start, stop, engine, params, extra=None) -> str:
    """Digest of everything that determines a chunk of results."""
    fields = {"setting": setting.key(), "seed": seed, "loops": [start, stop], "engine": engine,
              "params": {**DEFAULT_PARAMS, **params}, "version": RESULTS_VERSION,
              "extra": extra}
    if getattr(setting, "baseline", False):  # loops that also run the physics baseline
        fields["baseline"] = BASELINE_VERSION
    blob = json.dumps(fields, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:20]


def check_writable(folder):
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
    """What a chunk must hold to be trusted."""

    setting_key: str
    seed: int
    engine: str
    n_rows: int


def _problem(df, expect):
    """Why ``df`` cannot be trusted as ``expect`` (empty string: it can)."""
    if len(df) != expect.n_rows:
        return f"{len(df)} rows, expected {expect.n_rows}"
    for col, want in (("setting_key", expect.setting_key), ("seed", expect.seed),
                      ("engine", expect.engine)):
        if col not in df.columns:
            return f"no {col} column"
        if not (df[col] == want).all():
            return f"{col} is not {want!r}"
    if "score" not in df.columns:
        return "no score column"
    score = df["score"].to_numpy(dtype=float)
    # 100 x silhouette where the loop is grouped correctly (a silhouette may be <= 0), 0 else
    if not np.all(np.isfinite(score)) or score.min() < -100 or score.max() > 100:
        return "scores outside [-100, 100]"
    if "correct" in df.columns:
        ok = df["correct"].to_numpy(dtype=bool)
        if np.any(score[~ok] != 0):
            return "a misgrouped loop with a non-zero score"
        if "silhouette" in df.columns:
            sil = df["silhouette"].to_numpy(dtype=float)
            if np.any(np.abs(sil[np.isfinite(sil)]) > 1 + 1e-9):
                return "silhouettes outside [-1, 1]"
            if np.any(np.abs(score[ok] - 100 * sil[ok]) > 1e-6):
                return "scores that are not 100 x silhouette"
    elif score.min() < 0:
        return "negative scores without a correct column"
    return ""


def read_verified(path, expect):
    """The chunk at ``path`` if it exists and can be trusted, else ``None``.

    A chunk that cannot be read or fails :class:`Expected` is renamed to
    ``<name>.corrupt`` (never deleted: it may be evidence) with one
    :class:`CorruptChunkWarning`, so the caller recomputes it.
    """
    path = Path(path)
    if not path.exists():
        return None
    try:
        df = pd.read_parquet(path)
        why = _problem(df, expect)
    except Exception as exc:  # pyarrow raises many types for damaged files
        why = f"unreadable ({type(exc).__name__})"
    if not why:
        return df
    aside = path.with_name(path.name + ".corrupt")
    with contextlib.suppress(OSError):
        os.replace(path, aside)
    warnings.warn(f"cached chunk {path.name} failed verification ({why}): moved to "
                  f"{aside.name} and recomputed", CorruptChunkWarning, stacklevel=3)
    return None


def atomic_write(df, path) -> Path:
    """Write ``df`` to ``path`` (Parquet) all at once, or not at all."""
    return _write_atomically(path, lambda tmp: df.to_parquet(tmp, index=False))


@contextlib.contextmanager
def chunk_lock(path):
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


def cached(path, compute, meta, expect):
    """``(df, from_cache)``: the verified chunk at ``path``, or ``compute()`` stamped with
    ``meta`` and written atomically, all under the chunk's lock. Either way ``df`` is the
    chunk as read from disk, so a first run and a cached run return the same values of the
    same types (a list column comes back as arrays, as Parquet stores it)."""
    with chunk_lock(path):
        df = read_verified(path, expect)
        if df is not None:
            return df, True
        df = compute()
        for k, v in meta.items():
            df[k] = v
        why = _problem(df, expect)
        if why:  # never store what would not be trusted on reading
            raise RuntimeError(f"computed chunk {Path(path).name} is inconsistent: {why}")
        atomic_write(df, path)
        return pd.read_parquet(path), False
