"""The suite's two tiers: `make test` runs every test but the slow ones, `make check` (what CI
runs) runs them all with the quick book beside them (tests/conftest.py)."""
import ast
import re
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


def test_the_slow_groups_are_marked_slow_and_the_rest_keep_their_marks():
    """The dask cluster's tests and the book's are marked slow as they are collected
    (conftest.pytest_itemcollected); a plain test is not; of the engine's check against
    tslearn on every paper scenario, `make test` keeps scenario 3."""
    from types import SimpleNamespace

    import test_lockstep

    def collected(nodeid, fixtures):
        marks = []
        item = SimpleNamespace(nodeid=nodeid, fixturenames=fixtures,
                               add_marker=lambda m: marks.append(m.name))
        conftest.pytest_itemcollected(item)
        return marks

    assert collected("tests/test_parallel.py::t", ["dask_client"]) == ["xdist_group", "slow"]
    assert collected("tests/test_book.py::t", ["built_book", "tmp_path"]) == ["xdist_group",
                                                                              "slow"]
    assert collected("tests/test_book.py::t", ["tmp_path"]) == ["xdist_group"]
    assert {"dask", "book"} == set(conftest.SLOW_GROUPS)
    every_scenario = test_lockstep.test_lockstep_loops_equal_tslearn_on_every_scenario
    (params,) = [m.args[1] for m in every_scenario.pytestmark if m.name == "parametrize"]
    fast = [p.values for p in params if not [m for m in p.marks if m.name == "slow"]]
    assert fast == [(3, "inferred")] and len(params) == len(test_lockstep.LOOPS)
