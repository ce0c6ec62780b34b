"""Readings of the paper, and every experiment built under each."""
import pytest

import uavwind as uw
from uavwind import study as ex

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


def test_unknown_layout_and_reading_are_rejected():
    with pytest.raises(ValueError, match="layout"):
        uw.make_setting("light constant", "light constant", 5, layout="thirds")
    with pytest.raises(TypeError, match="layout"):
        uw.make_setting("light constant", "light constant", 5, layout=3)
    with pytest.raises(ValueError, match="reading"):
        uw.get_reading("guess")
    with pytest.raises(ValueError, match="turbulence"):
        uw.make_setting("light constant", "strong turbulence", 5, turbulence="von karman")


def test_readings_build_every_experiment_and_label_rows(tmp_path):
    for rd in uw.READINGS:
        for exp in ex.EXPERIMENTS.values():
            assert len(exp.cases(rd)) > 0
    long_inferred = ex.EXPERIMENTS["exp1"].cases("inferred")[-1].setting
    long_halves = ex.EXPERIMENTS["exp1"].cases("halves")[-1].setting
    assert long_inferred.n_env == 20 and long_halves.n_env == 10
    df = ex.run_experiment("exp1", profile=TINY, results=tmp_path, n_jobs=1, progress=False,
                           cases=[1], reading="halves")
    assert (df["reading"] == "halves").all() and df.attrs["reading"] == "halves"


@pytest.mark.parametrize("kwargs, err, match", [
    ({"name": 1}, TypeError, "name"), ({"long_run_per_group": 10 ** 9}, ValueError,
                                       "long_run_per_group"),
    ({"description": 3}, TypeError, "description"),
])
def test_a_reading_names_its_bad_field(kwargs, err, match):
    base = {"name": "mine", "layout": "halves", "turbulence": "mil-f-8785c",
            "long_run_per_group": 5}
    with pytest.raises(err, match=match):
        uw.Reading(**{**base, **kwargs})
    with pytest.raises(TypeError):
        uw.Reading("mine", "halves", "mil-f-8785c", 5)  # keyword-only
