"""figure8 split by concept (issue 66): the twin (:mod:`uavwind.analysis.twin`), its
calibration (:mod:`uavwind.analysis.twin_fit`) and Exp 13's simulated rows and validation
(:mod:`uavwind.analysis.figure8`). Every public name figure8 held before the split still
imports from it, as the very object its new module defines (an outside check calls
``figure8.calibrate_twin``, ``simulated_flights``, ``VALIDATION``, ``sim_rows``), and the
cache's version and seed are the ones the rows were filed under."""
import json
import warnings

import pandas as pd
import pytest

from uavwind.analysis import figure8, real_flights, twin, twin_fit

#: figure8's public names before the split (its ``__all__``, its other public constants, and
#: the names of the lower layers it imported that its callers reach through it): where each
#: is defined now.
OLD = {
    **dict.fromkeys(["TwinCalibration", "BARE", "VALIDATION", "simulated_flight",
                     "simulated_flights", "replicate_vehicle", "flight_duration", "FIGURE8",
                     "SIM_SEED", "N_SEEDS", "DURATION", "DT", "RAMP", "ERROR_TIME"], twin),
    **dict.fromkeys(["calibrate_twin", "held_out_controller", "real_force_targets",
                     "variability_table", "FIT_CONDITION", "SPREAD_CONDITION"], twin_fit),
    **dict.fromkeys(["SIM_VERSION", "sim_rows", "calibration_of", "validation_table",
                     "validation_score", "ranking_verdict", "PHYSICAL"], figure8),
    **dict.fromkeys(["STUDIES", "flight_summaries", "compute_rows", "decided_orders",
                     "noise_columns"], real_flights),
}
#: figure8's ``__all__`` before the split: every name in it is in OLD.
OLD_ALL = ["FIGURE8", "BARE", "SIM_SEED", "SIM_VERSION", "FIT_CONDITION", "SPREAD_CONDITION",
           "TwinCalibration", "calibrate_twin", "held_out_controller", "simulated_flight",
           "simulated_flights", "flight_duration", "sim_rows", "validation_table",
           "validation_score", "ranking_verdict", "real_force_targets", "calibration_of",
           "VALIDATION", "PHYSICAL", "ERROR_TIME", "variability_table"]


def test_every_old_name_is_the_new_modules_object():
    assert set(OLD_ALL) <= set(OLD)
    for name, home in OLD.items():
        assert getattr(figure8, name) is getattr(home, name), name
        if callable(getattr(home, name)) and hasattr(getattr(home, name), "__module__") \
                and home is not real_flights:
            assert getattr(home, name).__module__ == home.__name__, name
    assert figure8.CONDITIONS is real_flights.CONDITIONS


@pytest.mark.parametrize("name", sorted(OLD))
def test_from_figure8_import_works_without_a_warning(name):
    ns = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        exec(f"from uavwind.analysis.figure8 import {name} as x", ns)
    assert ns["x"] is getattr(OLD[name], name)


def test_each_module_owns_its_names_once():
    """One name per idea: no public name is defined in two of the three modules, and each
    module's ``__all__`` lists what it defines (figure8's re-exports are not in it)."""
    for mod in (twin, twin_fit, figure8):
        for name in mod.__all__:
            obj = getattr(mod, name)
            if hasattr(obj, "__module__") and callable(obj):
                assert obj.__module__ == mod.__name__, (mod.__name__, name)
    assert not set(twin.__all__) & set(twin_fit.__all__)
    assert not (set(twin.__all__) | set(twin_fit.__all__)) & set(figure8.__all__)


def test_the_cache_key_constants_are_unchanged():
    """sim_rows files its rows under these (with the study and the training rows' digest): a
    split that moved code must not move them."""
    assert figure8.SIM_VERSION == "9" and figure8.SIM_SEED == 13 and figure8.N_SEEDS == 5
    assert (figure8.FIT_CONDITION, figure8.SPREAD_CONDITION) == ("70wind", "100wind")


def test_a_calibration_survives_its_json_round_trip_from_any_path():
    """sim_rows stores the calibration as JSON (no class path): calibration_of rebuilds it,
    equal to the one the twin module defines."""
    cal = twin.TwinCalibration(drag_scale=0.8, noise=(("nowind", "noise_attitude_x", 0.001),),
                               fitted_on=(("lean", "nowind"),))
    df = pd.DataFrame()
    df.attrs["calibration"] = json.dumps(cal.to_dict())
    got = figure8.calibration_of(df)
    assert got == cal and type(got) is twin.TwinCalibration
