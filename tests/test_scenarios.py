"""Scenario builders: Table 2, Table 3 verbatim, Exp 2/3/5 removal rules."""
import numpy as np
import pytest

import uavwind as uw
from uavwind.study.conditions import SPEED_RANGES


def test_table2():
    t = uw.scenario_table()
    assert len(t) == 7
    assert t.loc[7].tolist() == ["light constant", "strong turbulence"]
    assert t.loc[5].tolist() == ["light shear", "strong shear"]


def test_table3_verbatim(worked_example):
    s = worked_example
    assert s.group_a.kind == "shear" and s.group_b.kind == "constant"
    assert np.allclose(np.array(s.group_a.values), [[2.1 + 0.1 * i, 10.1 + 0.1 * i, 0] for i in range(5)])
    assert np.allclose(np.array(s.group_b.values), [[1.1 + 0.1 * i, 1.1 + 0.1 * i, 0] for i in range(5)])
    assert s.groups.tolist() == [0] * 5 + [1] * 5
    frame = s.to_frame()
    assert frame.shape == (5, 6) and "x axis (m/s)" in frame["strong shear"].columns
    assert "strong shear" in str(s.group_a)


@pytest.mark.parametrize("a, b", [(a.label, b.label) for a, b in uw.PAPER_SCENARIOS.values()])
def test_generated_groups_stay_in_their_ranges(a, b):
    s = uw.make_setting(a, b, 10)
    sa, sb = s.group_a.speeds, s.group_b.speeds
    assert len(sa) == len(sb) == 10
    (lo_a, hi_a), (lo_b, hi_b) = SPEED_RANGES[a.split()[0]], SPEED_RANGES[b.split()[0]]
    eps = 1e-12  # the inferred lattice puts the outer environments on the range's ends
    assert np.all((sa >= lo_a - eps) & (sa <= hi_a + eps))
    assert np.all((sb >= lo_b - eps) & (sb <= hi_b + eps))
    if a.split()[0] == b.split()[0]:  # same class: group A below group B
        assert sa.max() < sb.min()
        h = uw.make_setting(a, b, 10, layout="halves")  # decision 5: adjacent halves
        both = np.sort(np.concatenate([h.group_a.speeds, h.group_b.speeds]))
        assert np.allclose(np.diff(both), np.diff(both)[0])  # evenly spaced over the range
        assert both.min() > lo_a and both.max() < hi_a
    if s.group_a.kind != "turbulence":
        v = np.array(s.group_a.values)
        assert np.allclose(v[:, 0], v[:, 1]) and np.all(v[:, 2] == 0)  # x = y, horizontal


@pytest.mark.parametrize("strength", ["light", "strong"])
def test_gap_layout_leaves_the_middle_of_the_range_empty(strength):
    lo, hi = SPEED_RANGES[strength]
    a0, b0 = uw.group_speeds(f"{strength} constant", f"{strength} shear", 5, layout="halves")
    same = uw.group_speeds(f"{strength} constant", f"{strength} shear", 5,
                           layout=uw.Layout(gap=0.0))
    assert np.array_equal(a0, same[0]) and np.array_equal(b0, same[1])  # gap 0 = decision 5
    for gap in (0.25, 1 / 3, 0.9):
        a, b = uw.group_speeds(f"{strength} constant", f"{strength} shear", 5,
                               layout=uw.Layout(gap=gap))
        width = hi - lo
        assert b.min() - a.max() == pytest.approx(gap * width + width * (1 - gap) / 10)
        assert np.allclose(np.diff(a), np.diff(b))  # same spacing in both groups
        assert a.min() > lo and b.max() < hi
        # the layout is symmetric about the middle of the range
        assert np.allclose(a + b[::-1], lo + hi)
    # different strengths ignore the gap: each group keeps its own range
    x = uw.group_speeds("light constant", "strong constant", 5, layout=uw.Layout(gap=0.5))
    y = uw.group_speeds("light constant", "strong constant", 5, layout="halves")
    assert np.array_equal(x[0], y[0]) and np.array_equal(x[1], y[1])
    for bad in (-0.1, 1.0, float("nan")):
        with pytest.raises(ValueError, match="gap"):
            uw.Layout(gap=bad)
    assert uw.make_setting("light constant", "light constant", 5, layout="gap").key() != \
        uw.make_setting("light constant", "light constant", 5, layout="halves").key()


def test_turbulence_group_builds_dryden():
    s = uw.make_setting("light constant", "strong turbulence", 4)
    w = s.wind(seed=1)
    assert isinstance(w.models[1], uw.DrydenWind)
    assert np.allclose(w.models[1].w20, s.group_b.speeds)


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


def test_setting_key_is_stable_and_sensitive():
    a = uw.make_setting("light constant", "strong constant", 5)
    b = uw.make_setting("light constant", "strong constant", 5)
    assert a.key() == b.key() and hash(a) == hash(b) and a == b
    assert a.key() != uw.make_setting("light constant", "strong constant", 6).key()
    assert a.key() != uw.make_setting("light constant", "strong constant", 5, n_changes=4).key()
    assert a.key() != uw.make_setting("light constant", "strong constant", 5, uav=uw.UAV(mass=3)).key()


@pytest.mark.parametrize("call, err, match", [
    (lambda: uw.WindCondition("medium", "constant"), ValueError, "strength"),
    (lambda: uw.WindCondition("light", "breeze"), ValueError, "kind"),
    (lambda: uw.WindCondition.parse("light"), ValueError, "condition"),
    (lambda: uw.WindCondition.parse(3), TypeError, "condition"),
    (lambda: uw.make_setting("light constant", "strong shear", 0), ValueError, "n_a"),
    (lambda: uw.make_setting("light constant", "strong shear", sampler="sobol"), ValueError, "sampler"),
    (lambda: uw.EnvironmentGroup("constant", [[1.0, np.nan, 0.0]]), ValueError, "finite"),
    (lambda: uw.EnvironmentGroup("constant", [[1.0, 0.0]]), ValueError, "shape"),
    (lambda: uw.EnvironmentGroup("turbulence", [0.0]), ValueError, "W20"),
    (lambda: uw.Setting("a", "b"), TypeError, "group_a"),
])
def test_validation(call, err, match):
    with pytest.raises(err, match=match):
        call()
