"""The twin's recorded noise fitted on its own content above the cutoff (issue 66, third
round): what is added to a channel is what the training controllers' noise leaves once the
twin's own fast motion is counted; off (the default: it worsens the score), the noise is
their mean (the twin before, to the double)."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from uavwind.analysis import figure8, real_flights as rf, twin_fit
from twin_helpers import STUDY, VARIED, training_rows


def _mean_square(cal, column, condition="nowind"):
    rows = [twin_fit._twin_row(cal, condition, STUDY, s) for s in range(figure8.N_SEEDS)]
    return float(np.mean([r[column] ** 2 for r in rows]))


def test_the_fitted_noise_tops_the_twins_own_content_up_to_the_target():
    own = _mean_square(VARIED, "noise_attitude_x")
    own_y = _mean_square(VARIED, "noise_attitude_y")
    own_fx = _mean_square(VARIED, "noise_aero_force_x")
    assert own > 0.001 ** 2  # the twin moves above the cutoff before any noise
    high = 2.0 * np.sqrt(own)  # a target above the twin's own content: topped up to it
    low = 0.5 * np.sqrt(own_y)  # one below it: nothing added
    cal = replace(VARIED, noise=(("nowind", "noise_attitude_x", high),
                                 ("nowind", "noise_attitude_y", low),
                                 ("nowind", "noise_aero_force_x", 0.2)))
    fit = twin_fit._fit_noise(cal, STUDY)
    got = dict(((c, col), v) for c, col, v in fit.noise)
    assert got[("nowind", "noise_attitude_x")] == pytest.approx(np.sqrt(high ** 2 - own))
    assert got[("nowind", "noise_attitude_y")] == 0.0
    assert got[("nowind", "noise_aero_force_x")] == pytest.approx(np.sqrt(0.04 - own_fx))
    # the variances add: the fitted twin's noise is the target, and the unfitted one's above it
    assert np.sqrt(_mean_square(fit, "noise_attitude_x")) == pytest.approx(high, rel=0.05)
    assert np.sqrt(_mean_square(cal, "noise_attitude_x")) > 1.05 * high
    assert fit.to_dict() | {"noise": ()} == cal.to_dict() | {"noise": ()}  # nothing else moves


def _rows():
    """Two training controllers' flight rows at every wind."""
    return training_rows(0.3, noise_step=0.002)


def test_off_is_the_twin_before_to_the_double_and_on_is_the_noise_fit_of_it(monkeypatch):
    rows = _rows()
    off = figure8.calibrate_twin(rows, STUDY, controllers=("A", "B"), variability=False,
                                 per_wind=False, fit_noise=False)
    assert off.noise == tuple((c, col, 0.011) for c in figure8.CONDITIONS
                              for col in rf.noise_columns())  # their mean, as before
    calls = []

    def spy(cal, study):
        calls.append(cal)
        return twin_fit.__dict__["_fit_noise_real"](cal, study)

    monkeypatch.setitem(twin_fit.__dict__, "_fit_noise_real", twin_fit._fit_noise)
    monkeypatch.setattr(twin_fit, "_fit_noise", spy)
    on = figure8.calibrate_twin(rows, STUDY, controllers=("A", "B"), variability=False,
                                per_wind=False, fit_noise=True)
    assert calls == [off]  # the same fit up to the noise, to the double
    assert on.to_dict() | {"noise": ()} == off.to_dict() | {"noise": ()}
    assert on.noise != off.noise


def test_fit_noise_must_be_a_bool():
    rows = pd.DataFrame({"kind": ["flight"], "controller": ["A"]})
    with pytest.raises(TypeError, match="fit_noise"):
        figure8.calibrate_twin(rows, STUDY, controllers=("A",), fit_noise=1)
    with pytest.raises(TypeError, match="fit_noise"):
        figure8.sim_rows(pd.DataFrame({"kind": [], "controller": []}), "quick", fit_noise="no")
