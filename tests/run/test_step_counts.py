"""dopri5 and dop853 take no more steps than scipy's RK45 and DOP853 on a smooth problem; the NumPy
backend's summary counts the steps scipy rejects.

Same pairs, same error norm, same starting-step algorithm and same controller constants: on the
Kepler ellipse (eccentricity 0.44, a little over three orbits) both codes take the very same
trials, accepted and rejected, at every tolerance. scipy does not report its steps; it spends
12 (DOP853) or 6 (RK45) right-hand sides on every trial and 2 before the first, which gives them.
(On a chaotic problem the counts differ by a few steps either way, from round-off growing.)
"""
from __future__ import annotations

import pytest

from tests.conftest import library_model

STOP = 20.0
METHODS = [("dop853", "DOP853", 12), ("dopri5", "RK45", 6)]


def kepler(t, y):
    """Kepler's problem in polar coordinates with G M = 1, as models/kepler.lag has it."""
    r, _, r_dot, theta_dot = y
    return [r_dot, theta_dot, r * theta_dot ** 2 - 1 / r ** 2, -2 * r_dot * theta_dot / r]


def scipy_trials(method: str, rhs_per_trial: int, rtol: float, atol: float) -> int:
    from scipy.integrate import solve_ivp
    solution = solve_ivp(kepler, (0.0, STOP), [1.0, 0.0, 0.0, 1.2], method=method, rtol=rtol, atol=atol)
    assert solution.status == 0
    trials, remainder = divmod(solution.nfev - 2, rhs_per_trial)
    assert remainder == 0
    return trials


@pytest.fixture(scope="module")
def model():
    return library_model("kepler")


@pytest.mark.parametrize("integrator, method, rhs_per_trial", METHODS)
@pytest.mark.parametrize("rtol", [1e-4, 1e-7, 1e-10, 1e-12])
def test_no_more_steps_than_scipy(model, integrator, method, rhs_per_trial, rtol):
    summary = model.simulate("ellipse", integrator=integrator, rtol=rtol, atol=rtol / 100, stop=STOP,
                             interval=STOP).summary
    ours = summary.count("accepted") + summary.count("rejected")
    assert ours <= scipy_trials(method, rhs_per_trial, rtol, rtol / 100)


@pytest.mark.parametrize("integrator", ["dop853", "dopri5"])
def test_the_numpy_summary_counts_scipys_rejected_steps(model, integrator):
    """The NumPy backend steps scipy's pairs itself and counts each step's trials from the
    right-hand sides it took, so its summary reports the rejected steps: the very same as the C
    code's here (module docstring)."""
    numpy_run, c_run = (model.simulate("ellipse", backend, integrator=integrator, rtol=1e-6, atol=1e-12, stop=STOP,
                                       interval=STOP).summary for backend in ("numpy", "c"))
    assert numpy_run.count("rejected") == c_run.count("rejected") > 0
    assert numpy_run.count("accepted") == c_run.count("accepted")
    assert f"{numpy_run.count('rejected')} rejected" in numpy_run.render()


def test_the_numpy_summary_says_what_scipy_does_not_count(model):
    summary = model.simulate("ellipse", "numpy", integrator="radau5", stop=2.0).summary
    assert summary.count("rejected") is None
    assert ", rejected: not counted by scipy's Radau, " in summary.render()
