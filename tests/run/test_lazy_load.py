"""`lagdsl.load` of a model whose plan the build cache holds (run/plans.py) defers parsing and
deriving it (api.Model's `derive`): its runs come from the stored plans and programs, equal to a
derived model's bit for bit, and the model is derived when something needs its equations."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import lagdsl
from lagdsl.api import Model
from lagdsl.source import SourceFile

from ..conftest import model_file

SPRING = """model LazySpring "a spring whose start is computed from its parameters"
  parameter m = 1.0 [kg];
  parameter k = 40.0 [N/m];
  parameter g = 9.81 [m/s^2];
  parameter d = 0.1 [m]         "the start below the rest length";
  coordinate x(start = m*g/k + d, velocity = 0) [m];
  T = m/2*der(x)^2;
  U = k/2*x^2 - m*g*x;
  scene bounce
    time(stop = 2, interval = 0.1);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output x, energy;
  end bounce;
end LazySpring;
"""
# Loads argv[1] and runs it as a fit would, then prints the heavy packages it imported.
RUN_REPORTING_IMPORTS = """import sys
import lagdsl
model = lagdsl.load(sys.argv[1])
model.simulate(); model.simulate(stop=1.5, rtol=1e-8); model.simulate(backend="numpy", set={"x.velocity": 0.2})
print(" ".join(sorted({name.split(".")[0] for name in sys.modules} & {"sympy", "lark"})), model.derived)
"""


@pytest.fixture
def stored():
    """The model's file, its default scene run once by a derived model on both backends (so its
    plans are stored), and that model."""
    path = model_file(SPRING, "lazy_spring")
    derived = Model(SourceFile.read(path))
    for backend in ("c", "numpy"):
        derived.simulate(backend=backend)
    return path, derived


def same_run(first, second) -> bool:
    return (np.array_equal(first.t, second.t) and np.array_equal(first.values, second.values)
            and (first.columns, first.units, first.origin) == (second.columns, second.units, second.origin))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_stored_model_runs_without_deriving_and_as_a_derived_one(stored, backend):
    path, derived = stored
    model = lagdsl.load(path)
    assert not model.derived
    for values in ({}, {"set": {"x.start": 0.2}, "rtol": 1e-8}, {"set": {"x.velocity": 0.3}, "stop": "1500 ms"}):
        assert same_run(model.simulate(backend=backend, **values), derived.simulate(backend=backend, **values))
    assert not model.derived
    # x.start is computed from k: the model's expressions are needed, so it is derived now
    assert same_run(model.simulate(backend=backend, set={"k": 60.0}), derived.simulate(backend=backend, k=60.0))
    assert model.derived


def test_load_reads_the_default_scenes_plan_once_for_its_first_run(stored, monkeypatch):
    from lagdsl.run import plans
    path, derived = stored
    found = []
    monkeypatch.setattr(plans, "find", lambda *asked, find=plans.find: found.append(asked[1:]) or find(*asked))
    model = lagdsl.load(path)
    assert same_run(model.simulate(), derived.simulate())
    assert found == [(None, "c", None)] and not model.derived


def test_a_stored_model_is_derived_when_its_equations_are_asked_for(stored):
    path, derived = stored
    model = lagdsl.load(path)
    assert model.name == "LazySpring" and model.derived
    assert model.equations.coordinates == derived.equations.coordinates
    assert same_run(model.simulate(), derived.simulate())


def test_a_model_without_a_stored_plan_is_derived_at_load(tmp_path, monkeypatch):
    monkeypatch.setenv("LAGDSL_CACHE", str(tmp_path / "cache"))
    path = tmp_path / "spring.lag"
    path.write_text(SPRING)
    assert lagdsl.load(path).derived
    path.write_text(SPRING.replace("k/2*x^2", "k/2*y^2"))
    with pytest.raises(lagdsl.LagError, match=r"spring\.lag:8:11: error: undefined name 'y'"):
        lagdsl.load(path)


@pytest.mark.slow
def test_a_new_process_runs_a_stored_model_without_sympy_or_lark(stored):
    path, _ = stored
    done = subprocess.run([sys.executable, "-c", RUN_REPORTING_IMPORTS, str(path)], capture_output=True, text=True,
                          check=True)
    assert done.stdout.split() == ["False"]
