"""Setting builders: the paper's words to settings (Exps 1-5)."""
import numpy as np
import pytest

import uavwind as uw
from uavwind.study.conditions import SPEED_RANGES


@pytest.mark.parametrize("a, b", [(a.label, b.label) for a, b in uw.PAPER_SCENARIOS.values()])
def test_generated_groups_stay_in_their_ranges(a, b):
    s = uw.make_setting(a, b, 10)
    sa, sb = s.group_a.speeds, s.group_b.speeds
    assert len(sa) == len(sb) == 10
    (lo_a, hi_a), (lo_b, hi_b) = SPEED_RANGES[a.split()[0]], SPEED_RANGES[b.split()[0]]
    eps = 1e-12  # the inferred lattice puts the outer environments on the range's ends
    if a.split()[0] == b.split()[0]:
        assert np.all((sa >= lo_a - eps) & (sa <= hi_a + eps))
        assert np.all((sb >= lo_b - eps) & (sb <= hi_b + eps))
    else:  # mixed: Table 3's spacing, centred on each class (10 light ones reach beyond it)
        assert sa.mean() == pytest.approx((lo_a + hi_a) / 2)
        assert sb.mean() == pytest.approx((lo_b + hi_b) / 2)
        h = uw.make_setting(a, b, 10, layout="halves")  # the class cells, inside the range
        assert h.group_a.speeds.min() > lo_a and h.group_a.speeds.max() < hi_a
    if a.split()[0] == b.split()[0]:  # same class: group A below group B
        assert sa.max() < sb.min()
        h = uw.make_setting(a, b, 10, layout="halves")  # decision 5: adjacent halves
        both = np.sort(np.concatenate([h.group_a.speeds, h.group_b.speeds]))
        assert np.allclose(np.diff(both), np.diff(both)[0])  # evenly spaced over the range
        assert both.min() > lo_a and both.max() < hi_a
    if s.group_a.kind != "turbulence":
        v = np.array(s.group_a.values)
        assert np.allclose(v[:, 0], v[:, 1]) and np.all(v[:, 2] == 0)  # x = y, horizontal


def test_range_similarity_removes_the_closest_pair():
    settings = uw.range_similarity_settings("light constant", "light constant", 10, 3)
    assert [s.n_env for s in settings] == [20, 18, 16, 14, 12, 10, 8, 6]
    gaps = [s.group_b.speeds.min() - s.group_a.speeds.max() for s in settings]
    assert np.all(np.diff(gaps) > 0)  # the gap widens
    first, last = settings[0], settings[-1]
    assert np.allclose(last.group_a.speeds, first.group_a.speeds[:3])  # the lowest three
    assert np.allclose(last.group_b.speeds, first.group_b.speeds[-3:])  # the highest three


def test_environment_count_keeps_the_gap_and_outer_speeds():
    settings = uw.environment_count_settings("light shear", "light shear", 10, 3)
    assert [s.n_env for s in settings] == [20, 18, 16, 14, 12, 10, 8, 6]
    for s in settings:
        a, b = s.group_a.speeds, s.group_b.speeds
        assert a.min() == settings[0].group_a.speeds.min() and a.max() == settings[0].group_a.speeds.max()
        assert b.min() == settings[0].group_b.speeds.min() and b.max() == settings[0].group_b.speeds.max()
        assert b.min() - a.max() == pytest.approx(settings[0].group_b.speeds.min() - settings[0].group_a.speeds.max())


def test_direction_flip():
    same, opposite = uw.direction_settings()
    assert np.array_equal(np.array(opposite.group_b.values), -np.array(same.group_b.values))
    assert np.array_equal(np.array(opposite.group_a.values), np.array(same.group_a.values))
    with pytest.raises(ValueError, match="turbulence"):
        uw.make_setting("light constant", "strong turbulence").group_b.negated()
