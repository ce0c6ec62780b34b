"""Cached analyses: a table an analysis computes once and every reader finds again.

This module owns :func:`memo`: a table computed by an analysis function (not an
experiment's loops: a measurement such as Exp 10's saturation split), filed by the one
verified cache (:func:`uavwind.core.store.get_or_compute`) in the result folder's
``analyses/`` under a key of the function's name, its arguments and :data:`MEMO_VERSION`;
the entry holds that key (the analysis and its inputs) under the digest of it and of its own
content (index included), so a missing, damaged, altered or swapped copy (two entries
exchanged with ``mv`` hold each other's keys) is recomputed (all but the first moved aside,
with a warning naming the file); tables of before the store, without a key, are recomputed
too; a caller may add its table's range rules (``verify``); and under
``UAVWIND_PAGES_READ_ONLY`` a page that would compute it fails naming it
(:func:`uavwind.core.io.refuse_to_compute`). :func:`derived` and :func:`derived_many` key a
table computed from result tables alone by those tables' content digests and by the source
of the modules that compute it (``code``): a changed rule in them is a new entry, never a
stale table read back (the claims page once showed rules older than its code).

The analyses the pages read, and the fill's tasks for them, are
:mod:`uavwind.analysis.page_analyses`; Exp 13's tables (:mod:`.real_flights`,
:mod:`.figure8`) are cached here too.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import ModuleType

import pandas as pd

from ..core.store import content_digest, get_or_compute

__all__ = ["memo", "derived", "derived_many", "code_digest", "MEMO_VERSION"]

#: Bump when an analysis routed through :func:`memo` changes its numbers.
MEMO_VERSION = "1"


def memo(name: str, params: Mapping, compute: Callable[[], pd.DataFrame],
         results=None, verify: Callable[[pd.DataFrame], str] | None = None) -> pd.DataFrame:
    """``compute()``'s table, cached under ``name`` and ``params`` (JSON-serialisable: the
    arguments that determine it) as ``analyses/<name>-<key>.parquet``; see the module text.
    ``verify(table)``, if given, is the table's own rules (a reason not to trust it, or
    ``""``), applied to what is read and to what is computed."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"name must be an identifier, got {name!r}")
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping, got {type(params).__name__}")
    return get_or_compute("analyses", {"name": name, "params": params}, compute,
                          verify=verify, folder=results, version=MEMO_VERSION, name=name,
                          what=f"analysis {name}")


def derived(name: str, compute: Callable[[], pd.DataFrame], inputs: Mapping[str, pd.DataFrame],
            results=None, code: Sequence[ModuleType] = ()) -> pd.DataFrame:
    """:func:`memo` for a table computed from result tables alone: cached under ``name``, the
    content digests of ``inputs`` (name -> the tables ``compute`` reads) and the source
    digests of ``code`` (the modules whose functions compute it), so a page and the fill that
    load the same results find the same entry, and a changed result or rule is a new one."""
    return memo(name, _input_key(inputs, code), compute, results)


def code_digest(modules: Sequence[ModuleType]) -> dict[str, str]:
    """Module name -> the SHA-256 of its source file (16 hex digits)."""
    out = {}
    for m in modules:
        if not isinstance(m, ModuleType) or not getattr(m, "__file__", None):
            raise TypeError(f"code must hold modules with a source file, got {m!r}")
        out[m.__name__] = hashlib.sha256(Path(m.__file__).read_bytes()).hexdigest()[:16]
    return out


def _input_key(inputs: Mapping[str, pd.DataFrame], code: Sequence[ModuleType] = ()) -> dict:
    """:func:`derived`'s parameters: the content digest of each input table (and, given
    ``code``, the source digest of each module)."""
    key = {"inputs": {k: content_digest(df.reset_index(drop=True)) for k, df in inputs.items()}}
    if code:
        key["code"] = code_digest(code)
    return key


def derived_many(computes: Mapping[str, Callable[[], pd.DataFrame]],
                 inputs: Mapping[str, pd.DataFrame], results=None,
                 code: Sequence[ModuleType] = ()) -> dict[str, pd.DataFrame]:
    """:func:`derived` for several tables of the same ``inputs`` and ``code``: name ->
    ``compute``, each cached as :func:`derived` caches it (the same entries), the digests
    taken once for all."""
    key = _input_key(inputs, code)
    return {name: memo(name, key, compute, results) for name, compute in computes.items()}
