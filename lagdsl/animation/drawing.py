"""The draw statements' channels at every frame -> the points each picture element shows.

The generated code evaluates every channel of every draw statement (draws.channels) as a further
output column of the run, so the C and NumPy backends give the same numbers and nothing is
evaluated twice. Here the columns become points, by geometry alone:

  line, point, trail, spring   the points as written
  circle     the centre C and the mark on the rim, C + r (cos a, sin a), a the angle (default 0)
  frame      the origin O and the tips of the axes, O + s R e_k (k = 1, 2, 3): R's columns scaled
             by the size s (default: a fifth of the extent of everything else drawn, or 1)
  box        the eight corners O + R (±a/2, ±b/2, ±c/2), corner 4i + 2j + k taking the + sign of
             edge 1 when i = 1, of edge 2 when j = 1, of edge 3 when k = 1
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..frontend import draws

if TYPE_CHECKING:           # lagc's commands import this module, and a warm `lagc run` imports no sympy
    from .. import ir

FRAME_SIZE = 0.2        # a frame's axes without a size: this fraction of the picture's extent


@dataclass(frozen=True)
class Shape:
    """One draw statement's picture element at every frame: `points` has the shape
    (frames, points, 2 or 3); `radius` (frames,) is a point's radius where one was given."""

    kind: str
    points: np.ndarray
    radius: np.ndarray | None = None

    @property
    def dimension(self) -> int:
        return self.points.shape[2]


@dataclass(frozen=True)
class Drawing:
    """What a run draws: its title and one Shape per draw statement, in the order written."""

    title: str
    shapes: tuple[Shape, ...]

    @property
    def dimension(self) -> int:
        return self.shapes[0].dimension


def drawing_of(title: str, statements: tuple[ir.Draw, ...], columns: np.ndarray) -> Drawing:
    """The shapes of the draw statements from their channels' columns, (frames, channels) in
    the order of draws.channels, statement after statement. Frames come last: their default
    size follows from the extent of everything else."""
    bounds = np.cumsum([0] + [len(draws.channels(statement)) for statement in statements])
    parts = [_Channels(statement, columns[:, start:stop]) for statement, start, stop in
             zip(statements, bounds[:-1], bounds[1:])]
    shapes = {i: part.shape() for i, part in enumerate(parts) if part.kind != "frame"}
    extent = _extent(list(shapes.values()))
    shapes.update({i: part.frame(extent) for i, part in enumerate(parts) if part.kind == "frame"})
    return Drawing(title, tuple(shapes[i] for i in range(len(parts))))


class _Channels:
    """One statement's channels, split into its points, rotation, edges and named values."""

    def __init__(self, statement: ir.Draw, channels: np.ndarray):
        frames, dimension = channels.shape[0], statement.dimension
        self.kind, self.frames = statement.kind, frames
        count = len(statement.points) * dimension
        self.points = channels[:, :count].reshape(frames, len(statement.points), dimension)
        rest = channels[:, count:]
        self.rotation = self.edges = None
        if statement.rotation is not None:
            self.rotation, rest = rest[:, :9].reshape(frames, 3, 3), rest[:, 9:]
        if statement.edges is not None:
            self.edges, rest = rest[:, :3], rest[:, 3:]
        self.values = {name: rest[:, i] for i, (name, _) in enumerate(statement.values)}

    def shape(self) -> Shape:
        """Every kind but frame (see the module docstring)."""
        if self.kind == "circle":
            centre, angle = self.points[:, 0], self.values.get("angle", np.zeros(self.frames))
            mark = centre + self.values["radius"][:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)
            return Shape("circle", np.stack([centre, mark], axis=1))
        if self.kind == "box":
            signs = np.array(list(itertools.product((-0.5, 0.5), repeat=3)))     # (8, 3), corner 4i + 2j + k
            offsets = np.einsum("fij,fcj->fci", self.rotation, signs[None] * self.edges[:, None, :])
            return Shape("box", self.points[:, :1] + offsets)
        return Shape(self.kind, self.points, self.values.get("radius"))

    def frame(self, extent: float) -> Shape:
        """The origin and the tips of R's columns at the given size, or at FRAME_SIZE of `extent`."""
        default = FRAME_SIZE * extent if extent > 0 else 1.0
        size = self.values.get("size", np.full(self.frames, default))
        tips = self.points[:, :1] + np.transpose(self.rotation, (0, 2, 1)) * size[:, None, None]
        return Shape("frame", np.concatenate([self.points[:, :1], tips], axis=1))


def _extent(shapes: list[Shape]) -> float:
    """The diagonal of the box that holds every finite point of the shapes at every frame."""
    if not shapes:
        return 0.0
    dimension = shapes[0].dimension
    points = np.concatenate([s.points.reshape(-1, dimension) for s in shapes])
    points = points[np.all(np.isfinite(points), axis=1)]
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0))) if len(points) else 0.0
