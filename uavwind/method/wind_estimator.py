"""Wind estimated on a multirotor's flight, scikit-learn style: :class:`WindEstimator`.

This module owns :class:`WindEstimator` (``fit(flights)`` on flights whose wind is known,
``predict(flight)`` -> the wind ``(n, 3)`` [m/s] in the world frame, one row per sample) and
:func:`training_wind`, the wind a training flight was flown in. It is the multirotor's member
of the family whose point-mass member is :func:`uavwind.estimate_wind` (Exp 9): the same
quantity (the velocity of the air mass, world frame, z up, [m/s]), the same reasoning (a drag
model inverted: what the air does to the vehicle says how the air moves), on a vehicle that
holds its path under a position controller instead of flying an open-loop thrust sequence.

Three methods (``method=``):

* ``"drag"`` -- drag-model inversion per horizontal axis. The air velocity relative to the
  vehicle is ``r = W - v`` (wind minus ground velocity); on the training flights the curve
  ``r = c + h(fa)``, ``h`` an odd cubic of the aerodynamic force, is fitted by least squares
  on the force and velocity low-passed at ``cutoff`` Hz (causal), and ``W = v + r`` on the
  flight to predict. The curve is fitted in wind space because the tunnel's drag grows faster
  between 8.5 and 12.1 m/s than a quadratic through the slower winds allows.
* ``"ekf"`` -- an extended Kalman filter per horizontal axis on ``[v, W]`` (PX4 EKF2's idea of
  fusing a drag model): ``m dv/dt = T (R e_z) + c + D(W - v)`` with ``T = m g T_sp /
  hover_throttle`` along the body's z axis and ``D`` the forward drag curve fitted on the
  training flights' ``fa``; ``W`` a random walk; the measured ground velocity corrects it.
* ``"clusters"`` -- causal curiosity's clusters as a classifier: each lap of the flight (its
  aerodynamic force and attitude, :func:`uavwind.data.flight_laps`) takes the mean wind of
  its ``neighbours`` DTW-nearest training laps; piecewise constant, and it can only name a
  wind it was trained on.

Training flights give their wind as ``wind_speed`` along ``direction`` (Neural-Fly's fan:
-x). A flight whose wind varies in a way the flight does not record (Neural-Fly's
``70p20sint``, whose sinusoid's phase is not referenced to the file's time) is left out of
the drag fits and labelled with its mean by ``"clusters"``. Samples before ``skip`` [s] (the
start-up lap) are never fitted on.
"""

from __future__ import annotations

import numpy as np

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from ..data.neuralfly import RealFlight, flight_laps
from .clustering import softdtw_engine

__all__ = ["WindEstimator", "ESTIMATORS", "training_wind", "UNRECORDED"]

#: The methods of :class:`WindEstimator`.
ESTIMATORS = ("drag", "ekf", "clusters")
#: Conditions whose wind varies in a way the flight does not record: fitted on (by
#: ``"clusters"``) with their mean only.
UNRECORDED = ("70p20sint",)
_GRAVITY = 9.81


def training_wind(flight: RealFlight, direction=(-1.0, 0.0, 0.0)) -> np.ndarray:
    """The wind ``(n, 3)`` [m/s] a training flight was flown in: ``wind_speed`` along the unit
    vector ``direction`` at every sample (the mean, for a condition in :data:`UNRECORDED`)."""
    check_instance(flight, "flight", RealFlight)
    d = check_array(direction, "direction", shape=(3,))
    d = d / np.linalg.norm(d)
    return np.broadcast_to(flight.wind_speed * d, (flight.n_samples, 3)).copy()


def _odd_cubic(x):
    """Basis of the drag curves: ``x, |x| x, x^3`` (odd: a curve through the origin's
    symmetry, up to the fitted intercept)."""
    return np.column_stack([x, np.abs(x) * x, x ** 3])


def _lowpass(x, dt, cutoff):
    """2nd-order Butterworth low-pass at ``cutoff`` [Hz], causal, started at the first
    value (what an on-board filter could do)."""
    from scipy import signal  # imported when used: `import uavwind` stays cheap

    b, a = signal.butter(2, cutoff, fs=1.0 / dt)
    zi = signal.lfilter_zi(b, a).reshape((-1,) + (1,) * (x.ndim - 1)) * x[0]
    return signal.lfilter(b, a, x, axis=0, zi=zi)[0]


def _dt(flight):
    return float(np.median(np.diff(flight.arrays["t"])))


class WindEstimator:
    """The wind a multirotor flew through, estimated from its flight (see the module text).

    Parameters
    ----------
    method : {"drag", "ekf", "clusters"}
    mass : float
        The vehicle's mass [kg] (the EKF's force balance), in (0, 1000]; default 2.6, the
        Neural-Fly quadrotor's.
    direction : array_like, shape (3,)
        The direction the training flights' wind blows along (unit after normalising);
        default -x, Neural-Fly's fan.
    cutoff : float
        ``"drag"``: the low-pass on the force and velocity [Hz], in (0, 10]; default 1.
    sigma_force, sigma_wind_rate, sigma_velocity : float
        ``"ekf"``: the process noise of the force balance [N], the wind's random walk
        [m/s per sqrt(s)] and the ground velocity's measurement noise [m/s]; defaults 0.6,
        3 and 0.02 (set by hand, not tuned on the flights scored).
    channels : tuple of str
        ``"clusters"``: the lap channels compared (:data:`uavwind.data.CHANNELS`).
    neighbours : int
        ``"clusters"``: laps whose winds are averaged, in [1, 100].
    skip : float
        Training samples before this time [s] are not fitted on (the start-up lap), in
        [0, 1e4]; default 2 pi.

    Notes
    -----
    After :meth:`fit`: ``coef_`` (``"drag"``, ``"ekf"``), per horizontal axis (0, 1) the
    curve's weights ``w``, intercept ``c`` and the fit's RMS residual; ``laps_``,
    ``lap_winds_`` and ``scale_`` (``"clusters"``), the training laps, their wind speeds
    [m/s] and the channel scales.

    Examples
    --------
    >>> est = WindEstimator(method="drag")  # doctest: +SKIP
    >>> est.fit(training_flights).predict(flight).shape  # doctest: +SKIP
    (2500, 3)
    """

    def __init__(self, method: str = "drag", *, mass: float = 2.6,
                 direction=(-1.0, 0.0, 0.0), cutoff: float = 1.0, sigma_force: float = 0.6,
                 sigma_wind_rate: float = 3.0, sigma_velocity: float = 0.02,
                 channels=("aero_force", "attitude"), neighbours: int = 1,
                 skip: float = 2 * np.pi):
        self.method = check_choice(method, "method", ESTIMATORS)
        self.mass = check_scalar(mass, "mass", low=0.0, low_inclusive=False, high=1e3)
        d = check_array(direction, "direction", shape=(3,))
        if not np.linalg.norm(d) > 0:
            raise ValueError("direction must be a non-zero (3,) vector")
        self.direction = d / np.linalg.norm(d)
        self.cutoff = check_scalar(cutoff, "cutoff", low=0.0, low_inclusive=False, high=10.0)
        self.sigma_force = check_scalar(sigma_force, "sigma_force", low=0.0,
                                        low_inclusive=False, high=1e3)
        self.sigma_wind_rate = check_scalar(sigma_wind_rate, "sigma_wind_rate", low=0.0,
                                            low_inclusive=False, high=1e3)
        self.sigma_velocity = check_scalar(sigma_velocity, "sigma_velocity", low=0.0,
                                           low_inclusive=False, high=1e3)
        if isinstance(channels, str) or not channels:
            raise TypeError(f"channels must be a non-empty tuple of channel names, got "
                            f"{channels!r}")
        self.channels = tuple(channels)
        self.neighbours = check_scalar(neighbours, "neighbours", low=1, high=100, integer=True)
        self.skip = check_scalar(skip, "skip", low=0.0, high=1e4)

    def __repr__(self):
        return f"WindEstimator(method={self.method!r})"

    # -- fitting ------------------------------------------------------------ #
    def fit(self, flights) -> WindEstimator:
        """Fit on ``flights`` (a list of :class:`~uavwind.data.RealFlight` whose
        ``wind_speed`` is known); returns ``self``."""
        if not isinstance(flights, (list, tuple)) or not flights:
            raise TypeError("flights must be a non-empty list of RealFlight")
        for f in flights:
            check_instance(f, "flights[i]", RealFlight)
        if self.method == "clusters":
            return self._fit_laps(flights)
        usable = [f for f in flights if f.condition not in UNRECORDED]
        if not usable:
            raise ValueError(f"flights must hold a flight whose wind is recorded (not only "
                             f"{list(UNRECORDED)})")
        self.coef_ = {}
        for ax in (0, 1):
            force, air = [], []
            for f in usable:
                a = f.arrays
                keep = a["t"] >= self.skip
                W = training_wind(f, self.direction)[:, ax]
                if self.method == "drag":
                    lp = _lowpass(np.column_stack([a["fa"][:, ax], a["v"][:, ax]]), _dt(f),
                                  self.cutoff)
                    fa, v = lp[:, 0], lp[:, 1]
                else:
                    fa, v = a["fa"][:, ax], a["v"][:, ax]
                force.append(fa[keep])
                air.append(W[keep] - v[keep])
            F, r = np.concatenate(force), np.concatenate(air)
            x, y = (F, r) if self.method == "drag" else (r, F)  # drag: r = c + h(fa)
            X = np.column_stack([_odd_cubic(x), np.ones_like(x)])
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            self.coef_[ax] = {"w": coef[:3], "c": float(coef[3]),
                              "rms": float(np.sqrt(np.mean((y - X @ coef) ** 2)))}
        return self

    def _lap_windows(self, flight):
        L = flight_laps(flight, self.channels, 120, 1)
        return np.concatenate([L[ch] for ch in self.channels], axis=2), L["starts"]

    def _fit_laps(self, flights):
        X, y = [], []
        for f in flights:
            laps, _ = self._lap_windows(f)
            X.append(laps)
            y.append(np.full(len(laps), float(f.wind_speed)))
        self.laps_, self.lap_winds_ = np.concatenate(X), np.concatenate(y)
        self.scale_ = self.laps_.reshape(-1, self.laps_.shape[2]).std(axis=0) + 1e-9
        return self

    # -- predicting --------------------------------------------------------- #
    def predict(self, flight: RealFlight) -> np.ndarray:
        """The wind ``(n, 3)`` [m/s], world frame, at every sample of ``flight`` (the
        vertical component 0: no method models a vertical wind)."""
        check_instance(flight, "flight", RealFlight)
        if not (hasattr(self, "coef_") or hasattr(self, "laps_")):
            raise ValueError("this WindEstimator is not fitted: call fit(flights) first")
        if self.method == "clusters":
            return self._predict_laps(flight)
        if self.method == "drag":
            return self._predict_drag(flight)
        return self._predict_ekf(flight)

    def _predict_drag(self, flight):
        a, dt = flight.arrays, _dt(flight)
        fa = _lowpass(np.asarray(a["fa"][:, :2], dtype=float), dt, self.cutoff)
        v = _lowpass(np.asarray(a["v"][:, :2], dtype=float), dt, self.cutoff)
        W = np.zeros((flight.n_samples, 3))
        for ax in (0, 1):
            k = self.coef_[ax]
            W[:, ax] = v[:, ax] + k["c"] + _odd_cubic(fa[:, ax]) @ k["w"]
        return W

    def _predict_ekf(self, flight):
        a = flight.arrays
        t, R = a["t"], a["R"]
        m = self.mass
        c = np.array([self.coef_[ax]["c"] for ax in (0, 1)])
        w = np.stack([self.coef_[ax]["w"] for ax in (0, 1)]) / m  # (2, 3): per axis
        thrust = m * _GRAVITY * a["T_sp"] / a["hover_throttle"]
        drive = (R[:, :2, 2] * thrust[:, None] + c) / m          # the non-drag acceleration
        steps = np.diff(t, prepend=t[0] - _dt(flight))
        qv, qw = (self.sigma_force / m) ** 2, self.sigma_wind_rate ** 2
        rv = self.sigma_velocity ** 2
        v_meas = np.asarray(a["v"][:, :2], dtype=float)
        out = np.zeros((len(t), 3))
        xv, xw = v_meas[0].copy(), np.zeros(2)
        P00, P01, P11 = np.full(2, rv), np.zeros(2), np.full(2, 100.0)
        for k in range(len(t)):
            h = steps[k]
            if k > 0:  # predict: v' = drive + D(W - v)/m, W' = 0
                r = xw - xv
                ar = np.abs(r)
                xv = xv + h * (drive[k - 1] + r * (w[:, 0] + ar * (w[:, 1] + w[:, 2] * ar)))
                slope = w[:, 0] + ar * (2.0 * w[:, 1] + 3.0 * w[:, 2] * ar)
                f00, f01 = 1.0 - h * slope, h * slope
                P00, P01, P11 = (f00 * f00 * P00 + 2 * f00 * f01 * P01 + f01 * f01 * P11
                                 + qv * h, f00 * P01 + f01 * P11, P11 + qw * h)
            s = P00 + rv  # correct on the measured ground velocity
            k0, k1 = P00 / s, P01 / s
            innovation = v_meas[k] - xv
            xv, xw = xv + k0 * innovation, xw + k1 * innovation
            P00, P01, P11 = (1 - k0) * P00, (1 - k0) * P01, P11 - k1 * P01
            out[k, :2] = xw
        return out

    def _predict_laps(self, flight):
        dtw = softdtw_engine().dtw  # the kernels load when a lap is compared, not on import
        laps, starts = self._lap_windows(flight)
        train, query = self.laps_ / self.scale_, laps / self.scale_
        D = np.array([[dtw(q, x) for x in train] for q in query])
        speed = self.lap_winds_[np.argsort(D, axis=1)[:, :self.neighbours]].mean(axis=1)
        t = flight.arrays["t"]
        lap = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(speed) - 1)
        return speed[lap][:, None] * self.direction
