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

FILLED IN BELOW once measured.

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
#: three controllers without NF-C it needs more (RotorPy's loop: about 30 steps, drag 0.41,
#: rotor drag 2.04) and stops with a ValueError at 12. A fit that converges within 12 steps
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
        pitch = " ".join(f"{f[c].get('pitch_sim', np.nan):.3f}({f[c].get('pitch_fold', np.nan):.3f})"
                         for c in folds if c in f)
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
