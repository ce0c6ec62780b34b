"""Issue 66, the loop-resonance hypothesis, measured without changing the library: the real
pitch spread peaks at 0.8-1.0 Hz and grows with wind; is that the closed loop's resonance (a
slower attitude loop and motors than RotorPy's hummingbird scaled) driven by forcing that
grows with the wind (the fan's turbulence at a length scale far below MIL-F-8785C's 23 m)?

The twin is refitted whole (``twin_fit.calibrate_twin`` on the training controllers; the
gusts' intensity refitted on the force spread at 12.1 m/s as usual) with, patched in for the
run only: SE3's attitude loop at natural frequency ``att_w`` [rad/s] (RotorPy's: sqrt(544) =
23.3) and damping ``att_zeta`` (RotorPy's 1.0; 0 for ``att_w`` keeps both), the motor time
constant ``tau_m`` [s] (RotorPy's 0.005), and the Dryden gusts' length scale times
``len_factor`` (the filters' time scale ``L / V``; 1 is the twin's 23 m). Printed: the
validation table's score (``figure8.validation_score``), the same without the attitude-noise
rows, the pitch spreads, and two criteria that use the training controllers only (never the
held-out one): the still-air pitch deviation's variance share in 0.7-1.2 Hz and its spectral
centroid in 0.3-2 Hz (a handle for the attitude/motor lag), and the scaled misses of the pitch
spread at the training winds (a handle for the gust length).

Measured (paper profile, SIM_VERSION 9, each row one refit, about 90 s):

=====  =====  ====  =====  ======  ===========  =====  ==========  ====================
tau_m  att_w  zeta  len x  score   w/o att.     pitch  still-air   training-wind pitch
                                   noise rows   8.5    share/cent  misses (sum sq.)
=====  =====  ====  =====  ======  ===========  =====  ==========  ====================
0.005  23.3   1.0   1      1.136   1.108        0.708  .391/.758   7.40 (the twin today)
0.005  23.3   1.0   0.05   1.133   1.061        0.766  .391/.758   5.19
0.03   23.3   1.0   1      1.355   1.105        0.710  --          --
0.03   23.3   1.0   0.02   1.552   1.096        0.752  .390/.760   5.62
0.005  8      0.6   1      1.309   1.167        0.679  --          --
0.005  8      0.6   0.05   1.228   1.085        0.858  --          --
0.005  8      0.6   0.02   1.194   1.061        0.905  .491/.729   1.87
0.005  8      0.6   0.015  1.197   1.070        0.907  .491/.729   1.92
0.005  10     0.6   0.05   1.140   1.069        0.840  --          --
0.005  10     0.6   0.02   1.088   1.048        0.877  .445/.762   2.64
0.005  8      0.5   0.05   1.206   1.057        0.852  --          --
0.005  8      0.5   0.02   1.171   1.034        0.918  --          --
0.03   10     0.6   0.1    1.112   1.084        0.806  .420/.786   4.16
0.03   10     0.6   0.05   1.074   1.059        0.851  .420/.786   3.19
0.03   10     0.6   0.03   1.018   1.026        0.900  .420/.786   2.52
0.03   10     0.6   0.02   1.004   1.034        0.910  .420/.786   2.41
0.03   10     0.6   0.015  0.996   1.042        0.915  .420/.786   2.37
0.03   11     0.6   0.02   1.062   1.025        0.907  .395/.800   2.33
0.03   9      0.6   0.02   1.095   1.036        0.899  .464/.783   2.51
0.03   8      0.6   0.015  1.173   1.054        0.954  .491/.763   1.57
0.035  10     0.6   0.02   1.018   1.041        0.880  .426/.786   2.71
0.02   10     0.6   0.02   1.054   1.047        0.886  .437/.786   2.49
=====  =====  ====  =====  ======  ===========  =====  ==========  ====================

(trivial model 1.232, without the attitude-noise rows 1.072; target <= 1.0; real pitch spread
at 8.5 m/s 0.911-1.500 deg; training still-air share 0.523, centroid 0.792 Hz.) Unstable or
unfittable: ``att_w`` 7 (zeta 0.6), 8 with zeta 0.4, ``tau_m`` >= 0.06 with RotorPy's attitude
loop (ground contact), ``tau_m`` 0.04 with ``att_w`` 8 (the gust fit does not converge),
``att_w`` 10 with zeta 0.5 (unstable at 12.1 m/s): the replicates' bandwidth spread (log-SD
0.25-0.32) puts the fastest controllers near the loop's edge. What it says: neither part alone
helps (the slow loop alone 1.31, the short gusts alone 1.13); together they move the pitch
spread at 8.5 m/s into or to the edge of the real range and, without the attitude-noise rows,
lower the score from 1.11 to 1.03-1.07. Both targets are met together only at a point picked by
looking at the held-out score (``tau_m`` 0.03, ``att_w`` 10, zeta 0.6, length 0.015 x 23 m =
0.35 m: 0.996, 0.915 deg), not by a training-only fit: the still-air share asks for a slower
loop (``att_w`` about 8: pitch 0.95 deg inside the range, score 1.17), the centroid barely
moves (0.76-0.80 Hz over the whole range), and the training winds' pitch misses fall
monotonically as the gusts shorten (the length fit takes its bound). Most of the score's rise
with a slower loop is the attitude-noise rows: the twin of today adds the training mean's noise
on top of its own content above 2 Hz, which a slow attitude loop no longer has, so the twin's
noise falls to the training mean, the trivial model's error (-4.7 and -3.7 at 4.2 and 8.5 m/s,
where the held-out controller is noisier). In the spectrum (``att_w`` 8, ``tau_m`` 0.03, length
0.015) the 0.7-1.2 Hz band grows with the wind (0.49, 0.63, 0.70, 0.72 deg at 0, 4.2, 8.5, 12.1
m/s; the training controllers' 0.46, 0.68, 0.88, 0.87) but the twin still holds too much below
0.3 Hz (0.34-0.50 at 8.5-12.1 m/s against 0.16-0.37), and its force spread lies flat to falling
with frequency where the real one rises (8.5 m/s, 0-0.3/0.3-0.7/0.7-1.2/1.2-2 Hz: twin 0.17
0.15 0.13 0.11 N, training mean 0.08 0.11 0.16 0.16).

``python benchmarks/twin_loop_resonance.py [paper|quick] tau_m att_w att_zeta len_factor``;
reads the real rows from (or fills) $UAVWIND_RESULTS, writes no twin rows there."""
import sys
import time

import numpy as np
import pandas as pd
from scipy.signal import welch

from twin_patch import fit_and_fly, patch
from uavwind.analysis import figure8, real_flights as rf, twin, twin_fit
from uavwind.data.neuralfly import CONDITIONS, cut_laps, load_neuralfly, pitch_degrees, split_noise

profile = sys.argv[1]
tau_m, att_w, att_z, len_f = map(float, sys.argv[2:6])
study = rf.STUDIES[profile]
patch(tau_m, att_w, att_z, len_f)
real = rf.real_flight_rows(profile=profile, n_jobs=1)
fl = real[real.kind == "flight"]
everyone = sorted(set(fl.controller))
held = twin_fit.held_out_controller(everyone)
train = [c for c in everyone if c != held]
t0 = time.time()
cal, flights, sim = fit_and_fly(real, study, train, held)
print(f"refitted in {time.time() - t0:.0f} s:",
      {k: v for k, v in cal.to_dict().items() if k not in ("noise", "fitted_on")})
val = figure8.validation_table(real, sim)
pd.set_option("display.width", 250)
pd.set_option("display.max_rows", 200)
print(val[["condition", "quantity", "sim", "held_out", "real_min", "real_max", "twin_error",
           "trivial_error", "fitted"]].round(3).to_string())
print("score", figure8.validation_score(val))
print("score without the attitude-noise rows",
      figure8.validation_score(val[val.quantity != "noise of the attitude x"]))
for c, r in val[val.quantity == "lap-to-lap spread of pitch"].set_index("condition").iterrows():
    print(f"pitch spread {c}: twin {r.sim:.3f} real {r.real_min:.3f}-{r.real_max:.3f}")

# training controllers only from here on
fs = study.n_samples / twin.FIGURE8.period


def still_air_spectrum(f):
    laps = cut_laps(f, split_noise(pitch_degrees(f.arrays["R"])[:, None], 0.02)[0],
                    study.n_samples, study.drop_first)
    fr, pp = welch((laps - laps.mean(0)).reshape(-1), fs=fs, nperseg=2 * study.n_samples)
    m, b = (fr >= 0.7) & (fr < 1.2), (fr >= 0.3) & (fr < 2.0)
    return pp[m].sum() / pp.sum(), (fr[b] * pp[b]).sum() / pp[b].sum()


tr = np.mean([still_air_spectrum(f) for f in load_neuralfly()
              if f.condition == "nowind" and f.controller in train], axis=0)
tw = np.mean([still_air_spectrum(f) for f in flights if f.condition == "nowind"], axis=0)
print(f"still-air pitch share in 0.7-1.2 Hz: twin {tw[0]:.3f}, training {tr[0]:.3f}; "
      f"centroid in 0.3-2 Hz: twin {tw[1]:.3f}, training {tr[1]:.3f}")
g = fl[fl.controller.isin(train)].groupby("condition")["pitch_spread"]
sp = sim.groupby("condition")["pitch_spread"].mean()
windy = [c for c in CONDITIONS if c != "nowind" and c in sp.index]
z = [(sp[c] - g.mean()[c]) / g.std(ddof=1)[c] for c in windy]
print("training winds' pitch spread, scaled misses:",
      " ".join(f"{c} {x:+.2f}" for c, x in zip(windy, z)),
      f"(sum of squares {np.sum(np.square(z)):.2f})")
