"""The NumPy backend's fixed-step integrators rk4 and gauss, and the Gauss-Legendre coefficients.

The test problem is the pendulum of test_gauss.py (L = m l^2 q'^2 / 2 + m g l cos q), here as
NumPy functions that take a state of shape (2,) or (2, B).  The C versions, compiled with the
test harness, must give the same numbers to round-off.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.run.c_harness import build_and_run
from tests.run.test_gauss import (G, L, M, PENDULUM_C, Q0, RUN_C, STEPS_FOR_ORDER, energy, exact_tableau,
                                  parse_runs, reference)

try:
    from lagdsl.integrators.python.fixed_step import IntegrationFailure, integrate_gauss, integrate_rk4
    from lagdsl.integrators.python.gauss_coefficients import gauss_legendre_tableau, symplectic_mu
except ImportError:         # the package is not installed: use the repository
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from lagdsl.integrators.python.fixed_step import IntegrationFailure, integrate_gauss, integrate_rk4
    from lagdsl.integrators.python.gauss_coefficients import gauss_legendre_tableau, symplectic_mu

Y0 = np.array([Q0, 0.0])


def rhs(t, y):
    return np.array([y[1], -G / L * np.sin(y[0])])


def hamilton_rhs(t, z):
    return np.array([z[1] / (M * L * L), -M * G * L * np.sin(z[0])])


def to_canonical(t, y):
    return np.array([y[0], M * L * L * y[1]])


def from_canonical(t, z):
    return np.array([z[0], z[1] / (M * L * L)])


def gauss(t_grid, y0, step, stages):
    return integrate_gauss(hamilton_rhs, to_canonical, from_canonical, t_grid, y0, step, stages)


def output_grid(t_end, dt):
    """The output times as the runner makes them: k dt, the last one clipped to t_end."""
    last = int(np.floor(t_end / dt + 1e-9))
    times = dt * np.arange(last + 1)
    times[-1] = min(times[-1], t_end)
    return times


def observed_orders(errors):
    return np.log2(np.array(errors[:-1]) / errors[1:])


# ---- the coefficients --------------------------------------------------------------------------

@pytest.mark.parametrize("s", range(1, 7))
def test_tableau_is_gauss_legendre(s):
    """Against 40-digit values; the order conditions B(2s) and C(s); symplecticity."""
    mpmath = pytest.importorskip("mpmath")
    c, b, A = gauss_legendre_tableau(s)
    with mpmath.workdps(40):
        c_exact, b_exact, a_exact = (np.array(v, dtype=float) for v in exact_tableau(mpmath, s))
    assert np.max(np.abs(c - c_exact)) < 4e-16
    assert np.max(np.abs(b - b_exact)) < 4e-16
    assert np.max(np.abs(A - a_exact)) < 4e-16
    nodes, weights = np.polynomial.legendre.leggauss(s)
    assert np.allclose(c, (1 + nodes) / 2, rtol=0, atol=1e-15)
    assert np.allclose(b, weights / 2, rtol=0, atol=1e-15)
    for k in range(1, 2 * s + 1):
        assert abs(b @ c ** (k - 1) - 1 / k) < 1e-15
    for k in range(1, s + 1):
        assert np.allclose(A @ c ** (k - 1), c ** k / k, rtol=0, atol=1e-15)
    assert np.allclose(b[:, None] * A + (b[:, None] * A).T, np.outer(b, b), rtol=0, atol=1e-16)
    mu = symplectic_mu(b, A)
    assert np.all(mu + mu.T == 1) and np.allclose(mu * b, A, rtol=0, atol=4e-16)


# ---- orders and energy -------------------------------------------------------------------------

def test_rk4_order_4():
    t_end = 3.0
    exact = reference(t_end).y[:, -1]
    errors = [np.max(np.abs(integrate_rk4(rhs, [0.0, t_end], Y0, h)[0][-1] - exact))
              for h in (0.1, 0.05, 0.025)]
    assert abs(observed_orders(errors)[-1] - 4) < 0.2, errors


@pytest.mark.parametrize("stages", [1, 2, 3])
def test_gauss_order_2s(stages):
    t_end = 3.0
    exact = reference(t_end).y[:, -1]
    errors = [np.max(np.abs(gauss([0.0, t_end], Y0, h, stages)[0][-1] - exact))
              for h in STEPS_FOR_ORDER[stages]]
    assert abs(observed_orders(errors)[-1] - 2 * stages) < 0.3, errors


@pytest.mark.slow
def test_gauss_energy_bounded_while_rk4_drifts():
    """2000 steps of h = 0.1: the energy error of gauss (s = 2) oscillates with a constant
    amplitude; that of rk4, not symplectic, grows linearly."""
    t_grid = 0.1 * np.arange(2001)
    h0 = energy(Q0, 0.0)
    for integrate, growing in ((lambda: gauss(t_grid, Y0, 0.1, 2)[0], False),
                               (lambda: integrate_rk4(rhs, t_grid, Y0, 0.1)[0], True)):
        Y = integrate()
        error = np.abs(energy(Y[:, 0], Y[:, 1]) - h0) / abs(h0)
        first, last = error[:200].max(), error[-200:].max()
        assert (last > 5 * first) if growing else (abs(last / first - 1) < 0.01), (first, last)


def test_step_count_and_last_step():
    _, stats = gauss(output_grid(10, 0.5), Y0, 0.01, 2)
    assert stats["accepted"] == 1000 and stats["rhs_evals"] == 2 * stats["newton_iters"]
    _, stats = integrate_rk4(rhs, [0.0, 0.7], Y0, 0.1)
    assert stats["accepted"] == 7 and stats["rhs_evals"] == 4 * 7 + 1
    Y, stats = gauss([0.0, 0.25, 1.0], Y0, 0.3, 3)
    assert stats["accepted"] == 4 and Y.shape == (3, 2)


# ---- batches -----------------------------------------------------------------------------------

def test_batch_equals_separate_runs():
    starts = np.array([[0.3, 1.2, 2.5], [0.0, -0.4, 1.0]])       # (n, B): three initial states
    t_grid = output_grid(5, 0.13)
    for integrate in (lambda y0: integrate_rk4(rhs, t_grid, y0, 0.05)[0],
                      lambda y0: gauss(t_grid, y0, 0.1, 3)[0]):
        together = integrate(starts)
        assert together.shape == (len(t_grid), 2, 3)
        for column in range(3):
            alone = integrate(starts[:, column])
            assert np.max(np.abs(together[:, :, column] - alone)) <= 1e-14


# ---- C and Python ------------------------------------------------------------------------------

COMPARE_MAIN_C = RUN_C + r"""
int main(int argc, char **argv)
{
    static lag_stepper s;
    lag_system sys;
    lag_options opt;
    model_unused();
    model_parameters(&sys);
    memset(&opt, 0, sizeof opt);
    if (argc != 5)
        return 2;
    opt.stages = atoi(argv[1]);
    opt.step = r_strtod(argv[2], NULL);
    printf("run\n");
    run(&s, &sys, &opt, r_strtod(argv[3], NULL), r_strtod(argv[4], NULL), 0, 0);
    return 0;
}
"""


@pytest.mark.parametrize("integrator, stages, step", [("gauss", 2, 0.1), ("gauss", 3, 0.07),
                                                      ("gauss", 6, 0.3), ("rk4", 0, 0.05)])
def test_c_and_python_agree(tmp_path, integrator, stages, step):
    """The same steps, iteration and dense output: the grid values agree to round-off (the grid
    0.13 k falls between the steps, except at t_end)."""
    t_end, dt = 10.4, 0.13
    args = [str(stages), str(step), str(t_end), str(dt)]
    iterations = "#define ITERATIONS(s) 0L\n" if integrator == "rk4" else ""
    text = build_and_run(tmp_path, PENDULUM_C, integrator, iterations + COMPARE_MAIN_C, args)
    c_run = parse_runs(text)[0]
    t_grid = output_grid(t_end, dt)
    if integrator == "gauss":
        Y, stats = gauss(t_grid, Y0, step, stages)
    else:
        Y, stats = integrate_rk4(rhs, t_grid, Y0, step)
    assert c_run["stats"]["status"] == 0 and c_run["stats"]["accepted"] == stats["accepted"]
    assert np.array_equal(c_run["grid"][:, 0], t_grid[1:])
    assert np.max(np.abs(c_run["grid"][:, 1:] - Y[1:])) < 1e-12


# ---- failures ----------------------------------------------------------------------------------

def test_rk4_failure_carries_the_partial_results():
    """y' = y^2, y(0) = 1 blows up at t = 1: the rows before are delivered, the last good state
    is reported."""
    t_grid = output_grid(2, 0.1)
    with pytest.raises(IntegrationFailure) as caught, np.errstate(over="ignore", invalid="ignore"):
        integrate_rk4(lambda t, y: y * y, t_grid, np.array([1.0]), 0.01)
    failure = caught.value
    assert isinstance(failure, RuntimeError)
    assert 10 <= failure.completed < len(t_grid) and failure.Y.shape == (failure.completed, 1)
    assert np.allclose(failure.Y[:9, 0], 1 / (1 - t_grid[:9]), rtol=1e-3)
    assert failure.t > 0.9 and np.all(np.isfinite(failure.y)) and failure.y.shape == (1,)


@pytest.mark.parametrize("batch", [False, True])
def test_gauss_failure_carries_the_partial_results(batch):
    """H = p^2/2 - q^4/4 from q = 1, p = 1/sqrt(2) runs off to infinity at t = sqrt(2) along
    q = 1/(1 - t/sqrt(2)): the fixed-point iteration fails there; the rows before are delivered
    and the last good state is reported, in the shape of y0 (the batch has a second, slower column)."""
    def quartic(t, z):
        return np.array([z[1], z[0] ** 3])

    def identity(t, x):
        return np.array(x)

    starts = np.array([[1.0, 0.5], [2 ** -0.5, 0.0]]) if batch else np.array([1.0, 2 ** -0.5])
    t_grid = output_grid(2, 0.1)
    with pytest.raises(IntegrationFailure) as caught, np.errstate(over="ignore", invalid="ignore"):
        integrate_gauss(quartic, identity, identity, t_grid, starts, 0.01, 3)
    failure = caught.value
    assert failure.status == 5 and "reduce the step" in str(failure)
    assert 12 <= failure.completed <= 15 and failure.Y.shape == (failure.completed,) + starts.shape
    first = failure.Y[:, 0, 0] if batch else failure.Y[:, 0]
    assert np.allclose(first[:13], 1 / (1 - t_grid[:13] / 2 ** 0.5), rtol=1e-6)    # t <= 1.2
    assert 1.3 < failure.t < 2 ** 0.5 and failure.y.shape == starts.shape and np.all(np.isfinite(failure.y))


def test_step_below_the_resolution_of_t_is_refused():
    for integrate in (lambda: integrate_rk4(rhs, [1e3, 1e3 + 1], Y0, 1e-14),
                      lambda: gauss([0.0, 1.0], Y0, 0.0, 2)):
        with pytest.raises(IntegrationFailure) as caught:
            integrate()
        assert caught.value.status == 3 and caught.value.completed == 1
