"""The integrator against invariants and closed forms (DESIGN decision 1)."""
import warnings

import numpy as np
import pytest

import uavwind as uw
from uavwind.sim.dynamics import max_stable_dt


def still(n=1):
    return uw.ConstantWind(np.zeros((n, 3)))


def test_shapes_and_start(worked_example):
    traj = uw.simulate(uw.PAPER_EXAMPLE, worked_example.wind())
    assert traj.shape == (10, 120, 3)
    f = uw.simulate_flight(uw.PAPER_EXAMPLE, worked_example.wind())
    assert np.array_equal(f.positions, traj)
    assert np.allclose(f.times, np.arange(1, 121) * 0.1)
    assert np.array_equal(f.start, [0, 0, 10])
    # r_k = r_{k-1} + v_ground_k dt
    prev = np.concatenate([np.broadcast_to(f.start, (10, 1, 3)), f.positions[:, :-1]], axis=1)
    assert np.allclose(f.positions, prev + 0.1 * f.ground_velocities, atol=1e-12)
    assert np.allclose(f.ground_velocities, f.air_velocities + f.winds, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_constant_wind_adds_wind_times_time(seed):
    rng = np.random.default_rng(seed)
    thrust = uw.sample_continuous(rng)
    winds = rng.uniform(-14, 14, size=(6, 3))
    moved = uw.simulate(thrust, uw.ConstantWind(winds))
    calm = uw.simulate(thrust, still())
    t = np.arange(1, 121) * 0.1
    expected = calm + winds[:, None, :] * t[None, :, None]
    assert np.max(np.abs(moved - expected)) < 1e-9


def test_hover_holds_altitude():
    uav = uw.UAV()
    hover = uw.ThrustSequence([0.0], [uav.mass * uav.gravity], [[0, 0, 1]])
    traj = uw.simulate(hover, still())
    assert np.max(np.abs(traj[0] - [0, 0, 10])) < 1e-12


def test_free_fall_matches_discrete_closed_form():
    uav = uw.UAV(drag_coefficient=0.0)
    off = uw.ThrustSequence([0.0], [0.0], [[0, 0, 1]])
    dt = 0.1
    traj = uw.simulate(off, still(), uav=uav, dt=dt, duration=12.0)
    k = np.arange(1, 121)
    z = 10.0 - 9.81 * dt ** 2 * k * (k + 1) / 2
    assert np.max(np.abs(traj[0, :, 2] - z)) < 1e-9
    assert np.all(traj[0, :, :2] == 0)
    assert traj[0, -1, 2] < 0  # no ground: the altitude goes negative


def test_drag_gives_terminal_velocity():
    uav = uw.UAV(gravity=0.0)
    push = uw.ThrustSequence([0.0], [10.0], [[1, 0, 0]])
    f = uw.simulate_flight(push, still(), uav=uav, dt=0.1, duration=400.0)
    v_terminal = np.sqrt(10.0 / uav.drag_factor)
    assert f.air_velocities[0, -1, 0] == pytest.approx(v_terminal, rel=1e-6)
    # and the drag is quadratic: at half the terminal speed the net force is 3/4 of the thrust
    v = f.air_velocities[0, :, 0]
    a = np.diff(v) / 0.1
    i = np.searchsorted(v, v_terminal / 2)
    assert a[i] * uav.mass == pytest.approx(10.0 * (1 - (v[i] / v_terminal) ** 2), rel=1e-3)


def test_drag_acts_on_air_relative_velocity():
    """In a constant wind a UAV with zero airspeed feels no drag: it drifts with the air."""
    uav = uw.UAV()
    hover = uw.ThrustSequence([0.0], [uav.weight], [[0, 0, 1]])
    f = uw.simulate_flight(hover, uw.ConstantWind([[12.0, 0, 0]]))
    assert np.all(f.air_velocities == 0)
    assert f.positions[0, -1, 0] == pytest.approx(12.0 * 12.0)


def test_shear_wind_met_along_the_path():
    wind = uw.ShearWind([[2.0, 1.0, 0.0]], alpha=0.143)
    climb = uw.ThrustSequence([0.0, 6.0], [30.0, 10.0], [[0, 0, 1], [0, 0, 1]])
    f = uw.simulate_flight(climb, wind)
    z_before = np.concatenate([[10.0], f.positions[0, :-1, 2]])
    assert np.allclose(f.winds[0], np.outer(wind.factor(z_before), [2.0, 1.0, 0.0]))


def test_environments_are_independent_of_the_batch():
    setting = uw.make_setting("light shear", "strong constant", 4)
    thrust = uw.sample_paper(np.random.default_rng(1))
    batch = setting.simulate(thrust)
    alone = uw.simulate(thrust, uw.ShearWind([setting.group_a.values[2]]))
    assert np.array_equal(batch[2], alone[0])


def test_turbulent_environments_repeat_with_the_seed():
    setting = uw.make_setting("light constant", "strong turbulence", 3)
    a = setting.simulate(uw.PAPER_EXAMPLE, seed=4)
    b = setting.simulate(uw.PAPER_EXAMPLE, seed=4)
    c = setting.simulate(uw.PAPER_EXAMPLE, seed=5)
    assert np.array_equal(a, b)
    assert np.array_equal(a[:3], c[:3]) and not np.allclose(a[3:], c[3:])


@pytest.mark.parametrize("kwargs, err, match", [
    ({"dt": 0.0}, ValueError, "dt"), ({"dt": -0.1}, ValueError, "dt"),
    ({"duration": 0.0}, ValueError, "duration"), ({"dt": 0.07}, ValueError, "multiple"),
    ({"duration": 8.0}, ValueError, "inside the flight"),
    ({"uav": "drone"}, TypeError, "uav"), ({"start_position": [0, 0]}, ValueError, "start_position"),
    ({"start_altitude": np.nan}, ValueError, "start_altitude"),
])
def test_simulate_validation(kwargs, err, match):
    with pytest.raises(err, match=match):
        uw.simulate(uw.PAPER_EXAMPLE, still(), **kwargs)


def test_simulate_rejects_wrong_objects():
    with pytest.raises(TypeError, match="thrust"):
        uw.simulate([[0, 0, 1]], still())
    with pytest.raises(TypeError, match="wind"):
        uw.simulate(uw.PAPER_EXAMPLE, np.zeros((2, 3)))


def _push(magnitude=50.0, times=(0.0,)):
    k = len(times)
    return uw.ThrustSequence(list(times), [magnitude] * k, [[0, 0, 1]] * k)


def test_unstable_drag_is_refused_with_a_step_that_works():
    light = uw.UAV(mass=0.1, drag_coefficient=1.0, area=0.1)
    wind = uw.ConstantWind([[1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=r"dt = 0.1 s .*mass = 0.1 kg.*use dt <") as err:
        uw.simulate(_push(), wind, uav=light, dt=0.1, duration=1.0)
    ok = float(str(err.value).split("e.g. dt = ")[1].split(" s")[0])  # the suggested step
    assert ok < max_stable_dt(_push(), light)
    pos = uw.simulate(_push(), wind, uav=light, dt=ok, duration=1.0)
    assert np.all(np.isfinite(pos))
    # the paper's UAV is far inside the stable range
    assert max_stable_dt(_push(), uw.UAV()) > 1.0


def test_off_grid_and_late_thrust_changes_warn():
    wind = uw.ConstantWind([[0.0, 0.0, 0.0]])
    with pytest.warns(UserWarning, match="falls between steps.*takes effect at 4.1 s"):
        uw.simulate(_push(20.0, (0.0, 4.05)), wind)
    with pytest.warns(UserWarning, match="11.95 s comes after the last step start"):
        uw.simulate(_push(20.0, (0.0, 11.95)), wind)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        uw.simulate(_push(20.0, (0.0, 4.0, 11.9)), wind)


@pytest.mark.parametrize("call, err, match", [
    (lambda: uw.score_loop(np.zeros((2, 5, 3)), [0, 1]), ValueError, "at least 3"),
    (lambda: uw.score_loop(np.full((4, 5, 3), 1e200), [0, 0, 1, 1]), ValueError, "within"),
    (lambda: uw.make_setting("light constant", "light constant", 1), ValueError, "at least 3"),
    (lambda: uw.DrydenWind([1e-300]), ValueError, r"w20 must be in \[0.001, 1000\]"),
    (lambda: uw.ConstantWind([[1e308, 0, 0]]), ValueError, "velocities"),
    (lambda: uw.ShearWind([[0, 2e3, 0]]), ValueError, "reference_velocities"),
    (lambda: uw.simulate(_push(), uw.ConstantWind([[0, 0, 0]]), dt=1e-12), ValueError,
     "dt = 1e-12 s"),
])
def test_tiny_huge_and_too_few_are_refused(call, err, match):
    with pytest.raises(err, match=match):
        call()
