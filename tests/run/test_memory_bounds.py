"""A result that would not fit in memory is refused before the run, with its size and a remedy;
a sweep written to a file runs block by block in bounded memory."""
from __future__ import annotations

import os
import resource
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

from lagdsl.errors import LagError
from lagdsl.run import memory, sweep_job
from tests.conftest import library_model, slow_unless_kept

WIDE = """model Wide
  parameter n = 200;
  coordinate x[n];
  T = sum(der(x[i])^2/2, i in 1:n);
  U = sum(x[i]^2/2, i in 1:n);
end Wide;
"""


def limited(command, tmp_path):
    """`command` under `ulimit -v 4194304` (4 GiB of address space), one BLAS thread."""
    return subprocess.run(command, capture_output=True, text=True, timeout=300,
                          preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30)),
                          env={**os.environ, "LAGDSL_CACHE": str(tmp_path / "cache"), "OPENBLAS_NUM_THREADS": "1",
                               "OMP_NUM_THREADS": "1"})


# runner._check refuses the result before either backend starts (C before it builds): the
# default run keeps C, NumPy is slow.
@pytest.mark.parametrize("backend", slow_unless_kept(["c", "numpy"], kept={"c"}))
def test_a_run_of_200_coordinates_and_10_million_rows_is_refused_before_it_runs(tmp_path, backend):
    model = tmp_path / "wide.lag"
    model.write_text(WIDE)
    done = limited([sys.executable, "-m", "lagdsl", "run", str(model), "--backend", backend, "--stop", "9999999",
                    "--interval", "1"], tmp_path)
    assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
    assert "the result (10000000 rows of 201 columns) would take" in done.stderr
    assert "choose a larger --interval or fewer outputs" in done.stderr


def test_a_sweep_of_10_million_members_is_refused_before_it_runs(monkeypatch):
    """In this process, with the 4 GiB of the run's test above given as what it can use (that test
    reads a real limit in a process of its own): the refusal comes before the table is allocated,
    as tracemalloc's peak (NumPy's arrays included) shows, a copy of the members at most."""
    model, members = library_model("double_pendulum"), np.linspace(-1, 1, 10**7)
    monkeypatch.setattr(memory, "available_bytes", lambda: 4 << 30)
    tracemalloc.start()
    try:
        with pytest.raises(LagError, match=r"the sweep's table \(10000000 members x 1001 rows x 3 columns\) "
                                           r"would take 447 GiB, more than the 2 GiB .*Model\.sweep_to_file"):
            model.sweep(set={"theta1.start": members}, stop=10, interval=0.01)
        assert tracemalloc.get_traced_memory()[1] < 4 * members.nbytes
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_a_sweep_to_a_file_runs_block_by_block_and_equals_the_sweep(tmp_path, monkeypatch, suffix):
    model = library_model("double_pendulum")
    values = {"theta1.start": np.linspace(-1, 1, 23), "m2": 2.0}
    monkeypatch.setattr(sweep_job, "BLOCK_CEILING", 64 * 11 * (3 + 1 + 3) * 5)     # 5 members a block
    path = tmp_path / f"table.{suffix}"
    summary = model.sweep_to_file(path, set=values, stop=1.0, interval=0.1)
    whole = model.sweep(set=values, stop=1.0, interval=0.1)
    assert summary.members == 23 and summary.counters == whole.summary.counters
    if suffix == "csv":
        assert path.read_text() == whole.csv()
    else:
        pandas = pytest.importorskip("pandas")
        pandas.testing.assert_frame_equal(pandas.read_parquet(path), whole.to_dataframe())
