"""The method: soft-DTW clustering of one loop, the search over thrust sequences, and the
physics baseline it is compared with.

Imports :mod:`uavwind.sim` and :mod:`uavwind.core`, nothing above.
"""
