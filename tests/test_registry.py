"""The registry drives the pages: adding an experiment is one registry entry, one notebook
and one line in book/_toc.yml; nothing else lists the experiments."""
import re
from pathlib import Path

import pytest

from uavwind import study as ex
from uavwind.analysis.claims import (
    CLAIMS,
    needed_experiments,
)
from uavwind.report.display import PRETTY
from uavwind.study import cases, registry
from uavwind.study.registry import EXPERIMENTS, column_names, label_columns

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = {p.stem for p in (ROOT / "notebooks").glob("*.md")}
TOC = set(re.findall(r"file: generated/(\w+)", (ROOT / "book" / "_toc.yml").read_text()))


def test_every_experiment_has_its_notebook_and_every_notebook_a_page():
    for e in EXPERIMENTS.values():
        assert e.notebook.removesuffix(".md") in NOTEBOOKS, e.id
    assert NOTEBOOKS == TOC  # the Makefile runs every notebook; the book shows each one


def test_the_makefile_lists_no_notebook_by_name():
    make = (ROOT / "Makefile").read_text()
    assert "$(wildcard $(NB_DIR)/*.md)" in make and "NB_DIR  ?= notebooks" in make
    assert not any(re.search(rf"\b{n}\b", make) for n in NOTEBOOKS if n != "notebooks")


def test_the_claims_page_reads_the_experiments_the_claims_need():
    need = needed_experiments()
    assert need == [e for e in EXPERIMENTS if any(e in n for n, _ in CLAIMS.values())]
    page = (ROOT / "notebooks" / "claims.md").read_text()
    assert "needed_experiments()" in page and not re.search(r'"exp\d"', page)


def _pages_reading(reading):
    """Experiments a notebook runs under ``reading`` by name (``reading="halves"``)."""
    out = set()
    for nb in (ROOT / "notebooks").glob("*.md"):
        for m in re.finditer(r'run_experiment\("(\w+)"[^)]*reading="' + reading + '"',
                             nb.read_text()):
            out.add(m.group(1))
    return out


def test_the_fill_computes_a_reading_only_where_the_book_shows_it():
    """The book's pages read every experiment under the inferred reading; the halves
    reading (the ablation) only where the claims page (both readings of what the claims
    need), Exp 1's page or an experiment of its own (Exp 12) shows it. An experiment whose
    halves entries the book never reads may keep the halves reading only if those entries
    are its inferred ones (nothing is computed for it)."""
    from uavwind.study.fill import needed_entries

    shown = set(needed_experiments()) | _pages_reading("halves") | {
        e.id for e in EXPERIMENTS.values() if e.readings == ("halves",)}
    assert {"exp1", "exp12"} <= shown
    for exp in EXPERIMENTS.values():
        if "halves" not in exp.readings or exp.id in shown:
            continue
        inferred = {e.path for e in needed_entries(exp.id, "quick", "inferred")}
        halves = {e.path for e in needed_entries(exp.id, "quick", "halves")}
        assert halves == inferred, f"{exp.id}: halves entries no page reads"


def test_every_label_column_has_one_display_name_from_the_registry():
    names = column_names()
    assert set(names) <= set(label_columns())
    assert all(PRETTY[k] == v for k, v in names.items())


def test_registry_matches_the_paper():
    assert list(ex.EXPERIMENTS) == ["example", "exp1", "exp2", "exp3", "exp4", "exp5", "exp6",
                                    "exp6_raw", "exp7", "exp8", "exp9", "exp10", "exp11",
                                    "exp11_cem", "exp12", "exp14", "exp14_cem", "fit_layout",
                                    "fit_mixed", "fit_turbulence"]
    sizes = {k: len(e.cases()) for k, e in ex.EXPERIMENTS.items()}
    n_ratios = len(cases.FIT_RATIOS)
    assert sizes == {"example": 1, "exp1": 8, "exp2": 32, "exp3": 32, "exp4": 28, "exp5": 2,
                     "exp6": 1, "exp6_raw": 1, "exp7": 3 * 11, "exp8": 3 * 4 * 2, "exp9": 3 * 11,
                     "exp10": 8 * 4 + 8 * 2, "exp11": 4 * 2 * 5 * 2, "exp11_cem": 4,
                     "exp12": 3 * 2, "exp14": 7 * 3 + 7 + 2 * 2, "exp14_cem": 2,
                     "fit_layout": 4 * n_ratios, "fit_mixed": 2 * 2 * 3, "fit_turbulence": 6}
    # Exp 9 is Exp 7's loops seen by the baseline: the same settings, so one cache
    assert [c.setting.key() for c in ex.EXPERIMENTS["exp9"].cases()] == \
        [c.setting.key() for c in ex.EXPERIMENTS["exp7"].cases()]
    # the layout fit: Exp 1's same-strength scenarios, every ratio of the grid
    fit = ex.EXPERIMENTS["fit_layout"].cases()
    assert sorted({c.labels["scenario_id"] for c in fit}) == [1, 3, 4, 6]
    for c in fit:
        a, b = c.setting.group_a.speeds, c.setting.group_b.speeds
        assert (b.min() - a.max()) / (a[1] - a[0]) == pytest.approx(c.labels["gap_ratio"])
    exp1 = ex.EXPERIMENTS["exp1"].cases()
    assert [c.long for c in exp1] == [False] * 7 + [True]
    assert all(c.setting.n_env == 10 for c in exp1[:7]) and exp1[7].setting.n_env == 20
    exp4 = ex.EXPERIMENTS["exp4"].cases()
    assert sorted({c.labels["thrust_changes"] for c in exp4}) == [0, 2, 4, 6, 8, 10, 12]
    assert {c.setting.n_changes for c in exp4} == {0, 2, 4, 6, 8, 10, 11}
    # Exp 6 flies Exp 5's similar-direction environments
    assert ex.EXPERIMENTS["exp6"].cases()[0].setting.key() == ex.EXPERIMENTS["exp5"].cases()[0].setting.key()
    for e in ex.EXPERIMENTS.values():
        assert (Path(__file__).parents[1] / "notebooks" / e.notebook).exists()


def test_profiles_and_loop_counts():
    assert ex.PROFILES["paper"].loops == 50 and ex.PROFILES["paper"].long_loops == 500
    assert ex.PROFILES["paper"].cem.to_dict() == {"n_samples": 30, "n_elite": 4, "max_iter": 20}
    # example 50, exp1 7x50 + 500, exp2/exp3 32x50 each, exp4 28x50, exp5 2x50,
    # exp6 and exp6_raw 30x20 each,
    # exp7/exp9 33x50 each (sized; 128 before they were sized on their share), exp8 24x50,
    # exp10 48x50, exp11 80 side-experiment cases x 20 (sized: its floor), exp11_cem 4 CEM searches x 30x10,
    # exp12 6 cases x 200 closed-loop episodes x 4 policies,
    # fit_layout 4 scenarios x 16 ratios x 20, fit_mixed 12 x 20, fit_turbulence 6 x 50
    assert ex.n_loops_total("paper") == (50 + 850 + 1600 + 1600 + 1400 + 100 + 2 * 600
                                         + 2 * 33 * 50 + 24 * 50 + 48 * 50 + 80 * 20 + 4 * 300 + 6 * 200 * 4 + 4 * 16 * 20
                                         + 12 * 20 + 6 * 50
                                         # exp14: 21 waypoint cases x 20, 7 thrust/position x 50,
                                         # 4 thrust (Exp 11's) x 20; exp14_cem 2 x 10 x 5
                                         + 21 * 20 + 7 * 50 + 4 * 20 + 2 * 10 * 5)
    with pytest.raises(ValueError, match="profile"):
        ex.run_experiment("exp5", profile="huge")
    with pytest.raises(ValueError, match="unknown experiment 'exp99'"):
        ex.run_experiment("exp99")
    with pytest.raises(TypeError, match="experiment id"):
        ex.get_experiment(5)
