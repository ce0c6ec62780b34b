"""Beyond the paper: observation noise, observation channels, the physics baseline."""

import numpy as np
import pandas as pd
import pytest

from uavwind import study as ex
from uavwind.analysis import beyond, tables

TINY = {"loops": 2, "long_loops": 2, "fit_loops": 2,
        "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 2}}


# --------------------------------------------------------------------------- #
# noise
# --------------------------------------------------------------------------- #


def test_results_do_not_depend_on_the_number_of_workers(tmp_path):
    kw = dict(profile=TINY, progress=False, cases=[4, 5, 12, 20])
    one = ex.run_experiment("exp7", n_jobs=1, results=tmp_path / "a", **kw)
    two = ex.run_experiment("exp7", n_jobs=2, results=tmp_path / "b", **kw)
    pd.testing.assert_frame_equal(one, two)
    assert "noise_sigma" in one.columns and "baseline_rmse" in one.columns


# --------------------------------------------------------------------------- #
# observation channels
# --------------------------------------------------------------------------- #


# --------------------------------------------------------------------------- #
# the physics baseline
# --------------------------------------------------------------------------- #


def test_baseline_summary_and_a_wrong_model(tmp_path):
    df = ex.run_experiment("exp9", profile=TINY, n_jobs=1, progress=False, results=tmp_path,
                           cases=[11, 12])  # light vs light: no noise, 0.02 m
    t = tables.summary_table(df)
    assert t["rmse"].iloc[0] < 1e-9 and t["baseline_correct_rate"].iloc[0] == 1.0
    assert (t["rmse_mass+20%"] > 1.0).all()


# --------------------------------------------------------------------------- #
# the tables and bad input
# --------------------------------------------------------------------------- #
def test_breaking_level_reads_the_first_level_below_one_half():
    rows = [{"scenario": "s", "noise_sigma": sig, "noise_bias": 0.0, "loop": i,
             "score": 80.0 if ok else 0.0, "correct": ok}
            for sig, rate in ((0.0, 1.0), (0.5, 0.9), (1.0, 0.6), (2.0, 0.2), (5.0, 0.0))
            for i, ok in enumerate(np.arange(10) < 10 * rate)]
    lv = beyond.breaking_level(pd.DataFrame(rows)).loc["s"]
    assert lv["last_ok"] == 1.0 and lv["first_broken"] == 2.0
    assert lv["correct_rate_at_first_broken"] == pytest.approx(0.2)


def test_breaking_sentences_and_rows_at_a_noise_level():
    rows = [{"scenario": s, "noise_sigma": sig, "noise_bias": 0.0, "loop": i,
             "score": 80.0 if ok else 0.0, "correct": ok}
            for s, rates in (("s", ((0.0, 1.0), (1.0, 0.6), (2.0, 0.2))),
                             ("t", ((0.0, 1.0), (1.0, 0.9), (2.0, 0.8))))
            for sig, rate in rates for i, ok in enumerate(np.arange(10) < 10 * rate)]
    df = pd.DataFrame(rows)
    text = beyond.breaking_sentences(beyond.breaking_level(df))
    assert text["s"] == "drops below half between 1 m (60% correct) and 2 m (20%)"
    assert text["t"].startswith("still groups 80%") and "2 m, the largest" in text["t"]
    table = beyond.noise_table(df)
    assert list(beyond.at_noise(table, sigma=1.0).index) == ["s", "t"]
    with pytest.raises(ValueError, match="noise_sigma = 3"):
        beyond.at_noise(table, sigma=3.0)


