"""Analyses the pages show, computed once by the fill and read by the pages.

This module owns :func:`memo`: a table computed by an analysis function (not an
experiment's loops: a measurement such as Exp 10's saturation split), filed in the result
folder's ``analyses/`` under a digest of the function's name, its arguments and
:data:`MEMO_VERSION`, with the digest of its own content; a missing, damaged or altered copy
is recomputed (with a warning for the latter two), and under
``UAVWIND_PAGES_READ_ONLY`` a page that would compute it fails naming it
(:func:`uavwind.core.io.refuse_to_compute`). :data:`PAGE_ANALYSES` lists what the fill
computes (``python -m uavwind analyses``).
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable, Mapping

import pandas as pd

from ..core.io import atomic_write, refuse_to_compute
from ..study.cache import content_digest, results_dir

__all__ = ["memo", "MEMO_VERSION", "PAGE_ANALYSES", "fill_page_analyses"]

#: Bump when an analysis routed through :func:`memo` changes its numbers.
MEMO_VERSION = "1"


def memo(name: str, params: Mapping, compute: Callable[[], pd.DataFrame],
         results=None) -> pd.DataFrame:
    """``compute()``'s table, cached under ``name`` and ``params`` (JSON-serialisable: the
    arguments that determine it); see the module text."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"name must be an identifier, got {name!r}")
    key = hashlib.sha256(json.dumps({"name": name, "params": params, "version": MEMO_VERSION},
                                    sort_keys=True, default=str).encode()).hexdigest()
    path = results_dir(results) / "analyses" / f"{name}-{key[:20]}.parquet"
    if path.exists():
        try:
            df = pd.read_parquet(path)
            flat = df.reset_index(drop=True)
            if df.attrs.get("inputs") == key and df.attrs.get("content") == content_digest(flat):
                return df
            why = "its content does not match its digest"
        except Exception as exc:
            why = f"{type(exc).__name__}: {exc}"
        warnings.warn(f"{path.name}: cached analysis not trusted ({why}); recomputing",
                      stacklevel=2)
    refuse_to_compute(f"the analysis {name} ({path.name})")
    df = compute()
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must compute a pandas DataFrame, got {type(df).__name__}")
    df.attrs.update(inputs=key, content=content_digest(df.reset_index(drop=True)))
    atomic_write(path, lambda tmp: df.to_parquet(tmp))
    return pd.read_parquet(path)


def _exp10_hover_settings():
    from ..study.registry import EXPERIMENTS
    return [c.setting for c in EXPERIMENTS["exp10"].cases()
            if c.labels["vehicle"] == "multirotor, RotorPy drag, hover"
            and c.labels["noise"] == "none" and c.labels["scenario_id"] > 0]


def saturation_split(seed: int, results=None) -> pd.DataFrame:
    """Exp 10's saturation split (:func:`uavwind.analysis.manoeuvres.saturation_split` on its
    hovering, RotorPy-drag, noise-free Table 2 settings, 10 loops each), cached."""
    from . import manoeuvres
    return memo("exp10_saturation_split", {"seed": seed, "n_loops": 10},
                lambda: manoeuvres.saturation_split(_exp10_hover_settings(), n_loops=10,
                                                    seed=seed), results)


def drift_offsets(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.drift_offsets` over 20 sequences, cached."""
    from . import manoeuvres
    return memo("exp10_drift_offsets", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.drift_offsets(20, seed=seed), results)


def zero_thrust_sensitivity(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.zero_thrust_sensitivity` over 20 sequences, cached."""
    from . import manoeuvres
    return memo("exp10_zero_thrust_sensitivity", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.zero_thrust_sensitivity(20, seed=seed), results)


#: What the fill computes for the pages: name -> function of ``(seed, results)``.
PAGE_ANALYSES = {"exp10_saturation_split": saturation_split,
                 "exp10_drift_offsets": drift_offsets,
                 "exp10_zero_thrust_sensitivity": zero_thrust_sensitivity}


def fill_page_analyses(seed: int, results=None, n_jobs: int | None = None) -> list[str]:
    """Compute every :data:`PAGE_ANALYSES` entry missing from the cache, one per worker;
    the names, in order."""
    from joblib import Parallel, delayed

    from ..core.parallel import check_jobs
    Parallel(n_jobs=check_jobs(n_jobs))(delayed(f)(seed, results) for f in PAGE_ANALYSES.values())
    return list(PAGE_ANALYSES)
