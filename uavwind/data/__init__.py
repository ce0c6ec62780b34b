"""Measured flights: real data the simulation is held against.

:mod:`uavwind.data.neuralfly` reads the Neural-Fly wind-tunnel flights (O'Connell et al.,
Science Robotics 2022) from a folder the user names. This layer sits just above
:mod:`uavwind.core` and below :mod:`uavwind.sim`: it knows files and their columns, nothing
of models. The data are never part of the package (the authors' terms): they are read from
where the user keeps them.
"""

from .neuralfly import (CHANNELS, CONDITIONS, RealFlight, channel_series, flight_laps,
                        load_neuralfly, neuralfly_folder)

__all__ = ["RealFlight", "CONDITIONS", "CHANNELS", "load_neuralfly", "neuralfly_folder",
           "flight_laps", "channel_series"]
