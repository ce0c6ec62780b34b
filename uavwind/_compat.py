"""The names of uavwind 0.1 that its users import and that moved, kept for one release.

0.1 was a package of flat modules; 0.2 arranged them into subpackages by layer. Its users
wrote ``import uavwind as uw`` (every ``uw.X`` of 0.1 still works, but for the two below)
and, as 0.1's README showed, three module paths: ``from uavwind import experiments as ex``
(``ex.EXPERIMENTS``, ``ex.run_experiment``, ``ex.comparison_table``),
``uavwind.fill.fill_cache`` and ``from uavwind.softdtw import SoftDTWKMeans,
silhouette_score``. This module owns those names (:data:`OLD_NAMES`) and 0.1's
``uw.SimulationSettings`` / ``uw.PAPER_SIMULATION`` (no setting ever used them: a
:class:`~uavwind.sim.setting.Setting` carries its own time grid). Each still works and
raises a ``DeprecationWarning`` naming where to import it from now; any other name of an
old module is an ``AttributeError`` that says where its module went. Nothing in uavwind,
its pages or its benchmarks imports them.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import types
import warnings
from dataclasses import dataclass

from .core.checks import check_scalar
from .sim.vehicle import n_steps

#: old module -> {name users of 0.1 import from it: the module to import it from now}
OLD_NAMES = {
    "uavwind.experiments": {"EXPERIMENTS": "uavwind.study.registry",
                            "run_experiment": "uavwind.study.runner",
                            "comparison_table": "uavwind.analysis.tables"},
    "uavwind.fill": {"fill_cache": "uavwind.study.fill"},
    "uavwind.softdtw": {"SoftDTWKMeans": "uavwind.method.softdtw",
                        "silhouette_score": "uavwind.method.softdtw"},
}

#: old module -> the package its other names went to (named in the AttributeError)
_NOW_IN = {"uavwind.experiments": "uavwind.study", "uavwind.fill": "uavwind.study.fill",
           "uavwind.softdtw": "uavwind.method.softdtw"}

#: 0.1's ``uw.X`` names that went
OLD_TOP = ("SimulationSettings", "PAPER_SIMULATION")


def _deprecated(old: str, name: str, new: str, stacklevel: int = 3) -> None:
    warnings.warn(f"{old}.{name} is deprecated and will be removed in the next release: "
                  f"use 'from {new} import {name}'", DeprecationWarning, stacklevel=stacklevel)


def _old_module(old: str) -> types.ModuleType:
    """The module object ``old`` names: its names of :data:`OLD_NAMES`, each warning."""
    names = OLD_NAMES[old]
    mod = types.ModuleType(old, f"Deprecated (uavwind 0.1): import {', '.join(names)} from "
                                f"{' / '.join(dict.fromkeys(names.values()))}.")

    def __getattr__(name):
        if name not in names:
            raise AttributeError(f"module {old!r} has no attribute {name!r} (uavwind 0.1's "
                                 f"{old} is gone: its names are in {_NOW_IN[old]})")
        _deprecated(old, name, names[name])
        return getattr(importlib.import_module(names[name]), name)

    mod.__getattr__ = __getattr__
    mod.__all__ = list(names)
    return mod


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the module paths of :data:`OLD_NAMES` and hands out their modules."""

    def find_spec(self, name, path=None, target=None):
        return importlib.util.spec_from_loader(name, self) if name in OLD_NAMES else None

    def create_module(self, spec):
        return _old_module(spec.name)

    def exec_module(self, module):
        pass


MISSING = object()


def old_attribute(name: str):
    """What ``uavwind.<name>`` meant in 0.1 if it went (a module of :data:`OLD_NAMES`, or a
    name of :data:`OLD_TOP`, which warns), else :data:`MISSING`."""
    if f"uavwind.{name}" in OLD_NAMES:
        return importlib.import_module(f"uavwind.{name}")
    if name in OLD_TOP:
        warnings.warn(f"uavwind.{name} is deprecated and will be removed in the next release: "
                      f"a Setting carries dt, duration and start_altitude itself",
                      DeprecationWarning, stacklevel=3)
        return SimulationSettings if name == "SimulationSettings" else SimulationSettings()
    return MISSING


@dataclass(frozen=True)
class SimulationSettings:
    """Deprecated (unused since 0.1): the time grid of one flight. A
    :class:`~uavwind.sim.setting.Setting` carries ``dt``, ``duration`` and
    ``start_altitude`` itself.

    >>> SimulationSettings().n_steps
    120
    """

    dt: float = 0.1
    duration: float = 12.0
    start_altitude: float = 10.0

    def __post_init__(self):
        object.__setattr__(self, "dt", check_scalar(self.dt, "dt", low=0, low_inclusive=False))
        object.__setattr__(self, "duration", check_scalar(self.duration, "duration", low=0,
                                                          low_inclusive=False))
        object.__setattr__(self, "start_altitude",
                           check_scalar(self.start_altitude, "start_altitude"))
        n_steps(self.dt, self.duration)

    @property
    def n_steps(self) -> int:
        """Number of recorded samples, duration / dt (120 for the paper)."""
        return n_steps(self.dt, self.duration)


def install() -> None:
    """Put the finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.insert(0, _OldPaths())
