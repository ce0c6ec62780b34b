"""uavwind: wind estimation for UAVs with causal curiosity, a reproducible replication.

A point-mass UAV flies one open-loop thrust sequence through two groups of wind
environments; its position trajectories are clustered with soft-DTW k-means
and the silhouette score rewards thrust sequences that separate the groups.

>>> import uavwind as uw
>>> setting = uw.table3_setting()
>>> traj = setting.simulate(uw.PAPER_EXAMPLE)
>>> traj.shape
(10, 120, 3)
"""

import warnings as _warnings

# tslearn warns at import that h5py (optional, unused here) is missing
_warnings.filterwarnings("ignore", message="h5py not installed", category=UserWarning)

from . import _compat

_compat.install()  # the flat module paths of 0.1 keep working for one release

from .sim.actions import (MAX_THRUST, PAPER_EXAMPLE, SAMPLERS, ThrustSequence, sample_continuous,
                      sample_paper)
from .method.clustering import LoopResult, score_loop
from .method.baseline import estimate_wind
from .report.display import pretty
from .sim.observation import CONSUMER_NOISE, OBSERVATIONS, Noise
from .sim.vehicle import PAPER_SIMULATION, PAPER_UAV, UAV, SimulationSettings
from .sim.dynamics import Flight, simulate, simulate_flight
from .study.conditions import (INFERRED_GAP_RATIOS, LAYOUTS, PAPER_SCENARIOS, READINGS, SPEED_RANGES,
                        EnvironmentGroup, Layout, Reading, Setting, WindCondition,
                        direction_settings, environment_count_settings, get_reading, group_speeds,
                        make_group, make_setting, range_similarity_settings, resolve_layout,
                        scenario_table, table3_setting)
from .method.search import CEMResult, cem, random_search, summarise
from .sim.dryden import (CitedDryden, DrydenWind, cited_dryden_parameters, cited_gusts,
                     dryden_parameters, dryden_psd, dryden_transfer_functions)
from .sim.wind import CombinedWind, ConstantWind, ShearWind, WindModel


__version__ = "0.1.0"


def __getattr__(name):
    """``uavwind.<old module>`` as an attribute (``uw.observation.Noise``): the flat module
    paths of 0.1, through :mod:`uavwind._compat` (one ``DeprecationWarning``)."""
    old = f"{__name__}.{name}"
    if old in _compat.MOVED:
        import importlib
        return importlib.import_module(old)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
