"""Old import paths: the flat modules of uavwind 0.1, kept importable for one release.

The package was arranged into subpackages by layer (``core``, ``sim``, ``method``,
``study``, ``analysis``, ``report``), and 0.1's ``SimulationSettings`` (never used by a
setting) went. Code that still imports ``uavwind.scenarios`` or
``uavwind.softdtw`` gets the module that now owns those names, with one
``DeprecationWarning`` naming the new place. A module that moved whole is the same object
under both names (so its numba kernels and caches are not loaded twice); one that was
split is a read-only view of the names of its successors.
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

#: old dotted name -> the module(s) that now own its names, first one first
MOVED = {
    "uavwind.config": ("uavwind.sim.vehicle", "uavwind.core.checks"),
    "uavwind.stats": ("uavwind.core.stats",),
    "uavwind.actions": ("uavwind.sim.actions",),
    "uavwind.wind": ("uavwind.sim.wind",),
    "uavwind.dryden": ("uavwind.sim.dryden",),
    "uavwind.dynamics": ("uavwind.sim.dynamics",),
    "uavwind.observation": ("uavwind.sim.observation",),
    "uavwind.clustering": ("uavwind.method.clustering",),
    "uavwind.softdtw": ("uavwind.method.softdtw",),
    "uavwind.search": ("uavwind.method.search", "uavwind.core.seeding", "uavwind.core.stats"),
    "uavwind.baseline": ("uavwind.method.baseline",),
    "uavwind.scenarios": ("uavwind.study.conditions", "uavwind.study.layouts",
                          "uavwind.study.readings", "uavwind.study.builders",
                          "uavwind.sim.setting"),
    "uavwind.experiments": ("uavwind.study.registry", "uavwind.study.runner",
                            "uavwind.study.profiles", "uavwind.study.readings",
                            "uavwind.analysis.tables", "uavwind.study.cache"),
    "uavwind.cache": ("uavwind.study.cache",),
    "uavwind.fill": ("uavwind.study.fill",),
    "uavwind.paper": ("uavwind.study.paper",),
    "uavwind.inference": ("uavwind.analysis.inference",),
    "uavwind.beyond": ("uavwind.analysis.beyond",),
    "uavwind.claims": ("uavwind.analysis.claims",),
    "uavwind.display": ("uavwind.report.display",),
    "uavwind.plotting": ("uavwind.report.plotting",),
    "uavwind.explore": ("uavwind.report.explore",),
    "uavwind.performance": ("uavwind.report.performance",),
}


def _successor(name):
    """``(old name, new names)`` for ``name`` or a submodule of a moved package, else None."""
    if name in MOVED:
        return name, MOVED[name]
    for old, new in MOVED.items():
        if len(new) == 1 and name.startswith(old + "."):
            return name, (new[0] + name[len(old):],)
    return None


class _OldPaths(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old dotted names and hands out their successors."""

    def find_spec(self, name, path=None, target=None):
        if _successor(name) is None:
            return None
        return importlib.util.spec_from_loader(name, self)

    def create_module(self, spec):
        old, new = _successor(spec.name)
        warnings.warn(f"{old} is deprecated and will be removed in the next release: import "
                      f"from {' / '.join(new)}", DeprecationWarning, stacklevel=2)
        mods = [importlib.import_module(n) for n in new]
        if len(mods) == 1:
            return mods[0]  # the very module: one set of objects under both names
        view = types.ModuleType(old, f"Deprecated: the names of {', '.join(new)}.")
        for m in reversed(mods):  # the first successor wins a name two of them define
            view.__dict__.update({k: v for k, v in vars(m).items() if not k.startswith("__")})
        return view

    def exec_module(self, module):
        pass


MISSING = object()


def old_attribute(name):
    """What ``uavwind.<name>`` meant in 0.1 if it no longer exists there (warns), else
    :data:`MISSING`."""
    old = f"uavwind.{name}"
    if old in MOVED:
        return importlib.import_module(old)
    if name in ("SimulationSettings", "PAPER_SIMULATION"):
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


def install():
    """Put the finder first on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _OldPaths) for f in sys.meta_path):
        sys.meta_path.insert(0, _OldPaths())
