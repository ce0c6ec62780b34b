"""The analyses the pages read: computed once by the fill, read back by the pages.

This module owns the book's page analyses -- a summary of an experiment's results (the
claims' verdicts, the fitted layouts, Exp 12's curves), a measurement of its own (Exp 10's
saturation split, the inference page's scale invariance) or an exercise's small run -- each
cached by :func:`uavwind.analysis.memo.memo` (or :func:`~uavwind.analysis.memo.derived`)
under the same name and arguments for the fill and the page, and the settings they fly
(:data:`SATURATION_LOOPS`, :data:`DRIFT_WIND`, ...), which a page asks for here instead of
typing them again.

Each is registered where it is defined, with the experiments it reads, in the one registry
(:func:`uavwind.study.registry.computes`), so the fill and the pages cannot drift apart: the
fill (``make results``: ``python -m uavwind run all --reading all``, one pool) runs each as a
task once what it reads is stored, and ``python -m uavwind run ID`` runs one.

An exercise's solution is the page's own executed cell (tagged ``exercise-computes``, see
:mod:`uavwind.report.pages`), its output printed under it. Exp 12's first exercise is
:func:`uavwind.run_experiment` on cache entries of the experiment itself, which the fill
stores (:func:`exp12_inferred_exercise`) and the page's cell reads back.
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from ..method.clustering import score_loop
from ..sim.actions import PAPER_EXAMPLE
from ..study.builders import make_setting
from ..study.conditions import table3_setting
from ..study.readings import DEFAULT_READING
from ..study.registry import EXPERIMENTS, computes
from ..study.runner import run_experiment
from ..core import stats
from . import beyond, claims, inference, manoeuvres
from . import closed_loop as closed_loop_analysis
from .claims import c1_by_vehicle, compare_readings, needed_experiments
from .closed_loop import accuracy_over_time, closing_the_loop, time_to_confidence
from .memo import derived, derived_many, memo

#: The modules whose rules make the claims' verdicts: a change in any is a new cache entry.
_CLAIMS_CODE = (claims, beyond, stats)

__all__ = ["CLAIMS_READINGS", "C1_READING", "claims_inputs", "claims_verdicts", "c1_vehicles",
           "layout_fits", "SCALE_FACTOR", "SCALE_LAYOUTS", "SCALE_ENVIRONMENTS",
           "scale_invariance_loops", "scale_invariance_summary", "exp12_summaries",
           "SATURATION_LOOPS", "exp10_hover_settings", "saturation_split",
           "DRIFT_LOOPS", "DRIFT_WIND", "drift_offsets", "SENSITIVITY_LOOPS",
           "SENSITIVITY_WIND", "SENSITIVITY_DELTA", "zero_thrust_sensitivity",
           "exp12_inferred_exercise", "model_example"]

def _read(exp_id, profile, seed, results, reading=None, n_jobs=1):
    return run_experiment(exp_id, profile=profile, seed=seed, n_jobs=n_jobs, reading=reading,
                          results=results, progress=False)


# ---- the claims page ----------------------------------------------------------------- #
#: The readings the claims page judges the claims under, side by side.
CLAIMS_READINGS = ("inferred", "halves")
#: The reading of Exp 10 that claim C1 is judged on for each vehicle.
C1_READING = DEFAULT_READING


def claims_inputs(profile: str, seed: int, n_jobs: int = 1,
                  results=None) -> dict[str, dict[str, pd.DataFrame]]:
    """What :func:`claims_verdicts` judges: reading (:data:`CLAIMS_READINGS`) -> experiment
    id (:func:`~uavwind.analysis.claims.needed_experiments`) -> its result table."""
    return {r: {i: _read(i, profile, seed, results, r, n_jobs) for i in needed_experiments()}
            for r in CLAIMS_READINGS}


def claims_verdicts(by_reading: Mapping[str, Mapping[str, pd.DataFrame]],
                    results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.claims.compare_readings` (its bootstraps), cached."""
    inputs = {f"{r}/{i}": df for r, res in by_reading.items() for i, df in res.items()}
    return derived("claims_verdicts", lambda: compare_readings(by_reading), inputs,
                   results=results, code=_CLAIMS_CODE)


def fewer_loops(by_reading: Mapping[str, Mapping[str, pd.DataFrame]], reading: str = "halves",
                results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.claims.verdicts_at_fewer_loops` of one reading, cached: how
    the claims' verdicts would change if every case had run fewer loops (the question a
    reading's loop count is sized on)."""
    res = by_reading[reading]
    return derived(f"claims_fewer_loops_{reading}",
                   lambda: claims.verdicts_at_fewer_loops(res),
                   {f"{reading}/{i}": df for i, df in res.items()}, results=results,
                   code=_CLAIMS_CODE)


def c1_vehicles(exp10: pd.DataFrame, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.claims.c1_by_vehicle` on Exp 10's table, cached."""
    return derived("claims_c1_by_vehicle", lambda: c1_by_vehicle(exp10), {"exp10": exp10},
                   results=results, code=_CLAIMS_CODE)


@computes("claims", reads=(*needed_experiments(), "exp10"), title="The claims' verdicts",
          notebook="claims.md")
def _fill_claims(profile, seed, results):
    inputs = claims_inputs(profile, seed, results=results)
    claims_verdicts(inputs, results)
    fewer_loops(inputs, "halves", results)
    c1_vehicles(_read("exp10", profile, seed, results, C1_READING), results)


# ---- the inference page -------------------------------------------------------------- #
#: The factor the scale-invariance table multiplies every wind by.
SCALE_FACTOR = 10.0
#: The layouts (a condition against itself) of the scale-invariance table.
SCALE_LAYOUTS = ("light constant", "light shear")
#: Environments a group in the scale-invariance table.
SCALE_ENVIRONMENTS = 5


def layout_fits(fit_results: pd.DataFrame, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.inference.fit_layouts` (its bootstraps), cached."""
    return derived("inference_layout_fits", lambda: inference.fit_layouts(fit_results),
                   {"fit_layout": fit_results}, results=results, code=(inference, stats))


def scale_invariance_loops(profile: str) -> int:
    """Loops of the scale-invariance table at ``profile``: 20 at the paper's, 4 otherwise."""
    return 20 if profile == "paper" else 4


def scale_invariance_summary(profile: str, seed: int, results=None) -> pd.DataFrame:
    """The inference page's scale-invariance table: for each of :data:`SCALE_LAYOUTS`
    (:data:`SCALE_ENVIRONMENTS` environments a group),
    :func:`uavwind.analysis.inference.scale_invariance` with a factor of
    :data:`SCALE_FACTOR` over :func:`scale_invariance_loops` loops, described by mean, std,
    min and max of the difference; cached."""
    n = scale_invariance_loops(profile)

    def compute():
        rows = {cond: inference.scale_invariance(
                    make_setting(cond, cond, SCALE_ENVIRONMENTS), factor=SCALE_FACTOR,
                    n_loops=n, seed=seed, n_jobs=1)["difference"]
                .describe()[["mean", "std", "min", "max"]] for cond in SCALE_LAYOUTS}
        return pd.DataFrame(rows).T.rename_axis("layout").assign(n_loops=n)
    return memo("inference_scale_invariance", {"n_loops": n, "seed": seed, "factor": SCALE_FACTOR,
                                                 "layouts": list(SCALE_LAYOUTS),
                                                 "environments": SCALE_ENVIRONMENTS},
                compute, results)


@computes("inference", reads=("fit_layout",), title="Layout fits, scale invariance",
          notebook="inference.md")
def _fill_inference(profile, seed, results):
    layout_fits(_read("fit_layout", profile, seed, results), results)
    scale_invariance_summary(profile, seed, results)


# ---- Exp 12's page ------------------------------------------------------------------- #
def exp12_summaries(exp12: pd.DataFrame, results=None) -> dict[str, pd.DataFrame]:
    """Exp 12's page summaries of its result table, cached by
    :func:`~uavwind.analysis.memo.derived_many` (the table's content digest taken once for
    the three: 0.9 s on the paper profile's 115,200 rows):
    ``"curves"`` (:func:`~uavwind.analysis.closed_loop.accuracy_over_time`, its bootstraps),
    ``"time_to_confidence"`` and ``"closing"``
    (:func:`~uavwind.analysis.closed_loop.closing_the_loop`)."""
    summaries = {"curves": accuracy_over_time, "time_to_confidence": time_to_confidence,
                 "closing": closing_the_loop}
    made = derived_many({f"exp12_{k}": (lambda f=f: f(exp12)) for k, f in summaries.items()},
                        {"exp12": exp12}, results, code=(closed_loop_analysis, stats))
    return {k: made[f"exp12_{k}"] for k in summaries}


@computes("exp12_summaries", reads=("exp12",), title="Exp 12's curves and summaries",
          notebook="exp12_closed_loop.md")
def _fill_exp12(profile, seed, results):
    exp12_summaries(_read("exp12", profile, seed, results, EXPERIMENTS["exp12"].readings[0]),
                    results)


# ---- Exp 10's page: where the motors saturate, the drift, zero thrust ---------------- #
#: Loops per setting of Exp 10's saturation split.
SATURATION_LOOPS = 10
#: Thrust sequences of the drift check (the paper's, drawn from the page's seed).
DRIFT_LOOPS = 20
#: The constant wind [m/s] the drift check flies through (beside still air).
DRIFT_WIND = (3.0, -2.0, 0.0)
#: Thrust sequences of the zero-thrust sensitivity.
SENSITIVITY_LOOPS = 20
#: The constant wind [m/s] the zero-thrust sensitivity flies through.
SENSITIVITY_WIND = (0.5, 0.5, 0.0)
#: The change of :data:`SENSITIVITY_WIND` along x [m/s] whose effect on the end of a
#: hovering flight the zero-thrust sensitivity measures.
SENSITIVITY_DELTA = 1e-9


def exp10_hover_settings() -> list:
    """The settings :func:`saturation_split` flies: Exp 10's hovering, RotorPy-drag,
    noise-free cases of the paper's Table 2 scenarios (the page counts its loops from them)."""
    return [c.setting for c in EXPERIMENTS["exp10"].cases()
            if c.labels["vehicle"] == "multirotor, RotorPy drag, hover"
            and c.labels["noise"] == "none" and c.labels["scenario_id"] > 0]


@computes("exp10_saturation_split", title="Exp 10: where the motors saturate",
          notebook="exp10_multirotor.md")
def saturation_split(seed: int, results=None) -> pd.DataFrame:
    """Exp 10's saturation split (:func:`uavwind.analysis.manoeuvres.saturation_split` on
    :func:`exp10_hover_settings`, :data:`SATURATION_LOOPS` loops each), cached."""
    return memo("exp10_saturation_split", {"seed": seed, "n_loops": SATURATION_LOOPS},
                lambda: manoeuvres.saturation_split(exp10_hover_settings(),
                                                    n_loops=SATURATION_LOOPS, seed=seed),
                results)


@computes("exp10_drift_offsets", title="Exp 10: the drift check", notebook="exp10_multirotor.md")
def drift_offsets(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.drift_offsets` over :data:`DRIFT_LOOPS` sequences
    in :data:`DRIFT_WIND`, cached."""
    return memo("exp10_drift_offsets", {"seed": seed, "n_loops": DRIFT_LOOPS,
                                         "wind": list(DRIFT_WIND)},
                lambda: manoeuvres.drift_offsets(DRIFT_LOOPS, seed=seed, wind=DRIFT_WIND),
                results)


@computes("exp10_zero_thrust_sensitivity", title="Exp 10: zero-thrust sensitivity",
          notebook="exp10_multirotor.md")
def zero_thrust_sensitivity(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.zero_thrust_sensitivity` over
    :data:`SENSITIVITY_LOOPS` sequences in :data:`SENSITIVITY_WIND`, changed by
    :data:`SENSITIVITY_DELTA`, cached."""
    return memo("exp10_zero_thrust_sensitivity", {"seed": seed, "n_loops": SENSITIVITY_LOOPS,
                                                   "wind": list(SENSITIVITY_WIND),
                                                   "delta": SENSITIVITY_DELTA},
                lambda: manoeuvres.zero_thrust_sensitivity(
                    SENSITIVITY_LOOPS, seed=seed, wind=SENSITIVITY_WIND,
                    delta=SENSITIVITY_DELTA), results)


# ---- the exercises' small runs: the code each solution shows, run by the fill ----------- #
@computes("exp12_inferred_exercise", reads=("exp12",), title="Exp 12's exercise",
          notebook="exp12_closed_loop.md")
def exp12_inferred_exercise(seed: int, results=None) -> pd.DataFrame:
    """Exp 12's exercise: its first two cases under the inferred reading, quick profile
    (cache entries of the experiment itself)."""
    return run_experiment("exp12", profile="quick", seed=seed, n_jobs=1, reading="inferred",
                          cases=[0, 1], results=results, progress=False)


@computes("model_example", title="The worked example's one loop", notebook="model.md")
def model_example(results=None) -> pd.DataFrame:
    """The model page's worked example: one loop of the paper's example thrust in Table 3's
    setting, as :meth:`uavwind.LoopResult.to_table` (the paper's one-loop table), cached."""
    def compute():
        setting = table3_setting()
        return score_loop(setting.simulate(PAPER_EXAMPLE), setting.groups).to_table(PAPER_EXAMPLE)
    return memo("model_example", {}, compute, results)
