"""The paper's wind conditions: speed classes, the Table 2 scenarios and the worked example.

This module owns the paper's vocabulary of winds (replication notes, decision 5):

* :data:`SPEED_RANGES` -- the US National Weather Service classes [m/s];
* :class:`WindCondition` -- a strength and a kind (``"light shear"``, ...);
* :data:`PAPER_SCENARIOS` and :func:`scenario_table` -- the seven condition pairs of Table 2;
* :func:`table3_setting` -- the worked example of Table 3, verbatim;
* :data:`HORIZONTAL` -- the direction generated winds blow along (x = y).

Where a pair's environments sit inside these ranges is :mod:`uavwind.study.layouts`'.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import pandas as pd

from ..sim.setting import KINDS, EnvironmentGroup, Setting

__all__ = ["SPEED_RANGES", "HORIZONTAL", "WindCondition", "PAPER_SCENARIOS", "scenario_table",
           "table3_setting"]

#: NWS wind-speed classes [m/s] (paper section "Experiments").
SPEED_RANGES = {"light": (0.45, 1.34), "strong": (11.18, 13.86)}


#: Default direction of generated winds: horizontal, x = y.
HORIZONTAL = (math.sqrt(0.5), math.sqrt(0.5), 0.0)


@dataclass(frozen=True)
class WindCondition:
    """A wind class: strength (``"light"``/``"strong"``) and kind (constant, shear, turbulence).

    >>> WindCondition.parse("light shear")
    WindCondition(strength='light', kind='shear')
    """

    strength: str
    kind: str

    def __post_init__(self):
        if self.strength not in SPEED_RANGES:
            raise ValueError(f"strength must be one of {sorted(SPEED_RANGES)}, got {self.strength!r}")
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {list(KINDS)}, got {self.kind!r}")

    @classmethod
    def parse(cls, text: str | WindCondition) -> WindCondition:
        """From ``"light constant"``, ``"strong turbulence"``, ... (or a WindCondition)."""
        if isinstance(text, WindCondition):
            return text
        if not isinstance(text, str):
            raise TypeError(f"condition must be a string like 'light constant', got {type(text).__name__}")
        parts = text.lower().split()
        if len(parts) != 2:
            raise ValueError(f"condition must read '<strength> <kind>', e.g. 'light constant', got {text!r}")
        return cls(*parts)

    @property
    def label(self) -> str:
        return f"{self.strength} {self.kind}"

    @property
    def speed_range(self) -> tuple[float, float]:
        return SPEED_RANGES[self.strength]


#: Table 2: scenario number -> (wind condition 1, wind condition 2).
PAPER_SCENARIOS = {
    1: (WindCondition("light", "constant"), WindCondition("light", "constant")),
    2: (WindCondition("light", "constant"), WindCondition("strong", "constant")),
    3: (WindCondition("strong", "constant"), WindCondition("strong", "constant")),
    4: (WindCondition("light", "shear"), WindCondition("light", "shear")),
    5: (WindCondition("light", "shear"), WindCondition("strong", "shear")),
    6: (WindCondition("strong", "shear"), WindCondition("strong", "shear")),
    7: (WindCondition("light", "constant"), WindCondition("strong", "turbulence")),
}


def scenario_table() -> pd.DataFrame:
    """Table 2 as a DataFrame (index: scenario)."""
    return pd.DataFrame(
        [(k, a.label, b.label) for k, (a, b) in PAPER_SCENARIOS.items()],
        columns=["Scenario", "Wind condition 1", "Wind condition 2"]).set_index("Scenario")


def table3_setting(**kwargs: Any) -> Setting:
    """The worked example, Table 3 verbatim: strong shear (group 0) vs light constant (group 1)."""
    shear = EnvironmentGroup("shear", [(2.1 + 0.1 * i, 10.1 + 0.1 * i, 0.0) for i in range(5)],
                             label="strong shear")
    const = EnvironmentGroup("constant", [(1.1 + 0.1 * i,) * 2 + (0.0,) for i in range(5)],
                             label="light constant")
    kwargs.setdefault("name", "strong shear vs light constant (Table 3)")
    return Setting(shear, const, **kwargs)
