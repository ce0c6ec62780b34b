"""Layouts: halves, gap, the inferred lattice."""

import numpy as np
import pytest

import uavwind as uw
from uavwind.study.conditions import SPEED_RANGES
from uavwind.study.layouts import Layout


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


def test_halves_layout_is_decision_5_bit_for_bit():
    # keys and speeds computed by the code before layouts existed (commit 79a1b00)
    assert uw.make_setting("light constant", "light constant", 5, layout="halves").key() \
        == "531858395b61aa2f"
    assert uw.make_setting("light constant", "strong turbulence", 5, layout="halves",
                           turbulence="mil-f-8785c").key() == "e02d5f44c1696134"
    assert uw.make_setting("strong shear", "strong shear", 10, layout="halves").key() \
        == "48178438c0780d2a"
    a, _ = uw.group_speeds("strong shear", "strong shear", 5, layout="halves")
    assert a.tolist() == [11.314, 11.581999999999999, 11.85, 12.118, 12.386]


@pytest.mark.parametrize("strength", ["light", "strong"])
@pytest.mark.parametrize("n", [3, 5, 10])
def test_lattice_layout_spans_the_class_range_with_the_fitted_gap(strength, n):
    lo, hi = uw.SPEED_RANGES[strength]
    a, b = uw.group_speeds(f"{strength} constant", f"{strength} constant", n,
                           layout=Layout("t", gap_ratio=7.0))
    assert a.size == b.size == n
    step = np.diff(a)
    assert np.allclose(step, step[0]) and np.allclose(np.diff(b), step[0])
    assert b[0] - a[-1] == pytest.approx(7.0 * step[0])
    assert a[0] == pytest.approx(lo) and b[-1] == pytest.approx(hi)


def test_lattice_with_an_absolute_spacing_starts_at_the_range():
    a, b = uw.group_speeds("light constant", "light shear", 3,
                           layout=Layout("t", gap_ratio=4.0, spacing=0.1))
    assert np.allclose(a, [0.45, 0.55, 0.65]) and np.allclose(b, [1.05, 1.15, 1.25])


def test_inferred_layout_uses_the_fitted_ratio_per_pair():
    for cond, rho in uw.INFERRED_GAP_RATIOS.items():
        s = uw.make_setting(cond, cond, 5)
        a, b = np.sort(s.group_a.speeds), np.sort(s.group_b.speeds)
        assert (b[0] - a[-1]) / (a[1] - a[0]) == pytest.approx(rho)


@pytest.mark.parametrize("a, b", [("light constant", "strong constant"),
                                  ("light shear", "strong shear")])
def test_mixed_pairs_take_table3s_spacing_centred_in_each_class(a, b):
    """The inferred reading: each group's environments 0.1 m/s apart on each of x and y, as
    in Table 3, centred on its class range; the halves reading keeps the class cells."""
    x = uw.make_setting(a, b, 5)
    for g, (lo, hi) in ((x.group_a, (0.45, 1.34)), (x.group_b, (11.18, 13.86))):
        v = np.array(g.values)
        assert np.allclose(np.diff(v, axis=0), [0.1, 0.1, 0.0], rtol=0, atol=1e-12)
        assert g.speeds.mean() == pytest.approx(0.5 * (lo + hi))
    y = uw.make_setting(a, b, 5, layout="halves")
    assert np.allclose(y.group_a.speeds, 0.45 + (np.arange(5) + 0.5) * 0.89 / 5)
    # a turbulent mixed pair keeps the cells its turbulence reading was chosen on
    t = uw.make_setting("light constant", "strong turbulence", 5)
    assert np.allclose(t.group_b.speeds, 11.18 + (np.arange(5) + 0.5) * 2.68 / 5)


def test_a_mixed_lattice_refuses_speeds_at_or_below_zero():
    lay = uw.Layout("t", mixed_spacing=0.5)
    with pytest.raises(ValueError, match="must be > 0"):
        uw.group_speeds("light constant", "strong constant", 5, layout=lay)


@pytest.mark.parametrize("kwargs, match", [
    ({"gap": 1.0}, "gap"), ({"gap": -0.1}, "gap"), ({"gap_ratio": 0.0}, "gap_ratio"),
    ({"gap_ratio": float("nan")}, "gap_ratio"), ({"gap_ratio": 1e9}, "gap_ratio"),
    ({"gap_ratio": 2.0, "spacing": -1.0}, "spacing"), ({"spacing": 0.1}, "spacing"),
    ({"direction": (0, 0, 0)}, "direction"), ({"direction": (1, 0)}, "direction"),
])
def test_bad_layout_parameters_name_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Layout("bad", **kwargs)


def test_inferred_layout_with_a_turbulent_group_a():
    s = uw.make_setting("strong turbulence", "strong shear", 3)
    assert s.group_a.kind == "turbulence" and s.n_env == 6
    with pytest.raises(ValueError, match="no fitted gap"):
        uw.make_setting("strong turbulence", "strong turbulence", 3)


@pytest.mark.parametrize("make, match", [
    (lambda: uw.Layout("x", gap=0.5, gap_ratio=3.0), "give one"),
    (lambda: uw.group_speeds("light constant", "light constant", 5,
                             layout=uw.Layout("x", gap_ratio=2.0, spacing=100.0)),
     "beyond the class range"),
])
def test_a_layout_never_silently_ignores_or_leaves_its_class(make, match):
    with pytest.raises(ValueError, match=match):
        make()
