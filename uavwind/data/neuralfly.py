"""The Neural-Fly wind-tunnel flights: a reader for their CSV format, and lap windows.

This module owns :func:`load_neuralfly` (one :class:`RealFlight` per file of a folder the
user names, or of ``$UAVWIND_NEURALFLY``), :data:`CONDITIONS` (the fan settings and their
wind speeds [m/s]), :data:`CHANNELS` (what Experiment 13 clusters: position, tracking error,
velocity, attitude, thrust set-point, aerodynamic force) and :func:`flight_laps` (one window
per reference lap, the first lap dropped, resampled to the paper's series length).

The data: O'Connell, Shi, Shi, Azizzadenesheli, Anandkumar, Yue and Chung, "Neural-Fly
enables rapid learning for agile flight in strong winds", Science Robotics 7(66), 2022,
doi:10.1126/scirobotics.abm6597; released at github.com/aerorobotics/neural-fly (folder
``data/experiment``) "for personal and educational use only" -- read from where the user
keeps them, never copied into this project, cited wherever a result from them is shown.

The format (one row per sample, 50 Hz): ``t`` [s]; ``p``, ``p_d`` position and its reference
[m]; ``v``, ``v_d`` [m/s]; ``q`` attitude quaternion; ``R`` body -> world rotation (3 x 3,
nested list); ``w`` body rates [rad/s]; ``T_sp`` normalised thrust set-point; ``q_sp``
attitude set-point; ``hover_throttle``; ``fa`` the authors' aerodynamic residual force [N];
``pwm`` the four motor commands. Vector cells are Python list literals (``"[1.0, 2.0]"``);
the first column is the row index. Files are ``<vehicle>_<trajectory>_<controller>_
<condition>.csv`` or ``.csv.xz``.
"""

from __future__ import annotations

import errno
import functools
import hashlib
import os
import re
import stat
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.checks import check_array, check_scalar

__all__ = ["RealFlight", "CONDITIONS", "CONDITION_LABELS", "condition_label", "CHANNELS",
           "COLUMNS", "ENV_VAR", "load_neuralfly", "neuralfly_folder", "flight_files",
           "files_digest", "read_flights", "flight_laps", "cut_laps", "channel_series",
           "tilt_degrees", "pitch_degrees", "split_noise", "NOISE_CUTOFF", "CITATION"]

#: The environment variable naming the folder of the flights.
ENV_VAR = "UAVWIND_NEURALFLY"
#: How the pages cite the data.
CITATION = ("O'Connell et al., Neural-Fly enables rapid learning for agile flight in strong "
            "winds, Science Robotics 7(66), 2022, doi:10.1126/scirobotics.abm6597")
#: Fan condition -> mean wind speed [m/s] at the vehicle (the data's README; ``70p20sint``
#: is 8.5 + 2.4 sin t m/s, its mean given here).
CONDITIONS: Mapping[str, float] = {"nowind": 0.0, "35wind": 4.2, "70wind": 8.5,
                                   "70p20sint": 8.5, "100wind": 12.1}
#: Fan condition -> how a page names it (the wind a reader knows, not the file's code).
CONDITION_LABELS: Mapping[str, str] = {"nowind": "still air", "35wind": "4.2 m/s",
                                       "70wind": "8.5 m/s", "70p20sint": "8.5 + 2.4 sin t m/s",
                                       "100wind": "12.1 m/s"}


def condition_label(condition: str) -> str:
    """How a page names the fan ``condition`` (:data:`CONDITION_LABELS`); a name it does not
    know passes through."""
    return CONDITION_LABELS.get(condition, condition)


#: Column -> width of its vector (``R`` is 3 x 3, read row-major).
COLUMNS: Mapping[str, int] = {"t": 1, "p": 3, "p_d": 3, "v": 3, "v_d": 3, "q": 4, "R": 9, "w": 3,
                              "T_sp": 1, "q_sp": 4, "hover_throttle": 1, "fa": 3, "pwm": 4}
_NAME = re.compile(r"^(?P<vehicle>[^_]+)_(?P<trajectory>[^_]+)_(?P<controller>.+)_"
                   r"(?P<condition>[^_]+)\.csv(?:\.xz)?$")


@dataclass(frozen=True, eq=False, kw_only=True)
class RealFlight:
    """One real flight: its labels and its columns as read-only arrays (n samples each).

    ``t`` (n,) [s]; ``p``, ``p_d`` (n, 3) [m]; ``v``, ``v_d`` (n, 3) [m/s]; ``q``, ``q_sp``
    (n, 4); ``R`` (n, 3, 3) body -> world; ``w`` (n, 3) [rad/s]; ``T_sp``, ``hover_throttle``
    (n,) normalised; ``fa`` (n, 3) [N]; ``pwm`` (n, 4).
    """

    controller: str
    condition: str
    wind_speed: float
    source: str
    vehicle: str = "custom"
    trajectory: str = "figure8"
    arrays: Mapping[str, np.ndarray] = field(repr=False)

    def __getattr__(self, name):
        arrays = self.__dict__.get("arrays")
        if arrays is not None and name in arrays:
            return arrays[name]
        raise AttributeError(name)

    @property
    def n_samples(self) -> int:
        return len(self.arrays["t"])

    @property
    def duration(self) -> float:
        """[s]"""
        t = self.arrays["t"]
        return float(t[-1] - t[0])


def neuralfly_folder(folder: os.PathLike | str | None = None) -> Path:
    """The folder of the flights: ``folder``, else ``$UAVWIND_NEURALFLY``; ``ValueError``
    saying how to get the data when neither names an existing folder."""
    if folder is None:
        folder = os.environ.get(ENV_VAR) or None
        if folder is None:
            raise ValueError(
                f"no folder of Neural-Fly flights: pass folder= or set ${ENV_VAR}. The flights "
                f"are the authors' (github.com/aerorobotics/neural-fly, data/experiment; for "
                f"personal and educational use, cite {CITATION})")
    if not isinstance(folder, (str, os.PathLike)):
        raise TypeError(f"folder must be a path, got {type(folder).__name__}")
    path = Path(folder).expanduser()
    if not path.is_dir():
        raise ValueError(f"folder must be an existing folder of Neural-Fly flights, got "
                         f"{str(path)!r}")
    return path


def flight_files(folder: os.PathLike | str | None = None, trajectory: str = "figure8",
                 ) -> list[Path]:
    """The files :func:`load_neuralfly` reads, in name order, without reading them: every
    file of ``trajectory`` in ``folder`` (else ``$UAVWIND_NEURALFLY``). A file of
    ``trajectory`` with an unknown condition, the same flight twice (plain and ``.xz``) or
    no flight at all is a ``ValueError`` naming the file."""
    path = neuralfly_folder(folder)
    if not isinstance(trajectory, str) or not trajectory:
        raise TypeError(f"trajectory must be a non-empty str, got {trajectory!r}")
    files, seen = [], {}
    for f in sorted(path.iterdir()):
        m = _NAME.match(f.name)
        if m is None or m["trajectory"] != trajectory:
            continue
        _check_readable(f)
        if m["condition"] not in CONDITIONS:
            raise ValueError(f"{f.name}: unknown wind condition {m['condition']!r} (known: "
                             f"{', '.join(CONDITIONS)})")
        key = (m["vehicle"], m["controller"], m["condition"])
        if key in seen:
            raise ValueError(f"{f.name}: the same flight as {seen[key]} (one file per vehicle, "
                             f"controller and condition)")
        seen[key] = f.name
        files.append(f)
    if not files:
        raise ValueError(f"no Neural-Fly flight of trajectory {trajectory!r} in {str(path)!r} "
                         f"(files named <vehicle>_{trajectory}_<controller>_<condition>.csv or "
                         f".csv.xz)")
    return files


def _check_readable(f: Path) -> None:
    """``ValueError`` naming ``f`` unless it is a regular file this process may read: a
    dangling symlink, a symlink loop, a folder or a file without read permission named like a
    flight is refused, never skipped in silence."""
    try:
        st = f.stat()
    except OSError as exc:
        kind = ("a symlink loop" if exc.errno == errno.ELOOP else
                "a dangling symlink" if f.is_symlink() else exc.strerror or type(exc).__name__)
        raise ValueError(f"{f.name}: named like a Neural-Fly flight but cannot be read "
                         f"({kind})") from None
    if not stat.S_ISREG(st.st_mode):
        raise ValueError(f"{f.name}: named like a Neural-Fly flight but is not a regular file")
    if not os.access(f, os.R_OK):
        raise ValueError(f"{f.name}: named like a Neural-Fly flight but cannot be read "
                         f"(permission denied)")


def files_digest(files: list[Path]) -> str:
    """SHA-256 of the files' names and bytes as stored (about 40 ms for the 25 flights,
    against 5 s to parse them): a key for what is computed from them."""
    h = hashlib.sha256()
    for f in files:
        h.update(Path(f).name.encode() + b"\0")
        try:
            with open(f, "rb") as fh:
                for block in iter(lambda: fh.read(1 << 20), b""):
                    h.update(block)
        except OSError as exc:
            raise ValueError(f"{Path(f).name}: cannot be read ({type(exc).__name__}: "
                             f"{exc.strerror or exc})") from None
        h.update(b"\0")
    return h.hexdigest()


def load_neuralfly(folder: os.PathLike | str | None = None, trajectory: str = "figure8",
                   ) -> list[RealFlight]:
    """Every flight of ``trajectory`` in ``folder`` (else ``$UAVWIND_NEURALFLY``), one
    :class:`RealFlight` per file, sorted by controller and wind speed.

    Files of other trajectories are left alone; a file of ``trajectory`` with an unknown
    condition, a missing or malformed column, ragged rows, a NaN, or times that do not
    increase is a ``ValueError`` naming the file and the column.

    Parameters
    ----------
    folder : path-like, optional
    trajectory : str
        The name's trajectory part (``"figure8"``: the lemniscate ``(1.25 sin t, 0,
        0.75 sin 2t)``).
    """
    return read_flights(flight_files(folder, trajectory))


def read_flights(files: list[Path]) -> list[RealFlight]:
    """One :class:`RealFlight` per file (as :func:`flight_files` lists them), sorted by
    controller and wind speed; a file not named as a flight of a known condition, or
    malformed, is a ``ValueError`` naming it (and the column)."""
    flights = []
    for f in map(Path, files):
        m = _NAME.match(f.name)
        if m is None or m["condition"] not in CONDITIONS:
            raise ValueError(f"{f.name}: not a Neural-Fly flight of a known condition (files "
                             f"named <vehicle>_<trajectory>_<controller>_<condition>.csv or "
                             f".csv.xz, conditions {', '.join(CONDITIONS)})")
        flights.append(RealFlight(controller=m["controller"], condition=m["condition"],
                                  wind_speed=CONDITIONS[m["condition"]], source=f.name,
                                  vehicle=m["vehicle"], trajectory=m["trajectory"],
                                  arrays=read_columns(f)))
    order = list(CONDITIONS)
    return sorted(flights, key=lambda fl: (fl.controller, fl.wind_speed, order.index(fl.condition)))


def read_columns(file: os.PathLike | str) -> dict[str, np.ndarray]:
    """The columns of one flight file as read-only float arrays (see the module text)."""
    name = Path(file).name
    try:
        df = pd.read_csv(file, dtype=str, keep_default_na=False)
    except Exception as exc:  # an unreadable file: say which
        raise ValueError(f"{name}: cannot be read as CSV ({type(exc).__name__}: {exc})") from exc
    missing = [c for c in COLUMNS if c not in df.columns]
    if missing:
        raise ValueError(f"{name}: missing column(s) {missing} (a Neural-Fly flight has "
                         f"{list(COLUMNS)})")
    if len(df) < 2:
        raise ValueError(f"{name}: {len(df)} rows; a flight needs at least 2")
    out = {}
    for col, width in COLUMNS.items():
        a = _vectors(df[col], name, col, width)
        out[col] = a[:, 0] if width == 1 else a.reshape(-1, 3, 3) if col == "R" else a
        out[col].setflags(write=False)
    if not np.all(out["hover_throttle"] > 0):
        i = int(np.argmin(out["hover_throttle"] > 0))
        raise ValueError(f"{name}: column 'hover_throttle', row {i}: {out['hover_throttle'][i]:g}; "
                         f"the throttle at hover must be positive (the thrust is T_sp over it)")
    if not np.all(np.diff(out["t"]) > 0):
        i = int(np.argmin(np.diff(out["t"]) > 0)) + 1
        raise ValueError(f"{name}: column 't' must increase, row {i} is {out['t'][i]:g} after "
                         f"{out['t'][i - 1]:g}")
    return out


#: What :func:`_vectors` strips from a cell before reading its numbers: the list brackets
#: and whitespace.
_STRIP = str.maketrans("", "", "[] \t\n\r\f\v")
#: What a cell may hold besides those: the characters of decimal numbers (and "nan", "inf",
#: refused later as not finite) and the separators; anything else is not a number.
_NUMBER_CHARS = str.maketrans("", "", "[] \t\n\r\f\v0123456789+-.eE,;naifNAIFty")


def _vectors(cells: pd.Series, file: str, col: str, width: int) -> np.ndarray:
    """(n, width) floats from a column of list literals (or plain numbers when width is 1):
    the column's cells joined and stripped in one pass (a regular expression per cell took
    half of a file's read)."""
    strings = cells.tolist()
    joined = ";".join(strings)
    odd = joined.translate(_NUMBER_CHARS)
    if odd:  # Python's float reads "0_5" as 5 and other digits than ASCII: refuse them
        i = next(i for i, t in enumerate(strings) if t.translate(_NUMBER_CHARS))
        raise ValueError(f"{file}: column {col!r}, row {i}: not numbers: {cells.iloc[i]!r}")
    text = [t.translate(_STRIP) for t in strings] if any(";" in t for t in strings) \
        else joined.translate(_STRIP).split(";")
    counts = np.fromiter((t.count(",") + 1 if t else 0 for t in text), np.int64, len(text))
    bad = np.flatnonzero(counts != width)
    if bad.size:
        i = int(bad[0])
        raise ValueError(f"{file}: column {col!r}, row {i}: {counts[i]} values, expected {width} "
                         f"(ragged or empty cell {cells.iloc[i]!r})")
    try:
        flat = np.array(",".join(text).split(","), dtype=float)
    except ValueError:
        for i, cell in enumerate(text):
            try:
                np.array(cell.split(","), dtype=float)
            except ValueError:
                raise ValueError(f"{file}: column {col!r}, row {i}: not numbers: "
                                 f"{cells.iloc[i]!r}") from None
        raise
    a = flat.reshape(-1, width)
    if not np.all(np.isfinite(a)):
        i = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
        raise ValueError(f"{file}: column {col!r}, row {i}: NaN or infinite value "
                         f"{cells.iloc[i]!r}")
    return a


# --------------------------------------------------------------------------- #
# channels and lap windows
# --------------------------------------------------------------------------- #
def tilt_degrees(R: np.ndarray) -> np.ndarray:
    """The angle between the body's z axis and up [deg], from rotations (..., 3, 3)."""
    return np.degrees(np.arccos(np.clip(np.asarray(R)[..., 2, 2], -1.0, 1.0)))


def pitch_degrees(R: np.ndarray) -> np.ndarray:
    """The signed lean of the body's z axis towards +x (about y) [deg], from rotations
    (..., 3, 3): positive when leaning into a wind that blows along -x."""
    R = np.asarray(R)
    return np.degrees(np.arctan2(R[..., 0, 2], R[..., 2, 2]))


#: The frequency [Hz] above which a channel's content is counted as measurement noise: the
#: figure-8 runs at 0.16 Hz (0.32 Hz in z), the controllers' and gusts' response lies below.
NOISE_CUTOFF = 2.0


def split_noise(series: np.ndarray, dt: float, cutoff: float = NOISE_CUTOFF
                ) -> tuple[np.ndarray, np.ndarray]:
    """``(slow, fast)``: a series (n, ...) sampled every ``dt`` [s] split at ``cutoff`` [Hz]
    by a zero-phase 4th-order Butterworth low-pass (``slow``) and the rest (``fast``,
    ``series - slow``): what the wind and the controller do, and measurement noise."""
    from scipy.signal import sosfiltfilt

    dt = check_scalar(dt, "dt", low=0.0, low_inclusive=False, high=10.0)
    cutoff = check_scalar(cutoff, "cutoff", low=0.0, low_inclusive=False, high=0.5 / dt,
                          high_inclusive=False)
    x = np.asarray(series, dtype=float)
    # a copy: scipy's sosfilt takes only a writable array
    slow = sosfiltfilt(_butter_sos(4, float(cutoff), float(dt)).copy(), x, axis=0)
    return slow, x - slow


@functools.lru_cache(maxsize=64)
def _butter_sos(order, cutoff, dt):
    """A Butterworth low-pass's second-order sections (read-only), designed once per
    ``(order, cutoff [Hz], dt [s])``: Experiment 13 splits thousands of series at a few
    rates, and designing the filter cost as much as running it."""
    from scipy.signal import butter

    sos = butter(order, cutoff, fs=1.0 / dt, output="sos")
    sos.flags.writeable = False
    return sos


#: Channel -> (what it is, its unit). Experiment 13 clusters each.
CHANNELS: Mapping[str, tuple[str, str]] = {
    "position": ("position p", "m"),
    "tracking_error": ("tracking error p - p_d", "m"),
    "velocity": ("velocity v", "m/s"),
    "attitude": ("body z axis in the world frame (tilt and its direction)", "1"),
    "thrust": ("thrust set-point over the hover throttle, T_sp / hover_throttle (1 in a "
               "hover whatever the battery)", "1"),
    "aero_force": ("aerodynamic residual force fa", "N"),
}


def channel_series(flight: RealFlight, channel: str) -> np.ndarray:
    """The (n, d) series of ``channel`` (:data:`CHANNELS`) of ``flight``."""
    a = flight.arrays
    if channel == "position":
        return a["p"]
    if channel == "tracking_error":
        return a["p"] - a["p_d"]
    if channel == "velocity":
        return a["v"]
    if channel == "attitude":
        return a["R"][:, :, 2]
    if channel == "thrust":  # the battery moves the hover throttle (0.45-0.51): divided out
        return (a["T_sp"] / a["hover_throttle"])[:, None]
    if channel == "aero_force":
        return a["fa"]
    raise ValueError(f"channel must be one of {list(CHANNELS)}, got {channel!r}")


def lap_starts(flight: RealFlight) -> np.ndarray:
    """Times [s] at which the reference starts a lap: ``p_d``'s x crosses the centre of its
    range upward (linear interpolation between samples); ``ValueError`` if it never does."""
    t, x = flight.arrays["t"], flight.arrays["p_d"][:, 0]
    c = 0.5 * (x.max() + x.min())
    d = x - c
    up = np.flatnonzero((d[:-1] < 0) & (d[1:] >= 0))
    if x.max() - x.min() < 1e-6 or up.size < 2:
        raise ValueError(f"{flight.source}: the reference p_d does not go round a lap (its x "
                         f"crosses the centre of its range upward {up.size} time(s); a lap "
                         f"needs two)")
    return t[up] + (t[up + 1] - t[up]) * (-d[up]) / (d[up + 1] - d[up])


def flight_laps(flight: RealFlight, channels=tuple(CHANNELS), n_samples: int = 120,
                drop_first: int = 1) -> dict[str, np.ndarray]:
    """One window per reference lap, the first ``drop_first`` laps dropped (the start-up
    transient), each resampled (linear) to ``n_samples`` times equally spaced over the lap.

    Returns ``{channel: (n_laps, n_samples, d)}`` plus ``"starts"`` (n_laps,) [s] and
    ``"tilt"`` (n_laps, n_samples) [deg]. ``ValueError`` if no lap is left.
    """
    n_samples = check_scalar(n_samples, "n_samples", low=4, high=100_000, integer=True)
    drop_first = check_scalar(drop_first, "drop_first", low=0, high=1000, integer=True)
    for ch in channels:
        if ch not in CHANNELS:
            raise ValueError(f"channels must be among {list(CHANNELS)}, got {ch!r}")
    times = _lap_times(flight, n_samples, drop_first)
    t = flight.arrays["t"]
    out = {ch: _resample(t, channel_series(flight, ch), times) for ch in channels}
    out["tilt"] = _resample(t, tilt_degrees(flight.arrays["R"])[:, None], times)[..., 0]
    out["starts"] = times[:, 0].copy()
    return out


def cut_laps(flight: RealFlight, series: np.ndarray, n_samples: int = 120,
             drop_first: int = 1) -> np.ndarray:
    """Any series (n, d) recorded at ``flight``'s times, cut into the laps
    :func:`flight_laps` cuts (the same windows, resampled the same way): (n_laps,
    n_samples, d). For a quantity that is no channel (a low-passed pitch, say)."""
    n_samples = check_scalar(n_samples, "n_samples", low=4, high=100_000, integer=True)
    drop_first = check_scalar(drop_first, "drop_first", low=0, high=1000, integer=True)
    t = flight.arrays["t"]
    series = check_array(series, "series", shape=(t.shape[0], None))
    return _resample(t, series, _lap_times(flight, n_samples, drop_first))


def _lap_times(flight, n_samples, drop_first):
    """(n_laps, n_samples) times [s] of the kept laps' windows (inputs checked)."""
    starts = lap_starts(flight)
    bounds = list(zip(starts[:-1], starts[1:]))[drop_first:]
    if not bounds:
        raise ValueError(f"{flight.source}: {len(starts) - 1} complete lap(s), none left after "
                         f"dropping drop_first={drop_first}")
    return np.stack([np.linspace(a, b, n_samples, endpoint=False) for a, b in bounds])


def _resample(t, y, times):
    """``y`` (n, d) at ``t``, linearly resampled at each row of ``times``: (laps, samples, d)."""
    return np.stack([np.stack([np.interp(tt, t, y[:, k]) for k in range(y.shape[1])], -1)
                     for tt in times])
