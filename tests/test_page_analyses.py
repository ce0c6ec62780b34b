"""The page analyses: registered where they are defined, found by the fill and by the pages
under the same cache keys as before they moved out of ``uavwind.analysis.memo``."""
import ast
import pickle
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from uavwind.analysis import memo, page_analyses
from uavwind.core.store import make_key
from uavwind.study import registry
from uavwind.study.registry import ANALYSES, Analysis, computes

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.md"))

#: The fill's page tasks in the order they had as a hand-kept dict in memo.py (Exp 12's
#: summaries were "exp12" until they joined the one registry, where that is the experiment).
ORDER = ["claims", "inference", "exp12_summaries", "exp10_saturation_split",
         "exp10_drift_offsets", "exp10_zero_thrust_sensitivity", "exp12_inferred_exercise",
         "model_example"]


def _page_analyses():
    return [a for a in ANALYSES.values() if a.fill.__module__ == page_analyses.__name__]


def test_every_page_analysis_is_registered_once_in_the_order_it_is_defined():
    tasks = _page_analyses()
    names = [a.id for a in tasks]
    assert names == ORDER
    for name in names:
        assert isinstance(ANALYSES[name], Analysis) and registry.REGISTRY[name] is ANALYSES[name]
    reads = {a.id: a.reads for a in tasks}
    assert reads["inference"] == ("fit_layout",) and reads["exp12_inferred_exercise"] == ("exp12",)
    assert reads["exp10_saturation_split"] == () and reads["model_example"] == ()
    # the fill sends them to worker processes
    assert [a.id for a in pickle.loads(pickle.dumps(tasks))] == names


def test_an_id_registered_twice_is_refused_naming_it(monkeypatch):
    before = dict(registry.REGISTRY)
    with pytest.raises(ValueError, match=r"'claims' is registered twice: by "
                                         r"uavwind\.analysis\.page_analyses\._fill_claims"):
        computes("claims")(lambda profile, seed, results: None)
    with pytest.raises(ValueError, match=r"'exp1' is registered twice: by the experiments"):
        computes("exp1")(lambda results: None)  # an analysis cannot take an experiment's id
    assert registry.REGISTRY == before  # the refused one left nothing behind

    monkeypatch.setattr(registry, "REGISTRY", dict(before))

    def twice(profile, seed, results):
        pass
    assert computes("twice")(twice) is twice  # returned unchanged
    with pytest.raises(ValueError, match=r"'twice' is registered twice: by .*twice and by .*twice"):
        computes("twice")(twice)
    assert list(ANALYSES)[-1] == "twice" and "twice" not in registry.EXPERIMENTS


def test_computes_checks_what_it_registers(monkeypatch):
    monkeypatch.setattr(registry, "REGISTRY", dict(registry.EXPERIMENTS))
    with pytest.raises(ValueError, match=r"'x' reads experiments not in the registry: \['nope'\]"):
        computes("x", reads=("exp1", "nope"))
    with pytest.raises(ValueError, match="identifier"):
        computes("not a name")
    with pytest.raises(TypeError, match="must take 'results'"):
        computes("x")(lambda profile, seed: None)
    with pytest.raises(TypeError, match="must take 'results'"):
        computes("x")(lambda seed, n_loops, results=None: None)
    with pytest.raises(TypeError, match="Experiment and Analysis"):
        registry.register("x")
    assert dict(ANALYSES) == {}
    # an analysis taking some of (profile, seed, results, n_jobs) is called with those it names
    got = []
    computes("x", reads=("exp1",))(lambda seed, results=None, n=3: got.append((seed, results, n)))
    task = ANALYSES["x"]
    assert task.reads == ("exp1",) and task.takes == ("seed", "results")
    task.run("quick", 7, "folder", n_jobs=2)
    assert got == [(7, "folder", 3)]


def _table(k):
    return pd.DataFrame({"a": np.arange(3) + k, "b": [0.5, 1.5, 2.5]})


def _keys(monkeypatch):
    """The file names (name-key) each analysis asks the store for, with fixed inputs."""
    seen = []

    def capture(kind, key_params, compute, folder=None, version=None, name=None, **kw):
        seen.append(f"{kind}/{name}-{make_key(kind, key_params, version)}")
        return pd.DataFrame()
    monkeypatch.setattr(memo, "get_or_compute", capture)
    pa = page_analyses
    pa.claims_verdicts({"inferred": {"exp1": _table(0)}, "halves": {"exp1": _table(1)}})
    pa.c1_vehicles(_table(2))
    pa.layout_fits(_table(3))
    pa.scale_invariance_summary("paper", 11)
    pa.scale_invariance_summary("quick", 11)
    pa.exp12_summaries(_table(4))
    pa.saturation_split(11)
    pa.drift_offsets(11)
    pa.zero_thrust_sensitivity(11)
    pa.model_example()
    return seen


@pytest.mark.parametrize("setting, value, moved", [
    ("DRIFT_WIND", (3.0, -1.0, 0.0), {"exp10_drift_offsets"}),
    ("SENSITIVITY_WIND", (0.5, 0.25, 0.0), {"exp10_zero_thrust_sensitivity"}),
    ("SENSITIVITY_DELTA", 1e-8, {"exp10_zero_thrust_sensitivity"}),
    ("SATURATION_LOOPS", 3, {"exp10_saturation_split"}),
    ("SCALE_FACTOR", 2.0, {"inference_scale_invariance"}),
    ("SCALE_ENVIRONMENTS", 3, {"inference_scale_invariance"}),
])
def test_a_setting_of_an_analysis_is_part_of_its_cache_key(monkeypatch, setting, value, moved):
    """Changing a page analysis' setting gives its entry a new key (a cache filled under the
    old setting is not read back as the new one's), and only its own."""
    before = _keys(monkeypatch)
    monkeypatch.setattr(page_analyses, setting, value)
    after = _keys(monkeypatch)
    changed = {b.split("/")[1].rsplit("-", 1)[0] for b, a in zip(before, after) if a != b}
    assert changed == moved


def test_every_name_a_page_asks_of_page_analyses_exists():
    used = {}
    for nb in NOTEBOOKS:
        text = nb.read_text()
        assert "memo as page_analyses" not in text, nb.name
        for name in re.findall(r"\bpage_analyses\.(\w+)", text):
            used.setdefault(name, nb.name)
    assert {"claims_inputs", "saturation_split", "model_example", "SATURATION_LOOPS"} <= set(used)
    missing = {n: page for n, page in used.items() if not hasattr(page_analyses, n)}
    assert not missing, missing


def test_exp12_exercise_cell_is_the_call_the_fill_makes(monkeypatch):
    """Exp 12's first exercise shows its solution as code that reads the fill's entries: the
    page's literal arguments are the ones exp12_inferred_exercise runs."""
    got = {}
    monkeypatch.setattr(page_analyses, "run_experiment",
                        lambda exp_id, **kw: got.update(exp_id=exp_id, **kw))
    page_analyses.exp12_inferred_exercise(5)
    text = (ROOT / "notebooks" / "exp12_closed_loop.md").read_text()
    calls = [ast.parse(m).body[0].value
             for m in re.findall(r"run_experiment\(\"exp12\",[^)]*\)", text) if "cases=" in m]
    assert len(calls) == 1
    page = {k.arg: ast.literal_eval(k.value) for k in calls[0].keywords
            if isinstance(k.value, (ast.Constant, ast.List))}
    assert ast.literal_eval(calls[0].args[0]) == got["exp_id"] == "exp12"
    assert page == {k: got[k] for k in ("profile", "reading", "cases")}


def test_a_derived_table_is_recomputed_when_its_code_changes(tmp_path, monkeypatch):
    """The claims page once read verdicts cached under an older claims module (their rules
    printed as they were); a derived table is keyed by its code's source too."""
    import importlib.util
    import sys

    import pandas as pd

    from uavwind.analysis.memo import code_digest, derived

    src = tmp_path / "rule_mod.py"
    src.write_text("LIMIT = 1\n")
    spec = importlib.util.spec_from_file_location("rule_mod", src)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    monkeypatch.setitem(sys.modules, "rule_mod", mod)
    inputs = {"t": pd.DataFrame({"x": [1.0, 2.0]})}
    calls = []

    def compute():
        calls.append(1)
        return pd.DataFrame({"n": [len(calls)]})
    first = derived("rule_table", compute, inputs, results=tmp_path / "r", code=(mod,))
    again = derived("rule_table", compute, inputs, results=tmp_path / "r", code=(mod,))
    assert len(calls) == 1 and again.equals(first)
    before = code_digest((mod,))
    src.write_text("LIMIT = 2\n")  # the rule changed, the inputs did not
    assert code_digest((mod,)) != before
    derived("rule_table", compute, inputs, results=tmp_path / "r", code=(mod,))
    assert len(calls) == 2
    with pytest.raises(TypeError, match="code must hold modules"):
        derived("rule_table", compute, inputs, results=tmp_path / "r", code=("claims",))


def test_two_analyses_swapped_with_mv_are_refused_and_recomputed(tmp_path):
    """Issue 68: two `analyses/` entries swapped with `mv` returned each other's tables:
    each holds the analysis and its inputs it was computed for."""
    import os

    from uavwind.core.store import CorruptEntryWarning

    tables = {n: pd.DataFrame({"rmse": [float(n)]}) for n in (1, 2)}
    for n in (1, 2):
        memo.memo("toy", {"n": n}, lambda n=n: tables[n], tmp_path)
    keys = [make_key("analyses", {"name": "toy", "params": {"n": n}}, memo.MEMO_VERSION)
            for n in (1, 2)]
    p1, p2 = (tmp_path / "analyses" / f"toy-{k}.parquet" for k in keys)
    os.replace(p1, tmp_path / "swap")
    os.replace(p2, p1)
    os.replace(tmp_path / "swap", p2)
    for n in (1, 2):
        with pytest.warns(CorruptEntryWarning, match="analysis toy.*another entry"):
            assert memo.memo("toy", {"n": n}, lambda n=n: tables[n], tmp_path).equals(tables[n])
    def rules(df):
        return "" if df["rmse"].between(0, 100).all() else "rmse outside [0, 100]"
    with pytest.raises(RuntimeError, match="rmse outside"):  # a caller's range rules
        memo.memo("toy", {"n": 3}, lambda: pd.DataFrame({"rmse": [-1.0]}), tmp_path, rules)
