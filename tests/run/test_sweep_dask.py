"""model.sweep on a Dask cluster: the library shipped as bytes, chunks of a worker that dies run
again elsewhere, every member arrives once and in order, equal to the local sweep."""
from __future__ import annotations

import os
import signal

import numpy as np
import pytest

from lagdsl.run import dask_sweep
from lagdsl.run import sweep as batch
from lagdsl.scene import Overrides
from tests.conftest import library_model

pytestmark = pytest.mark.slow      # a local cluster of two processes, workers killed and restarted


@pytest.fixture(scope="module")
def client():
    distributed = pytest.importorskip("dask.distributed")      # here, not at collection: the default run has no use for it
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as cluster, distributed.Client(cluster) as client:
        yield client


def test_a_sweep_on_dask_equals_the_local_one_even_when_a_worker_dies(client):
    model = library_model("double_pendulum")
    count = 160
    rng = np.random.default_rng(11)
    values = {"theta1.start": rng.uniform(-3, 3, count), "theta2.start": rng.uniform(-3, 3, count)}
    grid = dict(stop=3.0, interval=0.5)
    local = model.sweep("chaos", set=values, **grid)
    assert np.array_equal(model.sweep("chaos", set=values, client=client, **grid).values, local.values)

    members = batch.member_inputs(lambda o: model.plan("chaos", o), Overrides(stop=3.0, interval=0.5), values)
    program = model._program("chaos", members.plan, "c", Overrides())
    pids = client.run(os.getpid)
    killed = []

    def kill_one_worker(finished: int) -> None:
        if not killed and finished < count:      # the first chunk is back, the others are in flight
            victim = sorted(pids.values())[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    values_dask, summaries, chunks = dask_sweep.run_dask(client, program.library_bytes(), program.source.text,
                                                         program.source.suggested_name, batch.batch_layout(members.plan),
                                                         members.parameters, members.initial, kill_one_worker)
    assert killed and chunks > 2
    assert values_dask.shape == local.values.shape and np.array_equal(values_dask, local.values)
    assert list(summaries["status"]) == [0] * count


def test_every_member_arrives_when_both_workers_die_together(client):
    """The library is the result of a task that holds its bytes: when both workers die, the
    scheduler computes it again, the lost chunks run again, and the finished ones are kept."""
    model = library_model("double_pendulum")
    count = 120
    rng = np.random.default_rng(12)
    values = {"theta1.start": rng.uniform(-3, 3, count), "theta2.start": rng.uniform(-3, 3, count)}
    grid = dict(stop=3.0, interval=0.5)
    local = model.sweep("chaos", set=values, **grid)
    members = batch.member_inputs(lambda o: model.plan("chaos", o), Overrides(**grid), values)
    program = model._program("chaos", members.plan, "c", Overrides())
    client.wait_for_workers(2)          # the test before may have killed one
    pids = client.run(os.getpid)
    killed = []

    def kill_every_worker(finished: int) -> None:
        if not killed and finished < count:
            for victim in pids.values():
                os.kill(victim, signal.SIGKILL)
                killed.append(victim)

    values_dask, summaries, _ = dask_sweep.run_dask(client, program.library_bytes(), program.source.text,
                                                    program.source.suggested_name, batch.batch_layout(members.plan),
                                                    members.parameters, members.initial, kill_every_worker)
    assert len(killed) == 2
    assert np.array_equal(values_dask, local.values) and list(summaries["status"]) == [0] * count
    client.wait_for_workers(2)
