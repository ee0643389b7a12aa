"""Pendulums of the library against their closed forms: the large-amplitude period, the
conical pendulum and the spherical pendulum's turning points, the normal modes of the double
and triple pendulums and of the chain, the cart-pole's instability, the bead on the hoop's
equilibrium, Foucault's precession, Kapitza's inverted pendulum, the rod's tension."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

from tests.models.support import chain_modes, crossings, drift, mode_error, period, run

G = 9.81


@pytest.mark.parametrize("theta0", [0.5, 2.5, 3.1])
def test_large_amplitude_period_is_4K_sqrt_l_over_g(theta0):
    """P = 4 K(sin(theta0/2)) sqrt(l/g): at P/2 the bob is at -theta0, at P back at theta0
    (measured worst: 3e-10 rad)."""
    P = 4 * ellipk(np.sin(theta0 / 2) ** 2) * np.sqrt(1.0 / G)   # scipy's K takes k^2
    result = run("pendulum", "swing", theta0=theta0, stop=P, interval=P / 2)
    assert result["theta"][1] == pytest.approx(-theta0, abs=1e-8)
    assert result["theta"][2] == pytest.approx(theta0, abs=1e-8)
    assert abs(result["der(theta)"][2]) < 1e-7
    assert drift(result, "energy") < 1e-9


def test_conical_pendulum_keeps_its_angle():
    """phi' = sqrt(g/(l cos(theta0))) is a steady circle (measured: theta within 1e-12)."""
    theta0 = 1.0
    rate = np.sqrt(G / np.cos(theta0))
    result = run("spherical_pendulum", "precession", **{"phi.velocity": rate})
    assert np.max(np.abs(result["theta"] - theta0)) < 1e-9
    assert np.max(np.abs(result["phi"] - rate * result.t)) < 1e-8


def test_spherical_pendulum_turns_where_the_effective_potential_says():
    """theta' = 0 where E = p_phi^2/(2 m l^2 sin^2) - m g l cos: the other turning point of the
    precession scene, and p_phi and E kept (measured: 2e-7 rad at the sampling of 1 ms)."""
    theta0, rate = 1.0, 2.0
    result = run("spherical_pendulum", "precession", interval=0.001)
    p_phi = np.sin(theta0) ** 2 * rate
    energy = p_phi ** 2 / (2 * np.sin(theta0) ** 2) - G * np.cos(theta0)
    other = brentq(lambda th: p_phi ** 2 / (2 * np.sin(th) ** 2) - G * np.cos(th) - energy, 0.05, theta0 - 1e-6)
    assert result["theta"].min() == pytest.approx(other, abs=1e-6)
    assert result["theta"].max() == pytest.approx(theta0, abs=1e-9)
    assert drift(result, "momentum(phi)") < 1e-8 and drift(result, "energy") < 1e-8


@pytest.mark.parametrize("mode", [0, 1])
def test_double_pendulum_normal_modes(mode):
    """Equal masses and rods: omega^2 = (g/l)(2 -+ sqrt 2), shapes theta2/theta1 = +-sqrt 2
    (amplitude 1e-5: measured error 2e-5 of the amplitude over 20 s)."""
    squares, shapes = chain_modes(2)
    assert squares[mode] == pytest.approx(2 - np.sqrt(2) if mode == 0 else 2 + np.sqrt(2))
    shape = 1e-5 * shapes[:, mode]
    result = run("double_pendulum", "chaos", **{"theta1.start": shape[0], "theta2.start": shape[1]})
    assert mode_error(result, ["theta1", "theta2"], shape, np.sqrt(G * squares[mode])) < 1e-4


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_triple_pendulum_normal_modes(mode):
    """omega^2 = (g/l) x the roots of x^3 - 9 x^2 + 18 x - 6 (0.41577, 2.29428, 6.28995)."""
    squares, shapes = chain_modes(3)
    assert np.allclose(np.sort(np.roots([1, -9, 18, -6])), squares)
    shape = 1e-5 * shapes[:, mode]
    starts = {f"theta{i + 1}.start": value for i, value in enumerate(shape)}
    result = run("triple_pendulum", "slowest_mode", **starts)
    assert mode_error(result, ["theta1", "theta2", "theta3"], shape, np.sqrt(G * squares[mode])) < 1e-4


def test_pendulum_chain_slowest_mode():
    """The twelve-link chain started in its slowest mode swings in it (amplitude 1e-6)."""
    squares, shapes = chain_modes(12)
    shape = 1e-6 * shapes[:, 0]
    starts = {f"theta[{i + 1}].start": value for i, value in enumerate(shape)}
    result = run("pendulum_chain", "swing", stop=5, **starts)
    assert mode_error(result, ["theta[1]", "theta[n]"], shape[[0, -1]], np.sqrt(G * squares[0])) < 1e-4


def test_cart_pole_falls_like_cosh_and_keeps_its_momentum():
    """Near the top theta = theta0 cosh(lambda t), lambda = sqrt((M + m) g/(M l)) (theta0 = 1e-7:
    measured 3e-8 relative at t = 1.5); the horizontal momentum stays 0 during the full fall."""
    rate = np.sqrt(1.1 * G / (1.0 * 0.5))
    result = run("cart_pole", "fall", stop=1.5, interval=0.5, atol=1e-20, **{"theta.start": 1e-7})
    assert np.allclose(result["theta"], 1e-7 * np.cosh(rate * result.t), rtol=1e-6, atol=0)
    fall = run("cart_pole", "fall")
    assert np.max(np.abs(fall["momentum(x)"])) < 1e-10 and drift(fall, "energy") < 1e-9
    assert np.ptp(fall["theta"]) > 3       # it really fell and swung through the bottom


def test_bead_rests_at_cos_theta_g_over_omega2_R_and_oscillates_about_it():
    """cos(theta_e) = g/(omega^2 R); the small oscillation about it has Omega = omega sin(theta_e)
    (measured: 3e-11 rad, period 6e-9 relative); the lab energy changes, the Jacobi integral not."""
    omega, R = 6.0, 0.5
    theta_e = np.arccos(G / (omega ** 2 * R))
    rest = run("bead_on_hoop", "off_axis", **{"theta.start": theta_e})
    assert np.max(np.abs(rest["theta"] - theta_e)) < 1e-9
    swing = run("bead_on_hoop", "off_axis", interval=0.001, **{"theta.start": theta_e + 1e-4})
    assert period(swing.t, swing["theta"]) == pytest.approx(2 * np.pi / (omega * np.sin(theta_e)), rel=1e-6)
    big = run("bead_on_hoop", "off_axis")
    assert drift(big, "energy") < 1e-10 and np.ptp(big["lab_energy"]) > 1e-3


def test_foucault_plane_turns_at_omega_sin_latitude():
    """At each turning point the swing's azimuth is -Omega sin(lat) t (mod pi): 0.198 rad in an
    hour (measured 7.5e-4 relative, the effect of the finite amplitude and of Omega cos(lat))."""
    result = run("foucault_pendulum", "hour")
    radius = np.hypot(result["x"], result["y"])
    last = np.argmax(radius[-200:]) + len(radius) - 200        # the last turning point
    azimuth = np.arctan2(result["y"][last], result["x"][last])
    expected = -7.2921159e-5 * np.sin(0.852539) * result.t[last]
    turned = (azimuth - expected + np.pi / 2) % np.pi - np.pi / 2
    assert abs(turned) < 2e-3 * abs(expected)
    assert drift(result, "energy") < 1e-8


@pytest.mark.parametrize("omega, stays", [(100.0, True), (20.0, False)])
def test_kapitza_pendulum_stands_up_only_when_shaken_fast(omega, stays):
    """The top is stable when A omega > sqrt(2 g l) (4.43 m/s): 10 m/s stands, 2 m/s falls."""
    result = run("driven_support", "inverted", omega=omega)
    assert (np.max(np.abs(result["theta"] - np.pi)) < 0.3) == stays


def test_kapitza_slow_oscillation_frequency():
    """Averaged over the shaking, Omega^2 = (A omega)^2/(2 l^2) - g/l = 40.19 s^-2, period
    0.991 s (Kapitza's formula is itself first order in 1/omega: measured agreement 0.6 %)."""
    fast = 2 * np.pi / 100
    result = run("driven_support", "inverted", stop=5 * 16 * fast * 16 // 16, interval=fast / 16,
                 **{"theta.start": np.pi - 0.02})
    smooth = np.convolve(result["theta"] - np.pi, np.ones(16) / 16, mode="valid")
    times = crossings(result.t[:len(smooth)], smooth)
    slow = 2 * np.mean(np.diff(times))
    assert slow == pytest.approx(2 * np.pi / np.sqrt(0.1 ** 2 * 100 ** 2 / 2 - G), rel=0.02)


def test_cartesian_pendulum_tension_is_m_g_3cos_minus_2cos0():
    """The rod's tension from the multiplier: m g (3 cos(theta) - 2 cos(theta0)), cos = -y/l."""
    result = run("cartesian_pendulum", "swing")
    expected = G * (3 * -result["y"] - 2 * np.cos(0.5))
    assert np.max(np.abs(result["tension"] - expected)) < 1e-8
    assert result.summary.residual_max < 1e-12


def test_damped_pendulum_decays_as_the_linear_oscillator():
    """Undriven and small: theta0 e^(-gt)(cos(wd t) + g/wd sin(wd t)), g = b/(2 m l^2),
    wd = sqrt(g/l - g^2) (amplitude 1e-5: measured 1e-10 rad)."""
    result = run("damped_driven_pendulum", "driven", A=0.0, **{"theta.start": 1e-5})
    gamma = 0.5 / 2
    wd = np.sqrt(G - gamma ** 2)
    t = result.t
    expected = 1e-5 * np.exp(-gamma * t) * (np.cos(wd * t) + gamma / wd * np.sin(wd * t))
    assert np.max(np.abs(result["theta"] - expected)) < 1e-10
