"""The twin against the held-out controller (Exp 13, issue 66): its validation table, its
mean scaled error over the physical quantities beside the training mean's, and its pitch
lap-to-lap spread per wind.
`python benchmarks/twin_score.py [quick|paper] [on|off] [wind|one] [tilt] [fitnoise]
[vertical=S] [integral=S|bandwidth]` (off: the twin of gusts and noise alone; one: the twin
fitted at one wind, its correlation time assumed; tilt: with the attitude estimate's error
in wind fitted on the pitch spread; fitnoise: the recorded noise fitted on the twin's own
content above the cutoff; vertical=S: share S of the still-air vertical error carried by the
vertical velocity estimate, not the thrust, instead of the share's fit; vertical=0 is the
twin of SIM_VERSION 7; integral=S|bandwidth: the integral gain's log-SD S, or the
bandwidth's, instead of its fit; integral=bandwidth is the twin of SIM_VERSION 8); reads and
fills $UAVWIND_RESULTS."""
import sys
import time

import pandas as pd

from uavwind.analysis import figure8, real_flights as rf

profile = sys.argv[1] if len(sys.argv) > 1 else "quick"
variability = (sys.argv[2] != "off") if len(sys.argv) > 2 else True
per_wind = (sys.argv[3] != "one") if len(sys.argv) > 3 else True
tilt = "tilt" in sys.argv[4:]
fit_noise = "fitnoise" in sys.argv[4:]
share = [float(a.split("=")[1]) for a in sys.argv[4:] if a.startswith("vertical=")]
share = share[0] if share else "fit"
integral = [a.split("=")[1] for a in sys.argv[4:] if a.startswith("integral=")]
integral = (("bandwidth" if integral[0] == "bandwidth" else float(integral[0])) if integral
            else "fit")
real = rf.real_flight_rows(profile=profile, n_jobs=1)
t0 = time.process_time(); w0 = time.time()
sim = figure8.sim_rows(real, profile=profile, n_jobs=1, variability=variability,
                       per_wind=per_wind, pitch_turbulence=tilt, fit_noise=fit_noise,
                       vertical_share=share, integral_spread=integral)
print(f"twin rows: {time.process_time()-t0:.1f} CPU-s (this process), {time.time()-w0:.1f} s wall")
val = figure8.validation_table(real, sim)
c = figure8.calibration_of(sim); print({k: v for k, v in c.to_dict().items() if k != "noise"})
pd.set_option("display.width", 250)
pd.set_option("display.max_rows", 200)
print(val[["condition", "quantity", "sim", "sim_min", "sim_max", "held_out", "real_min", "real_max",
           "twin_error", "trivial_error", "fitted"]].round(3).to_string())
print("score", figure8.validation_score(val))
print("score (predicted only)", figure8.validation_score(val, True))
p = val[(val.quantity == "lap-to-lap spread of pitch")].set_index("condition")
for c in p.index:
    r = p.loc[c]
    print(f"pitch spread {c}: twin {r.sim:.3f} [{r.sim_min:.3f}, {r.sim_max:.3f}] "
          f"real {r.real_min:.3f}-{r.real_max:.3f}")
