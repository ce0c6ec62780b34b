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
* :func:`entry_key` -- the one statement of what an entry was computed for (its kind, its
  parameters -- experiment, setting, loops, seed, the analysis and its inputs -- and its
  version), stored inside the entry and checked on every read: a copied or swapped file is
  computed for another entry, and is refused;
* :func:`content_digest` -- the one content digest (SHA-256) of a table (every column's name,
  dtype and values; the index too unless it is the default ``0 .. n-1``) or of a JSON-able
  value; :func:`entry_digest` binds it to the entry's key, and is stored with the entry: in a
  Parquet file's schema metadata (:data:`DIGEST_KEY`, beside the key under :data:`KEY_KEY`),
  in a JSON file's envelope ``{"uavwind.sha256": digest, "uavwind.key": key, "content":
  value}``;
* :func:`atomic_write` -- the one atomic write, ``atomic_write(path, content)``: a temporary
  file with a unique name in the same folder, flushed and renamed over the target, removed if
  anything fails; it never replaces anything but a regular file;
* :func:`read_entry` -- the one trust rule: only a regular file is read (a named pipe, a
  folder or a symlink to either is never opened); an entry that does not parse, has no digest
  or no key (there is no path for entries of before either), whose digest does not match its
  key and content, whose key is not the one asked for, or that fails the caller's own rules
  (their ranges and consistency) is renamed ``<name>.corrupt`` (``.corrupt.1``, ... : never
  deleted, never over earlier evidence) with one :class:`CorruptEntryWarning` naming the
  file, and the caller recomputes it; a file that cannot be *read* (permissions, open files,
  I/O) raises :class:`TransientReadError` and is left in place. Readers racing over one
  damaged entry move it aside once: a reader that finds it gone, or replaced by a sound
  one, leaves it be;
* :func:`entry_lock`, :func:`fill_entry` and :func:`get_or_compute` -- the read, compute and
  write of one entry under an exclusive per-entry lock (:func:`file_lock`, which also serves
  the soft-DTW engine's compile), so two processes on one folder compute it once; a lock
  path that is not a regular file (a named pipe, a folder) is moved aside, never opened.

The recipes of keys and digests are :mod:`uavwind.core.digest`'s (offered here too); this module
imports nothing else of uavwind but :mod:`uavwind.core.io` (the read-only rule of the pages).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import stat
import tempfile
import warnings
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from .digest import (KEY_LENGTH, check_entry_key, check_kind, content_digest, entry_digest,
                     entry_key, make_key, plain)
from .io import check_target, refuse_to_compute

__all__ = ["DIGEST_KEY", "KEY_KEY", "KEY_LENGTH", "FORMATS", "CorruptEntryWarning",
           "TransientReadError", "results_dir", "make_key", "entry_key", "plain",
           "content_digest", "entry_digest", "atomic_write", "read_entry", "file_lock",
           "entry_lock", "fill_entry", "get_or_compute"]

#: Parquet schema metadata key (and JSON envelope key) of an entry's digest (its key and
#: content, :func:`entry_digest`).
DIGEST_KEY = b"uavwind.sha256"
#: Parquet schema metadata key (and JSON envelope key) of an entry's key (:func:`entry_key`).
KEY_KEY = b"uavwind.key"
#: The formats an entry may have: a pandas DataFrame as Parquet, a JSON-able dict as JSON.
FORMATS = ("parquet", "json")
_JSON_DIGEST = DIGEST_KEY.decode()
_JSON_KEY = KEY_KEY.decode()


class CorruptEntryWarning(UserWarning):
    """A cached entry failed verification and was moved aside to be recomputed."""


class TransientReadError(OSError):
    """A cached entry could not be *read* (permission, out of file descriptors, an I/O error):
    the file is left where it is, since it may be sound, and the run stops."""


def results_dir(folder: str | os.PathLike | None = None) -> Path:
    """The results folder, by one rule: ``folder`` if given; else ``$UAVWIND_RESULTS`` if set;
    else the user's cache folder, ``$XDG_CACHE_HOME/uavwind/results`` (by default
    ``~/.cache/uavwind/results``). ``~`` is expanded; an empty ``folder`` or an empty
    ``$UAVWIND_RESULTS`` is a ``ValueError`` naming it (name ``"."`` for the working folder):
    an empty setting is a mistake, never a silent "the default"."""
    if folder is not None:
        if not isinstance(folder, (str, os.PathLike)):
            raise TypeError(f"results must be a path or None, got {type(folder).__name__}")
        if str(folder) == "":
            raise ValueError("results must name a folder, got an empty string (use '.' for "
                             "the working folder, or None for the default)")
        return Path(folder).expanduser()
    env = os.environ.get("UAVWIND_RESULTS")
    if env is not None:
        if not env.strip():
            raise ValueError("UAVWIND_RESULTS must name a folder, got an empty string (unset it "
                             "for the user's cache folder, or name '.' for the working folder)")
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join("~", ".cache")
    return Path(base).expanduser() / "uavwind" / "results"


def _parquet_bytes(df, key):
    """``df`` as Parquet with its key and the digest of the key and its content as it reads
    back."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df)
    digest = entry_digest(table.to_pandas(), key)
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           DIGEST_KEY: digest.encode(),
                                           KEY_KEY: key.encode()})
    return lambda tmp: pq.write_table(table, tmp)


def _json_text(value, key):
    """``value`` as JSON in its envelope (its key, and the digest of the key and the value as
    it reads back)."""
    try:
        back = json.loads(json.dumps(value, allow_nan=False))
    except (TypeError, ValueError) as exc:
        raise TypeError(f"content must be JSON-able (no NaN), got {exc}") from None
    return json.dumps({_JSON_DIGEST: entry_digest(back, key), _JSON_KEY: key,
                       "content": back}, separators=(",", ":"))


def atomic_write(path: os.PathLike | str,
                 content: pd.DataFrame | Mapping | list | str | bytes | Callable[[Path], None],
                 name: str = "path", *, key: str | None = None) -> Path:
    """Write ``content`` to ``path`` all at once, or not at all; the one way the project
    writes a file another process or a later run may read.

    Parameters
    ----------
    path : path-like
        The target: a regular file (replaced) or a new path; its folder is created. A folder,
        a device or a named pipe there is a ``ValueError`` naming ``name``, never replaced.
    content : DataFrame, dict, list, str, bytes or callable
        A DataFrame is written as Parquet (its index and ``attrs`` kept) with ``key`` and its
        :func:`entry_digest` in the schema metadata; a dict or list as JSON in the envelope
        ``{"uavwind.sha256": digest, "uavwind.key": key, "content": value}``; a ``str`` or
        ``bytes`` as is (no digest); a callable as ``content(tmp_path)`` writes it (no
        digest).
    name : str
        The parameter named in errors.
    key : str
        The entry's key (:func:`entry_key`): required for a DataFrame, a dict or a list (an
        entry), refused otherwise.

    Returns
    -------
    Path
        The target.
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a str, got {type(name).__name__}")
    path = check_target(path, name)
    if isinstance(content, (pd.DataFrame, Mapping, list)):
        check_entry_key(key)
        write = (_parquet_bytes(content, key) if isinstance(content, pd.DataFrame) else
                 _json_text(content, key))
    elif isinstance(content, (str, bytes)) or callable(content):
        if key is not None:
            raise TypeError("key is for an entry (a DataFrame, a dict or a list), not for "
                            f"{type(content).__name__} content")
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


def _lstat(path):
    """``os.lstat(path)``, or ``None`` if nothing is there."""
    try:
        return os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None


def _same_file(a, b):
    return a is not None and b is not None and (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _open_regular(path):
    """``(bytes, seen)`` of the entry at ``path`` (``seen``: its ``lstat``, the file judged),
    ``(None, None)`` if nothing is there, or ``(why, seen)`` with why it is not a regular file
    to read: it is opened without blocking and checked with ``fstat``, so a named pipe (or a
    link to one, or one swapped in meanwhile) is never waited on. A failure to read a regular
    file is a :class:`TransientReadError`."""
    seen = _lstat(path)
    if seen is None:
        return None, None
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except (FileNotFoundError, NotADirectoryError):
        return ("a symlink to nothing", seen) if _lstat(path) is not None else (None, None)
    except IsADirectoryError:
        return "a folder" + (" behind a symlink" if os.path.islink(path) else ""), seen
    except OSError as exc:
        raise _transient(exc, path, "opened") from exc
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            what = ("a named pipe" if stat.S_ISFIFO(st.st_mode) else
                    "a folder" if stat.S_ISDIR(st.st_mode) else "not a regular file")
            return what + (" behind a symlink" if os.path.islink(path) else ""), seen
        with os.fdopen(fd, "rb", closefd=False) as fh:
            return fh.read(), seen
    except OSError as exc:
        raise _transient(exc, path, "read") from exc
    finally:
        os.close(fd)


def _transient(exc: OSError, path: Path, verb: str) -> TransientReadError:
    """The error for an entry that could not be ``verb`` (opened, read): left in place."""
    return TransientReadError(exc.errno, f"cached entry {path.name} could not be {verb} "
                              f"({exc.strerror or exc}); it is left in place: fix the cause "
                              f"(permissions, open files, the disk) and rerun", str(path))


def _parse(blob, fmt):
    """``(content, stored digest or None, stored key or None)`` from an entry's bytes; any
    failure means damaged."""
    if fmt == "json":
        doc = json.loads(blob)
        if not isinstance(doc, dict) or "content" not in doc or _JSON_DIGEST not in doc:
            return doc, None, None
        if set(doc) - {_JSON_DIGEST, _JSON_KEY, "content"}:
            return doc, None, None
        key = doc.get(_JSON_KEY)
        return doc["content"], str(doc[_JSON_DIGEST]), (key if isinstance(key, str) else None)
    import pyarrow.parquet as pq

    table = pq.read_table(io.BytesIO(blob))
    meta = table.schema.metadata or {}
    stored, key = meta.get(DIGEST_KEY), meta.get(KEY_KEY)
    return (table.to_pandas(), stored.decode() if stored else None,
            key.decode() if key else None)


def _untrusted(content, stored, stored_key, key, verify):
    """Why an entry that parsed cannot be trusted as ``key`` (``""``: it can)."""
    if stored is None:
        return "no checksum"
    if stored_key is None:
        return "no key: it does not say what it was computed for"
    if stored != entry_digest(content, stored_key):
        return "its content does not match its checksum"
    if stored_key != key:
        return "it was computed for another entry (a copied or swapped file)"
    return verify(content) if verify is not None else ""


def _move_aside(path, seen):
    """Rename ``path`` to ``<name>.corrupt`` (``.corrupt.1``, ``.corrupt.2``, ... if taken):
    evidence is never overwritten. ``seen`` is the ``lstat`` of the file judged: if ``path``
    is no longer that file (another reader moved it aside first, or a writer put a sound entry
    there), nothing is moved and ``None`` is returned. Returns the new name."""
    for i in range(10_000):
        if not _same_file(_lstat(path), seen):
            return None
        aside = path.with_name(path.name + (".corrupt" if i == 0 else f".corrupt.{i}"))
        if os.path.lexists(aside):
            continue
        try:
            os.link(path, aside, follow_symlinks=False)  # fails if aside exists
        except FileExistsError:
            continue
        except (FileNotFoundError, NotADirectoryError):
            return None  # gone meanwhile: another reader moved it
        except OSError:  # no hard links here (or a folder): rename, the name being free
            try:
                os.rename(path, aside)
            except (FileNotFoundError, NotADirectoryError):
                return None
            except OSError:  # a folder cannot replace what appeared at aside: next name
                continue
            return aside
        if not _same_file(os.lstat(aside), seen):  # a new file came between the checks
            aside.unlink()
            return None
        with contextlib.suppress(FileNotFoundError):
            if _same_file(_lstat(path), seen):
                path.unlink()
        return aside
    raise RuntimeError(f"10,000 corrupt copies of {path.name}: clean the folder")


def _shown(path):
    """``path`` as messages name it: its folder and file name."""
    return f"{path.parent.name}/{path.name}"


def _check_callable(f, name):
    if f is not None and not callable(f):
        raise TypeError(f"{name} must be a callable or None, got {type(f).__name__}")


def read_entry(path: os.PathLike | str, key: str,
               verify: Callable[[Any], str] | None = None, what: str = "cache entry") -> Any:
    """The entry at ``path`` (a ``.parquet`` DataFrame or a ``.json`` value) if it is there
    and can be trusted as the entry ``key`` (:func:`entry_key`), else ``None``.

    Trusted means, by one rule for every entry: it is a regular file, it parses, it holds a
    key and a digest, the digest is that of its key and content (:func:`entry_digest`), its
    key is ``key`` (a file copied or swapped from another entry is not), and
    ``verify(content)`` (the caller's own rules: ranges and consistency; a reason not to trust
    it, or ``""``) finds nothing. Anything else is renamed ``<name>.corrupt`` with one
    :class:`CorruptEntryWarning` naming the file and the reason (``what`` says what the entry
    is, e.g. ``"analysis toy"``), so the caller recomputes it. A file that cannot be read
    raises :class:`TransientReadError` and is left in place.
    """
    path = Path(path)
    fmt = _format_of(path)
    check_entry_key(key)
    _check_callable(verify, "verify")
    blob, seen = _open_regular(path)
    if seen is None:
        return None
    if isinstance(blob, str):
        why = blob
    else:
        try:
            content, stored, stored_key = _parse(blob, fmt)
            why = _untrusted(content, stored, stored_key, key, verify)
        except Exception as exc:  # pyarrow and json raise many types for damaged files
            why = f"unreadable ({type(exc).__name__})"
        if not why:
            return content
    aside = _move_aside(path, seen)
    if aside is not None:  # else another reader moved it, and warned
        warnings.warn(f"{what} {_shown(path)} not trusted ({why}): moved to {aside.name} and "
                      f"recomputed", CorruptEntryWarning, stacklevel=3)
    return None


def _open_lock(lock):
    """A descriptor of the lock file ``lock``, made if missing. Anything else there (a named
    pipe, a folder, a device) is never waited on: it is moved aside (``.corrupt``) with a
    :class:`CorruptEntryWarning` and a lock file made in its place."""
    lock = Path(lock)
    for _ in range(10):
        seen = _lstat(lock)
        if seen is not None and not stat.S_ISREG(seen.st_mode) and not stat.S_ISLNK(seen.st_mode):
            why = "a named pipe" if stat.S_ISFIFO(seen.st_mode) else (
                "a folder" if stat.S_ISDIR(seen.st_mode) else "not a regular file")
        else:
            try:
                fd = os.open(lock, os.O_RDONLY | os.O_CREAT | os.O_NONBLOCK
                             | getattr(os, "O_CLOEXEC", 0), 0o644)
            except IsADirectoryError:
                continue  # a folder appeared: judged on the next turn
            if stat.S_ISREG(os.fstat(fd).st_mode):
                return fd
            os.close(fd)
            if seen is not None and stat.S_ISLNK(seen.st_mode):
                why = "a symlink to what is not a regular file"
            else:
                continue
        aside = _move_aside(lock, seen)
        if aside is not None:
            warnings.warn(f"lock {_shown(lock)} is {why}, not a lock file: moved to "
                          f"{aside.name}", CorruptEntryWarning, stacklevel=4)
    raise RuntimeError(f"lock {lock} keeps being replaced by what is not a regular file")


@contextlib.contextmanager
def file_lock(lock: os.PathLike | str, wait: float | None = None) -> Iterator[bool]:
    """Exclusive lock (``fcntl.flock``) on the file ``lock`` (made if missing; anything but a
    regular file there is moved aside, with a :class:`CorruptEntryWarning`) for as long as the
    block runs; yields whether it is held. ``wait=None``: until it is held; else at most
    ``wait`` seconds, after which the block runs without it. A process that dies holding it
    releases it. Opening the file can raise ``OSError`` (its folder missing or read-only)."""
    import fcntl
    import time

    fd = _open_lock(lock)
    try:
        if wait is None:
            fcntl.flock(fd, fcntl.LOCK_EX)
            held = True
        else:
            deadline = time.monotonic() + wait
            while True:
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
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
                fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)


@contextlib.contextmanager
def entry_lock(path: os.PathLike | str) -> Iterator[None]:
    """Exclusive lock on the entry at ``path`` for as long as the block runs (``<path>.lock``,
    :func:`file_lock`)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with file_lock(path.with_name(path.name + ".lock")):
        yield


def fill_entry(path: os.PathLike | str, key: str, compute: Callable[[], Any],
               verify: Callable[[Any], str] | None = None,
               what: str = "cache entry") -> tuple[Any, bool]:
    """``(content, from_cache)``: under the entry's lock, the trusted entry ``key`` at ``path``
    (:func:`read_entry`), else ``compute()`` checked by ``verify`` (never stored if it would
    not be trusted on reading: a ``RuntimeError``), written atomically with its key and read
    back, so a first run and a cached run return the same values of the same types. Under
    ``$UAVWIND_PAGES_READ_ONLY`` a missing entry is a ``RuntimeError`` naming it
    (:func:`uavwind.core.io.refuse_to_compute`)."""
    path = Path(path)
    fmt = _format_of(path)
    check_entry_key(key)
    if not callable(compute):
        raise TypeError(f"compute must be a callable, got {type(compute).__name__}")
    with entry_lock(path):
        content = read_entry(path, key, verify, what)
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
        atomic_write(path, content, key=key)
        blob, _ = _open_regular(path)
        return _parse(blob, fmt)[0], False


def get_or_compute(kind: str, key_params: Mapping, compute: Callable[[], Any],
                   verify: Callable[[Any], str] | None = None,
                   folder: os.PathLike | str | None = None, *, version: str,
                   fmt: str = "parquet", name: str | None = None,
                   what: str | None = None) -> Any:
    """``compute()``'s result, cached as ``<folder>/<kind>/<name->key.<fmt>``.

    Parameters
    ----------
    kind : str
        The kind of entry, and its folder (e.g. ``"analyses"``, ``"filters"``).
    key_params : mapping
        JSON-able: everything that determines the result (with ``version``,
        :func:`make_key` names the file; with ``kind`` too, :func:`entry_key` is stored in it
        and checked on reading).
    compute : callable
        ``compute()`` returns a pandas DataFrame (``fmt="parquet"``) or a JSON-able dict
        or list (``fmt="json"``).
    verify : callable, optional
        ``verify(content)``: a reason not to trust a cached (or computed) result, or ``""``
        (the kind's ranges and consistency).
    folder : path-like, optional
        The results folder (:func:`results_dir`).
    version : str
        The version of what ``compute`` computes: bump it when its numbers change.
    fmt : {"parquet", "json"}
    name : str, optional
        A readable prefix of the file name (an identifier).
    what : str, optional
        What the entry is, in warnings and errors, e.g. ``"analysis toy"`` (default:
        ``"<kind> entry"``).

    Notes
    -----
    A cached entry is read without the lock (a complete cache in a read-only folder is
    readable); a missing or damaged one is computed by :func:`fill_entry`.
    """
    check_kind(kind)
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {list(FORMATS)}, got {fmt!r}")
    if name is not None and (not isinstance(name, str) or not name.isidentifier()):
        raise ValueError(f"name must be an identifier, got {name!r}")
    if what is None:
        what = f"{kind} entry"
    elif not isinstance(what, str):
        raise TypeError(f"what must be a str, got {type(what).__name__}")
    file_key = make_key(kind, key_params, version)
    key = entry_key(kind, key_params, version)
    path = results_dir(folder) / kind / f"{name + '-' if name else ''}{file_key}.{fmt}"
    content = read_entry(path, key, verify, what)
    if content is not None:
        return content
    return fill_entry(path, key, compute, verify, what)[0]
