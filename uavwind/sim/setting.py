"""Everything one loop flies: two groups of wind environments, the vehicle, the time grid.

This module owns :class:`EnvironmentGroup` (the environments of one wind condition: constant
or shear velocities, or turbulence W20 speeds, and the wind model they make) and
:class:`Setting` (two groups, the thrust sampler, the vehicle, the time grid, what is
observed and how noisily). A setting is a frozen, hashable value with a stable
:meth:`Setting.key`, the digest the result cache files its loops under.

How the paper's words ("light constant vs strong shear, 5 environments each") become the
groups of a setting is :mod:`uavwind.study`'s; this module only says what a setting is.
"""

from __future__ import annotations

import hashlib
import json
import math
import pickle
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from ..core.checks import Range, check_fields, check_scalar
from ..core.seeding import child_seed, root_seed
from .actions import SAMPLERS
from .manoeuvres import FLYABLE, FlyableLimits  # registers the "waypoints" sampler
from .cited_dryden import CitedDryden
from .dryden import VARIANTS, DrydenWind
from .mil_dryden import dryden_parameters
from .dynamics import simulate, simulate_flight
from .observation import Noise, check_observation, noise_seed, observe
from .multirotor import Multirotor
from .rotor_params import SE3_KD_POS, SE3_KP_POS
from .variability import VARIABILITY_KEY, FlightVariability
from .vehicle import UAV, n_steps
from .wind import ConstantWind, RampedWind, ShearWind, WindGroups

if TYPE_CHECKING:
    from .actions import ThrustSequence
    from .flight import Flight

__all__ = ["KINDS", "EnvironmentGroup", "Setting"]

#: Flights :meth:`Setting.observe` keeps in this process, the most recently used: the cases
#: of an experiment that differ only in what is observed and how noisily (Exp 11's channels
#: and noise levels, Exp 14's channels, Exp 10's noise) fly the same loop with the same
#: seed, so a worker that computes them one after another flies each loop once: a
#: multirotor flight of 10 environments costs about 0.08 CPU-s, a tenth to a half of its
#: loop (the clustering is the rest), so Exp 11 saves about 0.07 CPU-s on 9 loops in 10.
#: 64 flights of 10 environments are about 20 MB; a chunk of 50 loops fits.
FLIGHTS_KEPT = 64
_FLIGHTS: OrderedDict = OrderedDict()


def _remembered_flight(setting: Setting, thrust, seed) -> Flight:
    """``setting._flight(thrust, seed)``, from :data:`_FLIGHTS` when this process flew it
    already under a setting equal but for what is observed (its observation, noise and
    baseline, which the flight does not depend on). The same doubles either way: a flight
    is a function of the setting's other fields, the action and the seed; its arrays are
    made read-only, so no reader can change what another reads. A seed of ``None`` (fresh
    entropy) is never kept."""
    if seed is None:
        return setting._flight(thrust, seed)
    root = root_seed(seed)
    try:
        key = (replace(setting, observation="position", noise=None, baseline=False, name=""),
               hashlib.sha256(pickle.dumps(thrust, protocol=5)).digest(),
               root.entropy, tuple(root.spawn_key), root.pool_size)
        hash(key)
    except (TypeError, pickle.PicklingError):  # pragma: no cover - an unhashable custom part
        return setting._flight(thrust, seed)
    flight = _FLIGHTS.get(key)
    if flight is not None:
        _FLIGHTS.move_to_end(key)
        return flight
    flight = setting._flight(thrust, seed)
    for v in vars(flight).values():
        if isinstance(v, np.ndarray):
            v.flags.writeable = False
    _FLIGHTS[key] = flight
    while len(_FLIGHTS) > FLIGHTS_KEPT:
        _FLIGHTS.popitem(last=False)
    return flight


@lru_cache(maxsize=256)
def _group_model(group: EnvironmentGroup) -> ConstantWind | ShearWind | DrydenWind:
    """``group``'s wind model, checked once (a turbulence group's drawn from seed 0, which
    :meth:`EnvironmentGroup.wind` reseeds). Models are shared between loops and never
    changed after they are built."""
    if group.kind == "constant":
        return ConstantWind(group.values)
    if group.kind == "shear":
        return ShearWind(group.values, reference_height=group.reference_height,
                         alpha=group.alpha, floor=group.floor)
    return DrydenWind(group.values, altitude=group.altitude, seed=0, variant=group.variant,
                      cited=group.cited)


#: Wind models a condition can use.
KINDS = ("constant", "shear", "turbulence")

@dataclass(frozen=True)
class EnvironmentGroup:
    """The environments of one wind condition.

    Parameters
    ----------
    kind : {"constant", "shear", "turbulence"}
    values : tuple
        ``constant``/``shear``: one velocity ``(x, y, z)`` [m/s] per environment
        (for shear, at ``reference_height``); ``turbulence``: one W20 [m/s]
        per environment.
    label : str
        Human-readable name, e.g. ``"light constant"``.
    alpha, reference_height, floor : float
        Shear profile (see :class:`~uavwind.sim.wind.ShearWind`).
    altitude : float
        Altitude of the Dryden parameters [m] (see :class:`~uavwind.sim.dryden.DrydenWind`).
    variant : {"mil-f-8785c", "cited"}
        Dryden variant of a turbulence group.
    cited : CitedDryden, optional
        Options of the cited variant (default: the code as published).
    """

    kind: str
    values: tuple
    label: str = ""
    alpha: float = 0.143
    reference_height: float = 10.0
    floor: float = 0.5
    altitude: float = 10.0
    variant: str = "mil-f-8785c"
    cited: CitedDryden | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {list(KINDS)}, got {self.kind!r}")
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {list(VARIANTS)}, got {self.variant!r}")
        if self.cited is not None and not isinstance(self.cited, CitedDryden):
            raise TypeError(f"cited must be a CitedDryden or None, got {type(self.cited).__name__}")
        if self.kind == "turbulence":
            vals = tuple(float(v) for v in np.ravel(self.values))
            if any(not (math.isfinite(v) and v > 0) for v in vals):
                raise ValueError("values (W20 speeds) must be finite and > 0 m/s")
        else:
            arr = np.asarray(self.values, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != 3:
                raise ValueError(f"values must have shape (n_env, 3) for {self.kind} wind, got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise ValueError("values must contain only finite velocities (no NaN or inf)")
            vals = tuple(tuple(float(x) for x in row) for row in arr)
        if len(vals) == 0:
            raise ValueError("values must describe at least one environment")
        object.__setattr__(self, "values", vals)

    @property
    def n_env(self) -> int:
        return len(self.values)

    @property
    def speeds(self) -> np.ndarray:
        """Wind speed of each environment [m/s]: ``|velocity|`` or W20."""
        if self.kind == "turbulence":
            return np.array(self.values)
        return np.linalg.norm(np.array(self.values), axis=1)

    def wind(self, seed: int | np.random.SeedSequence | None = None,
             ) -> ConstantWind | ShearWind | DrydenWind:
        """The :class:`~uavwind.sim.wind.WindModel` of this group (``seed`` for turbulence):
        the group's model, built and checked once per group and process, reseeded
        (:meth:`~uavwind.sim.wind.WindModel.with_seed`)."""
        return _group_model(self).with_seed(seed)

    def max_speed(self, height: float) -> float:
        """The strongest horizontal wind [m/s] a vehicle of this group meets up to ``height``
        [m]: the largest horizontal speed (a shear profile's at ``height``, where it is
        strongest), or for turbulence three standard deviations of the horizontal gusts
        (``3 sqrt(sigma_u^2 + sigma_v^2)`` at ``altitude``, MIL-F-8785C)."""
        height = check_scalar(height, "height", low=0.0, high=1e5)
        if self.kind == "turbulence":
            p = dryden_parameters(np.array(self.values), self.altitude)
            return float(3.0 * np.hypot(p["sigma_u"], p["sigma_v"]).max())
        v = np.linalg.norm(np.array(self.values)[:, :2], axis=1).max()
        if self.kind == "shear":
            v = v * max(1.0, (max(height, self.floor) / self.reference_height) ** self.alpha)
        return float(v)

    def subset(self, keep: Iterable[int]) -> EnvironmentGroup:
        """Group with only the environments at indices ``keep`` (order kept)."""
        keep = sorted(int(i) for i in keep)
        return replace(self, values=tuple(self.values[i] for i in keep))

    def negated(self) -> EnvironmentGroup:
        """Same group with every wind velocity reversed (Exp 5's opposite direction)."""
        if self.kind == "turbulence":
            raise ValueError("a turbulence group is zero-mean: it has no direction to negate")
        return replace(self, values=tuple(tuple(-x for x in v) for v in self.values),
                       label=f"{self.label} (reversed)".strip())

    def to_frame(self) -> pd.DataFrame:
        """The group as the paper prints it (Table 3): one row per environment."""
        if self.kind == "turbulence":
            return pd.DataFrame({"W20 (m/s)": self.values})
        return pd.DataFrame(np.array(self.values),
                            columns=["x axis (m/s)", "y axis (m/s)", "z axis (m/s)"])

    def __str__(self):
        return f"{self.label or self.kind} ({self.n_env} environments)\n{self.to_frame().to_string(index=False)}"

@dataclass(frozen=True)
class Setting:
    """Everything one simulation loop needs, apart from the thrust and the seed.

    Parameters
    ----------
    group_a, group_b : EnvironmentGroup
        The two wind conditions (groups 0 and 1).
    n_changes : int
        Thrust changes after t = 0 drawn by the sampler. Paper: 6.
    sampler : {"paper", "continuous", "attitude", "waypoints"}
        Action sampler (:data:`uavwind.sim.actions.SAMPLERS`): the paper's thrust, continuous
        thrust, attitude actions (a multirotor), or flyable waypoint references for the
        position controller (:func:`uavwind.sim.manoeuvres.sample_waypoints`: a multirotor
        starting from a hover at ``(0, 0, start_altitude)``, within
        :data:`~uavwind.sim.manoeuvres.FLYABLE`).
    uav : UAV or Multirotor
        The vehicle: the paper's point mass, or RotorPy's quadrotor
        (:class:`~uavwind.sim.multirotor.Multirotor`); part of the key.
    dt, duration, start_altitude : float
        Time step [s], flight time [s], initial height [m].
    name : str
        Short label for tables.
    observation : str
        What the loop clusters (:data:`uavwind.sim.observation.OBSERVATIONS`); the paper:
        ``"position"``.
    noise : Noise, optional
        Observation noise (:class:`uavwind.sim.observation.Noise`); the paper: none.
    baseline : bool
        Also run the physics baseline (:func:`uavwind.method.baseline.baseline_metrics`) on
        the observed positions of every loop (Exp 9).
    wind_ramp : float
        The wind fades in from still air over this many seconds
        (:class:`~uavwind.sim.wind.RampedWind`), in [0, duration]; 0 (default): it is there
        from t = 0, a step on a vehicle that starts at rest.
    flyable : FlyableLimits
        The budget of the ``"waypoints"`` sampler (default
        :data:`~uavwind.sim.manoeuvres.FLYABLE`, still air); one with a ``thrust_margin``
        makes room for the strongest wind of both groups (:meth:`waypoint_limits`).
    variability : FlightVariability, optional
        A multirotor as unsteady as a real one
        (:class:`~uavwind.sim.variability.FlightVariability`: state-estimate and thrust
        errors, battery, controller gains, gusts), drawn per loop from the loop's wind seed
        (spawn key ``(..., 3)``); None (default) or all sizes 0: the steady vehicle.
    """

    group_a: EnvironmentGroup
    group_b: EnvironmentGroup
    n_changes: int = 6
    sampler: str = "paper"
    uav: UAV | Multirotor = field(default_factory=UAV)
    dt: float = 0.1
    duration: float = 12.0
    start_altitude: float = 10.0
    name: str = ""
    observation: str = "position"
    noise: Noise | None = None
    baseline: bool = False
    wind_ramp: float = 0.0
    flyable: FlyableLimits = FLYABLE
    variability: FlightVariability | None = None

    def __post_init__(self):
        check_observation(self.observation)
        if self.noise is not None and not isinstance(self.noise, Noise):
            raise TypeError(f"noise must be a Noise or None, got {type(self.noise).__name__}")
        if not isinstance(self.baseline, bool):
            raise TypeError(f"baseline must be a bool, got {type(self.baseline).__name__}")
        for g in ("group_a", "group_b"):
            if not isinstance(getattr(self, g), EnvironmentGroup):
                raise TypeError(f"{g} must be an EnvironmentGroup, got {type(getattr(self, g)).__name__}")
        if self.sampler not in SAMPLERS:
            raise ValueError(f"sampler must be one of {sorted(SAMPLERS)}, got {self.sampler!r}")
        check_fields(self, {"n_changes": Range(0, integer=True)})
        if not isinstance(self.uav, (UAV, Multirotor)):
            raise TypeError(f"uav must be a UAV or a Multirotor, got {type(self.uav).__name__}")
        if self.sampler == "waypoints" and not (isinstance(self.uav, Multirotor)
                                                and self.uav.start == "hover"):
            raise ValueError(f"sampler 'waypoints' flies references with a position controller: "
                             f"it needs uav=Multirotor(start='hover'), got {self.uav!r}")
        if not isinstance(self.flyable, FlyableLimits):
            raise TypeError(f"flyable must be a FlyableLimits, got {type(self.flyable).__name__}")
        if self.sampler == "waypoints" and self.start_altitude < self.flyable.floor:
            raise ValueError(f"start_altitude must be >= {self.flyable.floor:g} m (the floor of the "
                             f"'waypoints' sampler) [m], got {self.start_altitude!r}")
        check_fields(self, {"wind_ramp": Range(0.0, self.duration)})
        if self.sampler == "waypoints":
            self.waypoint_limits()  # a wind the vehicle cannot hold: say so now, not mid-search
        if self.variability is not None:
            if not isinstance(self.variability, FlightVariability):
                raise TypeError(f"variability must be a FlightVariability or None, got "
                                f"{type(self.variability).__name__}")
            if not isinstance(self.uav, Multirotor):
                raise ValueError("variability needs uav=Multirotor(...): its sources (attitude "
                                 "estimate, thrust, battery, controller) are a multirotor's")
            if self.variability.needs_control and self.sampler != "waypoints":
                raise ValueError("variability: velocity_error, gain_spread and integral_spread "
                                 "act through a position controller, which only the "
                                 "'waypoints' sampler flies; set them to 0 for actions flown "
                                 "open loop")
            if (self.variability.has_errors and self.sampler == "waypoints"
                    and self.uav.position_control is None):
                raise ValueError("variability: a reference flight flies state errors under a "
                                 "position control with an integral term; give the vehicle a "
                                 "position_control (rotor_params.PositionControl)")
        if self.n_env < 3:
            raise ValueError(f"a setting needs at least 3 environments in all (two groups, one "
                             f"with two members, for a silhouette), got {self.group_a.n_env} + "
                             f"{self.group_b.n_env}")

    @property
    def n_env(self) -> int:
        return self.group_a.n_env + self.group_b.n_env

    @property
    def groups(self) -> np.ndarray:
        """Group of each environment, shape (n_env,): 0 for ``group_a``, 1 for ``group_b``."""
        return np.repeat([0, 1], [self.group_a.n_env, self.group_b.n_env])

    @property
    def plain(self) -> bool:
        """The paper's loop: positions, no noise, no baseline."""
        return self.observation == "position" and self.noise is None and not self.baseline

    @property
    def has_turbulence(self) -> bool:
        return "turbulence" in (self.group_a.kind, self.group_b.kind)

    def wind(self, seed: int | np.random.SeedSequence | None = None, gusts=None
             ) -> WindGroups | RampedWind:
        """A :class:`~uavwind.sim.wind.WindGroups` of both groups (ramped in over
        :attr:`wind_ramp` seconds, if set).

        ``seed`` (int or SeedSequence) seeds the turbulence; each group draws
        from its own child, so the groups' gusts are independent. ``gusts``: a wind model
        of every environment added to the groups' (a :class:`~uavwind.sim.wind.SumWind`,
        ramped in with them; the variability's gusts).
        """
        ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        sa, sb = ss.spawn(2)
        groups = WindGroups(self.group_a.wind(sa), self.group_b.wind(sb))
        if gusts is not None:
            groups = groups + gusts
        return RampedWind(groups, self.wind_ramp) if self.wind_ramp > 0 else groups

    def max_wind_speed(self) -> float:
        """The strongest horizontal wind [m/s] of either group up to the top of the
        waypoints' box (:meth:`EnvironmentGroup.max_speed`)."""
        top = self.start_altitude + self.flyable.half_height
        return max(self.group_a.max_speed(top), self.group_b.max_speed(top))

    def waypoint_limits(self) -> FlyableLimits:
        """What the ``"waypoints"`` sampler keeps to: :attr:`flyable`, in the strongest wind
        of the setting (:meth:`~uavwind.sim.manoeuvres.FlyableLimits.in_wind`) when it has
        a ``thrust_margin``."""
        return self.flyable.in_wind(self.uav, self.max_wind_speed())

    def sample_thrust(self, rng: np.random.Generator) -> ThrustSequence:
        """Draw one action with this setting's sampler (a waypoint reference starts at
        ``(0, 0, start_altitude)``)."""
        if self.sampler == "waypoints":
            return SAMPLERS[self.sampler](rng, n_changes=self.n_changes, duration=self.duration,
                                          start_altitude=self.start_altitude,
                                          limits=self.waypoint_limits())
        return SAMPLERS[self.sampler](rng, n_changes=self.n_changes, duration=self.duration)

    @property
    def varies(self) -> bool:
        """Whether a loop draws any variability (:attr:`variability` set and not all 0)."""
        return self.variability is not None and not self.variability.off

    def simulate(self, thrust: ThrustSequence,
                 seed: int | np.random.SeedSequence | None = None) -> np.ndarray:
        """Positions (n_env, n_steps, 3) [m] of all environments under ``thrust``."""
        if self.varies:
            return self._flight(thrust, seed).positions
        return simulate(thrust, self.wind(seed), uav=self.uav, dt=self.dt,
                        duration=self.duration, start_altitude=self.start_altitude)

    def _flight(self, thrust, seed) -> Flight:
        """The loop's :class:`~uavwind.sim.flight.Flight`, with its variability drawn from
        ``seed``'s spawn key ``(..., 3)`` (:mod:`uavwind.sim.variability`)."""
        if not self.varies:
            return simulate_flight(thrust, self.wind(seed), uav=self.uav, dt=self.dt,
                                   duration=self.duration, start_altitude=self.start_altitude)
        var = self.variability
        vs = child_seed(seed, VARIABILITY_KEY)
        uav = var.vehicle(self.uav, vs)
        speeds = np.concatenate([np.zeros(g.n_env) if g.kind == "turbulence" else g.speeds
                                 for g in (self.group_a, self.group_b)])
        gusts = var.gusts(speeds, self.start_altitude, self.dt, vs)
        wind = self.wind(seed, gusts=gusts)
        errors = None
        if var.has_errors:
            n_ctrl = n_steps(self.dt, self.duration) * uav.check_grid(self.dt)
            errors = var.state_errors(self.n_env, n_ctrl, uav.control_rate, vs)
        return simulate_flight(thrust, wind, uav=uav, dt=self.dt, duration=self.duration,
                               start_altitude=self.start_altitude, state_errors=errors)

    def observe(self, thrust: ThrustSequence, seed: int | np.random.SeedSequence | None = None,
                ) -> tuple[np.ndarray, Flight, np.ndarray | None]:
        """``(observations, flight, positions)`` of one loop: the observed channel with
        its noise (seeded from ``seed``'s spawn key ``(..., 2)``), the
        :class:`~uavwind.sim.flight.Flight`, and the noisy positions (what the baseline sees)."""
        flight = _remembered_flight(self, thrust, seed)
        ns = noise_seed(seed)
        obs = observe(flight, self.observation, self.noise, seed=ns, gravity=self.uav.gravity)
        if not self.baseline:
            return obs, flight, None
        pos = obs if self.observation == "position" else observe(
            flight, "position", self.noise, seed=noise_seed(seed), gravity=self.uav.gravity)
        return obs, flight, pos

    def to_dict(self) -> dict:
        return asdict(self)

    def key(self) -> str:
        """Stable 16-hex-digit digest of every field that changes results (all but ``name``)."""
        fields = self.to_dict()
        fields.pop("name")
        for g in ("group_a", "group_b"):  # the standard variant keeps its earlier keys
            if fields[g]["variant"] == "mil-f-8785c" and fields[g]["cited"] is None:
                del fields[g]["variant"], fields[g]["cited"]
        for k, default in (("observation", "position"), ("noise", None), ("baseline", False),
                           ("wind_ramp", 0.0)):
            if fields[k] == default:  # the paper's loop keeps its earlier keys
                del fields[k]
        del fields["flyable"]  # a waypoint setting's limits: below, as they were
        if self.variability is None or self.variability.off:  # added later: earlier keys
            del fields["variability"]  # kept, and no variability flies as none
        if fields.get("noise"):  # noise fields added later keep earlier keys while zero
            for k in ("attitude", "rate"):
                if fields["noise"].get(k) == 0.0:
                    del fields["noise"][k]
        if isinstance(self.uav, Multirotor):  # the point mass keeps its earlier keys
            fields["uav"] = {"vehicle": "multirotor, rotorpy==3.0.0", **fields["uav"]}
            for k, default in (("drag_scale", 1.0), ("lift_scale", 1.0),
                               ("position_control", None), ("hover_throttle", None),
                               ("rotor_drag_scale", 1.0)):
                if fields["uav"].get(k, default) == default:  # added later: earlier keys kept
                    fields["uav"].pop(k, None)
            control = fields["uav"].get("position_control")
            if control is not None:  # gains added later: SE3's keep earlier keys
                for k, default in (("kp", SE3_KP_POS), ("kd", SE3_KD_POS)):
                    if tuple(control.get(k, default)) == tuple(default):
                        control.pop(k, None)
        if self.sampler == "waypoints":  # the sampler's limits are part of what it flies
            fields["waypoint_limits"] = self.waypoint_limits().to_dict()
        blob = json.dumps(fields, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    def group_label(self, group: int) -> str:
        """Display name of group ``group`` (0 or 1): its condition's label, else "group 0"."""
        if group not in (0, 1):
            raise ValueError(f"group must be 0 or 1, got {group!r}")
        g = self.group_a if group == 0 else self.group_b
        return g.label or f"group {group}"

    def to_frame(self) -> pd.DataFrame:
        """Both groups side by side, as in the paper's Table 3."""
        return pd.concat({self.group_label(0): self.group_a.to_frame(),
                          self.group_label(1): self.group_b.to_frame()}, axis=1)

    def __str__(self):
        return (f"Setting {self.name!r}: {self.group_a.label} ({self.group_a.n_env}) vs "
                f"{self.group_b.label} ({self.group_b.n_env}), {self.n_changes} thrust changes")
