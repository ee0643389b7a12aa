"""Forward sensitivities on the C backend: every adaptive C integrator, against the NumPy path and
central differences; the generated program compiled under the strict flags; a fit run on C."""
from __future__ import annotations

import functools

import numpy as np
import pytest

import lagdsl
from lagdsl.codegen.c_sensitivity import augmented_integrator, sensitivity_source
from lagdsl.sensitivity import run as sensitivity
from lagdsl.sensitivity.c_run import augmented, first_order
from lagdsl.settings import Overrides
from lagdsl.source import SourceFile
from tests.linear.support import model
from tests.run.c_harness import STRICT_FLAGS, find_cc
from tests.conftest import MODELS, compiled

# (model, scene, output column, directions): an unconstrained pendulum, a model whose
# accelerations read no velocity (rkn8) and a constrained one (its KKT system).
CASES = {"double_pendulum": (None, "theta2", ["m2", "l1", "theta1.start", "theta2.velocity"]),
         "coupled_oscillators": ("mode1", "x[2]", ["k", "A", "x[1].velocity"]),
         "cartesian_pendulum": (None, "y", ["l", "theta0", "x.start", "y.velocity"])}
INTEGRATORS = ["dopri5", "dop853", "rkn8", "radau5", "auto"]


def against_numpy(library: str, integrator: str, error_control: bool = True):
    """The C run's sensitivities against the NumPy path's, both at tight tolerances."""
    scene, column, names = CASES[library]
    subject = model(library)
    tight = dict(stop=2.0, rtol=1e-11, atol=1e-13)
    run = subject.simulate(scene, backend="c", sensitivities=names, integrator=integrator,
                           sensitivity_error_control=error_control, **tight)
    reference = subject.simulate(scene, backend="numpy", sensitivities=names, **tight)
    assert run.summary.backend == "c" and run.summary.integrator == integrator
    for name in names:
        expected = reference.sensitivity(column, name)
        assert np.max(np.abs(run.sensitivity(column, name) - expected)) <= 1e-6 * max(1.0, np.max(np.abs(expected))), \
            (integrator, name)


@pytest.mark.parametrize("library, integrator", [("double_pendulum", "dopri5"), ("coupled_oscillators", "rkn8"),
                                                 ("cartesian_pendulum", "radau5")])
def test_each_family_of_c_integrators_agrees_with_the_numpy_sensitivities(library, integrator):
    against_numpy(library, integrator)


@pytest.mark.slow
@pytest.mark.parametrize("error_control", [True, False])
@pytest.mark.parametrize("integrator", INTEGRATORS)
@pytest.mark.parametrize("library", list(CASES))
def test_every_adaptive_c_integrator_agrees_with_the_numpy_sensitivities(library, integrator, error_control):
    if integrator == "rkn8" and library != "coupled_oscillators":
        pytest.skip("rkn8 needs accelerations without velocities and without constraints")
    against_numpy(library, integrator, error_control)


def test_rkn8_is_refused_where_the_scene_refuses_it():
    with pytest.raises(Exception) as raised:
        model("double_pendulum").simulate(backend="c", sensitivities=["m2"], integrator="rkn8")
    assert "rkn8" in str(raised.value)


def test_the_augmented_state_orders_positions_before_velocities():
    # n = 2, m = 2: (q, v, S by rows) <-> (q, Sq_1, Sq_2, v, Sv_1, Sv_2)
    n, m = 2, 2
    y = np.arange(2 * n + 2 * n * m, dtype=float)
    S = y[2 * n:].reshape(2 * n, m)
    Y = augmented(y, n, m)
    np.testing.assert_array_equal(Y[:n], y[:n])
    np.testing.assert_array_equal(Y[n:2 * n], S[:n, 0])
    np.testing.assert_array_equal(Y[n * (1 + m) + n:n * (1 + m) + 2 * n], S[n:, 0])
    np.testing.assert_array_equal(first_order(Y[None, :], n, m)[0], y)


def test_without_error_control_only_the_error_norms_change():
    for name in ("dopri5", "dop853", "rkn8", "radau5", "auto"):
        full, state = augmented_integrator(name, True), augmented_integrator(name, False)
        assert full != state and "LAG_AUG_IN_ERROR" in state and "LAG_AUG_NERR" in state, name
        assert "lag_stepper" not in full.replace("lag_aug_stepper", "")   # every interface name is the copy's


@functools.cache
def _subject(library: str):
    """The library model; the pendulum chain with 5 links instead of 12, the fewest whose mass
    matrix is factored by the dense Cholesky loops (codegen/structure.py), derived in a fifth of
    the time."""
    if library != "pendulum_chain":
        return model(library)
    text = (MODELS / "pendulum_chain.lag").read_text(encoding="utf-8").replace("n = 12", "n = 5")
    return lagdsl.Model(SourceFile("pendulum_chain.lag", text))


@functools.cache
def _sensitivity_program(library: str, scene: str | None):
    """The variational equations of a library scene, derived once for both kinds of error control:
    only the printing differs between them."""
    return sensitivity.build(_subject(library), scene)


@pytest.mark.parametrize("library, scene, integrator", [
    ("cartesian_pendulum", None, "radau5"),         # dense LU of the KKT system, the augmented Jacobian
    # R does not depend on q: lag_residual_jacobian stores nothing in Dq, which it must clear all the
    # same (at -O3, the library's level, gcc sees a read of an uninitialised Dq otherwise)
    ("atwood", None, "dop853"),
    pytest.param("pendulum_chain", None, "dopri5", marks=pytest.mark.slow),      # dense Cholesky
    pytest.param("cartesian_chain", None, "auto", marks=pytest.mark.slow),     # sparse LDLᵀ with constraints
    pytest.param("coupled_oscillators", "mode1", "rkn8", marks=pytest.mark.slow),  # M factored once, rkn8's accelerations
])
@pytest.mark.parametrize("error_control", [True, pytest.param(False, marks=pytest.mark.slow)])
def test_the_sensitivity_program_compiles_under_the_strict_flags(tmp_path, library, scene, integrator, error_control):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    subject = _subject(library)
    program = _sensitivity_program(library, scene)
    plan = subject.plan(scene, Overrides(integrator=integrator))
    source = sensitivity_source(program.kernel, plan.integrator, 3, "model.lag", error_control)
    assert source.text == sensitivity_source(program.kernel, plan.integrator, 3, "model.lag", error_control).text
    path = tmp_path / "sensitivity.c"
    path.write_text(source.text)
    for extra in ([], ["-DLAG_LONG_DOUBLE"], *([["-O3"]] if library == "atwood" else [])):
        done = compiled([cc, *STRICT_FLAGS, *extra, "-c", str(path), "-o", str(tmp_path / "s.o")])
        assert done.returncode == 0, done.stderr[:3000]


def test_a_fit_runs_on_the_c_backend():
    subject = model("damped_driven_pendulum")
    truth = subject.simulate(backend="c", stop=4, interval=0.1, l=1.3, b=0.3)
    fit = subject.fit({"t": truth.t, "theta": truth["theta"]}, {"l": 1.0, "b": 0.5}, backend="c")
    assert fit.success
    assert fit.values["l"] == pytest.approx(1.3, rel=1e-6) and fit.values["b"] == pytest.approx(0.3, rel=1e-6)


@pytest.mark.slow          # 5 s of CPU; a per-component atol in C is checked without sensitivities in run/test_si_scales.py
def test_a_per_component_atol_holds_for_the_state_on_the_c_backend():
    # atol(x) weighs the state's own components (the sensitivities keep the scalar atol, as on
    # NumPy): tight, the C run agrees with NumPy's; equal to the scalar, it changes nothing; loose
    # on the state (the sensitivities out of the error control), it saves steps
    subject, names = model("double_pendulum"), ["m2", "theta1.start"]
    tight = dict(stop=2.0, rtol=1e-11, sensitivities=names)
    each = {"theta1": 1e-13, "theta2": 1e-14, "der(theta1)": 1e-13, "der(theta2)": 1e-13}
    run = subject.simulate(backend="c", atol=each, **tight)
    reference = subject.simulate(backend="numpy", atol=each, **tight)
    for name in names:
        expected = reference.sensitivity("theta2", name)
        assert np.max(np.abs(run.sensitivity("theta2", name) - expected)) <= 1e-6 * np.max(np.abs(expected))
    state = ["theta1", "der(theta1)", "theta2", "der(theta2)"]
    loose = dict(stop=2.0, rtol=1e-10, sensitivities=names, sensitivity_error_control=False)

    def steps(atol) -> int:
        return dict(subject.simulate(backend="c", atol=atol, **loose).summary.counters)["accepted"]

    assert steps([1e-10, *((name, 1e-10) for name in state)]) == steps(1e-10)
    assert steps([1e-10, *((name, 1e-2) for name in state)]) < steps(1e-10) / 2
