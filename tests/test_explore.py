"""The explorer: its cached grid follows what determines it."""


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


def _stub_grid(calls):
    def explore_grid(pairs=(), n_per_group=(), layouts=(), every=3, engine=None, seed=0):
        calls.append(1)
        return {"controls": {}, "loops": {}}
    return explore_grid
