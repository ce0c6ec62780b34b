"""The book's build never hangs: every page runs under a cell timeout and a page timeout,
a page that exceeds either fails the build naming the page and the cell, and no cell that
needs a live kernel (a widget) runs in the build."""
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: What a live-widget cell calls: it needs a kernel and a front end, so it cannot run in a build.
LIVE = re.compile(r"\bexplorer\(\)|\bipywidgets\b|\binteract(ive)?\(")


def _code_cells(md: Path):
    """(tags, source) of every ``{code-cell}`` of a MyST notebook."""
    text = md.read_text()
    for m in re.finditer(r"```\{code-cell\}[^\n]*\n(.*?)```", text, flags=re.S):
        body = m.group(1)
        tags = re.search(r"^:tags:\s*\[([^\]]*)\]", body, flags=re.M)
        yield ({t.strip() for t in tags.group(1).split(",")} if tags else set()), body


def test_no_live_widget_cell_executes_in_the_build():
    live = [(md.name, src.strip()[:60]) for md in sorted((ROOT / "notebooks").glob("*.md"))
            for tags, src in _code_cells(md) if LIVE.search(src) and "skip-execution" not in tags]
    assert not live, f"cells that need a live kernel but run in the build: {live}"
    # and the tag is honoured: papermill runs cells through nbclient, which skips it
    from nbclient import NotebookClient
    assert NotebookClient.skip_cells_with_tag.default_value == "skip-execution"


def _make_page(tmp_path, source, **timeouts):
    nb_dir = tmp_path / "nb"
    nb_dir.mkdir()
    (nb_dir / "hangs.md").write_text(
        "---\njupytext:\n  text_representation:\n    extension: .md\n    format_name: myst\n"
        "kernelspec:\n  display_name: Python 3\n  language: python\n  name: python3\n---\n\n"
        "# A page that hangs\n\n```{code-cell} ipython3\nprint('first cell')\n```\n\n"
        f"```{{code-cell}} ipython3\n{source}\n```\n")
    book = tmp_path / "book"
    env = {**os.environ, "UAVWIND_RESULTS": str(tmp_path / "results")}
    env.pop("MPLBACKEND", None)
    args = ["make", "-C", str(ROOT), "--no-print-directory", "-o", "results", f"BOOK={book}",
            f"NB_DIR={nb_dir}", "PROFILE=quick"] + [f"{k}={v}" for k, v in timeouts.items()]
    t0 = time.monotonic()
    proc = subprocess.run(args + [f"{book}/generated/hangs.ipynb"], env=env, capture_output=True,
                          text=True, timeout=300)
    return proc, time.monotonic() - t0, book


@pytest.mark.skipif(os.environ.get("UAVWIND_SKIP_BOOK") == "1", reason="UAVWIND_SKIP_BOOK=1")
def test_a_hung_cell_fails_its_page_naming_the_page_and_the_cell(tmp_path):
    proc, took, book = _make_page(tmp_path, "import time\ntime.sleep(3600)  # the hung cell",
                                  CELL_TIMEOUT=5)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert took < 120, took
    assert "hangs.md failed" in out, out[-2000:]
    assert "time.sleep(3600)" in out, out[-2000:]  # the cell, shown
    assert not (book / "generated" / "hangs.ipynb").exists()  # nothing partial becomes a page


@pytest.mark.skipif(os.environ.get("UAVWIND_SKIP_BOOK") == "1", reason="UAVWIND_SKIP_BOOK=1")
def test_a_page_over_its_page_timeout_is_stopped(tmp_path):
    proc, took, book = _make_page(tmp_path, "import time\ntime.sleep(3600)",
                                  CELL_TIMEOUT=3600, PAGE_TIMEOUT=10)
    out = proc.stdout + proc.stderr
    assert proc.returncode != 0
    assert took < 120, took
    assert "hangs.md failed" in out and "over PAGE_TIMEOUT=10 s" in out, out[-2000:]
    assert not (book / "generated" / "hangs.ipynb").exists()


def test_a_page_runs_with_the_builds_parameters_and_hides_them(tmp_path):
    """One page, one process (uavwind.report.pages): the MyST source executed with the
    build's profile and workers in place of its defaults, the injected cell hidden; a
    failing cell writes nothing."""
    import nbformat

    from uavwind.report.pages import run_page

    src = tmp_path / "page.md"
    src.write_text("---\njupytext:\n  text_representation:\n    extension: .md\n"
                   "    format_name: myst\n---\n\n# A page\n\n"
                   "```{code-cell} ipython3\n:tags: [parameters]\n\nprofile = 'x'\nn_jobs = 0\n```\n\n"
                   "```{code-cell} ipython3\nprint(profile, n_jobs + 1)\n```\n")
    out = run_page(src, tmp_path / "page.ipynb", "quick", 2, execution_timeout=60,
                   cwd=tmp_path)
    nb = nbformat.read(out, as_version=4)
    injected = [c for c in nb.cells if "injected-parameters" in c.metadata.get("tags", [])]
    assert len(injected) == 1 and "remove-cell" in injected[0].metadata["tags"]
    assert nb.cells[-1].outputs[0]["text"] == "quick 3\n"
    src.write_text(src.read_text().replace("n_jobs + 1", "1 / 0"))
    with pytest.raises(Exception, match="ZeroDivisionError"):
        run_page(src, tmp_path / "bad.ipynb", "quick", 2, execution_timeout=60)
    assert not (tmp_path / "bad.ipynb").exists()


def test_the_makefiles_page_driver_imports_none_of_the_package(tmp_path):
    """The Makefile runs uavwind/report/pages.py as a script: its driver imports no module
    of uavwind (the page's kernel does), and lifts the read-only flag by the name
    uavwind.core.io gives it around an exercise-computes cell; the page is written whole."""
    import nbformat

    from uavwind.core.io import READ_ONLY_ENV
    from uavwind.report.pages import COMPUTES

    make = (ROOT / "Makefile").read_text()
    assert "$(BIN)/python uavwind/report/pages.py $<" in make
    src = tmp_path / "page.md"
    probe = "import os\nprint(repr(os.environ.get('%s')))\n" % READ_ONLY_ENV
    src.write_text("---\njupytext:\n  text_representation:\n    extension: .md\n"
                   "    format_name: myst\n---\n\n# A page\n\n"
                   f"```{{code-cell}} ipython3\n:tags: [{COMPUTES}]\n\n{probe}```\n\n"
                   f"```{{code-cell}} ipython3\n{probe}```\n")
    env = {**os.environ, READ_ONLY_ENV: "1", "PYTHONPATH": str(ROOT)}
    args = [str(ROOT / "uavwind/report/pages.py"), str(src), str(tmp_path / "page.ipynb"),
            "--profile", "quick", "--jobs", "1", "--execution-timeout", "60", "--cwd",
            str(tmp_path)]
    loaded = tmp_path / "loaded.json"
    # the script as the Makefile runs it, then the modules its process holds
    driver = (f"import json, runpy, sys\nsys.argv = {args!r}\ntry:\n"
              f"    runpy.run_path(sys.argv[0], run_name='__main__')\nfinally:\n"
              f"    json.dump(sorted(k for k, v in sys.modules.items() if v is not None), "
              f"open({str(loaded)!r}, 'w'))\n")
    out = subprocess.run([sys.executable, "-c", driver], capture_output=True, text=True,
                         env=env, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    tops = {m.split(".")[0] for m in json.loads(loaded.read_text())}
    assert {"papermill", "jupytext", "nbformat"} <= tops
    assert not tops & {"uavwind", "jupyter_server", "pyarrow", "pandas"}
    loaded.unlink()
    nb = nbformat.read(tmp_path / "page.ipynb", as_version=4)
    shown = [c for c in nb.cells if c.cell_type == "code"
             and "remove-cell" not in c.metadata.get("tags", [])]
    assert [c.outputs[0]["text"] for c in shown] == ["None\n", "'1'\n"]
    assert [p.name for p in tmp_path.iterdir()] in (["page.md", "page.ipynb"],
                                                    ["page.ipynb", "page.md"])


def test_every_long_build_step_has_a_timeout():
    make = (ROOT / "Makefile").read_text()
    code = [ln for ln in make.replace("\\\n", " ").splitlines() if not ln.lstrip().startswith("#")]
    # a variable holding a step (PIP_INSTALL := ... pip install ...) stands for it where used
    defs = {m.group(1): ln for ln in code if (m := re.match(r"([A-Z_]+)\s*:?=", ln))}
    runs = [ln for ln in code if ln not in defs.values()]
    for step in ("pip install", "-m uavwind.warmup", "-m uavwind run all", "uavwind/report/pages.py",
                 "jupyter-book build", "benchmarks/bench.py"):
        names = [step] + [f"$({n})" for n, ln in defs.items() if step in ln]
        lines = [ln for ln in runs if any(n in ln for n in names)]
        assert lines and all("$(TIMEOUT)" in ln for ln in lines), step
    assert "--execution-timeout $(CELL_TIMEOUT)" in make


def test_a_missing_numba_cache_is_warmed_before_the_tests_and_the_book(tmp_path):
    """numba's cache lives in the sources' __pycache__, which `make clean` and a fresh clone
    beside a built venv lack: the warmup's stamp is kept there, and `make test`, `make check`
    and `make results` (so `make book`) run the warmup first when it is missing (a dry run,
    the venv taken as built), and not when it is there."""
    make = (ROOT / "Makefile").read_text()
    warm = re.search(r"^WARM\s*:=\s*(\S+)", make, flags=re.M).group(1)
    assert warm.startswith("uavwind/__pycache__/")  # where `make clean` removes it
    assert "-name __pycache__" in re.search(r"^clean:.*\n((?:\t.*\n)+)", make,
                                            flags=re.M).group(1)
    missing = tmp_path / "warm.done"
    for target, step in (("test", "pytest"), ("check", "pytest"),
                         ("results", "-m uavwind run all")):
        def dry(stamp):
            out = subprocess.run(["make", "-n", "-C", str(ROOT), "-o", ".venv/.installed",
                                  target, f"WARM={stamp}"], capture_output=True, text=True,
                                 check=True).stdout.splitlines()
            return ([i for i, ln in enumerate(out) if "-m uavwind.warmup" in ln],
                    [i for i, ln in enumerate(out) if step in ln])
        warmup, runs = dry(missing)
        assert warmup and runs and warmup[0] < runs[0], target
        missing.touch()
        assert dry(missing)[0] == [], target
        missing.unlink()


def _page_command(*assignments, parallel=None):
    """The command ``make`` runs for one page (a dry run, ``-n``, with the fill taken as
    made), with ``assignments`` such as ``BOOK_JOBS=1`` on the command line and
    UAVWIND_SOFTDTW_PARALLEL set to ``parallel`` in make's environment (None: unset)."""
    env = {k: v for k, v in os.environ.items() if k != "UAVWIND_SOFTDTW_PARALLEL"}
    if parallel is not None:
        env["UAVWIND_SOFTDTW_PARALLEL"] = parallel
    out = subprocess.run(["make", "-n", "-C", str(ROOT), "-o", "results", "-o", ".venv/.installed",
                          "-W", "notebooks/claims.md", "book/generated/claims.ipynb",
                          *assignments], capture_output=True, text=True, env=env, check=True)
    (line,) = [ln for ln in out.stdout.splitlines() if "uavwind/report/pages.py" in ln]
    return line


def test_pages_side_by_side_run_their_kernels_serially_unless_asked():
    """Pages run BOOK_JOBS at a time: each page's soft-DTW kernels run serially then (a
    thread waiting for a core another page holds spins), threaded when pages run one at a
    time, and as the caller's UAVWIND_SOFTDTW_PARALLEL says when it is set."""
    assert "UAVWIND_SOFTDTW_PARALLEL=0 " in _page_command("BOOK_JOBS=2")
    assert "UAVWIND_SOFTDTW_PARALLEL" not in _page_command("BOOK_JOBS=1")
    assert "UAVWIND_SOFTDTW_PARALLEL=1 " in _page_command("BOOK_JOBS=2", parallel="1")


def test_a_page_that_would_compute_fails_naming_what(tmp_path, monkeypatch):
    """Pages run with UAVWIND_PAGES_READ_ONLY=1 (the Makefile sets it for the pages): a
    result missing from the cache is an error naming it, not a silent computation."""
    import uavwind as uw
    from uavwind.core.io import READ_ONLY_ENV
    from uavwind.study import run_experiment

    assert f"{READ_ONLY_ENV}=1 " in _page_command()
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    with pytest.raises(RuntimeError, match="a page tried to compute the cache entry loops/"):
        run_experiment("exp5", profile="quick", cases=[0], results=tmp_path, n_jobs=1,
                       progress=False)
    monkeypatch.setenv(READ_ONLY_ENV, "0")
    df = run_experiment("exp5", profile="quick", cases=[0], results=tmp_path, n_jobs=1,
                        progress=False)
    monkeypatch.setenv(READ_ONLY_ENV, "1")  # now cached: read, never computed
    again = run_experiment("exp5", profile="quick", cases=[0], results=tmp_path, n_jobs=1,
                           progress=False)
    assert again["score"].tolist() == df["score"].tolist()
    from uavwind.analysis.filters import filter_comparison
    s = uw.make_setting("light constant", "strong constant", 2, uav=uw.Multirotor())
    with pytest.raises(RuntimeError, match="the filter comparison"):
        filter_comparison(s, n_flights=1, results=tmp_path)
    # a page's own small run (an exercise's loops, a closed-loop episode) is refused too:
    # the fill runs them (uavwind.analysis.page_analyses) and the page shows their code and result
    with pytest.raises(RuntimeError, match=r"a clustering loop \(score_loop\)"):
        uw.random_search(s, n_loops=1, seed=0, n_jobs=1, progress=False)
    from uavwind.method.closed_loop import ClosedLoop, run_episodes
    with pytest.raises(RuntimeError, match=r"closed-loop episodes"):
        run_episodes(ClosedLoop(setting=uw.make_setting("light constant", "strong constant", 2)),
                     "greedy", 0, 1)
    from uavwind.analysis import page_analyses
    with pytest.raises(RuntimeError, match="the analysis model_example"):
        page_analyses.model_example(results=tmp_path)


def test_only_an_exercise_computes_cell_may_compute_on_a_read_only_page(tmp_path, monkeypatch):
    """A cell tagged exercise-computes runs with the read-only flag lifted, and the cells
    after it run read-only again; the hidden cells around it are not shown."""
    import nbformat

    from uavwind.core.io import READ_ONLY_ENV
    from uavwind.report.pages import COMPUTES, run_page

    monkeypatch.setenv(READ_ONLY_ENV, "1")
    src = tmp_path / "page.md"
    probe = "import os\nprint(repr(os.environ.get('%s')))\n" % READ_ONLY_ENV
    src.write_text("---\njupytext:\n  text_representation:\n    extension: .md\n"
                   "    format_name: myst\n---\n\n# A page\n\n"
                   f"```{{code-cell}} ipython3\n{probe}```\n\n"
                   f"```{{code-cell}} ipython3\n:tags: [{COMPUTES}]\n\n{probe}```\n\n"
                   f"```{{code-cell}} ipython3\n{probe}```\n")
    nb = nbformat.read(run_page(src, tmp_path / "page.ipynb", "quick", 1, execution_timeout=60,
                                cwd=tmp_path), as_version=4)
    shown = [c for c in nb.cells if c.cell_type == "code"
             and "remove-cell" not in c.metadata.get("tags", [])]
    assert [c.outputs[0]["text"] for c in shown] == ["'1'\n", "None\n", "'1'\n"]


def test_a_page_that_reads_the_flights_reruns_when_they_arrive(tmp_path):
    """Make tracks files, not variables: the pages that read Neural-Fly's flights depend on a
    stamp of ``$UAVWIND_NEURALFLY`` (the folder and its listing), rewritten only when that
    changes, so a page built without the data is out of date once they are there; a page that
    does not read them does not depend on it."""
    book = tmp_path / "book"
    gen = book / "generated"
    gen.mkdir(parents=True)
    data = tmp_path / "flights"
    data.mkdir()
    (data / "custom_figure8_A_nowind.csv").write_text("t\n0\n")
    env = {k: v for k, v in os.environ.items() if k != "UAVWIND_NEURALFLY"}
    stamp = gen / ".neuralfly"

    def make(*targets, **extra):
        return subprocess.run(["make", "-C", str(ROOT),
                               "--no-print-directory", "-o", "results", "-o", ".venv/.installed",
                               f"BOOK={book}", "PROFILE=quick", *targets],
                              env={**env, **extra}, capture_output=True, text=True, check=True)

    make(str(stamp), str(gen / ".profile"))
    assert stamp.read_text().startswith("folder: \n")
    before = stamp.stat().st_mtime_ns
    make(str(stamp))
    assert stamp.stat().st_mtime_ns == before  # unchanged: not rewritten
    time.sleep(1.1)  # a rewritten stamp gets a new time on any file system's clock
    make(str(stamp), UAVWIND_NEURALFLY=str(data))
    assert stamp.stat().st_mtime_ns != before and "custom_figure8_A_nowind.csv" in stamp.read_text()
    # Make's own database: which pages have the stamp among what they are made from
    db = subprocess.run(["make", "-pq", "-C", str(ROOT), "--no-print-directory", f"BOOK={book}",
                         "help"], env=env, capture_output=True, text=True).stdout
    needs = {line.split(":")[0].rsplit("/", 1)[-1] for line in db.splitlines()
             if line.startswith(str(gen)) and ".ipynb:" in line and ".neuralfly" in line}
    assert needs == {"exp13_real_flights.ipynb", "exp14_flyable.ipynb"}


def test_the_longest_modules_start_first_and_the_rest_keep_their_order(monkeypatch):
    """xdist starts the units of work in collection order: the longest named ones first, in
    the order named, each keeping its tests' order; the others after them as collected."""
    from types import SimpleNamespace

    import conftest

    named = conftest.LONGEST_FIRST  # each a module of the suite, or the dask tests' group
    assert all(n == "dask" or (ROOT / n).is_file() for n in named), named
    monkeypatch.setattr(conftest, "LONGEST_FIRST", ("dask", "tests/test_b.py"))
    items = [SimpleNamespace(nodeid=f"tests/test_{m}.py::t{i}", group=g)
             for m, i, g in (("a", 0, None), ("b", 0, None), ("a", 1, None), ("c", 0, "dask"),
                             ("b", 1, None), ("d", 0, None), ("c", 1, "dask"))]
    conftest._longest_first(items, lambda i: i.group or i.nodeid.split("::")[0])
    assert [i.nodeid.split("tests/test_")[1] for i in items] == [
        "c.py::t0", "c.py::t1", "b.py::t0", "b.py::t1", "a.py::t0", "a.py::t1", "d.py::t0"]


def test_each_test_reaches_xdist_with_its_group():
    """Under --dist loadgroup the scheduler reads a test's unit of work from the '@group'
    suffix of its node id (pytest-xdist's, which pytest 9 drops: conftest appends it): a
    module's tests are one unit, the dask tests another; a suffix already there is kept, and
    without loadgroup nothing changes."""
    from types import SimpleNamespace

    import conftest
    NodeId = pytest.importorskip("_pytest.nodeid").NodeId
    from xdist.scheduler.loadgroup import LoadGroupScheduling

    class Item:
        def __init__(self, nodeid, fixtures=()):
            self._id, self.fixturenames = NodeId.parse(nodeid), fixtures

        nodeid = property(lambda self: str(self._id))

    def items():
        return [Item("tests/test_a.py::t[x@y]"), Item("tests/test_a.py::u"),
                Item("tests/test_a.py::v", ("client", "dask_client")),
                Item("tests/test_b.py::w@mine")]
    got = items()
    conftest._name_the_groups(SimpleNamespace(option=SimpleNamespace(loadgroup=True)), got)
    scopes = [LoadGroupScheduling._split_scope(None, i.nodeid) for i in got]
    assert scopes == ["tests/test_a.py", "tests/test_a.py", "dask", "mine"]
    plain = items()
    conftest._name_the_groups(SimpleNamespace(option=SimpleNamespace(loadgroup=False)), plain)
    assert [i.nodeid for i in plain] == [i.nodeid for i in items()]


def test_the_suite_says_where_its_time_went(tmp_path, monkeypatch):
    """make test's summary adds up each module's test time (largest first) and the background
    book's fill CPU by experiment, from the fill's --times record."""
    from types import SimpleNamespace

    import conftest

    reports = [SimpleNamespace(nodeid=f"tests/test_{m}.py::t{i}", when=w, duration=d)
               for m, i, w, d in (("a", 0, "call", 2.0), ("a", 1, "setup", 0.5),
                                  ("b", 0, "call", 9.0), ("b", 0, "teardown", 1.0))]
    lines = conftest._time_by_module({"passed": reports})
    assert lines[0].startswith("test time by module (wall s, 12 s over 2 modules")
    assert [line.split()[1] for line in lines[1:]] == ["tests/test_b.py", "tests/test_a.py"]
    assert [float(line.split()[0]) for line in lines[1:]] == [10.0, 2.5]
    (tmp_path / "times.json").write_text(json.dumps({"entries": [
        {"experiment": "exp2", "cpu_seconds": 1.5}, {"experiment": "exp11", "cpu_seconds": 4.0},
        {"experiment": "exp2", "cpu_seconds": 1.0}]}))
    monkeypatch.setattr(conftest, "_book_build", {"tmp": tmp_path})
    fill = conftest._fill_by_experiment()
    assert fill[0] == "quick book's fill: 6 CPU-s, by experiment:"
    assert [line.split() for line in fill[1:]] == [["4.0", "exp11"], ["2.5", "exp2"]]
    (tmp_path / "times.json").write_text("{not json")
    assert conftest._fill_by_experiment() == []  # a half-written record: nothing, no error
