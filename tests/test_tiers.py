"""The suite's two tiers: `make test` runs every test but the slow ones, `make check` (what CI
runs) runs them all with the quick book beside them (tests/conftest.py)."""
import ast
import re
import os
import subprocess
import sys
from pathlib import Path

import conftest

ROOT = Path(__file__).resolve().parents[1]


def _recipe(target):
    """The one command line of ``target``'s recipe in the Makefile, and the suite's command."""
    make = (ROOT / "Makefile").read_text()
    line = re.search(rf"^{target}:.*\n\t(.*)\n", make, flags=re.M).group(1)
    return line.strip(), re.search(r"^PYTEST := (.*)$", make, flags=re.M).group(1).strip()


def test_make_test_leaves_out_the_slow_tests_and_make_check_and_ci_run_them_all():
    test, pytest_cmd = _recipe("test")
    check, _ = _recipe("check")
    assert "-n $(TEST_JOBS) --dist loadgroup" in pytest_cmd and " -m " not in pytest_cmd[
        pytest_cmd.index("pytest"):]
    assert test == '$(TIMEOUT) $(TEST_TIMEOUT) $(PYTEST) -m "not slow"'
    assert check == "$(TIMEOUT) $(CHECK_TIMEOUT) $(PYTEST)"
    ci = (ROOT / ".ci" / "run").read_text()
    assert re.search(r"^make check$", ci, flags=re.M) and not re.search(r"^make test$", ci,
                                                                         flags=re.M)


def _slow(decorators):
    return any(ast.unparse(d) == "pytest.mark.slow" for d in decorators)


def test_every_module_keeps_a_test_in_make_test():
    """A module whose every test is slow would leave `make test` silently: each keeps one, so
    what it checks at scale is also checked small (the dask cluster's and the book's tests are
    slow as groups, conftest.SLOW_GROUPS, and their modules keep tests without them)."""
    whole = []
    for path in sorted((ROOT / "tests").glob("test_*.py")):
        tree = ast.parse(path.read_text())
        if any(isinstance(n, ast.Assign) and "slow" in ast.unparse(n.value)
               and any(getattr(t, "id", "") == "pytestmark" for t in n.targets)
               for n in tree.body):
            whole.append(path.name)  # a module-wide slow mark: refused below
        tests = [n for n in tree.body
                 if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")]
        fast = [n for n in tests if not _slow(n.decorator_list)
                and not {"dask_client", "client", "built_book"} & {a.arg for a in n.args.args}]
        assert fast, f"{path.name}: every test is slow, so `make test` runs none of it"
    assert not whole, f"a module-wide mark hides the tiers: {whole}"


def test_the_slow_groups_are_marked_slow_and_the_rest_keep_their_marks(tmp_path):
    """Collected with -m "not slow", the dask cluster's tests and the book's are left out and
    a plain test stays (pytest's own collection, in a child process: nothing runs)."""
    p = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p",
                        "no:cacheprovider", "-m", "not slow", "tests/test_parallel.py",
                        "tests/test_book.py", "tests/test_lockstep.py"],
                       cwd=ROOT, capture_output=True, text=True, timeout=300,
                       env={**os.environ, "UAVWIND_SKIP_BOOK": "1"})
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    ids = [line for line in p.stdout.splitlines() if "::" in line]
    assert not [i for i in ids if "test_dask_local_cluster_is_bit_identical" in i]
    assert any("test_n_jobs_is_capped_at_the_cores" in i for i in ids)
    assert not [i for i in ids if "test_book.py::test_every_experiment_page" in i]
    assert any("test_book.py::test_no_page_refers_to_a_label" in i for i in ids)
    assert [i for i in ids if "test_lockstep_loops_equal_tslearn_on_every_scenario" in i] == [
        i for i in ids if "on_every_scenario[3-inferred]" in i] != []
    assert {"dask", "book"} == set(conftest.SLOW_GROUPS)
