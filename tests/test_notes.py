"""Numbers typed in the replication notes must agree with what they cite.

Result numbers are glued from the executed pages (``{glue:text}``), never typed. What
is still typed is a paper value, a constant of the library, or a figure computed from
those constants; this test recomputes each one and fails if any typed decimal number in
the notes is none of them.
"""
import re
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.metrics import silhouette_score

import uavwind as uw
from uavwind.sim.mil_dryden import FEET
from uavwind.study.paper import PAPER_FILES, load_paper_values

NOTES = Path(__file__).resolve().parents[1] / "book" / "replication_notes.md"


def _typed_numbers(text):
    text = re.sub(r"\{glue:text\}`[^`]*`", " ", text)   # glued: computed in the build
    text = re.sub(r"`[^`]*`", " ", text)                 # code spans: names and arguments
    return {float(m) for m in re.findall(r"(?<![\w.])\d+\.\d+(?![\w.])", text)}


def _line_silhouette(n):
    x = np.arange(2 * n, dtype=float)[:, None]
    return round(100 * silhouette_score(x, np.repeat([0, 1], n)), 2)


def _allowed():
    ok = set()
    for exp in PAPER_FILES:                        # every value the paper reports
        df = load_paper_values(exp)
        for col in df.columns:
            ok |= {float(v) for v in pd.to_numeric(df[col], errors="coerce").dropna()}
    for lo, hi in uw.SPEED_RANGES.values():        # the NWS ranges
        ok |= {lo, hi}
    ok |= set(uw.INFERRED_GAP_RATIOS.values())     # the fitted layout in use
    ok |= {0.143, 0.5, 0.1, 0.177, 0.000823, 0.4, 1.2, 0.2, 0.305, 0.33, 1.1, 1.5,
           1.225, 2.1}                             # model constants quoted with their equations
    p = uw.dryden_parameters(12.0, 10.0)           # L_u at 10 m, exponent 1.2 and 0.2
    h = 10.0 / FEET
    ok |= {round(p["L_u"], 1), round(h / (0.177 + 0.000823 * h) ** 0.2 * FEET, 1),
           round(h, 1), round(p["L_u"] / 12.5, 1), 12.5}
    ok |= {_line_silhouette(5), _line_silhouette(10)}   # decision 5's caps
    speeds = np.linalg.norm([[1.1, 1.1], [1.5, 1.5]], axis=1)  # Table 3's light winds
    ok |= {round(s, 2) for s in speeds}
    ok |= {1.2}  # million probe points of the engine's libm self-check
    from uavwind.study.layouts import TABLE3_SPACING
    ok |= {round(TABLE3_SPACING, 2)}  # Table 3's spacing along x = y
    ok |= {0.01}  # wind spacing of test_the_multirotor_keeps_thrust_because_zero_thrust_is_chaotic
    from uavwind.data.neuralfly import CONDITIONS
    from uavwind.sim.rotor_params import NEURAL_FLY
    ok |= set(CONDITIONS.values())  # Neural-Fly's tunnel winds (section 13)
    ok |= {NEURAL_FLY["thrust_to_weight"]}  # the Neural-Fly quadrotor's, from its article
    return ok


def test_every_typed_number_in_the_notes_is_a_paper_value_or_a_constant():
    typed = _typed_numbers(NOTES.read_text())
    allowed = _allowed()
    unknown = sorted(v for v in typed if not any(abs(v - a) < 1e-9 for a in allowed))
    assert not unknown, f"typed numbers with no source: {unknown}"


def test_the_drift_check_catches_a_wrong_number():
    typed = _typed_numbers("the fit gives 11.3 and {glue:text}`x.ipynb::k:.1f` and `dt=0.3`")
    assert typed == {11.3}
    assert 11.3 not in _allowed()


def test_a_glued_number_from_another_page_names_its_format():
    """``{glue:text}`page.ipynb::key:fmt``` splits its format at the last colon, so a
    role from another page without one reads the key as part of the path and the book
    build fails ("No key 'page.ipynb:' found"): every such role names its format."""
    root = NOTES.parents[1]
    bad = []
    for path in sorted([*root.glob("book/*.md"), *root.glob("notebooks/*.md")]):
        for role in re.findall(r"\{glue:text\}`([^`]*)`", path.read_text()):
            if "::" in role and ":" not in role.split("::", 1)[1]:
                bad.append(f"{path.name}: {role}")
    assert not bad, bad
