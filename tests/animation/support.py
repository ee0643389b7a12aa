"""Models with draw statements, and reading a page's data back.

The draw statements are added to the IR of library models here, until the front end reads them
from .lag text."""
from __future__ import annotations

import json
import re
from dataclasses import replace

import sympy

import lagdsl
from lagdsl import ir

from ..conftest import MODELS

ZERO = sympy.S.Zero
DATA = re.compile(r'<script type="application/json" id="lagdsl-data">(.*?)</script>', re.S)


def page_data(page: str) -> dict:
    """The record in a page's #lagdsl-data element."""
    found = DATA.findall(page)
    assert len(found) == 1
    return json.loads(found[0])


def with_draws(model, *draws: ir.Draw):
    model.ir = replace(model.ir, draws=draws)
    return model


def lets(model) -> dict[str, sympy.Symbol]:
    return {let.name: let.symbol for let in model.ir.lets if let.span is not None}


def double_pendulum(bob_radius: float | None = None):
    """The library's double pendulum, drawn: the path of the lower bob, the rods, the lower bob
    (y of the model points down; the drawing is the model's x and y as they are)."""
    model = lagdsl.load(MODELS / "double_pendulum.lag")
    x = lets(model)
    lower = (x["x2"], x["y2"])
    values = (("radius", sympy.Float(bob_radius)),) if bob_radius else ()
    return with_draws(model, ir.Draw("trail", (lower,), None),
                      ir.Draw("line", ((ZERO, ZERO), (x["x1"], x["y1"]), lower), None),
                      ir.Draw("point", (lower,), None, values=values))


def heavy_top():
    """The heavy top: its body axes (R = Rz(phi) Rx(theta) Rz(psi), 3-1-3), the line from the
    fixed point to the centre of mass l R e3, and the centre of mass."""
    model = lagdsl.load(MODELS / "heavy_top.lag")
    symbols = {c.name: c.symbol for c in model.ir.coordinates}
    length = next(p.symbol for p in model.ir.parameters if p.name == "l")
    r = _about_z(symbols["phi"]) * _about_x(symbols["theta"]) * _about_z(symbols["psi"])
    centre = tuple(length * r[i, 2] for i in range(3))
    origin = (ZERO, ZERO, ZERO)
    return with_draws(model, ir.Draw("frame", (centre,), None, rotation=tuple(r), values=(("size", length / 2),)),
                      ir.Draw("line", (origin, centre), None),
                      ir.Draw("point", (centre,), None))


def _about_z(angle) -> sympy.Matrix:
    return sympy.Matrix([[sympy.cos(angle), -sympy.sin(angle), 0], [sympy.sin(angle), sympy.cos(angle), 0], [0, 0, 1]])


def _about_x(angle) -> sympy.Matrix:
    return sympy.Matrix([[1, 0, 0], [0, sympy.cos(angle), -sympy.sin(angle)], [0, sympy.sin(angle), sympy.cos(angle)]])
