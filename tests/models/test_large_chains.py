"""The large chains of the library, which lagc lowers to loops (mechanics/families.py): the
200-mass FPU chain against SciPy on a vectorised NumPy right-hand side, and the 40-element
string against its discrete normal mode."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.models.support import drift, run


def fpu_rhs(n: int, omega: float = 50.0, mu: float = 1.0, kappa: float = 1.0):
    """The chain's equations as a user would write them with NumPy (pairs q[2i-1], q[2i])."""
    def rhs(t, y):
        q, v = y[:n], y[n:]
        force = np.zeros(n)
        stiff = mu * omega**2 / 2 * (q[1::2] - q[0::2])
        force[0::2] += stiff
        force[1::2] -= stiff
        soft = 4 * kappa * (q[2::2] - q[1:-1:2]) ** 3
        force[1:-1:2] += soft
        force[2::2] -= soft
        force[0] -= 4 * kappa * q[0] ** 3
        force[-1] -= 4 * kappa * q[-1] ** 3
        return np.concatenate([v, force / mu])
    return rhs


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_fpu_chain_follows_the_vectorised_numpy_equations(backend):
    result = run("fpu_chain", "spread", stop=1.0, backend=backend)
    reference = fpu_reference(result.t)
    for column, k in (("q[1]", 0), ("q[2]", 1), ("q[3]", 2)):
        assert np.max(np.abs(result[column] - reference.y[k])) < 1e-9
    assert result["I1"][0] == pytest.approx(1.0, rel=1e-12)     # the book's start: I = 1
    assert drift(result, "energy") < 1e-8       # rtol 1e-10


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_fpu_chain_with_the_nystrom_pair(backend):
    """rkn8 integrates q'' = a(q) (the chain's M is constant, its forces read positions only) over
    the positions alone: the same trajectory to 1e-9 at the scene's rtol 1e-10, and the energy
    to the tolerance. (Its efficiency at equal accuracy: benchmarks/large_systems.py --accuracy.)"""
    result = run("fpu_chain", "nystrom", stop=1.0, backend=backend)
    reference = fpu_reference(result.t)
    for column, k in (("q[1]", 0), ("q[2]", 1), ("q[3]", 2)):
        assert np.max(np.abs(result[column] - reference.y[k])) < 1e-9
    assert drift(result, "energy") < 1e-8


def test_the_nystrom_pair_is_the_same_on_both_backends():
    """The Python rkn8 mirrors rkn8.c operation for operation: the same steps, the same rows to
    round-off (the accelerations are evaluated in a different order by the two backends)."""
    c, numpy = (run("fpu_chain", "nystrom", stop=1.0, backend=b) for b in ("c", "numpy"))
    assert c.summary.counters == numpy.summary.counters
    assert np.max(np.abs(c.values - numpy.values)) < 1e-12


def fpu_reference(t):
    """The book's start (fpu_chain.lag) integrated by SciPy's DOP853 at rtol 1e-12."""
    n, omega = 200, 50.0
    y0 = np.zeros(2 * n)
    y0[0], y0[1], y0[n + 1] = (1 - 1 / omega) / np.sqrt(2), (1 + 1 / omega) / np.sqrt(2), np.sqrt(2)
    return solve_ivp(fpu_rhs(n), (0, t[-1]), y0, method="DOP853", rtol=1e-12, atol=1e-14, t_eval=t)


def test_fpu_chain_with_radau5_factors_banded_newton_matrices():
    """radau5's iteration matrices E(g) = g Dz + Dv + Dq/g are tridiagonal here: the band LU
    reaches the trajectory of the dense reference, and energy is kept to the tolerance."""
    result = run("fpu_chain", "implicit", stop=1.0, rtol=1e-10, atol=1e-12)
    reference = fpu_reference(result.t)
    for column, k in (("q[1]", 0), ("q[2]", 1), ("q[3]", 2)):
        assert np.max(np.abs(result[column] - reference.y[k])) < 1e-8      # 5.6e-10 measured
    assert drift(result, "energy") < 1e-7       # 3.3e-8: Radau IIA is not symplectic


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_fine_string_moves_in_its_second_mode(backend):
    result = run("fem_string_fine", "mode2", backend=backend)
    theta = 2 * np.pi / 41
    omega = np.sqrt(6 * (1 - np.cos(theta)) / (2 + np.cos(theta)))      # tension = rho = h = 1
    for column, i in (("u[1]", 1), ("u[10]", 10), ("u[21]", 21)):
        exact = 0.1 * np.sin(i * theta) * np.cos(omega * result.t)
        assert np.max(np.abs(result[column] - exact)) < 1e-9
