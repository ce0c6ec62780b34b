"""The integral gain's spread fitted on the position spread at 12.1 m/s (issue 66, fourth
round): it changes what a replicate flies, its fit recovers a spread it was given and takes
the bound a target beyond its reach leans on, and bad values name the parameter."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from uavwind.analysis import figure8, twin_fit
from twin_helpers import STUDY, VARIED, fly, same

HIGH = 0.5  # the stand-in bandwidth's spread: the fit's upper bound


def _spread(cal):
    return twin_fit._replicate_mean(cal, figure8.SPREAD_CONDITION, STUDY, ("position_spread",))[0]


def _train(value):
    return pd.DataFrame({"condition": [figure8.SPREAD_CONDITION] * 2,
                         "position_spread": [value * 0.9, value * 1.1]})


def test_the_integral_spread_changes_the_replicates_controller_and_flight():
    slow = replace(VARIED, integral_spread=0.6)
    a = figure8.replicate_vehicle(VARIED.vehicle(), VARIED, 1, "100wind").position_control
    b = figure8.replicate_vehicle(slow.vehicle(), slow, 1, "100wind").position_control
    assert a.kp == b.kp and a.kd == b.kd  # the bandwidth's draw is the same
    assert a.ki != b.ki
    assert not same(fly(VARIED, "100wind", 1), fly(slow, "100wind", 1))
    # 0 draws no integral factor beyond the bandwidth's: the loop's shape is kept
    flat = replace(VARIED, integral_spread=0.0)
    c = figure8.replicate_vehicle(flat.vehicle(), flat, 1, "100wind").position_control
    base = flat.vehicle().position_control
    bw = c.kd[0] / base.kd[0]
    assert c.ki[0] == pytest.approx(base.ki[0] * bw ** 3)


@pytest.mark.slow
def test_the_fit_recovers_the_spread_that_made_its_target_and_takes_a_bound_beyond_it():
    built = []

    def build(x):
        built.append(x)
        return replace(VARIED, integral_spread=x)

    ends = _spread(build(0.0)), _spread(build(HIGH))
    assert ends[1] > 1.2 * ends[0]  # a slow integral lets the strong wind move the laps
    given = 0.25
    got = twin_fit._fit_integral_spread(build, _train(_spread(build(given))), STUDY, HIGH)
    assert got.integral_spread == pytest.approx(given, abs=0.08)
    assert ("lap-to-lap spread of position", figure8.SPREAD_CONDITION) in got.fitted_on
    built.clear()
    low = twin_fit._fit_integral_spread(build, _train(0.5 * ends[0]), STUDY, HIGH)
    assert low.integral_spread == 0.0 and built == [HIGH, 0.0]
    high = twin_fit._fit_integral_spread(build, _train(2 * ends[1]), STUDY, HIGH)
    assert high.integral_spread == HIGH
    assert high.fitted_on.count(("lap-to-lap spread of position",
                                 figure8.SPREAD_CONDITION)) == 1
    with pytest.raises(ValueError, match="position spread"):
        twin_fit._fit_integral_spread(build, _train(1.0).drop(columns="position_spread"),
                                     STUDY, HIGH)


def test_bad_values_name_the_parameter():
    assert twin_fit.check_integral_spread("bandwidth") == "bandwidth"
    assert twin_fit.check_integral_spread(np.float64(0.2)) == 0.2
    rows = pd.DataFrame({"kind": ["flight"], "controller": ["A"]})
    for bad in (-0.1, 2.5, "fitted", np.nan):
        with pytest.raises(ValueError, match="integral_spread"):
            figure8.calibrate_twin(rows, STUDY, controllers=("A",), integral_spread=bad)
        with pytest.raises(ValueError, match="integral_spread"):
            figure8.sim_rows(pd.DataFrame({"kind": [], "controller": []}), "quick",
                             integral_spread=bad)
