"""The still-air vertical error split between the thrust and the vertical velocity estimate
(issue 66, third round): share 0 is the twin before, to the double; the share moves the
error from the thrust to the velocity, which keeps the height's wander in still air and
stops pushing along x when the vehicle leans into a strong wind."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from uavwind.analysis import figure8, real_flights as rf, twin_fit
from twin_helpers import STUDY, VARIED, fly as _fly


def _rows(cal, condition):
    return [rf.flight_summaries([_fly(cal, condition, s)], STUDY)[0] for s in range(3)]


def test_share_zero_is_the_thrust_error_alone_to_the_double():
    assert twin_fit._vertical_fields(0.03, 0.0) == {"thrust_error": 0.03}
    got = twin_fit._vertical_fields(0.03, 0.25)
    assert got["thrust_error"] == pytest.approx(0.03 * np.sqrt(0.75))
    assert got["vertical_velocity_error"] == pytest.approx(0.015)
    assert twin_fit._vertical_fields(0.03, 1.0)["thrust_error"] == 0.0
    a, b = _fly(VARIED, "nowind", 1), _fly(replace(VARIED, vertical_velocity_error=0.0), "nowind", 1)
    assert all(np.array_equal(a.arrays[k], b.arrays[k]) for k in a.arrays)


def test_the_vertical_velocity_error_moves_the_height_and_not_x_in_strong_wind():
    thrust = VARIED
    velocity = replace(VARIED, thrust_error=0.0, vertical_velocity_error=0.03)
    none = replace(VARIED, thrust_error=0.0)
    assert velocity.varies and replace(figure8.BARE, vertical_velocity_error=0.03).varies
    z = {k: np.mean([r["z_tracking_spread"] for r in _rows(c, "nowind")])
         for k, c in (("thrust", thrust), ("velocity", velocity), ("none", none))}
    assert z["velocity"] > 2 * z["none"] and z["thrust"] > 2 * z["none"]  # both move height
    # leaning into 12.1 m/s, the thrust error pushes along x (fa too), the velocity's does not
    fx = {k: np.mean([r["fa_x_spread"] for r in _rows(c, "100wind")])
          for k, c in (("thrust", thrust), ("velocity", velocity))}
    assert fx["thrust"] > 1.3 * fx["velocity"]
    f = _fly(velocity, "nowind", 2)
    assert np.abs(f.arrays["v"][:, 2] - _fly(none, "nowind", 2).arrays["v"][:, 2]).max() > 0.01


def test_bad_values_name_the_parameter():
    with pytest.raises(ValueError, match="vertical_velocity_error"):
        replace(VARIED, vertical_velocity_error=-0.1)
    rows = pd.DataFrame({"kind": ["flight"], "controller": ["A"]})
    for bad in (-0.1, 1.5, "fitted"):
        with pytest.raises(ValueError, match="vertical_share"):
            figure8.calibrate_twin(rows, STUDY, controllers=("A",), vertical_share=bad)
        with pytest.raises(ValueError, match="vertical_share"):
            figure8.sim_rows(pd.DataFrame({"kind": [], "controller": []}), "quick",
                             vertical_share=bad)


def test_the_share_fit_meets_the_position_spread_or_takes_the_bound_it_leans_on():
    """A stand-in ``build`` (the vertical error of VARIED split at the share): the twin's
    position spread at 12.1 m/s falls as the share grows; a target between its ends is met to
    5%, one beyond an end gives that bound, and the row is marked fitted."""
    study = STUDY
    built = []

    def build(share):
        built.append(share)
        return replace(VARIED, **twin_fit._vertical_fields(0.05, share))

    def spread(share):
        c = build(share)
        return twin_fit._replicate_mean(c, figure8.SPREAD_CONDITION, study,
                                       ("position_spread",))[0]

    ends = spread(0.0), spread(1.0)
    assert ends[0] > 1.1 * ends[1]

    def train(value):
        return pd.DataFrame({"condition": [figure8.SPREAD_CONDITION] * 2,
                             "position_spread": [value * 0.9, value * 1.1]})
    built.clear()
    low = twin_fit._fit_vertical_share(build, train(0.5 * ends[1]), study)
    assert built == [1.0] and low.vertical_velocity_error == pytest.approx(0.05)
    assert ("lap-to-lap spread of position", figure8.SPREAD_CONDITION) in low.fitted_on
    high = twin_fit._fit_vertical_share(build, train(2 * ends[0]), study)
    assert high.vertical_velocity_error == 0.0 and high.thrust_error == 0.05
    mid = 0.5 * (ends[0] + ends[1])
    got = twin_fit._fit_vertical_share(build, train(mid), study)
    assert 0.0 < got.vertical_velocity_error < 0.05
    assert twin_fit._replicate_mean(got, figure8.SPREAD_CONDITION, study,
                                   ("position_spread",))[0] == pytest.approx(mid, rel=0.05)
    with pytest.raises(ValueError, match="position spread"):
        twin_fit._fit_vertical_share(build, train(mid).drop(columns="position_spread"), study)
