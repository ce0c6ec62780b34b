"""Every public function that takes ``**kwargs`` rejects a keyword it does not know, with a
``TypeError`` naming it (python-control's ``kwargs_test.py`` habit): a misspelt keyword fails
loudly instead of being ignored.

The walk finds every such function in the package; each must have a call below, so a new
``**kwargs`` function cannot slip through untested.
"""
import importlib
import inspect
import pkgutil

import numpy as np
import pytest

import uavwind
import uavwind as uw

BAD = {"no_such_keyword": 1}


def _setting():
    return uw.make_setting("light constant", "strong constant", 2, layout="halves")


#: qualified name -> a call with valid arguments and ``**BAD``
CALLS = {
    "uavwind.analysis.wind_estimates.error_decomposition": lambda: __import__(
        "uavwind.analysis.wind_estimates", fromlist=["error_decomposition"]).error_decomposition(
        [], **BAD),
    "uavwind.analysis.real_flights.compute_rows": lambda: __import__(
        "uavwind.analysis.real_flights", fromlist=["compute_rows"]).compute_rows(
        [object()], **BAD),
    "uavwind.method.clustering.score_loop": lambda: uw.score_loop(
        np.random.default_rng(0).normal(size=(4, 5, 3)), [0, 0, 1, 1], **BAD),
    "uavwind.method.clustering.score_loops": lambda: uw.score_loops(
        [np.random.default_rng(0).normal(size=(4, 5, 3))], [[0, 0, 1, 1]], **BAD),
    "uavwind.method.search.evaluate": lambda: __import__(
        "uavwind.method.search", fromlist=["evaluate"]).evaluate(
        _setting(), [uw.PAPER_EXAMPLE], [np.random.SeedSequence(0)], n_jobs=1, progress=False,
        **BAD),
    "uavwind.method.search.random_search": lambda: uw.random_search(
        _setting(), n_loops=1, n_jobs=1, progress=False, **BAD),
    "uavwind.method.search.cem": lambda: uw.cem(
        _setting(), n_samples=2, n_elite=1, max_iter=1, n_jobs=1, progress=False, **BAD),
    "uavwind.study.runner.run_experiment": lambda: uw.study.run_experiment(
        "exp5", progress=False, **BAD),
    "uavwind.study.fill.needed_entries": lambda: uw.study.needed_entries("exp5", **BAD),
    "uavwind.study.fill.fill_cache": lambda: uw.study.fill_cache("exp5", progress=False, **BAD),
    "uavwind.study.builders.make_group": lambda: uw.make_group("light constant", [1.0], **BAD),
    "uavwind.study.builders.make_setting": lambda: uw.make_setting(
        "light constant", "strong constant", 2, **BAD),
    "uavwind.study.builders.range_similarity_settings": lambda: uw.range_similarity_settings(
        "light constant", "light constant", 4, 3, **BAD),
    "uavwind.study.builders.environment_count_settings": lambda: uw.environment_count_settings(
        "light constant", "light constant", 4, 3, **BAD),
    "uavwind.study.builders.direction_settings": lambda: uw.direction_settings(n_per_group=2,
                                                                                **BAD),
    "uavwind.study.conditions.table3_setting": lambda: uw.table3_setting(**BAD),
    "uavwind.report.explore.cached_grid": lambda: __import__(
        "uavwind.report.explore", fromlist=["cached_grid"]).cached_grid(**BAD),
}


def _kwargs_functions():
    """Qualified names of every public function or method with a ``**`` parameter."""
    found = set()
    for info in pkgutil.walk_packages(uavwind.__path__, "uavwind."):
        if any(p.startswith("_") for p in info.name.split(".")[1:]):
            continue
        mod = importlib.import_module(info.name)
        for name, obj in vars(mod).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
                continue
            members = [(name, obj)]
            if inspect.isclass(obj):
                members = [(f"{name}.{m}", f) for m, f in vars(obj).items()
                           if inspect.isfunction(f) and not m.startswith("_")]
            for qual, f in members:
                if not inspect.isfunction(f):
                    continue
                params = inspect.signature(f).parameters.values()
                if any(p.kind is p.VAR_KEYWORD for p in params):
                    found.add(f"{mod.__name__}.{qual}")
    return found


def test_every_kwargs_function_is_checked_here():
    assert _kwargs_functions() == set(CALLS)


@pytest.mark.parametrize("name", sorted(CALLS))
def test_an_unknown_keyword_is_a_type_error_naming_it(name, tmp_path, monkeypatch):
    monkeypatch.setenv("UAVWIND_RESULTS", str(tmp_path))
    with pytest.raises(TypeError, match="no_such_keyword"):
        CALLS[name]()
    assert not any(tmp_path.iterdir())  # nothing written before the keyword was refused


def test_the_estimators_set_params_keeps_scikit_learns_value_error():
    from uavwind.method.softdtw import SoftDTWKMeans
    with pytest.raises(ValueError, match="no_such_keyword"):
        SoftDTWKMeans().set_params(**BAD)
