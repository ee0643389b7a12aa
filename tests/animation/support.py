"""Models with draw statements, and reading a page's data back."""
from __future__ import annotations

import json
import re

import lagdsl
from lagdsl.api import Model
from lagdsl.source import SourceFile

from ..conftest import MODELS

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
    return lagdsl.load(MODELS / "heavy_top.lag")
