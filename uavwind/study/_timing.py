"""The fill's timing report: what each computed entry cost, and where a run's compute went.

This module owns the CPU accounting of :func:`uavwind.study.fill.fill_cache`:
:func:`_cpu_seconds` (this process and each of its live children, by pid, so a task's cost
includes the workers it started), the ``times`` record of one computed entry or analysis
(:func:`_entry_record`, :func:`_analysis_record`), appended as each finishes, and
:func:`time_by_experiment`, which sums a run's records per experiment and reading
(``python -m uavwind run --times FILE`` writes the records, and prints that sum).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from .registry import EXPERIMENTS

if TYPE_CHECKING:
    from .runner import Entry


def _cpu_seconds():
    """CPU seconds (user + system) of this process and of each of its live children, by
    pid: a task's cost is the difference, workers it started included."""
    import psutil

    me = psutil.Process()
    out = {0: time.process_time()}
    for child in me.children(recursive=True):
        try:
            t = child.cpu_times()
            out[child.pid] = t.user + t.system
        except psutil.Error:
            pass
    return out


def _entry_record(entry: Entry, pairs: Sequence[tuple[str, str]], rows: int, tasks: int,
                  cpu: float) -> dict:
    """The ``times`` record of ``entry``, computed in ``tasks`` tasks into ``rows`` rows for
    ``cpu`` CPU seconds: ``pairs`` are the (experiment, reading) pairs that need it, the
    first first (the record's experiment; its reading, or ``"both"`` if both readings need
    it; the other experiments are ``shared_with``)."""
    readings = {r for _, r in pairs}
    return {"experiment": pairs[0][0],
            "reading": pairs[0][1] if len(readings) == 1 else "both",
            "shared_with": sorted({x for x, _ in pairs} - {pairs[0][0]}),
            "case": entry.labels["case"], "search": entry.search, "n_env": entry.setting.n_env,
            "rows": rows, "tasks": tasks, "cpu_seconds": cpu}


def _analysis_record(name: str, cpu: float) -> dict:
    """The ``times`` record of the analysis ``name`` (one task, ``cpu`` CPU seconds)."""
    return {"experiment": name, "reading": "both", "shared_with": [], "case": name,
            "search": "analysis", "n_env": 0, "rows": 0, "tasks": 1, "cpu_seconds": cpu}


def time_by_experiment(times: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """Where the compute of a :func:`fill_cache` run went: its ``times`` records summed
    per experiment and reading.

    Returns
    -------
    pandas.DataFrame
        Indexed by (``experiment``, ``reading``), experiments in registry order (``reading``
        is ``"both"`` for entries both readings share; an entry two experiments share is
        counted under the first), with
        ``entries``, ``rows`` (loops, CEM samples or closed-loop reports), ``cpu_seconds`` and ``share`` (% of
        the run's CPU seconds); empty if nothing was computed.

    Examples
    --------
    >>> t = [{"experiment": "exp5", "reading": "inferred", "case": 0, "search": "random",
    ...       "n_env": 6, "rows": 50, "cpu_seconds": 3.0},
    ...      {"experiment": "exp1", "reading": "inferred", "case": 0, "search": "random",
    ...       "n_env": 6, "rows": 50, "cpu_seconds": 1.0}]
    >>> time_by_experiment(t)["share"].tolist()
    [25.0, 75.0]
    """
    cols = ["entries", "rows", "cpu_seconds", "share"]
    if not times:
        return pd.DataFrame(columns=cols, index=pd.MultiIndex.from_tuples(
            [], names=["experiment", "reading"]))
    df = pd.DataFrame(list(times))
    for col in ("experiment", "reading", "rows", "cpu_seconds"):
        if col not in df.columns:
            raise ValueError(f"times records must each have {col!r}; a record lacks it")
    for col in ("rows", "cpu_seconds"):
        v = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(v) | (v < 0)
        if bad.any():
            raise ValueError(f"times record {int(np.argmax(bad))} has {col} = "
                             f"{df[col].iloc[int(np.argmax(bad))]!r}: must be a finite "
                             f"number >= 0")
    out = df.groupby(["experiment", "reading"]).agg(
        entries=("rows", "size"), rows=("rows", "sum"), cpu_seconds=("cpu_seconds", "sum"))
    out["share"] = 100 * out["cpu_seconds"] / out["cpu_seconds"].sum()
    order = {k: i for i, k in enumerate(EXPERIMENTS)}
    return out.sort_index(key=lambda ix: ix.map(order) if ix.name == "experiment" else ix)
