"""`lagc animate` end to end: the page's data against `lagc run`, the formats, the errors."""
from __future__ import annotations

import csv
import io
import math

import numpy as np
import pytest

from ..conftest import MODELS, lagc_in_process as lagc
from .support import page_data

PENDULUM = MODELS / "double_pendulum.lag"      # draws its rods as line({0, 0}, {x1, -y1}, {x2, -y2})


def test_the_page_holds_what_lagc_run_computes(tmp_path):
    """The issue's check: the lower bob in the page at three times is where lagc run's angles put
    it, (sin(theta1) + sin(theta2), -(cos(theta1) + cos(theta2))) with l1 = l2 = 1, to 1e-12."""
    page = tmp_path / "pendulum.html"
    done = lagc("animate", PENDULUM, "-o", page, "--stop", 3, "--fps", 10)
    assert done.returncode == 0, done.stderr
    assert "integrator dop853" in done.stderr
    data = page_data(page.read_text())
    run = lagc("run", PENDULUM, "--stop", 3, "--interval", 0.1)
    rows = list(csv.reader(io.StringIO(run.stdout)))
    assert rows[0] == ["t", "theta1", "theta2", "energy"]
    table = np.array(rows[1:], dtype=float)
    assert np.array_equal(table[:, 0], data["times"])
    line = np.array(data["draws"][1]["points"])          # (frames, 3 points, 2)
    for row in (5, 17, 30):
        theta1, theta2 = table[row, 1:3]
        bob = (math.sin(theta1) + math.sin(theta2), -(math.cos(theta1) + math.cos(theta2)))
        np.testing.assert_allclose(line[row, 2], bob, rtol=0, atol=1e-12)


def test_a_gif_at_the_frames_and_speed_given(tmp_path):
    from PIL import Image
    gif = tmp_path / "pendulum.gif"
    assert lagc("animate", PENDULUM, "-o", gif, "--stop", 2, "--fps", 5, "--speed", 0.5).returncode == 0
    with Image.open(gif) as frames:
        assert frames.n_frames == 21           # 2 model seconds at 0.5 per second, 5 frames a second


@pytest.mark.parametrize("arguments, message", [
    (("-o", "{dir}/run.txt"), "should end in .html"),
    (("-o", "{dir}/run.html", "--fps", "0"), "--fps: expected a whole number >= 1"),
    (("-o", "{dir}/run.html", "--speed", "-2"), "--speed: speed must be a positive number"),
    (("-o", "{dir}/nowhere/run.html"), "does not exist"),
])
def test_bad_options_are_refused_before_the_run_and_nothing_is_written(tmp_path, arguments, message):
    given = [a.format(dir=tmp_path) for a in arguments]
    done = lagc("animate", PENDULUM, *given)
    assert done.returncode != 0 and message in done.stderr and "Traceback" not in done.stderr
    assert not list(tmp_path.glob("run.*"))


def test_a_model_that_draws_nothing_is_a_located_error(tmp_path):
    done = lagc("animate", MODELS / "kepler.lag", "-o", tmp_path / "kepler.html")
    assert done.returncode == 1
    assert "kepler.lag:" in done.stderr and "draws nothing" in done.stderr
    assert not (tmp_path / "kepler.html").exists()


def test_a_failed_run_writes_the_animation_of_its_rows(tmp_path):
    page = tmp_path / "pendulum.html"
    done = lagc("animate", PENDULUM, "-o", page, "--max-steps", 100)
    assert done.returncode == 1
    assert "simulation failed" in done.stderr and "the run is incomplete" in done.stderr
    data = page_data(page.read_text())
    assert 1 < len(data["times"]) < 600 and len(data["draws"][0]["points"]) == len(data["times"])
