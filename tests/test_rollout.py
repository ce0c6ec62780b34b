"""Rollouts: flights continued segment by segment from their states, one command per row,
equal to the open-loop simulation bit for bit; the wind table equal to the wind models."""
import numpy as np
import pytest

import uavwind as uw
from uavwind.sim.cited_dryden import CitedDryden
from uavwind.sim.rollout import Rollout, WindTable, state_size
from uavwind.sim.setting import EnvironmentGroup, Setting
from uavwind.sim.wind import WindGroups, ConstantWind, ShearWind

GROUPS = {
    "constant": EnvironmentGroup("constant", ((0.5, 0.5, 0.0), (1.2, -0.3, 0.0)), "c"),
    "shear": EnvironmentGroup("shear", ((2.0, 1.0, 0.0), (3.0, 0.5, 0.0)), "s"),
    "mil": EnvironmentGroup("turbulence", (11.0, 13.0), "t"),
    "cited": EnvironmentGroup("turbulence", (11.0, 13.0), "tc", variant="cited",
                              cited=CitedDryden(turbulence_level=None, seeds=None)),
}
VEHICLES = {"point mass": uw.UAV(), "multirotor hover": uw.Multirotor(start="hover"),
            "multirotor drifting": uw.Multirotor(start="drifting")}


def _wind(a, b, seed=3):
    return Setting(GROUPS[a], GROUPS[b]).wind(seed)


@pytest.mark.parametrize("vehicle", sorted(VEHICLES))
@pytest.mark.parametrize("pair", [("constant", "shear"), ("shear", "mil"), ("constant", "cited")])
def test_chained_segments_equal_the_open_loop_simulation(vehicle, pair):
    uav = VEHICLES[vehicle]
    seq = uw.sample_paper(np.random.default_rng(7), n_changes=5, time_step=2.0)
    ref = uw.simulate(seq, _wind(*pair), uav=uav)
    ro = Rollout.for_flight(uav, _wind(*pair), 0.1, 12.0)
    env = np.arange(4)
    st = ro.start(env, [0.0, 0.0, 10.0])
    assert st.shape == (4, state_size(uav))
    parts = []
    for j in range(6):
        st, p = ro.advance(st, env, np.repeat(seq.vectors[j][None], 4, axis=0), 20 * j, 20)
        parts.append(p)
    assert np.array_equal(np.concatenate(parts, axis=1), ref)


def test_rows_hold_their_own_thrust_and_share_an_environment():
    uav = uw.UAV()
    wind = _wind("constant", "shear")
    ro = Rollout.for_flight(uav, wind, 0.1, 4.0)
    env = np.array([2, 2, 2])  # three rows in the first shear environment
    forces = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 40.0], [20.0, 0.0, 20.0]])
    _, pos = ro.advance(ro.start(env, [0, 0, 10.0]), env, forces, 0, 40)
    for i in range(3):
        seq = uw.ThrustSequence([0.0], [np.linalg.norm(forces[i]) or 0.0],
                                [forces[i] if forces[i].any() else [0, 0, 1]])
        one = uw.simulate(seq, ShearWind([GROUPS["shear"].values[0]]), duration=4.0)
        assert np.array_equal(pos[i], one[0])


def test_the_wind_table_is_the_wind_models_velocity():
    wind = WindGroups(_wind("constant", "shear"), _wind("mil", "cited", seed=9))
    times = np.arange(50) * 0.1
    table = WindTable(wind, times)
    rng = np.random.default_rng(0)
    env = np.arange(wind.n_env)
    for k in (0, 7, 49):
        pos = rng.normal(10.0, 5.0, (wind.n_env, 3))
        assert np.array_equal(table.velocity(k, env, pos), wind.velocity(times[k], pos))


def test_bad_input_is_refused():
    class MyShear(ShearWind):
        pass

    with pytest.raises(TypeError, match="MyShear"):
        WindTable(MyShear([[1.0, 0, 0]]), [0.0])
    with pytest.raises(TypeError, match="wind"):
        WindTable("wind", [0.0])
    ro = Rollout.for_flight(uw.UAV(), ConstantWind([[1.0, 0, 0]]), 0.1, 2.0)
    st = ro.start([0], [0, 0, 10.0])
    with pytest.raises(ValueError, match="outside the flight"):
        ro.advance(st, np.array([0]), np.zeros((1, 3)), 15, 10)
    with pytest.raises(ValueError, match="dt"):
        Rollout.for_flight(uw.Multirotor(), ConstantWind([[1.0, 0, 0]]), 0.015, 2.0)


def test_planning_fidelity_is_the_multirotor_s_substeps_only():
    ro = Rollout.for_flight(uw.Multirotor(), ConstantWind([[1.0, 0, 0]]), 0.1, 2.0)
    assert ro.with_substeps(1).uav.substeps == 1 and ro.uav.substeps == 4
    assert ro.with_substeps(1).table is ro.table
    pm = Rollout.for_flight(uw.UAV(), ConstantWind([[1.0, 0, 0]]), 0.1, 2.0)
    assert pm.with_substeps(1) is pm


# --------------------------------------------------------------------------- #
# rows checked before any kernel runs (issue 33)
# --------------------------------------------------------------------------- #
def _rows(uav):
    roll = Rollout.for_flight(uav, _wind("constant", "shear"), 0.1, 2.0)
    env = np.arange(4)
    return roll, roll.start(env, [0.0, 0.0, 10.0]), env, np.tile([0.0, 0.0, 20.0], (4, 1))


@pytest.mark.parametrize("vehicle", ["point mass", "multirotor hover"])
def test_advance_refuses_states_of_the_wrong_width(vehicle):
    roll, states, env, forces = _rows(VEHICLES[vehicle])
    other = 20 if states.shape[1] == 6 else 17
    with pytest.raises(ValueError, match=r"states must have shape \(n_rows, "):
        roll.advance(np.zeros((4, other)), env, forces, 0, 2)
    with pytest.raises(ValueError, match="states"):
        roll.advance(states[:, :, None], env, forces, 0, 2)


@pytest.mark.parametrize("vehicle", ["point mass", "multirotor hover"])
@pytest.mark.parametrize("what, word", [
    ("nan state", "states"), ("nan force", "forces"), ("inf force", "forces"),
    ("forces of 2 columns", "forces"), ("forces of 3 rows", "forces"),
    ("env out of range", "env"), ("negative env", "env"), ("env of 3 rows", "env"),
    ("float env", "env"), ("sample0 = -1", "sample0"), ("n = 1.5", "n")])
def test_advance_names_what_is_wrong(vehicle, what, word):
    roll, states, env, forces = _rows(VEHICLES[vehicle])
    s0, n = 0, 2
    if what == "nan state":
        states = states.copy()
        states[1, 3] = np.nan
    elif what == "nan force":
        forces = forces.copy()
        forces[0, 0] = np.nan
    elif what == "inf force":
        forces = forces.copy()
        forces[2, 2] = np.inf
    elif what == "forces of 2 columns":
        forces = forces[:, :2]
    elif what == "forces of 3 rows":
        forces = forces[:3]
    elif what == "env out of range":
        env = np.array([0, 1, 2, 4])
    elif what == "negative env":
        env = np.array([0, 1, 2, -1])
    elif what == "env of 3 rows":
        env = env[:3]
    elif what == "float env":
        env = env.astype(float)
    elif what == "sample0 = -1":
        s0 = -1
    else:
        n = 1.5
    with pytest.raises((ValueError, TypeError), match=word):
        roll.advance(states, env, forces, s0, n)


def test_advance_refuses_a_zero_quaternion_and_more_thrust_than_the_rotors_make():
    mr = uw.Multirotor(mass=0.1)  # 10 N at full rotor speed
    roll, states, env, _ = _rows(mr)
    states = states.copy()
    states[0, 6:10] = 0.0
    with pytest.raises(ValueError, match="quaternion"):
        roll.advance(states, env, np.zeros((4, 3)), 0, 1)
    roll, states, env, _ = _rows(mr)
    with pytest.raises(ValueError, match=r"forces must be <= 10\.0 N"):
        roll.advance(states, env, np.tile([0.0, 0.0, 40.0], (4, 1)), 0, 1)


def test_start_and_the_wind_table_refuse_an_environment_out_of_range():
    roll, _, _, _ = _rows(uw.UAV())
    with pytest.raises(ValueError, match=r"env must hold environment indices in \[0, 3\]"):
        roll.start([0, 7], [0.0, 0.0, 10.0])
    with pytest.raises(ValueError, match="env"):
        roll.table.velocity(0, np.array([5]), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="positions"):
        roll.table.velocity(0, np.array([1]), np.zeros((2, 3)))
