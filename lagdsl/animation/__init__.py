"""Animations of runs: the draw statements' points at every output time (drawing.py), shown by
a self-contained HTML player (page.py, player.js) or written as a GIF or an MP4 (video.py).

    animation = model.animate("chaos")               # or model.simulate(..., draw=True).animate()
    animation.save("chaos.html")                     # .html, .gif or .mp4
    animation                                        # in Jupyter: the player
"""
from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LagError, Setting
from .drawing import Drawing, Shape, drawing_of  # noqa: F401  (the package's interface)

FORMATS = {".html": "the player, one self-contained page", ".gif": "a GIF (matplotlib's Pillow writer)",
           ".mp4": "an MP4 (ffmpeg)"}
DEFAULT_FPS = 30


@dataclass(frozen=True)
class Animation:
    """What a run draws at its output times `t`, played at `speed` model seconds per second."""

    drawing: Drawing
    t: np.ndarray
    speed: float = 1.0

    def __post_init__(self):
        check_playback(DEFAULT_FPS, self.speed)

    def html(self) -> str:
        """The self-contained page (page.py)."""
        from .page import page_html
        return page_html(self)

    def _repr_html_(self) -> str:
        from .page import notebook_html
        return notebook_html(self)

    def save(self, path: str | os.PathLike, fps: int = DEFAULT_FPS) -> None:
        """Write the page (.html), a GIF (.gif) or an MP4 (.mp4, needs ffmpeg on the PATH) at
        `fps` frames per second; the file appears complete or not at all."""
        from ..run.files import write_output
        check_playback(fps, self.speed)
        kind = check_format(path)
        if kind == ".html":
            write_output(path, self.html())
            return
        from .video import video_bytes
        write_output(path, video_bytes(self, kind, fps))


def check_format(path: str | os.PathLike) -> str:
    """The format of an output file from its name's ending; for .mp4, that ffmpeg is at hand."""
    kind = Path(path).suffix.lower()
    if kind not in FORMATS:
        raise LagError(f"cannot tell what to write from the name '{os.fspath(path)}': it should end in "
                       + ", ".join(f"{ending} ({meaning})" for ending, meaning in FORMATS.items()))
    if kind == ".mp4":
        from .video import require_ffmpeg
        require_ffmpeg()
    return kind


def check_playback(fps, speed, options: bool = False) -> None:
    """A whole number of frames per second >= 1 and a positive, finite speed; `options`: given as
    `lagc animate --fps/--speed`, whose names the messages then carry."""
    if isinstance(fps, bool) or not isinstance(fps, numbers.Integral) or fps < 1:
        raise LagError(f"fps must be a whole number of frames per second >= 1, got {fps!r}",
                       Setting("--fps") if options else None)
    if isinstance(speed, bool) or not isinstance(speed, numbers.Real) or not (math.isfinite(speed) and speed > 0):
        raise LagError(f"speed must be a positive number of model seconds per second of playback, got {speed!r}",
                       Setting("--speed") if options else None)
