"""Problems in SI scales (issue 36): the relativistic cyclotron, an electron with R ~ 1e-3 m and a
period ~ 4e-11 s, at atol 1e-18, with every adaptive integrator on both backends; the absolute
tolerance per component (lagdsl/tolerances.py) in the language, on the command line and in the API.

Closed form (Jackson, 12.2): the speed is constant, so gamma = 1/sqrt(1 - beta^2) is, and the
orbit x = R cos(w t), y = R sin(w t), z = v_z t with w = |q| B / (gamma m), R = gamma m v_perp / (|q| B).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from lagdsl.errors import LagError
from lagdsl.tolerances import atol_vector
from tests.conftest import MODELS, lagc_in_process, library_model, model_file, slow_unless_kept
from tests.run.c_harness import find_cc

M, Q, C, B = 9.1093837015e-31, -1.602176634e-19, 299792458.0, 1.0
BETA, BETA_Z = 0.5, 0.2
GAMMA = 1 / math.sqrt(1 - BETA**2 - BETA_Z**2)
RADIUS = GAMMA * M * BETA * C / (abs(Q) * B)
OMEGA = abs(Q) * B / (GAMMA * M)
PERIOD = 2 * math.pi / OMEGA
CYCLOTRON = MODELS / "relativistic_cyclotron.lag"


def orbit_error(result) -> float:
    """The largest distance from the closed-form helix, in units of R."""
    t = np.asarray(result.t)
    x, y, z = (np.asarray(result.values[:, result.columns.index(name)]) for name in ("x", "y", "z"))
    planar = np.hypot(x - RADIUS * np.cos(OMEGA * t), y - RADIUS * np.sin(OMEGA * t))
    return float(max(planar.max(), np.abs(z - BETA_Z * C * t).max()) / RADIUS)


def needs_cc(backend: str) -> None:
    if backend == "c" and find_cc() is None:
        pytest.skip("no C compiler")


def test_the_model_states_the_closed_form_radius():
    """The model's derived parameter R is the closed form's (to rounding)."""
    plan = library_model("relativistic_cyclotron").plan()
    assert plan.initial_state[0] == pytest.approx(RADIUS, rel=1e-14)
    assert plan.initial_state[4] == pytest.approx(BETA * C, rel=1e-15)


# dopri5, radau5 and auto in C slow (5 s of CPU): the default run keeps a C explicit and the Taylor method, and NumPy's
ADAPTIVE = slow_unless_kept([("c", name) for name in ("dop853", "dopri5", "radau5", "taylor", "auto")],
                            kept={("c", "dop853"), ("c", "taylor")}) + \
    [("numpy", name) for name in ("dop853", "dopri5", "auto")] + \
    [pytest.param("numpy", "radau5", marks=pytest.mark.slow)]     # scipy's Radau: 13 s at rtol 1e-12


@pytest.mark.parametrize("backend,integrator", ADAPTIVE)
def test_the_cyclotron_at_atol_1e18_runs_and_matches_the_closed_form(backend, integrator):
    """Failed at t = 0 ("the step size collapsed") before: the starting step estimate, which
    weighs x' = 0 by atol = 1e-18 against x'' ~ 2e19 m/s^2, lay below the smallest step. One turn,
    at the scene's rtol 1e-12: radius and period as the closed form has them, to 1e-9 R (a
    global error a few hundred times rtol; 7e-12 R for dop853)."""
    needs_cc(backend)
    result = library_model("relativistic_cyclotron").simulate(
        backend=backend, integrator=integrator, stop=PERIOD, interval=PERIOD / 100)
    assert result.t[-1] == PERIOD
    assert orbit_error(result) < 1e-9
    x_end, y_end = (result.values[-1, result.columns.index(name)] for name in ("x", "y"))
    assert math.hypot(x_end - RADIUS, y_end) < 1e-9 * RADIUS     # back at the start after one period


def test_scipys_radau_at_a_looser_rtol_runs_at_atol_1e18_in_the_fast_set():
    result = library_model("relativistic_cyclotron").simulate(
        backend="numpy", integrator="radau5", rtol=1e-8, stop=PERIOD, interval=PERIOD / 100)
    assert orbit_error(result) < 1e-6


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_rkn8_starts_on_a_problem_in_si_scales(backend):
    """rkn8 (the cyclotron's force reads the velocity, so a pendulum of 1 mm under g = 1e10 m/s^2,
    period 2 pi sqrt(l/g) ~ 2e-6 s, started at theta = 0 with theta' = 1e5 rad/s) at atol 1e-18:
    it starts, and agrees with dop853."""
    needs_cc(backend)
    pendulum = library_model("pendulum")
    common = dict(backend=backend, rtol=1e-12, atol=1e-18, stop=2e-6, interval=2e-8, l=1e-3, g=1e10,
                  set={"theta.start": 0, "theta.velocity": 1e5})
    nystrom = pendulum.simulate(integrator="rkn8", **common)
    reference = pendulum.simulate(integrator="dop853", **common)
    assert np.abs(nystrom.values[:, 0] - reference.values[:, 0]).max() < 1e-9


def test_the_velocity_of_a_named_coordinate_gets_its_atol_over_the_span():
    """tolerances.py: a family's value, a member's own, a velocity's own, and atol(q)/span for the
    velocity of a coordinate named alone; the others keep the scalar atol."""
    names = ("x", "q[1]", "q[2]")
    vector = atol_vector(1e-10, (("q", 1e-6), ("q[2]", 1e-8), ("der(q[1])", 1e-3), ("x", 2e-12)), names, 2.0)
    assert vector == (2e-12, 1e-6, 1e-8, 1e-12, 1e-3, 5e-9)
    assert atol_vector(1e-10, (), names, 2.0) is None


def test_a_coordinate_whose_atol_is_tightened_is_controlled():
    """The error norm reads each component's atol. At rtol 1e-10 and atol = 1e3 for every
    component (metres for x, y, z; m/s for their velocities), the positions (~1e-3 m) are weighed
    by 1e3 and the orbit is off by 3e-5 R after a turn; the same run with atol(x) = atol(y) =
    1e-16 [m] and every other component still at 1e3 holds the orbit to 1e-9 R."""
    model = library_model("relativistic_cyclotron")
    common = dict(backend="numpy", integrator="dop853", rtol=1e-10, stop=PERIOD, interval=PERIOD / 100)
    loose = model.simulate(atol=1e3, **common)
    tight = model.simulate(atol={"x": 1e-16, "y": 1e-16, "z": 1e3, "der(x)": 1e3, "der(y)": 1e3, "der(z)": 1e3},
                           **common)
    assert orbit_error(loose) > 1e-6
    assert orbit_error(tight) < 1e-9
    assert dict(tight.summary.counters)["accepted"] > 3 * dict(loose.summary.counters)["accepted"]


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_atol_per_component_is_the_same_given_in_the_scene_the_cli_and_the_api(tmp_path, backend):
    needs_cc(backend)
    written = CYCLOTRON.read_text().replace(
        "integrator dop853(rtol = 1e-12, atol = 1e-18);",
        "integrator dop853(rtol = 1e-9, atol = 1, atol(x) = 1e-16, atol( y ) = 1e-16, atol(der(z)) = 1e-3);")
    scene_file = model_file(written, "scene")
    by_scene = tmp_path / "scene.csv"
    by_cli = tmp_path / "cli.csv"
    common = ["--backend", backend, "--stop", str(PERIOD), "--interval", str(PERIOD / 50)]
    assert lagc_in_process("run", scene_file, "-o", by_scene, *common).returncode == 0
    ran = lagc_in_process("run", CYCLOTRON, "-o", by_cli, *common, "--rtol", "1e-9", "--atol", "1",
                          "--atol", "x=1e-16", "--atol", "y = 1e-16", "--atol", "der(z)=1e-3")
    assert ran.returncode == 0, ran.stderr
    api = library_model("relativistic_cyclotron").simulate(
        backend=backend, rtol=1e-9, atol={"x": 1e-16, "y": 1e-16, "der(z)": 1e-3}, stop=PERIOD, interval=PERIOD / 50)
    assert by_scene.read_text() == by_cli.read_text()
    table = np.loadtxt(by_cli, delimiter=",", skiprows=1)
    # the API's unnamed components keep the scene's atol 1e-18, not 1: the same steps need not follow
    assert orbit_error(api) < 1e-8 and np.abs(table[:, 1:4] - api.values[:, :3]).max() < 1e-8 * RADIUS


@pytest.mark.parametrize("statement,message,column", [
    ("atol(w) = 1e-18", "atol(w): 'w' is not a coordinate of the model nor der() of one", 37),
    ("atol(der(w)) = 1e-18", "atol(der(w)): 'der(w)' is not a coordinate", 37),
    ("atol(x) = -1e-18", "atol(x) must be a finite number >= 0, not -1e-18", 37),
    ("atol(x) = 1, atol(x ) = 2", "atol(x) is given twice", 50),
    ("step(x) = 1", "'step(...)' is not an option of integrator dop853", 37),
])
def test_a_bad_atol_in_a_scene_is_located(tmp_path, statement, message, column):
    written = CYCLOTRON.read_text().replace("integrator dop853(rtol = 1e-12, atol = 1e-18);",
                                            f"integrator dop853(rtol = 1e-12, {statement});")
    path = tmp_path / "bad.lag"
    path.write_text(written)
    line = written.splitlines().index(next(t for t in written.splitlines() if statement in t)) + 1
    ran = lagc_in_process("check", path)
    assert ran.returncode == 1 and "Traceback" not in ran.stderr
    assert f"bad.lag:{line}:{column}: error: {message}" in ran.stderr
    assert "^" in ran.stderr


def test_atol_per_coordinate_is_refused_by_a_fixed_step_method_and_zero_by_an_implicit_one(tmp_path):
    for integrator, statement, message in (
            ("gauss", "step = 1e-13, atol(x) = 1e-18", "'atol(...)' is not an option of integrator gauss"),
            ("radau5", "atol(x) = 0", "atol(x) must be positive")):
        path = tmp_path / f"{integrator}.lag"
        path.write_text(CYCLOTRON.read_text().replace("integrator dop853(rtol = 1e-12, atol = 1e-18);",
                                                      f"integrator {integrator}({statement});"))
        ran = lagc_in_process("check", path)
        assert ran.returncode == 1 and message in ran.stderr


@pytest.mark.parametrize("items,message", [
    (["w=1e-18"], "--atol w=1e-18: atol(w): 'w' is not a coordinate"),
    (["x=-1"], "--atol x=-1: atol(x) must be a finite number >= 0"),
    (["x="], "--atol takes a number, or COMPONENT=NUMBER"),
    (["=1e-18"], "--atol takes a number, or COMPONENT=NUMBER"),
    (["der(x)=inf"], "atol(der(x)) must be a finite number >= 0"),
])
def test_a_bad_atol_on_the_command_line_names_the_option(tmp_path, items, message):
    arguments = [argument for item in items for argument in ("--atol", item)]
    ran = lagc_in_process("run", CYCLOTRON, "-o", tmp_path / "out.csv", *arguments)
    assert ran.returncode == 1 and message in ran.stderr and "Traceback" not in ran.stderr
    assert not (tmp_path / "out.csv").exists()


def test_a_bad_atol_in_the_api_is_a_lag_error():
    model = library_model("relativistic_cyclotron")
    with pytest.raises(LagError, match="'w' is not a coordinate"):
        model.simulate(atol={"w": 1e-18})
    with pytest.raises(LagError, match="atol.x. must be a number"):
        model.simulate(atol={"x": [1e-18]})
    with pytest.raises(LagError, match="atol.x.: expected a number, or a number and a unit"):
        model.simulate(atol={"x": "small"})
