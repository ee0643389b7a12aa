"""`stop when ...` in a scene: the run ends where the condition begins to hold, located on the
dense output of every integrator, on both backends and in the standalone C program."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipk

import lagdsl
from tests.conftest import MODELS, compiled, library_model, model_file, slow_unless_kept
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
# The ladder of models/ladder.lag (l = 4 m, theta0 = 1.2 rad) leaves the wall where
# sin(theta) = (2/3) sin(theta0), after t = integral of dtheta / sqrt((3 g/l)(sin(theta0) - sin(theta)))
# from there to theta0; with s = sin(theta) = sin(theta0) - w^2 the integrand is smooth, and quad
# gives t to 1e-14 s (solve_ivp's DOP853 at rtol 1e-14 on theta'' = -(3 g/2l) cos(theta) agrees to 3e-15 s).
LADDER_S0, LADDER_K = np.sin(1.2), 3 * 9.81 / 4
LEAVES_WALL = quad(lambda w: 2 / np.sqrt(LADDER_K * (1 - (LADDER_S0 - w * w)**2)), 0, np.sqrt(LADDER_S0 / 3),
                   epsabs=0, epsrel=1e-13)[0]
# The integrators that handle constraints on each backend (the NumPy backend refuses auto with
# constraints; taylor is C only), and the ladder's located stop time with each
# (measured: 1e-13 s, radau5 1.1e-11 s).
CONSTRAINED_INTEGRATORS = {"c": ("dop853", "dopri5", "radau5", "auto", "rk4", "taylor"),
                           "numpy": ("dop853", "dopri5", "radau5", "rk4")}
INTEGRATORS = {"dopri5": {}, "dop853": {}, "rkn8": {}, "radau5": {}, "auto": {}, "rk4": {"step": 0.01},
               "gauss": {"step": 0.01}}


def load(text: str, name: str = "model"):
    return lagdsl.load(model_file(text, name))


@pytest.mark.parametrize("backend", ["c", "numpy"])
# auto (dopri5, then radau5 where stiff: both kept) slow
@pytest.mark.parametrize("integrator", slow_unless_kept(INTEGRATORS, kept=set(INTEGRATORS) - {"auto"}))
def test_the_flight_ends_where_it_comes_down(backend, integrator):
    """y = 4 t - g t^2/2 is a quadratic, which every dense output reproduces: the stop time is
    2 * 4 / g to round-off, the last row is there, and the rows before it are on the grid."""
    tight = {"rtol": 1e-12, "atol": 1e-14} if integrator not in ("rk4", "gauss") else {}
    result = load(PROJECTILE).simulate("flight", backend, integrator=integrator,
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
def test_the_stop_time_has_the_accuracy_of_the_integrator(backend, integrator, options, tolerance):
    """A quarter period of a large swing: located inside a step, far from the output grid."""
    result = load(PENDULUM).simulate("quarter", backend, integrator=integrator, **options)
    assert abs(result.t[-1] - QUARTER) < tolerance
    assert abs(result["theta"][-1]) < tolerance * 10
    assert len(result.t) == int(QUARTER / 0.25) + 2


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_condition_that_holds_at_the_start_stops_there(backend):
    result = load(PROJECTILE).simulate("flight", backend, set={"y.start": -1})
    assert list(result.t) == [0.0]
    assert result.summary.stopped.time == 0.0


@pytest.mark.parametrize("backend", ["c", "numpy"])
@pytest.mark.parametrize("integrator", ["dop853", "rk4"])
def test_a_constrained_model_stops_on_its_constraint(backend, integrator):
    options = {"step": 0.001} if integrator == "rk4" else {}
    result = load(ROD).simulate("fall", backend, integrator=integrator, **options)
    assert abs(result["x"][-1]) < 1e-9
    assert result["y"][-1] == pytest.approx(-1, abs=1e-9)
    assert result.summary.residual_max < 1e-9


@pytest.mark.slow
def test_the_standalone_program_stops_and_says_where(tmp_path):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    model = load(PROJECTILE)
    for integrator in INTEGRATORS:
        source = tmp_path / f"{integrator}.c"
        source.write_text(model.emit("c", "flight", lagdsl.scene.Overrides(
            integrator=integrator, options=tuple((k, float(v)) for k, v in INTEGRATORS[integrator].items()))).text)
        for precision in ([], ["-DLAG_LONG_DOUBLE"])[:2 if integrator == "rk4" else 1]:   # the driver's part once
            program = tmp_path / f"{integrator}{len(precision)}"
            built = compiled([cc, *STRICT_FLAGS, *precision, str(source), "-o", str(program), "-lm"])
            assert built.returncode == 0, built.stderr
        run = subprocess.run([str(tmp_path / f"{integrator}0"), "y.velocity=10", "t.stop=3"],
                             capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
        last = run.stdout.splitlines()[-1].split(",")
        assert float(last[0]) == pytest.approx(20 / 9.81, abs=1e-9)
        assert f"stopped at t = {last[0]}, where r.y < 0" in run.stderr


@pytest.mark.parametrize("backend, integrator", slow_unless_kept(   # auto and radau5 in C: 6 s of CPU, slow
    [(backend, integrator) for backend, names in CONSTRAINED_INTEGRATORS.items() for integrator in names],
    kept={("c", "dop853"), ("c", "dopri5"), ("c", "rk4"), ("c", "taylor"),
          *(("numpy", name) for name in CONSTRAINED_INTEGRATORS["numpy"])}))
def test_the_ladder_leaves_the_wall_where_its_multiplier_turns_negative(backend, integrator):
    """`stop when multiplier(wall) < 0;`: the wall's push, solved for with q'' at each dense-output
    state the root search tries, vanishes where the centre has come down to 2/3 of its height."""
    options = {"step": 1e-3} if integrator == "rk4" else {}
    result = library_model("ladder").simulate("slide", backend, integrator=integrator, **options)
    assert result.summary.stopped is not None and result.summary.stopped.time == result.t[-1]
    assert abs(result.t[-1] - LEAVES_WALL) < 1e-9
    assert result["y"][-1] == pytest.approx(2 / 3 * result["y"][0], abs=1e-9)
    assert np.sin(result["theta"][-1]) == pytest.approx(2 / 3 * LADDER_S0, abs=1e-9)
    assert abs(result["wall_force"][-1]) < 1e-6 and np.all(result["wall_force"][:-1] > 0)
    assert "where multiplier(wall) < 0" in result.summary.render()


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_a_stop_on_a_nonholonomic_multiplier(backend):
    """The rolling penny (models/rolling_penny.lag): the plane's side force, the multiplier of
    roll_y, is -m sin(theta) 2 g s (2 cos(theta) - cos(theta0))/3 with theta = theta0 + w t (the
    corrected closed form of tests/models/test_constrained.py); it changes sign where
    cos(theta) = cos(theta0)/2."""
    scene = """  scene turn
    time(stop = 2, interval = 0.1);
    integrator dop853(rtol = 1e-12, atol = 1e-14);
    stop when multiplier(roll_y) > 0;
    output theta, multiplier(roll_y);
  end turn;
end RollingPenny;
"""
    text = (MODELS / "rolling_penny.lag").read_text().replace("end RollingPenny;\n", scene)
    result = load(text, "penny").simulate("turn", backend)
    assert result.t[-1] == pytest.approx(np.arccos(np.cos(0.3) / 2) - 0.3, abs=1e-9)
    assert np.all(result["multiplier(roll_y)"][:-1] < 0)


def test_a_multiplier_of_a_dropped_constraint_in_the_stop_condition_is_refused_there(tmp_path):
    """The rod of a pendulum in an angle holds identically, so it is dropped and has no multiplier."""
    text = """model Swing
  parameter m = 1 [kg];
  parameter r = 1 [m];
  parameter g = 9.81 [m/s^2];
  coordinate theta(start = 1) [rad];
  let x = r*sin(theta);
  let y = -r*cos(theta);
  T = m/2*(der(x)^2 + der(y)^2);
  U = m*g*y;
  constraint rod: x^2 + y^2 = r^2;
  scene s
    stop when -2*r*multiplier(rod) < 0;
  end s;
end Swing;
"""
    path = tmp_path / "swing.lag"
    path.write_text(text)
    done = subprocess.run([sys.executable, "-m", "lagdsl", "run", str(path)], capture_output=True, text=True)
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.splitlines()[:3] == [
        f"{path}:12:5: error: constraint 'rod' is identically satisfied by the coordinates and was dropped, "
        "so it has no multiplier",
        "    stop when -2*r*multiplier(rod) < 0;",
        "    ^~~~~~~~~~~~~~~~~~~~~~~~~~~~~~~~~~~"]
