"""Experiment 13 as one run: how the study's registry reaches the real flights.

This module owns Experiment 13's whole run -- what ``run_experiment("exp13")``, ``python -m
uavwind run exp13`` and the fill of ``make results`` compute: :func:`run_exp13` reads
Neural-Fly's flights from ``folder`` (default ``$UAVWIND_NEURALFLY``), computes (or reads from
the result cache) their rows (:func:`uavwind.analysis.real_flights.real_flight_rows`), then the
calibrated twin's (:func:`uavwind.analysis.figure8.sim_rows`), and returns the real ones.

The study's registry lists Exp 13 (:data:`uavwind.study.registry.MEASURED`) but cannot
import this layer, which sits above it: the package's face registers :func:`run_exp13` with
it (:func:`~uavwind.study.registry.register_measured`), importing this module only when Exp
13 runs, so every process that imports uavwind runs Exp 13 by name without loading the
analysis layer first.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from .figure8 import sim_rows
from .real_flights import real_flight_rows

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["run_exp13"]


def run_exp13(profile: str = "quick", results: os.PathLike | str | None = None,
              n_jobs: int | None = None, folder: os.PathLike | str | None = None
              ) -> pd.DataFrame:
    """Experiment 13's real-flight rows (:func:`~uavwind.analysis.real_flights.real_flight_rows`
    of the flights in ``folder``, default ``$UAVWIND_NEURALFLY``), with its simulated twin's
    rows computed and cached beside them (:func:`~uavwind.analysis.figure8.sim_rows` reads them
    back), each from the result cache ``results`` when it is there; ``profile`` is
    ``"quick"`` or ``"paper"``, ``n_jobs`` the workers of what is computed. Without a folder,
    a ``ValueError`` saying how to get the flights."""
    real = real_flight_rows(folder, profile=profile, results=results, n_jobs=n_jobs)
    sim_rows(real, profile=profile, results=results, n_jobs=n_jobs)
    return real
