"""uw.WindEstimator: the force model against flights built from it (closed form), the
calibrated twin's flights (its wind is ours), the protocol's tables, the sinusoid's phase
read off the force, and every bad input refused by name."""
import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.analysis import figure8, wind_estimates
from uavwind.data import RealFlight
from uavwind.method import drag_model
from uavwind.method.wind_estimator import ESTIMATORS, DragModel, WindEstimator, training_wind

CONDITIONS = ("nowind", "35wind", "70wind", "100wind")
CAL = figure8.TwinCalibration(drag_scale=0.75, lift_scale=0.73, gust_scale=0.08,
                              axis_offset=-2.6)
TRUTH = DragModel(offset=(1.2, -0.5), gain=1.0, jet=(0.06, 0.0, 0.12))


def _rot(theta, phi):
    """Rotations (n, 3, 3): pitch ``theta`` about y, then roll ``phi`` about x."""
    ct, st, cp, sp = np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    z, o = np.zeros_like(theta), np.ones_like(theta)
    Ry = np.stack([np.stack([ct, z, st], -1), np.stack([z, o, z], -1),
                   np.stack([-st, z, ct], -1)], -2)
    Rx = np.stack([np.stack([o, z, z], -1), np.stack([z, cp, -sp], -1),
                   np.stack([z, sp, cp], -1)], -2)
    return Ry @ Rx


def model_flight(speed, controller="a", condition=None, model=TRUTH, duration=30.0, dt=0.02,
                 phase=0.0, sine=0.0, noise=0.0):
    """A flight whose recorded force is exactly ``model``'s for a wind of ``speed`` [m/s]
    along -x (a figure-8 with some tracking error, a varying lean and thrust); with ``sine``
    the wind is ``speed + sine sin t`` [m/s], with ``noise`` the in-plane force has white
    noise of that std [N] (seeded by ``speed`` and ``phase``)."""
    t = np.arange(0.0, duration, dt)
    p_d = np.column_stack([1.25 * np.sin(t), np.zeros_like(t), 2.0 + 0.75 * np.sin(2 * t)])
    wobble = 0.05 * np.column_stack([np.sin(3 * t + phase), np.cos(2 * t), np.sin(t + phase)])
    p = p_d + wobble
    v = np.column_stack([1.25 * np.cos(t) + 0.15 * np.cos(3 * t + phase), -0.1 * np.sin(2 * t),
                         1.5 * np.cos(2 * t) + 0.05 * np.cos(t + phase)])
    R = _rot(0.3 * np.sin(0.7 * t + phase) + 0.02 * speed, 0.1 * np.sin(1.3 * t))
    tau = 1.0 + 0.1 * np.sin(0.5 * t + phase) + 0.01 * speed
    W = np.outer(speed + sine * np.sin(t), [-1.0, 0.0, 0.0])
    s = 1.0 + (p - p_d.mean(axis=0)) @ np.asarray(model.jet)
    u = np.einsum("nji,nj->ni", R, s[:, None] * W - v)[:, :2]
    fa_b = np.column_stack([tau[:, None] * (np.asarray(model.offset) + model.gain * u),
                            np.full(len(t), -0.3)])
    if noise:
        rng = np.random.default_rng([int(100 * speed) % 2 ** 32, int(100 * phase)])
        fa_b[:, :2] += rng.normal(0.0, noise, (len(t), 2))
    arrays = {"t": t, "p": p, "p_d": p_d, "v": v, "R": R, "T_sp": 0.5 * tau,
              "hover_throttle": np.full(len(t), 0.5),
              "fa": np.einsum("nij,nj->ni", R, fa_b)}
    cond = condition or {0.0: "nowind", 4.2: "35wind", 8.5: "70wind", 12.1: "100wind"}.get(
        speed, "custom")
    return RealFlight(controller=controller, condition=cond, wind_speed=float(speed),
                      source=f"model {controller} {speed}", arrays=arrays)


@pytest.fixture(scope="module")
def model_flights():
    return [model_flight(w, c, phase=i) for i, c in enumerate("abc")
            for w in (0.0, 4.2, 8.5, 12.1)]


@pytest.fixture(scope="module")
def twin_flights():
    """Four 'controllers' (gust seeds) at four steady winds, 20 s each: three laps."""
    return figure8.simulated_flights(CAL, n_seeds=4, conditions=CONDITIONS, duration=20.0)


# -- the model, in closed form -------------------------------------------------------- #
def test_the_fit_recovers_the_model_a_flight_was_built_from(model_flights):
    est = WindEstimator("ekf").fit(model_flights)  # the filter fits on the raw signals
    m = est.model_
    assert m.offset == pytest.approx(TRUTH.offset, abs=1e-9)
    assert m.gain == pytest.approx(TRUTH.gain, abs=1e-9)
    assert m.jet == pytest.approx(TRUTH.jet, abs=1e-9) and m.parasitic == 0.0


def test_a_flights_signals_are_read_once_while_its_columns_stay_the_same():
    """A flight whose columns are read-only (as read from its files) is read once per cutoff;
    a column replaced, or a writable one, is read again, so what the model reads is always
    the flight's data."""
    f = model_flight(8.5, "kept")
    assert f.arrays["fa"].flags.writeable  # a flight made in memory: read every time
    assert drag_model.signals(f, None) is not drag_model.signals(f, None)
    for a in f.arrays.values():
        a.flags.writeable = False
    first = drag_model.signals(f, 2.0)
    assert drag_model.signals(f, 2.0) is first and drag_model.signals(f, None) is not first
    assert not first["f"].flags.writeable
    with pytest.raises(TypeError):
        first["f"] = None  # a read-only mapping
    fa = f.arrays["fa"].copy()
    fa[:, 0] += 1.0
    fa.flags.writeable = False
    f.arrays["fa"] = fa
    again = drag_model.signals(f, 2.0)
    assert again is not first and not np.array_equal(again["f"], first["f"])
    assert np.array_equal(again["f"], drag_model._computed_signals(f, 2.0)["f"])


def test_the_inverted_model_reads_a_wind_it_was_never_fitted_on(model_flights):
    """Fitted on 0-12.1 m/s, it reads 20 m/s exactly: the model extrapolates (the odd cubic of
    the last round erred by 5.75 m/s at the edge of its range)."""
    est = WindEstimator("ekf").fit(model_flights)
    for speed in (-3.0, 2.0, 20.0):
        f = model_flight(speed, "held out", phase=7.0)
        W = est.model_.invert(drag_model.signals(f, None))
        assert np.abs(W - [-speed, 0.0]).max() < 1e-8
        mean, std = est.predict(f, return_std=True)
        late = f.t >= 10.0
        assert np.abs(mean[late, :2] - [-speed, 0.0]).max() < 1e-3
        assert np.all(std[:, :2] > 0) and np.all(std[:, 2] == 0) and np.all(mean[:, 2] == 0)


def test_a_parasitic_term_is_fitted_when_the_force_has_one():
    truth = DragModel(offset=(0.5, 0.0), gain=0.8, jet=(0.0, 0.0, 0.0), parasitic=0.03)
    flights = [model_flight(w, c, model=truth, phase=i) for i, c in enumerate("ab")
               for w in (0.0, 4.2, 8.5, 12.1)]
    # built by the linear code path: add the parasitic part by hand
    for f in flights:
        sig = drag_model.signals(f, None)
        W = np.array([-f.wind_speed, 0.0, 0.0])
        u = np.einsum("nij,j->ni", sig["RT"], W)[:, :2] - sig["vb"][:, :2]
        extra = truth.parasitic * np.linalg.norm(u, axis=1)[:, None] * u  # tau * (c/tau)|u|u
        fa_b = np.einsum("nji,nj->ni", f.R, f.fa)
        fa_b[:, :2] += extra
        f.arrays["fa"] = np.einsum("nij,nj->ni", f.R, fa_b)
    est = WindEstimator("ekf", jet=False, parasitic=True).fit(flights)
    assert est.model_.parasitic == pytest.approx(0.03, rel=1e-6)
    assert est.model_.gain == pytest.approx(0.8, rel=1e-6)
    lin = WindEstimator("ekf", jet=False).fit(flights)
    assert lin.model_.parasitic == 0.0 and lin.model_.gain > 0.8


# -- each flight's own offset, read off its body z force --------------------------------- #
WEIGHT = 2.6 * 9.81
Z_CURVE = (-0.3, -0.004, 3)  # the body z force over the thrust: a + b |u|^p, p


def leaning_flight(speed, controller, lean, phase=0.0):
    """A model flight whose body z force follows :data:`Z_CURVE` and whose logged attitude
    leans by ``lean`` [rad] (pitch) from the vehicle's: its force and attitude are recorded
    in the logged frame, as an autopilot with a tilted attitude estimate records them.
    Returns the flight and the in-plane offset [N per hover thrust] the lean makes."""
    f = model_flight(speed, controller, phase=phase)
    R = np.asarray(f.R)
    tau = f.T_sp / f.hover_throttle
    fa_b = np.einsum("nji,nj->ni", R, f.fa)  # the vehicle's frame (R is its true attitude)
    sig = drag_model.signals(f, None)
    u2 = np.sum(TRUTH.inplane(sig, np.array([-speed, 0.0])) ** 2, axis=1)
    fa_b[:, 2] = tau * (Z_CURVE[0] + Z_CURVE[1] * u2 ** (Z_CURVE[2] / 2))
    F = fa_b + np.outer(WEIGHT * tau, [0.0, 0.0, 1.0])  # the whole specific force, body
    tilt = _rot(np.full(len(tau), lean), np.zeros(len(tau)))  # logged body -> vehicle body
    logged = np.einsum("nji,nj->ni", tilt, F) - np.outer(WEIGHT * tau, [0.0, 0.0, 1.0])
    R_log = R @ tilt
    arrays = {**f.arrays, "R": R_log, "fa": np.einsum("nij,nj->ni", R_log, logged)}
    keep = f.t >= 2 * np.pi
    offset = ((logged - fa_b)[keep, :2] / tau[keep, None]).mean(axis=0)
    return (RealFlight(controller=controller, condition=f.condition, wind_speed=f.wind_speed,
                       source=f"leaning {controller} {speed}", arrays=arrays), offset)


@pytest.fixture(scope="module")
def leaning_flights():
    """Four controllers at four winds, each flight leaning by its own angle (+-1.5 deg)."""
    rng = np.random.default_rng(7)
    return [leaning_flight(w, c, float(rng.uniform(-0.026, 0.026)), phase=i)[0]
            for i, c in enumerate("abcd") for w in (0.0, 4.2, 8.5, 12.1)]


@pytest.mark.parametrize("method", ["drag", "ekf"])
def test_a_flights_own_lean_is_recovered_without_its_wind(leaning_flights, method):
    """Fitted on leaning flights, the estimator reads a held-out flight's injected offset off
    its body z force and removes it from the wind; without it (tilt=False) the lean stays in
    the estimate. A flight that does not lean (the negative control) is read as not leaning."""
    est = WindEstimator(method).fit(leaning_flights)
    plain = WindEstimator(method, tilt=False).fit(leaning_flights)
    for lean in (0.035, -0.035, 0.0):
        f, offset = leaning_flight(8.5, "held out", lean, phase=5.0)
        r, sd = est.offset(f)
        assert r[0] == pytest.approx(offset[0], abs=0.05 + 0.1 * abs(offset[0]))
        assert abs(r[1]) < 0.02 and 0 < sd[0] < 0.2  # y: no lean injected
        late = f.t >= 10.0
        err = abs(est.predict(f)[late, 0].mean() + 8.5)
        err_plain = abs(plain.predict(f)[late, 0].mean() + 8.5)
        if lean:
            assert abs(offset[0]) > 0.7  # what is injected: 0.035 rad of a 26 N force
            assert err < 0.15 < 0.6 < err_plain
        else:
            assert abs(offset[0]) < 1e-9 and err < 0.15 and err_plain < 0.15


def test_the_own_offset_changes_the_estimate_and_its_std(leaning_flights):
    f, _ = leaning_flight(4.2, "held out", 0.03, phase=2.0)
    a = WindEstimator("ekf").fit(leaning_flights).predict(f, return_std=True)
    b = WindEstimator("ekf", tilt=False).fit(leaning_flights).predict(f, return_std=True)
    assert not np.allclose(a[0], b[0], atol=0.1) and not np.allclose(a[1], b[1])


def test_the_z_curves_power_is_chosen_on_the_training_flights(leaning_flights):
    """The power the flights were built with is the one chosen (each training wind left out),
    and the curve is the one they were built with."""
    coef, z_var, reach, trained, power = WindEstimator("drag").fit(leaning_flights).tilt_
    assert power == Z_CURVE[2] and trained == (0.0, 4.2, 8.5, 12.1)
    assert coef == pytest.approx(Z_CURVE[:2], rel=0.05) and z_var < 1e-3 and reach < 1e-3


def test_the_z_curve_needs_three_training_winds(leaning_flights):
    """With three training winds the curve and its growth off them are fitted: a lean at a
    fourth wind, beyond them, is still read. With two none is fitted: the offset is the
    prior's, 0, and the estimate the plain model's."""
    three = [f for f in leaning_flights if f.wind_speed != 12.1]
    f, offset = leaning_flight(12.1, "held out", 0.03, phase=2.0)
    est = WindEstimator("drag").fit(three)
    r, _ = est.offset(f)
    assert r[0] == pytest.approx(offset[0], abs=0.25 * abs(offset[0]))
    late = f.t >= 10.0
    err = abs(est.predict(f)[late, 0].mean() + 12.1)
    plain = abs(WindEstimator("drag", tilt=False).fit(three).predict(f)[late, 0].mean() + 12.1)
    assert err < 0.3 * plain
    two = [f for f in leaning_flights if f.wind_speed in (0.0, 8.5)]
    est = WindEstimator("drag").fit(two)
    assert est.tilt_[0] is None and np.array_equal(est.offset(f)[0], [0.0, 0.0])
    assert np.array_equal(est.predict(f), WindEstimator("drag", tilt=False).fit(two).predict(f))


def test_the_offset_needs_a_fitted_z_curve_and_a_mass_that_holds(leaning_flights):
    f = leaning_flights[0]
    with pytest.raises(ValueError, match="tilt=True"):
        WindEstimator("drag", tilt=False).fit(leaning_flights).offset(f)
    with pytest.raises(ValueError, match="mass is too small"):
        WindEstimator("drag", mass=0.01).fit(leaning_flights)
    f = next(g for g in leaning_flights if g.wind_speed == 8.5)
    R = np.asarray(f.R)
    fa_b = np.einsum("nji,nj->ni", R, f.fa)
    fa_b[:, 2] = -40.0 * f.T_sp / f.hover_throttle  # more than the weight, pointing down
    heavy = _with(f, fa=np.einsum("nij,nj->ni", R, fa_b))
    with pytest.raises(ValueError, match="flight 'leaning .*mass is too small"):
        WindEstimator("drag").fit(leaning_flights).predict(heavy)


# -- on the twin ---------------------------------------------------------------------- #
@pytest.mark.parametrize("method", ["drag", "ekf"])
def test_the_estimate_of_a_held_out_flight_is_the_wind_it_flew(twin_flights, method):
    """The twin's rotor drag grows with the rotor speed (the square root of the thrust) and its
    frame has a quadratic drag: the model, written for the real vehicle, holds within 0.35."""
    train = [f for f in twin_flights if f.controller != "seed 3"]
    est = WindEstimator(method).fit(train)
    for f in (f for f in twin_flights if f.controller == "seed 3"):
        W, std = est.predict(f, return_std=True)
        keep = f.t >= est.skip
        assert W.shape == std.shape == (f.n_samples, 3) and np.all(W[:, 2] == 0.0)
        speed = -W[keep, 0]  # the tunnel's wind blows along -x
        assert speed.mean() == pytest.approx(f.wind_speed, abs=0.35), f.condition
        assert np.abs(W[keep, 1]).mean() < 0.3
        assert 0.05 < std[keep, 0].mean() < 1.5


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
    with pytest.raises(ValueError, match="classifier"):
        est.predict(twin_flights[0], return_std=True)


@pytest.mark.parametrize("change", [{"jet": False}, {"parasitic": True}, {"cutoff": 0.3},
                                    {"sigma_wind_rate": 2.0}, {"update_period": 0.2},
                                    {"innovation_window": 0.0},
                                    {"skip": 12.0}, {"tilt": False}, {"mass": 3.0}])
def test_every_parameter_changes_the_estimate(twin_flights, change):
    method = "drag" if set(change) <= {"jet", "parasitic", "cutoff", "skip", "tilt",
                                       "mass"} else "ekf"
    train = [f for f in twin_flights if f.controller != "seed 3"]
    f = twin_flights[-1]
    a = WindEstimator(method).fit(train).predict(f, return_std=True)
    b = WindEstimator(method, **change).fit(train).predict(f, return_std=True)
    assert not (np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]))


def test_the_std_grows_with_the_wind_and_covers_the_twins_wind(twin_flights):
    train = [f for f in twin_flights if f.controller != "seed 3"]
    est = WindEstimator("drag").fit(train)
    sds, cover = [], []
    for f in (f for f in twin_flights if f.controller == "seed 3"):
        mean, std = est.predict(f, return_std=True)
        late = f.t >= 10
        sds.append(std[late, 0].mean())
        cover.append(np.mean(np.abs(mean[late, 0] + f.wind_speed) <= 1.96 * std[late, 0]))
    assert sds == sorted(sds)
    assert np.mean(cover) > 0.8


def test_the_filters_std_holds_its_lag_behind_a_wind_that_changes():
    """Fitted on steady noisy flights, the filter (its random walk too slow for 2.4 sin t
    m/s) lags the sinusoid; its own variance does not know it, the innovations of the lap
    before do: the std's RMS is then the error's (within 15%) and the interval covers, where
    without them it covers under half. The mean is the same; on a steady wind the std barely
    moves."""
    train = [model_flight(w, c, phase=i, noise=2.5) for i, c in enumerate("abc")
             for w in (0.0, 4.2, 8.5, 12.1)]
    on, off = (WindEstimator("ekf", **kw).fit(train) for kw in ({}, {"innovation_window": 0.0}))
    assert on.innovation_window == pytest.approx(2 * np.pi)
    for sine in (2.4, 0.0):
        f = model_flight(8.5, "held out", phase=5.0, sine=sine, noise=2.5, duration=50.0)
        late = f.t >= 10.0
        err = (-(8.5 + sine * np.sin(f.t)) - on.predict(f)[:, 0])[late]
        (m1, s1), (m0, s0) = on.predict(f, return_std=True), off.predict(f, return_std=True)
        assert np.array_equal(m1, m0)
        rms_err, rms1, rms0 = (float(np.sqrt(np.mean(x ** 2))) for x in
                               (err, s1[late, 0], s0[late, 0]))
        cover1, cover0 = (np.mean(np.abs(err) <= 1.96 * sd[late, 0]) for sd in (s1, s0))
        if sine:
            assert rms_err > 1.0  # it lags
            assert rms1 == pytest.approx(rms_err, rel=0.15) and rms0 < 0.5 * rms_err
            assert cover1 > 0.9 and cover0 < 0.5
        else:
            assert rms1 == pytest.approx(rms0, rel=0.1) and cover1 >= cover0 > 0.9


# -- the protocol's tables ------------------------------------------------------------- #
def test_the_protocol_table(twin_flights):
    rows = pd.DataFrame(wind_estimates.estimation_rows(twin_flights, methods=("drag",),
                                                       variants=False, baseline=False))
    assert set(rows["variant"].dropna()) == {"default"}
    est = rows[rows["kind"] == "estimate"]
    by = est.groupby("protocol").size()
    assert by["controller"] == len(twin_flights)  # every flight, its controller held out
    assert by["wind"] == len(twin_flights)        # and each, its controller and wind held out
    series = rows[rows["kind"] == "series"]
    assert set(series["controller"]) == {"seed 0"} and set(series["protocol"]) == {"controller"}
    assert len(series) == sum(-(-f.n_samples // wind_estimates.SERIES_STEP)
                              for f in twin_flights if f.controller == "seed 0")
    table = wind_estimates.estimation_table(rows)
    assert list(table[table.protocol == "controller"]["condition"]) == list(CONDITIONS)
    assert (table["n_controllers"] == 4).all() and (table["rmse"] < 0.5).all()
    assert (table["bias_low"] <= table["bias"]).all() and (table["bias"] <= table["bias_high"]).all()
    assert table["coverage"].between(0, 1).all()
    summary = wind_estimates.summary_table(rows)
    assert list(summary["protocol"]) == ["controller", "wind"]
    assert (summary["rmse_low"] <= summary["rmse"]).all()
    assert (summary["rmse"] <= summary["rmse_high"]).all()
    one = wind_estimates.estimation_rows([f for f in twin_flights if f.controller == "seed 0"])
    assert one == []  # one controller: nothing to leave out


def test_the_trivial_baseline_is_scored_beside_and_loses(twin_flights):
    """Every sample named the training flights' mean wind: the same protocol, the same scores,
    and far worse than the model on the twin's flights."""
    rows = pd.DataFrame(wind_estimates.estimation_rows(twin_flights, methods=("drag",),
                                                       variants=False))
    summary = wind_estimates.summary_table(rows).set_index(["method", "protocol"])
    for p in wind_estimates.PROTOCOLS:
        base, drag = summary.loc[(wind_estimates.BASELINE, p)], summary.loc[("drag", p)]
        assert base.n_flights == drag.n_flights
        assert base.rmse > 3 * drag.rmse and base.sample_rmse > 2 * drag.sample_rmse
    est = rows[(rows.kind == "estimate") & (rows.method == wind_estimates.BASELINE)
               & (rows.protocol == "controller")]
    assert np.allclose(est.estimate, np.mean([0.0, 4.2, 8.5, 12.1]))  # three seeds x 4 winds


def test_clusters_are_scored_as_a_classifier(twin_flights):
    rows = pd.DataFrame(wind_estimates.estimation_rows(
        twin_flights, methods=("clusters",), baseline=False))
    assert set(rows["protocol"]) == {"controller"}  # a classifier cannot name a held-out wind
    assert rows["estimate"].isna().all() if "estimate" in rows else True
    table = wind_estimates.estimation_table(rows)
    assert "rmse" not in table or table["rmse"].isna().all()
    assert (table["named_low"] < table["named_high"]).all()  # never a zero-width interval


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


# -- refusals -------------------------------------------------------------------------- #
@pytest.mark.parametrize("kw, match", [
    ({"method": "kalman"}, "method"), ({"cutoff": 0.0}, "cutoff"), ({"cutoff": 20.0}, "cutoff"),
    ({"neighbours": 0}, "neighbours"), ({"direction": (0, 0, 0)}, "direction"),
    ({"direction": (1e308, 1e308, 0)}, None), ({"direction": (0, 0, 1)}, "horizontal"),
    ({"direction": (np.nan, 0, 0)}, "direction"), ({"sigma_wind_rate": 1e-200}, "sigma_wind_rate"),
    ({"sigma_wind_rate": -1.0}, "sigma_wind_rate"), ({"update_period": 0.0}, "update_period"),
    ({"skip": -1.0}, "skip"), ({"skip": np.inf}, "skip"), ({"mass": 1e-300}, "mass"),
    ({"mass": np.nan}, "mass"), ({"innovation_window": -1.0}, "innovation_window"),
    ({"innovation_window": np.nan}, "innovation_window")])
def test_bad_settings_are_refused_naming_the_parameter(kw, match):
    if match is None:  # a huge direction is fine: scaled before it is normalised
        assert WindEstimator(**kw).direction.tolist() == pytest.approx(
            [2 ** -0.5, 2 ** -0.5, 0.0])
        return
    with pytest.raises(ValueError, match=match):
        WindEstimator(**kw)


@pytest.mark.parametrize("kw, match", [
    ({"channels": "attitude"}, "channels"), ({"jet": "yes"}, "jet"), ({"parasitic": 1}, "parasitic"),
    ({"gain": 2.0}, "unexpected keyword"), ({"mass": "2.6"}, "mass"), ({"tilt": 1}, "tilt"),
    ({"sigma_velocity": 1e-200}, "unexpected keyword"), ({"cutoff": "1"}, "cutoff")])
def test_bad_types_are_refused_naming_the_parameter(kw, match):
    with pytest.raises(TypeError, match=match):
        WindEstimator("drag", **kw)


def _with(flight, **arrays):
    return RealFlight(controller=flight.controller, condition=flight.condition,
                      wind_speed=arrays.pop("wind_speed", flight.wind_speed),
                      source=flight.source, arrays={**flight.arrays, **arrays})


def _bad(f, column, row, value):
    a = np.array(f.arrays[column], dtype=float)
    a[row] = value
    return _with(f, **{column: a})


BAD_FLIGHTS = {
    "NaN in v": (lambda f: _bad(f, "v", 100, np.nan), "'v'.*NaN"),
    "inf in fa": (lambda f: _bad(f, "fa", 5, np.inf), "'fa'.*NaN or infinite"),
    "NaN in R": (lambda f: _bad(f, "R", 3, np.nan), "'R'"),
    "NaN wind speed": (lambda f: _with(f, wind_speed=np.nan), "wind_speed"),
    "1 sample": (lambda f: _with(f, **{k: v[:1] for k, v in f.arrays.items()}), "1 sample"),
    "0 samples": (lambda f: _with(f, **{k: v[:0] for k, v in f.arrays.items()}), "0 sample"),
    "constant t": (lambda f: _with(f, t=np.zeros(f.n_samples)), "'t' must increase"),
    "t backwards": (lambda f: _with(f, t=f.t[::-1].copy()), "'t' must increase"),
    "fa too short": (lambda f: _with(f, fa=f.fa[:-3]), "'fa' must have shape"),
    "fa of 2 columns": (lambda f: _with(f, fa=f.fa[:, :2]), "'fa' must have shape"),
    "hover throttle 0": (lambda f: _with(f, hover_throttle=np.zeros(f.n_samples)),
                         "hover_throttle"),
    "no R": (lambda f: RealFlight(controller="x", condition="nowind", wind_speed=0.0,
                                  source="s", arrays={k: v for k, v in f.arrays.items()
                                                      if k != "R"}), "lacks column"),
    "upside down": (lambda f: _with(f, R=-np.array(f.R)), "tilted 90 deg"),
    "text column": (lambda f: _with(f, fa=f.fa.astype(str)), "must hold numbers"),
}


@pytest.mark.parametrize("case", list(BAD_FLIGHTS))
def test_a_bad_flight_is_refused_by_fit_and_predict_naming_it(model_flights, case):
    make, match = BAD_FLIGHTS[case]
    bad = make(model_flights[2])
    with pytest.raises(ValueError, match=match):
        WindEstimator("drag").fit([*model_flights[:2], bad, *model_flights[3:]])
    est = WindEstimator("drag").fit(model_flights)
    with pytest.raises(ValueError, match=match):
        est.predict(bad)


def test_a_fit_that_cannot_be_made_is_refused(model_flights, twin_flights):
    still = [f for f in model_flights if f.wind_speed == 0.0]
    # one still-air flight gave 2085 m/s for a 12.1 m/s flight: now refused
    with pytest.raises(ValueError, match="two wind speeds"):
        WindEstimator("drag").fit(still[:1])
    with pytest.raises(ValueError, match="two wind speeds"):
        WindEstimator("ekf").fit(still)
    only = _with(model_flights[1], wind_speed=8.5)
    only = RealFlight(controller="x", condition="70p20sint", wind_speed=8.5, source="t",
                      arrays=dict(only.arrays))
    with pytest.raises(ValueError, match="recorded"):
        WindEstimator("drag").fit([only])
    with pytest.raises(ValueError, match="skip=40 s leaves 0 sample"):
        WindEstimator("drag", skip=40.0).fit(model_flights)
    with pytest.raises(ValueError, match="neighbours must be at most the training laps"):
        WindEstimator("clusters", neighbours=100).fit(twin_flights[:2])
    slow = [RealFlight(controller=f.controller, condition=f.condition, wind_speed=f.wind_speed,
                       source=f.source, arrays={k: v[::10] for k, v in f.arrays.items()})
            for f in model_flights]  # 5 Hz: Nyquist 2.5 Hz
    with pytest.raises(ValueError, match="cutoff must be below the Nyquist frequency"):
        WindEstimator("drag", cutoff=4.0).fit(slow)
    with pytest.raises(TypeError, match="flights"):
        WindEstimator("drag").fit([])
    with pytest.raises(TypeError, match="flights"):
        WindEstimator("drag").fit(model_flights[0])
    with pytest.raises(TypeError, match="flights"):
        WindEstimator("drag").fit(["flight"])


def test_a_failed_refit_leaves_the_estimator_as_it_was(model_flights):
    est = WindEstimator("ekf").fit(model_flights)
    f = model_flight(6.0, "held out", phase=3.0)
    before = est.predict(f, return_std=True)
    state = dict(est.__dict__)
    with pytest.raises(ValueError):
        est.fit([*model_flights[:3], _bad(model_flights[3], "fa", 7, np.nan)])
    with pytest.raises(ValueError):
        est.fit([f for f in model_flights if f.wind_speed == 0.0])
    assert est.__dict__.keys() == state.keys() and est.model_ is state["model_"]
    after = est.predict(f, return_std=True)
    assert np.array_equal(before[0], after[0]) and np.array_equal(before[1], after[1])


def test_predict_refuses_what_it_cannot_answer(model_flights):
    with pytest.raises(ValueError, match="not fitted"):
        WindEstimator("drag").predict(model_flights[0])
    est = WindEstimator("drag").fit(model_flights)
    with pytest.raises(TypeError, match="flight"):
        est.predict("flight")
    with pytest.raises(TypeError, match="return_std"):
        est.predict(model_flights[0], return_std="yes")
    slow = RealFlight(controller="x", condition="nowind", wind_speed=0.0, source="slow",
                      arrays={k: v[::25] for k, v in model_flights[0].arrays.items()})
    with pytest.raises(ValueError, match="Nyquist"):
        est.predict(slow)  # 2 Hz: Nyquist 1 Hz, the cutoff is 1 Hz


def test_the_names_of_the_interface():
    assert training_wind(model_flight(4.2)).tolist()[0] == [-4.2, 0, 0]
    assert ESTIMATORS == ("drag", "ekf", "clusters")
    assert repr(WindEstimator("ekf")) == "WindEstimator(method='ekf')"
    assert isinstance(uw.WindEstimator("drag"), WindEstimator)


# -- where the error comes from; the filter's noise chosen on training controllers ------ #
def test_the_error_splits_into_the_means_bias_and_the_scatter(twin_flights):
    dec = wind_estimates.error_decomposition(twin_flights, "drag")
    assert len(dec) == len(twin_flights)  # every steady flight held out once
    # closed form: the mean square about zero is the squared mean plus the variance
    np.testing.assert_allclose(dec.sample_rmse ** 2, dec.bias ** 2 + dec.scatter ** 2,
                               rtol=1e-10)
    assert ((dec.lap_share >= -1e-12) & (dec.lap_share <= 1 + 1e-12)).all()


def test_an_exact_model_leaves_no_bias_and_no_scatter(model_flights):
    dec = wind_estimates.error_decomposition(model_flights, "ekf")
    assert dec.bias.max() < 0.05
    assert dec.sample_rmse.max() < 0.1


def test_a_lap_locked_error_is_the_lap_share(model_flights):
    # the force made by a model with a different jet: the estimate's error follows the lap
    other = DragModel(offset=TRUTH.offset, gain=TRUTH.gain, jet=(0.3, 0.0, 0.3))
    flights = model_flights + [model_flight(w, "d", model=other, phase=3)
                               for w in (0.0, 4.2, 8.5, 12.1)]
    dec = wind_estimates.error_decomposition(flights, "ekf", jet=False)
    windy = dec[(dec.controller == "d") & (dec.wind_speed > 0)]
    assert (windy.scatter > 0.05).all() and (windy.lap_share > 0.5).all()


def test_the_filter_is_chosen_on_the_flights_it_is_given(twin_flights):
    grid = [(0.03, 0.5), (3.0, 0.5)]
    params, scores = wind_estimates.choose_filter(twin_flights, grid)
    assert len(scores) == 2 and (params["sigma_wind_rate"], params["update_period"]) in grid
    assert scores.sample_rmse.min() == pytest.approx(
        scores.set_index(["sigma_wind_rate", "update_period"]).loc[
            (params["sigma_wind_rate"], params["update_period"]), "sample_rmse"])
    # a grid of one is that one; and the scores depend on the grid's settings
    one, s1 = wind_estimates.choose_filter(twin_flights, [(3.0, 0.5)])
    assert one == {"sigma_wind_rate": 3.0, "update_period": 0.5}
    assert s1.sample_rmse.iloc[0] == scores.sample_rmse.iloc[1]
    assert scores.sample_rmse.iloc[0] != scores.sample_rmse.iloc[1]
    with pytest.raises(ValueError, match="grid"):
        wind_estimates.choose_filter(twin_flights, [])
    with pytest.raises(ValueError, match="three controllers"):
        wind_estimates.choose_filter([f for f in twin_flights
                                      if f.controller in ("seed 0", "seed 1")], grid)
