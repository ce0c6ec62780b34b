"""Issue 66: a training-only choice of the twin's attitude loop, motors and gust length
(``benchmarks/twin_loop_resonance.py``'s settings) by leave-one-training-controller-out
cross-validation.

For a setting (``tau_m``, ``att_w``, ``att_zeta``, ``len_factor``, patched in as
``twin_patch.patch`` does), each of the four training controllers ``c`` in turn is left out:
the twin is refitted whole on the other three (``twin_fit.calibrate_twin``) and scored on
``c`` by the project's own validation table and score (``figure8.validation_table``, with
``c`` as ``sim.attrs["held_out"]``, so the errors are scaled by the three's spread;
``figure8.validation_score``). The criterion is the mean of the four inner scores. The true
held-out controller (``twin_fit.held_out_controller``) is dropped from the real rows before
anything is fitted or scored, so the criterion never reads it. Printed per fold: the inner
score, the trivial model's (the three's mean), and the twin's pitch spread at 8.5 m/s
("70wind") against ``c``'s (the inner miss) and against the four training controllers' range.

The per-wind force fit gets 40 steps here instead of the library's 12 (:data:`STEPS`): on
L1, NF-T and baseline it needs more than 12 with RotorPy's loop (it then stops with a
ValueError; 40 are enough). A fold whose fit still fails
(a ValueError) rejects its setting: a twin that cannot be calibrated on three of the four
training controllers is not a usable choice.

Measured (paper profile, SIM_VERSION 9; each fold one refit on three controllers and the
study's flights, median 27 s wall and 27 s CPU at ``nice 19``; the 19 settings of the grid
asked for in 37:44 wall, 2196 s CPU). ``att_w`` RP: RotorPy's loop (23.3 rad/s, zeta 1);
pitch: the twin's lap-to-lap pitch spread at 8.5 m/s over the four folds (the left-out
controllers' own: L1 1.193, NF-C 0.911, NF-T 1.006, baseline 1.203 deg); miss: its mean
absolute error on the left-out controller, scaled as the score scales it; r: a refinement
added after part of the grid was in (training-only like the rest); in brackets the mean of
the folds that could be fitted:

=====  =====  ====  =====  =======  =====  =====  =====  ========  =========  =====  ==
tau_m  att_w  zeta  len x  CV mean  L1     NF-C   NF-T   baseline  pitch 8.5  miss
=====  =====  ====  =====  =======  =====  =====  =====  ========  =========  =====  ==
0.005  9      0.6   1      1.543    1.232  1.245  1.556  2.139     0.62-0.80  2.69   r
0.005  10     0.6   1      1.562    1.233  1.270  1.520  2.225     0.62-0.80  2.66
0.005  10     0.6   0.2    1.569    1.225  1.275  1.510  2.266     0.66-0.84  2.31   r
0.015  10     0.6   1      1.570    1.205  1.280  1.509  2.286     0.65-0.81  2.59   r
0.005  10     0.6   0.05   1.587    1.211  1.316  1.457  2.366     0.74-0.91  1.64
0.03   10     0.6   1      1.595    1.200  1.307  1.469  2.403     0.67-0.83  2.45
0.005  10     0.6   0.03   1.601    1.221  1.353  1.401  2.430     0.78-0.93  1.45   r
0.005  11     0.6   1      1.604    1.216  1.322  1.538  2.339     0.65-0.80  2.58   r
0.03   10     0.6   0.1    1.606    1.191  1.318  1.434  2.483     0.75-0.90  1.80   r
0.03   10     0.6   0.05   1.620    1.194  1.355  1.387  2.542     0.80-0.93  1.51
0.005  10     0.6   0.015  1.633    1.265  1.446  1.288  2.533     0.79-0.94  1.37
0.03   10     0.6   0.03   1.652    1.214  1.431  1.345  2.617     0.83-0.98  1.22   r
0.005  12     0.6   1      1.664    1.273  1.393  1.511  2.477     0.68-0.79  2.53
0.03   10     0.6   0.015  1.690    1.269  1.524  1.256  2.713     0.85-0.98  1.11
0.005  12     0.6   0.05   1.710    1.277  1.480  1.446  2.636     0.79-0.88  1.69
0.03   11     0.6   0.05   1.781    1.322  1.555  1.435  2.813     0.78-0.93  1.51   r
0.005  12     0.6   0.015  1.798    1.378  1.654  1.336  2.826     0.82-0.90  1.50
0.005  RP     1     1      1.866    1.426  1.526  1.539  2.974     0.67-0.77  2.51
0.03   12     0.6   1      1.901    1.451  1.593  1.582  2.978     0.67-0.83  2.46
0.03   12     0.6   0.05   2.014    1.510  1.698  1.697  3.152     0.78-0.91  1.76
0.03   12     0.6   0.015  2.209    1.659  1.964  1.852  3.361     0.82-0.93  1.48
0.005  8      0.6   1      (1.627)  1.259  fails  1.580  2.041     0.62-0.78  --
0.005  8      0.6   0.05   (1.627)  1.203  fails  1.513  2.166     0.81-0.89  --
0.005  8      0.6   0.015  (1.631)  1.225  fails  1.353  2.314     0.87-0.94  --
0.03   9      0.6   0.05   (1.644)  1.167  fails  1.423  2.341     0.76-0.93  --     r
0.03   8      0.6   1      (1.819)  fails  fails  1.587  2.051     0.68-0.82  --
0.03   8      0.6   0.015  (1.827)  fails  fails  1.333  2.320     0.96-0.96  --
0.03   8      0.6   0.05   (1.831)  fails  fails  1.489  2.174     0.91-0.94  --
=====  =====  ====  =====  =======  =====  =====  =====  ========  =========  =====  ==

(The trivial model, the three's mean, per fold: L1 1.231, NF-C 1.136, NF-T 1.553, baseline
1.951, mean 1.468; the four training controllers' pitch spread at 8.5 m/s 0.911-1.203 deg.)
The failures: without NF-C the gust fit's secant ends near zero gusts without meeting the
force spread at 12.1 m/s (with ``att_w`` 8 the replicates alone already give about it), and
without L1 or NF-C the error time's secant misses its 3% tolerance.

Chosen by the criterion: ``tau_m`` 0.005 (RotorPy's motors), ``att_w`` 9, zeta 0.6, the
gusts' length unchanged (among the grid asked for alone: the same with ``att_w`` 10, 1.562).
On the true held-out controller, read only after the choice
(``twin_loop_resonance.py paper 0.005 9 0.6 1``): score 1.272 (trivial 1.232, the twin today
1.136, target <= 1.0), pitch spread at 8.5 m/s 0.698 deg (real 0.911-1.500): it meets
neither target, and is worse than today's twin on the score.

What it says: the training controllers' own cross-validation does not pick the short gusts.
It asks for a slower attitude loop (``att_w`` 9-10 beats 11-12 and RotorPy's loop in every
column of ``tau_m`` and length; 8 cannot be fitted on every subset) and is near indifferent
to the gust length and the motor lag (the best eight lie within 0.065, and the fold-by-fold
differences change sign: the baseline fold, 2.1-3.4, drives most of them). The short gusts
bring the pitch spread at 8.5 m/s closest to the left-out controllers' (miss 1.1-1.5 at length
0.015 against 2.3-2.7 at 0.2-1), but cost more on the other rows than the pitch row gains.
Every setting's inner score is above the trivial model's (1.468): on three controllers the
twin does not beat their mean on the fourth. Read after the choice, for the record and not
used by it: on the seven settings both studies measured, the inner criterion and the held-out
score (``twin_loop_resonance.py``'s table and the chosen one) rank them nearly opposite
(Spearman -0.64, seven points, p 0.12): the held-out controller (indi) has the largest pitch
spread of the five at 8.5 m/s and in the sinusoidal wind (1.50 and 1.36 deg; the training
controllers' 0.91-1.20 and 0.49-0.88) and the noisiest attitude at 4.2 and 8.5 m/s and in the
sinusoidal wind, where the short gusts help, while the four training controllers lie closer
together. So the point found before (``tau_m`` 0.03, ``att_w`` 10, zeta 0.6, length 0.015:
0.996, 0.915 deg) stays a pick on the held-out score; this criterion gives it 1.690, 14th of
21. The check on the held-out controller refits on the four in 19-22 s (26-29 s a run).

``python benchmarks/twin_loop_cv.py [paper|quick] tau_m att_w att_zeta len_factor [OUT.jsonl]``
(one setting, its four folds; appends a JSON line per fold to OUT.jsonl);
``python benchmarks/twin_loop_cv.py table OUT.jsonl`` (the criterion per setting, the chosen
one first). The chosen setting is then checked on the true held-out controller with
``benchmarks/twin_loop_resonance.py``. Reads the real rows from (or fills) $UAVWIND_RESULTS,
writes no twin rows there."""
import json
import sys
import time

import numpy as np
import pandas as pd

PITCH = ("lap-to-lap spread of pitch", "70wind")


def inner_rows(real: pd.DataFrame):
    """``real`` without the true held-out controller's rows, and the training controllers."""
    from uavwind.analysis import twin_fit
    everyone = sorted(set(real.loc[real.kind == "flight", "controller"]))
    held = twin_fit.held_out_controller(everyone)
    return real[real.controller != held].copy(), [c for c in everyone if c != held]


#: The per-wind force fit's step limit here (the library's ``twin_fit._STEPS`` is 12): on the
#: three controllers without NF-C it needs more (RotorPy's loop: within 40 it converges, drag
#: 0.41, rotor drag 2.04) and stops with a ValueError at 12. A fit that converges within 12 steps
#: takes the same steps either way, so the four-controller twin is unchanged.
STEPS = 40


def run(profile, setting, out=None):
    from twin_patch import fit_and_fly, patch
    from uavwind.analysis import figure8, real_flights as rf, twin_fit
    patch(*setting)
    twin_fit._STEPS = STEPS
    study = rf.STUDIES[profile]
    inner, train = inner_rows(rf.real_flight_rows(profile=profile, n_jobs=1))
    pitch_real = inner[(inner.kind == "flight") & (inner.condition == PITCH[1])]["pitch_spread"]
    for c in train:
        t0, c0 = time.time(), time.process_time()
        row = {"profile": profile, "setting": list(setting), "fold": c}
        try:
            _, _, sim = fit_and_fly(inner, study, [x for x in train if x != c], c)
            val = figure8.validation_table(inner, sim)
            score = figure8.validation_score(val)
            p = val[(val.quantity == PITCH[0]) & (val.condition == PITCH[1])].iloc[0]
            row.update(score=score["twin"], trivial=score["trivial"], n=score["n"],
                       pitch_sim=p.sim, pitch_fold=p.held_out, pitch_error=p.twin_error,
                       pitch_min=float(pitch_real.min()), pitch_max=float(pitch_real.max()))
        except Exception as e:  # noqa: BLE001 - a setting whose fit fails is rejected, not fatal
            row.update(score=np.inf, error=f"{type(e).__name__}: {e}")
        row.update(wall=time.time() - t0, cpu=time.process_time() - c0)
        print(json.dumps(row), flush=True)
        if out:
            with open(out, "a") as f:
                f.write(json.dumps(row) + "\n")


def table(path):
    rows = [json.loads(x) for x in open(path) if x.strip()]
    by = {}
    for r in rows:
        by.setdefault((r["profile"], tuple(r["setting"])), {})[r["fold"]] = r
    out = []
    for (profile, s), folds in by.items():
        sc = [folds[c]["score"] for c in sorted(folds)]
        out.append((np.mean(sc) if len(sc) == 4 else np.inf, profile, s, folds))
    out.sort(key=lambda t: t[0])
    folds = sorted({c for *_, f in out for c in f})
    print("tau_m  att_w zeta  len x  | CV mean | " + " ".join(f"{c:>8}" for c in folds)
          + " | pitch 8.5: twin (fold's own) per fold | |pitch err|")
    best = out[0][3]
    for crit, profile, s, f in out:
        tau, w, z, lf = s
        cells = " ".join(f"{f[c]['score']:8.3f}" if c in f else "       -" for c in folds)
        pitch = " ".join(f"{f[c].get('pitch_sim', np.nan):.3f}"
                         f"({f[c].get('pitch_fold', np.nan):.3f})" for c in folds if c in f)
        perr = np.mean([abs(f[c].get("pitch_error", np.nan)) for c in folds if c in f])
        ok = [c for c in f if np.isfinite(f[c]["score"])]
        note = ""
        if len(ok) < len(folds):  # on the folds it could fit, beside the chosen one there
            note = (f"  fitted folds' mean {np.mean([f[c]['score'] for c in ok]):.3f} (chosen "
                    f"{np.mean([best[c]['score'] for c in ok]):.3f}); failed: " + "; ".join(
                        f"{c}: {f[c]['error'][:48]}" for c in f if "error" in f[c]))
        print(f"{tau:<6} {w:<5} {z:<4} {lf:<6} | {crit:7.3f} | {cells} | {pitch} | {perr:.2f}"
              + note)
    print("trivial model (the three's mean), per fold:", " ".join(
        f"{c} {best[c]['trivial']:.3f}" for c in folds),
        f"mean {np.mean([best[c]['trivial'] for c in folds]):.3f}")
    print("one fold's refit and flights, wall/CPU s: median "
          f"{np.median([r['wall'] for r in rows]):.0f}/{np.median([r['cpu'] for r in rows]):.0f}")
    r0 = next(iter(next(iter(by.values())).values()))
    print(f"training pitch spread range at 8.5 m/s: {r0.get('pitch_min', np.nan):.3f}-"
          f"{r0.get('pitch_max', np.nan):.3f} deg")
    print("chosen:", out[0][2], f"criterion {out[0][0]:.3f}")


if __name__ == "__main__":
    if sys.argv[1] == "table":
        table(sys.argv[2])
    else:
        run(sys.argv[1], tuple(map(float, sys.argv[2:6])),
            sys.argv[6] if len(sys.argv) > 6 else None)
