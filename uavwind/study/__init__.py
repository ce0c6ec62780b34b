"""The study: the paper's wind conditions, layouts and readings, the experiments as data,
and the runner, cache and fill that compute them.

* :mod:`.conditions` -- speed classes, Table 2's scenarios, the worked example;
* :mod:`.layouts` -- where a pair's environments sit (halves, gap, inferred);
* :mod:`.readings` -- named answers to what the paper leaves open;
* :mod:`.builders` -- settings from the paper's words (Exps 1-5);
* :mod:`.profiles` -- loop counts (paper, quick);
* :mod:`.cases` -- what each experiment flies, case by case;
* :mod:`.registry` -- THE registry: every computed thing by id (the experiments as data, the
  analyses registered where they are defined);
* :mod:`.runner` -- one experiment, as cache entries, into one table;
* :mod:`.cache` -- keys, verified reads, atomic writes, locks;
* :mod:`.fill` -- every missing entry of many experiments in one pool;
* :mod:`.paper` -- the paper's reported values.

Imports :mod:`uavwind.method`, :mod:`uavwind.sim` and :mod:`uavwind.core`, nothing above.
"""

from .cache import RESULTS_VERSION, results_dir
from .fill import fill_cache, needed_entries, time_by_experiment
from .paper import PAPER_FILES, load_paper_values
from .profiles import CHUNK, DEFAULT_SEED, PROFILES, Profile, get_profile
from .readings import DEFAULT_READING, READINGS, Reading, get_reading
from .registry import (ANALYSES, EXPERIMENTS, REGISTRY, Analysis, Case, Experiment, computes,
                       get_experiment, register)
from .runner import Entry, n_loops_total, run_experiment

__all__ = ["RESULTS_VERSION", "results_dir", "fill_cache", "needed_entries",
           "time_by_experiment", "PAPER_FILES", "load_paper_values", "CHUNK", "DEFAULT_SEED",
           "PROFILES", "Profile", "get_profile", "DEFAULT_READING", "READINGS", "Reading",
           "get_reading", "REGISTRY", "EXPERIMENTS", "ANALYSES", "Analysis", "computes",
           "register", "Case", "Experiment", "get_experiment", "Entry",
           "n_loops_total", "run_experiment"]
