"""A plain number means the same wherever a value is set: the declared unit of what it sets.

For a pendulum declared in grams, centimetres and degrees, a scene's `set`, `lagc run --set`
(plain or with a unit), `simulate(set=...)`, a sweep member and the generated C program's
NAME=VALUE arguments (and its --batch lines) all run the same inputs, bit for bit.
"""
from __future__ import annotations

import math
import subprocess
from fractions import Fraction

import numpy as np
import pytest

from lagdsl.api import Model
from lagdsl.errors import LagError
from lagdsl.source import SourceFile
from tests.conftest import Ran, lagc_in_process, model_file
from tests.run.c_harness import build_scene_programs

SWING = """model Swing
  parameter m = 500 [g];
  parameter l = 40 [cm];
  parameter g = 9.81 [m/s^2];
  coordinate theta(start = 10, velocity = 0) [deg];
  T = m*l^2/2*der(theta)^2;
  U = -m*g*l*cos(theta);
  scene plain
    time(stop = 0.5, interval = 0.05);
  end plain;
  scene set
    time(stop = 0.5, interval = 0.05);
    set m = 250;
    set l = 30;
    set theta(start = 30, velocity = 20);
  end set;
end Swing;
"""
PLAIN = {"m": 250, "l": 30, "theta.start": 30, "theta.velocity": 20}
WITH_UNITS = {"m": "250 g", "l": "30 cm", "theta.start": "30 deg", "theta.velocity": "20 deg/s"}
# The same values in SI units: 30 deg is the double 30 times the factor of deg, rounded once.
DEG = Fraction(repr(math.pi / 180))     # the double nearest pi/180, as lagdsl reads [deg] (tests/test_units.py)
IN_SI = {"m": "0.25 kg", "l": "0.3 [m]", "theta.start": f"{float(30 * DEG)!r} rad",
         "theta.velocity": f"{float(20 * DEG)!r} rad/s"}


@pytest.fixture(scope="module")
def swing():
    return model_file(SWING, "swing")


def lagc(*arguments: str) -> Ran:
    return lagc_in_process(*arguments)


def settings(values: dict) -> list[str]:
    return [f"{name}={value}" for name, value in values.items()]


@pytest.mark.parametrize("backend", [pytest.param("numpy", marks=pytest.mark.slow), "c"])
def test_every_way_of_setting_a_value_runs_the_same_csv(swing, backend):
    scene = lagc("run", str(swing), "--scene", "set", "--backend", backend)
    assert scene.returncode == 0, scene.stderr
    for values in (PLAIN, WITH_UNITS, IN_SI):
        given = [word for item in settings(values) for word in ("--set", item)]
        run = lagc("run", str(swing), "--scene", "plain", "--backend", backend, *given)
        assert run.returncode == 0, run.stderr
        assert run.stdout == scene.stdout, values
    assert scene.stdout != lagc("run", str(swing), "--scene", "plain", "--backend", backend).stdout


def test_the_api_and_a_sweep_take_numbers_in_the_declared_unit(swing):
    model = Model(SourceFile(str(swing), SWING))
    scene = model.simulate("set", backend="numpy")
    for values in (PLAIN, WITH_UNITS, IN_SI):
        run = model.simulate("plain", backend="numpy", set=values)
        assert np.array_equal(run.values, scene.values), values
    members = model.sweep("plain", backend="numpy", set={**PLAIN, "m": [100, 250]})
    in_scene = model.sweep("set", backend="numpy", set={"m": [100, 250]})
    assert np.array_equal(members.values, in_scene.values)
    assert members.values[1] == pytest.approx(scene.values, rel=1e-6)


def test_a_value_of_another_dimension_names_the_declared_unit(swing):
    model = Model(SourceFile(str(swing), SWING))
    with pytest.raises(LagError) as refused:
        model.simulate("plain", backend="numpy", set={"theta.start": "3 kg"})
    assert isinstance(refused.value, ValueError)
    assert "theta.start: '3 kg' is a mass, but this value is declared in [deg] (dimensionless)" in str(refused.value)
    done = lagc("run", str(swing), "--set", "theta.start=3 kg")
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "'3 kg' is a mass, but this value is declared in [deg]" in done.stderr


@pytest.fixture(scope="module")
def program(swing, tmp_path_factory):
    """The generated C program of each scene, compiled strictly."""
    return build_scene_programs(swing, ("plain", "set"), tmp_path_factory.mktemp("program"))


def run_program(path, *arguments: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([str(path), *arguments], input=stdin, capture_output=True, text=True, check=False)


def test_the_generated_program_reads_values_in_the_declared_unit(program):
    scene = run_program(program["set"])
    assert scene.returncode == 0, scene.stderr
    for values in (PLAIN, {**PLAIN, "m": "250 g", "l": "30cm", "theta.start": "30 [deg]"},
                   {**PLAIN, "m": "0.25 kg", "theta.start": IN_SI["theta.start"]}):
        run = run_program(program["plain"], *settings(values))
        assert run.returncode == 0, run.stderr
        assert run.stdout == scene.stdout, values
    batch = run_program(program["plain"], "--batch", stdin=" ".join(settings(PLAIN)) + "\n")
    assert batch.returncode == 0, batch.stderr
    rows = [line.partition(",")[2] for line in batch.stdout.splitlines()[1:]]
    assert rows == scene.stdout.splitlines()[1:]


def test_the_generated_program_refuses_a_unit_of_another_dimension(program):
    done = run_program(program["plain"], "theta.start=3 kg")
    assert done.returncode == 2 and done.stdout == ""
    assert "theta.start: '3 kg' is not in deg (dimensionless)" in done.stderr
    batch = run_program(program["plain"], "--batch", stdin="m=2s\n")
    assert batch.returncode == 2 and "line 1" in batch.stderr
    helped = run_program(program["plain"], "--help")
    assert "theta [deg]" in helped.stdout and "m [g]" in helped.stdout


def test_the_generated_program_runs_as_lagc_run(swing, program):
    """The C backend's run and the standalone program's CSV hold the same numbers."""
    run = lagc("run", str(swing), "--scene", "plain", "--backend", "c", *[w for item in settings(PLAIN)
                                                                          for w in ("--set", item)])
    standalone = run_program(program["plain"], *settings(PLAIN))
    parsed = [np.loadtxt(text.splitlines()[1:], delimiter=",") for text in (run.stdout, standalone.stdout)]
    assert np.array_equal(parsed[0], parsed[1])


TIMED = """model Spring
  parameter k = 4 [N/m];
  parameter m = 1 [kg];
  coordinate x(start = 1) [cm];
  T = m/2*der(x)^2;
  U = k/2*x^2;
  scene seconds
    time(stop = 0.8, interval = 0.1);
    integrator rk4(step = 0.001);
    set x(start = 0.2 [mm], velocity = 3 [cm/s]);
  end seconds;
  scene milliseconds
    time(stop = 800 [ms], interval = 100 [ms]);
    integrator rk4(step = 1 [ms]);
    set x(start = 0.02, velocity = 3);
  end milliseconds;
end Spring;
"""


def test_times_and_timed_options_take_units_in_a_scene_and_outside():
    model = Model(SourceFile("spring.lag", TIMED))
    seconds = model.simulate("seconds", backend="numpy")
    in_scene = model.simulate("milliseconds", backend="numpy")
    assert np.array_equal(in_scene.t, seconds.t) and np.array_equal(in_scene.values, seconds.values)
    given = model.simulate("seconds", backend="numpy", step="1 ms", stop="800 ms")
    assert np.array_equal(given.values, seconds.values)


@pytest.mark.parametrize("replaced, by, message", [
    ("stop = 800 [ms]", "stop = 800 [m]", "time(stop) must be a time, but [m] is a length"),
    ("rk4(step = 1 [ms])", "dop853(rtol = 1 [s])", "dop853(rtol = ...) takes a plain number, without a unit"),
    ("start = 0.02,", "start = 2 [kg],", "the start value of x must be a length, but [kg] is a mass"),
    ("x(start = 1) [cm]", "x(start = 1 [cm]) [cm]", "start takes a plain number here, in the unit declared"),
])
def test_a_written_unit_of_another_dimension_is_located(replaced, by, message):
    with pytest.raises(LagError) as refused:
        Model(SourceFile("spring.lag", TIMED.replace(replaced, by)))
    diagnostic = refused.value.diagnostics[0]
    assert message in diagnostic.message and diagnostic.span.text.startswith("[")


def test_command_line_steps_take_a_unit_of_time(tmp_path):
    path = tmp_path / "spring.lag"
    path.write_text(TIMED)
    plain = lagc("run", str(path), "--backend", "numpy", "--step", "0.002")
    given = lagc("run", str(path), "--backend", "numpy", "--step", "2 ms")
    assert given.returncode == 0 and given.stdout == plain.stdout
    wrong = lagc("run", str(path), "--backend", "numpy", "--step", "2 m")
    assert wrong.returncode == 1 and "--step: '2 m' is a length, but this value is declared in [s]" in wrong.stderr
