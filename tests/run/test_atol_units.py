"""An atol per component is read as every other value set from outside the model file is: a plain
number in the component's declared unit (its coordinate's, per second for der()), or a number
with a unit (tolerances.py). A scene's `atol(x) = 0.0005` on a coordinate in [mm], `lagc run
--atol x=0.0005`, `--atol "x=5e-7 m"`, `simulate(atol={"x": 0.0005})` and the generated program's
`--atol=x=0.0005` run the same steps, bit for bit; read in SI the same number runs others.
"""
from __future__ import annotations

import subprocess

import numpy as np
import pytest

from lagdsl.api import Model
from lagdsl.errors import LagError
from lagdsl.source import SourceFile
from tests.conftest import Ran, lagc_in_process, model_file
from tests.run.c_harness import build_scene_programs

# Uncoupled: a spring in millimetres and a pendulum in degrees, at tolerances loose enough that
# the per-component atol decides the steps.
CART = """model Cart
  parameter m = 2 [kg];
  parameter k = 50 [N/m];
  parameter g = 9.81 [m/s^2];
  parameter l = 0.5 [m];
  coordinate x(start = 10, velocity = 0) [mm];
  coordinate theta(start = 20, velocity = 0) [deg];
  T = m/2*der(x)^2 + m*l^2/2*der(theta)^2;
  U = k/2*x^2 - m*g*l*cos(theta);
  scene plain
    time(stop = 2, interval = 0.1);
    integrator dop853(rtol = 1e-3, atol = 1e-3);
  end plain;
  scene named
    time(stop = 2, interval = 0.1);
    integrator dop853(rtol = 1e-3, atol = 1e-3, atol(x) = 0.0005, atol(der(theta)) = 0.5);
  end named;
end Cart;
"""
# The scene's values as lagc run takes them: plain (declared units), with the declared unit, in SI
# (0.0005 mm is 5e-7 m exactly as the double 0.0005 times 1/1000 rounds).
GIVEN = (["x=0.0005", "der(theta)=0.5"], ["x=0.0005 mm", "der(theta)=0.5 deg/s"], ["x=5e-7 m", "der(theta)=0.5deg/s"])


@pytest.fixture(scope="module")
def cart():
    return model_file(CART, "cart")


def lagc(*arguments: str) -> Ran:
    return lagc_in_process(*arguments)


def atol_options(items: list[str]) -> list[str]:
    return [word for item in items for word in ("--atol", item)]


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_lagc_run_reads_atol_in_the_declared_unit_as_the_scene_does(cart, backend):
    scene = lagc("run", str(cart), "--scene", "named", "--backend", backend)
    assert scene.returncode == 0, scene.stderr
    for items in GIVEN:
        run = lagc("run", str(cart), "--scene", "plain", "--backend", backend, *atol_options(items))
        assert run.returncode == 0, run.stderr
        assert run.stdout == scene.stdout, items
    in_si = lagc("run", str(cart), "--scene", "plain", "--backend", backend, *atol_options(["x=0.0005 m"]))
    assert in_si.returncode == 0 and in_si.stdout != scene.stdout
    # the summary gives the values as used, in SI
    assert "atol(x) = 5e-07" in scene.stderr and "atol(der(theta)) = 0.00872665" in scene.stderr


def test_the_api_reads_atol_in_the_declared_unit(cart):
    model = Model(SourceFile(str(cart), CART))
    scene = model.simulate("named", backend="numpy")
    for atol in ({"x": 0.0005, "der(theta)": 0.5}, {"x": "0.0005 mm", "der(theta)": "0.5 deg/s"}):
        run = model.simulate("plain", backend="numpy", atol=atol)
        assert np.array_equal(run.values, scene.values), atol
    with pytest.raises(LagError, match=r"atol\(x\): '1 kg' is a mass, but this value is declared in \[mm\]"):
        model.simulate("plain", backend="numpy", atol={"x": "1 kg"})


@pytest.fixture(scope="module")
def programs(cart, tmp_path_factory):
    return build_scene_programs(cart, ("plain", "named"), tmp_path_factory.mktemp("atol_program"))


def run_program(path, *arguments: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(path), *arguments], capture_output=True, text=True, check=False)


def test_the_generated_program_takes_atol_per_component_in_the_declared_unit(cart, programs):
    scene = run_program(programs["named"])
    assert scene.returncode == 0, scene.stderr
    assert "atol(x) = 5e-07, atol(der(theta)) = 0.00872665" in scene.stderr
    for items in GIVEN:
        run = run_program(programs["plain"], *[f"--atol={item}" for item in items])
        assert run.returncode == 0, run.stderr
        assert run.stdout == scene.stdout, items
    assert run_program(programs["plain"], "--atol=x=0.0005 m").stdout != scene.stdout
    # the same rows as lagc run's C backend; a scalar --atol keeps the components named, as there
    ran = lagc("run", str(cart), "--scene", "named", "--backend", "c", "--atol", "1e-4")
    rows = run_program(programs["named"], "--atol=1e-4")
    assert np.array_equal(table(ran.stdout), table(rows.stdout))
    assert "atol = 0.0001, atol(x) = 5e-07" in rows.stderr


def table(csv: str) -> np.ndarray:
    return np.loadtxt(csv.splitlines()[1:], delimiter=",")


def test_the_velocity_of_a_coordinate_named_alone_follows_the_programs_grid(cart, programs):
    """atol(der(x)) = atol(x) / (stop - start) over the grid the run is given (t.stop=)."""
    for stop in ("1", "3"):
        ran = lagc("run", str(cart), "--scene", "plain", "--backend", "c", "--stop", stop, "--atol", "x=0.0005")
        rows = run_program(programs["plain"], f"t.stop={stop}", "--atol=x=0.0005")
        assert rows.returncode == 0, rows.stderr
        assert np.array_equal(table(ran.stdout), table(rows.stdout)), stop


@pytest.mark.parametrize("argument,message", [
    ("--atol=w=1", "'w' is not a coordinate nor der() of one"),
    ("--atol=x=-1", "atol(x) must be a finite number >= 0"),
    ("--atol=x=1 kg", "x: '1 kg' is not in mm (length)"),
    ("--atol=der(x)=nan", "atol(der(x)) must be a finite number >= 0"),
])
def test_the_generated_program_refuses_a_bad_atol(programs, argument, message):
    done = run_program(programs["plain"], argument)
    assert done.returncode == 2 and done.stdout == "" and message in done.stderr


def test_the_generated_programs_help_names_the_components(programs):
    helped = run_program(programs["plain"], "--help")
    assert "--atol=COMPONENT=VALUE" in helped.stdout and " x theta der(x) der(theta)" in helped.stdout
