"""The names users of uavwind 0.1 import and that moved keep working for one release, each
with a DeprecationWarning naming where to import it from now; nothing else of 0.1's flat
modules is kept, and the new paths never warn."""
import importlib
import re
import subprocess
import sys
import warnings

import pytest

from uavwind._compat import OLD_NAMES

KEPT = [(old, name, new) for old, names in OLD_NAMES.items() for name, new in names.items()]


@pytest.mark.parametrize("old, name, new", KEPT, ids=[f"{o}.{n}" for o, n, _ in KEPT])
def test_every_kept_name_warns_with_its_new_path_and_is_the_new_object(old, name, new):
    mod = importlib.import_module(old)
    with pytest.warns(DeprecationWarning, match=re.escape(f"from {new} import {name}")):
        obj = getattr(mod, name)
    assert obj is getattr(importlib.import_module(new), name)


def test_the_readme_of_0_1_still_runs_its_imports():
    with pytest.warns(DeprecationWarning, match="uavwind.study.runner"):
        from uavwind import experiments as ex
        run = ex.run_experiment
    with pytest.warns(DeprecationWarning, match="uavwind.method.softdtw"):
        from uavwind.softdtw import SoftDTWKMeans, silhouette_score  # noqa: F401
    with pytest.warns(DeprecationWarning, match="uavwind.study.fill"):
        from uavwind.fill import fill_cache  # noqa: F401
    from uavwind.study.runner import run_experiment
    assert run is run_experiment


def test_other_names_of_an_old_module_say_where_its_names_went():
    ex = importlib.import_module("uavwind.experiments")
    with pytest.raises(AttributeError, match="uavwind.study"):
        ex.summary_table
    with pytest.raises(ImportError):
        from uavwind.experiments import summary_table  # noqa: F401


@pytest.mark.parametrize("old", ["uavwind.scenarios", "uavwind.wind", "uavwind.config",
                                 "uavwind.plotting"])
def test_the_other_flat_modules_of_0_1_are_gone(old):
    sys.modules.pop(old, None)
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)


def test_old_module_attributes_of_the_package():
    import uavwind as uw
    vars(uw).pop("softdtw", None)  # an earlier import set it as an attribute
    with pytest.warns(DeprecationWarning, match="uavwind.method.softdtw"):
        km = uw.softdtw.SoftDTWKMeans
    from uavwind.method.softdtw import SoftDTWKMeans
    assert km is SoftDTWKMeans
    with pytest.raises(AttributeError, match="no_such_thing"):
        uw.no_such_thing
    with pytest.raises(AttributeError, match="observation"):
        uw.observation  # a flat module of 0.1 nobody was shown to import


def test_simulation_settings_is_deprecated_but_works():
    import uavwind as uw
    with pytest.warns(DeprecationWarning, match="SimulationSettings"):
        cls = uw.SimulationSettings
    assert cls().n_steps == 120


def test_paper_simulation_is_deprecated_but_works():
    import uavwind as uw
    with pytest.warns(DeprecationWarning, match="PAPER_SIMULATION"):
        paper = uw.PAPER_SIMULATION
    assert (paper.dt, paper.duration, paper.n_steps) == (0.1, 12.0, 120)


@pytest.mark.parametrize("kwargs, name", [
    ({"dt": 0.0}, "dt"), ({"dt": -0.1}, "dt"), ({"duration": -1.0}, "duration"),
    ({"dt": 0.07, "duration": 1.0}, "multiple of dt"),
])
def test_settings_reject_bad_values(kwargs, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from uavwind import SimulationSettings
    with pytest.raises(ValueError, match=name):
        SimulationSettings(**kwargs)


def test_the_new_paths_and_the_package_import_without_a_warning():
    code = ("import warnings; warnings.simplefilter('error')\n"
            "import uavwind, uavwind.study, uavwind.analysis, uavwind.report.plotting, "
            "uavwind.cli\n"
            "before = list(warnings.filters)\n"
            "import uavwind.method.clustering\n"
            "assert warnings.filters == before  # importing changes no warnings filter\n")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_the_engine_switches_of_0_1_still_work(monkeypatch):
    from uavwind.method.softdtw._consts import env_flag
    monkeypatch.delenv("UAVWIND_SOFTDTW_PARALLEL", raising=False)  # conftest sets it
    monkeypatch.setenv("FASTKMEANS_PARALLEL", "0")
    with pytest.warns(DeprecationWarning, match="UAVWIND_SOFTDTW_PARALLEL"):
        assert env_flag("PARALLEL") is False
    monkeypatch.setenv("UAVWIND_SOFTDTW_PARALLEL", "1")
    assert env_flag("PARALLEL") is True  # the new name wins
