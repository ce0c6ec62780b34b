"""The paper's future work on the multirotor: attitude actions, and the attitude, body-rate
and IMU observation channels, against closed forms and RotorPy's own IMU."""
import math

import os

import numpy as np
import pandas as pd
import pytest

import uavwind as uw
from uavwind.sim.actions import AttitudeSequence, euler_to_quaternion, sample_attitude
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.observation import CONSUMER_SENSORS, noise_seed, observe, rotorpy_imu_noise

pytest.importorskip("rotorpy.sensors.imu")


def test_attitude_actions_are_drawn_like_the_papers_and_seeded():
    a = sample_attitude(np.random.default_rng(3))
    b = sample_attitude(np.random.default_rng(3))
    assert a == b and a.n_changes == 6 and a.times[0] == 0.0
    assert np.all(a.thrusts % 5 == 0) and a.thrusts.max() <= 50
    assert np.all(np.abs(a.angles[:, :2]) <= math.radians(30) + 1e-12)
    assert np.allclose(np.round(np.degrees(a.angles[:, :2]) / 10), np.degrees(a.angles[:, :2]) / 10)
    v = a.to_vector()
    assert AttitudeSequence.from_vector(v, a.times) == a  # the CEM's vector form round-trips


def test_euler_angles_give_scipys_quaternions():
    from scipy.spatial.transform import Rotation

    ang = np.random.default_rng(0).uniform(-1, 1, (20, 3))
    ref = Rotation.from_euler("ZYX", ang[:, ::-1]).as_quat()
    got = euler_to_quaternion(ang)
    assert np.allclose(np.abs(np.sum(got * ref, axis=1)), 1.0, atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    ({"times": [0.0, 0.0], "thrusts": [1, 1], "angles": [[0, 0, 0]] * 2}, "increasing"),
    ({"times": [0.0], "thrusts": [-1.0], "angles": [[0, 0, 0]]}, "thrusts"),
    ({"times": [0.0], "thrusts": [1.0], "angles": [[2.0, 0, 0]]}, "roll and pitch"),
    ({"times": [0.0], "thrusts": [1.0], "angles": [[0, 0, 4.0]]}, "yaw"),
    ({"times": [1.0], "thrusts": [1.0], "angles": [[0, 0, 0]]}, "times"),
])
def test_bad_attitude_actions_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        AttitudeSequence(**kwargs)


def test_the_point_mass_refuses_attitude_actions_and_channels():
    a = sample_attitude(np.random.default_rng(1))
    with pytest.raises(ValueError, match="Multirotor"):
        uw.simulate(a, uw.ConstantWind([[0, 0, 0]]))
    f = uw.simulate_flight(uw.PAPER_EXAMPLE, uw.ConstantWind([[0, 0, 0]]))
    for channel in ("attitude", "body_rates", "imu"):
        with pytest.raises(ValueError, match="Multirotor"):
            observe(f, channel)


@pytest.fixture(scope="module")
def flight():
    mr = Multirotor(preset="rotorpy", start="hover")
    a = sample_attitude(np.random.default_rng(2))
    return mr, uw.simulate_flight(a, uw.ConstantWind([[2.0, -1.0, 0.0], [0.5, 0.5, 0.0]]),
                                  uav=mr)


def test_each_channel_has_its_shape_and_units(flight):
    mr, f = flight
    shapes = {"position": 3, "velocity": 3, "attitude": 6, "body_rates": 3, "imu": 6}
    for ch, d in shapes.items():
        assert observe(f, ch, gravity=mr.gravity).shape == (2, 120, d), ch
    att = observe(f, "attitude")
    ex, ey = att[..., :3], att[..., 3:]
    assert np.allclose(np.linalg.norm(ex, axis=-1), 1) and np.allclose(np.sum(ex * ey, -1), 0)
    assert np.array_equal(observe(f, "body_rates"), f.body_rates)  # [rad/s], body frame


def test_the_imu_channel_is_rotorpys_imu_without_noise(flight):
    from rotorpy.sensors.imu import Imu

    mr, f = flight
    imu = Imu()
    for j in (5, 60, 119):
        S = np.zeros((1, 20))
        S[0, 0:3], S[0, 3:6] = f.positions[0, j], f.ground_velocities[0, j]
        S[0, 6:10], S[0, 10:13] = f.attitudes[0, j], f.body_rates[0, j]
        S[0, 13:16], S[0, 16:20] = f.winds[0, j], f.rotor_speeds[0, j]
        # RotorPy's accelerometer needs v-dot: ours is measured under the command held over
        # the step, so compare the rotation and gravity handling on our v-dot
        acc_body = f.specific_forces[0, j]
        q = f.attitudes[0, j] / np.linalg.norm(f.attitudes[0, j])
        from scipy.spatial.transform import Rotation
        vdot = Rotation.from_quat(q).as_matrix() @ acc_body + np.array([0, 0, -9.81])
        state = {"x": S[0, 0:3], "v": S[0, 3:6], "q": q, "w": S[0, 10:13]}
        m = imu.measurement(state, {"vdot": vdot, "wdot": np.zeros(3)}, with_noise=False)
        assert np.allclose(m["accel"], acc_body, atol=1e-12)
        assert np.allclose(m["gyro"], observe(f, "imu")[0, j, 3:], atol=1e-15)


def test_imu_noise_is_seeded_from_the_loop_and_differs_between_loops(flight):
    mr, f = flight
    a = observe(f, "imu", CONSUMER_SENSORS, seed=noise_seed(np.random.SeedSequence(1)))
    b = observe(f, "imu", CONSUMER_SENSORS, seed=noise_seed(np.random.SeedSequence(1)))
    c = observe(f, "imu", CONSUMER_SENSORS, seed=noise_seed(np.random.SeedSequence(2)))
    assert np.array_equal(a, b) and not np.allclose(a, c)
    clean = observe(f, "imu")
    resid = (a - clean).reshape(-1, 6)
    assert resid[:, :3].std() == pytest.approx(CONSUMER_SENSORS.acceleration, rel=0.1)
    assert resid[:, 3:].std() == pytest.approx(CONSUMER_SENSORS.rate, rel=0.1)


def test_rotorpys_imu_noise_is_read_from_rotorpy():
    n = rotorpy_imu_noise(0.1)
    assert n.acceleration == pytest.approx(0.038 ** 2 * math.sqrt(5))
    assert n.rate == pytest.approx(0.01 ** 2 * math.sqrt(5))


def test_attitude_noise_turns_the_axes_by_about_its_sigma(flight):
    mr, f = flight
    noisy = observe(f, "attitude", CONSUMER_SENSORS, seed=3)
    clean = observe(f, "attitude")
    ang = np.arccos(np.clip(np.sum(noisy[..., :3] * clean[..., :3], -1), -1, 1))
    # the x axis moves by the rotation's component normal to it: sigma sqrt(2) on average-ish
    assert 0.5 * CONSUMER_SENSORS.attitude < np.sqrt(np.mean(ang ** 2)) < 2 * CONSUMER_SENSORS.attitude


def test_cem_searches_attitude_actions():
    s = uw.make_setting("light constant", "light shear", 2, sampler="attitude",
                        uav=Multirotor(start="hover"))
    res = uw.cem(s, n_samples=3, n_elite=1, max_iter=2, n_jobs=1, progress=False, seed=1)
    assert isinstance(res.best_thrust, AttitudeSequence) and len(res.history) == 2


# --------------------------------------------------------------------------- #
# RotorPy's wind filters
# --------------------------------------------------------------------------- #
def test_the_drag_calibration_recovers_the_papers_frame_drag():
    from uavwind.analysis.filters import calibrate_drag

    c = calibrate_drag(Multirotor(preset="paper", start="hover"), duration=6.0)
    # body x and y: the accelerometer's drag part is exactly -(c/m)|v|v (no thrust along them)
    assert c[:2] == pytest.approx([uw.PAPER_UAV.drag_factor] * 2, rel=1e-3)


def test_the_filters_find_a_known_wind_on_a_hover_probe(tmp_path):
    """A hover probe in constant wind (the flight the filters are designed for): RotorPy's UKF
    recovers the wind within 0.5 m/s; the table is cached and read back."""
    from uavwind.analysis.filters import filter_comparison

    s = uw.make_setting("light constant", "strong constant", 2, uav=Multirotor(start="hover"))
    df = filter_comparison(s, n_flights=1, probe=True, n_jobs=1, results=tmp_path)
    ukf = df[df["filter"] == "ukf"].iloc[0]
    assert ukf["diverged"] == 0 and ukf["rmse"] < 0.5 and ukf["correct"]
    assert set(df["filter"]) == {"ekf", "ukf"} and len(df) == 2
    again = filter_comparison(s, n_flights=1, probe=True, n_jobs=1, results=tmp_path)
    assert again.equals(df) and len(list((tmp_path / "filters").glob("*.parquet"))) == 1
    with pytest.raises(ValueError, match="kinds"):
        filter_comparison(s, kinds=("kalman",))
    with pytest.raises(TypeError, match="Multirotor"):
        filter_comparison(uw.make_setting("light constant", "strong constant", 2))


def test_the_lean_ukfs_models_fall_back_to_rotorpys_where_a_float_would_raise():
    """A state whose air-relative speed squares past the largest double (a filter running
    away): Python's float ** raises OverflowError where RotorPy's numpy gives inf, so the lean
    f and h hand that call to RotorPy's own and give its inf and nan (before, the
    OverflowError went through run_filter, which reads only LinAlgError and ValueError as a
    diverged filter, and ended the whole table); on ordinary states they are RotorPy's too."""
    import warnings

    from rotorpy.estimators.wind_ukf import WindUKF

    from uavwind.analysis import filters

    qp = Multirotor().quad_params()
    ukf, ukf0 = filters._filter_class("ukf")(qp, dt=0.01), WindUKF(qp, dt=0.01)
    ukf.uk = ukf0.uk = np.array([9.81, 0.1, -0.2, 0.3])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        for x in (np.r_[0, 0, 0, 1e200, 0, 0, 0, 0, 0.0], np.r_[0.1, 0.2, 0.3, 1, 2, 3, 1, 2, 3.0],
                  np.r_[0.1, 0.2, 0.3, 1, 2, 3, 0.5, 1.5, -2.0]):
            assert np.array_equal(ukf.f(x, 0.01), ukf0.f(x, 0.01), equal_nan=True)
            assert np.array_equal(ukf.h(x), ukf0.h(x), equal_nan=True)
        assert not np.isfinite(ukf.f(np.r_[0, 0, 0, 1e200, 0, 0, 0, 0, 0.0], 0.01)).all()


@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:Gimbal lock detected")
def test_the_lean_ukf_gives_rotorpys_estimates_exactly(monkeypatch):
    """The filter table's UKF (RotorPy's WindUKF with f and h on Python floats) against
    RotorPy's own class: every estimate of every step equal, with ==, on the loops' actions
    of an Exp 11 scenario (the states a search flies: tilted, fast) and on a hover probe."""
    from rotorpy.estimators.wind_ukf import WindUKF

    from uavwind.analysis import filters
    from uavwind.core.seeding import child_rng, child_seed, root_seed

    assert filters._filter_class("ukf") is not WindUKF
    s = uw.make_setting("light constant", "strong shear", 2, uav=Multirotor(start="hover"))
    root = root_seed(7)
    drag = filters.calibrate_drag(s.uav, seed=3)
    for action, envs in ((s.sample_thrust(child_rng(root, 0, 0)), (0, 3)),
                         (uw.ThrustSequence([0.0], [s.uav.weight], [[0.0, 0.0, 1.0]]), (3,))):
        f = uw.simulate_flight(action, s.wind(child_seed(root, 0, 1)), uav=s.uav,
                               dt=filters.FILTER_DT, duration=s.duration)
        for env in envs:
            lean = filters.run_filter(f, action, s.uav, "ukf", drag, env=env, seed=env)
            with monkeypatch.context() as m:
                m.setattr(filters, "_lean_ukf", lambda base: base)
                theirs = filters.run_filter(f, action, s.uav, "ukf", drag, env=env, seed=env)
            assert np.isfinite(theirs).any()
            assert np.array_equal(lean, theirs, equal_nan=True)


def test_the_lean_ukf_stops_at_the_step_rotorpys_own_filter_stops(monkeypatch):
    """Where the filter fails (a drag a thousand or a million times too large: its covariance
    is no longer positive definite, or no longer finite), the lean steps raise at the same
    step as filterpy's own, so the estimate ends at the same sample; and the filterpy object
    under it is the lean one (a RotorPy or filterpy that built it otherwise would leave it
    as it is, and this would fail)."""
    from uavwind.analysis import filters
    from uavwind.core.seeding import child_rng, child_seed, root_seed

    s = uw.make_setting("light constant", "strong shear", 2, uav=Multirotor(start="hover"))
    root = root_seed(7)
    action = s.sample_thrust(child_rng(root, 0, 0))
    f = uw.simulate_flight(action, s.wind(child_seed(root, 0, 1)), uav=s.uav,
                           dt=filters.FILTER_DT, duration=s.duration)
    ukf = filters._filter_class("ukf")(s.uav.quad_params(), dt=filters.FILTER_DT)
    assert type(ukf.filter).__name__ == "LeanUnscentedKalmanFilter"
    ended = []
    for drag in (1e3, 1e6):
        lean = filters.run_filter(f, action, s.uav, "ukf", [drag] * 3, env=0, seed=0)
        with monkeypatch.context() as m:
            m.setattr(filters, "_lean_filter", lambda ukf: ukf)
            theirs = filters.run_filter(f, action, s.uav, "ukf", [drag] * 3, env=0, seed=0)
        assert np.array_equal(lean, theirs, equal_nan=True)
        ended.append(int(np.isfinite(lean[:, 0]).sum()))
    assert 1 <= ended[1] < ended[0] < f.times.size  # both stop early, at different steps


# --------------------------------------------------------------------------- #
# the filters refuse what they cannot use (issue 33)
# --------------------------------------------------------------------------- #
def test_the_drag_calibration_refuses_a_flight_too_short_or_too_slow(monkeypatch):
    from uavwind.analysis import filters

    mr = Multirotor()
    for duration in (0.01, 1.0):
        with pytest.raises(ValueError, match=r"duration must be >= 2 s for a drag fit"):
            filters.calibrate_drag(mr, duration=duration)
    with pytest.raises(ValueError, match="duration"):
        filters.calibrate_drag(mr, duration=np.nan)
    with pytest.raises(ValueError, match="seed"):
        filters.calibrate_drag(mr, seed=-1)

    def level(rng, n_changes, duration, max_magnitude):  # a level probe: nothing to fit
        return AttitudeSequence([0.0], [mr.weight], [[0.0, 0.0, 0.0]])
    monkeypatch.setattr(filters, "sample_attitude", level)
    with pytest.raises(ValueError, match=r"RMS body velocity \(x .*, y .*\) is below 0.5 m/s"):
        filters.calibrate_drag(mr)


@pytest.fixture(scope="module")
def short_flight():
    from uavwind.analysis.filters import FILTER_DT

    mr = Multirotor(start="hover")
    hold = uw.ThrustSequence([0.0], [mr.weight], [[0.0, 0.0, 1.0]])
    f = uw.simulate_flight(hold, uw.ConstantWind([[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]), uav=mr,
                           dt=FILTER_DT, duration=0.5)
    return f, hold, mr


@pytest.mark.parametrize("change, error, word", [
    ({"drag": [0.1, np.nan, 0.1]}, ValueError, "drag"), ({"drag": [0.1, 0.1]}, ValueError, "drag"),
    ({"drag": [0.1, 0.0, 0.1]}, ValueError, "drag"), ({"env": 2}, ValueError, "env"),
    ({"env": -1}, ValueError, "env"), ({"seed": -1}, ValueError, "seed"),
    ({"kind": "kalman"}, ValueError, "kind"), ({"action": "hover"}, TypeError, "action"),
    ({"flight": "point mass"}, ValueError, "multirotor")])
def test_run_filter_names_what_it_cannot_use(short_flight, change, error, word):
    from uavwind.analysis.filters import run_filter

    f, hold, mr = short_flight
    kw = {"flight": f, "action": hold, "vehicle": mr, "kind": "ekf", "drag": [0.1] * 3,
          "env": 0, "seed": 0, **change}
    if kw["flight"] == "point mass":
        kw["flight"] = uw.simulate_flight(uw.PAPER_EXAMPLE, uw.ConstantWind([[1.0, 0, 0]]),
                                          dt=0.01, duration=12.0)
    with pytest.raises(error, match=word):
        run_filter(**kw)


@pytest.mark.slow
def test_a_cached_filter_table_with_swapped_rows_is_recomputed(tmp_path, forge_parquet):
    from uavwind.analysis.filters import filter_comparison
    from uavwind.study.cache import CorruptChunkWarning

    s = uw.make_setting("light constant", "strong constant", 2, duration=6.0,
                        uav=Multirotor(start="hover"))
    kw = dict(n_flights=2, probe=True, kinds="ekf", n_jobs=1, results=tmp_path)  # the cheaper one
    df = filter_comparison(s, **kw)
    (path,) = (tmp_path / "filters").glob("*.parquet")
    forge_parquet(path, lambda d: d.iloc[::-1].reset_index(drop=True))  # key and checksum right
    with pytest.warns(CorruptChunkWarning, match="out of order"):
        again = filter_comparison(s, **kw)
    assert again.equals(df)
    df.to_parquet(path, index=False)  # no digest: not trusted (a rewrite drops it), recomputed
    with pytest.warns(UserWarning, match="no checksum"):
        assert filter_comparison(s, **kw).equals(df)
    for kwargs, error in (({"probe": "yes"}, TypeError), ({"kinds": ("ekf", "ekf")}, ValueError),
                          ({"kinds": ()}, ValueError)):
        with pytest.raises(error, match="probe|kinds"):
            filter_comparison(s, n_flights=1, n_jobs=1, results=tmp_path, **kwargs)


@pytest.fixture(scope="module")
def hover_filter_table(tmp_path_factory):
    """One cheap filter comparison, computed once: ``(setting, kwargs without results,
    folder, table)``; tests copy the folder, never write into it."""
    from uavwind.analysis.filters import filter_comparison

    s = uw.make_setting("light constant", "strong constant", 2, duration=6.0,
                        uav=Multirotor(start="hover"))
    kw = dict(n_flights=1, probe=True, kinds="ekf", n_jobs=1)
    folder = tmp_path_factory.mktemp("filters")
    return s, kw, folder, filter_comparison(s, results=folder, **kw)


@pytest.mark.parametrize("keep_digest", [False, True])
def test_a_tampered_filter_table_is_moved_aside_recomputed_and_named(
        tmp_path, keep_digest, hover_filter_table, rewrite_parquet):
    """A value changed, the digest not (issue 45: rmse 0.001 was returned as is when the
    rewrite dropped the digest): moved aside, recomputed, with a warning naming the file."""
    import shutil

    from uavwind.analysis.filters import filter_comparison

    s, kw, folder, df = hover_filter_table
    shutil.copytree(folder, tmp_path, dirs_exist_ok=True)
    (path,) = (tmp_path / "filters").glob("*.parquet")
    rewrite_parquet(path, lambda d: d.assign(rmse=0.001), keep_digest)
    with pytest.warns(UserWarning, match=path.name):
        again = filter_comparison(s, results=tmp_path, **kw)
    assert again.equals(df) and again["rmse"].iloc[0] != 0.001
    assert path.with_name(path.name + ".corrupt").exists()  # kept, not deleted


@pytest.mark.parametrize("forgery", ["rmse 0.001, checksum of before", "rmse 250, key right",
                                     "swapped"])
def test_a_forged_or_swapped_filter_table_is_refused_and_recomputed(
        tmp_path, forgery, hover_filter_table, forge_parquet):
    """Issue 68: two filter tables swapped were trusted (rmse 5.22 returned where 2.69 was
    computed), and a table with rmse 0.001 and its checksum recomputed passed."""
    import shutil

    from uavwind.analysis.filters import filter_comparison

    s, kw, folder, df = hover_filter_table
    shutil.copytree(folder, tmp_path, dirs_exist_ok=True)
    (path,) = (tmp_path / "filters").glob("*.parquet")
    if forgery == "swapped":  # another seed's table (rmse 5.22), sound, moved over this one
        import json

        import pyarrow.parquet as pq

        from uavwind.core import store
        key = json.loads(pq.read_table(path).schema.metadata[store.KEY_KEY])
        assert key["params"]["seed"] == 0
        key["params"]["seed"] = 1
        theirs = store.atomic_write(tmp_path / "theirs.parquet", df.assign(rmse=5.22),
                                    key=store.entry_key(**key))
        os.replace(theirs, path)
        why = "another entry"
    elif forgery == "rmse 250, key right":
        forge_parquet(path, lambda d: d.assign(rmse=250.0))
        why = "rmse outside"
    else:
        forge_parquet(path, lambda d: d.assign(rmse=0.001), with_key=False)
        why = "no key"
    with pytest.warns(UserWarning, match=f"{path.name}.*{why}"):
        again = filter_comparison(s, results=tmp_path, **kw)
    assert again.equals(df)


def test_the_filter_table_flies_one_scenario_quick_and_all_four_at_the_paper_profile(
        monkeypatch):
    from uavwind.analysis import filters as F

    asked = []

    def fake(setting, n_flights, seed, probe, n_jobs, results):
        asked.append((setting.name, n_flights, probe))
        return pd.DataFrame({"filter": ["ekf", "ukf"] * n_flights,
                             "flight": np.repeat(np.arange(n_flights), 2),
                             "rmse": 1.0, "diverged": 0, "correct": True})

    monkeypatch.setattr(F, "filter_comparison", fake)
    scen = list(dict.fromkeys(c.labels["scenario"] for c in uw.study.EXPERIMENTS["exp11"].cases()))
    quick = F.filter_table("quick", n_jobs=1)
    assert list(dict.fromkeys(quick["scenario"])) == [scen[i] for i in F.QUICK_SCENARIOS]
    assert len(quick) == len(F.QUICK_SCENARIOS) * 2 * 2 and set(quick["n_flights"]) == {1}
    assert [p for _, _, p in asked] == [True, False] * len(F.QUICK_SCENARIOS)
    assert 0 < len(F.QUICK_SCENARIOS) < len(scen)
    paper = F.filter_table("paper", n_jobs=1)
    assert list(dict.fromkeys(paper["scenario"])) == scen and len(scen) == 4
    assert len(paper) == 4 * 2 * 2 and set(paper["n_flights"]) == {3}
