"""Forward sensitivities against closed forms and central finite differences of simulate."""
from __future__ import annotations

import numpy as np
import pytest

from lagdsl.errors import LagError
from lagdsl.source import SourceFile
from lagdsl.api import Model
from tests.linear.support import model

OSCILLATOR = """model Oscillator "mass on a spring"
  parameter m = 2.0 [kg];
  parameter k = 3.0 [N/m];
  parameter A = 0.5 [m];
  parameter v = 0.2 [m/s];
  coordinate x(start = A, velocity = v) [m];
  T = m/2*der(x)^2;
  U = k/2*x^2;
  scene free
    time(stop = 5, interval = 0.25);
    integrator dop853(rtol = 1e-12, atol = 1e-14);
    output x, der(x);
  end free;
end Oscillator;
"""


@pytest.fixture(scope="module")
def oscillator() -> Model:
    return Model(SourceFile("oscillator.lag", OSCILLATOR))


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_harmonic_oscillator_sensitivities_are_the_closed_forms(oscillator, backend):
    # x = A cos(w t) + (v/w) sin(w t), w = sqrt(k/m): dx/dk = dx/dw dw/dk, dx/dA = cos(w t), ...
    run = oscillator.simulate(backend=backend, sensitivities=["k", "m", "A", "x.velocity"])
    m, k, A, v, t = 2.0, 3.0, 0.5, 0.2, run.t
    w = np.sqrt(k / m)
    dx_dw = -A * t * np.sin(w * t) - v / w**2 * np.sin(w * t) + v / w * t * np.cos(w * t)
    np.testing.assert_allclose(run["x"], A * np.cos(w * t) + v / w * np.sin(w * t), atol=1e-12)
    np.testing.assert_allclose(run.sensitivity("x", "k"), dx_dw / (2 * np.sqrt(k * m)), atol=1e-11)
    np.testing.assert_allclose(run.sensitivity("x", "m"), -dx_dw * np.sqrt(k) / 2 * m**-1.5, atol=1e-11)
    np.testing.assert_allclose(run.sensitivity("x", "A"), np.cos(w * t), atol=1e-11)
    np.testing.assert_allclose(run.sensitivity("x", "x.velocity"), np.sin(w * t) / w, atol=1e-11)
    np.testing.assert_allclose(run.sensitivity("der(x)", "A"), -w * np.sin(w * t), atol=1e-11)
    assert run.units == ("m", "m/s") and run.origin == "Oscillator, scene free"       # for its plots, as any run


def test_a_start_written_in_a_parameter_moves_with_it_unless_set(oscillator):
    # x.start = A: dx/dA is cos(w t); with x.start set, A no longer moves the start: zero.
    fixed = oscillator.simulate(backend="numpy", sensitivities=["A"], set={"x.start": 0.5})
    np.testing.assert_array_equal(fixed.sensitivity("x", "A"), 0.0)


def central_difference(subject, scene, name, column, base, stop, h=1e-4, backend="numpy"):
    """(f(θ + h) - f(θ - h)) / 2h of a column, θ a parameter or start value at `base`."""
    runs = [subject.simulate(scene, backend=backend, set={name: base + s * h}, stop=stop, rtol=1e-13,
                             atol=1e-15)[column] for s in (1, -1)]
    return (runs[0] - runs[1]) / (2 * h)


def assert_agrees(computed, expected, what):
    """Agreement to 1e-6 relative (absolute where the derivative is below 1)."""
    assert np.max(np.abs(computed - expected)) <= 1e-6 * max(1.0, np.max(np.abs(expected))), what


# The default run takes the dense double pendulum and the constant M of the coupled oscillators in
# C (NumPy's dense sensitivities: against C's differences below, a sixth of the NumPy differences'
# CPU); the other pairs are slow.
@pytest.mark.parametrize("library, scene, column, names, backend", [
    pytest.param(library, scene, column, names, backend,
                 marks=() if (library, backend) in {("double_pendulum", "c"), ("coupled_oscillators", "c")}
                 else pytest.mark.slow)
    for library, scene, column, names in [
        ("double_pendulum", None, "theta2", {"m2": 1.0, "l1": 1.0, "theta1.start": 1.0, "theta2.velocity": 0.0}),
        ("damped_driven_pendulum", None, "theta", {"b": 0.5, "omega": 2.0, "l": 1.0}),
        ("coupled_oscillators", "mode1", "x[2]", {"k": 4.0, "A": 0.1})]
    for backend in ("numpy", "c")])
def test_sensitivities_agree_with_central_differences(library, scene, column, names, backend):
    subject = model(library)
    stop = 2.0
    run = subject.simulate(scene, backend=backend, sensitivities=list(names), stop=stop, rtol=1e-12, atol=1e-14)
    for name, base in names.items():
        assert_agrees(run.sensitivity(column, name), central_difference(subject, scene, name, column, base, stop,
                                                                         backend=backend), name)


def test_the_sensitivities_agree_with_differences_of_the_c_backend():
    subject, names = model("double_pendulum"), {"l2": 1.0, "theta2.start": 2.0}
    run = subject.simulate(backend="numpy", sensitivities=list(names), stop=2.0, rtol=1e-12, atol=1e-14)
    for name, base in names.items():
        expected = central_difference(subject, None, name, "theta1", base, 2.0, backend="c")
        assert np.max(np.abs(run.sensitivity("theta1", name) - expected)) <= 1e-6 * np.max(np.abs(expected)), name


@pytest.mark.parametrize("backend", [pytest.param("numpy", marks=pytest.mark.slow), "c"])
def test_the_sensitivities_hold_without_their_error_control(oscillator, backend):
    full = oscillator.simulate(backend=backend, sensitivities=["k"])
    state_only = oscillator.simulate(backend=backend, sensitivities=["k"], sensitivity_error_control=False)
    np.testing.assert_allclose(state_only.sensitivity("x", "k"), full.sensitivity("x", "k"), atol=1e-8)


def test_the_c_sensitivities_without_error_control_take_the_plain_runs_steps():
    subject, names = model("double_pendulum"), ["m2", "l1", "theta1.start", "theta2.velocity"]
    plain = subject.simulate(backend="c", stop=2.0)
    state_only = subject.simulate(backend="c", stop=2.0, sensitivities=names, sensitivity_error_control=False)
    full = subject.simulate(backend="c", stop=2.0, sensitivities=names)
    steps = lambda run: dict(run.summary.counters)["accepted"]     # noqa: E731
    # only the first step's guess (HNW I, II.4, over every component) differs from the plain run's
    assert abs(steps(state_only) - steps(plain)) <= 3 and steps(state_only) < steps(full)
    np.testing.assert_allclose(state_only["theta1"], plain["theta1"], atol=1e-6)


@pytest.mark.parametrize("names, options, message", [
    (["kk"], {}, "'kk' is neither a parameter nor a start value of model Oscillator; did you mean 'k'?"),
    (["x.begin"], {}, "'x.begin' is neither a parameter nor a start value"),
    (["k", "k"], {}, "named twice"),
    (["k"], {"integrator": "rk4", "step": 0.01}, "adaptive integrator"),
    (["k"], {"backend": "c", "integrator": "rk4", "step": 0.01}, "need an adaptive integrator"),
    (["k"], {"backend": "c", "integrator": "taylor"}, "its Taylor series are generated for the equations of motion"),
])
def test_bad_directions_are_refused_with_a_message(oscillator, names, options, message):
    options = {"backend": "numpy", **options}
    with pytest.raises(LagError) as raised:
        oscillator.simulate(sensitivities=names, **options)
    assert message in raised.value.render()


# The default run takes the holonomic pendulum in C and the nonholonomic penny on NumPy; the other
# pairs are slow.
@pytest.mark.parametrize("library, columns, names, backend", [
    pytest.param(library, columns, names, backend,
                 marks=() if (library, backend) in {("cartesian_pendulum", "c"), ("rolling_penny", "numpy")}
                 else pytest.mark.slow)
    for library, columns, names in [
        # the rod's length moves the constraint itself; x.start alone leaves it and is projected back
        ("cartesian_pendulum", ("x", "y", "multiplier(rod)", "tension"),
         {"l": 1.0, "theta0": 0.5, "x.start": np.sin(0.5), "y.velocity": 0.0}),
        ("rolling_penny", ("x", "y"), {"alpha": 0.2, "theta.velocity": 1.0, "phi.velocity": 0.0})]
    for backend in ("numpy", "c")])
def test_constrained_sensitivities_agree_with_central_differences(library, columns, names, backend):
    subject = model(library)
    run = subject.simulate(backend=backend, sensitivities=list(names), stop=2.0, rtol=1e-12, atol=1e-14)
    assert run.summary.residual_max < 1e-9
    for column in columns:
        for name, base in names.items():
            expected = central_difference(subject, None, name, column, base, 2.0, h=1e-5, backend=backend)
            assert_agrees(run.sensitivity(column, name), expected, (column, name))


def test_a_parameter_defined_by_another_follows_it(oscillator):
    # k = 2 h defined from h: d x/d h = 2 d x/d k; with k set, h no longer moves anything.
    derived = Model(SourceFile("derived.lag", OSCILLATOR.replace("parameter k = 3.0 [N/m];",
                                                               "parameter h = 1.5 [N/m];\n  parameter k = 2*h [N/m];")))
    by_h = derived.simulate(backend="numpy", sensitivities=["h"]).sensitivity("x", "h")
    by_k = oscillator.simulate(backend="numpy", sensitivities=["k"]).sensitivity("x", "k")
    np.testing.assert_allclose(by_h, 2 * by_k, atol=1e-11)
    held = derived.simulate(backend="numpy", sensitivities=["h"], k=3.0).sensitivity("x", "h")
    np.testing.assert_array_equal(held, 0.0)


@pytest.mark.parametrize("integrator", [pytest.param("dopri5", marks=pytest.mark.slow), "radau5",
                                        pytest.param("auto", marks=pytest.mark.slow)])
def test_every_adaptive_integrator_gives_the_same_sensitivities(integrator):
    subject, names = model("damped_driven_pendulum"), ["b", "theta.start"]
    reference = subject.simulate(backend="numpy", stop=3, sensitivities=names, rtol=1e-12, atol=1e-14)
    run = subject.simulate(backend="numpy", stop=3, sensitivities=names, integrator=integrator, rtol=1e-9,
                           atol=1e-11)
    for name in names:
        np.testing.assert_allclose(run.sensitivity("theta", name), reference.sensitivity("theta", name), atol=1e-6)
