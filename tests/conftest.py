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
