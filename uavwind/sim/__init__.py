"""The simulation (paper eqs 2-12): vehicles, actions, winds, Dryden turbulence, dynamics,
observations, and the :class:`~uavwind.sim.setting.Setting` one loop flies.

* :mod:`.vehicle` -- the point-mass UAV of the paper;
* :mod:`.multirotor` -- RotorPy's quadrotor as a vehicle (its kernels in ``_rotor_kernels``);
* :mod:`.rotor_params` -- the multirotor's parameters (the presets, the position controller);
* :mod:`.actions` -- open-loop thrust sequences and their samplers;
* :mod:`.references` -- position references a multirotor's position controller tracks;
* :mod:`.manoeuvres` -- flyable waypoint references, the actions of a position-controlled
  multirotor (the ``"waypoints"`` sampler);
* :mod:`.wind` -- the wind contract, constant and shear winds, several side by side;
* :mod:`.dryden` -- Dryden turbulence, MIL-F-8785C and the implementation the paper cites;
* :mod:`.dynamics` -- the integrator of eqs 2-8 (:mod:`.flight`: what one flight records);
* :mod:`.rollout` -- flights continued from given states, one command per row (closed loop);
* :mod:`.observation` -- what the UAV observes, and its noise;
* :mod:`.setting` -- two groups of environments, the vehicle and the grid of one loop.

The lowest domain layer: it imports only :mod:`uavwind.core`.
"""
