"""Rigid bodies and chains against closed forms: the intermediate-axis instability and flip,
the heavy top's nutation limits, the gyroscope in gimbals' equations and precession, the normal
modes of the chain of oscillators, the stiff Fermi-Pasta-Ulam chain's adiabatic invariant and
energy exchange."""
from __future__ import annotations

import numpy as np
import pytest
import sympy
from scipy.optimize import brentq

from tests.mechanics.eom import equations_of, residual_rows, symbols_of
from tests.models.support import drift, gimbal_rows, mode_error, run


def test_intermediate_axis_wobble_grows_like_cosh_lambda_t():
    """Linearised Euler equations: w1 = eps cosh(lambda t), lambda = w2 sqrt((I2-I1)(I3-I2)/(I1 I3))
    = 0.577 /s (measured 2e-7 relative at t = 15, where the wobble is 3e-3 of the spin)."""
    rate = np.sqrt(1 * 1 / 3)
    result = run("free_rigid_body", "flip", stop=15, interval=5)
    assert np.allclose(result["omega1"], 1e-6 * np.cosh(rate * result.t), rtol=1e-5)


def test_intermediate_axis_flips_and_keeps_energy_and_momentum():
    """The body flips over: w2 goes from +1 to -1 rad/s (to within the wobble's energy), and back;
    the energy (I2 w^2/2 = 1 J) and p_phi, the angular momentum about space z, are kept."""
    result = run("free_rigid_body", "flip")
    w2 = result["omega2"]
    assert w2.min() < -0.999 and w2[-1] > -1.0
    flips = np.nonzero(np.diff(np.sign(w2)))[0]
    assert len(flips) >= 2
    assert drift(result, "energy") < 1e-10 and drift(result, "momentum(phi)") < 1e-10
    # |L| = I2 w2 while the spin is about axis 2
    assert result["momentum(phi)"][0] == pytest.approx(2.0)


def test_heavy_top_nutates_between_the_roots_of_the_effective_potential():
    """With p_phi, p_psi and E fixed, theta' = 0 where
    E = (p_phi - p_psi cos)^2/(2 I1 sin^2) + p_psi^2/(2 I3) + m g l cos: the top nods between
    theta0 = 0.6 and the other root (measured 1e-7 rad at a sampling of 1 ms)."""
    I1, I3, mgl = 1.0, 0.5, 0.5 * 9.81
    theta0, phi_dot, psi_dot = 0.6, 0.5, 20.0
    p_psi = I3 * (psi_dot + phi_dot * np.cos(theta0))
    p_phi = I1 * np.sin(theta0) ** 2 * phi_dot + p_psi * np.cos(theta0)

    def excess(theta):     # effective potential minus the energy
        return ((p_phi - p_psi * np.cos(theta)) ** 2 / (2 * I1 * np.sin(theta) ** 2) + mgl * np.cos(theta)
                - (p_phi - p_psi * np.cos(theta0)) ** 2 / (2 * I1 * np.sin(theta0) ** 2) - mgl * np.cos(theta0))

    other = brentq(excess, theta0 + 1e-9, 1.5)
    result = run("heavy_top", "nutation", interval=0.001)
    assert result["theta"].min() == pytest.approx(theta0, abs=1e-8)
    assert result["theta"].max() == pytest.approx(other, abs=1e-6)
    for name in ("energy", "momentum(phi)", "momentum(psi)"):
        assert drift(result, name) < 1e-9, name


def test_gimbal_gyroscope_has_the_closed_form_equations():
    """The rows derived through omega_body of the rings' and the rotor's rotation matrices equal
    the header's closed form at random states and parameters (measured 1e-16 relative)."""
    equations = equations_of("gimbal_gyroscope")
    s = symbols_of(equations)
    symbols = sorted(s.values(), key=sympy.default_sort_key)
    rng = np.random.default_rng(7)
    for derived, closed in zip(residual_rows(equations), gimbal_rows(s)):
        derived_at, closed_at = (sympy.lambdify(symbols, row, "numpy") for row in (derived, closed))
        for values in rng.uniform(0.2, 1.5, (20, len(symbols))):
            assert derived_at(*values) == pytest.approx(closed_at(*values), rel=1e-12, abs=1e-14)


def test_gimbal_gyroscope_precesses_at_m_g_l_over_c_w3():
    """Released at rest in phi, the fast rotor precesses on average at m g l / (C w3) =
    0.13625 rad/s (measured 2e-5 relative over 20 s, the nutation's share); w3, p_phi, p_psi and
    E are kept."""
    result = run("gimbal_gyroscope", "precession")
    spin = result["spin"]
    assert np.max(np.abs(spin - 300)) < 1e-9
    rate = 0.25 * 9.81 * 0.002 / (1.2e-4 * 300)
    assert result["phi"][-1] / result.t[-1] == pytest.approx(rate, rel=1e-3)
    for name in ("energy", "momentum(phi)", "momentum(psi)"):
        assert drift(result, name) < 1e-10, name


@pytest.mark.parametrize("j", [1, 2, 3, 4, 5])
def test_chain_of_oscillators_normal_modes(j):
    """Mode j: x[i] = A sin(i j pi/6) cos(omega_j t), omega_j = 2 sqrt(k/m) sin(j pi/12)
    (linear, so exact up to the integration: measured 1e-10 of the amplitude)."""
    shape = 0.1 * np.sin(np.arange(1, 6) * j * np.pi / 6)
    starts = {f"x[{i}].start": value for i, value in enumerate(shape, start=1)}
    result = run("coupled_oscillators", "mode1", **starts)
    names = [f"x[{i}]" for i in range(1, 6)]
    assert mode_error(result, names, shape, 2 * np.sqrt(4.0) * np.sin(j * np.pi / 12)) < 1e-8


def test_stiff_fpu_keeps_its_adiabatic_invariant_while_the_springs_exchange_energy():
    """Hairer-Lubich-Wanner I.5: the total oscillatory energy I stays within O(1/omega) of 1
    (measured max |I - 1| = 0.062 at omega = 50, half that at omega = 100), while the first
    stiff spring gives its energy to the others: at omega = 50, within t = 200, I1 falls to 0.003
    and I3, the far spring, rises to 1.03."""
    deviation = {}
    for omega in (50.0, 100.0):
        result = run("fermi_pasta_ulam", "exchange", omega=omega)
        assert result["I"][0] == pytest.approx(1.0, rel=1e-12)
        deviation[omega] = np.max(np.abs(result["I"] - 1))
        assert drift(result, "energy") < 1e-7      # dop853 at rtol 1e-10 over 30000 steps: 1.2e-8
        if omega == 50.0:
            assert result["I1"].min() < 0.05 and result["I3"].max() > 0.9
    assert deviation[50.0] < 0.1 and deviation[100.0] < 0.6 * deviation[50.0]
