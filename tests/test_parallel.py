"""Scale-out: a Dask cluster through joblib gives bit-identical results."""
import os

import joblib
import pandas as pd
import pytest

import uavwind as uw
from uavwind.core.parallel import check_jobs

distributed = pytest.importorskip("dask.distributed")


def test_dask_local_cluster_is_bit_identical(dask_client):
    s = uw.make_setting("light constant", "strong turbulence", 3, dt=0.2, duration=4.0,
                       n_changes=3)
    local = uw.random_search(s, n_loops=6, seed=3, n_jobs=1, progress=False)
    dask_client.wait_for_workers(2, timeout=60)  # a worker another test killed is back
    with joblib.parallel_config(backend="dask", client=dask_client):
        remote = uw.random_search(s, n_loops=6, seed=3, progress=False)
        res = uw.cem(s, n_samples=4, n_elite=2, max_iter=2, seed=1, progress=False)
    pd.testing.assert_frame_equal(local, remote)
    ref = uw.cem(s, n_samples=4, n_elite=2, max_iter=2, seed=1, n_jobs=1, progress=False)
    pd.testing.assert_frame_equal(res.samples, ref.samples)


def test_n_jobs_is_capped_at_the_cores():
    cores = os.cpu_count()
    with pytest.warns(UserWarning, match="cores"):
        assert check_jobs(cores + 1000) == cores
    with pytest.raises(ValueError, match="n_jobs"):
        check_jobs(-cores - 1)
