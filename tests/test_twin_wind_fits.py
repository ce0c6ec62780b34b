"""The twin fitted on every wind (issue 66, second round): a rotor-drag factor beside the
drag factor (linear and quadratic drag set apart by the forces per wind), the state errors'
correlation time (fitted on the still-air position spread) and the attitude estimate's
error growing with the wind (fitted on the pitch spread per wind). Each at its default is
the first twin, to the double; each moves what it acts on; bad values name themselves."""
import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from uavwind.analysis import figure8, twin, twin_fit
from uavwind.core.seeding import child_rng
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.rotor_params import ROTOR_DRAG_KEYS
from uavwind import make_setting
from twin_helpers import BASE, STUDY, VARIED
from twin_helpers import fly as _fly, row as _row, same as _same


# --------------------------------------------------------------------------- #
# the rotor drag
# --------------------------------------------------------------------------- #
def test_rotor_drag_scale_scales_the_linear_drag_alone_and_1_is_the_preset():
    base = Multirotor.neural_fly(drag_scale=0.7)
    same = Multirotor.neural_fly(drag_scale=0.7, rotor_drag_scale=1.0)
    more = Multirotor.neural_fly(drag_scale=0.7, rotor_drag_scale=1.5)
    assert np.array_equal(base.packed, same.packed)
    qb, qm = base.quad_params(), more.quad_params()
    for k in qb:
        if k in ROTOR_DRAG_KEYS:
            assert qm[k] == pytest.approx(1.5 * qb[k])
        elif np.isscalar(qb[k]):
            assert qm[k] == qb[k], k
    # the rotor drag is linear in the airspeed, the frame's quadratic: at a low speed the
    # rotor part is most of the force, so 1.5 x it moves the force by nearly 1.5 there and
    # by less at a high speed, where the frame's share is larger
    low = more.drag_force(1.0) / base.drag_force(1.0)
    high = more.drag_force(15.0) / base.drag_force(15.0)
    assert 1.4 < low < 1.5 and 1.0 < high < low - 0.05
    with pytest.raises(ValueError, match="rotor_drag_scale"):
        Multirotor.neural_fly(rotor_drag_scale=0.0)


def test_setting_keys_keep_their_value_unless_the_rotor_drag_is_set():
    a = make_setting("light constant", "light constant", 3,
                     uav=Multirotor(preset="rotorpy", start="hover"))
    b = make_setting("light constant", "light constant", 3,
                     uav=Multirotor(preset="rotorpy", start="hover", rotor_drag_scale=1.0))
    c = make_setting("light constant", "light constant", 3,
                     uav=Multirotor(preset="rotorpy", start="hover", rotor_drag_scale=1.2))
    assert a.key() == b.key() != c.key()


def test_the_twins_rotor_drag_moves_its_force_in_wind():
    more = replace(BASE, gust_scale=0.0, rotor_drag_scale=1.2)
    calm = replace(BASE, gust_scale=0.0)
    assert _row(more, "70wind")["aero_force_x"] < _row(calm, "70wind")["aero_force_x"] - 0.5
    assert more.vehicle().rotor_drag_scale == 1.2


@pytest.mark.slow
def test_the_per_wind_force_fit_finds_the_factors_that_made_its_targets():
    """Targets made by the twin itself at drag 0.8, lift 0.7 and rotor drag 1.2 (two
    controllers 0.1 N either side of it at each wind): the fit, started from 1, 1, 1, finds
    the three factors again."""
    truth = figure8.TwinCalibration(drag_scale=0.8, lift_scale=0.7, rotor_drag_scale=1.2)
    rows = []
    for c, off in (("A", -0.1), ("B", 0.1)):
        for cond in ("nowind", "35wind", "70wind", "100wind"):
            r = twin_fit._twin_row(truth, cond, STUDY)
            d = 0.0 if cond == "nowind" else off  # the controllers differ in wind
            rows.append({"controller": c, "condition": cond,
                         "aero_force_x": r["aero_force_x"] + d,
                         "aero_force_z": r["aero_force_z"] - d})
    train = pd.DataFrame(rows)
    targets = twin_fit._force_targets(train)
    assert list(targets) == ["35wind", "70wind", "100wind"]
    assert targets["70wind"][1] == pytest.approx(np.std([-0.1, 0.1], ddof=1))
    got = twin_fit._fit_forces_per_wind(figure8.TwinCalibration(), targets, STUDY)
    assert got == pytest.approx((0.8, 0.7, 1.2), rel=0.03)
    flat = train.assign(aero_force_x=1.0, aero_force_z=0.0)
    with pytest.raises(ValueError, match="at least two training controllers"):
        twin_fit._force_targets(flat)


# --------------------------------------------------------------------------- #
# the errors' correlation time and the turbulence's tilt
# --------------------------------------------------------------------------- #
def test_the_error_time_at_its_default_is_the_first_twin_and_a_slower_one_wanders_more():
    assert _same(_fly(VARIED, "nowind", 1),
                 _fly(replace(VARIED, error_time=figure8.ERROR_TIME), "nowind", 1))
    e = twin._state_errors(replace(VARIED, error_time=0.8), child_rng(5, 0), 100_000, 100.0)
    f = twin._state_errors(VARIED, child_rng(5, 0), 100_000, 100.0)
    assert e[:, 0].std() == pytest.approx(f[:, 0].std(), rel=0.1)  # the same SD
    lag = 20  # 0.2 s; two first-order lags of time tau: correlation (1 + s/tau) exp(-s/tau)

    def corr(x):
        return np.corrcoef(x[:-lag, 0], x[lag:, 0])[0, 1]
    assert corr(f) == pytest.approx(2 * np.exp(-1.0), abs=0.03)
    assert corr(e) == pytest.approx(1.25 * np.exp(-0.25), abs=0.03)
    slow = _row(replace(VARIED, error_time=0.8), "nowind", 1)
    fast = _row(VARIED, "nowind", 1)
    assert slow["position_spread"] > 1.1 * fast["position_spread"]


def test_the_turbulence_tilt_acts_in_wind_alone_and_raises_the_pitch_spread():
    tilt = replace(VARIED, turbulence_tilt=0.1)
    assert tilt.varies and replace(BASE, turbulence_tilt=0.1).varies
    assert not replace(BASE, turbulence_tilt=0.1, variability=0.0).varies
    assert _same(_fly(VARIED, "nowind", 1), _fly(tilt, "nowind", 1))  # no wind, no tilt
    assert not _same(_fly(VARIED, "70wind", 1), _fly(tilt, "70wind", 1))
    spreads = [np.mean([_row(c, "70wind", s)["pitch_spread"] for s in range(3)])
               for c in (VARIED, tilt)]
    assert spreads[1] > 1.15 * spreads[0]
    e = twin._turbulence_tilt(tilt, child_rng(5, 0), 200_000, 100.0, 8.5)
    assert np.degrees(e[100_000:].std(axis=0)) == pytest.approx([0.85, 0.85], rel=0.1)
    assert np.abs(e[:100]).max() < np.abs(e[100_000:]).max() / 10  # ramped in with the wind


def test_bad_values_name_the_parameter():
    for field, value in (("rotor_drag_scale", 0.0), ("error_time", 0.0),
                         ("error_time", 20.0), ("turbulence_tilt", -0.1)):
        with pytest.raises(ValueError, match=field):
            replace(BASE, **{field: value})
    with pytest.raises(ValueError, match="fitted_on"):
        replace(BASE, fitted_on=(("lean", "200wind"),))
    with pytest.raises(TypeError, match="per_wind"):
        figure8.calibrate_twin(pd.DataFrame({"kind": ["flight"], "controller": ["A"]}),
                               STUDY, controllers=("A",), per_wind=1)
    with pytest.raises(TypeError, match="per_wind"):
        figure8.sim_rows(pd.DataFrame({"kind": [], "controller": []}), "quick", per_wind=1)
    with pytest.raises(TypeError, match="pitch_turbulence"):
        figure8.calibrate_twin(pd.DataFrame({"kind": ["flight"], "controller": ["A"]}),
                               STUDY, controllers=("A",), pitch_turbulence="yes")
    assert replace(BASE, fitted_on=[["lean", "35wind"]]).fitted_on == (("lean", "35wind"),)


def test_the_calibration_round_trips_its_new_fields():
    cal = replace(VARIED, rotor_drag_scale=1.1, error_time=0.3, turbulence_tilt=0.05,
                  fitted_on=(("force along x", "35wind"),))
    sim = pd.DataFrame()
    sim.attrs["calibration"] = json.dumps(cal.to_dict())
    assert figure8.calibration_of(sim) == cal
