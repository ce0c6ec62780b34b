"""The multirotor's packed layouts (``uavwind.sim._slots``): every slot named once, the blocks
tiling each layout exactly, the state columns RotorPy's own, ``_packed`` putting each of the
vehicle's numbers at its named slot, the kernels compiled with the layout they are given,
and no bare number indexing the layouts again."""
import re
import types
from pathlib import Path

import numpy as np
import pytest

from uavwind.sim import _rotor_kernels as rk
from uavwind.sim import _rotor_layout, _slots
from uavwind.sim._rotor_layout import _packed
from uavwind.sim.rotor_params import (GRAVITY, SE3_KD_POS, SE3_KP_POS, PositionControl,
                                      rotorpy_params)

NAMES = [n for n in vars(_slots) if n.isupper() and n != "LAYOUT"]
STATE = {n: getattr(_slots, n) for n in NAMES if n.startswith("S_")}
FLAT = {n: getattr(_slots, n) for n in NAMES if n.startswith("FLAT_")}
CMD = {n: getattr(_slots, n) for n in NAMES if n.startswith("CMD_")}
PARAMS = {n: getattr(_slots, n) for n in NAMES
          if not n.startswith(("S_", "N_", "FLAT_", "CMD_"))}


def _indices(slot):
    return list(range(slot.start, slot.stop)) if isinstance(slot, slice) else [slot]


def _tiles(layout, length):
    """Every index of ``range(length)`` in exactly one slot or block of ``layout``."""
    seen = [i for slot in layout.values() for i in _indices(slot)]
    assert sorted(seen) == list(range(length)), sorted(seen)


def test_every_name_is_an_int_or_a_plain_slice():
    for name in NAMES:
        v = getattr(_slots, name)
        assert isinstance(v, int) or (isinstance(v, slice) and v.step is None
                                      and 0 <= v.start < v.stop), name


def test_the_parameter_slots_tile_the_vector():
    assert len(PARAMS) == 30
    _tiles(PARAMS, _slots.N_PARAMS)


def test_the_state_columns_tile_the_state():
    _tiles({n: s for n, s in STATE.items() if n != "S_INTEGRAL"}, _slots.N_STATE)
    _tiles(STATE, _slots.N_STATE_PI)


def test_the_flat_output_and_se3_output_rows_are_tiled():
    _tiles({n: s for n, s in FLAT.items() if n != "FLAT_ERR"}, _slots.N_FLAT)
    _tiles(FLAT, _slots.N_FLAT_ERR)  # mode 4's row: the errors after the flat output
    _tiles(CMD, _slots.N_CMD)


def test_the_blocks_have_their_shapes():
    length = {n: s.stop - s.start for n, s in {**PARAMS, **STATE, **FLAT, **CMD}.items()
              if isinstance(s, slice)}
    assert length == {"INERTIA": 9, "INERTIA_INV": 9, "C_D": 3, "ROTOR_POS": 12, "ROTOR_DIR": 4,
                      "TM_TO_F": 16, "KP_POS": 3, "KD_POS": 3, "KI_POS": 3, "S_POS": 3, "S_VEL": 3,
                      "S_QUAT": 4, "S_RATES": 3, "S_WIND": 3, "S_ROTORS": 4, "S_INTEGRAL": 3,
                      "FLAT_POS": 3, "FLAT_VEL": 3, "FLAT_ACC": 3, "FLAT_ERR": 6, "CMD_MOMENT": 3, "CMD_Q": 4,
                      "CMD_ACC": 3, "CMD_W": 3}


def test_layout_lists_every_number():
    assert _slots.LAYOUT == tuple(x for n in NAMES for x in
                                  ((getattr(_slots, n).start, getattr(_slots, n).stop)
                                   if isinstance(getattr(_slots, n), slice)
                                   else (getattr(_slots, n),)))


def test_the_kernels_were_compiled_with_this_layout():
    assert rk.compiled_layout() == _slots.LAYOUT


def _fake_kernels(tmp_path, layout, name="uavwind.sim._rotor_kernels"):
    """A stand-in for the kernels' module: its compiled_layout reports ``layout`` and
    names ``tmp_path`` as its numba cache folder."""
    def compiled_layout():
        return layout
    compiled_layout._cache = types.SimpleNamespace(_cache_path=str(tmp_path))
    return types.SimpleNamespace(__name__=name, compiled_layout=compiled_layout)


def test_kernels_compiled_under_another_layout_are_compiled_again(tmp_path):
    """numba's cache does not see _slots.py: a stale kernel is never flown; its cache files
    are deleted (with a warning naming them) and the module imported again."""
    stale = [tmp_path / "_rotor_kernels.step-41.py311.nbi",
             tmp_path / "_rotor_kernels.step-41.py311.1.nbc"]
    other = tmp_path / "_dynamics_kernels.step-9.py311.nbi"
    for f in (*stale, other):
        f.write_bytes(b"x")
    old = _fake_kernels(tmp_path, _slots.LAYOUT[:-1] + (99,))
    new = _fake_kernels(tmp_path, _slots.LAYOUT)
    with pytest.warns(RuntimeWarning, match="2 stale file"):
        got = _rotor_layout._recompiled(old, reload=lambda m: new)
    assert got is new and not any(f.exists() for f in stale) and other.exists()
    with pytest.warns(RuntimeWarning), pytest.raises(RuntimeError, match="still reports"):
        _rotor_layout._recompiled(old, reload=lambda m: old)


def test_a_stale_layout_reaches_the_recompiling_path(monkeypatch):
    """_kernels() compares the compiled layout with _slots' and hands a mismatch over."""
    monkeypatch.setattr(_rotor_layout, "LAYOUT", _slots.LAYOUT[:-1] + (99,))
    monkeypatch.setattr(_rotor_layout, "_recompiled", lambda m: ("recompiled", m))
    _rotor_layout._kernels.cache_clear()
    try:
        assert _rotor_layout._kernels() == ("recompiled", rk)
    finally:
        _rotor_layout._kernels.cache_clear()


def test_the_state_columns_are_rotorpys_own():
    multirotor = pytest.importorskip("rotorpy.vehicles.multirotor")
    state = {"x": [1.0, 2, 3], "v": [4.0, 5, 6], "q": [7.0, 8, 9, 10], "w": [11.0, 12, 13],
             "wind": [14.0, 15, 16], "rotor_speeds": [17.0, 18, 19, 20]}
    s = multirotor.Multirotor._pack_state(state)
    assert s.shape == (_slots.N_STATE,)
    for key, name in (("x", "S_POS"), ("v", "S_VEL"), ("q", "S_QUAT"), ("w", "S_RATES"),
                      ("wind", "S_WIND"), ("rotor_speeds", "S_ROTORS")):
        assert s[STATE[name]].tolist() == state[key], name


@pytest.mark.parametrize("preset", ["rotorpy", "paper", "neuralfly"])
def test_packed_puts_the_vehicles_numbers_at_their_slots(preset):
    pytest.importorskip("rotorpy")
    control = PositionControl(ki=(1.0, 2.0, 3.0), max_tilt=30.0, min_thrust=0.1,
                              max_thrust=0.9, max_integral_acceleration=5.0)
    mass = 2.3
    P = _packed(preset, mass, 1.0, 1.0, control)
    qp = rotorpy_params(preset, mass)
    s = _slots
    assert P.shape == (s.N_PARAMS,) and not P.flags.writeable
    assert P[s.MASS] == qp["mass"] == mass and P[s.G] == GRAVITY == 9.81
    inertia = np.array([[qp["Ixx"], qp["Ixy"], qp["Ixz"]], [qp["Ixy"], qp["Iyy"], qp["Iyz"]],
                        [qp["Ixz"], qp["Iyz"], qp["Izz"]]])
    assert np.array_equal(P[s.INERTIA].reshape(3, 3), inertia)
    assert np.allclose(P[s.INERTIA_INV].reshape(3, 3) @ inertia, np.eye(3), atol=1e-12)
    assert P[s.C_D].tolist() == [qp.get(k, 0.0) for k in ("c_Dx", "c_Dy", "c_Dz")]
    for slot, key in ((s.K_ETA, "k_eta"), (s.K_M, "k_m"), (s.K_D, "k_d"), (s.K_Z, "k_z"),
                      (s.K_H, "k_h"), (s.K_FLAP, "k_flap"), (s.TAU_M, "tau_m"),
                      (s.SPEED_MIN, "rotor_speed_min"), (s.SPEED_MAX, "rotor_speed_max")):
        assert P[slot] == qp.get(key, 0.0), key
    assert np.array_equal(P[s.ROTOR_POS].reshape(4, 3), np.vstack(list(qp["rotor_pos"].values())))
    assert P[s.ROTOR_DIR].tolist() == list(qp["rotor_directions"])
    # row k of TM_TO_F gives rotor k's force: the four forces of one thrust T sum to T, and
    # a yaw moment's forces weighted by k_m / k_eta and the directions sum to it
    A = P[s.TM_TO_F].reshape(4, 4)
    assert np.allclose(A.sum(axis=0), [1.0, 0.0, 0.0, 0.0], atol=1e-9)
    yaw = qp["k_m"] / qp["k_eta"] * P[s.ROTOR_DIR] @ A
    assert np.allclose(yaw, [0.0, 0.0, 0.0, 1.0], atol=1e-9)
    assert P[s.K_W] == qp.get("k_w", 1.0) and P[s.AERO] == 1.0
    assert (P[s.KP_ATT], P[s.KD_ATT]) == (qp.get("kp_att", 3000.0), qp.get("kd_att", 360.0))
    assert (P[s.SE3_KP_ATT], P[s.SE3_KD_ATT]) == (qp.get("kp_att", 310.0), qp.get("kd_att", 57.0))
    assert tuple(P[s.KP_POS]) == SE3_KP_POS and tuple(P[s.KD_POS]) == SE3_KD_POS
    full = 4 * qp["k_eta"] * qp["rotor_speed_max"] ** 2
    assert P[s.KI_POS].tolist() == [1.0, 2.0, 3.0]
    assert P[s.TAN_TILT] == pytest.approx(np.tan(np.radians(30.0)), rel=1e-15)
    assert (P[s.THRUST_LOW], P[s.THRUST_HIGH]) == (0.1 * full, 0.9 * full)
    assert P[s.INTEGRAL_ACC] == 5.0


def test_without_position_control_its_slots_stay_zero():
    pytest.importorskip("rotorpy")
    P = _packed("rotorpy", 2.0)
    s = _slots
    assert not P[s.KI_POS].any() and P[[s.TAN_TILT, s.THRUST_LOW, s.THRUST_HIGH,
                                        s.INTEGRAL_ACC]].tolist() == [0.0] * 4


SIM = Path(__file__).resolve().parents[1] / "uavwind" / "sim"
#: A bare index into the kernels' parameter vector P, a state array S, a state row s, the
#: rows of its derivative (out, tmp, k1..k4), a flat-output row f or SE3's outputs aux: a
#: subscript, or a part of one after a comma or a colon, that starts with a number. Numbers
#: remain only as offsets within a named block (``S_VEL.start + i``) and as components of a
#: named block's local view (``w = s[S_RATES]``, ``w[0]``; ``A = P[TM_TO_F]``,
#: ``A[4 * k + 1]``), which this does not look into.
BARE_IN_KERNELS = re.compile(r"\b(?:P|S|s|out|tmp|k[1-4]|f|aux)\[(?:[^\]]*[,:])?\s*-?\d")
#: The same for the Python code that reads the layouts (``S[0, ...]``, a row, is fine there;
#: F is the flat-output rows of a reference flight).
BARE_IN_PYTHON = re.compile(r"\b(?:P|packed)\[\s*\d|\b(?:S|s|F)\[[^\]]*[,:]\s*\d")


@pytest.mark.parametrize("text, bare", [
    ("P[23]", True), ("P[32 + 3 * k]", True), ("S[:, 13:16]", True), ("s[6:10]", True),
    ("out[16 + k]", True), ("k1[3]", True), ("s[S_QUAT.start:10]", True), ("S[i, 2]", True),
    ("f[9]", True), ("aux[:, 1:4]", True), ("aux[i]", False), ("f[FLAT_YAW]", False),
    ("P[K_ETA]", False), ("s[S_VEL.start + i]", False), ("rotor_pos[3 * k + 1]", False),
    ("P[TM_TO_F]", False), ("out[i]", False), ("Rs[0]", False), ("tmp[j]", False)])
def test_the_bare_index_pattern(text, bare):
    assert bool(BARE_IN_KERNELS.search(text)) == bare


def test_no_bare_index_into_the_layouts_in_the_kernels():
    source = (SIM / "_rotor_kernels.py").read_text()
    assert source.count("P[") > 20  # the pattern has something to look at
    bad = [f"{i}: {line.strip()}" for i, line in enumerate(source.splitlines(), 1)
           if BARE_IN_KERNELS.search(line)]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("module", ["_rotor_layout.py", "multirotor.py"])
def test_no_bare_index_into_the_layouts_in_their_python_readers(module):
    lines = (SIM / module).read_text().splitlines()
    bad = [f"{i}: {line.strip()}" for i, line in enumerate(lines, 1)
           if BARE_IN_PYTHON.search(line)]
    assert not bad, "\n".join(bad)
