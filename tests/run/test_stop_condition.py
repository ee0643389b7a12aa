"""`stop when ...` in a scene: the run ends where the condition begins to hold, located on the
dense output of every integrator, on both backends and in the standalone C program."""
from __future__ import annotations

import subprocess

import numpy as np
import pytest
from scipy.special import ellipk

import lagdsl
from tests.run.c_harness import STRICT_FLAGS, find_cc

PROJECTILE = """model Projectile "a thrown point mass; the flight ends where it comes down"
  parameter m = 1 [kg];
  parameter g = 9.81 [m/s^2];
  coordinate x(velocity = 3) [m];
  coordinate y(velocity = 4) [m];
  let r = {x, y, 0};
  T = m*dot(der(r), der(r))/2;
  U = m*g*r.y;
  scene flight
    time(stop = 2, interval = 0.1);
    integrator dopri5(rtol = 1e-10, atol = 1e-12);
    stop when r.y < 0;
    output y, der(y);
  end flight;
end Projectile;
"""
# The pendulum released at rest from theta0 swings through the bottom after a quarter period,
# K(sin^2(theta0/2)) sqrt(l/g) (scipy's ellipk takes the parameter m = k^2).
PENDULUM = """model Pendulum
  parameter m = 1 [kg];
  parameter l = 2 [m];
  parameter g = 9.81 [m/s^2];
  coordinate theta(start = 2.5) [rad];
  T = m*l^2/2*der(theta)^2;
  U = -m*g*l*cos(theta);
  scene quarter
    time(stop = 10, interval = 0.25);
    stop when l*sin(theta) < 0;
    output theta;
  end quarter;
end Pendulum;
"""
QUARTER = ellipk(np.sin(2.5 / 2)**2) * np.sqrt(2 / 9.81)
ROD = """model Rod "a pendulum in Cartesian coordinates, held by a rod"
  parameter m = 1 [kg];
  parameter l = 1 [m];
  parameter g = 9.81 [m/s^2];
  coordinate x(start = 1) [m];
  coordinate y [m];
  T = m*(der(x)^2 + der(y)^2)/2;
  U = m*g*y;
  constraint rod: x^2 + y^2 = l^2;
  scene fall
    time(stop = 3, interval = 0.1);
    integrator dop853(rtol = 1e-12, atol = 1e-14);
    stop when x < 0;
    output x, y;
  end fall;
end Rod;
"""
INTEGRATORS = {"dopri5": {}, "dop853": {}, "rkn8": {}, "radau5": {}, "auto": {}, "rk4": {"step": 0.01},
               "gauss": {"step": 0.01}}


def load(tmp_path, text: str, name: str = "model"):
    path = tmp_path / f"{name}.lag"
    path.write_text(text)
    return lagdsl.load(path)


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_the_flight_ends_where_it_comes_down(tmp_path, backend, integrator):
    """y = 4 t - g t^2/2 is a quadratic, which every dense output reproduces: the stop time is
    2 * 4 / g to round-off, the last row is there, and the rows before it are on the grid."""
    tight = {"rtol": 1e-12, "atol": 1e-14} if integrator not in ("rk4", "gauss") else {}
    result = load(tmp_path, PROJECTILE).simulate("flight", backend, integrator=integrator,
                                                 **INTEGRATORS[integrator], **tight)
    landing = 8 / 9.81
    assert result.summary.stopped is not None
    assert result.summary.stopped.time == result.t[-1]
    assert result.t[-1] == pytest.approx(landing, abs=1e-12)
    assert abs(result["y"][-1]) < 1e-12
    assert np.allclose(result.t[:-1], 0.1 * np.arange(9))
    assert f"stopped at t = {result.t[-1]:.17g}, where r.y < 0" in result.summary.render()


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator, options, tolerance", [
    ("dop853", {"rtol": 1e-12, "atol": 1e-14}, 1e-10), ("radau5", {"rtol": 1e-10, "atol": 1e-12}, 1e-8),
    ("rk4", {"step": 0.01}, 1e-8), ("gauss", {"step": 0.05, "stages": 3}, 1e-8)])
def test_the_stop_time_has_the_accuracy_of_the_integrator(tmp_path, backend, integrator, options, tolerance):
    """A quarter period of a large swing: located inside a step, far from the output grid."""
    result = load(tmp_path, PENDULUM).simulate("quarter", backend, integrator=integrator, **options)
    assert abs(result.t[-1] - QUARTER) < tolerance
    assert abs(result["theta"][-1]) < tolerance * 10
    assert len(result.t) == int(QUARTER / 0.25) + 2


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_condition_that_holds_at_the_start_stops_there(tmp_path, backend):
    result = load(tmp_path, PROJECTILE).simulate("flight", backend, set={"y.start": -1})
    assert list(result.t) == [0.0]
    assert result.summary.stopped.time == 0.0


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", ["dop853", "rk4"])
def test_a_constrained_model_stops_on_its_constraint(tmp_path, backend, integrator):
    options = {"step": 0.001} if integrator == "rk4" else {}
    result = load(tmp_path, ROD).simulate("fall", backend, integrator=integrator, **options)
    assert abs(result["x"][-1]) < 1e-9
    assert result["y"][-1] == pytest.approx(-1, abs=1e-9)
    assert result.summary.residual_max < 1e-9


@pytest.mark.slow
def test_the_standalone_program_stops_and_says_where(tmp_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    model = load(tmp_path, PROJECTILE)
    for integrator in INTEGRATORS:
        source = tmp_path / f"{integrator}.c"
        source.write_text(model.emit("c", "flight", lagdsl.scene.Overrides(
            integrator=integrator, options=tuple((k, float(v)) for k, v in INTEGRATORS[integrator].items()))).text)
        for precision in ([], ["-DLAG_LONG_DOUBLE"])[:2 if integrator == "rk4" else 1]:   # the driver's part once
            program = tmp_path / f"{integrator}{len(precision)}"
            built = subprocess.run([cc, *STRICT_FLAGS, *precision, str(source), "-o", str(program), "-lm"],
                                   capture_output=True, text=True)
            assert built.returncode == 0, built.stderr
        run = subprocess.run([str(tmp_path / f"{integrator}0"), "y.velocity=10", "t.stop=3"],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        last = run.stdout.splitlines()[-1].split(",")
        assert float(last[0]) == pytest.approx(20 / 9.81, abs=1e-9)
        assert f"stopped at t = {last[0]}, where r.y < 0" in run.stderr
