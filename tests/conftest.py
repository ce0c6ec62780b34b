"""Shared fixtures: small, fast settings."""
import numpy as np
import pytest

import uavwind as uw


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def worked_example():
    return uw.table3_setting()


@pytest.fixture(scope="session", autouse=True)
def compiled_kernels():
    """Compile (or load) the fast engine's numba kernels once, in this process, before
    any test starts worker processes: they then load the on-disk cache instead of each
    compiling the same kernels at the same time."""
    from uavwind.method import softdtw

    softdtw.warmup(parallel=True, every=True)
