"""An Animation -> GIF (matplotlib's Pillow writer) or MP4 (matplotlib's ffmpeg writer).

Frame k of the video shows the run at t_0 + k speed/fps: the last output row at or before that
time (with the default grid of `lagc animate`, exactly one row per frame). The picture is the
player's (style.py): fitted once to everything drawn, y (2-D) or z (3-D) up, in 3-D the
orthographic view from the style's azimuth and elevation.
"""
from __future__ import annotations

import itertools
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import LagError
from .style import STYLE

if TYPE_CHECKING:
    from . import Animation

WIDTH, HEIGHT, DPI = 900, 600, 100      # pixels of a frame, and matplotlib's dots per inch


def require_ffmpeg() -> None:
    if shutil.which("ffmpeg") is None:
        raise LagError("writing an MP4 needs ffmpeg on the PATH, and there is none; write FILE.gif "
                       "(through matplotlib's Pillow writer) or FILE.html (the player, one self-contained page) instead")


def video_bytes(animation: "Animation", kind: str, fps: int) -> bytes:
    """The GIF (kind ".gif") or MP4 (".mp4") of the animation at `fps` frames per second."""
    import matplotlib
    matplotlib.use("Agg")
    from matplotlib import animation as writers
    from matplotlib import pyplot
    figure = pyplot.figure(figsize=(WIDTH / DPI, HEIGHT / DPI), dpi=DPI)
    axes = figure.add_axes((0, 0, 1, 1))
    picture = _Picture(animation, axes)
    writer = writers.PillowWriter(fps=fps) if kind == ".gif" else writers.FFMpegWriter(
        fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
    try:
        with tempfile.TemporaryDirectory() as directory:
            path = Path(directory) / f"animation{kind}"
            with writer.saving(figure, str(path), DPI):
                for row in frame_rows(animation.t, animation.speed, fps):
                    picture.draw(row)
                    writer.grab_frame()
            return path.read_bytes()
    finally:
        pyplot.close(figure)


def frame_rows(t: np.ndarray, speed: float, fps: int) -> np.ndarray:
    """The output row each video frame shows: the last at or before t_0 + k speed/fps."""
    count = int(np.floor((t[-1] - t[0]) * fps / speed * (1 + 1e-12))) + 1
    wanted = t[0] + np.arange(count) * speed / fps
    return np.clip(np.searchsorted(t, wanted * (1 + 1e-12) + 1e-300, side="right") - 1, 0, len(t) - 1)


class _Picture:
    """The shapes of one frame on matplotlib axes in the screen plane (u right, v up)."""

    def __init__(self, animation: "Animation", axes):
        self.drawing, self.times, self.axes = animation.drawing, animation.t, axes
        points = np.concatenate([s.points.reshape(-1, self.drawing.dimension) for s in self.drawing.shapes])
        points = points[np.all(np.isfinite(points), axis=1)]
        low, high = (points.min(axis=0), points.max(axis=0)) if len(points) else (np.zeros(2), np.zeros(2))
        self.centre = (low + high) / 2
        self.extent = float(np.linalg.norm(high - low)) or 1.0
        self.limits = self._limits(low, high)
        self.pixel = WIDTH / STYLE.reference_width * 72 / DPI      # a style pixel, in points

    def _limits(self, low: np.ndarray, high: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
        """The u and v ranges shown: the points' box widened by the radii (2-D) or the sphere
        around the points (3-D), with the style's margin, widened to the frame's aspect."""
        if self.drawing.dimension == 3:
            low, high = -self.extent / 2 * np.ones(2), self.extent / 2 * np.ones(2)
        for centre, radius in self._reaches():
            shown = np.isfinite(radius) & np.all(np.isfinite(centre), axis=1)
            if np.any(shown):
                low = np.minimum(low, (centre[shown] - radius[shown, None]).min(axis=0))
                high = np.maximum(high, (centre[shown] + radius[shown, None]).max(axis=0))
        middle, span = (low + high) / 2, high - low
        if not np.all(span > 0):
            span = np.maximum(span, 1e-12 * self.extent) if np.any(span > 0) else np.full(2, self.extent)
        scale = min((1 - 2 * STYLE.margin) * WIDTH / span[0], (1 - 2 * STYLE.margin) * HEIGHT / span[1])
        half = np.array([WIDTH, HEIGHT]) / scale / 2
        return (middle[0] - half[0], middle[0] + half[0]), (middle[1] - half[1], middle[1] + half[1])

    def _reaches(self):
        """(centres, radii) over the frames of what reaches beyond its points in 2-D: the points
        with a radius, the circles."""
        if self.drawing.dimension == 3:
            return
        for shape in self.drawing.shapes:
            if shape.radius is not None:
                yield shape.points[:, 0], shape.radius
            if shape.kind == "circle":
                yield shape.points[:, 0], np.linalg.norm(shape.points[:, 1] - shape.points[:, 0], axis=1)

    def project(self, points: np.ndarray) -> np.ndarray:
        """(..., 2 or 3) model points -> (..., 2) screen-plane points, as the player projects."""
        if self.drawing.dimension == 2:
            return points
        azimuth, elevation = np.radians(STYLE.azimuth), np.radians(STYLE.elevation)
        x, y, z = np.moveaxis(points - self.centre, -1, 0)
        u = -np.sin(azimuth) * x + np.cos(azimuth) * y
        v = -np.sin(elevation) * (np.cos(azimuth) * x + np.sin(azimuth) * y) + np.cos(elevation) * z
        return np.stack([u, v], axis=-1)

    def draw(self, row: int) -> None:
        from matplotlib.collections import LineCollection
        from matplotlib.patches import Circle
        axes = self.axes
        axes.cla()
        axes.set_axis_off()
        axes.set_xlim(*self.limits[0])
        axes.set_ylim(*self.limits[1])
        axes.set_facecolor(STYLE.background)
        for order, shape in enumerate(self.drawing.shapes):       # in the order written, as the player
            for polyline, color, width in self._polylines(shape, row):
                axes.add_collection(LineCollection([polyline], colors=color, linewidths=width * self.pixel,
                                                   capstyle="round", joinstyle="round", zorder=order))
            for centre, radius, fill, edge in self._discs(shape, row):
                axes.add_patch(Circle(centre, radius, facecolor=fill, edgecolor=edge or "none",
                                      linewidth=STYLE.line_width * self.pixel, zorder=order))
        axes.text(0.01, 0.98, f"t = {self.times[row]:.6g} s", transform=axes.transAxes, va="top", fontsize=10)

    def _polylines(self, shape, row: int):
        """(screen points, colour, width in style pixels) of the lines a shape draws at a row."""
        points = self.project(shape.points[row])
        if shape.kind == "line":
            return [(points, STYLE.color("line"), STYLE.line_width)]
        if shape.kind == "trail":
            return [(self.project(shape.points[:row + 1, j]), STYLE.color("trail"), STYLE.trail_width)
                    for j in range(shape.points.shape[1])]
        if shape.kind == "circle":
            return [(points, STYLE.color("circle"), STYLE.line_width)]
        if shape.kind == "spring":
            return [(zigzag(a, b, STYLE.spring_width * self.extent), STYLE.color("spring"), STYLE.line_width * 0.6)
                    for a, b in zip(points[:-1], points[1:])]
        if shape.kind == "frame":
            return [(points[[0, axis]], color, STYLE.line_width) for axis, color in
                    zip((1, 2, 3), STYLE.axis_colors)]
        if shape.kind == "box":
            return [(points[[c, c | bit]], STYLE.color("box"), STYLE.line_width)
                    for c, bit in itertools.product(range(8), (4, 2, 1)) if not c & bit]
        return []

    def _discs(self, shape, row: int):
        """(centre, radius, fill, edge) of the discs a shape draws at a row (radii in model units)."""
        from matplotlib.colors import to_rgb
        if shape.kind == "point":
            radius = shape.radius[row] if shape.radius is not None else \
                STYLE.point_radius * (self.limits[0][1] - self.limits[0][0]) / STYLE.reference_width
            return [(centre, radius, STYLE.color("point"), None) for centre in self.project(shape.points[row])]
        if shape.kind == "circle":
            centre, mark = shape.points[row]
            fill = (*to_rgb(STYLE.color("circle")), STYLE.circle_fill_alpha)
            return [(centre, float(np.linalg.norm(mark - centre)), fill, STYLE.color("circle"))]
        return []


def zigzag(a: np.ndarray, b: np.ndarray, width: float) -> np.ndarray:
    """The spring's polyline from a to b in the screen plane, as the player draws it: straight
    ends, then 2 coils corners alternating across the axis at width/2."""
    axis = b - a
    length = float(np.hypot(*axis))
    if not length > 0:
        return np.array([a, b])
    normal = np.array([-axis[1], axis[0]]) / length
    corners = 2 * STYLE.spring_coils
    along = STYLE.spring_ends + (1 - 2 * STYLE.spring_ends) * (np.arange(corners) + 0.5) / corners
    sides = np.where(np.arange(corners) % 2 == 0, width / 2, -width / 2)
    middle = a + along[:, None] * axis + sides[:, None] * normal
    return np.vstack([a, a + STYLE.spring_ends * axis, middle, b - STYLE.spring_ends * axis, b])
