"""The points each kind of draw statement shows, from its channels (animation/drawing.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy

from lagdsl import ir
from lagdsl.frontend import draws
from lagdsl.animation import drawing_of

A, B, C, D = sympy.symbols("a b c d")      # stand-ins: drawing_of reads the columns, not the expressions


def shapes(*statements: ir.Draw, columns) -> tuple:
    """The shapes of the statements from one row per frame of their channels, in order."""
    values = np.atleast_2d(np.asarray(columns, dtype=float))
    assert values.shape[1] == sum(len(draws.channels(s)) for s in statements)
    return drawing_of("test", statements, values).shapes


def test_line_point_trail_and_spring_show_their_points_as_given():
    line = ir.Draw("line", ((A, B), (C, D), (A, D)), None)
    point = ir.Draw("point", ((A, B),), None, values=(("radius", C),))
    row = [1, 2, 3, 4, 5, 6] + [7, 8, 0.5]
    drawn = shapes(line, point, columns=[row, [x + 1 for x in row]])
    assert drawn[0].points.shape == (2, 3, 2)
    assert drawn[0].points[1].tolist() == [[2, 3], [4, 5], [6, 7]]
    assert drawn[1].points[0, 0].tolist() == [7, 8]
    assert drawn[1].radius.tolist() == [0.5, 1.5]


def test_circle_shows_its_centre_and_the_mark_at_its_angle():
    circle = ir.Draw("circle", ((A, B),), None, values=(("radius", C), ("angle", D)))
    drawn = shapes(circle, columns=[[1, 2, 0.5, math.pi / 2], [1, 2, 0.5, 0]])[0]
    np.testing.assert_allclose(drawn.points[0], [[1, 2], [1, 2.5]], atol=1e-15)
    np.testing.assert_allclose(drawn.points[1], [[1, 2], [1.5, 2]], atol=1e-15)


def test_circle_without_an_angle_marks_the_rim_on_the_x_axis():
    circle = ir.Draw("circle", ((A, B),), None, values=(("radius", C),))
    assert shapes(circle, columns=[[0, 0, 2]])[0].points[0].tolist() == [[0, 0], [2, 0]]


def test_frame_shows_the_columns_of_R_at_its_size():
    quarter_turn = (0, -1, 0, 1, 0, 0, 0, 0, 1)        # about z: body x -> space y, body y -> space -x
    frame = ir.Draw("frame", ((A, B, C),), None, rotation=(D,) * 9, values=(("size", A),))
    drawn = shapes(frame, columns=[[1, 2, 3, *quarter_turn, 2]])[0]
    assert drawn.points[0].tolist() == [[1, 2, 3], [1, 4, 3], [-1, 2, 3], [1, 2, 5]]


def test_frame_without_a_size_takes_a_fifth_of_the_extent_of_the_rest():
    line = ir.Draw("line", ((A, A, A), (B, B, B)), None)
    frame = ir.Draw("frame", ((A, A, A),), None, rotation=(D,) * 9)
    identity = (1, 0, 0, 0, 1, 0, 0, 0, 1)
    drawn = shapes(frame, line, columns=[[0, 0, 0, *identity, 0, 0, 0, 3, 4, 12]])
    size = 0.2 * 13                                     # the line's box has the diagonal 13
    np.testing.assert_allclose(drawn[0].points[0, 1:], size * np.eye(3))
    assert drawn[1].kind == "line"                     # the order of the statements is kept


def test_box_corners_follow_R_and_the_edges():
    box = ir.Draw("box", ((A, B, C),), None, rotation=(D,) * 9, edges=(A, B, C))
    quarter_turn = (0, -1, 0, 1, 0, 0, 0, 0, 1)
    drawn = shapes(box, columns=[[1, 1, 1, *quarter_turn, 2, 4, 6]])[0]
    corners = drawn.points[0]
    assert corners.shape == (8, 3)
    # corner 4i + 2j + k takes +a/2 along R's first column (space y) when i = 1, +b/2 along the
    # second (space -x) when j = 1, +c/2 along z when k = 1
    np.testing.assert_allclose(corners[0], [1 + 2, 1 - 1, 1 - 3])
    np.testing.assert_allclose(corners[4], [1 + 2, 1 + 1, 1 - 3])
    np.testing.assert_allclose(corners[7], [1 - 2, 1 + 1, 1 + 3])


@pytest.mark.parametrize("kind", sorted(draws.KINDS))
def test_every_kind_has_a_painter_in_the_player_and_the_video(kind):
    from importlib import resources
    player = resources.files("lagdsl.animation").joinpath("player.js").read_text()
    video = resources.files("lagdsl.animation").joinpath("video.py").read_text()
    assert f"    {kind}: function" in player
    assert f'"{kind}"' in video
