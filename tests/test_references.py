"""Position references: closed forms (the lemniscate at known times, a spline through its
waypoints at rest), derivatives against finite differences, the sampler's limits, and bad
input named; flying them: a hover that stays put, the flight's new records, the ground, and
Neural-Fly's quadrotor."""
import math

import numpy as np
import pytest

import uavwind as uw
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.rotor_params import NEURAL_FLY
from uavwind.sim.references import FLAT_KEYS, Hover, Lemniscate, WaypointSpline

pytest.importorskip("rotorpy")

DERIVATIVES = ("x", "x_dot", "x_ddot", "x_dddot", "x_ddddot")
REFERENCES = [Hover((0.5, -1.0, 3.0)), Lemniscate(), Lemniscate((1, 2, 5), (0.5, 1.0, 2.0), 3.0),
              WaypointSpline([[0, 0, 1], [1, 2, 2], [-1, 0.5, 1.5], [0, 0, 3]], [0.5, 2, 3, 6])]


def test_the_lemniscate_is_neural_flys_figure_8():
    ref = Lemniscate()
    t = np.array([0.0, math.pi / 4, math.pi / 2, math.pi, 3 * math.pi / 2])
    want = np.array([[0, 0, 2], [1.25 * math.sqrt(0.5), 0, 2.75], [1.25, 0, 2], [0, 0, 2],
                     [-1.25, 0, 2]])
    flat = ref.flat_output(t)
    assert np.abs(flat["x"] - want).max() < 1e-15
    assert np.allclose(flat["x_dot"][0], [1.25, 0.0, 1.5])   # d/dt (1.25 sin t, 0, .75 sin 2t)
    assert np.allclose(flat["x_ddot"][2], [-1.25, 0.0, 0.0])
    assert np.all(flat["yaw"] == 0) and np.all(flat["yaw_dot"] == 0)
    one_lap = ref.flat_output(t + ref.period)
    assert all(np.allclose(one_lap[k], flat[k], atol=1e-12) for k in FLAT_KEYS)


@pytest.mark.parametrize("ref", REFERENCES, ids=lambda r: type(r).__name__)
def test_each_derivative_is_the_finite_difference_of_the_one_before(ref):
    t = np.linspace(0.013, 5.9, 97)
    t = t[np.all(np.abs(t[:, None] - getattr(ref, "times", np.array([-9.0]))[None]) > 1e-3, 1)]
    h = 1e-5
    up, down, mid = ref.flat_output(t + h), ref.flat_output(t - h), ref.flat_output(t)
    assert set(mid) == set(FLAT_KEYS)
    for lower, higher in zip(DERIVATIVES, DERIVATIVES[1:]):
        fd = (up[lower] - down[lower]) / (2 * h)
        scale = max(1.0, np.abs(mid[higher]).max())
        assert np.abs(fd - mid[higher]).max() < 1e-5 * scale, higher
        assert mid[higher].shape == (t.size, 3)


def test_a_spline_rests_at_its_waypoints_and_holds_its_ends():
    wp = np.array([[0, 0, 1], [1, 2, 2], [-1, 0.5, 1.5]])
    ref = WaypointSpline(wp, [1.0, 3.0, 4.0])
    flat = ref.flat_output([0.0, 1.0, 3.0, 4.0, 10.0])
    assert np.abs(flat["x"] - wp[[0, 0, 1, 2, 2]]).max() < 1e-15
    for k in ("x_dot", "x_ddot"):
        assert np.abs(flat[k]).max() < 1e-12
    # C^2 across a waypoint: both sides agree in position, velocity and acceleration
    left, right = ref.flat_output([3.0 - 1e-9]), ref.flat_output([3.0 + 1e-9])
    for k in ("x", "x_dot", "x_ddot"):
        assert np.abs(left[k] - right[k]).max() < 1e-6
    # the peak speed of a minimum-jerk segment: 1.875 d / T, mid-segment (the second is faster)
    assert ref.max_speed == pytest.approx(1.875 * math.sqrt(4 + 2.25 + 0.25) / 1.0)
    mid = ref.flat_output([2.0])["x_dot"]
    assert np.linalg.norm(mid) == pytest.approx(1.875 * math.sqrt(6) / 2.0)
    assert ref == WaypointSpline(wp.copy(), [1.0, 3.0, 4.0]) and hash(ref) == hash(
        WaypointSpline(wp.copy(), [1.0, 3.0, 4.0]))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sampled_splines_keep_their_box_and_limits(seed):
    box = ((-2.0, 2.0), (-1.0, 1.0), (1.0, 3.0))
    ref = WaypointSpline.sample(seed, 7, 12.0, box=box, max_speed=1.5, max_acceleration=2.0)
    assert ref.waypoints.shape == (7, 3) and ref.duration == 12.0
    assert ref.max_speed < 1.5 and ref.max_acceleration < 2.0
    flat = ref.flat_output(np.linspace(0, 12, 2401))
    lo, hi = np.array(box).T
    assert np.all(flat["x"] >= lo - 1e-12) and np.all(flat["x"] <= hi + 1e-12)
    assert np.linalg.norm(flat["x_dot"], axis=1).max() < 1.5
    again = WaypointSpline.sample(np.random.default_rng(seed), 7, 12.0, box=box, max_speed=1.5,
                                  max_acceleration=2.0)
    assert again == ref
    started = WaypointSpline.sample(seed, 3, 4.0, start=(0.0, 0.0, 2.0))
    assert started.waypoints[0].tolist() == [0.0, 0.0, 2.0]


@pytest.mark.parametrize("make, error, match", [
    (lambda: Lemniscate(period=0.0), ValueError, "period"),
    (lambda: Lemniscate(period="1"), TypeError, "period"),
    (lambda: Lemniscate(center=(0, 0)), ValueError, "center"),
    (lambda: Lemniscate(center=("a", 0, 0)), TypeError, "center"),
    (lambda: Lemniscate(amplitude=(-1, 0, 0)), ValueError, "amplitude"),
    (lambda: Hover((0, 0, math.nan)), ValueError, "position"),
    (lambda: WaypointSpline([[0, 0, 1]], [0.0]), ValueError, "waypoints"),
    (lambda: WaypointSpline([[0, 0], [1, 1]], [0.0, 1.0]), ValueError, "waypoints"),
    (lambda: WaypointSpline([[0, 0, 1], [1, 1, 1]], [0.0]), ValueError, "times"),
    (lambda: WaypointSpline([[0, 0, 1], [1, 1, 1]], [1.0, 1.0]), ValueError, "times"),
    (lambda: WaypointSpline([[0, 0, 1], [1, 1, 1]], [-1.0, 1.0]), ValueError, "times"),
    (lambda: WaypointSpline.sample("seed", 3, 5.0), TypeError, "rng"),
    (lambda: WaypointSpline.sample(0, 1, 5.0), ValueError, "n_waypoints"),
    (lambda: WaypointSpline.sample(0, 2.5, 5.0), TypeError, "n_waypoints"),
    (lambda: WaypointSpline.sample(0, 3, 0.0), ValueError, "duration"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, max_speed=-1.0), ValueError, "max_speed"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, max_acceleration=0.0), ValueError,
     "max_acceleration"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, box=((0, 1), (0, 1), (-1, 2))), ValueError,
     "ground"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, box=((1, 0), (0, 1), (1, 2))), ValueError, "box"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, box=((0, 1), (0, 1))), ValueError, "box"),
    (lambda: WaypointSpline.sample(0, 3, 5.0, start=(9, 0, 2)), ValueError, "start"),
    (lambda: Lemniscate().flat_output([[0.0, 1.0]]), ValueError, "t"),
])
def test_bad_reference_input_names_itself(make, error, match):
    with pytest.raises(error, match=match):
        make()


# -- flying a reference ------------------------------------------------------------------ #

def test_a_hover_reference_in_still_air_stays_at_its_point():
    for preset in ("paper", "rotorpy", "neuralfly"):
        mr = Multirotor(preset=preset)
        f = uw.simulate_flight(Hover((1.0, -2.0, 2.0)), uw.ConstantWind(np.zeros((2, 3))),
                               uav=mr, dt=0.1, duration=12.0)
        assert np.abs(f.positions - [1.0, -2.0, 2.0]).max() < 1e-9
        assert np.abs(f.thrust_commands - mr.weight).max() < 1e-9 * mr.weight
        assert np.abs(f.aero_forces).max() < 1e-9
        assert f.motor_limited == 0.0 and f.tilt_limited == 0.0


def test_a_reference_flight_records_the_reference_thrust_and_aerodynamic_force():
    """The paper preset's drag is isotropic frame drag, so its aerodynamic force is exactly
    ``-c |v_air| v_air`` in the world frame whatever the attitude."""
    ref = Lemniscate()
    wind = uw.ConstantWind([[0.0, 0.0, 0.0], [6.0, 1.0, 0.0]])
    mr = Multirotor(preset="paper")
    f = uw.simulate_flight(ref, wind, uav=mr, dt=0.05, duration=6.0)
    assert f.references.shape == (2, 120, 3) and f.thrust_commands.shape == (2, 120)
    assert np.array_equal(f.references[1], ref.positions(f.times))
    va = f.air_velocities
    drag = -uw.PAPER_UAV.drag_factor * np.linalg.norm(va, axis=2, keepdims=True) * va
    assert np.abs(f.aero_forces - drag).max() < 1e-12
    assert np.allclose(np.linalg.norm(f.thrust, axis=2), f.thrust_commands)
    assert np.array_equal(f.positions, uw.simulate(ref, wind, uav=mr, dt=0.05, duration=6.0))
    tracking = np.linalg.norm(f.positions - f.references, axis=2)
    assert tracking[:, -40:].max() < 0.1      # it tracks the figure-8 once the start has passed
    rp = uw.simulate_flight(ref, wind, uav=Multirotor(), dt=0.05, duration=6.0)
    # RotorPy's drag pushes downwind: the mean aerodynamic force points along the wind
    assert rp.aero_forces[1, :, 0].mean() > 1.0 > abs(rp.aero_forces[0, :, 0].mean())


def test_reference_flights_are_refused_where_they_cannot_be_flown():
    wind = uw.ConstantWind([[0.0, 0.0, 0.0]])
    with pytest.raises(TypeError, match="a reference needs a multirotor"):
        uw.simulate(Lemniscate(), wind)
    with pytest.raises(TypeError, match="a reference needs a multirotor"):
        uw.simulate_flight(Lemniscate(), wind, uav=uw.UAV())
    with pytest.raises(ValueError, match="start='hover'"):
        uw.simulate(Lemniscate(), wind, uav=Multirotor(start="drifting"))
    with pytest.raises(ValueError, match="start_position"):
        uw.simulate(Lemniscate(), wind, uav=Multirotor(), start_position=(0, 0, 1))
    with pytest.raises(ValueError, match="control steps"):
        uw.simulate(Lemniscate(), wind, uav=Multirotor(), dt=0.015, duration=0.03)
    with pytest.raises(TypeError, match="wind"):
        uw.simulate(Lemniscate(), [[0, 0, 0]], uav=Multirotor())


def test_the_ground_refuses_a_reference_below_it_and_a_flight_through_it():
    wind = uw.ConstantWind([[0.0, 0.0, 0.0], [0.0, 0.0, -30.0]])
    with pytest.raises(ValueError, match=r"reference: its path goes below the ground \(z = -0.25"):
        uw.simulate(Lemniscate(center=(0, 0, 0.5)), wind, uav=Multirotor())
    low = WaypointSpline([[0, 0, 0.0], [0, 0, 0.0]], [0.0, 1.0])   # on the ground: allowed
    assert uw.simulate(low, uw.ConstantWind([[0.0, 0.0, 0.0]]), uav=Multirotor(),
                       duration=1.0).min() >= 0.0
    with pytest.raises(ValueError, match=r"environment 1 would go below the ground .* at t = "):
        uw.simulate(Hover((0.0, 0.0, 0.3)), wind, uav=Multirotor())


def test_the_neural_fly_quadrotor_is_the_articles():
    mr = Multirotor.neural_fly()
    assert mr == Multirotor(preset="neuralfly") and mr.mass == NEURAL_FLY["mass"] == 2.6
    assert mr.max_thrust / mr.weight == pytest.approx(2.2, rel=1e-12)
    qp = mr.quad_params()
    hubs = np.array(list(qp["rotor_pos"].values()))
    assert 2 * np.linalg.norm(hubs[0]) == pytest.approx(0.93)             # hub-to-hub diagonal
    assert abs(hubs[0, 1] / hubs[0, 0]) == pytest.approx(0.85 / 0.75)     # wide-X aspect
    assert Multirotor(preset="neuralfly", mass=5.2).hover_speed == pytest.approx(mr.hover_speed)
    assert Multirotor().mass == 2.0 and Multirotor(preset="paper").mass == 2.0
    with pytest.raises(TypeError, match="preset"):
        Multirotor.neural_fly(preset="rotorpy")
    f = uw.simulate_flight(Lemniscate(), uw.ConstantWind([[8.5, 0.0, 0.0]]), uav=mr, dt=0.02,
                           duration=12.0)
    assert f.positions[..., 2].min() > 0.5 and f.motor_limited < 0.05
