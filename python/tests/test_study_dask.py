"""isowrench.study on a Dask LocalCluster of worker processes: the same bits as the local run,
also when a worker is killed mid-run (issue 30). A few seconds: one cluster for the module."""

import os
import signal

import numpy as np
import pytest

import isowrench
import isowrench.study as study

from conftest import URDF

distributed = pytest.importorskip("distributed")

INPUTS = ["transducer_stiffness:x=lognormal:0.5", "angle:hip_rz=normal:2", "angle:knee_rz=normal:2"]


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address="127.0.0.1:0", silence_logs=50)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def rat():
    return isowrench.load(str(URDF / "rat_hindlimb_5dof.urdf"))


def without_seconds(result):
    return {k: v for k, v in result.items() if k != "seconds"}


def postures(rat, count):
    Q = np.tile(rat.default_posture, (count, 1))
    Q[:, 3] += np.linspace(-0.5, 0.5, count)
    return Q


def test_local_cluster_with_processes_equals_the_local_run(rat, client):
    local = study.uncertainty(rat, "GP", inputs=INPUTS, samples=3 * 2048 + 7, threads=2)
    on_dask = study.uncertainty(rat, "GP", inputs=INPUTS, samples=3 * 2048 + 7, client=client,
                                blocks_per_task=1)
    assert without_seconds(on_dask) == without_seconds(local)
    Q = postures(rat, 999)
    assert np.array_equal(study.sweep(rat, "GP", Q, client=client, rows_per_task=200),
                          rat.wrench_batch("GP", Q, threads=1))


def test_a_killed_worker_does_not_change_the_result(rat, client):
    Q = postures(rat, 6)
    samples = 12 * 2048
    local = study.uncertainty(rat, "GP", inputs=INPUTS, postures=Q, samples=samples, threads=2)
    before = client.run(os.getpid)
    killed = []

    def kill_one_worker(done, total):
        # After the first task comes back, with the others running or queued on both workers.
        if done == 1 and not killed:
            pid = sorted(before.values())[0]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    on_dask = study.uncertainty(rat, "GP", inputs=INPUTS, postures=Q, samples=samples,
                                client=client, blocks_per_task=1, progress=kill_one_worker)
    assert killed, "no worker was killed"
    client.wait_for_workers(2, timeout=30)
    assert killed[0] not in client.run(os.getpid).values()  # the nanny started a new process
    assert without_seconds(on_dask) == without_seconds(local)
