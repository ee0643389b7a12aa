"""Honest failure: nearly singular mass matrices are caught, and a failed run keeps its rows.

A heavy top at theta = 1e-7 has Euler angles phi and psi turning it about almost the same axis:
its mass matrix is positive definite in exact arithmetic, but the accelerations would have no
correct digits. A free particle moving through the origin of polar coordinates reaches r = 0
exactly (rk4 with a step of 1/4 from r = -1 at speed 1 computes in exact dyadic arithmetic),
where M = diag(1, r^2) is singular: the run stops there and keeps the rows before.
"""
from __future__ import annotations

import csv

import numpy as np
import pytest

import lagdsl
from lagdsl.cli import main
from lagdsl.settings import RCOND_MIN
from tests.conftest import library_model, model_file

THROUGH_THE_POLE = """model Straight "a free particle on a line through the origin, in polar coordinates"
  coordinate r(start = -1, velocity = 1);
  coordinate phi(start = 0.3);
  T = der(r)^2/2 + r^2*der(phi)^2/2;
end Straight;
"""
HINT = "use coordinates that do not pass through this configuration"


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_heavy_top_near_theta_zero_stops_with_the_condition_estimate(backend):
    top = library_model("heavy_top")
    with pytest.raises(lagdsl.SimulationError) as failure:
        top.simulate(backend=backend, stop=0.1, set={"theta.start": 1e-7})
    error = failure.value
    assert "singular" in error.message and "reciprocal condition estimate" in error.message
    estimate = float(error.message.split("estimate ")[1].split(",")[0])
    assert 0 < estimate < RCOND_MIN
    assert error.time == 0 and error.state["theta"] == 1e-7 and HINT in error.remedy
    assert len(error.partial.t) == 1                     # the row at t = 0


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_heavy_top_a_little_further_from_the_pole_runs(backend):
    top = library_model("heavy_top")
    result = top.simulate(backend=backend, stop=0.05, set={"theta.start": 1e-4})
    assert np.all(np.isfinite(result.values))


def test_rows_before_a_singular_state_are_written_to_the_output(tmp_path, capsys):
    model = model_file(THROUGH_THE_POLE, "straight")
    output = tmp_path / "out.csv"
    status = main(["run", str(model), "--integrator", "rk4", "--step", "0.25", "--stop", "2",
                   "--interval", "0.25", "-o", str(output)])
    err = capsys.readouterr().err
    assert status == 1
    rows = list(csv.reader(output.read_text().splitlines()))
    assert rows[0] == ["t", "r", "phi"]
    times = [float(row[0]) for row in rows[1:]]
    assert times == [0.0, 0.25, 0.5, 0.75][:len(times)] and len(times) >= 3
    assert all(float(row[1]) == pytest.approx(-1 + t) for row, t in zip(rows[1:], times))
    assert "the run is incomplete: it stopped at t = " in err and str(output) in err
    assert "singular" in err and HINT in err
    assert not list(tmp_path.glob(".*tmp"))              # written atomically, nothing left behind


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_collapsing_step_keeps_the_rows_and_exits_1(tmp_path, capsys, backend):
    """Radial fall into 1/r: r reaches 0 at t = pi/(2 sqrt 2) = 1.11; the step size collapses."""
    model = model_file("model Fall\n  coordinate r(start = 1);\n  T = der(r)^2/2;\n  U = -1/r;\nend Fall;\n", "fall")
    output = tmp_path / "fall.csv"
    status = main(["run", str(model), "--backend", backend, "--stop", "2", "--interval", "0.1",
                   "-o", str(output)])
    err = capsys.readouterr().err
    assert status == 1 and "simulation failed at t = 1.1" in err
    rows = list(csv.reader(output.read_text().splitlines()))
    assert rows[0] == ["t", "r"] and len(rows) == 1 + 12     # t = 0, 0.1, ..., 1.1
    assert float(rows[-1][0]) == pytest.approx(1.1)
    assert "the run is incomplete: it stopped at t = 1.1" in err


def test_the_numpy_condition_of_one_system_is_numpys_cond_of_the_equilibrated_k():
    """The generated module computes 1/cond_1 of one equilibrated K itself (numpy.linalg.cond spends
    as long on its handling of stacks): the same number, bit for bit, as numpy's for positive
    definite, nearly and exactly singular, saddle-point (a constraint's zero diagonal), indefinite
    and non-finite K; a stack of them gives the smallest."""
    namespace = {}
    exec(library_model("cartesian_pendulum").emit("numpy").text, namespace)
    equilibrated, condition = namespace["equilibrated"], namespace["reciprocal_condition_of"]
    rng = np.random.default_rng(20261128)

    def numpys(K):
        with np.errstate(all="ignore"):
            return np.min(1 / np.linalg.cond(equilibrated(K), 1))

    def drawn(kind: int, n: int) -> np.ndarray:
        A = rng.normal(size=(n, n))
        K = A @ A.T
        if kind == 1:
            K = np.block([[K, A[:1].T], [A[:1], np.zeros((1, 1))]])         # a constraint's row
        elif kind == 2:
            K = np.outer(A[0], A[0])                                          # singular
        elif kind == 3:
            K[:, 0] *= 1e-17
            K[0, :] *= 1e-17                                                  # nearly singular
        elif kind == 4:
            K = A                                                             # indefinite, a negative diagonal
        elif kind == 5:
            K[0, -1] = (np.inf, np.nan)[n % 2]
        return K

    for trial in range(1200):
        K = drawn(trial % 6, int(rng.integers(1, 7)))
        np.testing.assert_equal(condition(K), numpys(K), err_msg=repr(K))
    stack = np.stack([drawn(0, 4), drawn(1, 3), drawn(0, 4)], axis=-1)       # (4, 4, 3), a sweep's
    np.testing.assert_equal(condition(stack), numpys(stack))
