"""How the picture elements look, in one record read by both renderers: the page's player (it
travels in the page's data as "style") and the GIF/MP4 writer (video.py).

Lengths in pixels are the player's at a 900-pixel-wide canvas; the video scales them with its
frame. The camera of a 3-D picture looks at the centre of everything drawn from the azimuth
(about z, from the x axis) and the elevation (above the x-y plane) given here, orthographically;
the player's camera orbits from there.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Style:
    background: str = "#ffffff"
    colors: tuple[tuple[str, str], ...] = (
        ("line", "#1f3b73"), ("point", "#ee7700"), ("trail", "#8a8a8a"), ("circle", "#1f3b73"),
        ("spring", "#5a5a5a"), ("box", "#1f3b73"))
    axis_colors: tuple[str, str, str] = ("#d62728", "#2ca02c", "#1f77b4")     # a frame's x, y, z
    circle_fill_alpha: float = 0.12     # a circle's disc: its colour, this opaque
    line_width: float = 2.5
    trail_width: float = 1.2
    point_radius: float = 7.0           # a point without a radius
    margin: float = 0.08                # of the canvas, on each side
    spring_coils: int = 8
    spring_width: float = 0.04          # of the picture's extent
    spring_ends: float = 0.12           # the straight part at each end, of the spring's length
    azimuth: float = 35.0               # degrees
    elevation: float = 20.0             # degrees
    reference_width: float = 900.0      # the canvas width the pixel sizes are given for

    def color(self, kind: str) -> str:
        return dict(self.colors)[kind]

    def as_data(self) -> dict:
        record = asdict(self)
        record["colors"] = dict(self.colors)
        return record


STYLE = Style()
