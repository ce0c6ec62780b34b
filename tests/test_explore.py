"""The explorer: its cached grid follows what determines it."""
import pytest


def test_the_explorer_grid_key_follows_the_fitted_layout(tmp_path, monkeypatch):
    from uavwind.report import explore
    from uavwind.study import layouts as scenarios

    calls = []
    monkeypatch.setattr(explore, "explore_grid", _stub_grid(calls))
    kw = dict(pairs=(("light constant", "light constant"),), n_per_group=(3,), layouts=("inferred",))
    explore.cached_grid(tmp_path, **kw)
    explore.cached_grid(tmp_path, **kw)
    assert len(calls) == 1  # cached
    monkeypatch.setitem(scenarios.INFERRED_GAP_RATIOS, "light constant", 20.0)
    explore.cached_grid(tmp_path, **kw)
    assert len(calls) == 2  # a refitted layout is a new grid


def test_the_fill_makes_the_grid_and_a_page_never_does(tmp_path, monkeypatch):
    from uavwind.core.io import READ_ONLY_ENV
    from uavwind.report import explore

    calls = []
    monkeypatch.setattr(explore, "explore_grid", _stub_grid(calls))
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    with pytest.raises(RuntimeError, match="the explorer's grid"):
        explore.cached_grid(tmp_path)
    assert calls == []
    monkeypatch.delenv(READ_ONLY_ENV)
    explore.fill_grid(tmp_path)  # what `python -m uavwind run explore_grid` runs
    monkeypatch.setenv(READ_ONLY_ENV, "1")
    assert explore.cached_grid(tmp_path) == {"controls": {}, "loops": {}} and calls == [1]


@pytest.mark.parametrize("damage", ["{}", "not json", "digest kept, controls gone"])
def test_a_damaged_explorer_grid_is_moved_aside_and_recomputed_with_a_warning(
        tmp_path, monkeypatch, damage):
    """A grid replaced by ``{}`` was trusted (issue 45; then explorer_html raised
    KeyError 'controls'): moved aside, recomputed, a warning naming the file."""
    import json

    from uavwind.report import explore

    calls = []
    monkeypatch.setattr(explore, "explore_grid", _stub_grid(calls))
    grid = explore.cached_grid(tmp_path)
    (path,) = (tmp_path / "explore").glob("grid-*.json")
    if damage == "digest kept, controls gone":
        stored = json.loads(path.read_text())
        path.write_text(json.dumps({k: v for k, v in stored.items() if k != "content"}
                                   | {"content": {"loops": {}}}))
    else:
        path.write_text(damage)
    with pytest.warns(UserWarning, match=path.name):
        again = explore.cached_grid(tmp_path)
    assert again == grid and "controls" in again and len(calls) == 2
    assert path.with_name(path.name + ".corrupt").exists()


def _stub_grid(calls):
    def explore_grid(pairs=(), n_per_group=(), layouts=(), every=3, engine=None, seed=0):
        calls.append(1)
        return {"controls": {}, "loops": {}}
    return explore_grid


@pytest.mark.parametrize("kwargs, match", [({"every": -1}, "every"), ({"pairs": ()}, "pairs"),
                                           ({"n_per_group": []}, "n_per_group")])
def test_explore_grid_refuses_controls_that_would_draw_nothing_or_backwards(kwargs, match):
    from uavwind.report.explore import explore_grid
    with pytest.raises(ValueError, match=match):
        explore_grid(**kwargs)


def test_the_static_explorer_escapes_what_it_writes_into_its_script():
    import re

    from uavwind.report.explore import explorer_html
    grid = {"controls": {"pair": ['a</script><script>alert("x")</script> vs b'], "n": [3],
                         "thrust": ["t"], "layout": ["inferred"]},
            "loops": {"0|3|0|inferred": {"x": [[0.0]], "y": [[0.0]], "z": [[0.0]],
                                         "groups": [0], "score": 1.0, "correct": True}}}
    page = explorer_html(grid)
    scripts = re.findall(r"<script>(.*?)</script>", page, flags=re.S)
    assert len(scripts) == 1 and "alert" in scripts[0] and "</script>" not in scripts[0]
    with pytest.raises(ValueError, match="element_id"):
        explorer_html(grid, element_id='x" onload="alert(1)')


def test_the_grid_scores_its_loops_side_by_side_as_each_loop_alone():
    """explore_grid scores its loops together (score_loops); each cell holds what
    score_loop gives the loop alone, and the trajectory it was flown along."""
    import numpy as np

    import uavwind as uw
    from uavwind.report.explore import _grid_settings, explore_grid, explore_thrusts

    pairs, n, layouts = (("light constant", "strong shear"),), (3,), ("halves",)
    grid = explore_grid(pairs=pairs, n_per_group=n, layouts=layouts)
    (key, s), = _grid_settings(pairs, n, layouts)
    thrusts = list(explore_thrusts().values())
    assert len(grid["loops"]) == len(thrusts)
    for j, thrust in enumerate(thrusts):
        traj = s.simulate(thrust, seed=0)
        alone = uw.score_loop(traj, s.groups)
        cell = grid["loops"][f"0|3|{j}|halves"]
        assert (cell["score"], cell["correct"]) == (round(alone.score, 2), alone.correct)
        assert cell["x"] == np.round(traj[:, ::3, 0], 2).tolist()


def _one_loop_grid(calls):
    def explore_grid(pairs=(), n_per_group=(), layouts=(), every=3, engine=None, seed=0):
        calls.append(every)
        return {"controls": {"pair": ["a vs b"], "n": [3], "thrust": ["t"],
                             "layout": ["inferred"]},
                "loops": {"0|3|0|inferred": {"x": [[0.0, 1.0], [0.0, 2.0]],
                                             "y": [[0.0, 0.0], [0.0, 0.0]],
                                             "z": [[10.0, 10.0], [10.0, 10.0]],
                                             "groups": [0, 1], "score": 2.69 * every,
                                             "correct": True}}}
    return explore_grid


@pytest.mark.parametrize("forgery, why", [
    ("swapped", "another entry"), ("score 999", "score outside"),
    ("misgrouped with a score", "misgrouped"), ("a loop missing", "one for each choice"),
    ("groups of 2", "groups"), ("a path too short", "paths")])
def test_a_swapped_or_out_of_range_grid_is_refused_and_recomputed(tmp_path, monkeypatch,
                                                                   forgery, why):
    """Issue 68: two explorer grids swapped were trusted, and a grid with score 999 (its
    checksum recomputed) passed its own rules."""
    import json
    import os

    from uavwind.core import store
    from uavwind.report import explore

    calls = []
    monkeypatch.setattr(explore, "explore_grid", _one_loop_grid(calls))
    grid = explore.cached_grid(tmp_path, every=1)
    (path,) = (tmp_path / "explore").glob("grid-*.json")
    if forgery == "swapped":
        explore.cached_grid(tmp_path, every=2)
        (other,) = set((tmp_path / "explore").glob("grid-*.json")) - {path}
        os.replace(other, path)
    else:
        doc = json.loads(path.read_text())
        loops = doc["content"]["loops"]
        loop = loops["0|3|0|inferred"]
        if forgery == "score 999":
            loop["score"] = 999
        elif forgery == "misgrouped with a score":
            loop["correct"] = False
        elif forgery == "a loop missing":
            loops["0|3|1|inferred"] = loops.pop("0|3|0|inferred")
        elif forgery == "groups of 2":
            loop["groups"] = [0, 2]
        else:
            loop["x"][1] = [0.0]
        store.atomic_write(path, doc["content"], key=doc["uavwind.key"])  # checksum right
    n = len(calls)
    with pytest.warns(store.CorruptEntryWarning, match=f"{path.name}.*{why}"):
        again = explore.cached_grid(tmp_path, every=1)
    assert again == grid and calls[n:] == [1]
