"""`lagc animate` end to end: the page's data against `lagc run`, the formats, the errors."""
from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from ..conftest import MODELS, lagc_in_process as lagc
from .support import page_data

PENDULUM = """\
model DoublePendulum "the issue's double pendulum"
  parameter m1 = 1.0 [kg];  parameter m2 = 1.0 [kg];
  parameter l1 = 1.0 [m];   parameter l2 = 1.0 [m];   parameter g = 9.81 [m/s^2];
  coordinate theta1(start = 1.0) [rad];
  coordinate theta2(start = 2.0) [rad];
  let x1 = l1*sin(theta1);   let y1 = l1*cos(theta1);
  let x2 = x1 + l2*sin(theta2);   let y2 = y1 + l2*cos(theta2);
  T = m1/2*(der(x1)^2 + der(y1)^2) + m2/2*(der(x2)^2 + der(y2)^2);
  U = -m1*g*y1 - m2*g*y2;
  draw line({0, 0}, {x1, y1}, {x2, y2});
  scene chaos
    time(stop = 20, interval = 0.01);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
    output x2, y2;
  end chaos;
end DoublePendulum;
"""


@pytest.fixture
def pendulum(tmp_path):
    path = tmp_path / "pendulum.lag"
    path.write_text(PENDULUM)
    return path


def test_the_page_holds_what_lagc_run_computes(pendulum, tmp_path):
    """The issue's check: x2, y2 in the page at three times equal lagc run's to 1e-12."""
    page = tmp_path / "pendulum.html"
    done = lagc("animate", pendulum, "-o", page, "--stop", 3, "--fps", 10)
    assert done.returncode == 0, done.stderr
    assert "integrator dop853" in done.stderr
    data = page_data(page.read_text())
    run = lagc("run", pendulum, "--stop", 3, "--interval", 0.1)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    assert rows[0] == ["t", "x2", "y2"]
    table = np.array(rows[1:], dtype=float)
    assert np.array_equal(table[:, 0], data["times"])
    line = np.array(data["draws"][0]["points"])          # (frames, 3 points, 2)
    for row in (5, 17, 30):
        np.testing.assert_allclose(line[row, 2], table[row, 1:], rtol=0, atol=1e-12)


@pytest.mark.slow          # ~10 s (matplotlib draws each frame); test_video.py writes GIFs in the default run
def test_a_gif_at_the_frames_and_speed_given(pendulum, tmp_path):
    from PIL import Image
    gif = tmp_path / "pendulum.gif"
    assert lagc("animate", pendulum, "-o", gif, "--stop", 2, "--fps", 5, "--speed", 0.5).returncode == 0
    with Image.open(gif) as frames:
        assert frames.n_frames == 21           # 2 model seconds at 0.5 per second, 5 frames a second


@pytest.mark.parametrize("arguments, message", [
    (("-o", "{dir}/run.txt"), "should end in .html"),
    (("-o", "{dir}/run.html", "--fps", "0"), "--fps: expected a whole number >= 1"),
    (("-o", "{dir}/run.html", "--speed", "-2"), "--speed: speed must be a positive number"),
    (("-o", "{dir}/nowhere/run.html"), "does not exist"),
])
def test_bad_options_are_refused_before_the_run_and_nothing_is_written(pendulum, tmp_path, arguments, message):
    given = [a.format(dir=tmp_path) for a in arguments]
    done = lagc("animate", pendulum, *given)
    assert done.returncode != 0 and message in done.stderr and "Traceback" not in done.stderr
    assert not list(tmp_path.glob("run.*"))


def test_a_model_that_draws_nothing_is_a_located_error(tmp_path):
    done = lagc("animate", MODELS / "kepler.lag", "-o", tmp_path / "kepler.html")
    assert done.returncode == 1
    assert "kepler.lag:" in done.stderr and "draws nothing" in done.stderr
    assert not (tmp_path / "kepler.html").exists()


def test_a_failed_run_writes_the_animation_of_its_rows(pendulum, tmp_path):
    page = tmp_path / "pendulum.html"
    done = lagc("animate", pendulum, "-o", page, "--max-steps", 100)
    assert done.returncode == 1
    assert "simulation failed" in done.stderr and "the run is incomplete" in done.stderr
    data = page_data(page.read_text())
    assert 1 < len(data["times"]) < 600 and len(data["draws"][0]["points"]) == len(data["times"])
