"""Helpers the test modules share (plain functions; the fixtures are in conftest.py)."""


def _py(v):
    v = v.tolist() if hasattr(v, "tolist") else v
    return [_py(x) for x in v] if isinstance(v, (list, tuple)) else v


def exact_cells(df):
    """Every cell as the repr of its Python value (a list read back from Parquet is an
    array): equal texts mean equal doubles."""
    return {c: [repr(_py(v)) for v in df[c]] for c in df.columns}


def record_fills(monkeypatch, analyses=None):
    """Replace the work of fill_cache by a record of the entries it hands out, in order (and
    of the analyses it runs in this process, appended to ``analyses`` when given)."""
    from uavwind.study import fill

    order = []

    def record(entry, pin=True, n_jobs=1):
        order.append(entry)
        return entry.path, entry.n_rows, False, 0.5

    def record_analysis(analysis, profile, seed, results, pin=True, n_jobs=1):
        if analyses is not None:
            analyses.append(analysis.id)
        return None, 0.5
    monkeypatch.setattr(fill, "_fill_one", record)
    monkeypatch.setattr(fill, "_run_analysis", record_analysis)
    return order
