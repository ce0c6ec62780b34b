"""The study: the paper's wind conditions, layouts and readings, the experiments as data,
and the cache and fill that run them.

Imports :mod:`uavwind.method`, :mod:`uavwind.sim` and :mod:`uavwind.core`, nothing above.
"""
