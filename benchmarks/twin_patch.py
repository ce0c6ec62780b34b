"""Shared by ``twin_loop_resonance.py`` and ``twin_loop_cv.py``: the twin's attitude loop,
motors and gust length patched in for one process without changing the library, and the
twin refitted and flown.

:func:`patch` sets, for the rest of the process: SE3's attitude loop at natural frequency
``att_w`` [rad/s] (RotorPy's: sqrt(544) = 23.3) and damping ``att_zeta`` (0 for ``att_w``
keeps RotorPy's gains), the motor time constant ``tau_m`` [s] (RotorPy's 0.005), and the
Dryden gusts' length scale times ``len_factor`` (the filters' time scale ``L / V``; 1 is the
twin's 23 m). :func:`fit_and_fly` calibrates the twin on ``train``
(``twin_fit.calibrate_twin``) and flies it at the study's winds, with ``held`` as the
controller its validation table checks."""
import functools
import json

import numpy as np
import pandas as pd

import uavwind.sim.multirotor as mr
from uavwind.analysis import real_flights as rf, twin, twin_fit
from uavwind.data.neuralfly import CONDITIONS
from uavwind.sim._slots import SE3_KD_ATT, SE3_KP_ATT, TAU_M

_packed = mr._packed


def patch(tau_m: float, att_w: float, att_zeta: float, len_factor: float) -> None:
    """Patch the kernels' parameter vector and the twin's wind for the rest of the process."""
    if not (tau_m > 0 and att_w >= 0 and len_factor > 0 and (att_w == 0 or att_zeta > 0)):
        raise ValueError(f"need tau_m > 0, att_w >= 0 (att_zeta > 0 with it), len_factor > 0; "
                         f"got {tau_m}, {att_w}, {att_zeta}, {len_factor}")

    @functools.lru_cache(maxsize=None)
    def patched(*a, **k):  # the kernels' parameter vector with the attitude loop and motors set
        P = np.array(_packed(*a, **k))
        P[TAU_M] = tau_m
        if att_w > 0:
            P[SE3_KP_ATT], P[SE3_KD_ATT] = att_w ** 2, 2 * att_zeta * att_w
        P.setflags(write=False)
        return P

    def wind(condition, seed, gust_scale):  # twin._wind, the gusts' time scale times len_factor
        from uavwind.sim.dryden import DrydenWind
        from uavwind.sim.wind import ConstantWind, RampedWind, SinusoidalWind
        speed = CONDITIONS[condition]
        if condition == "70p20sint":
            mean = SinusoidalWind([[-speed, 0.0, 0.0]], [[-2.4, 0.0, 0.0]], period=2 * np.pi)
        else:
            mean = ConstantWind([[-speed, 0.0, 0.0]])
        if gust_scale > 0 and speed > 0:
            mean = mean + DrydenWind([gust_scale * speed], altitude=twin.FIGURE8.center[2],
                                     dt=twin.DT, airspeed=speed / len_factor, seed=seed)
        return RampedWind(mean, twin.RAMP)

    mr._packed, twin._wind = patched, wind


def fit_and_fly(real: pd.DataFrame, study, train, held: str):
    """The twin calibrated on ``train``'s rows of ``real`` and flown at the study's winds (and
    the fit's): ``(cal, flights, sim)``, ``sim`` its flight rows with ``held`` as the
    held-out controller the validation table checks."""
    cal = twin_fit.calibrate_twin(real, study, list(train))
    conditions = tuple(c for c in CONDITIONS if not study.conditions or c in study.conditions
                       or c in (twin_fit.FIT_CONDITION, twin_fit.SPREAD_CONDITION))
    flights = twin.simulated_flights(cal, conditions=conditions,
                                     duration=twin.flight_duration(study))
    sim = pd.DataFrame(rf.flight_summaries(flights, study))
    sim["kind"] = "flight"
    sim.attrs.update(calibration=json.dumps(cal.to_dict()), held_out=held)
    return cal, flights, sim
