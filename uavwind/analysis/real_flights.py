"""Experiment 13, real flights: does causal curiosity's clustering tell the winds apart on
Neural-Fly's wind-tunnel flights, and through which channel?

This module owns :class:`RealFlightStudy` (what is clustered and how), :func:`real_flight_rows`
(every score of the experiment, cached in the result folder under a digest of the flights'
bytes and the study's parameters, verified on every read) and the summaries the page shows:
:func:`pair_table`, :func:`channel_table` and :func:`flight_table`.

The design (the page says it in prose):

* *Windows.* One window per reference lap of the figure-8 (6.28 s), the first lap dropped
  (the start-up ramp), resampled to :attr:`RealFlightStudy.n_samples` samples
  (:func:`uavwind.data.flight_laps`; 60, half the paper's series length: see there).
  Each channel is divided by its standard deviation over every window of every flight, so
  soft-DTW's ``gamma = 0.5`` means the same in every channel (the paper's positions, in
  metres, have a standard deviation of the same order).
* *Per controller.* For every pair of wind conditions, every channel and every controller,
  the laps of the two flights are clustered with the project's soft-DTW k-means and scored
  with the DTW silhouette (:func:`uavwind.score_loop`, the paper's rule: 0 unless the
  clusters are the two flights).
* *Pooled.* The same with every controller's laps together (one clustering per pair and
  channel): do the winds separate across controllers?
* *Leave one controller out.* Each lap of the held-out controller is given the condition of
  its nearest lap (DTW) among the other controllers' laps of the pair; the accuracy is the
  share right.
* *Replicates.* Each (controller, condition) is ONE flight, so its laps are not independent:
  the controllers are the replicates, and every CI is a Student t interval over controllers
  (a percentile bootstrap over five values undercovers).
* *Negative control.* The same clustering on two controllers' flights at the *same* wind
  (each controller against the next): what a channel scores there is flight identity. A
  channel separates the winds only where its score on different winds beats its control,
  paired by controller, with a CI (:func:`controlled_table`).
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass
from itertools import combinations

import numpy as np
import pandas as pd

from .._version import __version__
from ..core.checks import Range, check_fields, check_instance
from ..core.parallel import check_jobs
from ..core.stats import MIN_DECIDE, decide, t_ci
from ..data.neuralfly import (CHANNELS, CONDITIONS, RealFlight, channel_series, cut_laps,
                              files_digest, flight_files, flight_laps, lap_starts,
                              pitch_degrees, read_flights, split_noise)
from ..method.clustering import ClusteringParams, score_loop, softdtw_engine
from .memo import memo
from .wind_estimates import estimation_rows

__all__ = ["RealFlightStudy", "STUDIES", "REAL_VERSION", "SPREADS", "real_flight_rows",
           "compute_rows", "pair_table", "channel_table", "controlled_table", "flight_table",
           "flights_digest", "decided_orders", "NOISE_CHANNELS", "noise_columns",
           "flight_summaries"]

#: Bump when a change alters the rows (part of the cache digest), including a change to how
#: :func:`uavwind.data.neuralfly.read_columns` parses a file: rows read from a folder are
#: kept under the files' bytes, not the parsed arrays. 2: thrust over the hover throttle,
#: the same-wind controls, the flight rows' lean, vertical force, spread and noise.
#: 5: the flight rows' hover throttle (the battery), what the twin's draws are fitted on.
#: 6: the wind estimates read each flight's own offset (WindEstimator's tilt, the default),
#: scored beside the plain model (the variant "no own offset").
#: 7: the ekf's std raised to what its innovations show (WindEstimator's innovation_window).
REAL_VERSION = "7"


@dataclass(frozen=True, kw_only=True)
class RealFlightStudy:
    """What Experiment 13 clusters on the real flights.

    Attributes
    ----------
    n_samples : int
        Samples per lap window: 60 (9.5 per second of the 6.28 s lap). The paper's simulated
        series have 120; the real windows take half as many, which quarters every soft-DTW
        matrix and so most of the experiment's cost (measured when this was chosen, one
        process: 34 against 116 CPU-s for every pair, channel and control of the paper
        profile). What the page reads barely moves: every channel keeps its controlled
        verdict and no order of two channels is reversed, but one order the real flights
        decide at 120 samples (thrust above velocity) is left undecided at 60. The
        benchmark's ``exp13`` section holds the two lengths side by side, and the page
        reports it.
    drop_first : int
        Laps dropped at the start of each flight (1: the start-up ramp).
    max_laps : int
        Laps kept per flight after that (0: all; the paper profile keeps all, 5 per
        Neural-Fly flight).
    channels : tuple of str
        Of :data:`uavwind.data.CHANNELS`.
    conditions : tuple of str
        The wind conditions whose pairs are clustered (empty: every condition the flights
        hold; the quick profile takes three). Every flight still gets its ``"flight"`` row.
    max_iter : int
        The soft-DTW k-means' cap on iterations (the paper's clustering otherwise). 5, not
        the paper's 100: on lap windows the k-means keeps iterating on barycentre noise long
        after its labels settle, and the score depends on the labels alone (the benchmark's
        ``exp13`` section holds every score of the paper profile at the cap against those
        at 100: with laps of 60 samples, all 360 are identical).
    """

    n_samples: int = 60
    drop_first: int = 1
    max_laps: int = 0
    channels: tuple = tuple(CHANNELS)
    conditions: tuple = ()
    max_iter: int = 5

    def __post_init__(self):
        check_fields(self, {"n_samples": Range(4, 10_000, integer=True),
                            "drop_first": Range(0, 100, integer=True),
                            "max_laps": Range(0, 10_000, integer=True),
                            "max_iter": Range(1, 10_000, integer=True)})
        if isinstance(self.channels, str) or not self.channels:
            raise TypeError(f"channels must be a non-empty tuple of channel names, got "
                            f"{self.channels!r}")
        for ch in self.channels:
            if ch not in CHANNELS:
                raise ValueError(f"channels must be among {list(CHANNELS)}, got {ch!r}")
        object.__setattr__(self, "channels", tuple(self.channels))
        if isinstance(self.conditions, str):
            raise TypeError(f"conditions must be a tuple of condition names, got "
                            f"{self.conditions!r}")
        for c in self.conditions:
            if c not in CONDITIONS:
                raise ValueError(f"conditions must be among {list(CONDITIONS)}, got {c!r}")
        object.__setattr__(self, "conditions", tuple(self.conditions))


#: The study at each profile: the quick one keeps two laps per flight and three conditions
#: (three pairs instead of ten).
STUDIES = {"paper": RealFlightStudy(),
           "quick": RealFlightStudy(max_laps=2, conditions=("nowind", "70wind", "100wind"))}


def flights_digest(flights: list[RealFlight]) -> str:
    """SHA-256 of the flights' labels and every array's bytes: what the rows depend on."""
    h = hashlib.sha256()
    for f in flights:
        h.update(json.dumps([f.vehicle, f.trajectory, f.controller, f.condition]).encode())
        for k in sorted(f.arrays):
            h.update(k.encode())
            h.update(np.ascontiguousarray(f.arrays[k], dtype=float).tobytes())
    return h.hexdigest()


#: The channels a flight's own row summarises (:func:`_flight_rows`).
_FLIGHT_CHANNELS = ("tracking_error", "thrust", "aero_force")


def _laps(flights, study):
    """{(controller, condition): flight_laps(...)} with the laps the study keeps: every
    channel it clusters and every channel a flight row summarises, cut once per flight."""
    channels = tuple(dict.fromkeys(study.channels + _FLIGHT_CHANNELS))
    out = {}
    for f in flights:
        w = flight_laps(f, channels, study.n_samples, study.drop_first)
        out[(f.controller, f.condition)] = {k: v[_kept(study)] for k, v in w.items()}
    return out


def _kept(study):
    """The laps ``study`` keeps of those :func:`~uavwind.data.flight_laps` cuts."""
    return slice(None) if study.max_laps == 0 else slice(0, study.max_laps)


def _windows(raw, study):
    """{(controller, condition): {channel: (laps, n, d)}} from :func:`_laps`' ``raw``, every
    channel scaled by its own standard deviation over all windows, and the scales."""
    laps = {key: {ch: w[ch] for ch in study.channels} for key, w in raw.items()}
    scales = {ch: float(np.concatenate([v[ch] for v in laps.values()]).std())
              for ch in study.channels}
    for v in laps.values():
        for ch in study.channels:
            v[ch] = v[ch] / (scales[ch] if scales[ch] > 0 else 1.0)
    return laps, scales


def _check_design(flights):
    """Controllers and conditions; ``ValueError`` unless every controller flew every
    condition the flights hold (the pairs compare like with like) and there are two."""
    controllers = sorted({f.controller for f in flights})
    conditions = [c for c in CONDITIONS if any(f.condition == c for f in flights)]
    have = {(f.controller, f.condition) for f in flights}
    missing = [(k, c) for k in controllers for c in conditions if (k, c) not in have]
    if missing:
        raise ValueError(f"flights must hold every condition for every controller; missing "
                         f"(controller, condition): {missing}")
    if len(conditions) < 2:
        raise ValueError(f"flights must hold at least two wind conditions, got {conditions}")
    return controllers, conditions


def _pair_task(laps, controllers, a, b, channel, params):
    """The rows of one pair of conditions and one channel."""
    rows = []
    base = {"condition_a": a, "condition_b": b, "wind_a": CONDITIONS[a], "wind_b": CONDITIONS[b],
            "channel": channel}
    per = {k: (laps[(k, a)][channel], laps[(k, b)][channel]) for k in controllers}
    for k in controllers:
        xa, xb = per[k]
        X = np.concatenate([xa, xb])
        g = np.r_[np.zeros(len(xa), int), np.ones(len(xb), int)]
        r = score_loop(X, g, **params)
        rows.append({**base, "kind": "cluster", "controller": k, "score": r.score,
                     "silhouette": r.silhouette, "correct": bool(r.correct), "n_windows": len(X)})
    X = np.concatenate([np.concatenate(per[k]) for k in controllers])
    g = np.concatenate([np.r_[np.zeros(len(per[k][0]), int), np.ones(len(per[k][1]), int)]
                        for k in controllers])
    owner = np.concatenate([[k] * (len(per[k][0]) + len(per[k][1])) for k in controllers])
    r = score_loop(X, g, **params)
    rows.append({**base, "kind": "cluster", "controller": "pooled", "score": r.score,
                 "silhouette": r.silhouette, "correct": bool(r.correct), "n_windows": len(X)})
    if len(controllers) > 1:
        D = softdtw_engine().dtw_pdist(X)
        for k in controllers:
            held, train = owner == k, owner != k
            nearest = np.flatnonzero(train)[np.argmin(D[np.ix_(held, train)], axis=1)]
            acc = float(np.mean(g[nearest] == g[held]))
            rows.append({**base, "kind": "loco", "controller": k, "accuracy": acc,
                         "n_windows": int(held.sum())})
    return rows


def _control_task(laps, controllers, condition, channel, params):
    """The same-wind negative control of one condition and channel: each controller's laps
    against the next controller's (in name order) at the same wind, scored as a pair of
    winds is: a score above 0 there measures which flight it is, not the wind."""
    rows = []
    base = {"condition_a": condition, "condition_b": condition, "wind_a": CONDITIONS[condition],
            "wind_b": CONDITIONS[condition], "channel": channel}
    for i, k in enumerate(controllers):
        other = controllers[(i + 1) % len(controllers)]
        xa, xb = laps[(k, condition)][channel], laps[(other, condition)][channel]
        r = score_loop(np.concatenate([xa, xb]),
                       np.r_[np.zeros(len(xa), int), np.ones(len(xb), int)], **params)
        rows.append({**base, "kind": "control", "controller": k, "other": other,
                     "score": r.score, "silhouette": r.silhouette, "correct": bool(r.correct),
                     "n_windows": len(xa) + len(xb)})
    return rows


def compute_rows(flights: list[RealFlight], study: RealFlightStudy = RealFlightStudy(),
                 n_jobs: int | None = None, estimate: bool = True, **params) -> pd.DataFrame:
    """Every row of Experiment 13's real-flight part, computed (no cache): ``kind``
    ``"cluster"`` (``score``, ``silhouette``, ``correct`` per controller and ``"pooled"``),
    ``"loco"`` (``accuracy`` of the held-out ``controller``), ``"control"`` (the same-wind
    negative control: ``controller`` against ``other`` at one wind), for every pair of
    conditions and channel; ``"flight"`` (one row per flight: mean tilt and lean [deg],
    aerodynamic force [N], tracking error [m], thrust over the hover throttle, lap-to-lap
    spread and noise, over its kept laps, unscaled) and ``"estimate"`` (the wind estimated on
    each flight by each :class:`~uavwind.method.wind_estimator.WindEstimator` method fitted on
    the other controllers: :func:`uavwind.analysis.wind_estimates.estimation_rows`; only with
    ``estimate``)."""
    check_instance(study, "study", RealFlightStudy)
    params = ClusteringParams.from_kwargs({"max_iter": study.max_iter, **params},
                                          "clustering parameters").to_dict()
    if not isinstance(flights, (list, tuple)) or not flights:
        raise TypeError("flights must be a non-empty list of RealFlight (uavwind.load_neuralfly)")
    for f in flights:
        check_instance(f, "flights[i]", RealFlight)
    n_jobs = check_jobs(n_jobs)
    controllers, conditions = _check_design(flights)
    if study.conditions:
        missing = [c for c in study.conditions if c not in conditions]
        if missing:
            raise ValueError(f"the study's conditions {missing} are not among the flights' "
                             f"{conditions}")
        conditions = [c for c in conditions if c in study.conditions]
    raw = _laps(flights, study)
    laps, _ = _windows({k: w for k, w in raw.items() if k[1] in conditions}, study)
    from joblib import Parallel, delayed  # here: importing this module stays cheap

    tasks = [delayed(_pair_task)(laps, controllers, a, b, ch, params)
             for a, b in combinations(conditions, 2) for ch in study.channels]
    if len(controllers) > 1:
        tasks += [delayed(_control_task)(laps, controllers, c, ch, params)
                  for c in conditions for ch in study.channels]
    out = Parallel(n_jobs=n_jobs)(tasks)
    rows = [r for rs in out for r in rs]
    rows += _flight_rows(flights, raw, study)
    if estimate:
        rows += estimation_rows(flights)
    df = pd.DataFrame(rows)
    cols = ["kind", "controller", "other", "condition_a", "condition_b", "wind_a", "wind_b", "channel",
            "score", "silhouette", "correct", "accuracy", "n_windows", "condition", "wind_speed",
            "tilt_deg", "pitch_deg", "aero_force_x", "aero_force_z", "aero_force_norm",
            "tracking_rms", "thrust_sp", "hover_throttle", *SPREADS, "n_laps", *noise_columns(),
            "method", "variant", "protocol", "estimate", "sample_rmse", "coverage", "std", "amplitude",
            "phase", "phase_ref", "lag", "t", "truth"]
    for c in cols:
        if c not in df.columns:
            df[c] = np.nan
    df = df[cols]
    df["correct"] = df["correct"].astype("boolean")
    return df


#: A flight row's lap-to-lap spreads: column -> (what it spreads, its unit).
SPREADS = {"fa_x_spread": ("force along x", "N"), "pitch_spread": ("pitch", "deg"),
           "z_tracking_spread": ("vertical tracking error", "m"),
           "position_spread": ("position", "m")}


#: What a flight row's noise columns measure: ``noise_<channel>_<axis>``, the standard
#: deviation of the channel's content above :data:`~uavwind.data.neuralfly.NOISE_CUTOFF`.
NOISE_CHANNELS = {"position": "xyz", "velocity": "xyz", "attitude": "xyz", "thrust": "t",
                  "aero_force": "xyz"}


def noise_columns() -> list[str]:
    """The flight rows' noise columns, in order."""
    return [f"noise_{ch}_{ax}" for ch, axes in NOISE_CHANNELS.items() for ax in axes]


def flight_summaries(flights: list[RealFlight], study: RealFlightStudy = RealFlightStudy()
                     ) -> list[dict]:
    """The kind ``"flight"`` rows of :func:`compute_rows` alone (one per flight, over the
    laps ``study`` keeps), without the clustering."""
    check_instance(study, "study", RealFlightStudy)
    return _flight_rows(flights, _laps(flights, study), study)


def _flight_rows(flights, raw, study):
    """One row per flight: its kept laps' mean tilt and lean towards +x (``pitch_deg``),
    aerodynamic force (x, z, norm), tracking error, thrust over the hover throttle and the
    hover throttle itself (the weight over the full thrust the battery gives), unscaled (``raw``: :func:`_laps`); the lap-to-lap spreads (:data:`SPREADS`: RMS about
    the mean lap of the part below the noise cutoff, what gusts and the controller do) of the
    force along x, the pitch, the vertical tracking error and the position; and each
    channel's noise (:func:`noise_columns`) over the same laps."""
    rows = []
    for f in flights:
        w = raw[(f.controller, f.condition)]
        fa = w["aero_force"]
        a = f.arrays
        t = a["t"]
        dt = float(np.median(np.diff(t)))
        lap = float(np.median(np.diff(lap_starts(f))))
        span = (t >= w["starts"][0]) & (t < w["starts"][-1] + lap)  # the kept laps

        def spread(series):
            laps = cut_laps(f, split_noise(series, dt)[0], study.n_samples,
                            study.drop_first)[_kept(study)]
            return (float(np.sqrt(((laps - laps.mean(0)) ** 2).sum(-1).mean()))
                    if len(laps) > 1 else np.nan)

        row = {"kind": "flight", "controller": f.controller, "condition": f.condition,
               "wind_speed": f.wind_speed, "tilt_deg": float(w["tilt"].mean()),
               "pitch_deg": float(pitch_degrees(a["R"][span]).mean()),
               "aero_force_x": float(fa[..., 0].mean()),
               "aero_force_z": float(fa[..., 2].mean()),
               "aero_force_norm": float(np.linalg.norm(fa, axis=-1).mean()),
               "tracking_rms": float(np.sqrt((np.linalg.norm(w["tracking_error"],
                                                             axis=-1) ** 2).mean())),
               "thrust_sp": float(w["thrust"].mean()),
               "hover_throttle": float(a["hover_throttle"][span].mean()),
               "fa_x_spread": spread(a["fa"][:, :1]),
               "pitch_spread": spread(pitch_degrees(a["R"])[:, None]),
               "z_tracking_spread": spread((a["p"] - a["p_d"])[:, 2:]),
               "position_spread": spread(a["p"]),
               "n_laps": int(len(w["starts"]))}
        for ch, axes in NOISE_CHANNELS.items():
            _, fast = split_noise(channel_series(f, ch)[span], dt)
            for k, ax in enumerate(axes):
                row[f"noise_{ch}_{ax}"] = float(fast[:, k].std())
        rows.append(row)
    return rows


def real_flight_rows(folder: os.PathLike | str | None = None, profile: str = "paper",
                     results: os.PathLike | str | None = None, n_jobs: int | None = None,
                     flights: list[RealFlight] | None = None) -> pd.DataFrame:
    """Experiment 13's real-flight rows, from the cache or computed and stored.

    Parameters
    ----------
    folder : path-like, optional
        The Neural-Fly flights (default ``$UAVWIND_NEURALFLY``); or pass ``flights``.
    profile : {"paper", "quick"}
        The :data:`STUDIES` entry (the quick one keeps two laps per flight).
    results : path-like, optional
        The result folder; the table is kept by :func:`uavwind.analysis.memo.memo` under a
        digest of the study and of the flights: the files' bytes when read from ``folder``
        (so a cached table is found without parsing them), the arrays' bytes when
        ``flights`` are given; with the digest of its own content, so a damaged or altered
        copy is recomputed (with a warning), never trusted.
    """
    if profile not in STUDIES:
        raise ValueError(f"profile must be one of {list(STUDIES)}, got {profile!r}")
    study = STUDIES[profile]
    if flights is None:
        files = flight_files(folder)
        source = {"files": files_digest(files)}

        def load():
            return read_flights(files)
    else:
        source = {"flights": flights_digest(flights)}

        def load():
            return flights

    def compute():
        df = compute_rows(load(), study, n_jobs=n_jobs)
        df.attrs.update(profile=profile, uavwind_version=__version__,
                        citation="Neural-Fly (O'Connell et al. 2022)")
        return df

    return memo("exp13_real", {**source, "study": asdict(study), "version": REAL_VERSION},
                compute, results)


# --------------------------------------------------------------------------- #
# summaries (what the page shows)
# --------------------------------------------------------------------------- #
def _ci(values, bounds=None):
    """Mean and 95% t interval over controllers (NaN bounds for one); with ``bounds`` (the
    range the quantity lives in: 0-100 for a score, 0-1 for an accuracy) the interval is
    cut to it -- a t interval of five shares near 1 reached 1.10 on the Exp 13 page."""
    m, lo, hi = t_ci(np.asarray(values, dtype=float))
    if bounds is not None:
        lo, hi = (float(np.clip(b, *bounds)) for b in (lo, hi))  # NaN stays NaN
    return m, lo, hi


def pair_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per pair of conditions and channel: the mean score over controllers with its
    t interval over controllers, the share of controllers whose clusters are the two
    flights, the pooled score, and the leave-one-controller-out accuracy with its CI."""
    cl = rows[(rows["kind"] == "cluster") & (rows["controller"] != "pooled")]
    pooled = rows[(rows["kind"] == "cluster") & (rows["controller"] == "pooled")]
    loco = rows[rows["kind"] == "loco"]
    out = []
    keys = ["condition_a", "condition_b", "channel"]
    for (a, b, ch), g in cl.groupby(keys, sort=False):
        m, lo, hi = _ci(g["score"], (0.0, 100.0))
        p = pooled[(pooled.condition_a == a) & (pooled.condition_b == b) & (pooled.channel == ch)]
        lc = loco[(loco.condition_a == a) & (loco.condition_b == b) & (loco.channel == ch)]
        am, alo, ahi = _ci(lc["accuracy"], (0.0, 1.0)) if len(lc) else (np.nan,) * 3
        out.append({"condition_a": a, "condition_b": b, "channel": ch,
                    "wind_a": g["wind_a"].iloc[0], "wind_b": g["wind_b"].iloc[0],
                    "mean": m, "ci_low": lo, "ci_high": hi,
                    "correct_rate": float(g["correct"].astype(float).mean()),
                    "n_controllers": len(g), "pooled": float(p["score"].iloc[0]),
                    "loco_accuracy": am, "loco_low": alo, "loco_high": ahi})
    return pd.DataFrame(out)


def channel_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per channel, best first: its mean score over every pair and controller, with
    a CI over controllers (each controller's mean over pairs is one replicate), the pooled
    mean, the leave-one-controller-out accuracy (CI over controllers), how many pairs
    every controller separates and ``n_controllers``, the replicates of the CI."""
    cl = rows[(rows["kind"] == "cluster") & (rows["controller"] != "pooled")]
    pooled = rows[(rows["kind"] == "cluster") & (rows["controller"] == "pooled")]
    loco = rows[rows["kind"] == "loco"]
    out = []
    for ch, g in cl.groupby("channel", sort=False):
        per_ctl = g.groupby("controller")["score"].mean()
        m, lo, hi = _ci(per_ctl.to_numpy(), (0.0, 100.0))
        acc = loco[loco.channel == ch].groupby("controller")["accuracy"].mean()
        am, alo, ahi = _ci(acc.to_numpy(), (0.0, 1.0)) if len(acc) else (np.nan,) * 3
        pairs_all = g.groupby(["condition_a", "condition_b"])["correct"].all()
        out.append({"channel": ch, "mean": m, "ci_low": lo, "ci_high": hi,
                    "pooled": float(pooled[pooled.channel == ch]["score"].mean()),
                    "loco_accuracy": am, "loco_low": alo, "loco_high": ahi,
                    "pairs_separated": int(pairs_all.sum()), "n_pairs": len(pairs_all),
                    "n_controllers": len(per_ctl)})
    df = pd.DataFrame(out).sort_values("mean", ascending=False, ignore_index=True)
    df.insert(1, "rank", np.arange(1, len(df) + 1))
    return df


def decided_orders(channels: pd.DataFrame) -> list[tuple[str, str]]:
    """The orders of two channels a :func:`channel_table` decides: ``(a, b)`` with ``a``
    above ``b`` by mean and their CIs over controllers apart (``a``'s low bound above ``b``'s
    high one), best pair first; by the one rule (:func:`~uavwind.core.stats.decide`, on the
    difference of means with the interval ``[a_low - b_high, a_high - b_low]``), so no order
    is decided on fewer than :data:`~uavwind.core.stats.MIN_DECIDE` controllers."""
    r = channels.set_index("channel")
    order = list(r.sort_values("mean", ascending=False).index)
    if "n_controllers" not in r:
        raise ValueError("channels must be a channel_table (its n_controllers column is "
                         "missing)")
    n = r["n_controllers"]

    def above(a, b):
        return decide(r.loc[a, "mean"] - r.loc[b, "mean"], r.loc[a, "ci_low"] - r.loc[b, "ci_high"],
                      r.loc[a, "ci_high"] - r.loc[b, "ci_low"], int(min(n[a], n[b])),
                      unit="controllers").word == "higher"
    return [(a, b) for i, a in enumerate(order) for b in order[i + 1:] if above(a, b)]


def controlled_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per channel: the mean score over controllers on different winds (each
    controller's mean over the pairs of winds), on the same wind (the negative control,
    each controller's mean over the winds), their paired difference per controller with a
    95% t interval over controllers, the share of correctly grouped control pairs, and the
    ``verdict`` (the one rule, :func:`~uavwind.core.stats.decide`): ``"separates the winds"``
    when the difference's interval lies above 0, ``"no better than its control"`` when it
    lies below 0, else ``"cannot decide"`` (and with fewer than
    :data:`~uavwind.core.stats.MIN_DECIDE` controllers)."""
    cl = rows[(rows["kind"] == "cluster") & (rows["controller"] != "pooled")]
    ctl = rows[rows["kind"] == "control"]
    out = []
    for ch, g in cl.groupby("channel", sort=False):
        diff_wind = g.groupby("controller")["score"].mean()
        same = ctl[ctl.channel == ch].groupby("controller")["score"].mean()
        both = pd.concat({"winds": diff_wind, "same": same}, axis=1).dropna()
        m, lo, hi = _ci((both["winds"] - both["same"]).to_numpy()) if len(both) else (np.nan,) * 3
        verdict = decide(m, lo, hi, len(both), above="separates the winds",
                         below="no better than its control", unit="controllers").word
        c = ctl[ctl.channel == ch]
        out.append({"channel": ch, "different_winds": float(diff_wind.mean()),
                    "same_wind": float(same.mean()) if len(same) else np.nan,
                    "same_wind_correct": float(c["correct"].astype(float).mean())
                    if len(c) else np.nan,
                    "difference": m, "ci_low": lo, "ci_high": hi,
                    "n_controllers": len(both), "verdict": verdict})
    return pd.DataFrame(out).sort_values("difference", ascending=False, ignore_index=True)


def flight_table(rows: pd.DataFrame) -> pd.DataFrame:
    """One row per condition: the mean over controllers of each flight's mean tilt [deg],
    aerodynamic force along x and its norm [N], tracking error [m] and thrust set-point,
    each with the spread over controllers (min, max)."""
    fl = rows[rows["kind"] == "flight"]
    out = []
    for cond, g in fl.groupby("condition", sort=False):
        row = {"condition": cond, "wind_speed": float(g["wind_speed"].iloc[0]),
               "n_controllers": len(g)}
        for c in ("tilt_deg", "aero_force_x", "aero_force_norm", "tracking_rms", "thrust_sp"):
            row[c] = float(g[c].mean())
            row[c + "_min"], row[c + "_max"] = float(g[c].min()), float(g[c].max())
        out.append(row)
    return pd.DataFrame(out).sort_values(["wind_speed", "condition"], ignore_index=True)
