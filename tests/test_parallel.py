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
    # a worker test_cluster_fill killed is back (its restart loads the package and the kernels:
    # over a minute on 2 busy cores; with the groups one unit of work, this runs after it)
    dask_client.wait_for_workers(2, timeout=300)
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


# loky's own shutdown(wait=False, kill_workers=True) of a pool that ran tasks before (as the
# session's reusable pool has) can end its manager thread with a KeyError on a task id it
# had already dropped: the thread ends either way, and the test reads only what follows
@pytest.mark.filterwarnings("ignore::pytest.PytestUnhandledThreadExceptionWarning")
@pytest.mark.parametrize("held_back", [False, True], ids=["at once", "held back"])
def test_stop_workers_kills_busy_workers_at_once_and_again_is_harmless(held_back,
                                                                        monkeypatch):
    """Two workers each in a task of ten minutes, stopped twice in a row as the fill does (its
    stop watcher, then its own clean-up): both workers are dead within seconds and the pool's
    manager thread ends, also when that thread runs only after the second call, as under
    load. (A second ``shutdown`` then used to clear the pool's kill flag: the manager thread
    waited for the tasks to finish, the workers went on, and the interpreter's exit waited on
    that thread: a `make test` beside a book build once hung so.) Neither call waits, and no
    other pool is started."""
    import threading
    import time

    from joblib.externals.loky import reusable_executor

    from uavwind.core.parallel import stop_workers

    par = joblib.Parallel(n_jobs=2)  # the executor the fill's pool uses (study/_pools.py)
    par._initialize_backend()
    executor = par._backend._workers
    for _ in range(2):
        executor.submit(time.sleep, 600)
    deadline = time.monotonic() + 60
    while len(executor._processes) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    workers = list(executor._processes.values())
    assert len(workers) == 2 and all(p.is_alive() for p in workers)
    manager, wake = executor._executor_manager_thread, executor._executor_manager_thread_wakeup
    if held_back:  # the manager thread is woken only after both calls
        monkeypatch.setattr(wake, "wakeup", lambda: None)
    calls = threading.Thread(target=lambda: (stop_workers(), stop_workers()), daemon=True)
    calls.start()  # in a thread: a call that waits fails the test instead of hanging it
    calls.join(timeout=10)
    assert not calls.is_alive(), "stop_workers waited"
    if held_back:
        type(wake).wakeup(wake)
    for p in workers:
        p.join(timeout=10)
    assert not any(p.is_alive() for p in workers)
    manager.join(timeout=10)
    assert not manager.is_alive()
    assert reusable_executor._executor is executor  # no new pool started
