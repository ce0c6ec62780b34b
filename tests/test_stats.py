"""The one summary and confidence interval."""
import numpy as np
import pytest

from uavwind.analysis.claims import bootstrap_ci, paired_difference


def test_bootstrap_and_paired_difference():
    rng = np.random.default_rng(0)
    x = rng.normal(5, 1, size=400)
    est, lo, hi = bootstrap_ci(x)
    assert lo < 5 < hi and hi - lo < 0.3 and est == pytest.approx(x.mean())
    y = x - 1 + rng.normal(0, 0.01, size=400)
    d = paired_difference(x, y)
    assert d[1] > 0.99 and d[2] < 1.01  # pairing removes the shared noise
