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


# ---- one registry (issue 68) --------------------------------------------------------- #
def test_one_registry_holds_every_computed_thing_and_get_experiment_is_its_lookup():
    """Exp 13, Exp 11's filter table, the explorer's grid and the pages' analyses are entries
    of the one registry beside the experiments; get_experiment looks any of them up, and
    needed_entries plans any of them (an analysis: the entries of what it reads)."""
    from uavwind.study.fill import needed_entries
    from uavwind.study.registry import ANALYSES, REGISTRY, get_experiment

    assert {"exp13", "exp11_filter_table", "explore_grid", "claims"} <= set(ANALYSES)
    assert list(REGISTRY) == [*EXPERIMENTS, *ANALYSES]
    exp13 = get_experiment("exp13")
    assert exp13.kind == "analysis" and exp13.id == "exp13" and exp13.long
    assert ex.get_experiment("exp1") is EXPERIMENTS["exp1"] and EXPERIMENTS["exp1"].kind == "experiment"
    assert needed_entries(["exp13"]) == [] and needed_entries("explore_grid") == []
    claims = {e.path for e in needed_entries(["claims"], "quick", "inferred")}
    read = {e.path for e in needed_entries(list(ANALYSES["claims"].reads), "quick", "all")}
    assert claims == read
    with pytest.raises(ValueError, match="unknown experiment 'nope'.*exp13"):
        get_experiment("nope")


def test_the_package_face_imports_every_module_that_registers():
    """The analyses register where they are defined, above the study layer, which cannot
    import them: the package's face imports each module that calls ``computes`` (else the
    registry would miss its entries in a process that never imported it)."""
    import ast

    face = ast.parse((ROOT / "uavwind" / "__init__.py").read_text())
    imported = set()
    for node in ast.walk(face):
        if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
            imported |= {f"{node.module}.{a.name}" for a in node.names}
    registering = set()
    for path in (ROOT / "uavwind").rglob("*.py"):
        rel = path.relative_to(ROOT / "uavwind").with_suffix("")
        if rel.parts[0] == "study":
            continue  # the registry's own layer: it registers its experiments itself
        if re.search(r"^@computes\(", path.read_text(), re.M):
            registering.add(".".join(rel.parts))
    assert registering == {"analysis.page_analyses", "analysis.filters", "analysis.exp13",
                           "report.explore"}
    assert registering <= imported, registering - imported


def test_list_shows_every_entry_and_analyses_is_no_command(capsys):
    from uavwind.cli import main
    from uavwind.study.registry import REGISTRY

    assert main(["list"]) == 0
    out = capsys.readouterr().out
    shown = {line.split()[0] for line in out.splitlines()[1:]}
    assert shown == set(REGISTRY)
    assert {"exp13", "exp11_filter_table", "explore_grid", "exp1"} <= shown
    with pytest.raises(SystemExit) as stop:
        main(["analyses"])
    assert stop.value.code == 2 and "'run'" in capsys.readouterr().err


def test_fill_cache_all_is_what_make_results_runs(tmp_path, monkeypatch):
    """``fill_cache("all")`` and ``python -m uavwind run all --reading all`` (the Makefile's
    ``make results``) hand out the same entries and the same analyses."""
    from helpers import record_fills

    from uavwind.cli import main
    from uavwind.study import fill

    tiny = {"loops": 2, "long_loops": 3, "fit_loops": 2, "episodes": 1,
            "cem": {"n_samples": 3, "n_elite": 1, "max_iter": 1}}
    monkeypatch.setitem(ex.PROFILES, "tiny", ex.get_profile({**tiny, "name": "tiny"}))
    monkeypatch.delenv("UAVWIND_NEURALFLY", raising=False)
    make = (ROOT / "Makefile").read_text()
    assert "-m uavwind run all --reading all --profile $(PROFILE)" in make
    runs = {}
    for how in ("python", "cli"):
        analyses = []
        order = record_fills(monkeypatch, analyses)
        results = tmp_path / how
        if how == "python":
            done = fill.fill_cache("all", profile="tiny", results=results, n_jobs=1,
                                   progress=False)
        else:
            monkeypatch.setenv("UAVWIND_RESULTS", str(results))
            assert main(["run", "all", "--reading", "all", "--profile", "tiny", "--jobs", "1",
                         "--no-tables", "--no-progress"]) == 0
        runs[how] = (sorted(e.path.relative_to(results).as_posix() for e in order), analyses)
    assert runs["python"] == runs["cli"]
    entries, analyses = runs["python"]
    assert len(entries) == len(fill.needed_entries("all", "tiny")) > 0
    assert "exp13" not in analyses and {"explore_grid", "exp11_filter_table", "claims"} <= set(analyses)
    assert done["skipped"] == ["exp13"]
