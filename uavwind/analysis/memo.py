"""Analyses the pages show, computed once by the fill and read by the pages.

This module owns :func:`memo`: a table computed by an analysis function (not an
experiment's loops: a measurement such as Exp 10's saturation split), filed by the one
verified cache (:func:`uavwind.core.store.get_or_compute`) in the result folder's
``analyses/`` under a key of the function's name, its arguments and :data:`MEMO_VERSION`,
with the digest of its own content (index included); a missing, damaged or altered copy is
recomputed (the latter two moved aside, with a warning naming the file), and under
``UAVWIND_PAGES_READ_ONLY`` a page that would compute it fails naming it
(:func:`uavwind.core.io.refuse_to_compute`). :data:`PAGE_ANALYSES` lists what the fill
computes and :func:`page_analyses` hands them to it as tasks, each with the experiments it
reads (``make results``: ``python -m uavwind run all --reading all``, one pool).

An exercise's solution is the page's own executed cell (tagged ``exercise-computes``, see
:mod:`uavwind.report.pages`), its output printed under it. Exp 12's first exercise is
:func:`uavwind.run_experiment` on cache entries of the experiment itself, which the fill
stores (:func:`exp12_inferred_exercise`) and the page's cell reads back.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import pandas as pd

from ..core.store import content_digest, get_or_compute
from ..method.clustering import score_loop
from ..sim.actions import PAPER_EXAMPLE
from ..study.builders import make_setting
from ..study.conditions import table3_setting
from ..study.fill import Analysis
from ..study.readings import DEFAULT_READING
from ..study.registry import EXPERIMENTS
from ..study.runner import run_experiment
from . import inference, manoeuvres
from .claims import c1_by_vehicle, compare_readings, needed_experiments
from .closed_loop import accuracy_over_time, closing_the_loop, time_to_confidence

__all__ = ["memo", "derived", "MEMO_VERSION", "PAGE_ANALYSES", "page_analyses",
           "claims_verdicts", "c1_vehicles", "layout_fits", "scale_invariance_summary",
           "exp12_summaries", "exp10_hover_settings", "SATURATION_LOOPS",
           "model_example"]

#: Bump when an analysis routed through :func:`memo` changes its numbers.
MEMO_VERSION = "1"


def memo(name: str, params: Mapping, compute: Callable[[], pd.DataFrame],
         results=None) -> pd.DataFrame:
    """``compute()``'s table, cached under ``name`` and ``params`` (JSON-serialisable: the
    arguments that determine it) as ``analyses/<name>-<key>.parquet``; see the module text.
    An entry written before the store (its digest in ``attrs``, not in the file's metadata)
    is trusted if that digest still matches, and given the store's."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"name must be an identifier, got {name!r}")
    if not isinstance(params, Mapping):
        raise TypeError(f"params must be a mapping, got {type(params).__name__}")
    return get_or_compute("analyses", {"name": name, "params": params}, compute,
                          folder=results, version=MEMO_VERSION, name=name,
                          legacy=_legacy_memo, what=f"analysis {name}")


def _legacy_memo(df) -> bool:
    """True for a table :func:`memo` wrote before the store whose own digest (of its columns,
    in ``attrs``) still matches."""
    stored = df.attrs.get("content") if isinstance(df, pd.DataFrame) else None
    return isinstance(stored, str) and stored == content_digest(df.reset_index(drop=True))


def derived(name: str, compute: Callable[[], pd.DataFrame], inputs: Mapping[str, pd.DataFrame],
            results=None) -> pd.DataFrame:
    """:func:`memo` for a table computed from result tables alone: cached under ``name`` and
    the content digests of ``inputs`` (name -> the tables ``compute`` reads), so a page and
    the fill that load the same results find the same entry, and a changed result is a new
    one."""
    return memo(name, _input_key(inputs), compute, results)


def _input_key(inputs: Mapping[str, pd.DataFrame]) -> dict:
    """:func:`derived`'s parameters: the content digest of each input table."""
    return {"inputs": {k: content_digest(df.reset_index(drop=True)) for k, df in inputs.items()}}


def claims_verdicts(by_reading: Mapping[str, Mapping[str, pd.DataFrame]],
                    results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.claims.compare_readings` (its bootstraps), cached."""
    inputs = {f"{r}/{i}": df for r, res in by_reading.items() for i, df in res.items()}
    return derived("claims_verdicts", lambda: compare_readings(by_reading), inputs,
                   results=results)


def c1_vehicles(exp10: pd.DataFrame, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.claims.c1_by_vehicle` on Exp 10's table, cached."""
    return derived("claims_c1_by_vehicle", lambda: c1_by_vehicle(exp10), {"exp10": exp10},
                   results=results)


def layout_fits(fit_results: pd.DataFrame, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.inference.fit_layouts` (its bootstraps), cached."""
    return derived("inference_layout_fits", lambda: inference.fit_layouts(fit_results),
                   {"fit_layout": fit_results}, results=results)


def scale_invariance_summary(profile: str, seed: int, results=None) -> pd.DataFrame:
    """The inference page's scale-invariance table: for light constant and light shear (5
    environments a group), :func:`uavwind.analysis.inference.scale_invariance` with a factor
    of 10 over 20 loops (4 at the quick profile), described by mean, std, min and max of the
    difference; cached."""
    n = 20 if profile == "paper" else 4

    def compute():
        rows = {cond: inference.scale_invariance(make_setting(cond, cond, 5), factor=10.0,
                                                 n_loops=n, seed=seed, n_jobs=1)["difference"]
                .describe()[["mean", "std", "min", "max"]] for cond in ("light constant",
                                                                       "light shear")}
        return pd.DataFrame(rows).T.rename_axis("layout").assign(n_loops=n)
    return memo("inference_scale_invariance", {"n_loops": n, "seed": seed}, compute, results)


def exp12_summaries(exp12: pd.DataFrame, results=None) -> dict[str, pd.DataFrame]:
    """Exp 12's page summaries of its result table, each cached as :func:`derived` caches
    it, the table's content digest taken once for the three (0.9 s on the paper profile's
    115,200 rows):
    ``"curves"`` (:func:`~uavwind.analysis.closed_loop.accuracy_over_time`, its bootstraps),
    ``"time_to_confidence"`` and ``"closing"``
    (:func:`~uavwind.analysis.closed_loop.closing_the_loop`)."""
    key = _input_key({"exp12": exp12})
    summaries = {"curves": accuracy_over_time, "time_to_confidence": time_to_confidence,
                 "closing": closing_the_loop}
    return {k: memo(f"exp12_{k}", key, lambda f=f: f(exp12), results)
            for k, f in summaries.items()}


def _read(exp_id, profile, seed, results, reading=None):
    return run_experiment(exp_id, profile=profile, seed=seed, n_jobs=1, reading=reading,
                          results=results, progress=False)


def _fill_claims(profile, seed, results):
    by_reading = {r: {i: _read(i, profile, seed, results, r) for i in needed_experiments()}
                  for r in ("inferred", "halves")}
    claims_verdicts(by_reading, results)
    c1_vehicles(_read("exp10", profile, seed, results, DEFAULT_READING), results)


def _fill_exp12(profile, seed, results):
    exp12_summaries(_read("exp12", profile, seed, results, EXPERIMENTS["exp12"].readings[0]),
                    results)


def _fill_inference(profile, seed, results):
    layout_fits(_read("fit_layout", profile, seed, results), results)
    scale_invariance_summary(profile, seed, results)


#: Loops per setting of Exp 10's saturation split.
SATURATION_LOOPS = 10


def exp10_hover_settings() -> list:
    """The settings :func:`saturation_split` flies: Exp 10's hovering, RotorPy-drag,
    noise-free cases of the paper's Table 2 scenarios (the page counts its loops from them)."""
    return [c.setting for c in EXPERIMENTS["exp10"].cases()
            if c.labels["vehicle"] == "multirotor, RotorPy drag, hover"
            and c.labels["noise"] == "none" and c.labels["scenario_id"] > 0]


def saturation_split(seed: int, results=None) -> pd.DataFrame:
    """Exp 10's saturation split (:func:`uavwind.analysis.manoeuvres.saturation_split` on its
    hovering, RotorPy-drag, noise-free Table 2 settings, 10 loops each), cached."""
    return memo("exp10_saturation_split", {"seed": seed, "n_loops": SATURATION_LOOPS},
                lambda: manoeuvres.saturation_split(exp10_hover_settings(),
                                                    n_loops=SATURATION_LOOPS, seed=seed),
                results)


def drift_offsets(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.drift_offsets` over 20 sequences, cached."""
    return memo("exp10_drift_offsets", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.drift_offsets(20, seed=seed), results)


def zero_thrust_sensitivity(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.zero_thrust_sensitivity` over 20 sequences, cached."""
    return memo("exp10_zero_thrust_sensitivity", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.zero_thrust_sensitivity(20, seed=seed), results)


def exp12_inferred_exercise(seed: int, results=None) -> pd.DataFrame:
    """Exp 12's exercise: its first two cases under the inferred reading, quick profile
    (cache entries of the experiment itself)."""
    return run_experiment("exp12", profile="quick", seed=seed, n_jobs=1, reading="inferred",
                          cases=[0, 1], results=results, progress=False)


# ---- the exercises' small runs: the code each solution shows, run by the fill ----------- #
def model_example(results=None) -> pd.DataFrame:
    """The model page's worked example: one loop of the paper's example thrust in Table 3's
    setting, as :meth:`uavwind.LoopResult.to_table` (the paper's one-loop table), cached."""
    def compute():
        setting = table3_setting()
        return score_loop(setting.simulate(PAPER_EXAMPLE), setting.groups).to_table(PAPER_EXAMPLE)
    return memo("model_example", {}, compute, results)


def _seed_only(f):
    def fill(profile, seed, results):
        return f(seed, results)
    fill.__name__ = f.__name__
    return fill


#: What the fill computes for the pages: name -> function of ``(profile, seed, results)``
#: (the experiments' results must already be in the cache).
def _fixed(f):
    def fill(profile, seed, results):
        return f(results)
    fill.__name__ = f.__name__
    return fill


PAGE_ANALYSES = {"claims": _fill_claims,
                 "inference": _fill_inference,
                 "exp12": _fill_exp12,
                 "exp10_saturation_split": _seed_only(saturation_split),
                 "exp10_drift_offsets": _seed_only(drift_offsets),
                 "exp10_zero_thrust_sensitivity": _seed_only(zero_thrust_sensitivity),
                 "exp12_inferred_exercise": _seed_only(exp12_inferred_exercise),
                 "model_example": _fixed(model_example)}


#: The experiments a page analysis reads (the others compute their own small runs).
PAGE_ANALYSIS_READS = {"claims": (*needed_experiments(), "exp10"),
                       "inference": ("fit_layout",),
                       "exp12": ("exp12",),
                       "exp12_inferred_exercise": ("exp12",)}


def page_analyses() -> list[Analysis]:
    """:data:`PAGE_ANALYSES` as the fill's tasks (:class:`~uavwind.study.fill.Analysis`),
    each with the experiments it reads (:data:`PAGE_ANALYSIS_READS`)."""
    return [Analysis(name, f, PAGE_ANALYSIS_READS.get(name, ()))
            for name, f in PAGE_ANALYSES.items()]
