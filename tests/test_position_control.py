"""RotorPy's SE3 position controller, ported: its kernel equals ``SE3Control.update`` on random
states and flat outputs, and a whole closed-loop flight of a reference equals RotorPy's own
``Multirotor.step`` + ``SE3Control`` flown with the same fixed-step integrator; reference flights
start in a hover, record the reference, the thrust command and the aerodynamic force, and
never go below the ground."""
import math

import numpy as np
import pytest

import uavwind as uw
from uavwind.sim import _rotor_kernels as rk
from uavwind.sim.multirotor import Multirotor
from uavwind.sim.references import Lemniscate

rotorpy_multirotor = pytest.importorskip("rotorpy.vehicles.multirotor")
quadrotor_control = pytest.importorskip("rotorpy.controllers.quadrotor_control")
from scipy.integrate import OdeSolver  # noqa: E402

PRESETS = ["rotorpy", "paper", "neuralfly"]
OUTPUTS = ["cmd_motor_speeds", "cmd_thrust", "cmd_moment", "cmd_q", "cmd_acc", "cmd_w"]


def _random_states(rng, n):
    S = np.zeros((n, 20))
    S[:, 0:3] = rng.normal(0, 3, (n, 3))
    S[:, 3:6] = rng.normal(0, 3, (n, 3))
    q = rng.normal(size=(n, 4))
    S[:, 6:10] = q / np.linalg.norm(q, axis=1, keepdims=True) * rng.uniform(0.99, 1.01, (n, 1))
    S[:, 10:13] = rng.normal(0, 2, (n, 3))
    S[:, 13:16] = rng.normal(0, 6, (n, 3))
    S[:, 16:20] = rng.uniform(0, 1500, (n, 4))
    return S


def _random_flat(rng, n):
    F = np.zeros((n, 11))
    F[:, 0:9] = rng.normal(0, 3, (n, 9))
    F[:, 9] = rng.uniform(-math.pi, math.pi, n)
    F[:, 10] = rng.normal(0, 1, n)
    return F


def _state(s):
    return {"x": s[0:3].copy(), "v": s[3:6].copy(), "q": s[6:10].copy(), "w": s[10:13].copy(),
            "wind": s[13:16].copy(), "rotor_speeds": s[16:20].copy()}


def _flat(f):
    return {"x": f[0:3], "x_dot": f[3:6], "x_ddot": f[6:9], "x_dddot": np.zeros(3),
            "x_ddddot": np.zeros(3), "yaw": f[9], "yaw_dot": f[10]}


@pytest.mark.parametrize("preset", PRESETS)
def test_the_se3_kernel_equals_rotorpys_se3control(preset):
    """Every output of ``SE3Control.update`` (motor speeds, thrust, moment, attitude, the
    desired acceleration F_des / m and the body-rate command) on 400 random states and flat
    outputs, to 1e-12 of each output's scale."""
    mr = Multirotor(preset=preset)
    ctl = quadrotor_control.SE3Control(mr.quad_params())
    rng = np.random.default_rng(3)
    S, F = _random_states(rng, 400), _random_flat(rng, 400)
    ours = dict(zip(OUTPUTS, rk.se3_commands(mr.packed, S, F)))
    theirs = {k: [] for k in OUTPUTS}
    for s, f in zip(S, F):
        c = ctl.update(0.0, _state(s), _flat(f))
        for k in OUTPUTS:
            theirs[k].append(c[k])
    for k in OUTPUTS:
        th = np.asarray(theirs[k], dtype=float)
        scale = np.abs(th).max()
        assert np.abs(ours[k] - th).max() <= 1e-12 * scale, k


def test_mode_2_steps_with_the_se3_commands_and_returns_the_thrust():
    mr = Multirotor()
    rng = np.random.default_rng(4)
    S, F = _random_states(rng, 50), _random_flat(rng, 50)
    u, thrust = rk.se3_commands(mr.packed, S, F)[:2]
    S2, T = S.copy(), np.zeros(50)
    rk.control_step(mr.packed, S2, T, F, 2, 4, 0.0025, np.zeros(50, dtype=np.int64))
    assert np.array_equal(T, thrust)
    S3 = S.copy()  # the same step from the clipped speeds, flown as motor speeds
    U = np.clip(u, mr.packed[30], mr.packed[31])
    for i in range(50):
        for _ in range(4):
            s = S3[i]
            k1 = rk.state_derivative(mr.packed, s[None], U[i][None])[0]
            k2 = rk.state_derivative(mr.packed, (s + 0.00125 * k1)[None], U[i][None])[0]
            k3 = rk.state_derivative(mr.packed, (s + 0.00125 * k2)[None], U[i][None])[0]
            k4 = rk.state_derivative(mr.packed, (s + 0.0025 * k3)[None], U[i][None])[0]
            S3[i] = s + (0.0025 / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        S3[i, 6:10] /= np.linalg.norm(S3[i, 6:10])
    assert np.abs(S2 - S3).max() <= 1e-9 * np.abs(S3).max()


class FixedRK4(OdeSolver):
    """Classical RK4 in ``n_steps`` equal steps, for ``solve_ivp(method=FixedRK4)``: RotorPy's
    own ``Multirotor.step`` with the integrator uavwind uses (4 steps per 10 ms control step)."""

    def __init__(self, fun, t0, y0, t_bound, vectorized=False, n_steps=4, **extraneous):
        super().__init__(fun, t0, y0, t_bound, vectorized)
        self.h = (t_bound - t0) / n_steps
        self.left = n_steps

    def _step_impl(self):
        t, y, h = self.t, self.y, self.h
        k1 = self.fun(t, y)
        k2 = self.fun(t + 0.5 * h, y + (0.5 * h) * k1)
        k3 = self.fun(t + 0.5 * h, y + (0.5 * h) * k2)
        k4 = self.fun(t + h, y + h * k3)
        self.y = y + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        self.left -= 1
        self.t = self.t_bound if self.left == 0 else t + h
        return True, None

    def _dense_output_impl(self):  # pragma: no cover - solve_ivp asks only with dense_output
        raise NotImplementedError


class _Wind(uw.WindModel):
    """Altitude- and time-varying wind, one environment."""
    n_env = 1

    def _velocity(self, t, positions):
        z = positions[:, 2]
        return np.stack([3.0 + 0.5 * z, np.full_like(z, -1.0 + 1.5 * np.sin(t)),
                         np.full_like(z, 0.3)], axis=1)


def _rotorpy_flight(mr, reference, wind, duration, integrator_kwargs):
    """RotorPy's loop (``rotorpy.simulate``'s order): wind at the state, SE3Control.update on the
    state and the flat output at t, Multirotor.step over one control step."""
    vehicle = rotorpy_multirotor.Multirotor(mr.quad_params(),
                                            control_abstraction="cmd_motor_speeds", aero=True,
                                            integrator_kwargs=integrator_kwargs)
    ctl = quadrotor_control.SE3Control(mr.quad_params())
    h = 1 / mr.control_rate
    s0 = mr.initial_states(reference.positions([0.0])[0], np.zeros((1, 3)))[0]
    state = _state(s0)
    got = []
    for k in range(int(round(duration * mr.control_rate))):
        t = k * h
        flat = {key: v[0] for key, v in reference.flat_output([t]).items()}
        state["wind"] = wind.velocity(t, state["x"][None])[0]
        control = ctl.update(t, state, flat)
        state = vehicle.step(state, control, h)
        got.append(state["x"].copy())
    return np.array(got)


@pytest.mark.parametrize("preset", ["rotorpy", pytest.param("neuralfly", marks=pytest.mark.slow)])
def test_a_closed_loop_lemniscate_equals_rotorpys_own_flight(preset):
    """12 s of Neural-Fly's figure-8 in a sheared, gusting wind: our Multirotor with the ported
    SE3 controller against RotorPy's Multirotor.step + SE3Control.update, both at 100 Hz with
    four RK4 steps per control step (RotorPy through solve_ivp with a fixed-step solver): every
    position at every control step agrees to 1e-9 m (measured: 4.4e-16 m, every preset)."""
    mr = Multirotor(preset=preset)
    ref, wind = Lemniscate(), _Wind()
    ours = uw.simulate(ref, wind, uav=mr, dt=0.01, duration=12.0)[0]
    theirs = _rotorpy_flight(mr, ref, wind, 12.0, {"method": FixedRK4, "n_steps": 4})
    assert np.abs(ours - ref.positions(np.arange(1, 1201) * 0.01)).max() > 0.05  # it flies
    assert np.abs(ours - theirs).max() < 1e-9


@pytest.mark.slow
def test_rotorpys_adaptive_integrator_agrees_to_its_tolerance():
    """The same flight (4 s) with RotorPy's RK45 at rtol = atol = 1e-10: the fixed RK4 of 2.5 ms
    is the only difference, and it is small (measured: 1.5e-6 m; RotorPy's default RK45
    tolerances are far looser)."""
    mr = Multirotor()
    ref, wind = Lemniscate(), _Wind()
    ours = uw.simulate(ref, wind, uav=mr, dt=0.01, duration=4.0)[0]
    tight = {"method": "RK45", "rtol": 1e-10, "atol": 1e-10}
    theirs = _rotorpy_flight(mr, ref, wind, 4.0, tight)
    assert np.abs(ours - theirs).max() < 1e-5


def _states_at(flight, j, wind_of=None):
    """The 20 state columns of every environment after sample ``j`` of a recorded flight
    (position, velocity, attitude, body rates, wind, rotor speeds: the kernels' layout), the
    wind replaced by ``wind_of``'s when given."""
    from uavwind.sim._slots import S_POS, S_QUAT, S_RATES, S_ROTORS, S_VEL, S_WIND

    S = np.empty((flight.n_env, 20))
    S[:, S_POS], S[:, S_VEL] = flight.positions[:, j], flight.ground_velocities[:, j]
    S[:, S_QUAT], S[:, S_RATES] = flight.attitudes[:, j], flight.body_rates[:, j]
    S[:, S_WIND] = flight.winds[:, j if wind_of is None else wind_of]
    S[:, S_ROTORS] = flight.rotor_speeds[:, j]
    return S


@pytest.mark.parametrize("kind", ["reference", "thrust"])
def test_the_sensors_recorded_after_the_flight_are_those_of_each_sample_alone(kind):
    """A flight's sensors (specific force, aerodynamic force, thrust along the body z axis) are
    computed after the flight in one batch over every sample: each sample's equal, to the
    double, what the same formulas give on that sample's own state alone, under the command
    held over it (at one control step per sample, computed from the sample before's state
    with this sample's wind)."""
    from uavwind.sim._rotor_layout import (_aero_force, _body_z, _clipped_commands,
                                           _clipped_se3, _specific_force)
    from uavwind.sim._slots import FLAT_ACC, FLAT_POS, FLAT_VEL, FLAT_YAW, FLAT_YAW_RATE, N_FLAT

    mr = Multirotor(preset="rotorpy", start="hover")
    wind = uw.make_setting("light constant", "light shear").wind(3)
    if kind == "reference":
        ref = Lemniscate()
        f = uw.simulate_flight(ref, wind, uav=mr, dt=0.01, duration=3.0)
    else:
        d = np.array([[0.05, 0.0, 1.0], [0.0, -0.08, 1.0], [0.03, 0.03, 1.0]])
        ref = uw.ThrustSequence([0.0, 1.0, 2.0], [9.0, 10.5, 9.5],
                                d / np.linalg.norm(d, axis=1, keepdims=True))
        f = uw.simulate_flight(ref, wind, uav=mr, dt=0.01, duration=3.0)
    P = mr.packed
    for j in (1, 2, 57, 150, f.times.size - 1):
        before, after = _states_at(f, j - 1, wind_of=j), _states_at(f, j)
        if kind == "reference":
            flat = ref.flat_output(np.array([j * 0.01]))
            F = np.empty((f.n_env, N_FLAT))
            F[:, FLAT_POS], F[:, FLAT_VEL], F[:, FLAT_ACC] = flat["x"], flat["x_dot"], flat["x_ddot"]
            F[:, FLAT_YAW], F[:, FLAT_YAW_RATE] = flat["yaw"], flat["yaw_dot"]
            u = _clipped_se3(P, before, F, 2)
            assert np.array_equal(f.aero_forces[:, j], _aero_force(P, after, u))
            thrust = f.thrust_commands[:, j][:, None] * np.stack([_body_z(q) for q in
                                                                  before[:, 6:10]])
            assert np.array_equal(f.thrust[:, j], thrust)
        else:
            T, q, _ = mr.segment_commands(ref)[int(ref.segment(np.array([j * 0.01]))[0])]
            u = _clipped_commands(P, before, np.full(f.n_env, T), np.tile(q, (f.n_env, 1)))
        assert np.array_equal(f.specific_forces[:, j], _specific_force(P, after, u))


# --------------------------------------------------------------------------- #
# a wind that reads no position: the whole flight in the kernel (fly_flat)
# --------------------------------------------------------------------------- #
class _Asked(uw.WindModel):
    """``wind`` asked step by step (not ``position_free``): the same winds, flown by
    ``fly_reference``'s Python loop, one control step per call."""

    def __init__(self, wind):
        self.wind, self.n_env = wind, wind.n_env

    def _velocity(self, t, positions):
        return self.wind._velocity(t, positions)


def _gusting(n_env=2, seed=4):
    from uavwind.sim.dryden import DrydenWind
    from uavwind.sim.wind import RampedWind, SinusoidalWind
    mean = SinusoidalWind([[-6.0, 1.0, 0.0]] * n_env, [[-2.0, 0.0, 0.5]] * n_env, period=3.0)
    gusts = DrydenWind([4.0] * n_env, altitude=2.0, dt=0.01, airspeed=6.0, seed=seed)
    return RampedWind(mean + gusts, 1.5)


def _flight_arrays(flight):
    return {k: v for k, v in vars(flight).items() if isinstance(v, np.ndarray)}


@pytest.mark.parametrize("law", ["se3", "integral", "integral with state errors"])
def test_the_kernels_loop_flies_as_the_step_by_step_loop(law):
    """Neural-Fly's figure-8 in a ramped, sinusoidal, gusting wind, two environments: flown
    whole in the kernel (the wind is position free) and step by step (the same wind asked at
    each step), every recorded array is the same to the bit, for RotorPy's SE3 law (mode 2),
    the integral law (mode 3) and the integral law on an imperfect state (mode 4)."""
    from uavwind.sim.rotor_params import NEURAL_FLY_CONTROL
    wind = _gusting()
    assert wind.position_free and not _Asked(wind).position_free
    if law == "se3":
        mr, errors = Multirotor(preset="neuralfly"), None
    else:
        mr = Multirotor.neural_fly(position_control=NEURAL_FLY_CONTROL)
        errors = None
        if law != "integral":
            n_ctrl = 600 * mr.steps_per_sample(0.01)
            errors = 0.02 * np.random.default_rng(1).standard_normal((2, n_ctrl, 6))
    ref = Lemniscate()
    whole = mr.fly_reference(ref, wind, 0.01, 600, record_all=True, state_errors=errors)
    asked = mr.fly_reference(ref, _Asked(wind), 0.01, 600, record_all=True,
                             state_errors=errors)
    a, b = _flight_arrays(whole), _flight_arrays(asked)
    assert a.keys() == b.keys() and "aero_forces" in a
    assert [k for k in a if not np.array_equal(a[k], b[k])] == []
    assert whole.motor_limited == asked.motor_limited
    assert np.abs(a["positions"][0] - a["positions"][1]).max() > 1e-3  # gusts of their own
    assert np.array_equal(mr.fly_reference(ref, wind, 0.01, 600, state_errors=errors),
                          a["positions"])  # the positions alone, without the record
    other = mr.fly_reference(ref, _gusting(seed=5), 0.01, 600, state_errors=errors)
    assert np.abs(other - a["positions"]).max() > 1e-3  # the gusts are flown


def test_both_loops_refuse_the_same_ground_contact():
    """A wind blowing down at 40 m/s in the second environment only: both loops refuse the
    flight with the same GroundContact, naming environment 1 and the same time and height."""
    from uavwind.sim.multirotor import GroundContact
    wind = uw.ConstantWind([[0.0, 0.0, 0.0], [0.0, 0.0, -40.0]])
    mr, ref = Multirotor(preset="neuralfly"), Lemniscate()
    messages = []
    for w in (wind, _Asked(wind)):
        with pytest.raises(GroundContact, match="environment 1 would go below") as err:
            mr.fly_reference(ref, w, 0.01, 400)
        messages.append((str(err.value), err.value.env, err.value.time))
    assert messages[0] == messages[1]
