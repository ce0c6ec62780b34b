"""The paper profile's counts beyond the paper follow from the sizing of each question
(uavwind.study.sizing), and a page's sizing note says so and re-measures it on its build."""

from math import ceil

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

from uavwind.analysis.tables import sizing_note
from uavwind.core.stats import ci_halfwidth, loops_needed
from uavwind.study import EXPERIMENTS, PROFILES
from uavwind.study.profiles import get_profile
from uavwind.study.runner import case_loops
from uavwind.study.sizing import SIZINGS, Sizing


def test_loops_needed_is_the_normal_approximation():
    for sd, h, level in [(30.0, 5.0, 0.95), (28.8, 5.0, 0.95), (46.0, 10.0, 0.95),
                         (12.9, 5.0, 0.9), (3.0, 0.5, 0.99)]:
        z = norm.ppf(0.5 + level / 2)
        assert loops_needed(sd, h, level) == max(2, ceil((z * sd / h) ** 2))
        n = loops_needed(sd, h, level)  # the inverse: n loops reach h, n - 1 do not
        assert ci_halfwidth(sd, n, level) <= h < ci_halfwidth(sd, n - 1, level)
        assert ci_halfwidth(sd, n, level) == pytest.approx(z * sd / n ** 0.5, rel=1e-12)
    assert loops_needed(0.0, 5.0) == 2
    assert ci_halfwidth(10.0, 1) == float("inf")
    with pytest.raises(ValueError, match="halfwidth"):
        loops_needed(10.0, 0.0)
    with pytest.raises(ValueError, match="level"):
        loops_needed(10.0, 1.0, level=1.0)


def test_every_experiment_beyond_the_paper_up_to_exp12_is_sized():
    assert sorted(SIZINGS) == sorted(["exp7", "exp8", "exp9", "exp10", "exp11", "exp12"])
    for s in SIZINGS.values():
        assert s.count == max(s.floor, loops_needed(s.sd, s.halfwidth))
        assert s.question and s.floor_reason


def _runs(prof, exp, case):
    return prof.episodes if exp.search == "closed_loop" else case_loops(prof, case, exp.id)


def test_the_paper_profile_runs_the_sized_counts():
    paper = PROFILES["paper"]
    for exp_id, s in SIZINGS.items():
        exp = EXPERIMENTS[exp_id]
        counts = {_runs(paper, exp, c) for c in exp.cases()}
        assert counts == {s.count}, exp_id
    # what the sizing asked for, at the spreads measured (Exps 7 and 9, sized on the share
    # of correct groupings their pages decide, the paper's 50: their questions need 40 and
    # 43; sized on a mean score 10 points apart they ran 128; Exp 11's sweep, decided loop
    # by loop, its floor of 20: 82 when each case was sized on its own spread)
    assert SIZINGS["exp7"].count == SIZINGS["exp9"].count == 50
    assert SIZINGS["exp7"].needed < 50 and SIZINGS["exp9"].needed < 50
    assert SIZINGS["exp7"].value == "correct" and SIZINGS["exp9"].value == "baseline_correct"
    assert SIZINGS["exp11"].count == SIZINGS["exp11"].floor == 20 > SIZINGS["exp11"].needed
    # the paper's own experiments keep the paper's 50 loops per case
    for exp_id in ("exp1", "exp2", "exp3", "exp4", "exp5"):
        exp = EXPERIMENTS[exp_id]
        assert {case_loops(paper, c, exp_id) for c in exp.cases() if not c.long} == {50}
    # the quick profile is not sized
    assert PROFILES["quick"].sized_loops == {}


def test_exp14_reads_exp11_and_exp10_loops_at_their_counts():
    """Exp 14 copies some of Exp 11's and Exp 10's cases to read their cache: the same
    setting must run the same count, or Exp 14 would compute its own chunks."""
    paper = PROFILES["paper"]
    runs = {}
    for exp_id in ("exp10", "exp11"):
        exp = EXPERIMENTS[exp_id]
        for c in exp.cases():
            runs[c.setting.key()] = case_loops(paper, c, exp_id)
    shared = 0
    for c in EXPERIMENTS["exp14"].cases():
        key = c.setting.key()
        if key in runs:
            shared += 1
            assert case_loops(paper, c, "exp14") == runs[key], c.labels
    assert shared >= 7 + 4


def test_sized_loops_are_checked():
    base = {"loops": 1, "long_loops": 1, "fit_loops": 1,
            "cem": {"n_samples": 1, "n_elite": 1, "max_iter": 1}}
    with pytest.raises(ValueError, match="'exp77'"):
        get_profile(base | {"sized_loops": {"exp77": 3}})
    with pytest.raises(ValueError, match=r"sized_loops'\]\['exp7'\] must be in \[1"):
        get_profile(base | {"sized_loops": {"exp7": 0}})
    with pytest.raises(TypeError, match="sized_loops"):
        get_profile(base | {"sized_loops": [("exp7", 3)]})
    prof = get_profile(base | {"sized_loops": {"exp7": 3}})
    assert prof.loops_of("exp7") == 3 and prof.loops_of("exp8") == 1
    with pytest.raises(TypeError):  # read-only: a profile is a value
        prof.sized_loops["exp7"] = 5


def _frame(sd_a, sd_b, n, experiment="exp10"):
    rng = np.random.default_rng(0)
    a = rng.standard_normal(n)
    b = rng.standard_normal(n)
    df = pd.DataFrame({"case": [0] * n + [1] * n,
                       "score": np.r_[50 + sd_a * (a - a.mean()) / a.std(ddof=1),
                                      50 + sd_b * (b - b.mean()) / b.std(ddof=1)]})
    df.attrs["experiment"] = experiment
    return df


def test_sizing_note_states_the_choice_and_remeasures_it():
    s = SIZINGS["exp10"]
    # SD 20 in the most variable case: (1.96 * 20 / 5)^2 = 61.5 -> 62 loops
    text = sizing_note(_frame(10.0, 20.0, 70))
    assert s.question in text and "+-5 points" in text
    assert f"runs **{s.count} loops per case**" in text and f"up to {s.sd:.1f} points" in text
    assert "varies by up to 20.0 points, which takes 62; it ran 70 (+-4.7 points): enough." in text
    few = sizing_note(_frame(10.0, 20.0, 30))
    assert "it ran 30" in few and "cannot decide" in few
    # Exp 8's count is its floor: the note says the sizing asked for fewer, and why
    text8 = sizing_note(_frame(1.0, 1.0, 5, "exp8"))
    s8 = SIZINGS["exp8"]
    assert f"takes {s8.needed}, fewer than the 50 it runs at the least" in text8
    one = pd.DataFrame({"case": [0, 1], "score": [50.0, 60.0]})  # the quick Exp 11's one loop
    one.attrs["experiment"] = "exp10"
    assert sizing_note(one).endswith(" This build ran 1 loop per case: too few to measure a spread.")
    with pytest.raises(ValueError, match="no sizing for experiment 'exp1'"):
        sizing_note(_frame(1.0, 1.0, 5, "exp1"))
    with pytest.raises(TypeError, match="sizing"):
        sizing_note(_frame(1.0, 1.0, 5), sizing="exp10")


def test_sizing_note_of_exp7_measures_the_share_of_correct_groupings():
    """Exps 7 and 9 are sized on the share their pages decide (0/1 per loop, in percentage
    points), per noise case, not on the score."""
    n = 50
    rows = [{"scenario": "a", "noise_sigma": sig, "noise_bias": 0.0, "score": 99.0,
             "correct": float(i < k), "baseline_correct": 1.0}
            for sig, k in ((0.0, n), (2.0, n // 2)) for i in range(n)]
    df = pd.DataFrame(rows)
    df.attrs["experiment"] = "exp7"
    text = sizing_note(df)
    sd = float(pd.Series([1.0] * 25 + [0.0] * 25).std(ddof=1) * 100)  # 50.5 pp
    assert f"varies by up to {sd:.1f} percentage points" in text
    assert "runs **50 loops per case**" in text and "it ran 50" in text
    df.attrs["experiment"] = "exp9"  # its baseline is right everywhere: no spread
    assert "varies by up to 0.0 percentage points" in sizing_note(df)


def test_sizing_note_of_a_closed_loop_counts_episodes_at_the_last_time():
    n = 12
    rows = []
    for policy, p in (("greedy", 0.5), ("fixed", 1.0)):
        for ep in range(n):
            for t in (1.0, 2.0):
                # wrong everywhere at the first time: only the last time may count
                rows.append({"case": 0, "policy": policy, "episode": ep, "time": t,
                             "correct": float(t == 2.0 and (ep % 2 == 0 or p == 1.0))})
    df = pd.DataFrame(rows)
    df.attrs["experiment"] = "exp12"
    text = sizing_note(df)
    # greedy right in every other episode: SD sqrt(12/44) * 100 = 52.2 pp
    sd = float(pd.Series([1.0, 0.0] * 6).std(ddof=1) * 100)
    assert f"varies by up to {sd:.1f} percentage points" in text
    assert "episodes per case" in text and "it ran 12" in text


def test_a_sizing_record_checks_its_numbers():
    with pytest.raises(ValueError, match="exp7 sizing halfwidth"):
        Sizing(experiment="exp7", question="q", halfwidth=0, unit="points", sd=1.0,
               measured_with=10, floor=1, floor_reason="r")
    with pytest.raises(ValueError, match="exp7 sizing sd"):
        Sizing(experiment="exp7", question="q", halfwidth=1, unit="points", sd=-1.0,
               measured_with=10, floor=1, floor_reason="r")


def test_the_replication_notes_state_the_sized_counts():
    from pathlib import Path
    notes = (Path(__file__).parents[1] / "book" / "replication_notes.md").read_text()
    c = {e: s.count for e, s in SIZINGS.items()}
    n = {e: s.needed for e, s in SIZINGS.items()}
    assert c["exp7"] == c["exp8"] == c["exp9"] == c["exp10"] == 50
    assert (f"Exps 7, 8, 9 and 10 run the paper's 50 loops per case (their questions need "
            f"{n['exp7']}, {n['exp8']}, {n['exp9']} and\n{n['exp10']};") in notes
    assert f"ask), Exp 11's sweep {c['exp11']}" in notes
    assert f"Exp 12 its {c['exp12']} episodes (the accuracy question needs {n['exp12']};" in notes


def test_profile_note_counts_loops_per_case_and_flags_a_quick_build():
    from uavwind.analysis.tables import profile_note

    def frame(loops, profile="quick"):
        df = pd.DataFrame({"case": [0] * loops + [1] * loops, "loop": list(range(loops)) * 2})
        df.attrs.update(experiment="exp11", profile=profile)
        return df
    one = profile_note(frame(1))
    assert one.startswith("**This page shows the *quick* profile:** 1 loop per case over 2 cases.")
    assert "**Its verdicts are provisional**" in one
    assert f"the paper profile runs {SIZINGS['exp11'].count} loops per case" in one
    assert "2 loops per case over 2 cases." in profile_note(frame(2))
    # below the one rule's minimum the note says the page decides nothing (issue 67)
    assert "a verdict needs at least 5" in one and "*cannot decide*" in one
    assert "a verdict needs at least" not in profile_note(frame(5))
    assert "provisional" not in profile_note(frame(3, "paper"))
    cem = pd.DataFrame({"case": [0] * 8})  # Exp 6's quick CEM: one case, 8 samples
    cem.attrs.update(experiment="exp6", profile="quick")
    assert "8 CEM samples per case over 1 case." in profile_note(cem)
    # the claims page's counts say the same (tables.case_counts): a range over cases
    from uavwind.analysis.tables import case_counts
    long = pd.DataFrame({"case": [0] * 50 + [1] * 500, "loop": list(range(50)) + list(range(500))})
    long.attrs.update(experiment="exp1", profile="paper")
    assert case_counts(long) == "50-500 loops" and case_counts(cem) == "8 CEM samples"


def _channels(n, spread):
    """Exp 11-like rows of one scenario and noise level: position and velocity share each
    loop's value, velocity 1 point above it plus ``spread`` times a +-1 alternation, and the
    IMU 40 points below position; the reference (thrust, position) is the runner-up."""
    rows = []
    for i in range(n):
        base = 50.0 + (i % 5)
        for obs, v in (("position", base), ("velocity", base + 1 + spread * (-1) ** i),
                       ("imu", base - 40)):
            rows.append({"scenario": "S", "noise": "none", "action": "thrust",
                         "observation": obs, "loop": i, "score": v})
    df = pd.DataFrame(rows)
    df.attrs["experiment"] = "exp11"
    return df


def test_a_loop_by_loop_question_is_sized_on_its_paired_differences():
    from uavwind.analysis.tables import paired_spread
    s = SIZINGS["exp11"]
    assert s.compared == ("action", "observation") and s.reference == ("thrust", "position")
    # velocity - position alternates 1 +- 10 over 40 loops: SD 10 * sqrt(40/39); the IMU's
    # 40-point gap is no part of it (neither the runner-up nor the reference)
    sd, n = paired_spread(_channels(40, 10.0), s)
    assert n == 40 and sd == pytest.approx(10.0 * (40 / 39) ** 0.5)
    text = sizing_note(_channels(40, 10.0))
    need = loops_needed(sd, s.halfwidth)
    assert "+-10 points on that difference" in text and f"takes {need}; it ran 40" in text
    assert "paired difference (the best case against its runner-up" in text
    assert f"at {s.measured_at} ({s.measured_with} loops per case)" in text
    # the same loops with no spread between the channels: the difference's SD is 0 even
    # though each channel varies from loop to loop
    assert paired_spread(_channels(10, 0.0), s) == (0.0, 10)
    assert sizing_note(_channels(1, 0.0)).endswith("This build ran 1 loop per case: too few "
                                                   "to measure a spread.")
    with pytest.raises(ValueError, match="compares no cases loop by loop"):
        paired_spread(_channels(4, 1.0), SIZINGS["exp7"])
    with pytest.raises(ValueError, match="one value per compared column"):
        Sizing(experiment="x", question="q", halfwidth=1, unit="points", sd=1.0,
               measured_with=10, floor=1, floor_reason="r", compared=("a", "b"),
               reference=("only one",))


def test_the_cems_beyond_the_paper_run_their_scaled_size():
    """Exp 11's CEM runs half the profile's iterations (its page's question is settled by
    then), Exp 14's a third of the draws for a quarter of them; the paper's own CEM (Exp 6)
    the profile's size. Changing the scale changes what runs."""
    from dataclasses import replace

    from uavwind.study.runner import cem_size

    paper = PROFILES["paper"]
    assert cem_size(EXPERIMENTS["exp6"], paper) == paper.cem
    assert cem_size(EXPERIMENTS["exp11_cem"], paper) == replace(paper.cem, max_iter=10)
    assert cem_size(EXPERIMENTS["exp14_cem"], paper) == replace(paper.cem, n_samples=10,
                                                                max_iter=5)
    exp = replace(EXPERIMENTS["exp11_cem"], search_options={"cem_scale": {"max_iter": 1.0}})
    assert cem_size(exp, paper) == paper.cem
