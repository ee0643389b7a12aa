"""`lagc modes` and `lagc linearize`: the files they write, and bad input as a located message
with exit status 2 (1 for a numerical failure), never a traceback."""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
import scipy.io

from tests.conftest import MODELS
from tests.linear.support import lagc


def test_modes_of_the_damped_pendulum(capsys, tmp_path):
    """m l^2 theta'' + b theta' + m g l theta = 0: zeta = b / (2 sqrt(m l^2 m g l)), omega_n = sqrt(g/l)."""
    table, picture = tmp_path / "modes.csv", tmp_path / "modes.png"
    status, out, err = lagc(capsys, "modes", MODELS / "damped_driven_pendulum.lag", "--at", "theta=0",
                            "--set", "A=0", "-o", table, "--plot", picture)
    assert status == 0, err
    row, = csv.DictReader(table.open())
    assert abs(float(row["omega"]) / math.sqrt(9.81) - 1) < 1e-12
    assert abs(float(row["damping_ratio"]) / (0.5 / (2 * math.sqrt(9.81))) - 1) < 1e-12
    assert row["verdict"] == "stable" and "verdict: stable" in out
    assert picture.read_bytes().startswith(b"\x89PNG")


def test_linearize_writes_json_npz_and_mat(capsys, tmp_path):
    arguments = ["linearize", MODELS / "cart_pole_lqr.lag", "--at", "theta=0", "--input", "u", "--output", "x",
                 "--output", "theta"]
    for suffix in ("json", "npz", "mat"):
        status, _, err = lagc(capsys, *arguments, "-o", tmp_path / f"lin.{suffix}")
        assert status == 0, err
    document = json.loads((tmp_path / "lin.json").read_text())
    assert document["coordinates"] == ["x", "theta"] and document["inputs"] == ["u"]
    assert document["states"] == ["x", "theta", "x.velocity", "theta.velocity"]
    A = np.array(document["matrices"]["A"])
    archive = np.load(tmp_path / "lin.npz")
    assert np.array_equal(archive["A"], A) and list(archive["outputs"]) == ["x", "theta"]
    matlab = scipy.io.loadmat(tmp_path / "lin.mat")
    assert np.array_equal(matlab["A"], A) and np.array_equal(matlab["B"], np.array(document["matrices"]["B"]))
    assert [str(name[0]) for name in matlab["inputs"].ravel()] == ["u"]


def test_find_reports_the_equilibrium(capsys):
    status, out, err = lagc(capsys, "modes", MODELS / "bead_on_hoop.lag", "--at", "theta=1.2", "--find")
    assert status == 0
    assert "equilibrium after" in err and "theta = 0.99440721205" in err and "about theta = 0.994407" in out


def torque_pendulum(tmp_path, torque: float):
    path = tmp_path / "torque.lag"
    path.write_text(f"""model Torque
  parameter m = 1.0 [kg];
  parameter l = 1.0 [m];
  parameter g = 9.81 [m/s^2];
  parameter tau = {torque} [N*m];
  coordinate theta(start = 0.1) [rad];
  T = m/2*l^2*der(theta)^2;
  U = -m*g*l*cos(theta);
  force theta = tau;
end Torque;
""")
    return path


def test_torque_pendulum_equilibrium_where_the_torque_balances(capsys, tmp_path):
    status, out, _ = lagc(capsys, "modes", torque_pendulum(tmp_path, 5.0), "--find")
    assert status == 0 and f"theta = {math.asin(5 / 9.81):.6g}" in out


BAD_INPUT = [
    (["modes", "cartesian_pendulum.lag", "--at", "x=0.5", "--at", "y=0"],
     "--at: the state is not on constraint 'rod'"),
    (["linearize", "cart_pole_lqr.lag", "--input", "Fx", "-o", "lin.json"], "--input: input 'Fx' is not a parameter"),
    (["linearize", "cart_pole_lqr.lag", "--input", "u", "--output", "tipx", "-o", "lin.json"],
     "--output: no output 'tipx'"),
    (["linearize", "cart_pole_lqr.lag", "-o", "lin.txt"], "-o: cannot tell the format"),
    (["modes", "cart_pole.lag", "--at", "thetta=0"],
     "--at: 'thetta' names no coordinate of model CartPole; did you mean 'theta'?"),
    (["modes", "cart_pole.lag", "--at", "theta"], "--at takes NAME=VALUE"),
    (["modes", "pendulum.lag", "--count", "0"], "--count: expected a whole number >= 1, got '0'"),
    (["modes", "pendulum.lag", "--count", "x"], "--count: expected a whole number >= 1, got 'x'"),
    (["modes", "cartesian_pendulum.lag", "--at", "x=0", "--at", "y=-1", "--at", "y.velocity=1"],
     "--at: the state is not on constraint 'rod' (residual 0, velocity residual -2)"),
    (["linearize", "cartesian_pendulum.lag", "--input", "l", "-o", "lin.json"],
     "cartesian_pendulum.lag:15:3: error: input 'l' appears in constraint 'rod'"),
]


@pytest.mark.parametrize("arguments, message", BAD_INPUT, ids=[m for _, m in BAD_INPUT])
def test_bad_input_exits_2_with_a_located_message(capsys, tmp_path, arguments, message):
    arguments = [MODELS / a if a.endswith(".lag") else tmp_path / a if a.startswith("lin.") else a for a in arguments]
    status, out, err = lagc(capsys, *arguments)
    assert status == 2 and message in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())                  # nothing written


@pytest.mark.parametrize("arguments", [["--frobnicate"], ["--count"], ["--at"]])
def test_a_usage_error_is_bad_input_too(capsys, arguments):
    """lagc modes says a usage error as every lagc command does (the usage, then `lagc: error:`),
    with the exit status of its bad input."""
    with pytest.raises(SystemExit) as stopped:
        lagc(capsys, "modes", MODELS / "pendulum.lag", *arguments)
    err = capsys.readouterr().err
    assert stopped.value.code == 2 and err.startswith("usage: lagc modes") and "lagc: error: " in err


def test_a_model_error_exits_2(capsys, tmp_path):
    path = tmp_path / "bad.lag"
    path.write_text("model Bad\n  coordinate x;\n  T = der(y)^2;\nend Bad;\n")
    status, _, err = lagc(capsys, "modes", path)
    assert status == 2 and "bad.lag:3:" in err and "^" in err


def test_no_equilibrium_near_the_guess_exits_1(capsys, tmp_path):
    """A constant torque larger than m g l: nothing balances it."""
    status, _, err = lagc(capsys, "modes", torque_pendulum(tmp_path, 20.0), "--find")
    assert status == 1 and "Traceback" not in err
    assert "no equilibrium found near the guess" in err and "state: theta = " in err and "remedy:" in err


def test_singular_mass_matrix_at_the_point_exits_1(capsys):
    """The spherical pendulum at its pole: the azimuth stops describing the motion."""
    status, _, err = lagc(capsys, "modes", MODELS / "spherical_pendulum.lag", "--at", "theta=0")
    assert status == 1 and "singular at this state" in err and "Traceback" not in err
