"""RotorPy's wind filters (``WindEKF``, ``WindUKF``) as the model-based peer of the clustering.

This module owns how the filters that ship with RotorPy are run on uavwind's flights, the way
a user would run them:

* :func:`calibrate_drag` -- the drag coefficients the filters need, identified as RotorPy's
  own wind-filter example does: a calibration flight in still air, and per body axis a least
  squares fit of the accelerometer's drag part against ``-|v_b| v_b / m`` (this absorbs the
  rotor drag the filters do not model);
* :func:`run_filter` -- one filter over one environment of a 100 Hz flight: mocap attitude and
  velocity without noise, the accelerometer with RotorPy's IMU noise (seeded), the commanded
  collective thrust and the true body rates as inputs, RotorPy's default tuning (``Q``, ``R``,
  ``P0``, ``xhat0``); the body-frame wind estimate is turned into the world frame with the true
  attitude;
* :func:`filter_comparison` -- per setting, flights drawn with the setting's own sampler (the
  loops of Exp 11) or level hover probes (the flights the filters are designed for): each
  filter's wind error against the wind met (RMSE over environments of the estimate averaged
  over the last 4 s) and whether a two-means split of the estimates reproduces the groups.

The filters model only quadratic frame drag and near-level flight; where one diverges (a
non-finite estimate, or an error above :data:`DIVERGED`), the table says so rather than
averaging it in.
"""

from __future__ import annotations

import copy
import functools
import math

import numpy as np
import pandas as pd

from ..core.checks import check_array, check_choice, check_instance, check_scalar
from ..core.store import get_or_compute
from ..core.parallel import check_jobs, pin_threads
from ..core.seeding import child_rng, child_seed, root_seed
from ..method.baseline import two_means
from ..sim.actions import AttitudeSequence, ThrustSequence, sample_attitude
from ..sim.dynamics import simulate_flight
from ..sim.flight import Flight
from ..sim.multirotor import Multirotor
from ..sim.observation import rotorpy_imu_noise
from ..sim.setting import Setting
from ..sim.wind import ConstantWind
from ..study.profiles import DEFAULT_SEED
from ..study.registry import EXPERIMENTS, computes
from ..study.cache import RESULTS_VERSION

__all__ = ["filter_table", "QUICK_SCENARIOS", "FILTERS", "DIVERGED", "calibrate_drag", "run_filter", "filter_comparison"]

#: The filters: RotorPy's names.
FILTERS = ("ekf", "ukf")
#: A wind error above this [m/s] (or a non-finite one) counts as a diverged filter.
DIVERGED = 100.0
#: The sample rate the filters are designed for [s] (RotorPy's example: 100 Hz).
FILTER_DT = 0.01
#: Bump when the comparison's numbers change (part of its cache digest).
FILTERS_VERSION = "1"
#: The tail of a flight whose estimates are averaged [s].
TAIL = 4.0
#: Shortest calibration flight [s]: two attitude segments, time for the vehicle to reach
#: speeds whose quadratic drag shows (0.01 s fitted c_D,y = 4930 from nothing).
MIN_CALIBRATION = 2.0
#: Smallest RMS body velocity [m/s] along each axis a drag coefficient is fitted from (the
#: default 12-s flights reach 2 m/s or more; a level flight reaches 1e-15 m/s).
MIN_EXCITATION = 0.5
#: The comparison table's columns, in order.
COLUMNS = ("filter", "flight", "rmse", "diverged", "correct", "drag_x", "drag_y", "drag_z")


def _filter_class(kind):
    check_choice(kind, "kind", FILTERS)
    if kind == "ekf":
        from rotorpy.estimators.wind_ekf import WindEKF
        return WindEKF
    try:
        import filterpy  # noqa: F401 -- RotorPy's UKF fails silently without it
    except ImportError as exc:
        raise ImportError("RotorPy's WindUKF needs filterpy: pip install 'uavwind[filter]'") \
            from exc
    from rotorpy.estimators.wind_ukf import WindUKF
    return _lean_ukf(WindUKF)


@functools.cache
def _lean_ukf(base):
    """RotorPy's ``WindUKF`` (``base``) with its process and measurement models ``f`` and
    ``h`` evaluated on Python floats: the same expressions, operation for operation, so the
    same doubles (``tests/test_future_work.py`` checks every estimate with ``==``), without
    building numpy arrays and identity matrices for each of the 19 sigma points of every
    step; and the filterpy filter under it made lean in the same way (:func:`_lean_filter`).
    Where a Python float would raise (a square past the largest double: ``OverflowError``),
    the step is RotorPy's own numpy one, whose inf the filter then reads as diverged."""

    def airspeed(xk):  # RotorPy's va: the norm of the air-relative velocity
        return math.sqrt((xk[3]-xk[6])**2 + (xk[4]-xk[7])**2 + (xk[5]-xk[8])**2)

    class LeanWindUKF(base):
        def f(self, xk, dt):
            try:
                return self._f(xk.tolist(), self.uk.tolist(), dt)
            except OverflowError:  # a square past the largest double: numpy's inf, not an error
                return super().f(xk, dt)

        def _f(self, xk, uk, dt):
            va = airspeed(xk)
            xdot = [xk[2]*uk[2] + uk[3],
                    uk[2] - xk[2]*uk[3],
                    uk[1] + xk[2]*xk[1]*uk[2] + xk[0]*uk[3],
                    -self.c_Dx/self.mass*(xk[3]-xk[6])*va + self.g*xk[1] + xk[4]*uk[3] - xk[5]*uk[1],
                    -self.c_Dy/self.mass*(xk[4]-xk[7])*va - self.g*xk[2] + xk[5]*uk[1] - xk[3]*uk[3],
                    uk[0] - self.c_Dz/self.mass*(xk[5]-xk[8])*va - self.g + xk[3]*uk[2] - xk[4]*uk[1],
                    0, 0, 0]
            return np.array([a + b*dt for a, b in zip(xk, xdot)])

        def h(self, xk):
            try:
                return self._h(xk.tolist(), self.uk.tolist())
            except OverflowError:
                return super().h(xk)

        def _h(self, xk, uk):
            va = airspeed(xk)
            return np.array(xk[:6] + [-self.c_Dx/self.mass*(xk[3]-xk[6])*va,
                                      -self.c_Dy/self.mass*(xk[4]-xk[7])*va,
                                      uk[0]-self.c_Dz/self.mass*(xk[5]-xk[8])*va])

        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            _lean_filter(self.filter)

    LeanWindUKF.__name__ = LeanWindUKF.__qualname__ = "LeanWindUKF"
    return LeanWindUKF


def _lean_filter(ukf):
    """Turn filterpy's ``UnscentedKalmanFilter`` ``ukf`` (as RotorPy's ``WindUKF`` builds it:
    Merwe's scaled sigma points on scipy's Cholesky factor, ``np.subtract`` residuals,
    ``np.add``, no mean functions) into :func:`_lean_ukf_class`'s: the same predict and
    update, operation for operation, without filterpy's per-sigma-point Python loops."""
    from filterpy.kalman import MerweScaledSigmaPoints
    from scipy.linalg import cholesky

    pts = ukf.points_fn
    if not (type(pts) is MerweScaledSigmaPoints and pts.sqrt is cholesky
            and pts.subtract is np.subtract and ukf.residual_x is np.subtract
            and ukf.residual_z is np.subtract and ukf.state_add is np.add
            and ukf.x_mean is None and ukf.z_mean is None):
        return ukf  # not the filter whose steps the lean class repeats: left as it is
    ukf.__class__ = _lean_ukf_class(type(ukf))
    return ukf


@functools.cache
def _lean_ukf_class(base):
    """filterpy's ``UnscentedKalmanFilter`` (``base``) whose ``predict``, ``update`` and
    ``cross_variance`` compute what filterpy's do, the same numpy operations on the same
    operands (so the same doubles: ``tests/test_future_work.py`` checks every estimate against
    RotorPy's own filter with ==), on all sigma points at once where filterpy loops over them:

    * the sigma points: ``x - (-U[k])`` and ``x - U[k]`` for every row ``k`` of the Cholesky
      factor in one subtraction each, the factor from LAPACK's ``potrf`` as scipy's
      ``cholesky`` calls it (its errors: a non-finite matrix is a ``ValueError``, one that is
      not positive definite a ``LinAlgError``);
    * the cross variance: each term ``Wc[i] * outer(dx_i, dz_i)`` at once, then added to the
      zero matrix in filterpy's order.

    Any other call (another fx/hx, R, UT, or keyword arguments) is filterpy's own."""
    from filterpy.kalman import unscented_transform
    from scipy.linalg import LinAlgError
    from scipy.linalg.lapack import get_lapack_funcs

    potrf, = get_lapack_funcs(("potrf",), (np.zeros((1, 1)),))

    def sigma_points(pts, x, P):
        n = pts.n
        lambda_ = pts.alpha**2 * (n + pts.kappa) - n
        a = np.asarray_chkfinite((lambda_ + n) * P)  # scipy's check_finite: a ValueError
        U, info = potrf(a, lower=False, overwrite_a=False, clean=True)
        if info > 0:
            raise LinAlgError(f"{info}-th leading minor of the array is not positive definite")
        if info < 0:
            raise ValueError(f"LAPACK reported an illegal value in {-info}-th argument on "
                             f"entry to \"POTRF\".")
        sigmas = np.zeros((2 * n + 1, n))
        sigmas[0] = x
        sigmas[1:n + 1] = np.subtract(x, -U)
        sigmas[n + 1:] = np.subtract(x, U)
        return sigmas

    class LeanUnscentedKalmanFilter(base):
        def predict(self, dt=None, UT=None, fx=None, **fx_args):
            if UT is not None or fx is not None or fx_args or np.size(self.x) != self.points_fn.n:
                return super().predict(dt, UT, fx, **fx_args)
            if dt is None:
                dt = self._dt
            sigmas = sigma_points(self.points_fn, self.x, np.atleast_2d(self.P))
            for i, s in enumerate(sigmas):
                self.sigmas_f[i] = self.fx(s, dt)
            self.x, self.P = unscented_transform(self.sigmas_f, self.Wm, self.Wc, self.Q,
                                                 None, np.subtract)
            self.sigmas_f = sigma_points(self.points_fn, self.x, np.atleast_2d(self.P))
            self.x_prior = np.copy(self.x)
            self.P_prior = np.copy(self.P)

        def update(self, z, R=None, UT=None, hx=None, **hx_args):
            if z is None or R is not None or UT is not None or hx is not None or hx_args:
                return super().update(z, R, UT, hx, **hx_args)
            self.sigmas_h = np.atleast_2d([self.hx(s) for s in self.sigmas_f])
            zp, self.S = unscented_transform(self.sigmas_h, self.Wm, self.Wc, self.R, None,
                                             np.subtract)
            self.SI = self.inv(self.S)
            Pxz = self.cross_variance(self.x, zp, self.sigmas_f, self.sigmas_h)
            self.K = np.dot(Pxz, self.SI)
            self.y = np.subtract(z, zp)
            self.x = np.add(self.x, np.dot(self.K, self.y))
            self.P = self.P - np.dot(self.K, np.dot(self.S, self.K.T))
            self.z = copy.deepcopy(z)
            self.x_post = self.x.copy()
            self.P_post = self.P.copy()
            self._log_likelihood = None
            self._likelihood = None
            self._mahalanobis = None

        def cross_variance(self, x, z, sigmas_f, sigmas_h):
            dx = np.subtract(sigmas_f, x)
            dz = np.subtract(sigmas_h, z)
            terms = self.Wc[:, None, None] * (dx[:, :, None] * dz[:, None, :])
            Pxz = np.zeros((sigmas_f.shape[1], sigmas_h.shape[1]))
            for t in terms:
                Pxz += t
            return Pxz

    LeanUnscentedKalmanFilter.__name__ = LeanUnscentedKalmanFilter.__qualname__ = \
        "LeanUnscentedKalmanFilter"
    return LeanUnscentedKalmanFilter


def _rotation(q):
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = (q[..., i] for i in range(4))
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                     np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                     np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)],
                    axis=-2)


def _commanded_thrust(vehicle, action, times):
    """The collective thrust commanded at each time [N]."""
    commands = vehicle.segment_commands(action)
    seg = np.maximum(action.segment(times), 0)
    return np.array([commands[int(k)][0] for k in seg])


def calibrate_drag(vehicle: Multirotor, seed: int = 0, duration: float = 12.0) -> np.ndarray:
    """The drag coefficients ``(c_Dx, c_Dy, c_Dz)`` [N/(m/s)^2] a user would give the filters:
    fitted on a calibration flight in still air (attitude actions drawn from ``seed``), per
    body axis, by least squares of ``a_b - T/m e_z = -(c/m) |v_b| v_b``.

    Raises
    ------
    ValueError
        If ``duration`` is below :data:`MIN_CALIBRATION` seconds, or the flight's RMS body
        velocity along an axis stays below :data:`MIN_EXCITATION` (nothing to fit there).
    """
    check_instance(vehicle, "vehicle", Multirotor)
    root = root_seed(seed)
    duration = check_scalar(duration, "duration", high=1e4)
    if duration < MIN_CALIBRATION:
        raise ValueError(f"duration must be >= {MIN_CALIBRATION:g} s for a drag fit (at least "
                         f"two attitude segments: the vehicle needs time to reach speeds whose "
                         f"quadratic drag shows), got {duration:g} s")
    action = sample_attitude(child_rng(root, 0),
                             n_changes=max(int(math.ceil(duration)) - 1, 0), duration=duration,
                             max_magnitude=min(50.0, vehicle.max_thrust))
    f = simulate_flight(action, ConstantWind([[0.0, 0.0, 0.0]]), uav=vehicle, dt=FILTER_DT,
                        duration=duration)
    R = _rotation(f.attitudes[0])
    vb = np.einsum("nji,nj->ni", R, f.ground_velocities[0])
    T = _commanded_thrust(vehicle, action, f.times - FILTER_DT)
    drag = f.specific_forces[0].copy()
    drag[:, 2] -= T / vehicle.mass
    rms = np.sqrt(np.mean(vb * vb, axis=0))
    if np.any(rms < MIN_EXCITATION):
        axes = ", ".join(f"{a} {v:.2g} m/s" for a, v, w in zip("xyz", rms, rms < MIN_EXCITATION)
                         if w)
        raise ValueError(f"calibrate_drag: the calibration flight's RMS body velocity ({axes}) "
                         f"is below {MIN_EXCITATION:g} m/s, too slow to fit a quadratic drag "
                         f"(the fit would read noise); fly longer or draw another seed")
    x = -np.abs(np.linalg.norm(vb, axis=1))[:, None] * vb / vehicle.mass
    return np.array([max(float(np.dot(x[:, i], drag[:, i]) / np.dot(x[:, i], x[:, i])), 1e-9)
                     for i in range(3)])


def run_filter(flight, action, vehicle: Multirotor, kind: str, drag, env: int = 0,
               seed: int | np.random.SeedSequence | None = 0) -> np.ndarray:
    """The filter's wind estimate along one environment of a 100 Hz ``flight``, world frame
    [m/s], shape (n_steps, 3) (NaN from the first non-finite step on).

    ``flight`` must be a multirotor's (:func:`~uavwind.sim.dynamics.simulate_flight` with
    ``uav=Multirotor()``: attitudes, body rates, specific forces) of at least two samples,
    ``drag`` three finite coefficients > 0 [N/(m/s)^2], ``env`` one of its environments.
    """
    check_choice(kind, "kind", FILTERS)
    check_instance(flight, "flight", Flight)
    check_instance(action, "action", (ThrustSequence, AttitudeSequence))
    check_instance(vehicle, "vehicle", Multirotor)
    if flight.attitudes is None or flight.specific_forces is None or flight.body_rates is None:
        raise ValueError("flight must be a multirotor's (attitudes, body rates and specific "
                         "forces): fly it with simulate_flight(..., uav=Multirotor()); a point "
                         "mass has no attitude for the filters")
    if flight.times.size < 2:
        raise ValueError(f"flight must hold at least 2 samples, got {flight.times.size}")
    drag = check_array(drag, "drag", shape=(3,))
    if np.any(drag <= 0):
        raise ValueError(f"drag must hold three coefficients > 0 [N/(m/s)^2], got "
                         f"{drag.tolist()}")
    env = check_scalar(env, "env", low=0, high=flight.n_env - 1, integer=True)
    rng = np.random.default_rng(root_seed(seed))
    cls = _filter_class(kind)
    qp = vehicle.quad_params()
    qp.update(c_Dx=float(drag[0]), c_Dy=float(drag[1]), c_Dz=float(drag[2]))
    dt = float(flight.times[1] - flight.times[0])
    filt = cls(qp, dt=dt)
    accel_noise = rotorpy_imu_noise(dt).acceleration
    T = _commanded_thrust(vehicle, action, flight.times - dt)
    R = _rotation(flight.attitudes[env])
    out = np.full((flight.times.size, 3), np.nan)
    with np.errstate(all="ignore"):
        for j in range(flight.times.size):
            q = flight.attitudes[env, j] / np.linalg.norm(flight.attitudes[env, j])
            accel = flight.specific_forces[env, j] + accel_noise * rng.standard_normal(3)
            try:
                res = filt.step({"w": flight.body_rates[env, j]}, {"cmd_thrust": T[j]},
                                {"accel": accel}, {"q": q, "v": flight.ground_velocities[env, j]})
            except (np.linalg.LinAlgError, ValueError):
                break
            wb = np.asarray(res["filter_state"])[6:9]
            if not np.all(np.isfinite(wb)):
                break
            out[j] = R[j] @ wb
    return out


def filter_comparison(setting: Setting, n_flights: int = 5, seed: int = 0, probe: bool = False,
                      kinds=FILTERS, n_jobs: int | None = None, results=None) -> pd.DataFrame:
    """Both filters on ``n_flights`` flights of ``setting`` (a multirotor setting), at 100 Hz.

    Parameters
    ----------
    setting : Setting
        Its vehicle must be a :class:`~uavwind.sim.multirotor.Multirotor`.
    n_flights : int
        Flights, each through all of the setting's environments, in [1, 1000].
    seed : int
        Flight ``i`` draws its action from ``(i, 0)`` and its turbulence from ``(i, 1)``, as
        loop ``i`` of a search does; the filters' noise from ``(i, 3)``.
    probe : bool
        Fly level hover probes (collective thrust = weight, 12 s) instead of the setting's
        sampled actions: the flights the filters are designed for.
    n_jobs : int, optional
        Worker processes over flights (-1/None: all cores); the table does not depend on it.
    results : path-like, optional
        The result folder (:func:`~uavwind.core.store.results_dir`): the table is kept in
        its ``filters/`` folder by :func:`~uavwind.core.store.get_or_compute` under a key of
        everything that determines it, and read back (a damaged, tampered or unsigned file is
        moved aside, with a warning naming it, and recomputed).

    Returns
    -------
    pandas.DataFrame
        One row per flight and filter: ``filter``, ``flight``, ``rmse`` [m/s] (over the
        environments whose filter stayed finite and within :data:`DIVERGED`), ``diverged``
        (how many environments diverged), ``correct`` (a two-means split of the estimates
        reproduces the groups; False if any diverged) and ``drag_x``, ``drag_y``, ``drag_z``
        (the calibrated c_D [N/(m/s)^2]).
    """
    check_instance(setting, "setting", Setting)
    check_instance(setting.uav, "setting.uav", Multirotor)
    n_flights = check_scalar(n_flights, "n_flights", low=1, high=1000, integer=True)
    seed = check_scalar(seed, "seed", low=0, high=2 ** 63 - 1, integer=True)
    if not isinstance(probe, (bool, np.bool_)):
        raise TypeError(f"probe must be a bool, got {type(probe).__name__}")
    if isinstance(kinds, str):
        kinds = (kinds,)
    kinds = tuple(check_choice(k, "kinds", FILTERS) for k in kinds)
    if not kinds or len(set(kinds)) != len(kinds):
        raise ValueError(f"kinds must name each filter of {list(FILTERS)} at most once, and "
                         f"one at least, got {list(kinds)}")
    n_jobs = check_jobs(n_jobs)

    def compute():
        root = root_seed(seed)
        drag = calibrate_drag(setting.uav, seed=child_seed(root, 10 ** 6))
        from joblib import Parallel, delayed
        chunks = Parallel(n_jobs=n_jobs)(delayed(_one_flight)(setting, i, root, probe, kinds,
                                                              drag)
                                         for i in range(n_flights))
        return pd.DataFrame([r for rows in chunks for r in rows], columns=list(COLUMNS))
    # the key is the one these tables had before the store: cached tables keep their names
    key = {"setting": setting.key(), "n_flights": n_flights, "seed": seed,
           "probe": bool(probe), "kinds": kinds, "filters": FILTERS_VERSION}
    return get_or_compute("filters", key, compute,
                          lambda df: _table_problem(df, n_flights, kinds, setting.n_env),
                          results, version=RESULTS_VERSION,
                          what=f"filter comparison ({setting.name or setting.key()})")


def _table_problem(df, n_flights, kinds, n_env):
    """Why a cached comparison table cannot be trusted (empty string: it can)."""
    if list(df.columns) != list(COLUMNS):
        return f"columns {list(df.columns)}"
    want = [(i, k) for i in range(n_flights) for k in kinds]
    if len(df) != len(want):
        return f"{len(df)} rows, expected {len(want)}"
    if list(zip(df["flight"].tolist(), df["filter"].tolist())) != want:
        return "rows out of order (flight by flight, each filter in turn)"
    diverged = df["diverged"].to_numpy()
    if df["diverged"].dtype.kind not in "iu" or np.any((diverged < 0) | (diverged > n_env)):
        return f"diverged counts outside [0, {n_env}]"
    rmse = df["rmse"].to_numpy(dtype=float)
    if np.any(np.isnan(rmse) != (diverged == n_env)):
        return "an rmse missing where some environment stayed finite, or the reverse"
    ok = np.isfinite(rmse)
    if np.any(np.isinf(rmse)) or np.any((rmse[ok] < 0) | (rmse[ok] > DIVERGED)):
        return f"rmse outside [0, {DIVERGED:g}] m/s"
    if df["correct"].dtype.kind != "b" or np.any(df["correct"].to_numpy() & (diverged > 0)):
        return "a correct split where an environment diverged"
    drag = df[["drag_x", "drag_y", "drag_z"]].to_numpy(dtype=float)
    if not (np.all(np.isfinite(drag)) and np.all(drag > 0) and np.all(drag == drag[0])):
        return "drag coefficients that are not one positive triple"
    return ""


def _one_flight(setting, i, root, probe, kinds, drag):
    """The rows of flight ``i`` of :func:`filter_comparison` (in a worker process)."""
    pin_threads()
    vehicle = setting.uav
    rows = []
    if probe:
        action = ThrustSequence([0.0], [vehicle.weight], [[0.0, 0.0, 1.0]])
    else:
        action = setting.sample_thrust(child_rng(root, i, 0))
    wind = setting.wind(child_seed(root, i, 1))
    f = simulate_flight(action, wind, uav=vehicle, dt=FILTER_DT, duration=setting.duration,
                        start_altitude=setting.start_altitude)
    tail = f.times > f.times[-1] - TAIL
    truth = f.winds[:, tail].mean(axis=1)
    for kind in kinds:
        est = np.array([run_filter(f, action, vehicle, kind, drag, env=e,
                                   seed=child_seed(root, i, 3, e))[tail].mean(axis=0)
                        for e in range(f.n_env)])
        err = np.linalg.norm(est - truth, axis=1)
        bad = ~np.isfinite(err) | (err > DIVERGED)
        ok = ~bad
        correct = False
        if not bad.any():
            labels = two_means(est)
            g = setting.groups
            correct = bool(np.array_equal(labels, g) or np.array_equal(labels, 1 - g))
        rows.append({"filter": kind, "flight": i,
                     "rmse": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else np.nan,
                     "diverged": int(bad.sum()), "correct": correct,
                     "drag_x": float(drag[0]), "drag_y": float(drag[1]),
                     "drag_z": float(drag[2])})
    return rows


#: The scenarios of Exp 11 (positions in its order) the filter table flies at a profile
#: other than ``"paper"``: light constant vs light shear (Exp 11's CEM scenario, where
#: position alone struggles). The paper profile flies all four. A comparison costs about
#: 14 CPU-s (10 environments, two filters in Python at 100 Hz): the quick table's 2
#: instead of 8 keep it near half a minute of CPU.
QUICK_SCENARIOS = (2,)


@computes("exp11_filter_table", long=True, title="Exp 11: RotorPy's wind filters",
          notebook="exp11_future_work.md")
def filter_table(profile: str = "quick", seed: int | None = None, n_jobs: int | None = None,
                 results=None) -> pd.DataFrame:
    """Experiment 11's filter table: both filters on hover probes and on the loops' actions
    of each scenario of Exp 11 (its thrust-action, position, noise-free cases; at a profile
    other than ``"paper"`` only those of :data:`QUICK_SCENARIOS`), ``n_flights``
    3 at the paper profile and 1 otherwise; one row per scenario, kind of flight and filter
    with the mean wind RMSE [m/s], the diverged environments, the share of flights whose
    estimates split into the groups (``correct_rate``, in [0, 1]) and the flights run. Each
    :func:`filter_comparison` is cached, so the fill computes this and the page reads it."""
    seed = DEFAULT_SEED if seed is None else seed
    n_flights = 3 if profile == "paper" else 1
    rows = []
    cases = [(c.labels["scenario"], c.setting) for c in EXPERIMENTS["exp11"].cases()
             if c.labels["action"] == "thrust" and c.labels["observation"] == "position"
             and c.labels["noise"] == "none"]
    if profile != "paper":
        cases = [cases[i] for i in QUICK_SCENARIOS]
    from joblib import Parallel, delayed
    runs = [(scen, setting, probe) for scen, setting in cases for probe in (True, False)]
    # one comparison per worker (each cached on its own), in a fixed order: the table does
    # not depend on the number of workers
    tables = Parallel(n_jobs=check_jobs(n_jobs))(
        delayed(filter_comparison)(setting, n_flights=n_flights, seed=seed, probe=probe,
                                   n_jobs=1, results=results)
        for _, setting, probe in runs)
    for (scen, _, probe), df in zip(runs, tables):
        for kind, sub in df.groupby("filter"):
            rows.append({"scenario": scen,
                         "flights": "hover probes" if probe else "the loops' actions",
                         "filter": kind, "rmse": float(sub["rmse"].mean()),
                         "diverged": int(sub["diverged"].sum()),
                         "correct_rate": float(sub["correct"].mean()),
                         "n_flights": len(sub)})
    return pd.DataFrame(rows)
