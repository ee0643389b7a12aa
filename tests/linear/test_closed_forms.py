"""Modes and equilibria against closed forms (issue 30, "How we will know it works")."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from lagdsl.errors import LagWarning
from lagdsl.linear import analyse
from tests.conftest import MODELS, slow_unless_kept
from tests.linear.support import lagc, model


def omegas(linear) -> np.ndarray:
    return np.array([m.omega for m in analyse(linear).modes])


def test_double_pendulum_normal_modes():
    """Equal masses and lengths: omega^2 = (g/l)(2 -+ sqrt 2)."""
    linear = model("double_pendulum").linearize(at={"theta1": 0, "theta2": 0})
    g, l = 9.81, 1.0
    expected = (g / l) * np.array([2 - math.sqrt(2), 2 + math.sqrt(2)])
    assert np.max(np.abs(omegas(linear) ** 2 / expected - 1)) < 1e-12
    modes = analyse(linear)
    assert modes.verdict == "marginally stable"
    assert np.allclose(modes.modes[0].shape.real, [1 / math.sqrt(2), 1], atol=1e-12)   # in phase
    assert np.allclose(modes.modes[1].shape.real, [-1 / math.sqrt(2), 1], atol=1e-12)  # against


def test_chain_of_200_masses_from_the_command_line(capsys, tmp_path):
    """Fixed ends: omega_k = 2 sqrt(k/m) sin(k pi/(2 (N + 1))), all N = 200 of them, to 1e-10;
    the mode shapes are sin(i k pi/(N + 1)). The banded eigensolver is used."""
    table = tmp_path / "modes.csv"
    status, out, err = lagc(capsys, "modes", MODELS / "spring_chain.lag", "--at", "x[1]=0", "-o", table)
    assert status == 0, err
    assert "eig_banded" in out and "verdict: marginally stable" in out
    rows = list(csv.DictReader(table.open()))
    N, k, m = 200, 4.0, 1.0
    index = np.arange(1, N + 1)
    expected = 2 * math.sqrt(k / m) * np.sin(index * math.pi / (2 * (N + 1)))
    found = np.array([float(r["omega"]) for r in rows])
    assert len(rows) == N and np.max(np.abs(found / expected - 1)) < 1e-10
    assert {"mode", "real", "imag", "omega", "frequency_hz", "damping_ratio"} <= set(rows[0])
    third = np.array([float(rows[2][f"x[{i}]"]) for i in index])
    shape = np.sin(index * 3 * math.pi / (N + 1))       # +-1 at i = 33, 34, 100, 101, 167, 168: the first is 1
    assert np.max(np.abs(third - shape / shape[32])) < 1e-8


@pytest.mark.parametrize("omega", [3.0, 4.0])
def test_bead_on_hoop_below_the_threshold(omega):
    """omega^2 < g/R = 19.62: the bottom is stable, at sqrt(g/R - omega^2)."""
    linear = model("bead_on_hoop").linearize(at={"theta": 0}, set={"omega": omega})
    modes = analyse(linear)
    assert modes.verdict == "marginally stable"
    assert abs(modes.modes[0].omega / math.sqrt(9.81 / 0.5 - omega ** 2) - 1) < 1e-12


@pytest.mark.parametrize("omega", [5.0, 6.0, 8.0])
def test_bead_on_hoop_above_the_threshold(omega):
    """omega^2 > g/R: the bottom is unstable; the equilibrium at cos theta* = g/(R omega^2) is
    stable, at omega sin theta*."""
    bead = model("bead_on_hoop")
    bottom = analyse(bead.linearize(at={"theta": 0}, set={"omega": omega}))
    assert bottom.verdict == "unstable"
    assert abs(bottom.modes[0].s.real / math.sqrt(omega ** 2 - 9.81 / 0.5) - 1) < 1e-12
    theta = math.acos(9.81 / (0.5 * omega ** 2))
    found = bead.equilibrium(guess={"theta": theta + 0.2}, set={"omega": omega})
    assert abs(found.at["theta"] - theta) < 1e-12
    off_axis = analyse(bead.linearize(at=found.at, set={"omega": omega}))
    assert off_axis.verdict == "marginally stable"
    assert abs(off_axis.modes[0].omega / (omega * math.sin(theta)) - 1) < 1e-10


@pytest.mark.parametrize("field", [2.83, 2.9, 3.0, 5.0])
def test_gyroscopic_stabilisation_holds(field):
    """omega_c^2 > 4 |omega_0^2| (= 8 here): marginally stable, at omega_c/2 +- sqrt(omega_c^2/4 - |omega_0^2|)."""
    linear = model("magnetic_saddle").linearize(at={"x": 0}, set={"B": field})
    assert np.max(np.abs(linear.G)) > 0 and np.all(np.diag(linear.K) < 0)       # a hill, held by G
    modes = analyse(linear)
    assert modes.verdict == "marginally stable" and "eig" in modes.method
    root = math.sqrt(field ** 2 / 4 - 2.0)
    assert np.allclose(sorted(omegas(linear)), [field / 2 - root, field / 2 + root], rtol=1e-12)


@pytest.mark.parametrize("field", [1.0, 2.0, 2.8, 2.828])
def test_gyroscopic_stabilisation_fails(field):
    """omega_c^2 < 4 |omega_0^2|: unstable."""
    modes = analyse(model("magnetic_saddle").linearize(at={"x": 0}, set={"B": field}))
    assert modes.verdict == "unstable"


def test_cartesian_pendulum_with_a_rod():
    """x, y with x^2 + y^2 = l^2: the rod eliminates y, and the frequency is sqrt(g/l)."""
    linear = model("cartesian_pendulum").linearize(at={"x": 0, "y": -1})
    assert linear.coordinates == ("x",) and linear.eliminated == ("y",)
    assert abs(omegas(linear)[0] / math.sqrt(9.81) - 1) < 1e-12
    assert linear.A.shape == (2, 2)


def test_cartesian_pendulum_equilibrium_found_on_the_rod():
    found = model("cartesian_pendulum").equilibrium(guess={"x": 0.3, "y": -0.8})
    assert abs(found.at["x"]) < 1e-12 and abs(found.at["y"] + 1) < 1e-12
    assert abs(found.multipliers[0] + 9.81 / 2) < 1e-12        # tension m g = -2 lambda l
    linear = model("cartesian_pendulum").linearize(at={"x": 0.3, "y": -0.8}, find=True)
    assert abs(omegas(linear)[0] / math.sqrt(9.81) - 1) < 1e-12


def test_cart_pole_upright_is_unstable_at_the_textbook_rate():
    """Near the top the fall grows like exp(lambda t), lambda = sqrt((M + m) g/(M l)); x is free."""
    modes = analyse(model("cart_pole").linearize(at={"theta": 0}))
    assert modes.verdict == "unstable"
    assert abs(modes.modes[-1].s.real / math.sqrt(1.1 * 9.81 / 0.5) - 1) < 1e-12
    assert modes.modes[0].omega == 0 and modes.modes[0].verdict == "marginally stable"


def test_second_order_split():
    """The cart-pole's feedback force: a damping D and a gyroscopic G from the rate gains, a
    circulatory N from the angle gain on the cart (not symmetric)."""
    linear = model("cart_pole_lqr").linearize(at={"theta": 0})
    for symmetric in (linear.M, linear.D, linear.K):
        assert np.array_equal(symmetric, symmetric.T)
    for skew in (linear.G, linear.N):
        assert np.array_equal(skew, -skew.T)
    assert np.max(np.abs(linear.N)) > 0 and np.max(np.abs(linear.G)) > 0
    n = len(linear.M)
    assert np.allclose(linear.M @ linear.A[n:, :n], -(linear.K + linear.N), rtol=1e-14, atol=1e-14)
    assert np.allclose(linear.M @ linear.A[n:, n:], -(linear.D + linear.G), rtol=1e-14, atol=1e-14)


def test_conical_pendulum_is_a_relative_equilibrium():
    """The spherical pendulum with the azimuth turning at phi' = w (a cyclic coordinate at a given
    rate): the cone at cos theta* = g/(l w^2), and the small nutation about it at
    Omega^2 = (g/l)(1 + 3 cos^2 theta*)/cos theta* (Coriolis terms: the gyroscopic G)."""
    pendulum, w = model("spherical_pendulum"), 5.0
    found = pendulum.equilibrium(guess={"theta": 0.9, "phi.velocity": w})
    theta = math.acos(9.81 / w ** 2)
    assert abs(found.at["theta"] - theta) < 1e-12 and found.at["phi.velocity"] == w
    modes = analyse(pendulum.linearize(at=found.at))
    assert modes.verdict == "marginally stable"
    nutation = math.sqrt(9.81 * (1 + 3 * math.cos(theta) ** 2) / math.cos(theta))
    assert abs(modes.modes[-1].omega / nutation - 1) < 1e-12


# The default run keeps one spin on each side of the threshold W^2 = g/(3a) (W = 8.09 rad/s).
@pytest.mark.parametrize("spin", slow_unless_kept([4.0, 8.0, 30.0, 60.0], kept={4.0, 30.0}))
def test_rolling_disk_upright_on_both_sides_of_the_threshold(spin):
    """Nonholonomic, about a steady motion: rolling upright at psi' = W, x' = a W. Stable for
    W^2 > g/(3a), the tilt then wobbling at sqrt(4 (3 a W^2 - g)/(5 a)); below, it falls at
    sqrt(4 (g - 3 a W^2)/(5 a)). The first-order model on the tangent space: five positions,
    three velocities."""
    a, g = 0.05, 9.81
    linear = model("rolling_disk").linearize(at={"theta": 0, "x.velocity": a * spin, "psi.velocity": spin})
    assert linear.M is None and len(linear.states) == 8 and linear.coordinates == ("x", "y", "phi", "theta", "psi")
    modes = analyse(linear)
    rate = 4 * (3 * a * spin ** 2 - g) / (5 * a)
    if rate > 0:
        assert modes.verdict == "marginally stable"
        assert abs(modes.modes[-1].omega / math.sqrt(rate) - 1) < 1e-12
    else:
        assert modes.verdict == "unstable"
        assert abs(max(m.s.real for m in modes.modes) / math.sqrt(-rate) - 1) < 1e-12


def test_tangent_space_agrees_with_the_null_space_of_the_rod():
    """The pendulum with a rod, passing the bottom at a small speed: the first-order form on the
    tangent space (a moving constrained state) tends to the second-order one at rest, sqrt(g/l)."""
    with pytest.warns(LagWarning, match="x moves at the point"):
        moving = model("cartesian_pendulum").linearize(at={"x": 0, "y": -1, "x.velocity": 1e-7})
    assert moving.M is None and moving.states == ("x", "x.velocity")
    at_rest = model("cartesian_pendulum").linearize(at={"x": 0, "y": -1})
    assert np.max(np.abs(moving.A - at_rest.A)) < 1e-12


def test_nonholonomic_at_rest():
    """The Chaplygin sledge at rest, no forces: every state nearby is at rest too (all modes
    zero); the blade takes one velocity, never a position."""
    linear = model("chaplygin_sledge").linearize(at={"x.velocity": 0, "phi.velocity": 0})
    assert linear.coordinates == ("x", "y", "phi") and len(linear.states) == 5
    modes = analyse(linear)
    assert modes.verdict == "marginally stable" and all(m.omega == 0 for m in modes.modes)


@pytest.mark.parametrize("speed", [-0.5, 0.5, 2.0])
def test_chaplygin_sledge_turns_round_when_pushed_backwards(speed):
    """Sliding straight at V along the blade: the turning rate grows (V < 0) or decays (V > 0) at
    m b |V| / (I + m b^2), the rate of its closed form V tanh(m b V (t - t0)/(I + m b^2))."""
    modes = analyse(model("chaplygin_sledge").linearize(at={"x.velocity": speed, "phi.velocity": 0}))
    rate = 1.0 * 0.5 * speed / (0.1 + 1.0 * 0.5 ** 2)
    turning = max(modes.modes, key=lambda m: abs(m.s))
    assert abs(turning.s.real / -rate - 1) < 1e-12 and turning.s.imag == 0
    assert modes.verdict == ("unstable" if speed < 0 else "marginally stable")


def test_modes_table_from_python():
    """LinearModel.modes(): the table of `lagc modes -o`, a DataFrame with pandas installed."""
    table = model("double_pendulum").linearize(at={"theta1": 0, "theta2": 0}).modes()
    rows = table.to_dict("records") if hasattr(table, "to_dict") else table
    assert [r["mode"] for r in rows] == [1, 2]
    assert list(rows[0])[:7] == ["mode", "real", "imag", "omega", "frequency_hz", "damping_ratio", "verdict"]
    assert rows[1]["theta1"] < 0 < rows[1]["theta2"] and rows[0]["frequency_hz"] == rows[0]["omega"] / (2 * math.pi)
