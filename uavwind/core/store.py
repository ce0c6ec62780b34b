"""The one verified store of computed results: where entries live, how they are named, written,
read and trusted.

Every cache of the project (the study's result chunks, the analyses' tables, Exp 11's filter
tables, the explorer's grid) goes through this module, so each rule exists once:

* :func:`results_dir` -- the folder: the one a caller names, else ``$UAVWIND_RESULTS``, else
  the user's cache folder (``$XDG_CACHE_HOME/uavwind/results``, by default
  ``~/.cache/uavwind/results``), never a folder inside the installed package;
* :func:`make_key` -- the one key recipe: an entry of a *kind* (the folder it is filed in) is
  named by the first 20 hex digits of the SHA-256 of the canonical JSON of its parameters and
  its version;
* :func:`content_digest` -- the one content digest (SHA-256) of a table (every column's name,
  dtype and values; the index too unless it is the default ``0 .. n-1``) or of a JSON-able
  value, stored with the entry: in a Parquet file's schema metadata (:data:`DIGEST_KEY`), in
  a JSON file's envelope ``{"uavwind.sha256": digest, "content": value}``;
* :func:`atomic_write` -- the one atomic write, ``atomic_write(path, content)``: a temporary
  file with a unique name in the same folder, flushed and renamed over the target, removed if
  anything fails; it never replaces anything but a regular file;
* :func:`read_entry` -- the one rule for a damaged or tampered entry: only a regular file is
  read (a named pipe, a folder or a symlink to either is never opened); an entry that does not
  parse, has no digest, whose content does not match its digest, or that fails the caller's
  own check is renamed ``<name>.corrupt`` (``.corrupt.1``, ... : never deleted, never over
  earlier evidence) with one :class:`CorruptEntryWarning` naming the file, and the caller
  recomputes it; a file that cannot be *read* (permissions, open files, I/O) raises
  :class:`TransientReadError` and is left in place;
* :func:`entry_lock`, :func:`fill_entry` and :func:`get_or_compute` -- the read, compute and
  write of one entry under an exclusive per-entry lock (:func:`file_lock`, which also serves
  the soft-DTW engine's compile), so two processes on one folder compute it once.

It imports nothing of uavwind but :mod:`uavwind.core.io` (the read-only rule of the pages).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import re
import stat
import tempfile
import warnings
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .io import check_target, refuse_to_compute

__all__ = ["DIGEST_KEY", "KEY_LENGTH", "FORMATS", "CorruptEntryWarning", "TransientReadError",
           "results_dir", "make_key", "plain", "content_digest", "atomic_write", "read_entry",
           "file_lock", "entry_lock", "fill_entry", "get_or_compute"]

#: Parquet schema metadata key (and JSON envelope key) of an entry's content digest.
DIGEST_KEY = b"uavwind.sha256"
#: Hex digits of SHA-256 an entry's key keeps.
KEY_LENGTH = 20
#: The formats an entry may have: a pandas DataFrame as Parquet, a JSON-able dict as JSON.
FORMATS = ("parquet", "json")
_JSON_DIGEST = DIGEST_KEY.decode()
_KIND = re.compile(r"[A-Za-z0-9][\w.-]*")


class CorruptEntryWarning(UserWarning):
    """A cached entry failed verification and was moved aside to be recomputed."""


class TransientReadError(OSError):
    """A cached entry could not be *read* (permission, out of file descriptors, an I/O error):
    the file is left where it is, since it may be sound, and the run stops."""


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


def _check_kind(kind):
    if not isinstance(kind, str):
        raise TypeError(f"kind must be a str (the entry's folder), got {type(kind).__name__}")
    if not _KIND.fullmatch(kind):
        raise ValueError(f"kind must be a folder name (a letter or digit, then letters, digits, "
                         f"_, . or -), got {kind!r}")
    return kind


def make_key(kind: str, params: Mapping, version: str) -> str:
    """The key of an entry of ``kind``: the first :data:`KEY_LENGTH` hex digits of the SHA-256
    of ``json.dumps({**params, "version": version}, sort_keys=True, default=str)``.

    ``kind`` is the folder the entry is filed in (:func:`get_or_compute`); it separates kinds
    without entering the digest, so the keys written before this module (result chunks,
    filter tables) keep their names. ``params`` must not hold ``"version"`` itself.
    """
    _check_kind(kind)
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping (what determines the entry), got "
                        f"{type(params).__name__}")
    if not isinstance(version, str) or not version:
        raise ValueError(f"version must be a non-empty str, got {version!r}")
    if "version" in params:
        raise ValueError("params must not hold 'version': it is the version argument")
    blob = json.dumps({**params, "version": version}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:KEY_LENGTH]


#: numpy dtype kinds whose ``tolist()`` is Python scalars already (floats, ints, flags): the
#: content digest takes them as they come.
_SCALAR_KINDS = "fiub"


def plain(v: Any) -> Any:
    """``v`` as plain Python values: arrays (also object arrays of arrays, as pyarrow returns
    nested lists) and tuples as lists, numpy scalars as Python scalars."""
    if isinstance(v, np.ndarray):
        if v.dtype.kind in _SCALAR_KINDS:  # nested lists of Python scalars already
            return v.tolist()
        return [plain(x) for x in v.tolist()]
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, np.generic):
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


def _default_index(index: pd.Index) -> bool:
    return (isinstance(index, pd.RangeIndex) and index.start == 0 and index.step == 1
            and index.name is None)


def content_digest(content: pd.DataFrame | Mapping | list) -> str:
    """SHA-256 (hex) of an entry's content.

    A DataFrame: every column's name, dtype and values, in order (list columns as lists,
    floats by their shortest round-trip repr), preceded by its index levels when the index is
    not the default ``0 .. n-1``; ``attrs`` are not content. A dict or list: its canonical
    JSON (sorted keys, no NaN).
    """
    h = hashlib.sha256()
    if isinstance(content, pd.DataFrame):
        df = _bare(content)
        if not _default_index(df.index):
            for level in range(df.index.nlevels):
                values = df.index.get_level_values(level)
                h.update(json.dumps([f"index:{values.name}", str(values.dtype),
                                     [plain(v) for v in values.tolist()]], default=str,
                                    allow_nan=True).encode())
        for col, column in df.items():
            values = column.tolist()
            if column.dtype.kind not in _SCALAR_KINDS:
                values = [plain(v) for v in values]
            h.update(json.dumps([str(col), str(column.dtype), values], default=str,
                                allow_nan=True).encode())
        return h.hexdigest()
    if isinstance(content, (Mapping, list)):
        h.update(json.dumps(content, sort_keys=True, separators=(",", ":"),
                            allow_nan=False).encode())
        return h.hexdigest()
    raise TypeError(f"content must be a pandas DataFrame, a dict or a list, got "
                    f"{type(content).__name__}")


def _parquet_bytes(df):
    """``df`` as Parquet with the digest of its content as it reads back."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df)
    digest = content_digest(table.to_pandas())
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           DIGEST_KEY: digest.encode()})
    return lambda tmp: pq.write_table(table, tmp)


def _json_text(value):
    """``value`` as JSON in its digest envelope (the digest of the value as it reads back)."""
    try:
        back = json.loads(json.dumps(value, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise TypeError(f"content must be JSON-able (no NaN), got {exc}") from None
    return json.dumps({_JSON_DIGEST: content_digest(back), "content": back},
                      separators=(",", ":"))


def atomic_write(path: os.PathLike | str,
                 content: pd.DataFrame | Mapping | list | str | bytes | Callable[[Path], None],
                 name: str = "path") -> Path:
    """Write ``content`` to ``path`` all at once, or not at all; the one way the project
    writes a file another process or a later run may read.

    Parameters
    ----------
    path : path-like
        The target: a regular file (replaced) or a new path; its folder is created. A folder,
        a device or a named pipe there is a ``ValueError`` naming ``name``, never replaced.
    content : DataFrame, dict, list, str, bytes or callable
        A DataFrame is written as Parquet (its index and ``attrs`` kept) with its
        :func:`content_digest` in the schema metadata; a dict or list as JSON in the envelope
        ``{"uavwind.sha256": digest, "content": value}``; a ``str`` or ``bytes`` as is (no
        digest); a callable as ``content(tmp_path)`` writes it (no digest).
    name : str
        The parameter named in errors.

    Returns
    -------
    Path
        The target.
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    path = check_target(path, name)
    if isinstance(content, pd.DataFrame):
        write = _parquet_bytes(content)
    elif isinstance(content, (Mapping, list)):
        write = _json_text(content)
    elif isinstance(content, (str, bytes)) or callable(content):
        write = content
    else:
        raise TypeError(f"content must be a DataFrame, a dict, a list, str, bytes or a "
                        f"callable, got {type(content).__name__}")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        if isinstance(write, str):
            tmp.write_text(write)
        elif isinstance(write, bytes):
            tmp.write_bytes(write)
        else:
            write(tmp)
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def _format_of(path):
    fmt = path.suffix.lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"path must end in .parquet or .json (the entry's format), got "
                         f"{str(path)!r}")
    return fmt


def _not_regular(path):
    """Why ``path`` is not a regular file to read (``None`` if it is one, ``""`` if nothing is
    there), from ``stat`` alone: a pipe, a folder or a link to either is never opened."""
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        if os.path.lexists(path):
            return "a symlink to nothing"
        return ""
    except OSError as exc:
        raise TransientReadError(exc.errno, f"cached entry {path.name} could not be examined "
                                 f"({exc.strerror or exc}); it is left in place: fix the cause "
                                 f"and rerun", str(path)) from exc
    if stat.S_ISREG(st.st_mode):
        return None
    what = ("a named pipe" if stat.S_ISFIFO(st.st_mode) else
            "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file")
    return what + (" behind a symlink" if os.path.islink(path) else "")


def _read_bytes(path):
    """The file's bytes (``None`` if it is gone); a failure to read them is a
    :class:`TransientReadError`."""
    try:
        return path.read_bytes()
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as exc:
        raise TransientReadError(exc.errno, f"cached entry {path.name} could not be read "
                                 f"({exc.strerror or exc}); it is left in place: fix the cause "
                                 f"(permissions, open files, the disk) and rerun",
                                 str(path)) from exc


def _parse(blob, fmt):
    """``(content, stored digest or None)`` from an entry's bytes; any failure means
    damaged."""
    if fmt == "json":
        doc = json.loads(blob)
        if not isinstance(doc, dict) or set(doc) != {_JSON_DIGEST, "content"}:
            return doc, None
        return doc["content"], str(doc[_JSON_DIGEST])
    import pyarrow.parquet as pq

    table = pq.read_table(io.BytesIO(blob))
    stored = (table.schema.metadata or {}).get(DIGEST_KEY)
    return table.to_pandas(), (stored.decode() if stored else None)


def _move_aside(path):
    """Rename ``path`` to ``<name>.corrupt`` (``.corrupt.1``, ``.corrupt.2``, ... if taken):
    evidence is never overwritten. Returns the new name."""
    for i in range(10_000):
        aside = path.with_name(path.name + (".corrupt" if i == 0 else f".corrupt.{i}"))
        if os.path.lexists(aside):
            continue
        try:
            os.link(path, aside, follow_symlinks=False)  # fails if aside exists
        except FileExistsError:
            continue
        except OSError:  # no hard links here (or a folder): rename, the name being free
            os.replace(path, aside)
            return aside
        path.unlink()
        return aside
    raise RuntimeError(f"10,000 corrupt copies of {path.name}: clean the folder")


def _shown(path):
    """``path`` as messages name it: its folder and file name."""
    return f"{path.parent.name}/{path.name}"


def _check_callable(f, name):
    if f is not None and not callable(f):
        raise TypeError(f"{name} must be a callable or None, got {type(f).__name__}")


def read_entry(path: os.PathLike | str, verify: Callable[[Any], str] | None = None,
               legacy: Callable[[Any], bool] | None = None, what: str = "cache entry") -> Any:
    """The entry at ``path`` (a ``.parquet`` DataFrame or a ``.json`` value) if it is there
    and can be trusted, else ``None``.

    Trusted means: it is a regular file, it parses, its stored digest matches its content,
    and ``verify(content)`` (the caller's own rules: a reason not to trust it, or ``""``)
    finds nothing. An entry without a digest is untrusted unless ``legacy(content)`` says it
    was written before entries carried one and checks what it can; it is then given its
    digest in place. Anything else is renamed ``<name>.corrupt`` with one
    :class:`CorruptEntryWarning` naming the file and the reason (``what`` says what the entry
    is, e.g. ``"analysis toy"``), so the caller recomputes it. A file that cannot be read raises
    :class:`TransientReadError` and is left in place.
    """
    path = Path(path)
    fmt = _format_of(path)
    _check_callable(verify, "verify")
    _check_callable(legacy, "legacy")
    why = _not_regular(path)
    if why == "":
        return None
    content = None
    if why is None:
        blob = _read_bytes(path)
        if blob is None:
            return None
        stored = None
        try:
            content, stored = _parse(blob, fmt)
            if stored is not None and stored != content_digest(content):
                why = "its content does not match its checksum"
            elif stored is None and not (legacy is not None and legacy(content)):
                why = "no checksum"
            elif verify is not None:
                why = verify(content)
        except Exception as exc:  # pyarrow and json raise many types for damaged files
            why = f"unreadable ({type(exc).__name__})"
        if not why:
            if stored is None:  # a sound entry of before digests: give it its digest, if we may
                with contextlib.suppress(OSError):
                    atomic_write(path, content)
            return content
    aside = _move_aside(path)
    warnings.warn(f"{what} {_shown(path)} not trusted ({why}): moved to {aside.name} and "
                  f"recomputed", CorruptEntryWarning, stacklevel=3)
    return None


@contextlib.contextmanager
def file_lock(lock: os.PathLike | str, wait: float | None = None) -> Iterator[bool]:
    """Exclusive lock (``fcntl.flock``) on the file ``lock`` (made if missing) for as long as
    the block runs; yields whether it is held. ``wait=None``: until it is held; else at most
    ``wait`` seconds, after which the block runs without it. A process that dies holding it
    releases it. Opening the file can raise ``OSError`` (its folder missing or read-only)."""
    import fcntl
    import time

    with open(lock, "a") as fh:
        if wait is None:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX)
            held = True
        else:
            deadline = time.monotonic() + wait
            while True:
                try:
                    fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                    held = True
                    break
                except BlockingIOError:
                    if time.monotonic() > deadline:
                        held = False
                        break
                    time.sleep(0.2)
        try:
            yield held
        finally:
            if held:
                fcntl.flock(fh.fileno(), fcntl.LOCK_UN)


@contextlib.contextmanager
def entry_lock(path: os.PathLike | str) -> Iterator[None]:
    """Exclusive lock on the entry at ``path`` for as long as the block runs (``<path>.lock``,
    :func:`file_lock`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with file_lock(path.with_name(path.name + ".lock")):
        yield


def fill_entry(path: os.PathLike | str, compute: Callable[[], Any],
               verify: Callable[[Any], str] | None = None,
               legacy: Callable[[Any], bool] | None = None,
               what: str = "cache entry") -> tuple[Any, bool]:
    """``(content, from_cache)``: under the entry's lock, the trusted entry at ``path``
    (:func:`read_entry`), else ``compute()`` checked by ``verify`` (never stored if it would
    not be trusted on reading: a ``RuntimeError``), written atomically and read back, so a
    first run and a cached run return the same values of the same types. Under
    ``$UAVWIND_PAGES_READ_ONLY`` a missing entry is a ``RuntimeError`` naming it
    (:func:`uavwind.core.io.refuse_to_compute`)."""
    path = Path(path)
    fmt = _format_of(path)
    if not callable(compute):
        raise TypeError(f"compute must be a callable, got {type(compute).__name__}")
    with entry_lock(path):
        content = read_entry(path, verify, legacy, what)
        if content is not None:
            return content, True
        refuse_to_compute(f"the {what} {_shown(path)}")
        content = compute()
        want = pd.DataFrame if fmt == "parquet" else (dict, list)
        if not isinstance(content, want):
            raise TypeError(f"{what} must compute a "
                            f"{'pandas DataFrame' if fmt == 'parquet' else 'dict or list'}, "
                            f"got {type(content).__name__}")
        why = verify(content) if verify is not None else ""
        if why:
            raise RuntimeError(f"computed {what} {path.name} is inconsistent: {why}")
        atomic_write(path, content)
        back, _ = _parse(_read_bytes(path), fmt)
        return back, False


def get_or_compute(kind: str, key_params: Mapping, compute: Callable[[], Any],
                   verify: Callable[[Any], str] | None = None,
                   folder: os.PathLike | str | None = None, *, version: str,
                   fmt: str = "parquet", name: str | None = None,
                   legacy: Callable[[Any], bool] | None = None,
                   what: str | None = None) -> Any:
    """``compute()``'s result, cached as ``<folder>/<kind>/<name->key.<fmt>``.

    Parameters
    ----------
    kind : str
        The kind of entry, and its folder (e.g. ``"analyses"``, ``"filters"``).
    key_params : mapping
        JSON-able: everything that determines the result (with ``version``,
        :func:`make_key`).
    compute : callable
        ``compute()`` returns a pandas DataFrame (``fmt="parquet"``) or a JSON-able dict
        or list (``fmt="json"``).
    verify : callable, optional
        ``verify(content)``: a reason not to trust a cached (or computed) result, or ``""``.
    folder : path-like, optional
        The results folder (:func:`results_dir`).
    version : str
        The version of what ``compute`` computes: bump it when its numbers change.
    fmt : {"parquet", "json"}
    name : str, optional
        A readable prefix of the file name (an identifier).
    legacy : callable, optional
        ``legacy(content)``: True for an entry written before entries carried a digest that
        is sound (:func:`read_entry`).
    what : str, optional
        What the entry is, in warnings and errors, e.g. ``"analysis toy"`` (default:
        ``"<kind> entry"``).

    Notes
    -----
    A cached entry is read without the lock (a complete cache in a read-only folder is
    readable); a missing or damaged one is computed by :func:`fill_entry`.
    """
    _check_kind(kind)
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {list(FORMATS)}, got {fmt!r}")
    if name is not None and (not isinstance(name, str) or not name.isidentifier()):
        raise ValueError(f"name must be an identifier, got {name!r}")
    if what is None:
        what = f"{kind} entry"
    elif not isinstance(what, str):
        raise TypeError(f"what must be a str, got {type(what).__name__}")
    key = make_key(kind, key_params, version)
    path = results_dir(folder) / kind / f"{name + '-' if name else ''}{key}.{fmt}"
    content = read_entry(path, verify, legacy, what)
    if content is not None:
        return content
    return fill_entry(path, compute, verify, legacy, what)[0]
