"""The recipes of the result store's names and digests: what an entry is called, what it says
it was computed for, and the digest that binds that to its content.

This module owns :func:`make_key` (an entry's file name), :func:`entry_key` (what it was
computed for, stored inside it), :func:`content_digest` (a table's or a value's SHA-256),
:func:`entry_digest` (the two together) and :func:`plain`. The files themselves (writes,
reads, the trust rule, locks) are :mod:`uavwind.core.store`'s, which offers these names too.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["KEY_LENGTH", "make_key", "entry_key", "plain", "content_digest", "entry_digest"]

#: Hex digits of SHA-256 an entry's file name keeps.
KEY_LENGTH = 20
_KIND = re.compile(r"[A-Za-z0-9][\w.-]*")


def check_kind(kind):
    """``kind`` if it names an entry's folder; else a ``TypeError`` or ``ValueError``."""
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
    _check_key_parts(kind, params, version)
    blob = json.dumps({**params, "version": version}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:KEY_LENGTH]


def _check_key_parts(kind, params, version):
    check_kind(kind)
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping (what determines the entry), got "
                        f"{type(params).__name__}")
    if not isinstance(version, str) or not version:
        raise ValueError(f"version must be a non-empty str, got {version!r}")
    if "version" in params:
        raise ValueError("params must not hold 'version': it is the version argument")


def entry_key(kind: str, params: Mapping, version: str) -> str:
    """What an entry of ``kind`` was computed for: the canonical JSON (sorted keys, no spaces)
    of ``{"kind": kind, "params": params, "version": version}``.

    It is written inside the entry, under its digest (:func:`entry_digest`), and a read
    (:func:`read_entry`) trusts the entry only if it holds exactly the key asked for: a file
    copied or moved over another entry's name is refused. ``params`` are those of
    :func:`make_key` (which names the file).
    """
    _check_key_parts(kind, params, version)
    return json.dumps({"kind": kind, "params": params, "version": version}, sort_keys=True,
                      separators=(",", ":"), default=str)


def check_entry_key(key):
    """``key`` if it can be an entry's key (:func:`entry_key`); else a ``TypeError``."""
    if not isinstance(key, str) or not key:
        raise TypeError(f"key must be the entry's key, a non-empty str (entry_key), got "
                        f"{key!r}")
    return key


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


def entry_digest(content: pd.DataFrame | Mapping | list, key: str) -> str:
    """SHA-256 (hex) of an entry: its key (:func:`entry_key`) and its
    :func:`content_digest`, so neither can be changed alone."""
    h = hashlib.sha256(b"uavwind entry\0")
    h.update(check_entry_key(key).encode())
    h.update(b"\0" + content_digest(content).encode())
    return h.hexdigest()
