"""The method: soft-DTW clustering of one loop, the search over thrust sequences, and the
physics baseline it is compared with.

* :mod:`.clustering` -- :func:`~uavwind.method.clustering.score_loop`, the paper's score of one loop;
* :mod:`.softdtw` -- the exact fast engine (:class:`~uavwind.method.softdtw.SoftDTWKMeans`);
* :mod:`.search` -- random exploration and the Cross-Entropy Method;
* :mod:`.baseline` -- a model-based wind estimate from the same positions;
* :mod:`.closed_loop` -- one vehicle in one unknown wind: a belief, four policies, episodes.

Imports :mod:`uavwind.sim` and :mod:`uavwind.core`, nothing above.
"""
