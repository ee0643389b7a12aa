"""model.sweep: many members in one call, each equal to its own simulate() on the C backend,
failures kept to their member, the NumPy batch path within tolerance."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

from lagdsl.abi import INTERRUPTED
from lagdsl.errors import LagError
from lagdsl.run import sweep as batch
from lagdsl.run.loading import load_library
from lagdsl.run.toolchain import shared_library
from tests.conftest import MODELS, library_model
from tests.run.test_failures import SINGULAR_LATER, load

DERIVED = """model Spring
  parameter k = 4;
  parameter m = 1;
  parameter w = sqrt(k/m);             // computed from the others unless set
  coordinate x(start = 1/w, velocity = 0);
  T = m*der(x)^2/2;
  U = k*x^2/2;
  scene s
    time(stop = 1, interval = 0.25);
    integrator dopri5(rtol = 1e-9, atol = 1e-12);
    output x, w;
  end s;
end Spring;
"""


@pytest.fixture(scope="module")
def pendulum():
    return library_model("double_pendulum")


def starts(count, seed=3):
    rng = np.random.default_rng(seed)
    return {"theta1.start": rng.uniform(-3, 3, count), "theta2.velocity": rng.uniform(-1, 1, count),
            "m2": rng.uniform(0.5, 2.0, count)}


def test_each_member_equals_its_own_simulate_bit_for_bit(pendulum):
    values = starts(6)
    sweep = pendulum.sweep("chaos", set=values, stop=1.5, interval=0.25, workers=2)
    assert sweep.values.shape == (6, 7, 3) and sweep["theta1"].shape == (6, 7)
    assert list(sweep.status) == ["ok"] * 6 and np.all(np.isnan(sweep.failure_time))
    for b in range(6):
        alone = pendulum.simulate("chaos", set={k: v[b] for k, v in values.items()}, stop=1.5, interval=0.25)
        assert np.array_equal(alone.values, sweep.values[b]) and np.array_equal(alone.t, sweep.t)
        assert alone.summary.count("accepted") == sweep.counters["accepted"][b]
    assert np.array_equal(sweep.inputs["m2"], values["m2"])


def test_threads_and_a_library_without_openmp_give_the_same_bits(pendulum):
    values = starts(5, seed=4)
    one = pendulum.sweep("chaos", set=values, stop=1.0, interval=0.5, workers=1)
    two = pendulum.sweep("chaos", set=values, stop=1.0, interval=0.5, workers=2)
    assert np.array_equal(one.values, two.values)
    members = batch.member_inputs(lambda o: pendulum.plan("chaos", o), _overrides(stop=1.0, interval=0.5), values)
    source = pendulum.emit("c", "chaos")
    serial = load_library(shared_library(source.text, source.suggested_name, openmp=False))
    plain, _ = batch.run_c_batch(serial, batch.batch_layout(members.plan), members.parameters, members.initial, 2)
    assert np.array_equal(plain, two.values)


def _overrides(**grid):
    from lagdsl.scene import Overrides
    return Overrides(start=grid.get("start"), stop=grid.get("stop"), interval=grid.get("interval"))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_member_reaching_a_singular_configuration_fails_alone(backend):
    model = load(SINGULAR_LATER)      # x = x0 - t: M = diag(1, x^2) is singular where x = 0
    sweep = model.sweep(None, backend, set={"x.start": [1.3, 1.0, 2.7]})
    assert sweep.status[1].startswith("the mass matrix is singular at this state")
    assert sweep.failure_time[1] == 0.875 and sweep.rows[1] == 4
    assert np.all(np.isnan(sweep.values[1, 4:])) and sweep["x"][1, :4] == pytest.approx([1, 0.75, 0.5, 0.25])
    assert list(sweep.status[[0, 2]]) == ["ok", "ok"] and not np.any(np.isnan(sweep.values[[0, 2]]))
    assert sweep["x"][2, -1] == pytest.approx(0.7)
    assert sweep.summary.failed == 1 and "1 failed: the mass matrix is singular" in sweep.summary.render()


def test_numpy_batch_agrees_with_c_within_the_tolerance(pendulum):
    values = starts(4, seed=5)
    c = pendulum.sweep("chaos", set=values, stop=1.0, interval=0.25, rtol=1e-9, atol=1e-11)
    stacked = pendulum.sweep("chaos", "numpy", set=values, stop=1.0, interval=0.25, rtol=1e-9, atol=1e-11)
    assert list(stacked.status) == ["ok"] * 4
    assert np.allclose(stacked.values, c.values, rtol=0, atol=1e-6)


def test_members_with_parameters_computed_from_varied_ones_are_planned_one_by_one():
    model = load(DERIVED)
    sweep = model.sweep(set={"k": [1.0, 9.0]})
    assert sweep["w"][:, 0] == pytest.approx([1.0, 3.0])
    for b, k in enumerate((1.0, 9.0)):
        assert np.array_equal(model.simulate(k=k).values, sweep.values[b])
    # x = cos(w t) / w
    assert sweep["x"][1] == pytest.approx(np.cos(3 * sweep.t) / 3, abs=1e-7)


def test_the_tidy_table_has_one_row_per_member_and_time(pendulum):
    sweep = pendulum.sweep("chaos", set={"m2": [1.0, 2.0, 3.0]}, stop=0.5, interval=0.25)
    table = sweep.to_dataframe()
    assert list(table.columns) == ["member", "m2", "t", "theta1", "theta2", "energy", "status"]
    assert len(table) == 9 and list(table["member"]) == [0, 0, 0, 1, 1, 1, 2, 2, 2]
    assert np.array_equal(np.asarray(table["theta2"]), sweep["theta2"].reshape(-1))


@pytest.mark.parametrize("values, message", [
    ({"m2": [1.0, 2.0], "m1": [1.0, 2.0, 3.0]}, "one common length"),
    ({"m9": [1.0]}, "cannot set 'm9'"),
    ({"m2": [[1.0]]}, "1-D array"),
    ({"m2": [1.0, np.nan]}, "member 1"),
    ({"m2": []}, "no members"),
])
def test_bad_values_are_located_errors(pendulum, values, message):
    with pytest.raises(LagError, match=message):
        pendulum.sweep("chaos", set=values, stop=0.5)


def test_members_not_begun_after_an_interrupt_are_marked(pendulum):
    sweep = pendulum.sweep("chaos", set={"m2": [1.0]}, stop=0.5)      # builds and keeps the library
    source = pendulum.emit("c", "chaos")
    library = load_library(shared_library(source.text, source.suggested_name))
    flag = ctypes.c_int.in_dll(library, "lag_interrupt")
    members = batch.member_inputs(lambda o: pendulum.plan("chaos", o), _overrides(stop=0.5), {"m2": [1.0, 2.0]})
    layout = batch.batch_layout(members.plan)
    values = np.zeros((2, layout.rows, layout.columns))
    summaries = layout.summary.empty(2)
    summaries.view(np.float64)[:] = np.nan      # what a C caller's buffer may hold
    double_p = ctypes.POINTER(ctypes.c_double)
    pointer = lambda a: np.ascontiguousarray(a).ctypes.data_as(double_p)   # noqa: E731
    settings = np.array(layout.settings)
    flag.value = 1
    try:
        library.lag_run_batch(ctypes.c_long(2), pointer(members.parameters), pointer(members.initial),
                              pointer(settings), pointer(values), ctypes.c_long(layout.rows), pointer(summaries),
                              ctypes.c_long(layout.summary.size), ctypes.c_int(1))
    finally:
        flag.value = 0
    assert list(summaries["status"]) == [INTERRUPTED] * 2 and list(summaries["rows"]) == [0, 0]
    assert list(summaries["accepted"]) == [0, 0] and list(summaries["t_fail"]) == [0, 0]
    assert sweep.status[0] == "ok"


def test_lagc_sweep_writes_the_grid_as_a_tidy_table(tmp_path):
    from tests.test_cli import lagc
    output = tmp_path / "grid.csv"
    done = lagc("sweep", MODELS / "double_pendulum.lag", "--vary", "m2=1:2:2", "--vary", "theta1.start=0:1:3",
                "--stop", "0.5", "--interval", "0.5", "-o", output)
    assert done.returncode == 0, done.stderr
    assert "sweep of 6 members" in done.stderr and "6 ok, 0 failed" in done.stderr
    lines = output.read_text().splitlines()
    assert lines[0] == "member,m2,theta1.start,t,theta1,theta2,energy,status" and len(lines) == 1 + 6 * 2
    assert lines[1].startswith("0,1,0,0,0,2,") and lines[-1].startswith("5,2,1,0.5,")


@pytest.mark.slow
def test_lagc_sweep_writes_parquet_and_random_samples(tmp_path):
    pandas = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    from tests.test_cli import lagc
    output = tmp_path / "sample.parquet"
    done = lagc("sweep", MODELS / "double_pendulum.lag", "--random", "m2=1:2", "-n", "3", "--seed", "7",
                "--stop", "0.5", "--interval", "0.5", "-o", output)
    assert done.returncode == 0, done.stderr
    table = pandas.read_parquet(output)
    assert len(table) == 6 and np.array_equal(table["m2"].to_numpy()[::2], np.random.default_rng(7).uniform(1, 2, 3))


@pytest.mark.parametrize("options, message", [     # each a new interpreter: two in the default run
    (["--vary", "m2=1:2"], "lagc: error: --vary m2=1:2: expected NAME=START:STOP:COUNT"),
    pytest.param(["--vary", "m2=1:2:0"], "COUNT must be a whole number >= 1", marks=pytest.mark.slow),
    pytest.param(["--random", "m2=1:2"], "lagc: error: --random: needs -n", marks=pytest.mark.slow),
    pytest.param(["--random", "m2=2:1", "-n", "3"], "need LOW < HIGH", marks=pytest.mark.slow),
    pytest.param(["--vary", "m2=1:2:2", "--random", "m1=1:2", "-n", "2"], "not both", marks=pytest.mark.slow),
    (["--vary", "m2=1:2:2", "--vary", "m2=0:1:2"], "'m2' is varied twice"),
    pytest.param([], "nothing varies", marks=pytest.mark.slow),
])
def test_lagc_sweep_refuses_bad_options_with_a_located_error(tmp_path, options, message):
    from tests.test_cli import lagc
    done = lagc("sweep", MODELS / "double_pendulum.lag", *options, "-o", tmp_path / "x.csv")
    assert done.returncode == 1 and message in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "x.csv").exists()


def test_threads_come_from_workers_then_omp_num_threads(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    assert batch.default_threads(None) == 3 and batch.default_threads(2) == 2
    monkeypatch.delenv("OMP_NUM_THREADS")
    assert batch.default_threads(None) >= 1
    with pytest.raises(LagError, match="at least 1"):
        batch.default_threads(0)


def test_numpy_members_under_pure_relative_error_control_run_one_by_one(pendulum):
    values = {"m2": [1.0, 2.0]}
    sweep = pendulum.sweep("chaos", "numpy", set=values, stop=0.5, interval=0.25, rtol=1e-8, atol=0.0)
    for b in range(2):
        alone = pendulum.simulate("chaos", "numpy", set={"m2": values["m2"][b]}, stop=0.5, interval=0.25,
                                  rtol=1e-8, atol=0.0)
        assert np.array_equal(alone.values, sweep.values[b])


def test_a_start_velocity_computed_from_a_varied_parameter_is_recomputed_per_member():
    text = DERIVED.replace("coordinate x(start = 1/w, velocity = 0);", "coordinate x(start = 1, velocity = k);")
    model = load(text)
    sweep = model.sweep(set={"k": [1.0, 4.0], "x.start": [0.5, 0.25]})
    assert list(sweep.values[:, 0, 0]) == [0.5, 0.25]
    for b, (k, x) in enumerate(((1.0, 0.5), (4.0, 0.25))):
        assert np.array_equal(model.simulate(set={"k": k, "x.start": x}).values, sweep.values[b])
