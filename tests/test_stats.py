"""The one summary and confidence interval."""
import math
import numpy as np
import pytest

from uavwind.analysis.claims import bootstrap_ci, paired_difference


def test_bootstrap_and_paired_difference():
    rng = np.random.default_rng(0)
    x = rng.normal(5, 1, size=400)
    est, lo, hi = bootstrap_ci(x)
    assert lo < 5 < hi and hi - lo < 0.3 and est == pytest.approx(x.mean())
    y = x - 1 + rng.normal(0, 0.01, size=400)
    d = paired_difference(x, y)
    assert d[1] > 0.99 and d[2] < 1.01  # pairing removes the shared noise


# -- the one rule of every verdict (issue 67) -------------------------------------------
from uavwind.core.stats import (MIN_DECIDE, MIN_INTERVAL, UNDECIDED, Decision, decide,  # noqa: E402
                                interval_label)


def test_decide_refuses_below_the_minimum_whatever_the_interval():
    d = decide(50.0, 40.0, 60.0, MIN_DECIDE - 1)
    assert isinstance(d, Decision) and not d.decided and d.word == UNDECIDED and d.too_few
    assert f"fewer than the {MIN_DECIDE}" in d.reason and d.n == MIN_DECIDE - 1
    # two loops' zero-width "interval" (both loops alike) decides nothing either
    assert decide(1.0, 1.0, 1.0, 2, threshold=0.5).word == UNDECIDED


def test_decide_an_interval_spanning_the_threshold_is_undecided():
    d = decide(0.3, -0.2, 0.8, 50)
    assert not d.decided and d.word == UNDECIDED and "spans 0" in d.reason and not d.too_few


def test_decide_a_zero_width_interval_is_read_off_the_estimate():
    up = decide(1.0, 1.0, 1.0, 5, threshold=0.5, above="separates")
    assert up.decided and up.word == "separates" and "no spread" in up.reason
    tie = decide(0.0, 0.0, 0.0, 8, within="tied")
    assert tie.decided and tie.word == "tied"
    assert decide(-2.0, -2.0, -2.0, 8).word == "lower"


def test_decide_a_decided_difference_and_its_words():
    assert decide(3.0, 1.0, 5.0, 50).word == "higher"
    assert decide(-3.0, -5.0, -1.0, 50, below="drops below").word == "drops below"
    d = decide(0.95, 0.92, 0.99, 50, threshold=0.9, above="works")
    assert d.decided and d.word == "works" and d.threshold == 0.9


def test_decide_the_size_of_the_difference():
    small = decide(0.5, -1.0, 2.0, 50, margin=5.0, within="no major effect")
    assert small.decided and small.word == "no major effect"
    # an interval reaching past the margin neither says "no effect" nor decides a sign
    assert decide(3.0, -1.0, 7.0, 50, margin=5.0).word == UNDECIDED
    # a NaN bound: nothing to read
    assert decide(1.0, float("nan"), float("nan"), 50).word == UNDECIDED


def test_decide_rejects_an_inverted_interval_and_a_bad_n():
    with pytest.raises(ValueError, match="low"):
        decide(0.0, 1.0, -1.0, 10)
    with pytest.raises(ValueError, match="n"):
        decide(0.0, -1.0, 1.0, -1)


def test_decision_is_frozen():
    d = decide(3.0, 1.0, 5.0, 50)
    with pytest.raises(AttributeError):
        d.word = "lower"
    assert str(d) == "higher"


def test_interval_label_never_calls_two_loops_an_interval_nor_shows_zero_width():
    assert MIN_INTERVAL == 3
    assert interval_label(81.39, 80.0, 82.0, 2) == "81.39 (2 loops, no interval)"
    assert interval_label(98.66, 98.66, 98.66, 5) == "98.66 (the same on all 5 loops)"
    assert interval_label(1.0, 1.0, 1.0, 5, digits=0, scale=100) == "100 (the same on all 5 loops)"
    assert interval_label(85.0, 80.1, 89.9, 50, digits=1) == "85.0 [80.1, 89.9]"
    assert interval_label(-1e-17, -1e-17, 0.5, 5) == "0.00 [0.00, 0.50]"
    assert interval_label(85.0, 85.0, 85.0, 1, digits=1) == "85.0 (1 loop, no interval)"
    assert interval_label(85.04, 80.12, 89.96, 3, digits=1) == "85.0 [80.1, 90.0]"
    assert interval_label(85.0, math.nan, math.nan, 8, digits=1) == "85.0 (8 loops, no interval)"
    # a difference, signed: a zero-width one (every episode alike) is no interval either
    assert interval_label(0.0, 0.0, 0.0, 6, 1, unit="episodes", signed=True) == \
        "+0.0 (the same on all 6 episodes)"
    assert interval_label(-16.7, -50.0, -1e-9, 6, 1, signed=True) == "-16.7 [-50.0, +0.0]"


def test_interval_label_is_the_only_interval_formatter():
    """One name per idea: the report layer's former interval_text is gone, its pages use this."""
    import uavwind.report.sentences as sentences
    assert not hasattr(sentences, "interval_text")


@pytest.mark.parametrize("args, name", [((85.0, 80.0, 90.0, 0), "n"),
                                        ((math.nan, 80.0, 90.0, 3), "estimate"),
                                        ((85.0, 90.0, 80.0, 3), "low")])
def test_interval_label_rejects_what_it_cannot_write_naming_it(args, name):
    with pytest.raises(ValueError, match=f"^{name} must"):
        interval_label(*args)
