"""Closed-loop identification: one UAV in one unknown wind chooses its next segment from
what it has seen, and says which known condition it believes it is in, and how sure it is.

The paper's second piece of future work. Every other experiment flies one open-loop
sequence through many environments and scores the clustering; here one vehicle flies, and
the question is how many seconds it needs.

* :mod:`.problem` -- :class:`ClosedLoop` (known groups, decision grid, action set) and the
  held-out test environments;
* :mod:`.belief` -- the likelihood of the noisy positions and the posterior over groups;
* :mod:`.policies` -- open-loop random, open-loop best, closed-loop greedy and receding-
  horizon CEM, and their planning objective;
* :mod:`.episode` -- flying episodes, one row per reported belief.
"""

from .belief import Belief, Evidence
from .episode import EPISODE_COLUMNS, episode_environment, fly_episode, run_episodes
from .policies import (POLICIES, Greedy, OpenLoopBest, OpenLoopRandom, Policy, RecedingCEM,
                       Situation, categorical_cem, get_policy, separation_bound)
from .problem import ClosedLoop, held_out, segment_actions

__all__ = ["ClosedLoop", "held_out", "segment_actions", "Belief", "Evidence",
           "Policy", "OpenLoopRandom", "OpenLoopBest", "Greedy", "RecedingCEM", "POLICIES",
           "get_policy", "Situation", "separation_bound", "categorical_cem", "fly_episode",
           "episode_environment", "run_episodes", "EPISODE_COLUMNS"]
