"""The paper's reported numbers, read from ``uavwind/study/paper_values/`` (transcribed, with sources).

The CSV files ship inside the package, so an installed ``uavwind`` (``pip install .``)
finds them without a checkout.

This module owns the mapping from an experiment id to the CSV file holding the
values the paper reports for it, and the loader every comparison uses.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["PAPER_FILES", "paper_dir", "load_paper_values"]

#: Experiment id (or ``"example"``) -> file under ``uavwind/study/paper_values``.
PAPER_FILES = {
    "example": "table3_worked_example.csv",
    "exp1": "table4_wind_speed.csv",
    "exp2": "table5_range_similarity.csv",
    "exp3": "table6_environment_count.csv",
    "exp4": "table7_thrust_changes.csv",
    "exp5": "table8_wind_direction.csv",
    "exp6": "fig9_cem.csv",
}


def paper_dir() -> Path:
    return Path(__file__).resolve().parent / "paper_values"


def load_paper_values(exp_id: str) -> pd.DataFrame:
    """The paper's values for ``exp_id`` as a DataFrame (with a ``source`` column).

    >>> load_paper_values("exp1").loc[0, "maximum"]
    np.float64(85.86)
    """
    if exp_id not in PAPER_FILES:
        raise ValueError(f"unknown experiment {exp_id!r}; valid: {', '.join(PAPER_FILES)}")
    return pd.read_csv(paper_dir() / PAPER_FILES[exp_id])
