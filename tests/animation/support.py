"""Models with draw statements, pictures of every kind, and reading a page's data back."""
from __future__ import annotations

import itertools
import json
import re

import numpy as np

from lagdsl.animation import Animation, Drawing, Shape
from lagdsl.api import Model
from lagdsl.frontend.draws import KINDS
from lagdsl.source import SourceFile

from ..conftest import MODELS, library_model

DATA = re.compile(r'<script type="application/json" id="lagdsl-data">(.*?)</script>', re.S)
DRAWS = re.compile(r"\n  draw [^\n]*")


def page_data(page: str) -> dict:
    """The record in a page's #lagdsl-data element."""
    found = DATA.findall(page)
    assert len(found) == 1
    return json.loads(found[0])


def redrawn(name: str, draws: str) -> Model:
    """A library model with its draw statements replaced by `draws` (before its first scene)."""
    text = DRAWS.sub("", (MODELS / f"{name}.lag").read_text())
    at = text.index("\n  scene ")
    return Model(SourceFile(f"{name}.lag", text[:at] + "\n" + draws + text[at:]))


def double_pendulum(bob_radius: float | None = None) -> Model:
    """The double pendulum drawn as in the issue, x and y as the model has them (y down): the
    path of the lower bob, the rods, the lower bob."""
    radius = f", radius = {bob_radius}" if bob_radius else ""
    return redrawn("double_pendulum", "  draw trail({x2, y2});\n  draw line({0, 0}, {x1, y1}, {x2, y2});\n"
                                      f"  draw point({{x2, y2}}{radius});")


def heavy_top() -> Model:
    """The library's heavy top: the path of the centre of mass, the symmetry axis, the body's
    axes at the centre of mass, the centre of mass."""
    return library_model("heavy_top")


def every_kind(dimension: int) -> Animation:
    """Two frames of every kind drawn in `dimension` (draws.KINDS), as animation/drawing.py shapes
    them, on a picture of about 4 m: a line, a point, a trail and a spring from (2, 0) to (3, 0)
    (at z = 0 in 3-D); in 2-D a circle of radius 1 at the origin, its mark at angle 0, then pi/2;
    in 3-D a frame of size 2 at (0, 0, 2) and a unit cube at the origin, turned about z by 0.3 rad
    in the second frame."""
    path = np.array([[[-2.0, 1.0], [-1.0, 2.0]], [[-2.0, 1.5], [-1.5, 2.0]]])
    shapes = [Shape("line", path), Shape("point", path[:, 1:]), Shape("trail", path[:, :1]),
              Shape("spring", np.array([[[2.0, 0.0], [3.0, 0.0]]] * 2))]
    if dimension == 2:
        shapes.append(Shape("circle", np.array([[[0.0, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]]])))
    else:
        shapes = [Shape(s.kind, np.concatenate([s.points, np.zeros(s.points.shape[:2] + (1,))], axis=2))
                  for s in shapes]
        turns = [np.eye(3), np.array([[np.cos(0.3), -np.sin(0.3), 0], [np.sin(0.3), np.cos(0.3), 0], [0, 0, 1]])]
        signs = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))
        shapes += [Shape("frame", np.array([np.vstack([[0, 0, 2.0], 2.0 * np.eye(3) + [0, 0, 2.0]])] * 2)),
                   Shape("box", np.array([signs @ turn.T for turn in turns]))]
    assert sorted(s.kind for s in shapes) == sorted(k for k, kind in KINDS.items() if dimension in kind.dimensions)
    return Animation(Drawing(f"every kind in {dimension}-D", tuple(shapes)), np.array([0.0, 1.0]))
