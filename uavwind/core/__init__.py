"""Foundations every layer may use, knowing nothing of winds, UAVs or experiments:

* :mod:`.checks` -- input checks that name the parameter and the allowed range;
* :mod:`.seeding` -- seeding by SeedSequence address;
* :mod:`.parallel` -- worker counts, one thread per worker, stopping workers;
* :mod:`.io` -- what a write may replace, and the pages' read-only rule;
* :mod:`.store` -- the one verified cache: keys, digests, the atomic write, damaged entries;
* :mod:`.stats` -- the one summary and confidence interval.

It imports nothing of uavwind.
"""
