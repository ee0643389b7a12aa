"""Library models animate as drawn (the rolling penny in 2-D, the rolling disk in 3-D), and a
scene's own draw statements follow the model's."""
from __future__ import annotations

import numpy as np

from lagdsl.api import Model
from lagdsl.source import SourceFile

from ..conftest import library_model


def test_the_penny_is_a_segment_of_its_diameter_centred_on_its_path():
    """Seen from above, the upright penny is its diameter: of length 2a, centred at (x, y), along
    its heading (sin theta, -cos theta), the direction the rolling constraints let it move."""
    result = library_model("rolling_penny").simulate("roll", stop=2, draw=True)
    trail, diameter = result.drawing.shapes
    position = np.stack([result["x"], result["y"]], axis=1)
    np.testing.assert_allclose(trail.points[:, 0], position, rtol=0, atol=1e-12)
    ends = diameter.points
    np.testing.assert_allclose((ends[:, 0] + ends[:, 1]) / 2, position, rtol=0, atol=1e-12)
    heading = np.stack([np.sin(result["theta"]), -np.cos(result["theta"])], axis=1)
    np.testing.assert_allclose(ends[:, 0] - ends[:, 1], 2 * 0.01 * heading, rtol=0, atol=1e-12)
    assert np.ptp(position[:, 0]) > 0.1         # it has rolled down the ramp


def test_the_rolling_disk_touches_the_ground_where_it_rolls():
    """The rim's point k = 9 (angle 3 pi / 2 in the disk's plane) is the contact point (x, y, 0);
    every rim point is at the radius a = 0.05 from the centre, where the spoke starts."""
    result = library_model("rolling_disk").simulate("curve", stop=1, draw=True)
    assert result.drawing.dimension == 3
    trail, rim, spoke = result.drawing.shapes
    contact = np.stack([result["x"], result["y"], np.zeros_like(result.t)], axis=1)
    np.testing.assert_allclose(trail.points[:, 0], contact, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rim.points[:, 9], contact, rtol=0, atol=1e-12)
    radii = np.linalg.norm(rim.points - spoke.points[:, :1], axis=2)
    np.testing.assert_allclose(radii, 0.05, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(spoke.points[:, 1] - spoke.points[:, 0], axis=1), 0.05, rtol=1e-12)


PENDULUM = """model Pendulum
  parameter l = 1.0 [m];
  parameter g = 9.81 [m/s^2];
  parameter m = 1.0 [kg];
  coordinate theta(start = 1) [rad];
  T = m*l^2*der(theta)^2/2;
  U = -m*g*l*cos(theta);
  draw line({0, 0}, {l*sin(theta), -l*cos(theta)});
  scene traced
    time(stop = 1, interval = 0.1);
    draw trail({l*sin(theta), -l*cos(theta)});
  end traced;
  scene plain
    time(stop = 1, interval = 0.1);
  end plain;
end Pendulum;
"""


def test_a_scene_draws_the_models_statements_then_its_own():
    model = Model(SourceFile("pendulum.lag", PENDULUM))
    traced = model.animate("traced", fps=10).drawing
    assert [shape.kind for shape in traced.shapes] == ["line", "trail"]
    np.testing.assert_array_equal(traced.shapes[1].points[:, 0], traced.shapes[0].points[:, 1])
    assert [shape.kind for shape in model.animate("plain", fps=10).drawing.shapes] == ["line"]
