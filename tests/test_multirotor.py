"""The multirotor against RotorPy itself: its derivative and its commands equal RotorPy's
own methods, a flight integrated by RotorPy agrees with ours, and the invariants hold (the
w t shift of a drifting start in constant wind, a hover that stays put)."""
import math
import sys

import numpy as np
import pytest

import uavwind as uw
from uavwind.sim import _rotor_kernels as rk
from uavwind.sim import multirotor as mrmod
from uavwind.sim.multirotor import Multirotor, force_command

rotorpy_multirotor = pytest.importorskip("rotorpy.vehicles.multirotor")


def _rotorpy(mr, abstraction="cmd_ctatt", **kw):
    return rotorpy_multirotor.Multirotor(mr.quad_params(), control_abstraction=abstraction,
                                         aero=True, **kw)


def _random_states(rng, n, mr):
    S = np.zeros((n, 20))
    S[:, 0:3] = rng.normal(0, 20, (n, 3))
    S[:, 3:6] = rng.normal(0, 8, (n, 3))
    q = rng.normal(size=(n, 4))
    S[:, 6:10] = q / np.linalg.norm(q, axis=1, keepdims=True) * rng.uniform(0.99, 1.01, (n, 1))
    S[:, 10:13] = rng.normal(0, 2, (n, 3))
    S[:, 13:16] = rng.normal(0, 6, (n, 3))
    S[:, 16:20] = rng.uniform(0, mr.packed[31], (n, 4))
    return S


def _unpack(s):
    return {"x": s[0:3], "v": s[3:6], "q": s[6:10], "w": s[10:13], "wind": s[13:16],
            "rotor_speeds": s[16:20]}


@pytest.mark.parametrize("preset", ["rotorpy", "paper"])
def test_the_derivative_equals_rotorpys_own(preset):
    mr = Multirotor(preset=preset)
    ref = _rotorpy(mr)
    rng = np.random.default_rng(1)
    S = _random_states(rng, 200, mr)
    U = rng.uniform(0, mr.packed[31], (200, 4))
    ours = rk.state_derivative(mr.packed, S, U)
    theirs = np.array([ref._s_dot_fn(0.0, s, u) for s, u in zip(S, U)])
    for block in (slice(0, 3), slice(3, 6), slice(6, 10), slice(10, 13), slice(16, 20)):
        scale = max(np.abs(theirs[:, block]).max(), 1e-300)
        assert np.abs(ours[:, block] - theirs[:, block]).max() <= 1e-12 * scale, block


@pytest.mark.parametrize("preset", ["rotorpy", "paper"])
@pytest.mark.parametrize("abstraction, mode", [("cmd_ctatt", 0), ("cmd_ctbr", 1)])
def test_the_commands_equal_rotorpys_get_cmd_motor_speeds(preset, abstraction, mode):
    mr = Multirotor(preset=preset)
    ref = _rotorpy(mr, abstraction)
    rng = np.random.default_rng(2)
    S = _random_states(rng, 100, mr)
    T = rng.uniform(0, 100, 100)
    if mode == 0:
        C = rng.normal(size=(100, 4))
        C /= np.linalg.norm(C, axis=1, keepdims=True)
        ctrl = [{"cmd_thrust": t, "cmd_q": c} for t, c in zip(T, C)]
    else:
        C = rng.normal(0, 3, (100, 3))
        ctrl = [{"cmd_thrust": t, "cmd_w": c} for t, c in zip(T, C)]
    ours = np.clip(rk.motor_commands(mr.packed, S, T, C, mode), 0, mr.packed[31])
    theirs = np.clip([ref.get_cmd_motor_speeds(_unpack(s), c) for s, c in zip(S, ctrl)],
                     0, mr.packed[31])
    assert np.abs(ours - theirs).max() <= 1e-9 * mr.packed[31]


class _Wind(uw.WindModel):
    """Altitude- and time-varying test wind, one environment."""
    n_env = 1

    def _velocity(self, t, positions):
        z = positions[:, 2]
        return np.stack([2.0 + 0.1 * z, np.full_like(z, -1.0 + 0.5 * np.sin(t)),
                         np.full_like(z, 0.2)], axis=1)


@pytest.mark.slow
def test_a_flight_integrated_by_rotorpy_agrees_with_ours():
    """RotorPy's own Multirotor.step (RK45, rtol = atol = 1e-10) flown through the same wind
    (our wind, fed through a one-environment adapter) and the same commands, 4 s: our fixed
    RK4 at 2.5 ms agrees within 1e-3 m (RotorPy's default tolerances are 3e-3 m from its own
    tight solution on such flights)."""
    mr = Multirotor(preset="rotorpy", start="hover")
    thrust = uw.ThrustSequence([0.0, 1.0, 2.5], [25.0, 15.0, 30.0],
                               [[0, 0, 1], [1, 0, 0], [0, 1, 1]])
    wind = _Wind()
    ours = uw.simulate_flight(thrust, wind, uav=mr, duration=4.0)
    ref = _rotorpy(mr, integrator_kwargs={"method": "RK45", "rtol": 1e-10, "atol": 1e-10})
    s0 = mr.initial_states(np.array([0.0, 0.0, 10.0]), np.zeros((1, 3)))[0]
    state = _unpack(s0.copy())
    cmds = [force_command(v, mr.tilt_limit) for v in thrust.vectors]
    got = []
    for k in range(400):
        t = k / mr.control_rate
        T, q, _ = cmds[int(thrust.segment(t))]
        state["wind"] = wind.velocity(t, state["x"][None])[0]
        state = ref.step(state, {"cmd_thrust": T, "cmd_q": q}, 1 / mr.control_rate)
        if (k + 1) % 10 == 0:
            got.append(state["x"].copy())
    assert np.abs(np.array(got) - ours.positions[0]).max() < 1e-3


def test_a_drifting_start_in_constant_wind_is_the_still_air_path_plus_w_t():
    mr = Multirotor(preset="rotorpy", start="drifting")
    w = np.array([[3.0, -2.0, 0.5], [11.0, 11.0, 0.0], [0.0, 0.0, 0.0]])
    pos = uw.simulate(uw.PAPER_EXAMPLE, uw.ConstantWind(w), uav=mr)
    still = pos[2]
    t = np.arange(1, 121) * 0.1
    for i in range(2):
        assert np.abs(pos[i] - still - w[i] * t[:, None]).max() < 1e-9


@pytest.mark.parametrize("preset", ["rotorpy", "paper"])
def test_a_hover_start_with_hover_thrust_in_still_air_stays_put(preset):
    mr = Multirotor(preset=preset, start="hover")
    hold = uw.ThrustSequence([0.0], [mr.weight], [[0, 0, 1]])
    f = uw.simulate_flight(hold, uw.ConstantWind([[0.0, 0.0, 0.0]] * 2), uav=mr)
    assert np.abs(f.positions - [0.0, 0.0, 10.0]).max() < 1e-9
    assert np.allclose(f.specific_forces, [0.0, 0.0, mr.gravity], atol=1e-9)  # at rest
    assert f.tilt_limited == 0.0 and f.motor_limited == 0.0


def test_the_wind_acts_through_drag_only_from_a_hover():
    """Hovering in a 5 m/s wind, the paper's frame drag barely moves the vehicle, RotorPy's
    rotor drag carries it; a drifting start is carried all along (5 m/s x 12 s = 60 m)."""
    hold = uw.ThrustSequence([0.0], [2.0 * 9.81], [[0, 0, 1]])
    wind = uw.ConstantWind([[5.0, 0.0, 0.0]])
    drift = {k: uw.simulate(hold, wind, uav=Multirotor(preset=k[0], start=k[1]))[0, -1, 0]
             for k in (("paper", "hover"), ("rotorpy", "hover"), ("rotorpy", "drifting"))}
    assert drift[("paper", "hover")] < 2.0 < 30.0 < drift[("rotorpy", "hover")] < 60.0
    assert drift[("rotorpy", "drifting")] == pytest.approx(60.0, abs=1e-6)


def test_force_commands_respect_the_tilt_limit():
    T, q, limited = force_command([0.0, 0.0, -20.0])
    assert T == 0.0 and limited and np.allclose(q, [0, 0, 0, 1])   # never pushes down
    T, q, limited = force_command([15.0, 0.0, 0.0], tilt_limit=60.0)
    assert limited and T == pytest.approx(15.0 * math.sin(math.radians(60.0)))
    for F in ([10.0, 0, 0], [0, 10.0, 0], [0, 0, 10.0], [3.0, 4.0, 5.0]):
        T, q, limited = force_command(F)
        R = np.array(rotorpy_multirotor.Rotation.from_quat(q).as_matrix())
        assert not limited and np.allclose(T * R[:, 2], F, atol=1e-12)  # exact within 90


@pytest.mark.parametrize("kwargs, match", [
    ({"preset": "heavy"}, "preset"), ({"start": "landed"}, "start"),
    ({"tilt_limit": 120.0}, "tilt_limit"), ({"tilt_limit": 0.0}, "tilt_limit"),
    ({"mass": -1.0}, "mass"), ({"control_rate": 1.0}, "control_rate"),
    ({"substeps": 0}, "substeps"),
])
def test_bad_vehicle_parameters_name_themselves(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Multirotor(**kwargs)


def test_thrust_beyond_the_rotors_and_an_off_grid_step_are_refused():
    mr = Multirotor()
    too_much = uw.ThrustSequence([0.0], [250.0], [[0, 0, 1]])
    with pytest.raises(ValueError, match="thrust magnitudes must be <= 200.5 N"):
        uw.simulate(too_much, uw.ConstantWind([[0, 0, 0]]), uav=mr)
    hold = uw.ThrustSequence([0.0], [20.0], [[0, 0, 1]])
    with pytest.raises(ValueError, match="control steps"):
        uw.simulate(hold, uw.ConstantWind([[0, 0, 0]]), uav=mr, dt=0.015, duration=0.03)
    with pytest.raises(TypeError, match="once"):
        uw.simulate(uw.PAPER_EXAMPLE, uw.ConstantWind([[0, 0, 0]]), uav=mr, vehicle=mr)


def test_without_rotorpy_the_multirotor_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "rotorpy", None)
    monkeypatch.setitem(sys.modules, "rotorpy.vehicles", None)
    monkeypatch.setitem(sys.modules, "rotorpy.vehicles.hummingbird_params", None)
    mrmod._packed.cache_clear()
    try:
        with pytest.raises(ImportError, match=r"uavwind\[multirotor\]"):
            Multirotor(mass=2.5)
    finally:
        mrmod._packed.cache_clear()


def test_a_setting_carries_its_vehicle_in_its_key():
    pm = uw.make_setting("light constant", "strong constant", 3)
    mr = uw.make_setting("light constant", "strong constant", 3, uav=Multirotor())
    hv = uw.make_setting("light constant", "strong constant", 3,
                         uav=Multirotor(start="drifting"))
    assert len({pm.key(), mr.key(), hv.key()}) == 3
    assert mr.simulate(uw.PAPER_EXAMPLE).shape == (6, 120, 3)


# --------------------------------------------------------------------------- #
# bad input: refused, naming the parameter (issue 33)
# --------------------------------------------------------------------------- #
@pytest.mark.parametrize("force, tilt, word", [
    ([np.nan, 0.0, 10.0], 90.0, "force"), ([0.0, 0.0, np.inf], 90.0, "force"),
    ([1.0, 2.0], 90.0, "force"), ([0.0, 0.0, 10.0], -10.0, "tilt_limit"),
    ([0.0, 0.0, 10.0], np.nan, "tilt_limit"), ([0.0, 0.0, 10.0], 0.0, "tilt_limit"),
    ([0.0, 0.0, 10.0], 120.0, "tilt_limit")])
def test_force_command_refuses_what_it_cannot_fly(force, tilt, word):
    with pytest.raises(ValueError, match=word):
        force_command(force, tilt_limit=tilt)


def test_the_multirotor_checks_its_public_helpers():
    mr = Multirotor()
    with pytest.raises(ValueError, match="start_position"):
        mr.initial_states([0.0, np.nan, 10.0], np.zeros((2, 3)))
    with pytest.raises(ValueError, match="winds0"):
        mr.initial_states([0.0, 0.0, 10.0], np.zeros((2, 2)))
    with pytest.raises(ValueError, match="dt"):
        mr.check_grid(np.nan)
    with pytest.raises(TypeError, match="action"):
        mr.segment_commands([[0.0, 0.0, 10.0]])
    with pytest.raises(TypeError, match="thrust"):
        mr.check_thrust(np.array([10.0]))
