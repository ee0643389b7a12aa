"""A run asked to draw: the draw statements computed by the generated code as further columns,
taken out into the result's drawing (simulate(draw=True), result.animate(), model.animate())."""
from __future__ import annotations

import numpy as np
import pytest

from lagdsl import LagError, SimulationError

from ..conftest import library_model
from .support import double_pendulum, page_data


def lower_bob(result) -> np.ndarray:
    """x2, y2 of the double pendulum (l1 = l2 = 1) from the run's angles."""
    theta1, theta2 = result["theta1"], result["theta2"]
    return np.stack([np.sin(theta1) + np.sin(theta2), np.cos(theta1) + np.cos(theta2)], axis=1)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_the_drawing_holds_the_points_at_every_output_time(backend):
    model = double_pendulum()
    result = model.simulate("chaos", backend, stop=2, draw=True)
    plain = model.simulate("chaos", backend, stop=2)
    assert result.columns == plain.columns == ("theta1", "theta2", "energy")
    assert np.array_equal(result.values, plain.values)          # drawing does not change the run
    trail, line, point = result.drawing.shapes
    assert [s.kind for s in result.drawing.shapes] == ["trail", "line", "point"]
    assert line.points.shape == (len(result.t), 3, 2)
    np.testing.assert_allclose(point.points[:, 0], lower_bob(result), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(line.points[:, 0], 0.0)
    assert point.radius is None


def test_both_backends_draw_the_same_motion():
    model = double_pendulum()
    c, numpy = (model.simulate("chaos", backend, stop=1, draw=True) for backend in ("c", "numpy"))
    np.testing.assert_allclose(c.drawing.shapes[1].points, numpy.drawing.shapes[1].points, rtol=0, atol=1e-9)


def test_the_page_holds_the_drawing_exactly():
    model = double_pendulum(bob_radius=0.05)
    result = model.simulate("chaos", stop=1, draw=True)
    data = page_data(result.animate().html())
    assert data["times"] == result.t.tolist()
    assert data["dimension"] == 2 and data["speed"] == 1
    assert [d["kind"] for d in data["draws"]] == ["trail", "line", "point"]
    assert data["draws"][2]["points"] == result.drawing.shapes[2].points.tolist()     # bit for bit
    assert data["draws"][2]["radius"] == [0.05] * len(result.t)
    assert data["draws"][1]["radius"] is None


def test_model_animate_runs_one_row_per_frame():
    animation = double_pendulum().animate("chaos", fps=10, speed=2, stop=3)
    np.testing.assert_allclose(np.diff(animation.t), 0.2, rtol=1e-12)
    assert animation.t[-1] == 3 and animation.speed == 2


def test_a_failed_run_keeps_the_drawing_of_its_rows():
    model = double_pendulum()
    with pytest.raises(SimulationError) as failure:
        model.simulate("chaos", stop=20, max_steps=200, draw=True)
    partial = failure.value.partial
    assert 0 < len(partial.t) < 2001 and partial.columns == ("theta1", "theta2", "energy")
    assert partial.drawing.shapes[2].points.shape[0] == len(partial.t)
    np.testing.assert_allclose(partial.drawing.shapes[2].points[:, 0], lower_bob(partial), atol=1e-12)


def test_a_result_run_without_drawing_says_how_to_get_one():
    with pytest.raises(LagError, match=r"draw=True"):
        double_pendulum().simulate("chaos", stop=0.1).animate()


def test_a_model_without_draw_statements_is_refused_where_it_is_declared():
    model = library_model("kepler")
    with pytest.raises(LagError) as refused:
        model.animate()
    assert "draws nothing" in str(refused.value) and "kepler.lag:" in str(refused.value)


@pytest.mark.parametrize("fps, speed", [(0, 1), (2.5, 1), (30, 0), (30, -1), (30, float("nan")), (30, float("inf"))])
def test_playback_settings_are_checked(fps, speed):
    with pytest.raises(LagError, match="fps|speed"):
        double_pendulum().animate("chaos", fps=fps, speed=speed, stop=0.1)


def test_a_drawn_run_leaves_the_plain_runs_of_the_scene_alone():
    """The drawn program is kept apart from the scene's own (and from its warm plan)."""
    model = double_pendulum()
    model.simulate("chaos", stop=0.5, draw=True)
    again = model.simulate("chaos", stop=0.5)
    assert again.drawing is None and again.values.shape[1] == 3
