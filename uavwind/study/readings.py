"""Readings: named sets of answers to what the paper leaves open.

This module owns :class:`Reading` and :data:`READINGS` -- ``"inferred"`` (the paper reading:
the fitted lattice layout and the cited Dryden code as its packaged derivative runs it,
:data:`INFERRED_TURBULENCE`) and ``"halves"`` (decision 5, our first guess) -- with
:data:`DEFAULT_READING`, and the turbulence candidates the inference compares
(:data:`TURBULENCE_CANDIDATES`). Every experiment runs under a reading, and every table and
figure says which.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.checks import Range, check_fields
from ..sim.cited_dryden import CitedDryden
from ..sim.dryden import VARIANTS
from .conditions import HORIZONTAL
from .layouts import Layout, resolve_layout

__all__ = ["INFERRED_TURBULENCE", "TURBULENCE_CANDIDATES", "Reading", "READINGS",
           "DEFAULT_READING", "get_reading", "turbulence_fields"]

#: The paper reading of its turbulence: the cited implementation as its packaged
#: derivative runs it -- the level taken from each environment's W20, a seed per
#: environment, and the W20 as a base wind under the gusts ("strong turbulence" = a
#: strong wind with gusts). Chosen by :func:`uavwind.analysis.inference.compare_turbulence` as
#: the candidate closest to Table 4's light constant vs strong turbulence row.
INFERRED_TURBULENCE = CitedDryden(turbulence_level=None, seeds=None, base_direction=HORIZONTAL)


#: Readings of "strong turbulence" tried on Table 4's scenario 7 (label -> turbulence).
TURBULENCE_CANDIDATES = {
    "MIL-F-8785C (decision 4)": "mil-f-8785c",
    "cited, as published (level 15, fixed seeds)": CitedDryden(),
    "cited, level = W20, fixed seeds": CitedDryden(turbulence_level=None),
    "cited, level = W20, seed per environment": CitedDryden(turbulence_level=None, seeds=None),
    "cited, level = W20, seed per environment, W20 base wind": CitedDryden(
        turbulence_level=None, seeds=None, base_direction=HORIZONTAL),
    "cited, as published, W20 base wind": CitedDryden(base_direction=HORIZONTAL),
}


def turbulence_fields(turbulence: str | CitedDryden) -> tuple[str, CitedDryden | None]:
    """``(variant, cited)`` of an :class:`EnvironmentGroup` from ``turbulence``."""
    if isinstance(turbulence, CitedDryden):
        return "cited", turbulence
    if turbulence in VARIANTS:
        return turbulence, None
    raise ValueError(f"turbulence must be one of {list(VARIANTS)} or a CitedDryden, "
                     f"got {turbulence!r}")


@dataclass(frozen=True, kw_only=True)
class Reading:
    """A named set of answers to what the paper leaves open.

    Attributes
    ----------
    name : str
    layout : str or Layout
        Layout of the generated groups (see :func:`resolve_layout`).
    turbulence : str or CitedDryden
        Dryden variant of turbulence groups (``"mil-f-8785c"``, ``"cited"`` or the
        cited variant with options).
    long_run_per_group : int
        Environments per group of Exp 1's 500-loop light-vs-light case.
    description : str
    """

    name: str
    layout: object
    turbulence: object
    long_run_per_group: int
    description: str = ""

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.description, str):
            raise TypeError(f"description must be a string, got {type(self.description).__name__}")
        turbulence_fields(self.turbulence)
        if not isinstance(self.layout, Layout):
            resolve_layout(self.layout, "light constant", "light constant")
        check_fields(self, {"long_run_per_group": Range(2, 1000, integer=True)})

    @property
    def builder_kwargs(self) -> dict[str, str | Layout | CitedDryden]:
        """What this reading tells every setting builder: ``{"layout", "turbulence"}``
        (``make_setting(a, b, n, **reading.builder_kwargs)``)."""
        return {"layout": self.layout, "turbulence": self.turbulence}


READINGS = {
    "inferred": Reading(
        name="inferred", layout="inferred", turbulence=INFERRED_TURBULENCE,
        long_run_per_group=10, description="the paper reading: same-strength groups on the evenly spaced lattice of Table 3 "
        "with the gap fitted from Table 4; turbulence as the cited implementation computes "
        "it; Exp 1's 500-loop case with 10 environments per group"),
    "halves": Reading(
        name="halves", layout="halves", turbulence="mil-f-8785c", long_run_per_group=5,
        description="decision 5, our first guess: same-strength groups in adjacent halves of the class "
        "range; MIL-F-8785C turbulence"),
}


def get_reading(reading: str | Reading) -> Reading:
    """A :class:`Reading` by name (``"inferred"``, ``"halves"``) or itself."""
    if isinstance(reading, Reading):
        return reading
    if not isinstance(reading, str) or reading not in READINGS:
        raise ValueError(f"reading must be one of {sorted(READINGS)} or a Reading, got {reading!r}")
    return READINGS[reading]


#: The reading experiments run under unless told otherwise.
DEFAULT_READING = "inferred"
