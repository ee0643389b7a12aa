"""An Animation -> one self-contained HTML page: the player (player.js, plain JavaScript on a
canvas) and the data, with no reference to any network address.

The data sits in `<script type="application/json" id="lagdsl-data">` so that tools and tests can
read what is drawn:

    {"title": ..., "dimension": 2 or 3, "speed": model seconds per second of playback,
     "times": [t_0, ..., t_K],
     "draws": [{"kind": "line", "points": [[[x, y], ...] at t_0, ..., at t_K]},
               {"kind": "point", "points": ..., "radius": [r_0, ..., r_K] or null}, ...],
     "style": the record of animation/style.py}

one entry of "draws" per draw statement, in the order written, with the points that
animation/drawing.py gives for its kind. Numbers are written as Python's repr of a float (the
shortest text that reads back as the same double), so the page holds the run's values exactly;
a value that is not a number (NaN) is null.
"""
from __future__ import annotations

import html
import json
from functools import lru_cache
from importlib import resources
from typing import TYPE_CHECKING

import jinja2
import numpy as np
from markupsafe import Markup

from .. import __version__
from .style import STYLE

if TYPE_CHECKING:
    from . import Animation

FRAME_HEIGHT = 560      # pixels: the player's frame in a notebook


def page_data(animation: "Animation") -> dict:
    """The record the player reads (see the module docstring)."""
    drawing = animation.drawing
    return {
        "title": drawing.title, "dimension": drawing.dimension, "speed": animation.speed,
        "times": _numbers(animation.t),
        "draws": [{"kind": shape.kind, "points": _numbers(shape.points),
                   "radius": None if shape.radius is None else _numbers(shape.radius)} for shape in drawing.shapes],
        "style": STYLE.as_data(),
    }


def data_json(animation: "Animation") -> str:
    """The record as JSON, safe inside a <script> element: every '<' escaped (no '</script>')."""
    text = json.dumps(page_data(animation), separators=(",", ":"), allow_nan=False)
    return text.replace("<", "\\u003c")


def page_html(animation: "Animation") -> str:
    """The whole page: player, controls and data in one file."""
    return _template().render(title=animation.drawing.title, version=__version__,
                              data=Markup(data_json(animation)), script=Markup(_player_script()))


def notebook_html(animation: "Animation") -> str:
    """The page inside an iframe (its own document: several players in one notebook keep apart)."""
    return (f'<iframe srcdoc="{html.escape(page_html(animation), quote=True)}" '
            f'style="width: 100%; height: {FRAME_HEIGHT}px; border: 0" title="lagdsl animation"></iframe>')


def _numbers(values: np.ndarray):
    """Nested lists of floats, None where a value is not finite (JSON has no NaN)."""
    values = np.asarray(values, dtype=float)
    if np.all(np.isfinite(values)):
        return values.tolist()
    return np.where(np.isfinite(values), values, None).tolist()


@lru_cache(maxsize=1)
def _template() -> jinja2.Template:
    environment = jinja2.Environment(loader=jinja2.PackageLoader("lagdsl.animation", "."),
                                     undefined=jinja2.StrictUndefined, autoescape=True,
                                     keep_trailing_newline=True)
    return environment.get_template("player.html.j2")


@lru_cache(maxsize=1)
def _player_script() -> str:
    return resources.files("lagdsl.animation").joinpath("player.js").read_text(encoding="utf-8")
