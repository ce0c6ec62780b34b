"""The registry drives the pages: adding an experiment is one registry entry, one notebook
and one line in book/_toc.yml; nothing else lists the experiments."""
import re
from pathlib import Path

from uavwind.analysis.claims import CLAIMS, needed_experiments
from uavwind.report.display import PRETTY
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
    assert "$(wildcard notebooks/*.md)" in make
    assert not any(re.search(rf"\b{n}\b", make) for n in NOTEBOOKS if n != "notebooks")


def test_the_claims_page_reads_the_experiments_the_claims_need():
    need = needed_experiments()
    assert need == [e for e in EXPERIMENTS if any(e in n for n, _ in CLAIMS.values())]
    page = (ROOT / "notebooks" / "claims.md").read_text()
    assert "needed_experiments()" in page and not re.search(r'"exp\d"', page)


def test_every_label_column_has_one_display_name_from_the_registry():
    names = column_names()
    assert set(names) <= set(label_columns())
    assert all(PRETTY[k] == v for k, v in names.items())
