"""Constrained models against closed forms: the Atwood machine's acceleration and tension, the
swinging Atwood machine's start, the rolling penny (the seeds' corrected multipliers), the
rolling disk's wobble, the Chaplygin sledge's tanh, the ladder's contact forces, the two bodies on a sphere in angles and
in Cartesian coordinates, the block on the wedge, the chain in Cartesian coordinates against the
chain in angles."""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from tests.conftest import MODELS, model_file
from tests.models.support import drift, period, run

G = 9.81


def test_atwood_acceleration_and_tension():
    """d1'' = (m1 - m2) g/(m1 + m2), tension 2 m1 m2 g/(m1 + m2) (measured: 1e-15, 4e-15)."""
    m1, m2 = 3.0, 2.0
    result = run("atwood", "drop")
    a = (m1 - m2) * G / (m1 + m2)
    assert np.allclose(result["d1"], 1.0 + a * result.t ** 2 / 2, rtol=0, atol=1e-12)
    assert np.allclose(result["tension"], 2 * m1 * m2 * G / (m1 + m2), rtol=1e-12)
    assert np.max(np.abs(result["residual(string)"])) < 1e-12


def test_swinging_atwood_starts_as_its_equations_say_and_keeps_its_energy():
    """From rest r'' = g (m cos(theta) - M)/(M + m), theta'' = -g sin(theta)/r; third
    derivatives vanish at rest, so r(h) - r0 = r'' h^2/2 + O(h^4) (measured 3e-7 relative at
    h = 1e-3). Over the chaotic scene the energy drifts by 1e-10 J (of 44)."""
    M, m, r0, theta0, h = 4.5, 1.0, 1.0, 1.5, 1e-3
    start = run("swinging_atwood", "chaos", stop=h, interval=h)
    assert (start["r"][1] - r0) / (h ** 2 / 2) == pytest.approx(G * (m * np.cos(theta0) - M) / (M + m), rel=1e-5)
    assert (start["theta"][1] - theta0) / (h ** 2 / 2) == pytest.approx(-G * np.sin(theta0) / r0, rel=1e-5)
    chaos = run("swinging_atwood", "chaos")
    assert drift(chaos, "energy") < 1e-9
    assert np.ptp(chaos["theta"]) > 2 * np.pi       # it winds round the pulley


def test_rolling_penny_follows_the_corrected_closed_form():
    """theta'' = 0, phi'' = -2 g sin(alpha) sin(theta)/(3a), and the multipliers
    mu1 = m (2 g s sin(theta)^2 - 3 g s - 3 a cos(theta) phi' theta')/3,
    mu2 = -m sin(theta) (3 a phi' theta' + 2 g s cos(theta))/3 with s = sin(alpha) (the seeds'
    README; the lecture notes' mu1 = -m g sin(alpha) is wrong). Measured: 1e-12 relative."""
    m, a, alpha, theta0, w = 0.0025, 0.01, 0.2, 0.3, 1.0
    result = run("rolling_penny", "roll")
    t, s = result.t, np.sin(alpha)
    theta = theta0 + w * t
    c = 2 * G * s / (3 * a)
    phi = c / w ** 2 * (np.sin(theta) - np.sin(theta0) - w * t * np.cos(theta0))
    phi_dot = -c / w * (np.cos(theta0) - np.cos(theta))
    mu1 = m * (2 * G * s * np.sin(theta) ** 2 - 3 * G * s - 3 * a * np.cos(theta) * phi_dot * w) / 3
    mu2 = -m * np.sin(theta) * (3 * a * phi_dot * w + 2 * G * s * np.cos(theta)) / 3
    assert np.allclose(result["theta"], theta, rtol=1e-10, atol=1e-10)
    assert np.allclose(result["phi"], phi, rtol=1e-8, atol=1e-8)
    assert np.allclose(result["multiplier(roll_x)"], mu1, rtol=1e-8, atol=1e-14)
    assert np.allclose(result["multiplier(roll_y)"], mu2, rtol=1e-8, atol=1e-14)
    assert drift(result, "energy") < 1e-10       # J, of kinetic energies up to 1e-3 J


def test_rolling_disk_wobbles_at_the_linearised_frequency():
    """Rolling upright at W with a small tilt: the tilt oscillates at sqrt(4 (3 a W^2 - g)/(5 a))
    (measured 1e-9 relative); the energy is kept and the rolling constraints hold."""
    a, W = 0.05, 30.0
    result = run("rolling_disk", "wobble", stop=2, interval=0.0005, **{"theta.start": 1e-6})
    assert period(result.t, result["theta"]) == pytest.approx(2 * np.pi / np.sqrt(4 * (3 * a * W ** 2 - G) / (5 * a)),
                                                              rel=1e-6)
    curve = run("rolling_disk", "wobble", **{"theta.start": 0.4})
    assert drift(curve, "energy") < 1e-10 and curve.summary.residual_max < 1e-12
    assert np.ptp(curve["phi"]) > 1        # a leaning disk turns


@pytest.mark.parametrize("factor, stable", [(2.0, True), (0.5, False)])
def test_rolling_disk_upright_is_stable_above_g_over_3a(factor, stable):
    """Upright rolling is stable for W^2 > g/(3a): a tilt of 0.01 rad stays below 0.05 rad for
    3 s at W^2 = 2 g/(3a) (measured 0.030) and passes 0.5 rad at g/(6a) (measured 0.86, where
    the disk leans into a curve). Near the threshold the wobble is slow and wide."""
    result = run("rolling_disk", "wobble", stop=3, W=np.sqrt(factor * G / (3 * 0.05)), **{"theta.start": 0.01})
    assert np.max(np.abs(result["theta"])) < (0.05 if stable else np.inf)
    assert np.max(np.abs(result["theta"])) > (0.0 if stable else 0.5)


def test_chaplygin_sledge_speed_is_a_tanh():
    """v(t) = V tanh(m b V (t - t0)/(I + m b^2)), V = sqrt(2E/m): pushed backwards, it turns
    round and ends up sliding ahead at V (measured: 1e-11 m/s)."""
    m, I, b, v0, w0 = 1.0, 0.1, 0.5, -0.5, 3.0
    J = I + m * b ** 2
    V = np.sqrt((m * v0 ** 2 + J * w0 ** 2) / m)
    rate = m * b * V / J
    t0 = -np.arctanh(v0 / V) / rate
    result = run("chaplygin_sledge", "settle")
    assert np.allclose(result["v"], V * np.tanh(rate * (result.t - t0)), rtol=0, atol=1e-9)
    assert np.allclose(result["der(phi)"] ** 2, (m * V ** 2 - m * result["v"] ** 2) / J, rtol=0, atol=1e-9)
    assert drift(result, "energy") < 1e-10 and result.summary.residual_max < 1e-12


def test_two_bodies_on_the_equator_breathe_at_sqrt_2k_over_m_cos():
    """omega^2 = 2 k cos(alpha_e)^2/m, sin(alpha_e) = l0/(2R), from rest near alpha_e
    (amplitude 1e-4: measured 2e-9 relative)."""
    k, m, l0, R = 10.0, 1.0, 1.0, 1.0
    alpha_e = np.arcsin(l0 / (2 * R))
    result = run("sphere_two_bodies", "breathe", interval=0.001, alpha0=alpha_e + 1e-4)
    assert period(result.t, result["phi2"]) == pytest.approx(2 * np.pi / np.sqrt(2 * k / m) / np.cos(alpha_e), rel=1e-6)
    assert np.max(np.abs(result["theta1"] - np.pi / 2)) < 1e-12


@pytest.mark.slow
def test_two_bodies_on_a_sphere_agree_in_angles_and_in_cartesian_coordinates():
    """The same start in both models gives the same motion (measured 3e-10 m over 10 s);
    in Cartesian coordinates every component of the angular momentum is conserved and the
    constraints hold to rounding; in angles its z component."""
    angles = run("sphere_two_bodies", "tumble")
    cartesian = run("sphere_two_bodies_cartesian", "tumble")
    for name in ("x1", "y1", "z1", "x2", "y2", "z2"):
        assert np.max(np.abs(angles[name] - cartesian[name])) < 1e-8, name
    for name in ("Lx", "Ly", "Lz"):
        assert np.ptp(cartesian[name]) < 1e-10, name
    assert np.ptp(angles["Lz"]) < 1e-10
    assert np.max(np.abs(cartesian["residual(sphere1)"])) < 1e-12
    assert drift(cartesian, "energy") < 1e-9 and drift(angles, "energy") < 1e-9
    assert np.ptp(angles["z1"]) > 0.3        # the motion leaves the equator


def test_ladder_pushes_on_the_wall_and_floor_as_the_closed_form_says():
    """While both contacts hold, theta'^2 = (3 g/l)(s0 - sin(theta)) and the contact forces are
    N_wall = (3 m g/4) cos(theta) (3 sin(theta) - 2 s0) and
    N_floor = m g (1 - (3/4) cos(theta)^2 - (3/2) sin(theta) (s0 - sin(theta))), s0 = sin(theta0);
    the scene stops where N_wall = 0, sin(theta) = (2/3) s0, where N_floor = m g/4 (measured:
    theta'^2 4e-12/s^2, the forces 7e-11 N, the height 5e-13 m; the stop time is checked in
    tests/run/test_stop_condition.py)."""
    m, theta0 = 10.0, 1.2
    result = run("ladder", "slide")
    s, s0 = np.sin(result["theta"]), np.sin(theta0)
    cos2 = 1 - s ** 2
    assert np.allclose(result["der(theta)"] ** 2, 3 * G / 4 * (s0 - s), rtol=0, atol=1e-10)
    assert np.allclose(result["wall_force"], 3 * m * G / 4 * np.sqrt(cos2) * (3 * s - 2 * s0), rtol=0, atol=1e-9)
    assert np.allclose(result["floor_force"], m * G * (1 - 0.75 * cos2 - 1.5 * s * (s0 - s)), rtol=0, atol=1e-9)
    assert result["y"][-1] == pytest.approx(2 / 3 * result["y"][0], abs=1e-11)
    assert result["floor_force"][-1] == pytest.approx(m * G / 4, abs=1e-9)
    assert drift(result, "energy") < 1e-11 and result.summary.residual_max < 1e-12


def test_wedge_accelerations():
    """x'' = -m g sin cos/(M + m sin^2), s'' = (M + m) g sin/(M + m sin^2) (measured: rounding)."""
    M, m, alpha = 3.0, 1.0, 0.5
    d = M + m * np.sin(alpha) ** 2
    result = run("wedge", "slide")
    t = result.t
    assert np.allclose(result["x"], -m * G * np.sin(alpha) * np.cos(alpha) / d * t ** 2 / 2, atol=1e-12)
    assert np.allclose(result["s"], (M + m) * G * np.sin(alpha) / d * t ** 2 / 2, atol=1e-12)
    assert np.max(np.abs(result["momentum(x)"])) < 1e-12


@pytest.mark.slow
def test_the_chain_in_cartesian_coordinates_moves_as_the_chain_in_angles():
    """8 bobs on light links released straight at 0.5 rad: in Cartesian coordinates with one
    constraint per link (24 unknowns, the saddle-point system factored by the sparse LDLᵀ), and
    pendulum_chain.lag in absolute angles (x_n = Σ l sin θ_j, y_n = -Σ l cos θ_j). Over 3 s the
    last bob agrees to 1e-10 m (measured 4e-12), the energy drifts by 1e-11 of its 310 J at most
    (measured 6e-13), the constraints hold to 1e-13 (2e-15), and the C backend's sparse LDLᵀ
    agrees with the NumPy backend's dense LU to 1e-11 (2e-13)."""
    angles = (MODELS / "pendulum_chain.lag").read_text().replace("parameter n = 12", "parameter n = 8")
    angles = angles.replace("rtol = 1e-8, atol = 1e-10", "rtol = 1e-12, atol = 1e-12")
    angles = angles.replace("output theta[1], theta[n], energy;", "output x[n], y[n], energy;")
    reference = lagdsl.load(model_file(angles, "chain")).simulate(stop=3.0, interval=0.05)
    cartesian = {backend: run("cartesian_chain", backend=backend, stop=3.0, interval=0.05) for backend in ("c", "numpy")}
    result = cartesian["c"]
    assert np.max(np.abs(result["x[n]"] - reference["x[n]"])) < 1e-10
    assert np.max(np.abs(result["y[n]"] - reference["y[n]"])) < 1e-10
    assert result["energy"][0] == pytest.approx(reference["energy"][0], rel=1e-14)
    assert drift(result, "energy") < 1e-11 and result.summary.residual_max < 1e-13
    assert np.max(np.abs(result.values - cartesian["numpy"].values)) < 1e-11
