"""Searching for informative thrust sequences: random exploration and CEM.

This module owns the loops of the paper (replication notes, decisions 7 and 8):

* :func:`evaluate` -- fly a batch of thrust sequences through a setting and score each;
* :func:`random_search` -- ``n_loops`` fresh random thrust sequences, one row each;
* :func:`cem` -- the Cross-Entropy Method over magnitudes and direction components;
* :class:`CEMRun` -- one CEM run stepped from outside (ask for an iteration's samples, tell
  their results), which the fill uses to hand an iteration's samples out as tasks.

Randomness: one ``numpy.random.SeedSequence`` per call. Loop ``i`` draws its
thrust from the child with spawn key ``(i, 0)`` and its turbulence from
``(i, 1)``; CEM iteration ``t`` draws its samples from ``(t + 1,)`` and sample
``j``'s turbulence from ``(t + 1, j + 1)``. Seeds are fixed before any work is
handed out, so results are bit-identical whatever the number of workers or the
order in which they finish. Thrust sequences depend only on the seed and the
loop index, so two settings run with the same seed fly the same manoeuvres
(common random numbers).

Work is spread with joblib (``n_jobs``; default all cores). Any joblib backend
works, including Dask through ``joblib.parallel_config(backend="dask")``.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core.checks import check_choice, check_instance, check_scalar
from ..core.parallel import check_jobs, pin_threads, stop_workers
from ..core.seeding import child_rng, child_seed, root_seed
from ..core.stats import summarise
from ..sim.actions import MAX_THRUST, ThrustSequence
from ..sim.manoeuvres import WAYPOINT_CEM_STD, waypoints_from_vector
from ..sim.references import Reference, WaypointSpline
from ..sim.multirotor import GroundContact, Multirotor
from ..sim.setting import Setting
from .baseline import baseline_metrics
from .clustering import ClusteringParams, LoopResult, LoopScorer, check_engine

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["evaluate", "random_search", "cem", "CEMRun", "CEMResult", "cem_step"]


def _one_loop(setting, thrust, wind_seed, scorer, pin=False):
    """One loop of ``setting`` flown with ``thrust`` in the winds of ``wind_seed``, scored by
    ``scorer`` (a :class:`~uavwind.method.clustering.LoopScorer`: checked once, by
    :func:`evaluate`)."""
    if pin:  # inside a worker process: do not oversubscribe the cores
        pin_threads()
    obs, finish = _fly(setting, thrust, wind_seed)
    return finish(None if obs is None else scorer(obs))


def _block(setting, thrusts, wind_seeds, scorer):
    """The loops of one block, flown one after another, then clustered side by side
    (:meth:`~uavwind.method.clustering.LoopScorer.many`): the results :func:`_one_loop`
    gives each, in order."""
    flown = [_fly(setting, th, ws) for th, ws in zip(thrusts, wind_seeds)]
    todo = [i for i, (obs, _) in enumerate(flown) if obs is not None]
    scored = dict(zip(todo, scorer.many([flown[i][0] for i in todo])))
    return [finish(scored.get(i)) for i, (_, finish) in enumerate(flown)]


def _fly(setting, thrust, wind_seed):
    """``(trajectories, finish)`` of one loop: what the scorer clusters (None for a loop
    that has none: a reference the vehicle could not fly) and ``finish``, which makes the
    loop's :class:`~uavwind.method.clustering.LoopResult` from the scored one (adding the
    flight's metrics, measured here, so the flight itself is not kept)."""
    multirotor = isinstance(setting.uav, Multirotor)
    if setting.plain and not multirotor:
        return setting.simulate(thrust, seed=wind_seed), _as_scored
    try:
        obs, flight, positions = setting.observe(thrust, seed=wind_seed)
    except GroundContact as exc:
        if not isinstance(thrust, Reference):
            raise
        crashed = _crashed(setting, exc)
        return None, lambda _: crashed
    metrics = {}
    if multirotor:  # how often the vehicle's limits bound in this loop
        metrics.update(tilt_limited=flight.tilt_limited, motor_limited=flight.motor_limited)
    if isinstance(thrust, Reference):  # what the flown reference asked of the vehicle
        metrics.update(_reference_metrics(flight), crashed=0.0, crash_time=float("nan"))
    if setting.baseline:
        metrics.update(baseline_metrics(flight, positions, thrust, setting.uav, setting.dt,
                                        setting.groups, start_position=flight.start))
    if not metrics:
        return obs, _as_scored
    return obs, lambda res: replace(res, metrics=metrics)


def _as_scored(res):
    return res


def _crashed(setting, exc):
    """The row of a reference loop the vehicle could not fly: it would have gone below the
    ground in some environment (:class:`~uavwind.sim.multirotor.GroundContact`), so there is
    no trajectory to cluster. Scored as the paper scores a loop whose clusters are not the
    groups: 0, one cluster, not correct; ``crashed`` 1 and ``crash_time`` [s] say why."""
    n = setting.n_env
    nan = float("nan")
    return LoopResult(score=0.0, silhouette=nan, labels=np.zeros(n, dtype=int), correct=False,
                      n_iter=0, groups=setting.groups,
                      metrics={"tilt_limited": 0.0, "motor_limited": nan, "max_tilt": nan,
                               "max_tracking_error": nan, "min_altitude": 0.0,
                               "min_thrust": nan, "flipped": nan, "crashed": 1.0,
                               "crash_time": exc.time})


def _reference_metrics(flight):
    """The largest tilt flown [deg] (and ``flipped``: 1 when it passed 90, upside down) and
    tracking error [m], the lowest height [m] and the lowest commanded collective thrust [N],
    over the environments of a reference flight."""
    q = flight.attitudes / np.linalg.norm(flight.attitudes, axis=-1, keepdims=True)
    cos_tilt = 1 - 2 * (q[..., 0] ** 2 + q[..., 1] ** 2)
    err = np.linalg.norm(flight.positions - flight.references, axis=-1)
    tilt = np.degrees(np.arccos(np.clip(cos_tilt, -1, 1)))
    return {"max_tilt": float(tilt.max()), "flipped": float(tilt.max() > 90.0),
            "max_tracking_error": float(err.max()),
            "min_altitude": float(flight.positions[..., 2].min()),
            "min_thrust": float(flight.thrust_commands.min())}


#: Loops clustered side by side in :func:`evaluate` with ``n_jobs=1`` (the fill's tasks):
#: their k-means fits share the barycentre kernel's vectors, which one loop's two clusters
#: of 5 or 10 series leave a quarter to a third idle; the results do not depend on it.
BLOCK = 16


def evaluate(setting: Setting, thrusts: Sequence[ThrustSequence],
             wind_seeds: Sequence[np.random.SeedSequence], engine: str | None = None,
             n_jobs: int | None = None, progress: bool = True, desc: str = "loops",
             **params: float | str) -> list[LoopResult]:
    """Score every thrust sequence of ``thrusts`` on ``setting``.

    Parameters
    ----------
    setting : Setting
    thrusts : sequence of ThrustSequence
    wind_seeds : sequence of SeedSequence
        Turbulence seed of each loop (same length as ``thrusts``).
    engine : str, optional
        Clustering engine (see :func:`uavwind.method.clustering.score_loop`).
    n_jobs : int, optional
        Worker processes (joblib); -1 or None = all cores, 1 = in this process, in blocks
        of :data:`BLOCK` loops clustered side by side (the same results).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    list of LoopResult, in the order of ``thrusts``.
    """
    from joblib import Parallel, delayed

    check_instance(setting, "setting", Setting)
    if len(thrusts) != len(wind_seeds):
        raise ValueError(f"thrusts and wind_seeds must have the same length, "
                         f"got {len(thrusts)} and {len(wind_seeds)}")
    n_jobs = check_jobs(n_jobs)
    scorer = LoopScorer.of(setting.groups, engine, **params)
    tasks = [delayed(_one_loop)(setting, th, ws, scorer, pin=True)
             for th, ws in zip(thrusts, wind_seeds)]
    bar = None
    if progress:
        # the text bar (stderr), not tqdm.auto's widget: make book shows it in the
        # terminal through papermill --log-output, and the book drops stderr
        from tqdm import tqdm
        bar = tqdm(total=len(tasks), desc=desc, leave=False, file=sys.stderr)
    results = []
    if n_jobs == 1:  # blocks of BLOCK loops, each clustered side by side
        for b in range(0, len(thrusts), BLOCK):
            results += _block(setting, thrusts[b:b + BLOCK], wind_seeds[b:b + BLOCK], scorer)
            if bar is not None:
                bar.update(len(results) - bar.n)
    else:
        try:
            for res in Parallel(n_jobs=n_jobs, return_as="generator")(tasks):
                results.append(res)
                if bar is not None:
                    bar.update()
        except BaseException:  # interrupted or failed: leave no worker running
            stop_workers()
            raise
    if bar is not None:
        bar.close()
    return results


def _rows(results, thrusts):
    rows = []
    for i, (res, th) in enumerate(zip(results, thrusts)):
        # a thrust sequence's directions, or an attitude action's angles [rad]
        rows.append({"loop": i, "score": res.score, "silhouette": res.silhouette,
                     "correct": res.correct, "n_iter": res.n_iter,
                     "labels": res.labels.tolist(), **th.to_dict(), **res.metrics})
    return rows


def random_search(setting: Setting, n_loops: int = 50,
                  seed: int | np.random.SeedSequence | None = 0, n_jobs: int | None = None,
                  engine: str | None = None, progress: bool = True, loop_offset: int = 0,
                  **params: float | str) -> pd.DataFrame:
    """Random exploration: ``n_loops`` fresh thrust sequences, each scored on ``setting``.

    Parameters
    ----------
    setting : Setting
        The two environment groups, sampler, UAV and time grid.
    n_loops : int
        Number of loops, >= 1. Paper: 50 (500 for one Exp 1 case).
    seed : int or SeedSequence
        Root seed; loop ``i`` uses its children ``(i, 0)`` (thrust) and ``(i, 1)``
        (turbulence), so the first ``k`` loops do not depend on ``n_loops``.
    n_jobs : int, optional
        Worker processes; -1/None = all cores. Results do not depend on it.
    engine : str, optional
        Clustering engine.
    loop_offset : int
        Index of the first loop (to extend a run: loops ``offset .. offset+n-1``).
    **params
        Clustering parameters (see :func:`uavwind.method.clustering.score_loop`).

    Returns
    -------
    pandas.DataFrame
        One row per loop: ``loop, score, silhouette, correct, n_iter, labels,
        times, magnitudes, directions``; ``df.attrs`` holds ``max``, ``mean``,
        ``setting`` (name) and ``seed``.

    Examples
    --------
    >>> import uavwind as uw
    >>> df = random_search(uw.table3_setting(), n_loops=2, seed=1, n_jobs=1,
    ...                    progress=False, engine="tslearn")
    >>> list(df.columns[:4])
    ['loop', 'score', 'silhouette', 'correct']
    """
    check_instance(setting, "setting", Setting)
    n_loops = check_scalar(n_loops, "n_loops", low=1, high=10 ** 7, integer=True)
    loop_offset = check_scalar(loop_offset, "loop_offset", low=0, high=2 ** 62, integer=True)
    root = root_seed(seed)
    idx = range(loop_offset, loop_offset + n_loops)
    thrusts = [setting.sample_thrust(child_rng(root, i, 0)) for i in idx]
    wind_seeds = [child_seed(root, i, 1) for i in idx]
    results = evaluate(setting, thrusts, wind_seeds, engine=engine, n_jobs=n_jobs,
                       progress=progress, desc=setting.name or "random search", **params)
    df = pd.DataFrame(_rows(results, thrusts))
    df["loop"] += loop_offset
    df.attrs.update(summarise(df), setting=setting.name, seed=repr(seed))
    return df


@dataclass
class CEMResult:
    """Outcome of :func:`cem`.

    Attributes
    ----------
    history : pandas.DataFrame
        One row per iteration: ``iteration, max, mean, elite_mean, best_so_far``
        (scores) and the distribution after the update (``mu``, ``sigma``, lists).
    samples : pandas.DataFrame
        One row per evaluated sample (``iteration, sample, score, ...`` as in
        :func:`random_search`, plus ``elite``).
    best_thrust : ThrustSequence
        Best sequence found.
    best_score : float
    times : ndarray
        The change times [s] fixed for the run.
    stopped_early : bool
    """

    history: pd.DataFrame
    samples: pd.DataFrame
    best_thrust: ThrustSequence
    best_score: float
    times: np.ndarray
    stopped_early: bool


def cem_step(samples: ArrayLike, scores: ArrayLike,
             n_elite: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One CEM update (eqs CEM1-2): mean and (population) standard deviation of the
    ``n_elite`` best rows of ``samples`` (ties keep the lower index)."""
    order = np.argsort(-np.asarray(scores, dtype=float), kind="stable")
    elite = np.asarray(samples)[order[:n_elite]]
    mu = elite.mean(axis=0)
    sigma = np.sqrt(((elite - mu) ** 2).mean(axis=0))
    return mu, sigma, order[:n_elite]


class CEMRun:
    """One CEM run, stepped from outside: :meth:`ask` gives the next iteration's draws (the
    actions and their turbulence seeds), :meth:`tell` takes their loop results in the same
    order and updates the distribution, :attr:`done` says when the run is over, and
    :meth:`result` gives what :func:`cem` returns.

    :func:`cem` steps it with :func:`evaluate` (each iteration's samples over ``n_jobs``
    workers); the fill (:func:`uavwind.study.fill.fill_cache`) hands each sample out as a
    task of its own, beside other experiments' work, and steps the run as an iteration's
    last sample returns. Every draw and seed is fixed by ``seed`` and the iteration, so the
    rows are the same doubles however the samples were computed. The parameters are
    :func:`cem`'s; ``engine`` and ``params`` (the clustering parameters, checked) are carried
    for whoever scores the samples (:func:`evaluate` with them).
    """

    def __init__(self, setting: Setting, n_samples: int = 30, n_elite: int = 4,
                 max_iter: int = 20, seed: int | np.random.SeedSequence | None = 0,
                 patience: int | None = None, magnitude_mean: float = 25.0,
                 magnitude_std: float = 50.0, direction_mean: float = 0.0,
                 direction_std: float = 0.33, max_magnitude: float = MAX_THRUST,
                 rank_by: str = "score", engine: str | None = None,
                 params: Mapping[str, float | str] | None = None):
        check_instance(setting, "setting", Setting)
        self.n_samples = check_scalar(n_samples, "n_samples", low=1, integer=True)
        self.n_elite = check_scalar(n_elite, "n_elite", low=1, high=self.n_samples,
                                    integer=True)
        self.max_iter = check_scalar(max_iter, "max_iter", low=1, integer=True)
        self.patience = (None if patience is None
                         else check_scalar(patience, "patience", low=1, integer=True))
        magnitude_std = check_scalar(magnitude_std, "magnitude_std", low=0)
        direction_std = check_scalar(direction_std, "direction_std", low=0)
        magnitude_mean = check_scalar(magnitude_mean, "magnitude_mean")
        direction_mean = check_scalar(direction_mean, "direction_mean")
        self.rank_by = check_choice(rank_by, "rank_by", ("score", "silhouette"))
        self.setting = setting
        self.engine = check_engine(engine)
        self.params = ClusteringParams.from_kwargs(dict(params or {}),
                                                   "clustering parameters").to_dict()
        self._root = root_seed(seed)

        first = setting.sample_thrust(child_rng(self._root, 0))
        times = self.times = first.times
        k = times.shape[0]
        action = type(first)
        if action is ThrustSequence:
            mu = np.tile([magnitude_mean, direction_mean, direction_mean, direction_mean], k)
            sigma = np.tile([magnitude_std, direction_std, direction_std, direction_std], k)
        elif action is WaypointSpline:  # waypoint offsets from the hover start [m]
            mu = np.zeros(3 * (k - 1))
            sigma = np.tile(WAYPOINT_CEM_STD, k - 1).astype(float)
        else:  # attitude actions: thrust [N], roll, pitch, yaw [rad] per segment
            mu = np.tile(action.CEM_MEAN, k).astype(float)
            sigma = np.tile(action.CEM_STD, k).astype(float)
        if action is WaypointSpline:
            start = first.waypoints[0]
            limits = setting.waypoint_limits()
            self._decode = lambda x: waypoints_from_vector(x, times, start, limits)
        else:
            self._decode = lambda x: action.from_vector(x, times, max_magnitude)
        self.mu, self.sigma = mu, sigma
        self._history, self._sample_rows = [], []
        self._best_score, self._best_thrust, self._best_iter = -np.inf, None, -1
        self._it = 0
        self._draws = self._thrusts = None
        self._stopped = False

    @property
    def iteration(self) -> int:
        """Iterations done so far."""
        return self._it

    @property
    def done(self) -> bool:
        """True once ``max_iter`` iterations ran, or ``patience`` stopped the run."""
        return self._stopped or self._it >= self.max_iter

    def ask(self) -> tuple[list, list[np.random.SeedSequence]]:
        """The next iteration's ``n_samples`` actions and their turbulence seeds (iteration
        ``t`` draws from the seed's child ``(t + 1,)``, sample ``j``'s turbulence from
        ``(t + 1, j + 1)``). Asking again before :meth:`tell` gives the same draws."""
        if self.done:
            raise ValueError("the run is done: nothing left to ask")
        it = self._it
        self._draws = child_rng(self._root, it + 1).normal(
            self.mu, self.sigma, size=(self.n_samples, self.mu.size))
        self._thrusts = [self._decode(x) for x in self._draws]
        seeds = [child_seed(self._root, it + 1, j + 1) for j in range(self.n_samples)]
        return self._thrusts, seeds

    def tell(self, results: Sequence[LoopResult]) -> None:
        """The loop results of the samples :meth:`ask` gave, in its order."""
        if self._draws is None:
            raise ValueError("tell() needs the samples of ask() first")
        if len(results) != self.n_samples:
            raise ValueError(f"results must hold one loop result per sample "
                             f"({self.n_samples}), got {len(results)}")
        scores = np.array([r.score for r in results])
        rank = scores if self.rank_by == "score" else np.nan_to_num(
            np.array([r.silhouette for r in results]), nan=-1.0)
        self._update(scores, rank, _rows(results, self._thrusts))

    def tell_scores(self, scores: ArrayLike) -> None:
        """Scores of the samples :meth:`ask` gave, from an objective instead of loops (the
        samples' rows then hold only ``score``)."""
        if self._draws is None:
            raise ValueError("tell_scores() needs the samples of ask() first")
        scores = np.asarray(scores, dtype=float)
        if scores.shape != (self.n_samples,):
            raise ValueError(f"objective must return one score per sample, shape "
                             f"({self.n_samples},), got {scores.shape}")
        self._update(scores, scores, [{"loop": j, "score": s} for j, s in enumerate(scores)])

    def draws(self) -> np.ndarray:
        """The search vectors of the samples :meth:`ask` gave last, ``(n_samples, dim)``."""
        if self._draws is None:
            raise ValueError("draws() needs the samples of ask() first")
        return self._draws

    def _update(self, scores, rank, rows):
        it = self._it
        if np.all(np.isnan(scores)):
            raise ValueError(f"every score of CEM iteration {it + 1} is NaN: nothing to rank "
                             f"the samples by")
        draws, thrusts = self._draws, self._thrusts
        self.mu, self.sigma, elite = cem_step(draws, rank, self.n_elite)
        chosen = set(elite.tolist())
        for j, row in enumerate(rows):
            row.pop("loop", None)
            self._sample_rows.append({"iteration": it + 1, "sample": j, **row,
                                      "elite": bool(j in chosen),
                                      "vector": draws[j].tolist()})
        j_best = int(np.nanargmax(scores))
        if scores[j_best] > self._best_score:
            self._best_score, self._best_thrust, self._best_iter = (
                float(scores[j_best]), thrusts[j_best], it)
        self._history.append({"iteration": it + 1, "max": float(np.nanmax(scores)),
                              "mean": float(np.nanmean(scores)),
                              "elite_mean": float(np.nanmean(scores[elite])),
                              "best_so_far": self._best_score, "mu": self.mu.tolist(),
                              "sigma": self.sigma.tolist()})
        self._it = it + 1
        self._draws = self._thrusts = None
        if self.patience is not None and it - self._best_iter >= self.patience:
            self._stopped = self._it < self.max_iter

    def run(self, n_jobs: int | None = None, progress: bool = True) -> CEMResult:
        """Step the run to its end in this process, each iteration's samples scored by
        :func:`evaluate` over ``n_jobs`` workers; its :meth:`result`."""
        while not self.done:
            thrusts, seeds = self.ask()
            self.tell(evaluate(self.setting, thrusts, seeds, engine=self.engine, n_jobs=n_jobs,
                               progress=progress, desc=f"CEM iteration {self._it + 1}",
                               **self.params))
        return self.result()

    def result(self) -> CEMResult:
        """What the run found: its history, every sample's row and the best action."""
        if not self._it:
            raise ValueError("the run has not finished an iteration yet")
        return CEMResult(history=pd.DataFrame(self._history),
                         samples=pd.DataFrame(self._sample_rows), best_thrust=self._best_thrust,
                         best_score=self._best_score, times=self.times,
                         stopped_early=self._stopped)


def cem(setting: Setting, n_samples: int = 30, n_elite: int = 4, max_iter: int = 20,
        seed: int | np.random.SeedSequence | None = 0, patience: int | None = None,
        magnitude_mean: float = 25.0, magnitude_std: float = 50.0,
        direction_mean: float = 0.0, direction_std: float = 0.33,
        max_magnitude: float = MAX_THRUST, n_jobs: int | None = None,
        engine: str | None = None, progress: bool = True,
        objective: Callable[[np.ndarray], ArrayLike] | None = None, rank_by: str = "score",
        clustering: Mapping[str, float | str] | None = None,
        **params: float | str) -> CEMResult:
    """Cross-Entropy Method over thrust magnitudes and direction components.

    The search vector holds, per thrust segment, ``[magnitude, dx, dy, dz]``
    (see :meth:`ThrustSequence.to_vector`); for a setting that samples attitude actions
    (``sampler="attitude"``), ``[thrust, roll, pitch, yaw]`` per segment, started from
    :attr:`AttitudeSequence.CEM_MEAN <uavwind.sim.actions.AttitudeSequence.CEM_MEAN>` and
    ``CEM_STD``; for flyable waypoint references (``sampler="waypoints"``), the waypoints'
    offsets from the hover start (:func:`~uavwind.sim.manoeuvres.waypoints_to_vector`),
    started at 0 (hover) with :data:`~uavwind.sim.manoeuvres.WAYPOINT_CEM_STD` and decoded
    onto the limits by :func:`~uavwind.sim.manoeuvres.waypoints_from_vector`. Each iteration draws ``n_samples``
    vectors from independent Gaussians N(mu, sigma^2); each draw is turned into a
    thrust sequence by clipping magnitudes to [0, max_magnitude] and normalising
    directions; the ``n_elite`` best-scoring *draws* refit mu and sigma (eqs
    CEM1-2). The change times are drawn once per run with the setting's sampler.

    Parameters
    ----------
    setting : Setting
    n_samples, n_elite : int
        N and N_e (paper: 30 and 4); ``1 <= n_elite <= n_samples``.
    max_iter : int
        Cap on the iterations (default 20); the history's length is the count run.
    seed : int or SeedSequence
    patience : int, optional
        Stop when the best score has not improved for this many iterations
        (default: never stop early).
    magnitude_mean, magnitude_std : float
        mu_0 and sigma_0 of the magnitudes [N] (paper: 25 and 50).
    direction_mean, direction_std : float
        mu_0 and sigma_0 of each direction component (paper: 0 and 0.33).
    objective : callable, optional
        ``f(samples (n, dim)) -> scores (n,)`` replacing the simulation (for tests
        and other uses); the setting then only provides the change times.
    clustering : dict, optional
        Clustering parameters of every loop (see :func:`uavwind.method.clustering.score_loop`);
        the k-means cap goes here, ``clustering={"max_iter": 50}``, since ``max_iter``
        is this search's own cap. Other clustering parameters may also be given as
        keyword arguments. They are checked with or without ``objective``: an unknown
        one is a ``TypeError`` naming it.
    rank_by : {"score", "silhouette"}
        What picks the elites: the paper's score (0 when the clusters miss the
        groups, so a population without a correct loop carries no signal) or the
        raw silhouette coefficient (in [-1, 1]; -1 when only one cluster was found),
        which still orders the draws when none groups correctly. ``best_score`` and
        the history always report the paper's score.

    Returns
    -------
    CEMResult
    """
    run = CEMRun(setting, n_samples=n_samples, n_elite=n_elite, max_iter=max_iter, seed=seed,
                 patience=patience, magnitude_mean=magnitude_mean, magnitude_std=magnitude_std,
                 direction_mean=direction_mean, direction_std=direction_std,
                 max_magnitude=max_magnitude, rank_by=rank_by, engine=engine,
                 params={**params, **(clustering or {})})
    if rank_by == "silhouette" and objective is not None:
        raise ValueError("rank_by='silhouette' needs the simulation: leave objective=None")
    if objective is None:
        return run.run(n_jobs=n_jobs, progress=progress)
    while not run.done:
        run.ask()
        run.tell_scores(objective(run.draws()))
    return run.result()
