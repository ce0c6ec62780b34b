"""Wind estimated on a multirotor's flight, scikit-learn style: :class:`WindEstimator`.

This module owns :class:`WindEstimator` (``fit(flights)`` on flights whose wind is known,
``predict(flight)`` -> the wind ``(n, 3)`` [m/s] in the world frame, one row per sample;
``predict(flight, return_std=True)`` -> ``(mean, std)``, scikit-learn's convention),
:func:`training_wind` and :func:`check_flight`; the force model it fits (:class:`DragModel`, re-exported
here) and the fits and filters it runs are :mod:`uavwind.method.drag_model`'s. It is the multirotor's
member of the family whose point-mass member is :func:`uavwind.estimate_wind` (Exp 9): the
same quantity (the velocity of the air mass, world frame, z up, [m/s]), the same reasoning (a
drag model inverted: what the air does to the vehicle says how the air moves) and the same
``return_std`` convention, on a vehicle that holds its path under a position controller.

**The force model** (:class:`DragModel`). ``fa`` is the aerodynamic force the flight records
(the authors' residual of the force balance of thrust, attitude and acceleration, so it
carries every channel the autopilot logs). In the body frame ``b`` (``R`` body -> world), with
``tau = T_sp / hover_throttle`` the thrust in hovers, its horizontal components are::

    fa_b,xy / tau = delta + k u + (c / tau) |u| u,    u = [R^T (s(p) W - v)]_xy,
    s(p) = 1 + g . (p - p_c)

* ``k [N s/m]``: rotor drag, linear in the airspeed across the rotor discs and proportional
  to the thrust (blade flapping and induced drag: Kai et al. 2017, Faessler et al. 2018).
  On the Neural-Fly flights ``(fa_b,x / tau - delta) / u_b,x`` is 1.04, 0.98 and 0.99 N s/m at
  4.2, 8.5 and 12.1 m/s: the quadratic parasitic drag ``c`` of the frame (``parasitic=True``;
  fitted at or above 0, and solved in closed form) is left out by default, since a fitted one
  takes the still-air intercept with it (still air left out of the fit is then read as 4-5
  m/s). RotorPy's vehicle, the twin, has one.
* ``delta [N]``: the thrust-axis offset (the body z axis as logged is not the thrust's: the
  still-air lean of -2.5 to -3.2 deg), per hover thrust.
* ``s(p)``: the tunnel's jet is not uniform. The estimate's error along a lap follows the
  vehicle's position (R^2 0.6-0.8 in wind), so the wind is taken as ``W`` at the centre of the
  reference path ``p_c`` (mean ``p_d``) scaled linearly with the distance from it; ``g``
  [1/m] is fitted on the training flights (clipped to ``s`` in [0.5, 2]). ``W`` is what the
  estimator returns: the jet's wind at the path's centre (``jet=False``: a uniform wind).
* the vertical wind is taken as zero (every method returns 0 in z, with std 0: assumed, not
  estimated); the equation is solved for ``W_xy`` per sample (a 2 x 2 system, invertible below
  90 deg of tilt).

The model is linear in its six parameters and fitted by least squares on every sample after
``skip`` of the training flights, each flight weighted alike.

**Each flight's own offset** (``tilt=True``, the default). On the Neural-Fly flights most of
a held-out flight's error is its mean's (each flight's logged attitude leans by its own small
angle, which shifts ``fa_b,xy / tau`` by a constant ``r`` [N per hover thrust] that the
in-plane equation cannot tell from the wind). A lean also turns the force into the body z axis
(by ``gamma . r``, ``gamma = f_xy / (f_z + m g)``, ``m`` the ``mass``), and the body z force
over the thrust ``f_z`` follows the airspeed, so a flight's means obey::

    mean f_z + gamma . r = z(W(r)),   z(W) = a + b mean |u|^p,
    W(r) = W_0 - mean(H^-1) r

(``W_0`` the wind the in-plane equation reads, ``H = k s R^T_xy``). ``(a, b)`` are fitted on
the training flights' means, each with its offset known from its label, and the power ``p``
(of :data:`Z_POWERS`) is the one whose curve errs least with each training wind left out of
its fit in turn (4 on every fit of the Neural-Fly flights). A held-out flight's ``r`` is then
the posterior of a Gaussian prior ``N(0, k^2 flight(W)^2)`` per axis (the controllers'
flight-mean spread, below) and that equation (Gauss-Newton), whose variance is the curve's
flight-level error with each training controller left out of its fit, growing as
``reach * d^2`` with the distance ``d`` [m/s] from the nearest training wind speed (``reach``
fitted on the errors with each training wind left out). With fewer than three training wind
speeds no curve is fitted and the prior alone stands: the estimate is then the plain
model's. Every part is fitted on the training flights only; the held-out flight gives its
force, attitude and thrust, never its wind. The offset is read from the whole
flight (after ``skip``): with it the ``"ekf"`` estimate is no longer causal (``tilt=False``
keeps it causal). The body y offset is barely read (across the wind the force turns little
into z): it stays near its prior, 0.

**Methods** (``method=``):

* ``"drag"`` -- the model inverted at every sample, on the force, velocity, attitude and thrust
  low-passed at ``cutoff`` Hz (causal 2nd-order Butterworth).
* ``"ekf"`` -- a Kalman filter on ``W_xy`` (a random walk of ``sigma_wind_rate``) whose
  measurement is the same equation averaged over blocks of ``update_period`` s (the force's
  noise is coloured: block means are close to white); causal: a sample's estimate uses the
  blocks before its own. Linear in ``W`` without the parasitic term (the filter is then
  exact); with it, the gain is taken at the prior's airspeed.
  The random walk is set for a steady wind: a wind that changes faster (Neural-Fly's 2.4 m/s
  sinusoid at 1 rad/s) it follows late, and its variance does not know it; the std does
  (below).
* ``"clusters"`` -- causal curiosity's clusters as a *classifier*: each lap (its force and
  attitude, :func:`uavwind.data.flight_laps`) takes the mean wind of its ``neighbours``
  DTW-nearest training laps. It can only name a wind it was trained on, so it has no std and
  is scored by its accuracy, never by an RMSE.

**Uncertainty** (``return_std=True``): per world axis, ``std^2 = noise(W)^2 + flight(W)^2``
(with the flight's own offset, ``flight(W)^2`` is replaced by the offset's posterior variance
carried into the wind, ``mean(H^-1) P mean(H^-1)^T``).
``noise``: the estimate's scatter about its own flight mean on the training flights (for
``"ekf"``, the filter's variance with the block noise fitted the same way, raised to what the
filter's innovations show: a block's variance is at least the mean, over the blocks of the
last ``innovation_window`` s, of the squared innovation (a block's reading less the filter's
prediction for it) less the reading's noise variance. A block's reading is the truth plus its noise,
the prediction is what that block's samples are given, so this is the estimate's own mean
square error, lag included, read without the wind; the training flights' wind is steady, so
no fitted term could learn the lag); ``flight``: the
error of a flight's mean when its controller is left out of the fit (refitted once per
training controller), which carries the controllers' differences and the tunnel labels'
between-session uncertainty. Each is ``sqrt(a + b W^2)``, fitted on the squared errors.

Training flights give their wind as ``wind_speed`` along ``direction`` (Neural-Fly's fan:
-x). A flight whose wind varies in a way the flight does not record (Neural-Fly's
``70p20sint``) is left out of the drag fits and labelled with its mean by ``"clusters"``.
Samples before ``skip`` [s] (the start-up lap) are never fitted on. A flight is checked once,
where it enters (:meth:`WindEstimator.fit`, :meth:`WindEstimator.predict`); the private
functions below trust what they are given.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from ..data.neuralfly import RealFlight, flight_laps
from .clustering import softdtw_engine
from .drag_model import (Z_POWERS, DragModel, block_starts, fit_model, fit_tilt, flight_dt,
                         kalman, normal_equations, signals, tilted, variance_curve)

__all__ = ["WindEstimator", "DragModel", "ESTIMATORS", "Z_POWERS", "training_wind", "UNRECORDED",
           "check_flight"]

#: The methods of :class:`WindEstimator`.
ESTIMATORS = ("drag", "ekf", "clusters")
#: Conditions whose wind varies in a way the flight does not record: fitted on (by
#: ``"clusters"``) with their mean only.
UNRECORDED = ("70p20sint",)
#: The columns a flight needs, and each row's shape.
_COLUMNS = {"t": (), "p": (3,), "p_d": (3,), "v": (3,), "R": (3, 3), "T_sp": (),
            "hover_throttle": (), "fa": (3,)}
#: The fewest samples a flight may have (a low-pass and a block need a few).
MIN_SAMPLES = 10


def _unit(direction, name="direction"):
    """``direction`` as a horizontal unit vector (scaled before it is normalised, so a huge
    or tiny vector is not an overflow)."""
    d = check_array(direction, name, shape=(3,))
    big = float(np.max(np.abs(d)))
    if not big > 0:
        raise ValueError(f"{name} must be a non-zero (3,) vector, got {d.tolist()}")
    d = d / big
    d = d / np.linalg.norm(d)
    if abs(d[2]) > 1e-9:
        raise ValueError(f"{name} must be horizontal (z component 0): the model takes the "
                         f"vertical wind as zero, got {d.tolist()}")
    return d


def check_flight(flight, name: str = "flight") -> RealFlight:
    """``flight`` if it is a :class:`~uavwind.data.RealFlight` the estimator can read: the
    columns it uses present, of one length (at least :data:`MIN_SAMPLES`), finite, times
    increasing, ``hover_throttle`` and ``T_sp`` positive, the body upright (tilt below 90
    deg) and a finite ``wind_speed``; else a ``ValueError`` naming the flight and the column."""
    check_instance(flight, name, RealFlight)
    who = f"{name} {flight.source!r}"
    a = flight.arrays
    missing = [c for c in _COLUMNS if c not in a]
    if missing:
        raise ValueError(f"{who} lacks column(s) {missing} (the estimator reads "
                         f"{list(_COLUMNS)})")
    n = None
    for col, shape in _COLUMNS.items():
        x = np.asarray(a[col])
        if x.dtype.kind not in "fiu":
            raise ValueError(f"{who}: column {col!r} must hold numbers, got dtype {x.dtype}")
        if n is None:
            n = len(x) if x.ndim else 0
        if x.ndim != 1 + len(shape) or x.shape[1:] != shape or len(x) != n:
            raise ValueError(f"{who}: column {col!r} must have shape ({n}, "
                             f"{', '.join(map(str, shape))}{')' if shape else ')'}, "
                             f"got {x.shape}".replace(", )", ")"))
        if not np.all(np.isfinite(x)):
            i = int(np.flatnonzero(~np.isfinite(x.reshape(len(x), -1)).all(axis=1))[0])
            raise ValueError(f"{who}: column {col!r} has a NaN or infinite value at row {i}")
    if n < MIN_SAMPLES:
        raise ValueError(f"{who} has {n} sample(s); the estimator needs at least "
                         f"{MIN_SAMPLES}")
    t = np.asarray(a["t"], dtype=float)
    steps = np.diff(t)
    if not np.all(steps > 0):
        i = int(np.argmin(steps > 0)) + 1
        raise ValueError(f"{who}: column 't' must increase, row {i} is {t[i]:g} after "
                         f"{t[i - 1]:g}")
    for col in ("hover_throttle", "T_sp"):
        if not np.all(np.asarray(a[col]) > 0):
            raise ValueError(f"{who}: column {col!r} must be positive (a thrust), got "
                             f"{float(np.min(a[col])):g}")
    if not np.all(np.asarray(a["R"])[:, 2, 2] > 0):
        raise ValueError(f"{who}: column 'R' has the body tilted 90 deg or more (R[2, 2] <= 0): "
                         f"the drag model is written for a flying multirotor")
    if not (isinstance(flight.wind_speed, (int, float, np.integer, np.floating))
            and math.isfinite(flight.wind_speed)):
        raise ValueError(f"{who}: wind_speed must be a finite number [m/s], got "
                         f"{flight.wind_speed!r}")
    return flight


def training_wind(flight: RealFlight, direction=(-1.0, 0.0, 0.0)) -> np.ndarray:
    """The wind ``(n, 3)`` [m/s] a training flight was flown in: ``wind_speed`` along the unit
    vector ``direction`` at every sample (the mean, for a condition in :data:`UNRECORDED`)."""
    check_instance(flight, "flight", RealFlight)
    d = _unit(direction)
    return np.broadcast_to(flight.wind_speed * d, (flight.n_samples, 3)).copy()


class WindEstimator:
    """The wind a multirotor flew through, estimated from its flight (see the module text).

    Parameters
    ----------
    method : {"drag", "ekf", "clusters"}
    direction : array_like, shape (3,)
        The direction the training flights' wind blows along (horizontal; unit after
        normalising); default -x, Neural-Fly's fan.
    cutoff : float
        ``"drag"``: the low-pass on the force, velocity, attitude and thrust [Hz], in
        (0, 10] and below each flight's Nyquist frequency; default 1.
    sigma_wind_rate : float
        ``"ekf"``: the wind's random walk [m/s per sqrt(s)], in [1e-3, 100]; default 0.3.
    update_period : float
        ``"ekf"``: the length of a measurement block [s], in [0.02, 10]; default 0.5.
    jet : bool
        Fit the jet's linear speed profile (module text); default True.
    parasitic : bool
        Add the quadratic parasitic drag ``c |u| u`` to the model (module text); default
        False: on the real flights the rotor drag alone holds, and a fitted quadratic term
        takes the still-air intercept with it when still air is left out. RotorPy's vehicle
        (the twin) has one.
    channels : tuple of str
        ``"clusters"``: the lap channels compared (:data:`uavwind.data.CHANNELS`).
    neighbours : int
        ``"clusters"``: laps whose winds are averaged, in [1, 100] and at most the training
        laps.
    skip : float
        Training samples before this time [s] are not fitted on (the start-up lap), in
        [0, 1e4]; default 2 pi.
    tilt : bool
        ``"drag"``, ``"ekf"``: estimate each flight's own offset from its body z force
        (module text; :meth:`offset`); default True. False: the training flights' offset for
        every flight (and a causal ``"ekf"``).
    mass : float
        The vehicle's mass [kg] (``tilt``: the weight ``m g`` the body z force is measured
        against), in [0.01, 1e4]; default 2.6, Neural-Fly's quadrotor.
    innovation_window : float
        ``"ekf"``: the std is at least the error the filter's innovations over the last this
        many seconds show (module text; causal), in [0, 1e4]; default 2 pi, one lap of
        Neural-Fly's figure-8 (its lap-locked force averages out). 0: the filter's own
        variance alone. The estimate (the mean) does not depend on it.

    Notes
    -----
    After :meth:`fit`: ``model_`` (:class:`DragModel`), ``noise_`` and ``flight_`` (each per
    world axis ``(a, b)`` of ``var = a + b W^2`` [m^2/s^2, 1]), ``block_noise_`` (``"ekf"``),
    ``tilt_`` (``tilt``: the z curve's ``(a, b)``, its variance, ``reach``, the training wind
    speeds and the power ``p``);
    ``laps_``, ``lap_winds_`` and ``scale_`` (``"clusters"``). A fit that fails leaves the
    estimator as it was.

    Examples
    --------
    >>> est = WindEstimator(method="drag")  # doctest: +SKIP
    >>> mean, std = est.fit(training_flights).predict(flight, return_std=True)  # doctest: +SKIP
    >>> mean.shape, std.shape  # doctest: +SKIP
    ((2500, 3), (2500, 3))
    """

    def __init__(self, method: str = "drag", *, direction=(-1.0, 0.0, 0.0),
                 cutoff: float = 1.0, sigma_wind_rate: float = 0.3,
                 update_period: float = 0.5, jet: bool = True, parasitic: bool = False,
                 channels=("aero_force", "attitude"), neighbours: int = 1,
                 skip: float = 2 * np.pi, tilt: bool = True, mass: float = 2.6,
                 innovation_window: float = 2 * np.pi):
        self.method = check_choice(method, "method", ESTIMATORS)
        self.direction = _unit(direction)
        self.cutoff = check_scalar(cutoff, "cutoff", low=0.0, low_inclusive=False, high=10.0)
        self.sigma_wind_rate = check_scalar(sigma_wind_rate, "sigma_wind_rate", low=1e-3,
                                            high=100.0)
        self.update_period = check_scalar(update_period, "update_period", low=0.02,
                                          high=10.0)
        if not isinstance(jet, (bool, np.bool_)):
            raise TypeError(f"jet must be a bool, got {type(jet).__name__}")
        self.jet = bool(jet)
        if not isinstance(parasitic, (bool, np.bool_)):
            raise TypeError(f"parasitic must be a bool, got {type(parasitic).__name__}")
        self.parasitic = bool(parasitic)
        if isinstance(channels, str) or not isinstance(channels, (tuple, list)) \
                or not channels:
            raise TypeError(f"channels must be a non-empty tuple of channel names, got "
                            f"{channels!r}")
        self.channels = tuple(channels)
        self.neighbours = check_scalar(neighbours, "neighbours", low=1, high=100, integer=True)
        self.skip = check_scalar(skip, "skip", low=0.0, high=1e4)
        if not isinstance(tilt, (bool, np.bool_)):
            raise TypeError(f"tilt must be a bool, got {type(tilt).__name__}")
        self.tilt = bool(tilt)
        self.mass = check_scalar(mass, "mass", low=0.01, high=1e4)
        self.innovation_window = check_scalar(innovation_window, "innovation_window", low=0.0,
                                              high=1e4)

    def __repr__(self):
        return f"WindEstimator(method={self.method!r})"

    # -- checks at the boundary --------------------------------------------- #
    def _check_cutoff(self, flight):
        nyquist = 0.5 / flight_dt(flight)
        if self.method == "drag" and not self.cutoff < nyquist:
            raise ValueError(f"cutoff must be below the Nyquist frequency of flight "
                             f"{flight.source!r} ({nyquist:g} Hz), got {self.cutoff:g} Hz")

    def _kept(self, flight, name):
        keep = flight.arrays["t"] >= self.skip
        if keep.sum() < MIN_SAMPLES:
            raise ValueError(f"skip={self.skip:g} s leaves {int(keep.sum())} sample(s) of "
                             f"{name} {flight.source!r} (it ends at "
                             f"{float(flight.arrays['t'][-1]):g} s); at least {MIN_SAMPLES} "
                             f"are needed")
        return keep

    # -- fitting ------------------------------------------------------------ #
    def fit(self, flights) -> WindEstimator:
        """Fit on ``flights`` (a list of :class:`~uavwind.data.RealFlight` whose
        ``wind_speed`` is known); returns ``self``. A fit that fails raises and leaves the
        estimator as it was."""
        if not isinstance(flights, (list, tuple)) or not flights:
            raise TypeError("flights must be a non-empty list of RealFlight")
        for i, f in enumerate(flights):
            check_flight(f, f"flights[{i}]")
        if self.method == "clusters":
            state = self._fit_laps(flights)
        else:
            state = self._fit_drag(flights)
        for k in ("model_", "noise_", "flight_", "block_noise_", "laps_", "lap_winds_",
                  "scale_", "tilt_"):
            self.__dict__.pop(k, None)
        self.__dict__.update(state)
        return self

    def _fit_drag(self, flights):
        usable = [f for f in flights if f.condition not in UNRECORDED]
        if not usable:
            raise ValueError(f"flights must hold a flight whose wind is recorded (not only "
                             f"{list(UNRECORDED)})")
        speeds = sorted({float(f.wind_speed) for f in usable})
        if len(speeds) < 2:
            raise ValueError(f"flights must span at least two wind speeds to fit the drag "
                             f"model, got only {speeds[0]:g} m/s")
        for f in usable:
            self._check_cutoff(f)
        cut = self.cutoff if self.method == "drag" else None
        items = [(f, signals(f, cut), self._kept(f, "training flight")) for f in usable]
        normals = [normal_equations(sig, f.wind_speed * self.direction, keep) for f, sig, keep in items]
        model = fit_model(normals, self.jet, self.parasitic)
        # the scatter about each flight's mean, and each flight's mean error with its
        # controller left out of the fit (once per controller; in-sample with one controller)
        controllers = sorted({f.controller for f in usable})
        held = {c: (fit_model([nm for (f, _, _), nm in zip(items, normals)
                                if f.controller != c], self.jet, self.parasitic)
                    if len(controllers) > 1 else model) for c in controllers}
        sp, fast, mean, blocks = [], [], [], []
        for f, sig, keep in items:
            W = f.wind_speed * self.direction[:2]
            err = model.invert(sig)[keep] - W
            if self.method == "ekf":
                starts = block_starts(int(keep.sum()), flight_dt(f), self.update_period)
                b = np.add.reduceat(err, starts) / np.diff(np.append(starts, len(err)))[:, None]
                blocks.append(np.mean((b - b.mean(axis=0)) ** 2, axis=0))
            sp.append(f.wind_speed)
            fast.append(np.mean((err - err.mean(axis=0)) ** 2, axis=0))
            # (invertible: check_flight keeps the tilt below 90 deg, the jet's scale >= 0.5)
            mean.append((held[f.controller].invert(sig)[keep] - W).mean(axis=0) ** 2)
        fast, mean = np.array(fast), np.array(mean)
        state = {"model_": model,
                 "noise_": tuple(variance_curve(sp, fast[:, ax]) for ax in (0, 1)),
                 "flight_": tuple(variance_curve(sp, mean[:, ax]) for ax in (0, 1))}
        if self.method == "ekf":
            blocks = np.array(blocks)
            state["block_noise_"] = variance_curve(sp, blocks.mean(axis=1))
        if self.tilt:
            raw = items if cut is None else [(f, signals(f, None), k) for f, _, k in items]
            state["tilt_"] = fit_tilt(model, raw,
                                       [f.wind_speed * self.direction[:2] for f in usable],
                                       [f.controller for f in usable], self.mass * 9.81)
        return state

    def _lap_windows(self, flight):
        L = flight_laps(flight, self.channels, 120, 1)
        return np.concatenate([L[ch] for ch in self.channels], axis=2), L["starts"]

    def _fit_laps(self, flights):
        X, y = [], []
        for f in flights:
            laps, _ = self._lap_windows(f)
            X.append(laps)
            y.append(np.full(len(laps), float(f.wind_speed)))
        laps, winds = np.concatenate(X), np.concatenate(y)
        if self.neighbours > len(laps):
            raise ValueError(f"neighbours must be at most the training laps ({len(laps)}), "
                             f"got {self.neighbours}")
        return {"laps_": laps, "lap_winds_": winds,
                "scale_": laps.reshape(-1, laps.shape[2]).std(axis=0) + 1e-9}

    # -- predicting --------------------------------------------------------- #
    def predict(self, flight: RealFlight, return_std: bool = False):
        """The wind ``(n, 3)`` [m/s], world frame, at every sample of ``flight`` (z: 0, the
        vertical wind is assumed zero); with ``return_std=True`` also its standard deviation
        ``(n, 3)`` [m/s] per axis (module text; z: 0). ``"clusters"`` is a classifier and
        has no std."""
        check_flight(flight)
        if not isinstance(return_std, (bool, np.bool_)):
            raise TypeError(f"return_std must be a bool, got {type(return_std).__name__}")
        if not (hasattr(self, "model_") or hasattr(self, "laps_")):
            raise ValueError("this WindEstimator is not fitted: call fit(flights) first")
        if self.method == "clusters":
            if return_std:
                raise ValueError("method 'clusters' is a classifier (it names a trained "
                                 "wind): it gives no std; use 'drag' or 'ekf'")
            return self._predict_laps(flight)
        self._check_cutoff(flight)
        model, offset_var = self.model_, None
        if self.tilt:
            model, offset_var = self._offset_model(flight)
        if self.method == "drag":
            W, var = self._predict_drag(flight, model)
        else:
            W, var = self._predict_ekf(flight, model)
        mean = np.zeros((flight.n_samples, 3))
        mean[:, :2] = W
        if not np.all(np.isfinite(mean)):
            raise ValueError(f"flight {flight.source!r}: the drag model cannot be inverted on "
                             f"it (a non-finite estimate)")
        if not return_std:
            return mean
        std = np.zeros_like(mean)
        speed = np.linalg.norm(W, axis=1)
        for ax in (0, 1):
            a, b = self.flight_[ax]
            # the flight mean's error: the controllers' spread, or with tilt=True what is
            # left of it once the flight's own offset is estimated (its posterior)
            std[:, ax] = np.sqrt(var[:, ax] + (a + b * speed ** 2 if offset_var is None
                                               else offset_var[ax]))
        return mean, std

    def offset(self, flight: RealFlight):
        """``tilt=True``: the flight's own offset ``(mean, std)``, each (2,) [N per hover
        thrust], estimated from the flight without its wind (module text)."""
        check_flight(flight)
        if not hasattr(self, "tilt_"):
            raise ValueError("offset needs an estimator fitted with tilt=True (method 'drag' "
                             "or 'ekf')")
        r, P = self._offset(flight)
        return r, np.sqrt(np.diag(P))

    def _offset(self, flight):
        sig = signals(flight, None)
        keep = sig["t"] >= self.skip
        if keep.sum() < MIN_SAMPLES:
            keep[:] = True
        sig = {k: v[keep] for k, v in sig.items()}
        coef, z_var, reach, trained, power = self.tilt_
        speed2 = float(np.sum(self.model_.invert(sig).mean(axis=0) ** 2))
        r_var = [self.model_.gain ** 2 * max(a + b * speed2, 1e-12) for a, b in self.flight_]
        d2 = float(np.min((np.asarray(trained) - math.sqrt(speed2)) ** 2))
        z_var = z_var + (reach * d2 if d2 > 0 else 0.0)
        if coef is None or not math.isfinite(z_var):
            return np.zeros(2), np.diag(r_var)  # off the fitted winds: the prior alone
        try:
            return tilted(self.model_, sig, coef, power, z_var, r_var, self.mass * 9.81)
        except ValueError as e:
            raise ValueError(f"flight {flight.source!r}: {e}") from None

    def _offset_model(self, flight):
        """The model with the flight's own offset added, and the variance (2,) it adds to
        the wind [m^2/s^2]."""
        from dataclasses import replace

        r, P = self._offset(flight)
        sig = signals(flight, None)
        H = self.model_.gain * self.model_.scale(sig)[:, None, None] * sig["RT"][:, :2, :2]
        Hi = np.linalg.inv(H).mean(axis=0)
        model = replace(self.model_, offset=tuple(float(x) for x in
                                                  np.asarray(self.model_.offset) + r))
        return model, np.diag(Hi @ P @ Hi.T)

    def _predict_drag(self, flight, model):
        W = model.invert(signals(flight, self.cutoff))
        speed2 = np.sum(W ** 2, axis=1)
        var = np.column_stack([a + b * speed2 for a, b in self.noise_])
        return W, var

    def _predict_ekf(self, flight, model):
        sig = signals(flight, None)
        starts = block_starts(len(sig["t"]), flight_dt(flight), self.update_period)
        a, b = self.block_noise_
        q = self.sigma_wind_rate ** 2 * self.update_period
        window = (max(1, int(round(self.innovation_window / self.update_period)))
                  if self.innovation_window > 0 else 0)
        return kalman(model, sig, starts, q, lambda s: math.sqrt(a + b * s * s), window)

    def _predict_laps(self, flight):
        dtw = softdtw_engine().dtw  # the kernels load when a lap is compared, not on import
        laps, starts = self._lap_windows(flight)
        train, query = self.laps_ / self.scale_, laps / self.scale_
        D = np.array([[dtw(q, x) for x in train] for q in query])
        speed = self.lap_winds_[np.argsort(D, axis=1)[:, :self.neighbours]].mean(axis=1)
        t = flight.arrays["t"]
        lap = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(speed) - 1)
        return speed[lap][:, None] * self.direction
