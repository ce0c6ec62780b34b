"""The simulation: vehicles, actions, winds, Dryden turbulence, dynamics, observations.

The lowest domain layer (paper eqs 2-12): it imports only :mod:`uavwind.core`.
"""
