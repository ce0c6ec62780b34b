"""The old import paths and names of 0.1 keep working for one release, each with a
DeprecationWarning naming the new place; the new paths never warn."""
import importlib
import subprocess
import sys
import warnings

import pytest

from uavwind._compat import MOVED


@pytest.mark.parametrize("old", sorted(MOVED))
def test_every_old_module_path_imports_and_warns(old):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED[old][0].replace(".", r"\.")):
        mod = importlib.import_module(old)
    assert mod.__doc__ is not None


def test_old_names_are_the_new_objects():
    for old in ("uavwind.scenarios", "uavwind.experiments"):
        sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning):
        from uavwind.scenarios import Setting, make_setting  # noqa: F401 (split module)
        from uavwind.experiments import run_experiment, summary_table
    from uavwind.analysis.tables import summary_table as new_summary
    from uavwind.sim.setting import Setting as NewSetting
    from uavwind.study.runner import run_experiment as new_run
    assert Setting is NewSetting and run_experiment is new_run and summary_table is new_summary


def test_old_module_attributes_of_the_package():
    import uavwind as uw
    sys.modules.pop("uavwind.observation", None)
    vars(uw).pop("observation", None)  # an earlier import set it as an attribute
    with pytest.warns(DeprecationWarning, match="uavwind.sim.observation"):
        noise = uw.observation.Noise
    assert noise is uw.Noise
    with pytest.raises(AttributeError, match="no_such_thing"):
        uw.no_such_thing


def test_simulation_settings_is_deprecated_but_works():
    import uavwind as uw
    with pytest.warns(DeprecationWarning, match="SimulationSettings"):
        cls = uw.SimulationSettings
    assert cls().n_steps == 120


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
