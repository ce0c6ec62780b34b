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

from .actions import (MAX_THRUST, PAPER_EXAMPLE, SAMPLERS, ThrustSequence, sample_continuous,
                      sample_paper)
from .clustering import LoopResult, score_loop
from .baseline import estimate_wind
from .display import pretty
from .observation import CONSUMER_NOISE, OBSERVATIONS, Noise
from .config import PAPER_SIMULATION, PAPER_UAV, UAV, SimulationSettings
from .dynamics import Flight, simulate, simulate_flight
from .scenarios import (INFERRED_GAP_RATIOS, LAYOUTS, PAPER_SCENARIOS, READINGS, SPEED_RANGES,
                        EnvironmentGroup, Layout, Reading, Setting, WindCondition,
                        direction_settings, environment_count_settings, get_reading, group_speeds,
                        make_group, make_setting, range_similarity_settings, resolve_layout,
                        scenario_table, table3_setting)
from .search import CEMResult, cem, random_search, summarise
from .dryden import (CitedDryden, DrydenWind, cited_dryden_parameters, cited_gusts,
                     dryden_parameters, dryden_psd, dryden_transfer_functions)
from .wind import CombinedWind, ConstantWind, ShearWind, WindModel


__version__ = "0.1.0"
