"""Experiment 13 as one entry of the registry: the real flights, then their twin.

This module owns Experiment 13's whole run -- what ``run_experiment("exp13")``, ``python -m
uavwind run exp13`` and the fill of ``make results`` compute: :func:`run_exp13` reads
Neural-Fly's flights from ``folder`` (default ``$UAVWIND_NEURALFLY``), computes (or reads from
the result cache) their rows (:func:`uavwind.analysis.real_flights.real_flight_rows`), then the
calibrated twin's (:func:`uavwind.analysis.figure8.sim_rows`), and returns the real ones. It
joins the registry here (:func:`uavwind.study.registry.computes`), with the variable that
names its flights: without them ``run all`` leaves it out, and asking for it by id fails
before any work. :func:`exp13_report` is what ``python -m uavwind run exp13`` prints.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from ..data.neuralfly import ENV_VAR as NEURALFLY_ENV
from ..study.registry import computes
from .figure8 import calibration_of, ranking_verdict, sim_rows, validation_table
from .real_flights import channel_table, real_flight_rows

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["run_exp13", "exp13_report"]


def exp13_report(profile: str = "quick", results: os.PathLike | str | None = None) -> str:
    """Experiment 13's tables as text, read from the result cache (computed there if
    missing): the real flights' channel table, the simulated twin's validation and whether
    the simulation ranks the channels as the real flights do."""
    real = run_exp13(profile, results=results, n_jobs=1)
    sim = sim_rows(real, profile=profile, results=results)  # computed beside it: read back
    real_ch, sim_ch = channel_table(real), channel_table(sim)
    cal = calibration_of(sim)
    v = ranking_verdict(real_ch, sim_ch)
    return "\n".join([
        f"exp13 ({profile} profile): real flights, mean score over controllers (95% CI over "
        f"controllers)",
        real_ch.round(2).to_string(), "",
        f"simulated twin (drag x {cal.drag_scale:.3f}, lift x {cal.lift_scale:.3f}, gusts "
        f"W20 = {cal.gust_scale:.3f} x the mean speed; fitted on "
        f"{', '.join(cal.controllers)}, checked on {sim.attrs['held_out']}):",
        validation_table(real, sim).round(2).to_string(), "",
        f"does the simulation rank the channels as the real flights do? {v['verdict']} "
        f"(agree {len(v['agree'])}, disagree {len(v['disagree'])}, tied in the simulation "
        f"{len(v['sim_tied'])}, Spearman {v['spearman']:.2f})"])


def _show(profile, seed, results):
    return exp13_report(profile, results=results)


@computes("exp13", long=True, title="Real flights (Neural-Fly)", notebook="exp13_real_flights.md",
          data=NEURALFLY_ENV, show=_show)
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
