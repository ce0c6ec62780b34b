"""What the UAV observes, and its seeded noise."""
from dataclasses import replace

import numpy as np
import pytest

import uavwind as uw
from uavwind.method.baseline import estimate_wind
from uavwind.sim.observation import (
    CONSUMER_NOISE,
    Noise,
    gauss_markov,
    noise_seed,
    observe,
)


def _flight(wind, thrust=uw.PAPER_EXAMPLE):
    return uw.simulate_flight(thrust, wind)


def test_white_position_noise_has_its_sigma_and_mean_zero():
    f = _flight(uw.ConstantWind([[1.0, 1.0, 0.0]] * 200))
    err = observe(f, "position", Noise(position=0.3), seed=1) - f.positions
    assert err.std() == pytest.approx(0.3, rel=0.02)
    assert abs(err.mean()) < 4 * 0.3 / np.sqrt(err.size)


def test_gauss_markov_bias_is_stationary_with_its_autocorrelation():
    dt, sigma, tau = 0.1, 2.0, 3.0
    b = gauss_markov((4000, 120, 3), dt, sigma, tau, np.random.default_rng(0))
    phi = np.exp(-dt / tau)
    assert b[:, 0].std() == pytest.approx(sigma, rel=0.03)    # stationary from the start
    assert b[:, -1].std() == pytest.approx(sigma, rel=0.03)
    for lag in (1, 10, 50):
        r = np.mean(b[:, lag:] * b[:, :-lag]) / sigma ** 2
        assert r == pytest.approx(phi ** lag, abs=0.02)


def test_noise_seeds_come_from_the_loop_seed():
    f = _flight(uw.ConstantWind([[1.0, 0.0, 0.0]] * 3))
    root = np.random.SeedSequence(5, spawn_key=(3, 1))
    a = observe(f, "position", Noise(position=1.0), seed=noise_seed(root))
    b = observe(f, "position", Noise(position=1.0), seed=noise_seed(root))
    c = observe(f, "position", Noise(position=2.0), seed=noise_seed(root))
    assert np.array_equal(a, b)
    assert np.allclose(c - f.positions, 2 * (a - f.positions))  # common random numbers
    assert noise_seed(root).spawn_key == (3, 1, 2)


def test_channels_equal_the_simulators_velocities_and_accelerations():
    uav = uw.UAV()
    w = np.array([[1.2, -0.4, 0.0], [0.3, 0.9, 0.0]])
    f = _flight(uw.ConstantWind(w))
    assert np.array_equal(observe(f, "velocity"), f.ground_velocities)
    assert np.array_equal(observe(f, "position"), f.positions)
    pv = observe(f, "position+velocity")
    assert pv.shape == (2, 120, 6) and np.array_equal(pv[..., 3:], f.ground_velocities)
    # specific force, closed form of the explicit update: F/m - (k/m)|v_prev| v_prev
    va = f.air_velocities
    prev = np.concatenate([np.zeros_like(va[:, :1]), va[:, :-1]], axis=1)
    speed = np.linalg.norm(prev, axis=2, keepdims=True)
    expected = f.thrust[None] / uav.mass - uav.drag_factor / uav.mass * speed * prev
    assert np.allclose(observe(f, "acceleration"), expected, atol=1e-9)
    # a constant wind is invisible to an accelerometer
    assert np.allclose(observe(f, "acceleration")[0], observe(f, "acceleration")[1], atol=1e-9)


@pytest.mark.parametrize("call, match", [
    (lambda: Noise(position=-0.1), "position"),
    (lambda: Noise(bias_time=0.0), "bias_time"),
    (lambda: Noise(velocity=float("nan")), "velocity"),
    (lambda: gauss_markov((1, 5, 3), 0.1, 1.0, -1.0, np.random.default_rng(0)), "tau"),
    (lambda: observe(_flight(uw.ConstantWind([[0, 0, 0]])), "attitude"), "observation"),
    (lambda: estimate_wind(np.zeros((2, 5)), uw.PAPER_EXAMPLE), "positions"),
    (lambda: estimate_wind(np.zeros((2, 5, 2)), uw.PAPER_EXAMPLE), "positions"),
    (lambda: estimate_wind(np.zeros((2, 5, 3)), uw.PAPER_EXAMPLE, model="kalman"), "model"),
    (lambda: estimate_wind(np.zeros((2, 5, 3)), uw.PAPER_EXAMPLE, dt=0.0), "dt"),
    (lambda: replace(uw.table3_setting(), observation="gyro"), "observation"),
])
def test_bad_inputs_name_the_parameter(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_consumer_noise_levels_are_the_cited_figures():
    assert CONSUMER_NOISE.position == pytest.approx(2.5 / 1.1774)
    assert CONSUMER_NOISE.velocity == 0.05
    assert CONSUMER_NOISE.acceleration == pytest.approx(0.0088, abs=1e-4)


def test_observe_refuses_a_gravity_that_is_not_a_number():
    with pytest.raises(ValueError, match="gravity"):
        observe(_flight(uw.ConstantWind([[0, 0, 0]])), "acceleration", gravity=float("nan"))


# --------------------------------------------------------------------------- #
# bad input named (issue 33)
# --------------------------------------------------------------------------- #
def _short_flight():
    return uw.simulate_flight(uw.PAPER_EXAMPLE, uw.ConstantWind([[1.0, 0.0, 0.0]]),
                              duration=12.0)


@pytest.mark.parametrize("seed, error", [(-1, ValueError), (1.5, TypeError), ("0", TypeError)])
def test_observe_names_a_bad_seed(seed, error):
    from uavwind.sim.observation import observe

    with pytest.raises(error, match="seed"):
        observe(_short_flight(), "position", uw.Noise(position=1.0), seed=seed)


def test_observe_refuses_what_is_not_a_flight():
    from uavwind.sim.observation import observe

    with pytest.raises(TypeError, match="flight"):
        observe(np.zeros((2, 5, 3)), "position")


@pytest.mark.parametrize("shape, rng, word", [
    ((2, 5), np.random.default_rng(0), "shape"), ((2, 0, 3), np.random.default_rng(0), "shape"),
    ((2, 5, 3), 0, "rng")])
def test_gauss_markov_names_a_bad_shape_or_generator(shape, rng, word):
    from uavwind.sim.observation import gauss_markov

    with pytest.raises((ValueError, TypeError), match=word):
        gauss_markov(shape, 0.1, 1.0, 10.0, rng)
