"""Numerical failures on both backends: a SimulationError with the time, the state and a remedy,
the rows computed before kept, and no numpy warning or traceback on the way."""
from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import SimulationError
from lagdsl.pipeline import execute, generate
from tests.conftest import MODELS, library_model, model_file
from tests.test_cli import lagc

SINGULAR_START = """model SingularStart
  coordinate x(start = 0, velocity = 1);
  coordinate y(start = 0, velocity = 1);
  T = (x*der(y))^2/2 + der(x)^2/2;     // M = diag(1, x^2): singular at x = 0
  scene s
    time(stop = 1, interval = 0.1);
  end s;
end SingularStart;
"""
# x = 1 - t exactly (y' = 0 keeps the y momentum zero), so the step landing on t = 1 finds M singular.
SINGULAR_LATER = SINGULAR_START.replace("start = 0, velocity = 1);\n  coordinate y",
                                        "start = 1, velocity = -1);\n  coordinate y").replace(
    "y(start = 0, velocity = 1)", "y(start = 0, velocity = 0)").replace(
    "time(stop = 1, interval = 0.1);", "time(stop = 2, interval = 0.25);\n    integrator rk4(step = 0.125);")
BLOW_UP = """model BlowUp
  parameter a = 1;
  coordinate x(start = a, velocity = 100);
  T = der(x)^2/2;
  U = -x^4;                            // x reaches infinity at t = 0.1459...
  output r = sqrt(x - 2);              // NaN before x reaches 2: a column, not a failure
  scene s
    time(stop = 10, interval = 0.01);
    output x, r;
  end s;
end BlowUp;
"""


def load(text):
    return lagdsl.load(model_file(text))


def failure(model, backend, **settings) -> SimulationError:
    with warnings.catch_warnings():
        warnings.simplefilter("error")        # a leaked RuntimeWarning fails the test
        with pytest.raises(SimulationError) as caught:
            model.simulate(None, backend, **settings)
    return caught.value


# M = [[1, x], [x, 1]]: positive diagonal, det M = 1 - x^2 = 0 at x = 1 (the C code inverts a
# full 2 x 2 M in closed form; its singularity shows in the determinant alone).
SINGULAR_DETERMINANT = SINGULAR_START.replace("T = (x*der(y))^2/2 + der(x)^2/2;",
                                              "T = (der(x)^2 + der(y)^2)/2 + x*der(x)*der(y);").replace(
    "x(start = 0, velocity = 1)", "x(start = 1, velocity = 1)")


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_singular_mass_matrix_at_the_start(backend):
    error = failure(load(SINGULAR_START), backend)
    assert error.message.startswith("the mass matrix is singular at this state")
    assert error.time == 0 and error.state == {"x": 0, "y": 0, "x'": 1, "y'": 1}
    assert "start away from it" in error.remedy
    assert list(error.partial.t) == [0] and list(error.partial.values[0]) == [0, 0]


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", ["dop853", "taylor"])
def test_a_full_2x2_mass_matrix_singular_in_its_determinant_alone(backend, integrator):
    if backend == "numpy" and integrator == "taylor":
        pytest.skip("taylor runs on the C backend only")
    error = failure(load(SINGULAR_DETERMINANT), backend, integrator=integrator)
    assert error.message.startswith("the mass matrix is singular at this state")
    assert error.time == 0 and error.state == {"x": 1, "y": 0, "x'": 1, "y'": 1}


NEGATIVE_MASS = """model Spring
  parameter m = 1 [kg];  parameter k = 4 [N/m];
  coordinate x(start = 1) [m];
  T = m/2*der(x)^2;
  U = k/2*x^2;
end Spring;
"""


def test_a_negative_mass_is_refused_at_check_and_named(tmp_path):
    path = tmp_path / "spring.lag"
    path.write_text(NEGATIVE_MASS.replace("m = 1 [kg]", "m = -1 [kg]"), encoding="utf-8")
    done = lagc("check", path)
    assert done.returncode == 1 and ":2:13: error: the mass matrix is not positive definite: with m = -1" in done.stderr


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_negative_mass_set_for_a_run_names_the_sign_in_the_remedy(backend):
    error = failure(load(NEGATIVE_MASS), backend, set={"m": -1.0}, stop=1.0)
    assert error.message.startswith("the mass matrix is singular at this state") and error.time == 0
    assert "a negative value does the same (the kinetic energy must be positive" in error.remedy


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", ["rk4", "gauss"])
def test_singular_mass_matrix_later_keeps_the_rows_before(backend, integrator):
    model = load(SINGULAR_LATER)
    if integrator == "gauss":          # Hamilton's equations never evaluate M at x = 0 here
        assert model.simulate(None, backend, integrator="gauss").t[-1] == 2.0
        return
    error = failure(model, backend)
    assert error.message.startswith("the mass matrix is singular at this state")
    assert error.time == 0.875 and error.state["x"] == pytest.approx(0.125)
    assert list(error.partial.t) == [0, 0.25, 0.5, 0.75]
    assert error.partial["x"] == pytest.approx([1, 0.75, 0.5, 0.25])


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", ["dop853", pytest.param("radau5", marks=pytest.mark.slow),
                                        pytest.param("rk4", marks=pytest.mark.slow)])
def test_blow_up(backend, integrator):
    settings = {"integrator": integrator, **({"step": 0.001} if integrator == "rk4" else {})}
    error = failure(load(BLOW_UP), backend, **settings)
    # a method that crawls towards the singularity may be ended there by the work forecast,
    # before its step collapses
    forecast = error.message.startswith("at this pace reaching t = 10 would take ")
    assert forecast or error.message in ("the step size collapsed below the resolution of t",
                                         "the state or its derivative became infinite or NaN")
    assert 0.1459 < error.time < 0.15 and error.state["x"] > (1e7 if forecast else 1e10)
    assert error.remedy
    rows = error.partial
    assert list(rows.t) == pytest.approx(np.arange(15) * 0.01)
    assert np.isnan(rows["r"][0]) and np.all(np.isfinite(rows["x"]))


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_non_finite_initial_state(backend):
    # A start value that is NaN only once the integration has begun would be refused by the plan;
    # the runners check the state they are given all the same.
    model = load(BLOW_UP)
    plan = model.plan(None)
    state = (float("nan"),) + plan.initial_state[1:]
    _, source = generate(model.equations, plan, backend, "blow_up.lag")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(SimulationError) as caught:
            execute(source, replace(plan, initial_state=state))
    error = caught.value
    assert error.message == "the state or its derivative became infinite or NaN"
    assert error.time == 0 and np.isnan(error.state["x"])
    assert "check the parameters and initial values" in error.remedy


# A let that is a bare number is a Python float in the generated NumPy code, and a Python float
# raises OverflowError where NumPy's gives inf (found by the fuzz campaign: a constant let of
# rolling_disk.lag set to 1e308).
CONSTANT_OVERFLOW = """model ConstantOverflow
  let huge = 1e308;
  coordinate x(start = 1);
  T = der(x)^2/2;
  U = (huge*x)^2;
end ConstantOverflow;
"""


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator, options", [("dop853", {}), ("rk4", {"step": 0.01})])
def test_overflow_of_a_constant_is_a_simulation_error(backend, integrator, options):
    model = load(CONSTANT_OVERFLOW)
    with pytest.raises(SimulationError, match="infinite or NaN"):
        model.simulate(backend=backend, integrator=integrator, stop=0.1, **options)


def test_the_command_line_shows_no_warning_or_traceback(tmp_path):
    path = tmp_path / "blow_up.lag"
    path.write_text(BLOW_UP, encoding="utf-8")
    done = lagc("run", path, "--backend", "numpy", "-o", tmp_path / "out.csv")
    assert done.returncode == 1
    assert "simulation failed at t = 0.14" in done.stderr
    assert "Warning" not in done.stderr and "Traceback" not in done.stderr
    assert (tmp_path / "out.csv").read_text().startswith("t,x,r\n0,1,")     # the rows before are written


@pytest.mark.parametrize("option", ["--rtol", "--atol"])
def test_non_finite_tolerances_are_option_errors(tmp_path, option):
    path = tmp_path / "blow_up.lag"
    path.write_text(BLOW_UP, encoding="utf-8")
    done = lagc("run", path, "--backend", "numpy", option, "inf")
    assert done.returncode == 1
    assert done.stderr == f"lagc: error: {option}: dop853({option[2:]} = ...) must be a finite number >= 0\n"


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_initial_state_off_a_singular_constraint(backend):
    """The state reported is the initial one (the C driver reported zeros before its stepper began)."""
    model = library_model("cartesian_pendulum")
    error = failure(model, backend, set={"x.start": 0.0, "y.start": 0.0, "x.velocity": 0.5}, start=0.25)
    assert error.message == "projection onto the constraints did not converge"
    assert error.time == 0.25 and len(error.partial.t) == 0
    assert error.state == {"x": 0.0, "y": 0.0, "x'": 0.5, "y'": 0.0}
    done = lagc("run", MODELS / "cartesian_pendulum.lag", "--backend", backend, "--set", "x.start=0",
                "--set", "y.start=0")
    assert done.returncode == 1 and "Traceback" not in done.stderr


def test_a_non_finite_jacobian_in_scipys_radau_is_a_simulation_error():
    """m = 1e-308 overflows the iteration matrix built from e B / m ~ 2e308: scipy's LU refuses
    it with a ValueError, which must become the non-finite failure with the start row kept, not a
    traceback. (At m = 1e-300 the entries stay finite, and radau5 solves the circle of radius
    1e-300 from a first step no smaller than the floor, settings.START_STEP_MIN_STEPS.)"""
    particle = library_model("charged_particle")
    with pytest.raises(SimulationError) as failure:
        particle.simulate(backend="numpy", integrator="radau5", stop=0.1, m=1e-308)
    assert "infinite or NaN" in str(failure.value)
    assert len(failure.value.partial.t) == 1


def test_outputs_with_multipliers_at_a_singular_start_leave_no_row_on_either_backend():
    """The penny with a zero moment of inertia (radius 1e-200: m a^2/4 underflows to 0): the
    system for q'' is singular at t = 0, so its start row has no multipliers. Both backends stop
    there with no row, as the C driver delivers no row it cannot evaluate (the NumPy one raised
    LinAlgError). (A model whose mass matrix underflows at every value of its parameters, as
    with a^exp(1000), is refused by lagc check.)"""
    penny = library_model("rolling_penny")
    for backend in ("c", "numpy"):
        with pytest.raises(SimulationError) as failure:
            penny.simulate(backend=backend, stop=0.1, a=1e-200)
        assert "singular" in str(failure.value) and len(failure.value.partial.t) == 0
        assert "): ," not in failure.value.partial.summary.render()      # no empty list of counts
