"""What each `draw` statement takes: one record per kind of picture element, read by the front
end (draw_statements.py: arguments, options, 2-D or 3-D; model_dimensions.py: what each argument
is in units), the scene plan (scene.py: the columns computed) and the animation
(animation/drawing.py: the points each element shows).

An argument's role says what it is and so what its dimension must be:

  point     a 2- or 3-vector of lengths, {x, y} or {x, y, z}: where something is
  points    one or more points (a polyline's vertices)
  length    a scalar length (a radius, an axis's length)
  angle     a dimensionless scalar (the turning mark's angle, from the x axis, counterclockwise)
  rotation  a 3x3 dimensionless matrix R, body to space: its columns are the body's axes in space
  edges     a 3-vector of lengths, the box's edges along R's columns

A plain number is taken in SI units (as a scene's time(stop = 20) is in seconds).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Role:
    words: str                  # what an argument of the role is, in messages: "a point"
    # each of its components is a length to this power: 1 a length, 0 a plain number (an exponent,
    # not a units.Dimension: the animation reads this module, and a warm run imports no sympy)
    length_power: int


ROLES = {"point": Role("a point", 1), "points": Role("points", 1), "length": Role("a length", 1),
         "angle": Role("an angle", 0), "rotation": Role("a rotation matrix", 0),
         "edges": Role("a 3-vector of edge lengths", 1)}


@dataclass(frozen=True)
class DrawKind:
    name: str
    arguments: tuple[tuple[str, str], ...]      # (name, role) in the order written
    options: tuple[tuple[str, str], ...]        # `name = value` after them: (name, role)
    dimensions: tuple[int, ...]                 # 2-D, 3-D or both
    meaning: str
    least_points: int = 1                       # a kind whose argument is `points`: at least this many


KINDS = {kind.name: kind for kind in (
    DrawKind("line", (("vertices", "points"),), (), (2, 3),
             "a polyline through the points (links, rods)", least_points=2),
    DrawKind("point", (("positions", "points"),), (("radius", "length"),), (2, 3),
             "a bob or a particle at each point; its radius as given, else a fixed size on the screen"),
    DrawKind("trail", (("positions", "points"),), (), (2, 3),
             "the path each point has left up to the time shown"),
    DrawKind("circle", (("centre", "point"), ("radius", "length")), (("angle", "angle"),), (2,),
             "a disc, wheel or hoop, with a mark on the rim at the angle (default 0), which turns with it"),
    DrawKind("spring", (("ends", "points"),), (), (2, 3),
             "a zigzag from each point to the next", least_points=2),
    DrawKind("frame", (("origin", "point"), ("rotation", "rotation")), (("size", "length"),), (3,),
             "the axes of R (its columns) drawn from the origin, of length size (default: a fifth of "
             "the picture's extent)"),
    DrawKind("box", (("centre", "point"), ("rotation", "rotation"), ("edges", "edges")), (), (3,),
             "a rigid block centred at the point, its edges along R's columns"),
)}

def channels(draw) -> tuple[tuple[str, object], ...]:
    """The scalar expressions a drawn element needs at every frame, labelled, in the order
    animation/drawing.py reads them back: the points' coordinates, R's entries row by row, the
    edges, the named values."""
    axes = "xyz"
    labelled = [(f"point {k + 1} {axes[i]}", x) for k, point in enumerate(draw.points) for i, x in enumerate(point)]
    labelled += [(f"R[{i // 3 + 1},{i % 3 + 1}]", x) for i, x in enumerate(draw.rotation or ())]
    labelled += [(f"edge {i + 1}", x) for i, x in enumerate(draw.edges or ())]
    return tuple(labelled) + tuple(draw.values)


def column_name(statement: int, label: str) -> str:
    """The hidden output column of a draw statement's channel (statement counted from 1)."""
    return f"draw {statement}: {label}"
