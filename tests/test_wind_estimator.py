"""uw.WindEstimator on flights whose wind is known: the calibrated twin's (its wind is ours),
the leave-one-controller-out table, the sinusoid's phase read off the force, and bad input."""
import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import figure8, wind_estimates
from uavwind.data import RealFlight
from uavwind.method.wind_estimator import ESTIMATORS, WindEstimator, training_wind

CONDITIONS = ("nowind", "35wind", "70wind", "100wind")
CAL = figure8.TwinCalibration(drag_scale=0.75, lift_scale=0.73, gust_scale=0.08,
                              axis_offset=-2.6)


@pytest.fixture(scope="module")
def twin_flights():
    """Four 'controllers' (gust seeds) at four steady winds, 20 s each: three laps."""
    return figure8.simulated_flights(CAL, n_seeds=4, conditions=CONDITIONS, duration=20.0)


@pytest.mark.parametrize("method", ["drag", "ekf"])
def test_the_estimate_of_a_held_out_flight_is_the_wind_it_flew(twin_flights, method):
    train = [f for f in twin_flights if f.controller != "seed 3"]
    est = WindEstimator(method).fit(train)
    for f in (f for f in twin_flights if f.controller == "seed 3"):
        W = est.predict(f)
        keep = f.t >= est.skip
        assert W.shape == (f.n_samples, 3) and np.all(W[:, 2] == 0.0)
        speed = -W[keep, 0]  # the tunnel's wind blows along -x
        assert speed.mean() == pytest.approx(f.wind_speed, abs=0.3), f.condition
        assert np.abs(W[keep, 1]).mean() < 0.3


def test_an_estimate_follows_a_wind_that_changes(twin_flights):
    """Fitted on steady winds, the drag estimate follows the sinusoid 8.5 + 2.4 sin t of a
    flight it never saw: its swing and phase (the twin's sinusoid is at phase 0)."""
    est = WindEstimator("drag").fit(twin_flights)
    f = figure8.simulated_flight(CAL.vehicle(), "70p20sint", 9, 26.0, CAL)
    keep = f.t >= 2 * np.pi
    speed = -est.predict(f)[keep, 0]
    t = f.t[keep]
    mean, amp, phase = wind_estimates._harmonic(t, speed, 1.0)
    assert mean == pytest.approx(8.5, abs=0.4) and amp == pytest.approx(2.4, abs=0.5)
    assert abs(phase) < 0.3  # a lag of less than 0.3 s


def test_the_clusters_name_the_wind_they_were_trained_on(twin_flights):
    train = [f for f in twin_flights if f.controller != "seed 0"]
    est = WindEstimator("clusters").fit(train)
    for f in (f for f in twin_flights if f.controller == "seed 0"):
        speed = -est.predict(f)[:, 0]
        assert set(np.round(speed, 6)) <= {0.0, 4.2, 8.5, 12.1}
        assert np.median(speed) == f.wind_speed


def test_the_leave_one_out_table(twin_flights):
    rows = pd.DataFrame(wind_estimates.estimation_rows(twin_flights, methods=("drag",)))
    assert len(rows) == len(twin_flights) and (rows["kind"] == "estimate").all()
    table = wind_estimates.estimation_table(rows)
    assert list(table["condition"]) == list(CONDITIONS)
    assert (table["n_controllers"] == 4).all() and (table["rmse"] < 0.3).all()
    assert table["meets"].all()
    assert (table["bias_low"] <= table["bias"]).all() and (table["bias"] <= table["bias_high"]).all()
    one = wind_estimates.estimation_rows([f for f in twin_flights if f.controller == "seed 0"])
    assert one == []  # one controller: nothing to leave out


def test_the_sinusoids_phase_is_read_off_the_force():
    """Two synthetic flights: the same figure-8 force, one with an extra force swing at a
    known phase; force_phase returns the wind's phase (more wind, more negative force)."""
    t = np.arange(0, 40, 0.02)
    base = -8.0 + 0.3 * np.sin(t + 1.0)

    def flight(fa_x, condition):
        n = len(t)
        arrays = {"t": t, "fa": np.column_stack([fa_x, np.zeros(n), np.zeros(n)])}
        return RealFlight(controller="a", condition=condition, wind_speed=8.5, source="test",
                          arrays=arrays)
    for phi in (-1.8, -1.0, 0.4):
        sint = flight(base - 2.0 * np.sin(t + phi), "70p20sint")
        assert wind_estimates.force_phase(sint, flight(base, "70wind")) == pytest.approx(phi,
                                                                                       abs=1e-6)


def test_bad_input_is_refused_naming_the_parameter(twin_flights):
    with pytest.raises(ValueError, match="method"):
        WindEstimator("kalman")
    for kw, match in (({"mass": 0.0}, "mass"), ({"cutoff": 0.0}, "cutoff"),
                      ({"neighbours": 0}, "neighbours"), ({"direction": (0, 0, 0)}, "direction"),
                      ({"sigma_force": -1.0}, "sigma_force"), ({"skip": -1.0}, "skip")):
        with pytest.raises(ValueError, match=match):
            WindEstimator("drag", **kw)
    with pytest.raises(TypeError, match="channels"):
        WindEstimator("clusters", channels="attitude")
    with pytest.raises(TypeError, match="unexpected keyword"):
        WindEstimator("drag", gain=2.0)
    with pytest.raises(ValueError, match="not fitted"):
        WindEstimator("drag").predict(twin_flights[0])
    with pytest.raises(TypeError, match="flights"):
        WindEstimator("drag").fit([])
    with pytest.raises(TypeError, match="flight"):
        WindEstimator("drag").fit(twin_flights).predict("flight")
    sint = [f for f in twin_flights if f.condition == "nowind"][0]
    only = RealFlight(controller="x", condition="70p20sint", wind_speed=8.5, source="t",
                      arrays=dict(sint.arrays))
    with pytest.raises(ValueError, match="recorded"):
        WindEstimator("drag").fit([only])
    assert training_wind(twin_flights[-1]).tolist()[0] == [-twin_flights[-1].wind_speed, 0, 0]
    assert ESTIMATORS == ("drag", "ekf", "clusters")
    assert repr(WindEstimator("ekf")) == "WindEstimator(method='ekf')"
    assert isinstance(uw.WindEstimator("drag"), WindEstimator)
