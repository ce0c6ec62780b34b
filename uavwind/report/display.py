"""Presentation: the one place where the library's column names become pretty names.

This module owns how tables and verdicts look on a page, so that notebooks stay thin
and tests can reach the presentation too:

* :data:`PRETTY` and :func:`pretty` -- the project's vocabulary (``max``, ``mean``,
  ``ci_low``, ``ci_high``, ``correct_rate``, ``n_loops``, ...) turned into display
  names, shares shown as percentages;
* :func:`claims_markdown` -- the claims page's evidence under both readings;
* :func:`group_name` -- the display name of group 0 or 1 (code always says 0 and 1).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core.stats import MIN_INTERVAL
from ..study.registry import column_names

if TYPE_CHECKING:
    from ..sim.setting import Setting

__all__ = ["show_missing", "MISSING", "PRETTY", "SHARES", "pretty", "claims_markdown",
           "verdicts_markdown", "group_name",
           "channel_name", "signed"]

#: Observation channel (its code name) -> display name, where the code name does not read.
CHANNEL_NAMES = {"imu": "IMU", "body_rates": "body rates", "position_velocity": "position + velocity"}


def channel_name(name: str) -> str:
    """The display name of an observation channel: ``"body_rates"`` -> ``"body rates"``,
    ``"imu"`` -> ``"IMU"`` (:data:`CHANNEL_NAMES`, else underscores as spaces)."""
    if not isinstance(name, str):
        raise ValueError(f"name must be a channel name (str), got {name!r}")
    return CHANNEL_NAMES.get(name, name.replace("_", " "))

def signed(value: float, digits: int = 2) -> str:
    """``value`` with its sign and ``digits`` decimals, as a page shows a difference: a value
    that rounds to zero reads ``+0.00``, never ``-0.00`` (a bias of -1e-17 is no bias)."""
    if not isinstance(digits, int) or not 0 <= digits <= 10:
        raise ValueError(f"digits must be an int in [0, 10], got {digits!r}")
    return f"{round(float(value), digits) + 0.0:+.{digits}f}"  # -0.0 + 0.0 is +0.0


#: Column name -> display name.
PRETTY = {
    "max": "maximum", "mean": "mean", "ci_low": "95% CI low", "ci_high": "95% CI high",
    "correct_rate": "correct (%)", "correct_low": "correct, CI low (%)",
    "correct_high": "correct, CI high (%)", "n_loops": "loops",
    "paper_max": "paper maximum", "paper_mean": "paper mean", "elite_mean": "elite mean",
    "best_so_far": "best so far", "difference": "difference", "paper_in_ci": "paper in CI",
    "motor_limited": "motor limited (%)", "tilt_limited": "tilt limited (%)",
    "mean_difference": "mean - paper mean", "max_difference": "maximum - paper maximum",
    "geometry_alone": "geometry alone",
    "baseline_correct_rate": "baseline correct (%)", "cc_correct_rate": "clustering correct (%)",
    "cc_mean": "clustering mean", "rmse": "wind RMSE (m/s)", "rmse_low": "RMSE CI low",
    "rmse_high": "RMSE CI high", "paper_mean_t4": "paper mean",
    # Exp 7's breaking level (analysis.beyond.breaking_level)
    "last_ok": "last level, half or more correct (m)",
    "first_broken": "first level, under half correct (m)",
    "correct_rate_at_last_ok": "correct at the last (%)",
    "correct_rate_at_first_broken": "correct at the first (%)",
    "decided": "placed by the one rule",
    # the inference page's fitted layouts (analysis.inference)
    "in_use": "in use", "in_ci": "in the 95% CI",
    # Exp 8's best observation against its runner-up (analysis.beyond.best_observation)
    "runner_up": "runner-up", "runner_up_diff": "best minus runner-up",
    "runner_up_low": "difference, 95% CI low", "runner_up_high": "difference, 95% CI high",
    **column_names(),  # the experiments' label columns, as the registry names them
}
#: Columns holding shares in [0, 1], shown as percentages.
SHARES = ("correct_rate", "correct_low", "correct_high", "baseline_correct_rate",
          "cc_correct_rate", "motor_limited", "tilt_limited")


def pretty(df: pd.DataFrame, precision: int = 2) -> pd.DataFrame:
    """A display copy of ``df``: shares as percentages, columns and index levels renamed
    by :data:`PRETTY` (unknown names pass through), numbers rounded to ``precision``; a row
    of fewer than :data:`~uavwind.core.stats.MIN_INTERVAL` loops (``n_loops``) shows no
    interval (its bounds, ``ci_low``/``ci_high`` and any ``*_low``/``*_high``, as
    :data:`MISSING`): one value has none, and two values' bootstrap is only their range, not
    a 95% interval; nor does a zero-width interval (every loop alike) show as one."""
    out = df.copy()
    bounds = [c for c in out.columns
              if c in _INTERVAL_BOUNDS or str(c).endswith(("_low", "_high"))]
    if "n_loops" in out.columns:
        few = (out["n_loops"].astype(float) < MIN_INTERVAL).to_numpy()
        for col in bounds:
            if few.any():
                out[col] = out[col].astype(float).where(~few)
    for low in [c for c in bounds if str(c).endswith("_low")]:
        high = str(low)[:-4] + "_high"
        if high in out.columns:
            flat = (out[low].astype(float) == out[high].astype(float)).to_numpy()
            if flat.any():
                out[low] = out[low].astype(float).where(~flat)
                out[high] = out[high].astype(float).where(~flat)
    for col in out.columns:
        name = col[-1] if isinstance(col, tuple) else col  # side-by-side tables: the last level
        if name in SHARES or str(name).startswith("correct_rate"):
            out[col] = 100 * out[col]
    out = out.rename(columns=_display_name)
    if isinstance(out.index, pd.MultiIndex):
        out.index = out.index.set_names([PRETTY.get(n, n) for n in out.index.names])
    elif out.index.name:
        out.index.name = PRETTY.get(out.index.name, out.index.name)
    for col in out.columns:  # a yes/no column in words, not Python's True/False
        if out[col].dtype == bool:
            out[col] = out[col].map({True: "yes", False: "no"})
    return _fixed_decimals(show_missing(out.round(precision), precision), precision)


#: Exp 9's columns of a mis-modelled estimator: "rmse_mass+20%", "correct_rate_drag+20%".
_MODEL_ERROR = re.compile(r"^(rmse|correct_rate)_(mass|drag)([+-]\d+%)$")


def _display_name(column):
    """A column's name as a table shows it: :data:`PRETTY`'s, a mis-modelled estimator's
    ("wind RMSE, mass +20% (m/s)"), else the name with spaces for underscores."""
    if not isinstance(column, str):
        return column
    if column in PRETTY:
        return PRETTY[column]
    m = _MODEL_ERROR.match(column)
    if m:
        what = {"mass": "mass", "drag": "drag coefficient"}[m.group(2)]
        error = f"{m.group(3)[0]}{m.group(3)[1:]}"
        return (f"wind RMSE, {what} {error} (m/s)" if m.group(1) == "rmse"
                else f"correct, {what} {error} (%)")
    return column.replace("_", " ")


#: Columns that count (loops, crashes): whole numbers, shown without decimals.
COUNTS = ("n_loops", "loops", "crashed", "flipped", "n_env", "iteration", "thrust_changes")


def _fixed_decimals(df: pd.DataFrame, precision: int) -> pd.DataFrame:
    """Every float column written with the table's ``precision`` decimals, as text: pandas
    trims the zeros a whole column shares, so a column of whole numbers printed as "100.0"
    or "0.0", and one of halves as "50.0", beside another's "98.50". A count
    (:data:`COUNTS`) is written whole."""
    out = df.copy()
    for col in out.columns:
        values = out[col]
        if values.dtype.kind != "f" or not len(values):
            continue
        name = col[-1] if isinstance(col, tuple) else col
        if name in COUNTS or name in [PRETTY.get(c, c) for c in COUNTS]:
            if values.notna().all() and np.all(values == np.round(values)):
                out[col] = values.astype(int)
            continue
        out[col] = [MISSING if pd.isna(v) else f"{v:.{precision}f}" for v in values]
    return out


#: The columns holding a 95% interval's bounds.
_INTERVAL_BOUNDS = ("ci_low", "ci_high", "correct_low", "correct_high")

#: What a table shows where a value does not apply (a point mass's motor limits, a
#: measurement a section does not take): never a bare "NaN".
MISSING = "–"


def show_missing(df: pd.DataFrame, precision: int | None = None) -> pd.DataFrame:
    """``df`` with every missing value shown as :data:`MISSING` (only the columns that have
    one change; the others keep their numbers). Such a column holds text, which pandas shows
    as each float's shortest form ("2.0" beside "2.09"); with ``precision``, its floats are
    written with that many decimals, as the table's other columns show theirs."""
    out = df.copy()
    for col in out.columns:
        if out[col].isna().any():
            out[col] = [MISSING if pd.isna(v) else
                        f"{v:.{precision}f}" if precision is not None and isinstance(v, float)
                        else v for v in out[col]]
    return out


def group_name(setting: Setting, group: int) -> str:
    """Display name of group ``group`` (0 or 1) of ``setting``: its condition's label
    (:meth:`~uavwind.sim.setting.Setting.group_label`)."""
    return setting.group_label(group)


def claims_markdown(verdicts: pd.DataFrame,
                    readings: Sequence[str] = ("inferred", "halves")) -> str:
    """The claims page's evidence: per claim, the verdict and evidence under each reading,
    what the difference teaches and the rule (from :func:`uavwind.analysis.claims.compare_readings`)."""
    names = {"inferred": "Inferred reading", "halves": "Halves (decision 5)"}
    parts = []
    for cid, row in verdicts.iterrows():
        lines = [f"**{cid}.** {row['statement']}", ""]
        lines += [f"- *{names.get(r, r)}: {row[f'verdict ({r})']}.* "
                  f"{_sentence(row[f'evidence ({r})'])}" for r in readings]
        lines += ["", f"*What the difference teaches.* {row['lesson']}", "",
                  f"*Rule.* {row['rule']}"]
        parts.append("\n".join(lines))
    return "\n\n".join(parts)


def _sentence(text: str) -> str:
    """``text`` as a sentence after a full stop: its first letter capitalised ("means by
    scenario: ..." follows "*cannot decide.*")."""
    text = str(text)
    return text[:1].upper() + text[1:]


def verdicts_markdown(verdicts: pd.DataFrame) -> str:
    """A table of verdicts with their evidence (``verdict`` and ``evidence`` columns, one row
    per case named by its index) as a Markdown list, one item per row: "**point mass, none**:
    *cannot decide*. <evidence>". The evidence is prose with Markdown in it (`make book`),
    which a table's cell would print with its backticks, and a paragraph a cell squeezes."""
    missing = {"verdict", "evidence"} - set(verdicts.columns)
    if missing:
        raise ValueError("verdicts must have the columns verdict and evidence, missing "
                         f"{sorted(missing)}")
    items = []
    for key, row in verdicts.iterrows():
        name = ", ".join(str(k) for k in key) if isinstance(key, tuple) else str(key)
        items.append(f"- **{name}**: *{row['verdict']}*. {_sentence(row['evidence'])}")
    return "\n".join(items)
