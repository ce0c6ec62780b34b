"""The Neural-Fly reader: its format on small files the tests write, every malformed input
refused naming the file and the column, lap windows, and the shared real flights when they
are on this machine (skipped, with the reason, when not)."""
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from uavwind.data import neuralfly as nf
from uavwind.data import CHANNELS, flight_laps, load_neuralfly

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "neuralfly"


def _cell(v):
    return str([float(x) for x in np.ravel(v)]) if np.ndim(v) == 1 else str(np.asarray(v).tolist())


def write_flight(folder, controller="ctl", condition="35wind", laps=4, rate=50.0, force=-3.0,
                 tilt=0.1, suffix=".csv", seed=0, edit=None):
    """A figure-8 flight in Neural-Fly's format: the reference about (0.25, 0, 2.15), the
    position on it plus small noise, a body tilted by ``tilt`` rad about y, ``fa`` = (force,
    0, 0) plus noise. ``edit(df)`` may spoil the table before it is written."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, laps * 2 * np.pi + 0.5, 1 / rate)
    n = len(t)
    c = np.array([0.25, 0.0, 2.15])
    p_d = c + np.stack([1.25 * np.sin(t), 0 * t, 0.75 * np.sin(2 * t)], -1)
    p = p_d + 0.01 * rng.normal(size=(n, 3))
    R = np.array([[np.cos(tilt), 0, np.sin(tilt)], [0, 1, 0], [-np.sin(tilt), 0, np.cos(tilt)]])
    cols = {"t": t, "p": p, "p_d": p_d, "v": np.gradient(p, t, axis=0),
            "v_d": np.gradient(p_d, t, axis=0), "q": np.tile([0, np.sin(tilt / 2), 0, np.cos(tilt / 2)], (n, 1)),
            "R": np.tile(R, (n, 1, 1)), "w": 0.01 * rng.normal(size=(n, 3)),
            "T_sp": 0.5 + 0.01 * rng.normal(size=n), "q_sp": np.tile([0, 0, 0, 1.0], (n, 1)),
            "hover_throttle": np.full(n, 0.48),
            "fa": np.array([force, 0, 0]) + 0.2 * rng.normal(size=(n, 3)),
            "pwm": np.full((n, 4), 1200.0)}
    df = pd.DataFrame({k: (v if k == "t" else [(_cell(x) if k != "T_sp" and k != "hover_throttle"
                                                  else str([float(x)])) for x in v])
                       for k, v in cols.items()})
    if edit is not None:
        edit(df)
    path = Path(folder) / f"custom_figure8_{controller}_{condition}{suffix}"
    df.to_csv(path, compression="xz" if suffix.endswith(".xz") else None)
    return path


def test_reads_plain_and_xz_files_into_labelled_read_only_flights(tmp_path):
    write_flight(tmp_path, "B", "nowind", suffix=".csv.xz")
    write_flight(tmp_path, "A", "100wind")
    write_flight(tmp_path, "A", "nowind")
    (tmp_path / "custom_circle_A_nowind.csv").write_text("other trajectories are left alone")
    (tmp_path / "notes.txt").write_text("not a flight")
    fl = load_neuralfly(tmp_path)
    assert [(f.controller, f.condition) for f in fl] == [("A", "nowind"), ("A", "100wind"),
                                                         ("B", "nowind")]
    f = fl[1]
    assert f.wind_speed == 12.1 and f.source == "custom_figure8_A_100wind.csv"
    assert f.p.shape == (f.n_samples, 3) and f.R.shape == (f.n_samples, 3, 3)
    assert f.T_sp.shape == (f.n_samples,) and f.pwm.shape == (f.n_samples, 4)
    with pytest.raises(ValueError):
        f.p[0, 0] = 1.0
    np.testing.assert_allclose(fl[2].fa[:, 0].mean(), -3.0, atol=0.05)


def test_the_folder_comes_from_the_argument_else_the_environment(tmp_path, monkeypatch):
    write_flight(tmp_path)
    monkeypatch.setenv(nf.ENV_VAR, str(tmp_path))
    assert len(load_neuralfly()) == 1
    monkeypatch.delenv(nf.ENV_VAR)
    with pytest.raises(ValueError, match="aerorobotics/neural-fly"):
        load_neuralfly()
    with pytest.raises(ValueError, match="existing folder"):
        load_neuralfly(tmp_path / "nowhere")
    with pytest.raises(TypeError, match="folder"):
        load_neuralfly(3)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="no Neural-Fly flight"):
        load_neuralfly(empty)


def _drop(col):
    return lambda df: df.__delitem__(col)


def _set(col, row, value):
    def edit(df):
        df.loc[row, col] = value
    return edit


@pytest.mark.parametrize("edit, match", [
    (_drop("fa"), r"missing column\(s\) \['fa'\]"),
    (_set("p", 5, "[1.0, 2.0]"), r"column 'p', row 5: 2 values, expected 3"),
    (_set("R", 7, "[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]"), r"column 'R', row 7: 6 values"),
    (_set("v", 3, "[nan, 0.0, 0.0]"), r"column 'v', row 3: NaN"),
    (_set("w", 4, "[0.1, abc, 0.2]"), r"column 'w', row 4: not numbers"),
    (_set("T_sp", 9, ""), r"column 'T_sp', row 9: 0 values"),
    (_set("t", 10, 0.0), r"column 't' must increase, row 10"),
    (_set("hover_throttle", 6, "[0.0]"), r"column 'hover_throttle', row 6: 0; .* positive"),
    (_set("hover_throttle", 2, "[-0.4]"), r"column 'hover_throttle', row 2: -0.4"),
    (_set("T_sp", 8, "[0_5]"), r"column 'T_sp', row 8: not numbers: '\[0_5\]'"),
    (_set("fa", 3, "[1.0, \u0661, 0.0]"), r"column 'fa', row 3: not numbers"),
])
def test_a_malformed_file_is_refused_naming_the_file_and_the_column(tmp_path, edit, match):
    write_flight(tmp_path, edit=edit)
    with pytest.raises(ValueError, match=match) as err:
        load_neuralfly(tmp_path)
    assert "custom_figure8_ctl_35wind.csv" in str(err.value)


@pytest.mark.parametrize("make, match", [
    (lambda d: (d / "custom_figure8_ctl_nowind.csv").symlink_to(d / "gone.csv"),
     "custom_figure8_ctl_nowind.csv: .*cannot be read \\(a dangling symlink\\)"),
    (lambda d: ((d / "custom_figure8_ctl_nowind.csv").symlink_to(d / "loop.csv"),
                (d / "loop.csv").symlink_to(d / "custom_figure8_ctl_nowind.csv")),
     "custom_figure8_ctl_nowind.csv: .*cannot be read \\(a symlink loop\\)"),
    (lambda d: (d / "custom_figure8_ctl_nowind.csv").mkdir(),
     "custom_figure8_ctl_nowind.csv: .*not a regular file"),
])
def test_a_file_named_like_a_flight_that_cannot_be_read_is_refused(tmp_path, make, match):
    write_flight(tmp_path, condition="35wind")
    make(tmp_path)
    with pytest.raises(ValueError, match=match):
        load_neuralfly(tmp_path)


def test_a_flight_without_read_permission_is_refused_naming_it(tmp_path, monkeypatch):
    """Mode 000 (root reads it anyway: the permission is what ``os.access`` says)."""
    path = write_flight(tmp_path, condition="35wind")
    path.chmod(0)
    real = os.access
    monkeypatch.setattr(nf.os, "access", lambda p, mode: False if Path(p) == path
                        else real(p, mode))
    with pytest.raises(ValueError, match="custom_figure8_ctl_35wind.csv: .*permission denied"):
        load_neuralfly(tmp_path)
    with pytest.raises(ValueError, match="gone.csv: cannot be read"):
        nf.files_digest([tmp_path / "gone.csv"])


def test_unknown_conditions_and_duplicates_are_refused(tmp_path):
    write_flight(tmp_path, condition="50wind")
    with pytest.raises(ValueError, match="custom_figure8_ctl_50wind.csv: unknown wind condition"):
        load_neuralfly(tmp_path)
    (tmp_path / "custom_figure8_ctl_50wind.csv").unlink()
    write_flight(tmp_path, condition="nowind")
    write_flight(tmp_path, condition="nowind", suffix=".csv.xz")
    with pytest.raises(ValueError, match="the same flight as"):
        load_neuralfly(tmp_path)
    # read_flights, given files by hand, refuses a name that is not a flight's
    from uavwind.data.neuralfly import read_flights
    plain = tmp_path / "custom_figure8_ctl_nowind.csv"
    (tmp_path / "notes.csv").write_bytes(plain.read_bytes())
    with pytest.raises(ValueError, match="notes.csv: not a Neural-Fly flight"):
        read_flights([plain, tmp_path / "notes.csv"])
    assert read_flights([plain])[0].condition == "nowind"


def test_laps_are_whole_reference_laps_resampled_the_first_dropped(tmp_path):
    write_flight(tmp_path, laps=5, tilt=0.2)
    f = load_neuralfly(tmp_path)[0]
    starts = nf.lap_starts(f)
    np.testing.assert_allclose(np.diff(starts), 2 * np.pi, atol=1e-3)
    w = flight_laps(f, n_samples=120)
    assert w["position"].shape == (len(starts) - 2, 120, 3)  # laps between crossings, minus 1
    assert set(CHANNELS) <= set(w)
    np.testing.assert_allclose(w["starts"], starts[1:-1])
    # a lap starts at the reference's centre, heading +x: the position window starts there
    np.testing.assert_allclose(w["position"][:, 0], [[0.25, 0.0, 2.15]] * len(w["starts"]),
                               atol=0.05)
    np.testing.assert_allclose(w["tilt"], np.degrees(0.2), atol=1e-9)
    np.testing.assert_allclose(w["tracking_error"].std(), 0.01, rtol=0.2)
    assert w["thrust"].shape[-1] == 1
    with pytest.raises(ValueError, match="none left after dropping drop_first=10"):
        flight_laps(f, drop_first=10)
    with pytest.raises(ValueError, match="channels must be among"):
        flight_laps(f, channels=("altitude",))
    with pytest.raises(ValueError, match="n_samples"):
        flight_laps(f, n_samples=1)


def test_a_flight_without_laps_is_refused(tmp_path):
    write_flight(tmp_path, edit=lambda df: df.__setitem__("p_d", "[0.25, 0.0, 2.15]"))
    with pytest.raises(ValueError, match="does not go round a lap"):
        flight_laps(load_neuralfly(tmp_path)[0])


@pytest.mark.skipif(not SHARED.is_dir() and not os.environ.get(nf.ENV_VAR),
                    reason="Neural-Fly's flights are not on this machine (set UAVWIND_NEURALFLY)")
@pytest.mark.slow
def test_the_real_flights_read_as_the_data_readme_describes():
    fl = load_neuralfly(os.environ.get(nf.ENV_VAR) or SHARED)
    assert len(fl) == 25
    assert {f.controller for f in fl} == {"baseline", "indi", "L1", "NF-C", "NF-T"}
    assert {f.condition for f in fl} == set(nf.CONDITIONS)
    for f in fl:
        assert 49 < f.duration < 51
        np.testing.assert_allclose(np.median(np.diff(f.t)), 0.02, rtol=0.01)  # 50 Hz
        w = flight_laps(f, ("position",))
        assert len(w["starts"]) == 5
        np.testing.assert_allclose(np.diff(w["starts"]), 2 * np.pi, atol=0.02)
    tilt = {c: np.mean([flight_laps(f, ())["tilt"].mean() for f in fl if f.condition == c])
            for c in ("nowind", "35wind", "70wind", "100wind")}
    assert tilt["nowind"] < tilt["35wind"] < tilt["70wind"] < tilt["100wind"]


def test_every_condition_has_a_readers_name():
    """A page names a fan setting by its wind, not the file's code: every condition has a
    label, each different, each saying its speed; an unknown name passes through."""
    from uavwind.data.neuralfly import CONDITION_LABELS, CONDITIONS, condition_label

    assert set(CONDITION_LABELS) == set(CONDITIONS)
    assert len(set(CONDITION_LABELS.values())) == len(CONDITIONS)
    for c, speed in CONDITIONS.items():
        assert condition_label(c) == ("still air" if speed == 0 else CONDITION_LABELS[c])
        assert speed == 0 or f"{speed:g} " in condition_label(c)
    assert condition_label("bogus") == "bogus"
