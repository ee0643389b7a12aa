"""Computed parameters and start values (computed_values.py): double evaluation of their
expressions, compiled once per model, the same in a fresh and in a repeated simulate()."""
from __future__ import annotations

import gc
import math

import numpy as np
import pytest
import sympy

import lagdsl
from lagdsl import computed_values
from lagdsl.errors import LagError
from lagdsl.settings import Overrides
from tests.conftest import MODELS, model_file

COMPUTED = """
model Computed "values computed from parameters"
  parameter m = 4.0 [kg];
  parameter k = 9.0 [N/m];
  parameter w = sqrt(k/m) [1/s]     "computed from m and k";
  parameter third = 1/3;
  parameter l = 2.0 [m];
  coordinate x(start = third*l*m*w^2/k, velocity = w*l/3) [m];
  coordinate theta(start = 30) [deg];
  T = m/2*der(x)^2 + m/2*l^2*der(theta)^2;
  U = k/2*x^2 + k/2*l^2*theta^2;
  scene short
    time(stop = 0.1, interval = 0.05);
    output x, theta;
  end short;
end Computed;
"""


def computed_model():
    return lagdsl.load(model_file(COMPUTED, "computed"))


def test_constants_and_unit_conversions_are_correctly_rounded():
    """A constant start in degrees is converted as a value set in degrees is (given_values.input_in_si,
    exact in the unit's factor); a computed value whose exact value is a double (sqrt(9/4) = 1.5)
    is that double; others are the double evaluation of the expression, its constant 1/3 rounded
    once (within an ulp or two of the exact value rounded once)."""
    model = computed_model()
    plan = model.plan()
    parameters = dict(zip(("m", "k", "w", "third"), plan.parameters))
    assert parameters["w"] == 1.5 and parameters["third"] == float(sympy.Rational(1, 3))
    x0, theta0, v0, _ = plan.initial_state
    assert theta0 == model.plan(overrides=Overrides(values=(("theta.start", 30.0),))).initial_state[1]
    assert x0 == pytest.approx(2 / 3, rel=4.5e-16) and v0 == 1.0


def test_a_computed_value_follows_the_parameters_it_is_computed_from():
    model = computed_model()
    plan = model.plan(overrides=Overrides(values=(("m", 1.0),)))
    assert plan.parameters[2] == 3.0 and plan.initial_state[2] == 2.0
    plan = model.plan(overrides=Overrides(values=(("w", 6.0),)))
    assert plan.parameters[2] == 6.0 and plan.initial_state[2] == 4.0      # set: not computed


def test_a_value_that_cannot_be_computed_is_reported():
    model = computed_model()
    with pytest.raises(LagError, match="the parameter w, computed from the others, is nan, not a finite number"):
        model.plan(overrides=Overrides(values=(("k", -1.0),)))
    with pytest.raises(LagError, match="the parameter w, computed from the others, is inf"):
        model.plan(overrides=Overrides(values=(("m", 0.0),)))


def test_repeated_runs_with_a_new_dependent_input_equal_fresh_ones():
    """The elastic pendulum's start s = m g cos(phi0)/k: a repeated simulate() that sets k, m or
    phi0 (the run planned from the stored plan with the compiled values, model_runs.QuickRuns) equals the
    run of a model that never ran, bit for bit."""
    path = MODELS / "elastic_pendulum.lag"
    model = lagdsl.load(path)
    model.simulate(stop=0.2)
    prepared = len(model._quick.runs)       # the first run's too, where it ran from the cache's plan
    for values in (dict(k=150.0), dict(m=1.7, k=80.0), dict(phi0=0.3, set={"phi.start": 0.2})):
        again, fresh = model.simulate(stop=0.2, **values), lagdsl.load(path).simulate(stop=0.2, **values)
        assert np.array_equal(again.values, fresh.values) and np.array_equal(again.t, fresh.t), values
    assert len(model._quick.runs) == prepared + 3, "the repeated calls did not take the prepared run"


def test_a_dependent_input_is_computed_without_sympy(monkeypatch):
    """After the first run, setting k (which the start value of s is computed from) evaluates no
    sympy expression and compiles nothing: the functions compiled once per model do the work."""
    model = lagdsl.load(MODELS / "elastic_pendulum.lag")
    model.simulate(stop=0.2, k=120.0)
    prepared = len(model._quick.runs)

    def refused(*arguments, **options):
        raise AssertionError("sympy called on a repeated run")
    monkeypatch.setattr(sympy.Expr, "evalf", refused)
    monkeypatch.setattr(sympy.Expr, "xreplace", refused)
    monkeypatch.setattr(sympy, "lambdify", refused)
    for k in (130.0, 140.0, 150.0):
        result = model.simulate(stop=0.2, k=k, m=2.0)
        s0 = result.values[0, list(result.columns).index("s")]
        assert s0 == pytest.approx(2.0 * 9.81 * math.cos(1.0) / k, rel=4.5e-16)
    assert len(model._quick.runs) == prepared + 3, "the repeated calls did not take the prepared run"


def test_compiled_once_per_model_and_dropped_with_it():
    model = computed_model()
    model.plan()
    assert computed_values.computed_values(model.ir) is computed_values.computed_values(model.ir)
    key = id(model.ir)
    assert key in computed_values._COMPILED
    del model
    gc.collect()
    assert key not in computed_values._COMPILED
