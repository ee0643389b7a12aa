"""Generated code pinned in tests/golden/, and every C golden compiled strictly and run.

Regenerate after an intended change with
    python -m pytest tests/codegen/test_golden.py --update-golden
and review the diff of tests/golden/ like any code change. Each C golden is also compiled
with -std=c99 -Wall -Wextra -Werror -pedantic and its output checked against a closed form
or an independent reference: a golden that only matches itself proves nothing.
"""
from __future__ import annotations

import difflib
import io
import subprocess

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.conftest import MODELS, ROOT, compiled, library_model
from tests.run.c_harness import STRICT_FLAGS, find_cc

GOLDEN = ROOT / "tests" / "golden"
# (model, scene): a fixed-step rk4 scene, a constrained one, an implicit one, a symplectic one,
# the chaotic benchmark, and a banded mass matrix. The mass matrices: dense 2 x 2 (wedge,
# double_pendulum: a straight-line LDLᵀ), dense 12 x 12 (pendulum_chain: the Cholesky loops),
# diagonal (charged_particle, kepler), tridiagonal (fem_string: a sparse LDLᵀ), with constraints
# (rolling_penny: LU of the saddle-point system; cartesian_chain, 16 coordinates and 8
# constraints: the sparse LDLᵀ of the saddle-point system), and the local form's loops over members
# (fpu_chain: diagonal, 200 masses; fem_string_fine: a band, 40 nodes). The Jacobians of radau5:
# dense (charged_particle.helix) and banded (fpu_chain.implicit, the local form's loops). The
# Nystrom pair rkn8: pleiades.nystrom. A stop condition that reads a multiplier (solved for at
# each state the event search tries): ladder.slide.
CASES = [("wedge", "slide"), ("rolling_penny", "roll"), ("charged_particle", "helix"),
         ("kepler", "symplectic"), ("double_pendulum", "chaos"), ("fem_string", "mode2"),
         ("pendulum_chain", "swing"), ("fpu_chain", "spread"), ("fpu_chain", "implicit"),
         ("fem_string_fine", "mode2"), ("cartesian_chain", "swing"), ("pleiades", "nystrom"),
         ("ladder", "slide")]
EXTENSIONS = {"c": "c", "numpy": "py"}


def generated(model: str, scene: str, backend: str) -> str:
    return library_model(model).emit(backend, scene).text.replace(str(MODELS), "models")


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("model, scene", CASES, ids=[f"{m}.{s}" for m, s in CASES])
def test_generated_code_matches_golden(model, scene, backend, update_golden):
    path = GOLDEN / f"{model}.{scene}.{EXTENSIONS[backend]}"
    text = generated(model, scene, backend)
    if update_golden:
        GOLDEN.mkdir(exist_ok=True)
        changed = not path.exists() or path.read_text() != text
        path.write_text(text)
        if changed:
            print(f"updated {path.relative_to(ROOT)}")
        return
    assert path.exists(), f"no golden file {path.name}; run pytest with --update-golden"
    expected = path.read_text()
    if text != expected:
        diff = "".join(difflib.unified_diff(expected.splitlines(True), text.splitlines(True),
                                            f"golden/{path.name}", "generated"))
        pytest.fail(f"generated code differs from the golden file:\n{diff}")


def test_generation_is_deterministic():
    assert generated("rolling_penny", "roll", "c") == generated("rolling_penny", "roll", "c")


def run_golden(tmp_path, model, scene, *arguments):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    exe = tmp_path / model
    compiled([cc, *STRICT_FLAGS, str(GOLDEN / f"{model}.{scene}.c"), "-o", str(exe), "-lm"], check=True)
    done = subprocess.run([str(exe), *arguments], check=True, capture_output=True, text=True)
    table = np.genfromtxt(io.StringIO(done.stdout), delimiter=",", names=True, deletechars="")
    return table, done.stderr


def test_wedge_golden_follows_the_closed_form(tmp_path):
    table, summary = run_golden(tmp_path, "wedge", "slide")
    M, m, alpha, g = 3.0, 1.0, 0.5, 9.81
    denominator = M + m * np.sin(alpha)**2
    xdd = -m * g * np.sin(alpha) * np.cos(alpha) / denominator
    sdd = (M + m) * g * np.sin(alpha) / denominator
    t = table["t"]
    assert np.allclose(table["x"], xdd * t**2 / 2, atol=1e-12)
    assert np.allclose(table["s"], sdd * t**2 / 2, atol=1e-12)
    assert "drift of energy" in summary


def test_rolling_penny_golden_follows_the_closed_form(tmp_path):
    table, _ = run_golden(tmp_path, "rolling_penny", "roll", "t.stop=3")
    a, g, alpha, theta0, omega = 0.01, 9.81, 0.2, 0.3, 1.0
    t = table["t"]
    theta = theta0 + omega * t
    # phi'' = -2 g sin(alpha) sin(theta) / (3 a), theta = theta0 + omega t, phi(0) = phi'(0) = 0
    k = 2 * g * np.sin(alpha) / (3 * a)
    phi = k / omega**2 * (np.sin(theta) - np.sin(theta0)) - k / omega * np.cos(theta0) * t
    assert np.allclose(table["theta"], theta, atol=1e-9)
    assert np.allclose(table["phi"], phi, rtol=1e-8, atol=1e-8)
    assert np.max(np.abs(table["residual(roll_x)"])) < 1e-10


def test_charged_particle_golden_is_a_helix(tmp_path):
    table, _ = run_golden(tmp_path, "charged_particle", "helix")
    t = table["t"]
    omega = 2.0      # e B / m; from x = 1, y' = -2: a circle of radius 1 about the origin
    assert np.allclose(table["x"], np.cos(omega * t), atol=1e-8)
    assert np.allclose(table["y"], -np.sin(omega * t), atol=1e-8)
    assert np.allclose(table["z"], 0.1 * t, atol=1e-10)


def test_kepler_golden_stays_on_its_ellipse(tmp_path):
    table, summary = run_golden(tmp_path, "kepler", "symplectic")
    # r(theta) = p / (1 + e cos theta) with p = p_theta^2/(G M m^2) = 1.44 and e = p/r0 - 1
    p = 1.2**2
    e = p - 1.0
    assert np.allclose(table["r"] * (1 + e * np.cos(table["theta"])), p, rtol=1e-7)
    assert np.max(np.abs(table["momentum(theta)"] - 1.2)) < 1e-12
    assert np.max(np.abs(table["energy"] - table["energy"][0])) < 1e-9


def test_double_pendulum_golden_matches_the_worksheet_equations(tmp_path):
    table, _ = run_golden(tmp_path, "double_pendulum", "chaos", "t.stop=2")
    g = 9.81

    def worksheet(t, y):        # m1 = m2 = l1 = l2 = 1
        t1, t2, w1, w2 = y
        c, s = np.cos(t1 - t2), np.sin(t1 - t2)
        mass = np.array([[2.0, c], [c, 1.0]])
        force = np.array([-s * w2**2 - 2 * g * np.sin(t1), s * w1**2 - g * np.sin(t2)])
        return [w1, w2, *np.linalg.solve(mass, force)]

    reference = solve_ivp(worksheet, (0, 2), [1.0, 2.0, 0.0, 0.0], method="DOP853", rtol=1e-13,
                          atol=1e-13, t_eval=table["t"])
    assert np.allclose(table["theta1"], reference.y[0], atol=1e-7)
    assert np.allclose(table["theta2"], reference.y[1], atol=1e-7)


def test_fem_string_golden_moves_in_its_discrete_mode(tmp_path):
    table, _ = run_golden(tmp_path, "fem_string", "mode2")
    t = table["t"]
    omega = np.sqrt(6 / 5)          # omega^2 = 6 tension/(rho h^2) (1 - cos theta)/(2 + cos theta), theta = pi/3
    assert np.allclose(table["u[1]"], 0.1 * np.sqrt(3) / 2 * np.cos(omega * t), atol=1e-9)
    assert np.max(np.abs(table["u[3]"])) < 1e-12


def test_pleiades_golden_with_the_nystrom_pair_reaches_the_test_sets_state(tmp_path):
    from tests.models.test_celestial import PLEIADES_AT_3
    table, summary = run_golden(tmp_path, "pleiades", "nystrom")
    assert table["t"][-1] == 3.0
    for axis, values in PLEIADES_AT_3.items():
        assert np.allclose([table[f"{axis}[{i}]"][-1] for i in range(1, 8)], values, atol=1e-8, rtol=0)
    assert "integrator rkn8(rtol = 1e-12, atol = 1e-12)" in summary


def test_ladder_golden_stops_where_the_ladder_leaves_the_wall(tmp_path):
    from tests.run.test_stop_condition import LEAVES_WALL
    table, summary = run_golden(tmp_path, "ladder", "slide")
    assert abs(table["t"][-1] - LEAVES_WALL) < 1e-9
    assert table["y"][-1] == pytest.approx(2 / 3 * table["y"][0], abs=1e-9)
    assert f"stopped at t = {table['t'][-1]:.17g}, where multiplier(wall) < 0" in summary


def test_standalone_program_takes_overrides(tmp_path):
    table, _ = run_golden(tmp_path, "wedge", "slide", "s.velocity=1.5", "M=5", "t.stop=0.1", "t.interval=0.05")
    assert list(table["t"]) == [0.0, 0.05, 0.1]
    assert table["der(s)"][0] == 1.5
    done = subprocess.run([str(tmp_path / "wedge"), "bogus=1"], capture_output=True, text=True)
    assert done.returncode == 2 and "unknown setting 'bogus'" in done.stderr
