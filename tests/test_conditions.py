"""The paper's conditions: Table 2, Table 3."""
import numpy as np

import uavwind as uw


def test_table2():
    t = uw.scenario_table()
    assert len(t) == 7
    assert t.loc[7].tolist() == ["light constant", "strong turbulence"]
    assert t.loc[5].tolist() == ["light shear", "strong shear"]


def test_table3_verbatim(worked_example):
    s = worked_example
    assert s.group_a.kind == "shear" and s.group_b.kind == "constant"
    assert np.allclose(np.array(s.group_a.values), [[2.1 + 0.1 * i, 10.1 + 0.1 * i, 0] for i in range(5)])
    assert np.allclose(np.array(s.group_b.values), [[1.1 + 0.1 * i, 1.1 + 0.1 * i, 0] for i in range(5)])
    assert s.groups.tolist() == [0] * 5 + [1] * 5
    frame = s.to_frame()
    assert frame.shape == (5, 6) and "x axis (m/s)" in frame["strong shear"].columns
    assert "strong shear" in str(s.group_a)
