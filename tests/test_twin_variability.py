"""The twin's variability (issue 66): a replicate is a controller and a flight drawn from the
training controllers' spread, flown on an imperfect state (the kernels' mode 4); scale 0 is
the twin of gusts and noise alone, to the double."""
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import figure8, twin, twin_fit
from uavwind.core.seeding import child_rng
from uavwind.data.neuralfly import split_noise
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.rotor_params import NEURAL_FLY_CONTROL, PositionControl
from twin_helpers import BASE, STUDY, VARIED, training_rows
from twin_helpers import fly as _fly, row as _row, same as _same


def test_scale_zero_is_todays_twin_to_the_double_and_a_seed_repeats_bit_for_bit():
    for cond in ("nowind", "100wind"):
        assert _same(_fly(BASE, cond, 2), _fly(replace(VARIED, variability=0.0), cond, 2))
        assert _same(_fly(VARIED, cond, 2), _fly(VARIED, cond, 2))
        assert not _same(_fly(BASE, cond, 2), _fly(VARIED, cond, 2))
    assert not BASE.varies and VARIED.varies and not replace(VARIED, variability=0.0).varies


def test_each_source_changes_what_it_should():
    """Still air (no gusts): the bare-state twin flies every lap alike; each error makes the
    laps differ where it acts, and a larger variability scale more."""
    calm = _row(BASE)
    tilt = _row(replace(BASE, attitude_error=0.3))
    thrust = _row(replace(BASE, thrust_error=0.03))
    vel = _row(replace(BASE, velocity_error=0.04))
    assert calm["pitch_spread"] < 0.05
    assert tilt["pitch_spread"] > 5 * calm["pitch_spread"]
    assert tilt["fa_x_spread"] > 2 * calm["fa_x_spread"]  # fa is computed from the estimate
    assert vel["pitch_spread"] > 5 * calm["pitch_spread"]
    assert thrust["z_tracking_spread"] > 5 * calm["z_tracking_spread"]
    double = _row(replace(BASE, attitude_error=0.3, variability=2.0))
    assert double["pitch_spread"] > 1.5 * tilt["pitch_spread"]


def test_a_seed_is_one_controller_at_every_wind_and_the_battery_is_drawn_per_flight():
    v = VARIED.vehicle()
    a, b = (figure8.replicate_vehicle(v, VARIED, 1, c) for c in ("nowind", "100wind"))
    other = figure8.replicate_vehicle(v, VARIED, 2, "nowind")
    assert a.position_control == b.position_control != other.position_control
    assert a.hover_throttle != b.hover_throttle
    gains = np.array(a.position_control.kp) / np.array(NEURAL_FLY_CONTROL.kp)
    assert np.allclose(gains, gains[0]) and gains[0] != 1.0  # one bandwidth, shape kept
    f = _fly(VARIED, "nowind", 1)
    assert f.hover_throttle[0] == pytest.approx(a.hover_throttle)
    assert a.max_thrust == pytest.approx(a.weight / a.hover_throttle)
    assert figure8.replicate_vehicle(v, BASE, 1, "nowind") is v
    # the replicates differ in their lap-to-lap spread (not only their gusts)
    spreads = [_row(VARIED, "70wind", s)["pitch_spread"] for s in range(3)]
    assert np.ptp(spreads) > 0.05


def test_the_state_errors_have_their_sd_and_stay_below_the_noise_cutoff():
    cal = replace(BASE, attitude_error=0.5, thrust_error=0.02, velocity_error=0.1)
    e = twin._state_errors(cal, child_rng(5, 0), 200_000, 100.0)
    sd = cal.state_error_sds()
    assert e.std(0)[sd > 0] == pytest.approx(sd[sd > 0], rel=0.05)
    assert np.all(e[:, sd == 0] == 0)
    slow, fast = split_noise(e[::2, 0], 0.02)
    assert fast.var() < 0.02 * e[:, 0].var()
    again = twin._state_errors(cal, child_rng(5, 0), 1000, 100.0)
    assert np.array_equal(again, twin._state_errors(cal, child_rng(5, 0), 1000, 100.0))


def _hover(errors, duration=40.0):
    v = Multirotor.neural_fly(position_control=NEURAL_FLY_CONTROL)
    n_ctrl = int(round(duration / 0.1)) * 10
    E = np.tile(np.asarray(errors, float), (1, n_ctrl, 1))
    return v, uw.simulate_flight(uw.Hover((0.0, 0.0, 2.0)), uw.ConstantWind([[0.0, 0, 0]]),
                                 uav=v, dt=0.1, duration=duration, state_errors=E)


def test_mode_4_in_closed_form():
    """A constant tilt error: the integral holds the estimate tilted and the true body level
    over its point; a constant thrust error: the commanded thrust settles at weight / (1 + e);
    zero errors: mode 3 to the double."""
    e = np.radians(2.0)
    v, f = _hover([0.0, e, 0.0, 0.0, 0.0, 0.0])
    q = f.attitudes[0, -1]
    true_tilt = np.arccos(1 - 2 * (q[0] ** 2 + q[1] ** 2))
    assert true_tilt < 0.02 * e
    assert np.abs(f.positions[0, -1] - [0.0, 0.0, 2.0]).max() < 0.01
    v, f = _hover([0.0, 0.0, 0.05, 0.0, 0.0, 0.0])
    assert f.thrust_commands[0, -1] == pytest.approx(v.weight / 1.05, rel=1e-3)
    _, zero = _hover(np.zeros(6), duration=10.0)
    plain = uw.simulate_flight(uw.Hover((0.0, 0.0, 2.0)), uw.ConstantWind([[1.0, 0, 0]]),
                               uav=v, dt=0.1, duration=10.0)
    assert np.array_equal(zero.positions, uw.simulate_flight(
        uw.Hover((0.0, 0.0, 2.0)), uw.ConstantWind([[0.0, 0, 0]]), uav=v, dt=0.1,
        duration=10.0).positions)
    assert not np.array_equal(zero.positions, plain.positions)


def test_bad_input_names_the_parameter():
    for field, value in (("attitude_error", -0.1), ("gain_spread", 3.0),
                         ("thrust_error", 0.5), ("velocity_error", -1.0),
                         ("variability", -1.0), ("hover_throttle_sd", 0.5)):
        with pytest.raises(ValueError, match=field):
            replace(BASE, **{field: value})
    with pytest.raises(ValueError, match="hover_throttle"):
        replace(BASE, hover_throttle=0.05)
    with pytest.raises(ValueError, match="hover_throttle"):
        Multirotor.neural_fly(hover_throttle=1.5)
    with pytest.raises(ValueError, match="kp"):
        PositionControl(kp=(0.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="bandwidth"):
        NEURAL_FLY_CONTROL.scaled(0.0)
    v = Multirotor.neural_fly(position_control=NEURAL_FLY_CONTROL)
    hover, calm = uw.Hover((0.0, 0.0, 2.0)), uw.ConstantWind([[0.0, 0, 0]])
    with pytest.raises(ValueError, match="state_errors must have shape"):
        uw.simulate_flight(hover, calm, uav=v, dt=0.1, duration=1.0,
                           state_errors=np.zeros((1, 5, 6)))
    with pytest.raises(ValueError, match="position_control"):
        uw.simulate_flight(hover, calm, uav=Multirotor.neural_fly(), dt=0.1, duration=1.0,
                           state_errors=np.zeros((1, 100, 6)))
    with pytest.raises(ValueError, match="position_control"):
        figure8.replicate_vehicle(Multirotor.neural_fly(), VARIED, 0, "nowind")
    with pytest.raises(TypeError, match="variability"):
        figure8.sim_rows(pd.DataFrame({"kind": [], "controller": []}), "quick",
                         variability=1)


def _target_rows():
    """Two training controllers' flight rows, still-air spreads included."""
    return training_rows(0.45, still_air={"fa_x_spread": 0.12}, per_controller=lambda i: {
        "pitch_spread": 0.5, "z_tracking_spread": 0.01, "tracking_rms": 0.06 + 0.03 * i,
        "hover_throttle": 0.47 + 0.02 * i})


def test_the_variability_fit_hits_its_still_air_targets():
    rows = _target_rows()
    cal = figure8.calibrate_twin(rows, STUDY, controllers=("A", "B"), per_wind=False)
    assert cal.hover_throttle == pytest.approx(0.48)
    assert cal.hover_throttle_sd == pytest.approx(np.std([0.47, 0.49] * 5, ddof=1))
    assert cal.gain_spread > 0 and cal.integral_spread == cal.gain_spread
    got = twin_fit._replicate_mean(replace(cal, gust_scale=0.0), "nowind", STUDY,
                                  twin_fit._ERROR_TARGETS)
    assert got == pytest.approx([0.5, 0.12, 0.01], rel=0.06)
    gusty = twin_fit._replicate_mean(cal, figure8.SPREAD_CONDITION, STUDY, ("fa_x_spread",))
    assert gusty[0] == pytest.approx(0.45, rel=0.03)
    with pytest.raises(ValueError, match="pitch_spread"):
        figure8.calibrate_twin(rows.drop(columns="pitch_spread"), STUDY, controllers=("A", "B"),
                               per_wind=False)
