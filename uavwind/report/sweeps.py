"""The pages of the paper's three sweeps: Experiments 2, 3 and 4, one swept parameter each.

This module owns :func:`sweep_page` and what it returns, :class:`SweepPage`: the parts the
range-similarity, environment-count and thrust-change pages show, in their order -- how the
results were made (provenance and the profile's note), the paper's table regenerated beside
ours (Tables 5-7), the mean and the maximum score of every setting (one column per scenario)
and the score against the swept parameter (Figs 5-7), stamped. The three pages differ only
in the experiment; each calls :func:`sweep_page` once and shows its parts between its own
prose. The swept parameter is the registry's (the last of the experiment's ``group_by``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..analysis.tables import comparison_table, profile_note, provenance, summary_table
from ..core.checks import check_choice
from ..study.paper import load_paper_values
from ..study.profiles import DEFAULT_SEED
from ..study.registry import get_experiment
from ..study.runner import run_experiment
from .display import pretty
from .plotting import score_vs_parameter, stamp

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure

__all__ = ["SWEEPS", "SweepPage", "sweep_page"]

#: The sweeps: experiment id -> the x-axis label of its figure (the parameter's display name).
SWEEPS = {"exp2": "environments (both groups)", "exp3": "environments (both groups)",
          "exp4": "thrust changes"}


@dataclass(frozen=True, eq=False)
class SweepPage:
    """What a sweep's page shows, from one experiment's ``results`` (a table of
    :func:`~uavwind.study.runner.run_experiment`)."""

    results: pd.DataFrame

    @property
    def experiment(self) -> str:
        """The experiment's id (``"exp2"``, ``"exp3"`` or ``"exp4"``)."""
        return self.results.attrs["experiment"]

    @property
    def parameter(self) -> str:
        """The swept column: ``"n_env"`` (Exps 2, 3) or ``"thrust_changes"`` (Exp 4)."""
        return get_experiment(self.experiment).group_by[-1]

    def show_provenance(self) -> None:
        """Print how the results were made (with how many chunks came from the cache) and
        display the profile's note (Markdown: under any profile but the paper's, its
        verdicts are provisional)."""
        from IPython.display import Markdown, display

        a = self.results.attrs
        print(provenance(self.results), f"({a['cached']} of {a['chunks']} chunks from the cache)")
        display(Markdown(profile_note(self.results)))

    def comparison(self) -> pd.DataFrame:
        """The paper's table regenerated (Tables 5-7): its reported rows, paper beside
        replication, with display names."""
        return pretty(comparison_table(self.results).drop(columns="case"))

    def scores(self, stat: str) -> pd.DataFrame:
        """``stat`` (``"mean"`` or ``"max"``) of every setting: one row per value of the
        swept parameter, named as the figure's axis names it (a reader sees "environments
        (both groups)", not the column ``n_env``), one column per scenario."""
        check_choice(stat, "stat", ("mean", "max"))
        return (summary_table(self.results)[stat].unstack("scenario")
                .rename_axis(index=SWEEPS[self.experiment]))

    def figure(self) -> Figure:
        """Figs 5-7: maximum and mean score against the swept parameter, one panel per
        scenario, the paper's reported settings in grey, stamped with the provenance."""
        fig = score_vs_parameter(self.results, self.parameter,
                                 paper=load_paper_values(self.experiment),
                                 xlabel=SWEEPS[self.experiment])
        return stamp(fig, self.results)


def sweep_page(experiment: str, profile: str = "quick", seed: int = DEFAULT_SEED,
               n_jobs: int | None = None, reading: str | None = None) -> SweepPage:
    """Run (or read from the cache) sweep ``experiment`` (a key of :data:`SWEEPS`) as its
    page asks, with :func:`~uavwind.study.runner.run_experiment`'s ``profile``, ``seed``,
    ``n_jobs`` and ``reading``, and return what the page shows."""
    check_choice(experiment, "experiment", tuple(SWEEPS))
    return SweepPage(run_experiment(experiment, profile=profile, seed=seed, n_jobs=n_jobs,
                                    reading=reading))
