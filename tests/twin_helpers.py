"""What the twin's test modules share (test_twin_variability, test_twin_wind_fits,
test_twin_vertical, test_twin_noise_fit): a short study, a fitted-like twin without and with
the variability, flying it, and two training controllers' flight rows."""
from dataclasses import replace

import numpy as np
import pandas as pd

from uavwind.analysis import figure8, real_flights as rf

STUDY = rf.RealFlightStudy(max_laps=2)
DURATION = 27.0
BASE = figure8.TwinCalibration(drag_scale=0.73, lift_scale=0.62, gust_scale=0.08,
                               axis_offset=-2.6)
#: A twin flown on an imperfect state: its velocity estimate's error moves the attitude above
#: the cutoff (about 0.0015 in the attitude's x in still air) before any noise is added.
VARIED = replace(BASE, gain_spread=0.25, integral_spread=0.25, hover_throttle=0.48,
                 hover_throttle_sd=0.02, attitude_error=0.3, thrust_error=0.03,
                 velocity_error=0.04)


def fly(cal, condition="70wind", seed=0):
    return figure8.simulated_flight(cal.vehicle(), condition, seed, DURATION, cal)


def same(a, b):
    return all(np.array_equal(a.arrays[k], b.arrays[k]) for k in a.arrays)


def row(cal, condition="nowind", seed=0):
    return rf.flight_summaries([fly(cal, condition, seed)], STUDY)[0]


def training_rows(spread, still_air=None, noise=0.01, noise_step=0.0, per_controller=None):
    """Two training controllers' ("A", "B") flight rows at every wind: no force or pitch but
    -2.5 deg and +1 N in still air and -6 N, -0.4 N at the fit's wind, ``fa_x_spread``
    ``spread`` at the gusts' wind (and what ``still_air`` adds in still air), every noise
    column ``noise + noise_step i`` for controller i, and ``per_controller(i)``'s columns."""
    rows = []
    for i, c in enumerate(("A", "B")):
        for cond in figure8.CONDITIONS:
            r = {"kind": "flight", "controller": c, "condition": cond,
                 "aero_force_x": 0.0, "aero_force_z": 0.0, "pitch_deg": 0.0,
                 "fa_x_spread": 0.0, **(per_controller(i) if per_controller else {}),
                 **dict.fromkeys(rf.noise_columns(), noise + noise_step * i)}
            if cond == "nowind":
                r.update(pitch_deg=-2.5, aero_force_x=1.0, **(still_air or {}))
            if cond == figure8.FIT_CONDITION:
                r.update(aero_force_x=-6.0, aero_force_z=-0.4)
            if cond == figure8.SPREAD_CONDITION:
                r.update(fa_x_spread=spread)
            rows.append(r)
    return pd.DataFrame(rows)
