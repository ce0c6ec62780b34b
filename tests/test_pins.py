"""Behaviour pins: every cache key and a few result digests, as they were before the
package was arranged into subpackages (commit f16d6b8). A move that changed a setting's
key, an entry's path or a single double of a result row fails here.

A deliberate change of results (a new reading, a bumped RESULTS_VERSION) updates these
pins in the same commit, and says so. Changed since: the inferred reading's mixed-strength
constant and shear pairs take Table 3's spacing (exp1-4 under "inferred", and exp1's case 1).
Added since: exp14 and exp14_cem (issue 31's flyable manoeuvres; no earlier pin changed).
Changed since: the paper profile's Exps 7 and 9 (128 loops a case) and Exp 11 with Exp 14's
copies of its cases (82) run the counts their sizing chose (uavwind.study.sizing): more
chunks (Exp 7's first 50 loops keep their entry; Exp 11's 0-20 entry becomes 0-50 and 50-82).
Changed back since: Exp 11's verdicts are decided loop by loop, and sized so its sweep runs
its floor of 20 loops per case: its and Exp 14's paper entry paths are again those before
the sizing (the four digests as at 027ed6e's parent).
Changed since: Exp 14's waypoint cases fly the Neural-Fly vehicle with its fitted drag, SE3
with an integral term and a thrust cone, the wind ramped in and a budget in the wind (issue
43): every exp14 and exp14_cem key is new (its eight digests); no other pin changed.
Changed since: Exp 11's CEM runs half the profile's iterations (uavwind.study.cases.
FUTURE_CEM_SCALE, sized on its page's question): its four entry-path digests; no other pin
changed.
Changed since: the multirotor's hover trim (Exp 14's waypoint limits in the wind, part of
its keys) is solved to its root's last digits and rounded to 12 significant digits
(uavwind.sim.multirotor.TRIM_DIGITS): where its Newton steps stopped moved with the host, so
an AVX2 EPYC and an AVX-512 Xeon gave Exp 14 different keys. Every exp14 and exp14_cem
digest is new (eight); no other pin changed.
"""
import hashlib
import tempfile

import numpy as np
import pytest

from uavwind.study import EXPERIMENTS, run_experiment
from uavwind.study.fill import needed_entries
from uavwind.study.profiles import PROFILES, CEMSize, Profile

#: The profiles the pins were taken under: the paper profile, and as "quick" the quick
#: profile's counts when they were taken (4 loops a case, 8 long, 2 per fit and side case,
#: 1 flyable, 10 episodes, CEM 6/2/3). The quick profile itself is what CI can afford and
#: changes with it (2 loops a case since); the pins hold the code's results, not that choice.
PINNED_PROFILES = {
    "paper": PROFILES["paper"],
    "quick": Profile(name="quick", loops=4, long_loops=8, fit_loops=2, episodes=10,
                     flyable_loops=1, cem=CEMSize(n_samples=6, n_elite=2, max_iter=3)),
}

#: profile/reading/experiment -> digest of the sorted relative paths of its cache entries
ENTRY_PATHS = {
    "quick/inferred/example": "3b124da9fed53415",
    "quick/inferred/exp1": "a869d0dfd34f1675",
    "quick/inferred/exp2": "3a0cb1a05b1c1512",
    "quick/inferred/exp3": "1194b7d11597cc56",
    "quick/inferred/exp4": "40cb059005d144dc",
    "quick/inferred/exp5": "bdc142320cf3951f",
    "quick/inferred/exp6": "3890dd609dc3b6a2",
    "quick/inferred/exp6_raw": "628e28b0dd489eab",
    "quick/inferred/exp7": "a19c1ac22a1095f8",
    "quick/inferred/exp8": "938fc569fdd8a7e5",
    "quick/inferred/exp9": "a19c1ac22a1095f8",
    "quick/inferred/exp10": "0c9cc78ab82fe9dd",
    "quick/inferred/exp11": "a707dc5ec512b5ce",
    "quick/inferred/exp11_cem": "c536986c9492ff6c",
    "quick/inferred/exp12": "4a1fa0b690c9ccfc",
    "quick/inferred/exp14": "d79841b1e6a8ab52",
    "quick/inferred/exp14_cem": "e0562c58c5e5c13c",
    "quick/inferred/fit_layout": "f3801fbc86dfb8b7",
    "quick/inferred/fit_mixed": "112d11a98a089764",
    "quick/inferred/fit_turbulence": "98462edb38442c3b",
    "quick/halves/example": "3b124da9fed53415",
    "quick/halves/exp1": "2a9e96ab0379510a",
    "quick/halves/exp2": "e1dddfcb840afec2",
    "quick/halves/exp3": "ff34a44e7376a8db",
    "quick/halves/exp4": "903cdf6927a7102e",
    "quick/halves/exp5": "dabb5c765497393b",
    "quick/halves/exp6": "5748f9c690a8ec7a",
    "quick/halves/exp6_raw": "f9af43541e09a495",
    "quick/halves/exp7": "aa2022438305f0ae",
    "quick/halves/exp8": "6ea199792bbc540e",
    "quick/halves/exp9": "aa2022438305f0ae",
    "quick/halves/exp10": "a66279354bbc3374",
    "quick/halves/exp11": "8fb1eafabe9b0414",
    "quick/halves/exp11_cem": "fc63ec8a2f1d1de7",
    "quick/halves/exp12": "80e6458646f8e881",
    "quick/halves/exp14": "da03f5add0468041",
    "quick/halves/exp14_cem": "59c1ee2d535006f2",
    "quick/halves/fit_layout": "f3801fbc86dfb8b7",
    "quick/halves/fit_mixed": "112d11a98a089764",
    "quick/halves/fit_turbulence": "98462edb38442c3b",
    "paper/inferred/example": "6f3e053cab478488",
    "paper/inferred/exp1": "188170c5b4a0a1bf",
    "paper/inferred/exp2": "6a90f2d96bb3cff1",
    "paper/inferred/exp3": "8bf26e41ee085ce4",
    "paper/inferred/exp4": "16c0478a2e2b75eb",
    "paper/inferred/exp5": "22b4a412a7cdd06d",
    "paper/inferred/exp6": "d00836cf68652e8a",
    "paper/inferred/exp6_raw": "6f8435c7511136c3",
    "paper/inferred/exp7": "f6a86d54c4959fcf",  # 50 loops a case, sized (was 128)
    "paper/inferred/exp8": "0df52e69bd1d0ff9",
    "paper/inferred/exp9": "f6a86d54c4959fcf",  # the same loops as exp7
    "paper/inferred/exp10": "c273d1a915d5f450",
    "paper/inferred/exp11": "b06d46f03fa28a4b",
    "paper/inferred/exp11_cem": "39c1abee3b9c85b9",
    "paper/inferred/exp12": "4f5bf690e507a7b0",
    "paper/inferred/exp14": "a6cd0c14594e4a6c",
    "paper/inferred/exp14_cem": "b1f5deab9d58ac91",
    "paper/inferred/fit_layout": "98d979c639533209",
    "paper/inferred/fit_mixed": "d0e7a315564174f2",
    "paper/inferred/fit_turbulence": "9f34c77cc0c7cc0a",
    "paper/halves/example": "6f3e053cab478488",
    "paper/halves/exp1": "db5bd75a41bd09d5",
    "paper/halves/exp2": "8ea77df8e95da57d",
    "paper/halves/exp3": "bfbefbff0a3eab73",
    "paper/halves/exp4": "8c36d94fcad7754f",
    "paper/halves/exp5": "4f4fe9f0d256eacd",
    "paper/halves/exp6": "af5b1e15b1664857",
    "paper/halves/exp6_raw": "17fd33a9c6c8d000",
    "paper/halves/exp7": "f265297e3dc4e61b",  # 50 loops a case, sized (was 128)
    "paper/halves/exp8": "899b6fde6de46a3b",
    "paper/halves/exp9": "f265297e3dc4e61b",  # the same loops as exp7
    "paper/halves/exp10": "aa65a1e090669563",
    "paper/halves/exp11": "1e3a3c3984d63763",
    "paper/halves/exp11_cem": "7b9e1b77c8f7df3e",
    "paper/halves/exp12": "d5ef54547e0c443a",
    "paper/halves/exp14": "8f2a50aa5c32274c",
    "paper/halves/exp14_cem": "b911e5c7efc038af",
    "paper/halves/fit_layout": "98d979c639533209",
    "paper/halves/fit_mixed": "d0e7a315564174f2",
    "paper/halves/fit_turbulence": "9f34c77cc0c7cc0a",
}

#: experiment/case/reading -> digest of the rows of that case (the pinned quick profile)
RESULT_ROWS = {
    "exp1/1/inferred": "5ecf0d578abf3932",
    "exp1/1/halves": "df423608cc0aa500",
    "exp5/1/inferred": "2fdd3e359569e1ed",
    "exp5/1/halves": "00bdb667423591e4",
    "exp7/3/inferred": "03908d6073cde360",
    "exp7/3/halves": "e60481958bd26a07",
    "exp8/5/inferred": "343ac39c3e8121bb",
    "exp8/5/halves": "c1c908f5829fefb3",
    "exp6/0/inferred": "415b9481ce363421",
    "exp6/0/halves": "d5524f2125fa0bd3",
    "fit_turbulence/5/inferred": "1b04cf955c256275",
    "fit_turbulence/5/halves": "76a637ef39abfec0",
}

#: columns that name the library version, not the result
_VERSION_COLUMNS = {"uavwind_version", "results_version"}


def _rows_digest(df):
    parts = []
    for c in sorted(set(df.columns) - _VERSION_COLUMNS):
        cells = [repr(np.asarray(v).tolist()) if hasattr(v, "__len__") and not isinstance(v, str)
                 else repr(v) for v in df[c]]
        parts.append(c + "=" + repr(cells))
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()[:16]


def test_every_cache_entry_path_is_pinned():
    got = {}
    for key in ENTRY_PATHS:
        profile, reading, exp = key.split("/")
        es = needed_entries([exp], profile=PINNED_PROFILES[profile], readings=[reading],
                            results="/pins")
        names = sorted(str(e.path.relative_to("/pins")) for e in es)
        got[key] = hashlib.sha256("\n".join(names).encode()).hexdigest()[:16]
    assert set(EXPERIMENTS) == {k.split("/")[2] for k in ENTRY_PATHS}
    assert got == ENTRY_PATHS


@pytest.mark.parametrize("key", sorted(RESULT_ROWS))
def test_result_rows_are_pinned(key):
    exp, case, reading = key.split("/")
    with tempfile.TemporaryDirectory() as d:
        df = run_experiment(exp, profile=PINNED_PROFILES["quick"], cases=[int(case)],
                            reading=reading, results=d, n_jobs=1, progress=False)
    assert _rows_digest(df) == RESULT_ROWS[key]
