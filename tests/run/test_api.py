"""The Python API, the build cache, and names that would collide in C."""
from __future__ import annotations

import pickle
from dataclasses import replace

import numpy as np
import pytest

import lagdsl
from lagdsl.codegen import c as c_printer, kernel, numpy as numpy_printer
from lagdsl.run import loading, toolchain
from tests.conftest import MODELS, library_model, model_file

COLLIDING = """
model Collide "names that are C keywords, libm or POSIX functions"
  parameter y0 = 1.0;
  parameter j1 = 2.0;
  parameter gamma = 0.5;
  parameter main = 3.0;
  parameter errno = 1.0;
  coordinate int(start = y0);
  coordinate double(velocity = j1);
  let sqrt2 = gamma*int;
  T = main/2*(der(int)^2 + der(double)^2);
  U = errno*sqrt2^2/2;
  scene exp
    time(stop = 1, interval = 0.5);
    integrator dopri5(rtol = 1e-10, atol = 1e-12);
    output int, double, energy;
  end exp;
end Collide;
"""


def test_simulate_returns_named_columns_and_summary(tmp_path):
    result = library_model("kepler").simulate("ellipse", stop=1.0)
    assert result.t[0] == 0.0 and result.t[-1] == pytest.approx(1.0)
    assert result["r"].shape == result.t.shape
    assert result.columns == ("r", "theta", "energy", "momentum(theta)")
    assert result.summary.count("accepted") > 0 and "drift of energy" in result.summary.render()
    result.to_csv(tmp_path / "kepler.csv")
    assert (tmp_path / "kepler.csv").read_text().startswith("t,r,theta,energy,momentum(theta)\n")


def test_parameter_and_initial_overrides():
    model = library_model("wedge")
    heavy = model.simulate(M=100.0, stop=0.1)
    light = model.simulate(set={"M": 0.5, "s.velocity": 1.0}, stop=0.1)
    assert abs(heavy["x"][-1]) < abs(light["x"][-1])
    assert light["der(s)"][0] == 1.0


@pytest.mark.parametrize("values, words", [
    (dict(m2=[1, 2]), "lagc: error: m2: a run takes one value of each input, got 2 values; to run a member for "
                      "each, use model.sweep(set={'m2': [...]})"),
    (dict(set={"theta1.start": np.linspace(0, 1, 5)}), "theta1.start: a run takes one value of each input, got 5"),
    (dict(m2="heavy"), "lagc: error: m2: expected a number, or a number and a unit such as '30 deg', got 'heavy'"),
])
def test_several_values_where_one_is_expected_point_to_sweep(values, words):
    """simulate(m2=[1, 2]) raised a bare TypeError from float()."""
    model = lagdsl.load(MODELS / "double_pendulum.lag")
    with pytest.raises(lagdsl.errors.LagError) as refused:
        model.simulate(stop=0.1, **values)
    assert words in str(refused.value)


def test_names_that_collide_in_c():
    model = lagdsl.load(model_file(COLLIDING, "collide"))
    c = model.simulate()
    numpy = model.simulate(backend="numpy")
    # int'' = -(errno gamma^2 / main) int: a harmonic oscillator with omega^2 = 1/12
    omega = np.sqrt(0.25 / 3.0)
    assert np.allclose(c["int"], np.cos(omega * c.t), atol=1e-9)
    assert np.allclose(c.values, numpy.values, atol=1e-9)


def test_second_run_reuses_the_compiled_library(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path))
    model = lagdsl.load(MODELS / "wedge.lag")
    model.simulate(stop=0.1)
    compiled = []
    original = toolchain.compile_c
    monkeypatch.setattr(toolchain, "compile_c", lambda *a, **k: compiled.append(a) or original(*a, **k))
    model.simulate(stop=0.1, M=5.0)           # parameters are run-time inputs: same library
    assert compiled == []
    assert len(list(tmp_path.glob("*.so"))) == 1


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_model_keeps_its_loaded_code(backend, monkeypatch):
    """A repeated simulate() with other inputs neither lowers, renders, compiles nor loads."""
    model = lagdsl.load(MODELS / "double_pendulum.lag")
    first = model.simulate(backend=backend, stop=1.0)
    calls = []

    def counted(module, name):
        original = getattr(module, name)
        monkeypatch.setattr(module, name, lambda *a, **k: calls.append(name) or original(*a, **k))

    for module, name in ((kernel, "lower_to_kernel"), (c_printer, "render_c"), (numpy_printer, "render_numpy"),
                         (loading, "load"), (loading, "shared_library"), (loading, "load_module"),
                         (loading, "load_program_library"), (loading, "import_module"), (toolchain, "compile_c")):
        counted(module, name)
    again = model.simulate(backend=backend, stop=1.0)
    heavier = model.simulate(backend=backend, stop=2.0, interval=0.05, rtol=1e-9, m2=3.0,
                             set={"theta1.start": 0.5})
    assert calls == []
    assert np.array_equal(first.values, again.values) and np.array_equal(first.t, again.t)
    assert heavier.t[-1] == 2.0 and not np.allclose(heavier.values[:5], first.values[:5])
    model.simulate(backend=backend, stop=1.0, integrator="rk4", step=0.01)    # another integrator: new code,
    # generated (or its source kept by an earlier process: codegen/kept.py) and loaded, or (a model
    # loaded from its stored plans, api.load) the program of the stored plan loaded
    assert {"load", "load_program_library", "import_module"} & set(calls)


def test_failure_keeps_partial_results():
    model = library_model("wedge")
    with pytest.raises(lagdsl.SimulationError) as failure:
        model.simulate(integrator="dopri5", set={"M": -1.0, "m": 0.0})
    assert failure.value.partial is not None


def test_repeated_runs_planned_without_sympy_equal_fresh_ones():
    """A repeated simulate() plans from the scene's stored settings (as a warm `lagc run` does);
    whatever the overrides, its run equals that of a model that never ran, bit for bit."""
    path = MODELS / "double_pendulum.lag"
    model = lagdsl.load(path)
    model.simulate(stop=0.5)
    for overrides in (dict(stop=0.7), dict(m2=2.5, stop=0.5), dict(set={"theta2.start": 0.3}, stop=0.5),
                      dict(interval=0.05, rtol=1e-6, stop=0.5), dict(integrator="rk4", step=0.01, stop=0.5)):
        again, fresh = model.simulate(**overrides), lagdsl.load(path).simulate(**overrides)
        assert np.array_equal(again.values, fresh.values) and np.array_equal(again.t, fresh.t), overrides
        assert again.summary.counters == fresh.summary.counters


def test_repeated_calls_equal_a_plain_run_and_share_no_memory():
    """A repeated simulate() with the same inputs (its run prepared once, model_runs.QuickRuns) returns
    what a plain simulate() returns, bit for bit, with the same summary, units and origin; each
    call's rows are its own, so that a later call, or a change to one result, leaves the others
    as they were."""
    path = MODELS / "elastic_pendulum.lag"
    plain = lagdsl.load(path).simulate()
    model = lagdsl.load(path)
    model.simulate()
    second, third = model.simulate(), model.simulate()
    assert model._quick.runs, "the repeated calls did not take the prepared run"
    untimed = lambda result: replace(result.summary, wall_time=0.0)     # noqa: E731
    for again in (second, third, pickle.loads(pickle.dumps(third))):
        assert np.array_equal(again.t, plain.t) and np.array_equal(again.values, plain.values)
        assert (again.columns, again.units, again.origin) == (plain.columns, plain.units, plain.origin)
        assert untimed(again) == untimed(plain)
    assert not np.shares_memory(second.values, third.values) and not np.shares_memory(second.t, third.t)
    third.values[:] = np.nan
    third.t[:] = np.nan
    assert np.array_equal(second.values, plain.values) and np.array_equal(second.t, plain.t)


def test_rows_still_held_in_part_are_never_written_over():
    """A repeated C run may take the rows' array of an earlier call that nothing holds any more
    (c_backend._RowArrays); a part still held (a result's t, a view of its values) keeps its
    array out of reach of every later call."""
    model = lagdsl.load(MODELS / "elastic_pendulum.lag")
    model.simulate()
    held_t = model.simulate(k=80.0).t
    held_view = model.simulate(k=90.0).values[:3]
    view = held_view.copy()
    for k in (100.0, 110.0, 120.0, 130.0):
        model.simulate(k=k)                     # dropped at once: their arrays free again
    later = [model.simulate(k=k) for k in (140.0, 150.0, 160.0)]
    assert np.array_equal(held_view, view)
    for result in later:
        assert not np.shares_memory(result.values, held_t) and not np.shares_memory(result.values, held_view)


def test_threads_running_a_prepared_run_at_once_each_get_rows_of_their_own():
    """Calls of one prepared run from several threads (a parallel fit: the C call releases the
    GIL) each take rows that no other call is writing or holds (c_backend._RowArrays), whether
    their results are kept or dropped at once; each equals the same call made alone."""
    from concurrent.futures import ThreadPoolExecutor
    model = lagdsl.load(MODELS / "elastic_pendulum.lag")
    model.simulate()
    ks = (80.0, 90.0, 100.0, 110.0)
    alone = {k: model.simulate(k=k).values.copy() for k in ks}
    model.simulate()
    with ThreadPoolExecutor(4) as pool:
        kept = list(pool.map(lambda i: (ks[i % 4], model.simulate(k=ks[i % 4])), range(40)))
        list(pool.map(lambda i: model.simulate().t[0], range(40)))
    for k, result in kept:
        assert np.array_equal(result.values, alone[k]), k


def test_a_held_result_and_its_unread_summary_outlive_later_calls():
    """The rows and the summary's doubles of a repeated C run are arrays made for that call: a
    result held, its summary not yet read (it is made when first read), is unchanged by later
    calls with other inputs, which run the same prepared program."""
    path = MODELS / "elastic_pendulum.lag"
    model = lagdsl.load(path)
    model.simulate()
    held = model.simulate(k=80.0)
    rows, t = held.values.copy(), held.t.copy()
    for k in (120.0, 90.0, 80.0):
        model.simulate(k=k).summary
    fresh = lagdsl.load(path).simulate(k=80.0)
    assert np.array_equal(held.values, rows) and np.array_equal(held.t, t)
    assert np.array_equal(held.values, fresh.values)
    assert replace(held.summary, wall_time=0.0) == replace(fresh.summary, wall_time=0.0)

