"""uavwind: wind estimation for UAVs with causal curiosity, a reproducible replication.

A point-mass UAV flies one open-loop thrust sequence through two groups of wind
environments; its position trajectories are clustered with soft-DTW k-means
and the silhouette score rewards thrust sequences that separate the groups.

The package is layered, data flowing one way (a layer imports only the layers below it):

* :mod:`uavwind.core` -- input checks, seeding, workers, atomic writes, statistics;
* :mod:`uavwind.data` -- measured flights (Neural-Fly's, read from a folder you name);
* :mod:`uavwind.sim` -- vehicles, actions, winds, Dryden turbulence, dynamics,
  observations, and the :class:`~uavwind.sim.setting.Setting` one loop flies;
* :mod:`uavwind.method` -- clustering (and its fast engine), search, the physics baseline;
* :mod:`uavwind.study` -- the paper's conditions, layouts and readings, the experiments as
  data, the runner, the cache and the fill;
* :mod:`uavwind.analysis` -- summary tables, the inference, beyond the paper, the claims;
* :mod:`uavwind.report` -- display names, figures, the explorer, the performance page.

>>> import uavwind as uw
>>> setting = uw.table3_setting()
>>> traj = setting.simulate(uw.PAPER_EXAMPLE)
>>> traj.shape
(10, 120, 3)
"""

from . import _compat
from ._version import __version__

_compat.install()  # the module paths 0.1's users import keep working for one release

from .data.neuralfly import RealFlight, load_neuralfly  # noqa: E402
from .method.baseline import estimate_wind  # noqa: E402
from .method.wind_estimator import WindEstimator  # noqa: E402
from .method.closed_loop import ClosedLoop, run_episodes  # noqa: E402
from .method.clustering import ClusteringParams, LoopResult, score_loop, score_loops  # noqa: E402
from .method.search import CEMResult, cem, random_search  # noqa: E402
from .report.display import pretty  # noqa: E402
from .sim.actions import (MAX_THRUST, PAPER_EXAMPLE, SAMPLERS, AttitudeSequence,  # noqa: E402
                          ThrustSequence, sample_attitude, sample_continuous, sample_paper)
from .sim.cited_dryden import CitedDryden, cited_dryden_parameters, cited_gusts  # noqa: E402
from .sim.dryden import DrydenWind  # noqa: E402
from .sim.dynamics import simulate, simulate_flight  # noqa: E402
from .sim.flight import Flight  # noqa: E402
from .sim.manoeuvres import (FLYABLE, FLYABLE_IN_WIND, FlyableLimits, check_flyable,  # noqa: E402
                             sample_waypoints)
from .sim.mil_dryden import dryden_parameters, dryden_psd, dryden_transfer_functions  # noqa: E402
from .sim.multirotor import Multirotor  # noqa: E402
from .sim.references import Hover, Lemniscate, Reference, WaypointSpline  # noqa: E402
from .sim.rotor_params import PositionControl  # noqa: E402
from .sim.observation import CONSUMER_NOISE, CONSUMER_SENSORS, OBSERVATIONS, Noise  # noqa: E402
from .sim.setting import EnvironmentGroup, Setting  # noqa: E402
from .sim.vehicle import PAPER_UAV, UAV  # noqa: E402
from .sim.wind import (CombinedWind, ConstantWind, RampedWind, ShearWind,  # noqa: E402
                       SinusoidalWind, SumWind, WindGroups, WindModel)
from .study.builders import (direction_settings, environment_count_settings,  # noqa: E402
                             make_group, make_setting, range_similarity_settings)
from .study.conditions import (PAPER_SCENARIOS, SPEED_RANGES, WindCondition,  # noqa: E402
                               scenario_table, table3_setting)
from .study.layouts import INFERRED_GAP_RATIOS, LAYOUTS, Layout, group_speeds, resolve_layout  # noqa: E402
from .study.readings import READINGS, Reading, get_reading  # noqa: E402
from .study.runner import run_experiment  # noqa: E402

__all__ = [
    # sim
    "UAV", "PAPER_UAV", "ThrustSequence", "sample_paper", "sample_continuous", "SAMPLERS",
    "MAX_THRUST", "PAPER_EXAMPLE", "WindModel", "ConstantWind", "ShearWind", "WindGroups",
    "CombinedWind", "SumWind", "RampedWind", "SinusoidalWind",
    "DrydenWind", "CitedDryden", "dryden_parameters", "dryden_transfer_functions", "dryden_psd",
    "cited_dryden_parameters", "cited_gusts", "simulate", "simulate_flight", "Flight",
    "Noise", "CONSUMER_NOISE", "CONSUMER_SENSORS", "OBSERVATIONS", "EnvironmentGroup",
    "Setting", "Multirotor", "PositionControl", "AttitudeSequence", "sample_attitude",
    "Reference", "Hover", "Lemniscate", "WaypointSpline", "FlyableLimits", "FLYABLE",
    "FLYABLE_IN_WIND", "sample_waypoints",
    "check_flyable",
    # data
    "load_neuralfly", "RealFlight",
    # method
    "score_loop", "score_loops", "LoopResult", "ClusteringParams", "random_search", "cem",
    "CEMResult",
    "estimate_wind", "WindEstimator", "ClosedLoop", "run_episodes",
    # study
    "SPEED_RANGES", "WindCondition", "PAPER_SCENARIOS", "scenario_table", "table3_setting",
    "Layout", "LAYOUTS", "INFERRED_GAP_RATIOS", "resolve_layout", "group_speeds", "Reading",
    "READINGS", "get_reading", "make_group", "make_setting", "range_similarity_settings",
    "environment_count_settings", "direction_settings", "run_experiment",
    # report
    "pretty",
    "__version__",
]


# the analyses join the study's registry where they are defined, in the layers above it,
# which it cannot import: the package's face imports the modules that register them, so the
# registry (python -m uavwind list, run ID, fill_cache("all")) is whole wherever uavwind is
# imported (tests/test_registry.py: every module that registers is imported here)
# (in the order the fill has always put them: the long ones first)
from .report import explore  # noqa: E402,F401
from .analysis import filters, exp13, page_analyses, sensitivity  # noqa: E402,F401,I001


def __getattr__(name):
    """Names of 0.1 that moved or went: ``uavwind.<old module>`` as an attribute
    (``from uavwind import experiments as ex``, as 0.1's README showed) and
    ``uw.SimulationSettings``, through :mod:`uavwind._compat` (a ``DeprecationWarning``
    naming the new import path)."""
    found = _compat.old_attribute(name)
    if found is _compat.MISSING:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return found
