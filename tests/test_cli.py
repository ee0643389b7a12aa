"""The command line end to end: exit codes, output formats, no output file on failure."""
from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import MODELS


def lagc(*arguments, cwd=None):
    return subprocess.run([sys.executable, "-m", "lagdsl", *map(str, arguments)], capture_output=True,
                          text=True, cwd=cwd)


def test_check_reports_the_double_pendulum():
    done = lagc("check", MODELS / "double_pendulum.lag")
    assert done.returncode == 0, done.stderr
    assert "degrees of freedom: 2" in done.stdout
    assert "rod1: holonomic, identically satisfied by the coordinates: dropped" in done.stdout
    assert "energy:" in done.stdout
    assert "chaos" in done.stdout


def test_eom_prints_text_and_latex():
    text = lagc("eom", MODELS / "double_pendulum.lag")
    assert text.returncode == 0
    assert "cos(theta1 - theta2)" in text.stdout and "theta2''" in text.stdout
    latex = lagc("eom", "--latex", MODELS / "double_pendulum.lag")
    assert latex.stdout.startswith("\\begin{aligned}") and "\\ddot" in latex.stdout


def test_run_writes_csv_with_the_exact_header(tmp_path):
    out = tmp_path / "out.csv"
    done = lagc("run", MODELS / "rolling_penny.lag", "--stop", "0.1", "-o", out)
    assert done.returncode == 0, done.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == ("t,x,y,phi,theta,energy,momentum(theta),multiplier(roll_x),multiplier(roll_y),"
                        "residual(roll_x),residual(roll_y)")
    assert len(lines) == 1 + 11
    assert "steps accepted" in done.stderr and "largest constraint residual" in done.stderr


def test_run_overrides(tmp_path):
    done = lagc("run", MODELS / "wedge.lag", "--set", "m=2", "--set", "s.velocity=1", "--stop", "0.1")
    assert done.returncode == 0, done.stderr
    first = done.stdout.splitlines()[1].split(",")
    assert float(first[4]) == 1.0             # der(s) at t = 0


def test_model_errors_exit_1_without_traceback(tmp_path):
    bad = tmp_path / "bad.lag"
    bad.write_text("model Bad\n  coordinate x;\n  T = m*der(x)^2;\nend Bad;\n")
    done = lagc("check", bad)
    assert done.returncode == 1
    assert f"{bad}:3:7: error: undefined name 'm'" in done.stderr
    assert "Traceback" not in done.stderr


def test_numerical_failure_names_time_state_and_remedy_and_keeps_the_rows(tmp_path):
    model = tmp_path / "collapse.lag"
    # T = r^2 r'^2 / 2: r^2 = 1 - 2t reaches 0 at t = 1/2, where the mass matrix r^2 is singular.
    model.write_text("model Collapse\n  coordinate r(start = 1, velocity = -1);\n"
                     "  T = r^2*der(r)^2/2;\nend Collapse;\n")
    out = tmp_path / "out.csv"
    done = lagc("run", model, "--stop", "1", "-o", out)
    assert done.returncode == 1
    assert "simulation failed at t = 0.4" in done.stderr or "simulation failed at t = 0.5" in done.stderr
    assert "state: r = " in done.stderr and "remedy:" in done.stderr
    assert "Traceback" not in done.stderr
    lines = out.read_text().splitlines()                 # the rows before the failure, a valid CSV
    assert lines[0] == "t,r" and 2 <= len(lines) <= 52 and [float(x) for x in lines[1].split(",")] == [0, 1]
    assert "the run is incomplete: it stopped at t = 0.4" in done.stderr or \
        "the run is incomplete: it stopped at t = 0.5" in done.stderr


@pytest.mark.parametrize("language", ["c", "numpy"])
def test_emit_writes_source(tmp_path, language):
    out = tmp_path / ("model.c" if language == "c" else "model.py")
    done = lagc(MODELS / "kepler.lag", "--emit", language, "-o", out)
    assert done.returncode == 0, done.stderr
    assert "Kepler" in out.read_text()
