"""What the UAV believes about its wind: a likelihood of its noisy positions under each
known environment, and the posterior over the two groups.

This module owns :class:`Evidence` (the running sums a belief needs) and :class:`Belief`
(the posterior at one moment). The model, in full (replication notes, "closed loop"):

* Every known environment ``e`` predicts the flight exactly: ``p_e``, the positions the
  vehicle would have flown there under the same actions (its replay, from t = 0), all
  samples so far stacked into one vector of ``n`` numbers.
* The UAV observes ``y = p + noise``: white Gaussian noise of ``sigma`` [m] per axis.
* An unknown member of group ``g`` flies near, not on, a known one, and how it differs is
  *learnt from the group*, by what kind of condition it is (:func:`directions`):

  - a family of steady winds (constant, shear): a new member lies *between* known ones.
    With the members in order of speed, the differences between neighbours,
    ``p_(i+1) - p_i``, say how far apart neighbouring members fly (for a constant wind a
    drift along the wind by one spacing, for shear drifts that grow with height), and the
    second differences ``p_(i-1) - 2 p_i + p_(i+1)`` how far a member strays from the chord
    between its neighbours (the trajectory is not linear in the wind speed where the
    vehicle's response is not: drag, motor limits). ``C_g`` is the second moment of "a new
    member minus the known one nearest to it", for a new member placed uniformly between
    two neighbours: 1/12 of the neighbours' differences' and 1/120 of the second
    differences' outer products, averaged over the group.
  - a random process (turbulence): a new member is a *new draw*, as far from every known
    one as they are from each other, so ``C_g`` is the mean over all pairs
    ``(p_i - p_j)(p_i - p_j)^T``.

  Either way ``C_g`` has low rank: one direction per difference.
* So group ``g`` predicts ``y ~ mean_{e in g} N(p_e, sigma^2 I + C_g)``, and with equal
  priors ``P(g | y) ∝ mean_{e in g} N(y; p_e, sigma^2 I + C_g)``.
* The model can be wrong: a manoeuvre can make the flight depend on the wind so steeply
  (motor limits, free fall) that a new environment is unlike every member of both
  conditions. Both conditions therefore share a *neither* component of prior weight
  :data:`NEITHER` (1%): one broad Gaussian around all members' mean
  (:meth:`Evidence.log_neither`). A flight that fits a condition is judged by its members;
  one that fits neither pulls the belief towards one half instead of to the less bad
  condition with certainty.

The directions are fixed combinations ``M`` of the members' replays ``P``, so everything is
a sum over samples (``|y - p_e|^2``, ``P P^T`` and ``P (p_e - y)``, the replays centred on
their mean), updated as samples arrive; the likelihood is evaluated with the Woodbury
identity and the matrix determinant lemma in the directions' dimension (seven for five
members of a family, ten for five draws), never in the samples'.

All pairs for every group were tried first: a steady-wind member is then blurred by the
group's whole range, which for two adjacent groups overlaps the other (under-confident:
calibration error 0.14 on the halves reading's light constant pair); so were the neighbours'
full differences, not their second moment for a member between them (with a tenth of the
GNSS noise, fewer flights reached 95% than with the full noise: each member's blur reached
into the adjacent group); neighbour pairs for
every group are too narrow for turbulence (log-loss 24 nats at 12 s on light constant vs
strong turbulence, point mass, 40 flights); neighbour pairs without the curvature were
confidently wrong on the multirotor when a plan's free fall and sideways thrust made its
drift non-linear in the wind speed (log-loss 33 nats at 12 s in the worst of 200 flights);
without the *neither* component a few multirotor flights through a shear, unlike every
member, were read as constant wind with log-losses of hundreds to thousands of nats.

What is not solved: five draws of a random process span four directions, and a new gust
history strays in others. On the multirotor in turbulence the belief is over-confident
(of the flights that reach 95% on one condition, 84-90% are right, for light constant vs
strong turbulence, 80 flights). Adding the members' leave-one-out spread outside the span
of the others, in every direction, was tried and made no clear difference over those 80
flights (mean log-loss at 12 s 3.5 against 3.6 nats), so the simpler model stays.

An earlier version blurred each member by an isotropic kernel (independent across samples,
its width the leave-one-out bandwidth): under turbulence it was confidently wrong (a held-out
gust history far from all five known ones, log-loss above 100 nats), because a correlated
deviation counted as hundreds of independent ones. The tests keep that case.

The probabilities are probabilities by construction (in [0, 1], the two groups' sum to 1,
the smaller computed directly so it does not round to 0), and the log-loss comes from the
log-odds, so it is finite. Whether they are *calibrated* is measured (Experiment 12's
reliability diagram).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.checks import check_array, check_choice, check_scalar

__all__ = ["Evidence", "Belief", "directions", "SIGMA_FLOOR", "NEITHER", "POSITION_LIMIT"]

#: Prior probability that a flight is unlike every known member (of either condition): the
#: weight of the "neither" component both conditions share.
NEITHER = 0.01

#: Smallest noise standard deviation of the likelihood [m]: positions are never taken to
#: be known better than this (noise-free observations would make the likelihood singular).
SIGMA_FLOOR = 0.01

#: Largest position [m] the evidence takes (a million kilometres): beyond it the sums of
#: squares lose every digit (1e160 m overflowed them to NaN probabilities).
POSITION_LIMIT = 1e9


def _logsumexp(x):
    m = float(np.max(x))
    if not math.isfinite(m):
        return m
    return m + math.log(float(np.sum(np.exp(x - m))))


@dataclass(frozen=True)
class Belief:
    """The posterior at one moment.

    Attributes
    ----------
    p : ndarray, shape (2,)
        Probability of group 0 and of group 1 (sum 1).
    log_odds : float
        ``log P(group 1) - log P(group 0)``.
    weights : ndarray, shape (n_known,)
        Posterior weight of each known environment (sum 1).
    spread : float
        Per-number variance [m^2] the planning uses: ``sigma^2`` plus the groups' mean
        ``trace(C_g) / n``.
    """

    p: np.ndarray
    log_odds: float
    weights: np.ndarray
    spread: float

    @property
    def predicted(self) -> int:
        """The more probable group (0 on a tie)."""
        return int(self.log_odds > 0)

    def log_loss(self, group: int) -> float:
        """``-log P(group)``, from the log-odds (finite however sure the belief); ``group``
        0 or 1."""
        group = check_choice(group, "group", (0, 1))
        z = self.log_odds if group == 0 else -self.log_odds
        return float(np.logaddexp(0.0, z))


def directions(k: int, random: bool) -> np.ndarray:
    """The rows of ``M`` (n_directions, k): the combinations of a group's ``k`` member
    replays (in speed order) whose outer products make its covariance ``C = (M P)^T (M P)``.

    A random process: every pair ``p_i - p_j``, each scaled by ``1 / sqrt(n_pairs)`` (the
    mean over pairs: a new draw differs from a known one as two known ones differ).

    A family of steady winds, for a new member at a uniform place between two neighbours:
    it differs from the nearer one by ``u (p_(i+1) - p_i)``, ``|u| <= 1/2``, whose second
    moment is ``1/12`` of the difference's; and from the chord by about
    ``u (1 - u) / 2`` times the second difference ``p_(i-1) - 2 p_i + p_(i+1)``, second
    moment ``1/120``. So the neighbours' differences are scaled by
    ``1 / sqrt(12 (k - 1))`` and the second differences by ``1 / sqrt(120 (k - 2))``.

    >>> (directions(3, random=False) * 100).round(1).tolist()
    [[-20.4, 20.4, 0.0], [0.0, -20.4, 20.4], [9.1, -18.3, 9.1]]
    """
    k = check_scalar(k, "k", low=1, high=10 ** 4, integer=True)
    rows = []
    if random:
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
        for i, j in pairs:
            r = np.zeros(k)
            r[i], r[j] = 1.0, -1.0
            rows.append(r / math.sqrt(len(pairs)))
        return np.array(rows).reshape(-1, k)
    for i in range(k - 1):
        r = np.zeros(k)
        r[i], r[i + 1] = -1.0, 1.0
        rows.append(r / math.sqrt(12.0 * (k - 1)))
    for i in range(1, k - 1):
        r = np.zeros(k)
        r[i - 1], r[i], r[i + 1] = 1.0, -2.0, 1.0
        rows.append(r / math.sqrt(120.0 * (k - 2)))
    return np.array(rows).reshape(-1, k)


class Evidence:
    """The running sums behind a belief (see the module text).

    Parameters
    ----------
    groups : array_like of int, shape (n_known,)
        Group (0/1) of each known environment; at least two in each.
    sigma : float
        Position noise [m] per axis (raised to :data:`SIGMA_FLOOR`).
    random : tuple of 2 bools
        Whether each group's members are draws of a random process (turbulence: a new
        member is a new draw, its covariance learnt from *all* pairs of members) rather
        than a family of steady winds (a new member lies between known ones: from the
        neighbours in speed and the curvature).
    speeds : array_like, shape (n_known,), optional
        The known environments' speeds [m/s], which order a steady-wind family's members
        (default: their order in ``groups``).
    """

    def __init__(self, groups, sigma: float, random: tuple[bool, bool] = (False, False),
                 speeds=None):
        g = check_array(groups, "groups", ndim=1)
        if not np.all(np.isin(g, (0, 1))):
            raise ValueError(f"groups must hold only 0 and 1 (the group of each known "
                             f"environment), got {np.unique(g).tolist()}")
        self.groups = g.astype(np.intp)
        sizes = np.bincount(self.groups, minlength=2)
        if sizes.min() < 2:
            raise ValueError(f"groups must hold at least 2 known environments of each group "
                             f"(a group's spread is learnt from its members), got "
                             f"{sizes[0]} of group 0 and {sizes[1]} of group 1")
        if (not isinstance(random, (tuple, list)) or len(random) != 2
                or not all(isinstance(r, (bool, np.bool_)) for r in random)):
            raise TypeError(f"random must be a pair of bools (one per group), got {random!r}")
        self.random = tuple(bool(r) for r in random)
        self.sigma2 = max(check_scalar(sigma, "sigma", low=0.0, high=POSITION_LIMIT),
                          SIGMA_FLOOR) ** 2
        speeds = (np.arange(self.groups.size, dtype=float) if speeds is None
                  else check_array(speeds, "speeds", shape=(self.groups.size,)))
        # each group's members, in speed order (ties: their order)
        self.members = [m[np.argsort(speeds[m], kind="stable")]
                        for m in (np.flatnonzero(self.groups == g) for g in (0, 1))]
        self.M = [directions(len(m), r) for m, r in zip(self.members, self.random)]
        self.obs_sq = np.zeros(self.groups.size)
        self.gram_p = [np.zeros((len(m), len(m))) for m in self.members]  # sum P'P'^T
        self.cross = [np.zeros((len(m), len(m))) for m in self.members]   # sum P'(p_e - y)^T
        k = self.groups.size  # the "neither" component: every member, as draws
        self.M_all = directions(k, random=True)
        self.gram_all = np.zeros((k, k))
        self.cross_all = np.zeros(k)   # sum P'(p_mean - y)
        self.mean_sq = 0.0             # sum |p_mean - y|^2
        self.n_obs = 0

    def add(self, observed: np.ndarray, predicted: np.ndarray) -> None:
        """Add samples: ``observed`` (m, 3) noisy positions [m], ``predicted`` (n_known, m,
        3) the replays' positions at the same times; both finite and within
        :data:`POSITION_LIMIT`."""
        observed = check_array(observed, "observed", shape=(None, 3))
        predicted = check_array(predicted, "predicted",
                                shape=(self.groups.size, observed.shape[0], 3))
        for name, arr in (("observed", observed), ("predicted", predicted)):
            if arr.size and np.abs(arr).max() > POSITION_LIMIT:
                raise ValueError(f"{name} positions must be within +-{POSITION_LIMIT:g} m, "
                                 f"got {np.abs(arr).max():g} m")
        diff = (predicted - observed[None]).reshape(predicted.shape[0], -1)
        self.obs_sq += np.einsum("en,en->e", diff, diff)
        for g, m in enumerate(self.members):
            pm = predicted[m].reshape(len(m), -1)
            pc = pm - pm.mean(axis=0)  # directions sum to zero: centring loses nothing
            self.gram_p[g] += pc @ pc.T
            self.cross[g] += pc @ diff[m].T
        flat = predicted.reshape(predicted.shape[0], -1)
        centred = flat - flat.mean(axis=0)
        d_mean = flat.mean(axis=0) - observed.ravel()
        self.gram_all += centred @ centred.T
        self.cross_all += centred @ d_mean
        self.mean_sq += float(d_mean @ d_mean)
        self.n_obs += diff.shape[1]

    def _covariance(self, g):
        """``(U^T U, U^T (p_e - y) per member, trace)``, ``U = (M P)^T`` of group ``g``."""
        M = self.M[g]
        gram = M @ self.gram_p[g] @ M.T
        return gram, M @ self.cross[g], float(np.trace(gram))

    def log_likelihoods(self, covariances=None) -> np.ndarray:
        """``log N(y; p_e, sigma^2 I + C_g)`` of each known environment (n_known,)."""
        out = np.empty(self.groups.size)
        s2, n = self.sigma2, self.n_obs
        covariances = covariances or [self._covariance(g) for g in (0, 1)]
        for g in (0, 1):
            gram, proj, _ = covariances[g]
            r = gram.shape[0]
            L = np.linalg.cholesky(s2 * np.eye(r) + gram)  # sigma^2 (I + U^T U / sigma^2)
            z = np.linalg.solve(L, proj)                    # (r, members)
            quad = (self.obs_sq[self.members[g]] - np.einsum("rm,rm->m", z, z)) / s2
            logdet = 2.0 * float(np.log(np.diag(L)).sum()) + (n - r) * math.log(s2)
            out[self.members[g]] = -0.5 * (np.maximum(quad, 0.0) + logdet
                                           + n * math.log(2.0 * math.pi))
        return out

    def log_neither(self) -> float:
        """``log N(y; p_mean, (sigma^2 + tau^2) I + C_all)``: the flight as unlike any one
        member, the members' mean blurred by all their pairs' spread and, in every
        direction, by ``tau^2``, that spread per number."""
        n = self.n_obs
        if n == 0:
            return 0.0
        M = self.M_all
        gram = M @ self.gram_all @ M.T
        s2 = self.sigma2 + float(np.trace(gram)) / n
        r = gram.shape[0]
        L = np.linalg.cholesky(s2 * np.eye(r) + gram)
        z = np.linalg.solve(L, M @ self.cross_all)
        quad = (self.mean_sq - float(z @ z)) / s2
        logdet = 2.0 * float(np.log(np.diag(L)).sum()) + (n - r) * math.log(s2)
        return -0.5 * (max(quad, 0.0) + logdet + n * math.log(2.0 * math.pi))

    def belief(self) -> Belief:
        """The posterior given everything added so far (the prior, 1/2 each, before)."""
        cov = [self._covariance(g) for g in (0, 1)]
        log_l = self.log_likelihoods(cov)
        sizes = np.bincount(self.groups, minlength=2)
        log_w = log_l - np.log(sizes[self.groups])
        ev = np.array([_logsumexp(log_w[m]) for m in self.members])
        if self.n_obs:  # each condition: its members, or (with NEITHER) none of them
            neither = self.log_neither() + math.log(NEITHER)
            ev = np.logaddexp(ev + math.log1p(-NEITHER), neither)
        d = float(ev[1] - ev[0])
        # imported here: scipy.special costs 0.3 s, and a page that reads results (it
        # imports this module with uavwind) never forms a belief
        from scipy.special import expit
        if d >= 0:
            p0 = float(expit(-d))
            p = np.array([p0, 1.0 - p0])
        else:
            p1 = float(expit(d))
            p = np.array([1.0 - p1, p1])
        weights = np.exp(log_w - _logsumexp(log_w))
        trace = (cov[0][2] + cov[1][2]) / 2
        spread = self.sigma2 + (trace / self.n_obs if self.n_obs else 0.0)
        return Belief(p=p, log_odds=d, weights=weights / weights.sum(), spread=spread)
