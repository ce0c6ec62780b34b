"""Foundations every layer may use: input checks, the one statistics module.

Nothing here knows about winds, UAVs or experiments; it imports nothing of uavwind.
"""
