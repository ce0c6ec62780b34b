"""The book's verdict sentences (uavwind.report.sentences): one test per branch."""
import math

import pytest

from uavwind.report.sentences import (compare_phrase, first_to_lose, grouping_phrase,
                                      interval_order)


def test_interval_order_says_above_below_or_cannot_decide():
    assert interval_order((5, 6), (1, 4), n=5) == 1
    assert interval_order((1, 4), (5, 6), n=5) == -1
    assert interval_order((1, 5), (4, 6), n=5) == 0      # overlap
    assert interval_order((1, 4), (4, 6), n=5) == 0      # touching: not separated
    assert interval_order((3, 3), (3, 3), n=5) == 0      # two equal scores (exp10's 0.0 and 0.0)
    assert interval_order((5, 6), (1, 4), n=2) == 0      # two loops decide nothing (issue 67)


@pytest.mark.parametrize("a, b, name", [((2, 1), (0, 1), "a"), ((0, 1), (math.nan, 1), "b")])
def test_interval_order_rejects_a_bad_interval_naming_it(a, b, name):
    with pytest.raises(ValueError, match=f"^{name} must"):
        interval_order(a, b, n=5)


def test_compare_phrase_takes_each_branch():
    words = dict(higher="up", lower="down", undecided="cannot decide")
    assert compare_phrase((90, 95), (80, 85), **words, n=50) == "up"
    assert compare_phrase((80, 85), (90, 95), **words, n=50) == "down"
    assert compare_phrase((80, 92), (90, 95), **words, n=50) == "cannot decide"
    assert compare_phrase((90, 95), (80, 85), **words, n=2) == "cannot decide"


def test_grouping_phrase_takes_each_branch():
    what = "the zero-mean readings"
    assert grouping_phrase({"a": 1.0, "b": 1.0}, what) == f"{what}: every loop grouped correctly"
    assert grouping_phrase({"a": 0.1, "b": 0.3}, what) == \
        f"{what}: most loops misgrouped (at most 30% grouped correctly)"
    assert grouping_phrase({"a": 0.64}, what) == f"{what}: 64% of the loops grouped correctly"
    # the case: one zero-mean row at 100%, another at 64%: neither "all wrong" nor "all right"
    assert grouping_phrase({"a": 0.64, "b": 1.0}, what) == \
        f"{what}: from 64% to 100% of the loops grouped correctly, case by case"
    with pytest.raises(ValueError, match="^correct_rates must hold"):
        grouping_phrase({}, what)
    with pytest.raises(ValueError, match=r"^correct_rates must lie in \[0, 1\]"):
        grouping_phrase({"a": 1.5}, what)


def test_first_to_lose_names_the_largest_drop_or_none():
    clean = {"position": 90.0, "attitude": 5.0, "IMU": 80.0}
    assert first_to_lose(clean, {"position": 10.0, "attitude": 0.0, "IMU": 70.0}) == \
        "position loses most (80.0 points)"
    # attitude scoring 0 with noise loses little: it had little to lose
    assert first_to_lose({"a": 50.0, "b": 50.0}, {"a": 0.0, "b": 0.0}) == \
        "a and b lose most (50.0 points)"
    assert first_to_lose({"a": 50.0}, {"a": 60.0}) == "no channel loses score to the noise"
    # with the loops' losses the ranking is the one rule's (issue 67)
    two = first_to_lose(clean, {"position": 10.0, "attitude": 0.0, "IMU": 70.0},
                        losses={"position": [80.0, 79.0], "attitude": [5.0, 5.0],
                                "IMU": [10.0, 11.0]})
    assert two.startswith("position loses most (80.0 points), not told apart from IMU")
    assert "cannot decide" in two and "fewer than the 5" in two
    many = first_to_lose(clean, {"position": 10.0, "attitude": 0.0, "IMU": 70.0},
                         losses={"position": [80.0 + i for i in range(-3, 4)],
                                 "attitude": [5.0] * 7, "IMU": [10.0 + i for i in range(-3, 4)]})
    assert many == "position loses most (80.0 points)"
    with pytest.raises(ValueError, match="^clean and noisy must name"):
        first_to_lose({"a": 1.0}, {"b": 1.0})
    with pytest.raises(ValueError, match="^clean and noisy must be numbers"):
        first_to_lose({"a": math.nan}, {"a": 1.0})
