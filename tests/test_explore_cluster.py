"""spherestep.explore on real Dask clusters on loopback: threads and worker processes agree, and a worker
killed in the middle of a sweep loses no result."""

import os
import signal
import socket

import pandas as pd
import pytest
from distributed import Client, LocalCluster

from spherestep.explore import MEASURED, Grid, ResultStore, dask_client, run_sweep

pytestmark = pytest.mark.slow

# 16 designs of 0.05-1.5 s each (60- and 30-pole rotors over three O stators and a same-family I stator;
# holding torque of two states each, so the physical model runs in the workers too)
GRID = Grid(rotors=("truncated-icosahedron", "icosidodecahedron"),
            stators=("truncated-cuboctahedron", "rhombicosidodecahedron", "truncated-octahedron",
                     "rhombicuboctahedron"),
            rotor_levels=(0,), stator_levels=(0, 1), cap_half_angles_deg=(60.0,), primary_ratio_max=None, samples=500,
            torque_states=2)


def measured(store: ResultStore, points) -> pd.DataFrame:
    return store.read().set_index("key").loc[[p.key for p in points], MEASURED[1:]]


@pytest.fixture(scope="module")
def threads_table(tmp_path_factory):
    """The sweep on two threads in this process (the reference)."""
    points = GRID.points()
    store = ResultStore(tmp_path_factory.mktemp("threads") / "results")
    with dask_client(threads=True, workers=2) as client:
        summary = run_sweep(points, store, client, batch_size=5)
    assert summary.evaluated == len(points) and not summary.lost
    return measured(store, points)


def test_threads_and_worker_processes_give_identical_results(threads_table, tmp_path):
    points = GRID.points()
    store = ResultStore(tmp_path / "results")
    with dask_client(workers=2) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        assert all(addr.startswith("tcp://127.0.0.1:") for addr in client.scheduler_info()["workers"])
        pids = set(client.run(os.getpid).values())
        summary = run_sweep(points, store, client, batch_size=5)
    assert summary.evaluated == len(points) and not summary.lost
    workers = set(store.read()["worker"])
    assert workers <= {f"{socket.gethostname()}:{pid}" for pid in pids}  # computed in the worker processes
    assert os.getpid() not in pids
    assert (threads_table["status"] == "ok").sum() >= 12
    pd.testing.assert_frame_equal(measured(store, points), threads_table)


def test_a_killed_worker_loses_no_result(threads_table, tmp_path):
    points = GRID.points()
    store = ResultStore(tmp_path / "results")
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address="127.0.0.1:0")
    killed = {}
    try:
        with Client(cluster) as client:
            def kill_a_busy_worker(row):
                if killed:
                    return
                busy = {addr: len(keys) for addr, keys in client.processing().items() if keys}
                if not busy:  # between tasks: try again at the next result
                    return
                address = next(iter(busy))
                pid = client.run(os.getpid, workers=[address])[address]
                os.kill(pid, signal.SIGKILL)  # the nanny notices, restarts the worker; its tasks run again
                killed.update(address=address, pid=pid, tasks=busy[address])

            summary = run_sweep(points, store, client, batch_size=3, retries=2, on_result=kill_a_busy_worker)
            alive = set(client.run(os.getpid).values())
    finally:
        cluster.close()
    assert killed and killed["tasks"] >= 1 and killed["pid"] not in alive
    assert summary.lost == {} and summary.evaluated == len(points)
    pd.testing.assert_frame_equal(measured(store, points), threads_table)
