"""Extreme and long cases, short versions of benchmarks/stability/: long Kepler runs with the
symplectic method, mass ratios of 1e8 and lengths from 1e-6 to 1e6 m, the stiff FPU chain's
adiabatic invariant."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from tests.conftest import library_model
from tests.run.test_ivp_test_set import rigid_pendulum_angle

G = 9.81


def kepler_energy_errors(orbits: int, eccentricity: float, scene: str, **options):
    """Relative energy error |E(t) - E(0)| / |E(0)| of models/kepler.lag (G M = 1) started at
    perihelion r = 1, every tenth of a period for `orbits` periods."""
    period = 2 * math.pi * (1 / (1 - eccentricity)) ** 1.5          # a = r_p / (1 - e)
    result = library_model("kepler").simulate(
        scene, set={"theta.velocity": math.sqrt(1 + eccentricity)}, stop=orbits * period,
        interval=period / 10, **options)
    energy = result["energy"]
    return np.abs(energy - energy[0]) / abs(energy[0])


def first_and_last_tenth(values: np.ndarray) -> tuple[float, float]:
    tenth = len(values) // 10
    return float(np.max(values[:tenth])), float(np.max(values[-tenth:]))


def test_gauss_keeps_the_kepler_energy_error_bounded():
    """e = 0.6 over 100 orbits: the symplectic Gauss method's energy error oscillates without
    growing (measured 1.57e-8 in the first ten orbits, 1.63e-8 in the last ten); dop853 at
    rtol 1e-8, a smaller error at first, drifts (5.0e-8, then 5.6e-7)."""
    early, late = first_and_last_tenth(kepler_energy_errors(100, 0.6, "symplectic", step=0.05))
    assert late < 1e-7 and late < 1.2 * early, (early, late)
    early, late = first_and_last_tenth(kepler_energy_errors(100, 0.6, "ellipse", rtol=1e-8, atol=1e-10))
    assert late > 5 * early, (early, late)


@pytest.mark.parametrize("M, m", [(1e8, 1.0), (1e-8, 1.0)], ids=["heavy-wedge", "light-wedge"])
def test_block_on_wedge_at_extreme_mass_ratios(M, m):
    """From rest both move with constant accelerations (models/wedge.lag):
    x'' = -m g sin a cos a / (M + m sin^2 a), s'' = (M + m) g sin a / (M + m sin^2 a)."""
    result = library_model("wedge").simulate("slide", M=M, m=m)
    a = 0.5
    denominator = M + m * math.sin(a) ** 2
    for name, acceleration in (("x", -m * G * math.sin(a) * math.cos(a) / denominator),
                               ("s", (M + m) * G * math.sin(a) / denominator)):
        exact = acceleration / 2 * result.t ** 2
        assert np.max(np.abs(result[name] - exact)) < 1e-12 * np.max(np.abs(exact))


def test_double_pendulum_with_a_light_lower_bob_swings_like_a_simple_pendulum():
    result = library_model("double_pendulum").simulate("chaos", m2=1e-8, stop=5.0)
    # measured 5e-8: the lower bob pulls on the upper one with a force of order m2 g
    assert np.max(np.abs(result["theta1"] - rigid_pendulum_angle(result.t))) < 1e-6


def test_double_pendulum_with_a_light_upper_bob_stays_finite():
    """m1/m2 = 1e-8: the upper joint has almost no inertia and moves fast; the run completes
    and keeps the energy (measured: relative drift 4e-7 over 5 s in 2773 steps)."""
    result = library_model("double_pendulum").simulate("chaos", m1=1e-8, stop=5.0)
    assert np.all(np.isfinite(result.values))
    (_, start, drift), = result.summary.invariants
    assert drift < 1e-5 * abs(start)


@pytest.mark.parametrize("length", [1e-6, 1.0, 1e6])
@pytest.mark.parametrize("mass", [1e-8, 1e8])
def test_cartesian_pendulum_at_every_scale(length, mass):
    """A rod of 1 um to 1000 km: after one period, T = 4 sqrt(l/g) K(sin^2(theta0/2)), the bob
    is back where it started, and the rod keeps its length to round-off relative to l^2."""
    theta0 = 0.5
    period = 4 * math.sqrt(length / G) * ellipk(math.sin(theta0 / 2) ** 2)
    result = library_model("cartesian_pendulum").simulate(
        "swing", l=length, m=mass, stop=period, interval=period / 100, atol=1e-12 * length)
    x, y = result["x"], result["y"]
    assert abs(x[-1] - x[0]) < 1e-9 * length and abs(y[-1] - y[0]) < 1e-9 * length
    assert np.max(np.abs(x ** 2 + y ** 2 - length ** 2)) < 1e-15 * length ** 2
    # the rod's tension balances gravity at the start (at rest): -2 lambda l = m g cos(theta0)
    assert -2 * result["multiplier(rod)"][0] * length == pytest.approx(mass * G * math.cos(theta0), rel=1e-12)


def test_stiff_fpu_chain_keeps_its_oscillatory_energy():
    """omega = 50 over 200 s: the energy moves from the first stiff spring to the third, while
    the total oscillatory energy stays within O(1/omega) of 1 (measured: max |I - 1| = 3.1/omega;
    3.6/omega at omega = 25, 3.3/omega at 100, 3.4/omega at 200) and the energy is conserved."""
    omega = 50.0
    result = library_model("fermi_pasta_ulam").simulate("exchange")
    assert result["I"][0] == pytest.approx(1.0, rel=1e-14)
    assert np.max(np.abs(result["I"] - 1)) < 4 / omega
    assert result["I1"][-1] < 0.05 and result["I3"][-1] > 0.5
    (_, start, drift), = result.summary.invariants
    assert drift < 1e-7 * abs(start)
