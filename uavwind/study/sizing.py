"""Sizing: how many loops (or episodes) the paper profile runs for each experiment beyond the
paper, chosen from the evidence its question needs.

This module owns :class:`Sizing` (one experiment's question, the 95% CI half-width it needs,
the spread of one loop's value measured in a paper build, and the count that follows) and
:data:`SIZINGS` (Exps 7-12). :data:`uavwind.study.profiles.PROFILES` ``["paper"]`` takes its
counts for these experiments from here, and each page's sizing note
(:func:`uavwind.analysis.tables.sizing_note`) states the same question, re-measures the
spread on the build it shows and says whether the loops run suffice.

The rule: a question that compares means ``2 h`` apart needs 95% CIs of ``+- h`` on each;
one loop's value with standard deviation ``sd`` (the most variable case) needs
``ceil((1.96 sd / h)^2)`` loops (:func:`uavwind.core.stats.loops_needed`); the count run is
that, or the experiment's ``floor`` where that is more (the paper's own 50 loops for the
experiments that extend its Tables). A question decided loop by loop (``compared``: every
case of a group flies the same loops, and the page sets the best against the runner-up and
a reference by paired differences) takes ``sd`` from those differences instead, and
``+- h`` is then the CI of the difference itself. Exp 13's counts are the data's own (its
flights and laps) and are not sized here.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.checks import check_scalar
from ..core.stats import loops_needed

__all__ = ["Sizing", "SIZINGS", "SIZED_AT"]

#: The paper build whose spreads the counts below were chosen from (`make bench ONLY=paper
#: FULL=1` at this commit; its per-case counts are each record's ``measured_with``).
SIZED_AT = "0174f34"


@dataclass(frozen=True, kw_only=True)
class Sizing:
    """One experiment's sizing.

    Attributes
    ----------
    experiment : str
        The experiment's id.
    question : str
        What its verdict decides, as a page states it.
    halfwidth : float
        The 95% CI half-width that question needs [``unit``].
    unit : str
        ``"points"`` (scores) or ``"percentage points"`` (accuracies).
    sd : float
        One loop's (episode's) standard deviation of ``value`` in the most variable group
        of the paper build :data:`SIZED_AT` [``unit``].
    measured_with : int
        Loops (episodes) per group that build ran.
    floor : int
        The least count the profile runs whatever the sizing asks, and ``floor_reason`` why.
    value, by, scale, last_time
        How a page re-measures the spread: the column, the grouping, the factor to ``unit``
        (100 for a 0/1 column in percentage points), and whether only the last report time
        of a closed-loop run counts.
    compared : tuple of str
        For a question decided loop by loop: the columns whose values a verdict ranks within
        each ``by`` group (e.g. action and observation); ``sd`` is then the standard
        deviation of the loop-by-loop difference between the group's highest mean and its
        runner-up, and between it and ``reference``, the largest over the groups.
    reference : tuple
        The value of ``compared`` the best is also set against (the paper's choice).
    measured_at : str
        The commit of the paper build ``sd`` was measured in (default :data:`SIZED_AT`).
    """

    experiment: str
    question: str
    halfwidth: float
    unit: str
    sd: float
    measured_with: int
    floor: int
    floor_reason: str
    value: str = "score"
    by: tuple[str, ...] = ("case",)
    scale: float = 1.0
    last_time: bool = False
    compared: tuple[str, ...] = ()
    reference: tuple = ()
    measured_at: str = SIZED_AT

    def __post_init__(self):
        check_scalar(self.halfwidth, f"{self.experiment} sizing halfwidth", low=0.0,
                     low_inclusive=False)
        check_scalar(self.sd, f"{self.experiment} sizing sd", low=0.0)
        check_scalar(self.floor, f"{self.experiment} sizing floor", low=1, integer=True)
        check_scalar(self.measured_with, f"{self.experiment} sizing measured_with", low=2,
                     integer=True)
        if self.reference and len(self.reference) != len(self.compared):
            raise ValueError(f"{self.experiment} sizing reference must give one value per "
                             f"compared column {self.compared}, got {self.reference!r}")

    @property
    def needed(self) -> int:
        """Loops per group the question needs at the measured spread."""
        return loops_needed(self.sd, self.halfwidth)

    @property
    def count(self) -> int:
        """Loops per group the paper profile runs: ``max(floor, needed)``."""
        return max(self.floor, self.needed)


_PAPER_FLOOR = "the paper's own 50 loops per case, which this experiment extends"

#: Exps 7-12's sizings, from the paper build :data:`SIZED_AT`.
SIZINGS: dict[str, Sizing] = {s.experiment: s for s in (
    Sizing(experiment="exp7", question="Placing a noise level on its side of one half (the "
           "page's verdict: where the share of correctly grouped loops falls below it) when "
           "that share is 15 percentage points or more from one half", halfwidth=15,
           unit="percentage points", sd=48.2, measured_with=128, floor=50,
           floor_reason=_PAPER_FLOOR, value="correct", by=("scenario", "noise_sigma",
                                                           "noise_bias"),
           scale=100.0, measured_at="4e97d73"),
    Sizing(experiment="exp8", question="Ranking two observations whose means differ by 10 "
           "points", halfwidth=5, unit="points", sd=14.0, measured_with=50, floor=50,
           floor_reason=_PAPER_FLOOR),
    Sizing(experiment="exp9", question="Telling the baseline's share of correctly grouped "
           "loops from one half and from the clustering's when they differ by 30 percentage "
           "points", halfwidth=15, unit="percentage points", sd=50.0, measured_with=128,
           floor=50, floor_reason=_PAPER_FLOOR, value="baseline_correct",
           by=("scenario", "noise_sigma", "noise_bias"), scale=100.0, measured_at="4e97d73"),
    Sizing(experiment="exp10", question="Telling a vehicle whose mean score is 10 points "
           "lower from one that matches the point mass", halfwidth=5, unit="points",
           sd=12.9, measured_with=50, floor=50, floor_reason=_PAPER_FLOOR),
    Sizing(experiment="exp11", question="Telling a scenario's best action and observation "
           "from its runner-up, and from the paper's choice (thrust actions, position), when "
           "they differ by 20 points", halfwidth=10, unit="points", sd=13.7, measured_with=82,
           floor=20,
           floor_reason="the count of the other sweeps beyond the paper, the inference fits",
           by=("scenario", "noise"), compared=("action", "observation"),
           reference=("thrust", "position"), measured_at="4363649"),
    Sizing(experiment="exp12", question="Telling policies whose accuracies differ by 20 "
           "percentage points", halfwidth=10, unit="percentage points", sd=38.1,
           measured_with=200, floor=200,
           floor_reason="the page's calibration and time to confidence read only the "
                        "episodes where a policy reached confidence, a subset of them",
           value="correct", by=("case", "policy"), scale=100.0,
           last_time=True),
)}
