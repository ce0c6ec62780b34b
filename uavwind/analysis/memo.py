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
from dataclasses import replace

import pandas as pd

from ..core.io import atomic_write, refuse_to_compute
from ..core.parallel import check_jobs
from ..method.closed_loop import ClosedLoop, Greedy, RecedingCEM, run_episodes
from ..sim.observation import Noise
from ..study.builders import make_setting
from ..study.cache import content_digest, results_dir
from ..study.readings import DEFAULT_READING
from ..study.registry import EXPERIMENTS
from ..study.runner import run_experiment
from . import inference, manoeuvres
from .claims import c1_by_vehicle, compare_readings, needed_experiments
from .closed_loop import time_to_confidence

__all__ = ["memo", "derived", "MEMO_VERSION", "PAGE_ANALYSES", "fill_page_analyses",
           "claims_verdicts", "c1_vehicles", "layout_fits", "scale_invariance_summary"]

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


def derived(name: str, compute: Callable[[], pd.DataFrame], inputs: Mapping[str, pd.DataFrame],
            results=None) -> pd.DataFrame:
    """:func:`memo` for a table computed from result tables alone: cached under ``name`` and
    the content digests of ``inputs`` (name -> the tables ``compute`` reads), so a page and
    the fill that load the same results find the same entry, and a changed result is a new
    one."""
    digests = {k: content_digest(df.reset_index(drop=True)) for k, df in inputs.items()}
    return memo(name, {"inputs": digests}, compute, results)


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


def _read(exp_id, profile, seed, results, reading=None):
    return run_experiment(exp_id, profile=profile, seed=seed, n_jobs=1, reading=reading,
                          results=results, progress=False)


def _fill_claims(profile, seed, results):
    by_reading = {r: {i: _read(i, profile, seed, results, r) for i in needed_experiments()}
                  for r in ("inferred", "halves")}
    claims_verdicts(by_reading, results)
    c1_vehicles(_read("exp10", profile, seed, results, DEFAULT_READING), results)


def _fill_inference(profile, seed, results):
    layout_fits(_read("fit_layout", profile, seed, results), results)
    scale_invariance_summary(profile, seed, results)


def _exp10_hover_settings():
    return [c.setting for c in EXPERIMENTS["exp10"].cases()
            if c.labels["vehicle"] == "multirotor, RotorPy drag, hover"
            and c.labels["noise"] == "none" and c.labels["scenario_id"] > 0]


def saturation_split(seed: int, results=None) -> pd.DataFrame:
    """Exp 10's saturation split (:func:`uavwind.analysis.manoeuvres.saturation_split` on its
    hovering, RotorPy-drag, noise-free Table 2 settings, 10 loops each), cached."""
    return memo("exp10_saturation_split", {"seed": seed, "n_loops": 10},
                lambda: manoeuvres.saturation_split(_exp10_hover_settings(), n_loops=10,
                                                    seed=seed), results)


def drift_offsets(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.drift_offsets` over 20 sequences, cached."""
    return memo("exp10_drift_offsets", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.drift_offsets(20, seed=seed), results)


def zero_thrust_sensitivity(seed: int, results=None) -> pd.DataFrame:
    """:func:`uavwind.analysis.manoeuvres.zero_thrust_sensitivity` over 20 sequences, cached."""
    return memo("exp10_zero_thrust_sensitivity", {"seed": seed, "n_loops": 20},
                lambda: manoeuvres.zero_thrust_sensitivity(20, seed=seed), results)


def _exp12_case(labels=None):
    exp = EXPERIMENTS["exp12"]
    cases = exp.cases(exp.readings[0])
    return cases[0] if labels is None else next(c for c in cases if c.labels == labels)


def exp12_inferred_exercise(seed: int, results=None) -> pd.DataFrame:
    """Exp 12's exercise: its first two cases under the inferred reading, quick profile
    (cache entries of the experiment itself)."""
    return run_experiment("exp12", profile="quick", seed=seed, n_jobs=1, reading="inferred",
                          cases=[0, 1], results=results, progress=False)


def exp12_noise_exercise(seed: int, results=None) -> pd.DataFrame:
    """Exp 12's exercise: the greedy policy on its first case with GNSS noise of 2.1 and
    0.21 m, 20 episodes each: per noise level the median time to 95% confidence [s] and the
    share of flights that reach it, cached."""
    def compute():
        case = _exp12_case()
        rows = []
        for sigma in (2.1, 0.21):
            prob = ClosedLoop(setting=replace(case.setting, noise=Noise(position=sigma)),
                              report_interval=0.5)
            df = run_episodes(prob, "greedy", 0, 20, seed=seed).assign(**case.labels)
            t = time_to_confidence(df)
            rows.append({"sigma": sigma, "median_time": float(t["median_time"].iloc[0]),
                         "reached": float(t["reached"].iloc[0]), "episodes": 20})
        return pd.DataFrame(rows)
    return memo("exp12_noise_exercise", {"seed": seed}, compute, results)


def exp12_horizon_exercise(seed: int, results=None) -> pd.DataFrame:
    """Exp 12's exercise: greedy beside a one-segment receding-horizon CEM on light constant
    vs light shear for the multirotor, 10 episodes: the accuracy of each at 4 s, cached."""
    def compute():
        case = _exp12_case({"scenario": "Light constant vs light shear",
                            "vehicle": "multirotor, RotorPy drag, hover"})
        prob = ClosedLoop(setting=case.setting, report_interval=0.5)
        df = run_episodes(prob, [Greedy(), RecedingCEM(horizon=1)], 0, 10, seed=seed)
        acc = df[df["time"] == 4.0].groupby("policy")["correct"].mean()
        return pd.DataFrame({"policy": acc.index.astype(str), "accuracy_at_4s": acc.to_numpy(float),
                             "episodes": 10})
    return memo("exp12_horizon_exercise", {"seed": seed}, compute, results)


def _seed_only(f):
    def fill(profile, seed, results):
        return f(seed, results)
    fill.__name__ = f.__name__
    return fill


#: What the fill computes for the pages: name -> function of ``(profile, seed, results)``
#: (the experiments' results must already be in the cache).
PAGE_ANALYSES = {"claims": _fill_claims,
                 "inference": _fill_inference,
                 "exp10_saturation_split": _seed_only(saturation_split),
                 "exp10_drift_offsets": _seed_only(drift_offsets),
                 "exp10_zero_thrust_sensitivity": _seed_only(zero_thrust_sensitivity),
                 "exp12_inferred_exercise": _seed_only(exp12_inferred_exercise),
                 "exp12_noise_exercise": _seed_only(exp12_noise_exercise),
                 "exp12_horizon_exercise": _seed_only(exp12_horizon_exercise)}


def fill_page_analyses(profile: str, seed: int, results=None, n_jobs: int | None = None,
                       first: Mapping[str, Callable] | None = None) -> list[str]:
    """Compute every :data:`PAGE_ANALYSES` entry missing from the cache, one per worker,
    after ``first`` (more such functions, from layers above this one: the longest tasks,
    dispatched first); the names, in order."""
    from joblib import Parallel, delayed
    tasks = {**(first or {}), **PAGE_ANALYSES}
    Parallel(n_jobs=check_jobs(n_jobs))(delayed(f)(profile, seed, results)
                                        for f in tasks.values())
    return list(tasks)
