"""The values of the expression language, and what names mean.

A value is a scalar (a sympy expression), a 3-vector (`Vector`) or a 3x3 matrix (`Matrix`). A
name is bound in a `Scope` to a `Binding`: its value (or, for an indexed family, its members)
and its dimension (dimensions.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from .dimensions import Form
from ..errors import LagError, suggest
from ..source import Span

AXES = ("x", "y", "z")
# A Binding's kind in words, for messages ("'m' is a parameter, not a function").
KIND_WORDS = {"parameter": "a parameter", "coordinate": "a coordinate", "let": "a let",
              "output": "an output", "pending output": "an output", "constraint": "a constraint",
              "loop": "an index", "partial": "a let", "invalid": "a name whose declaration failed"}


@dataclass(frozen=True)
class Vector:
    """A 3-vector {x, y, z} of scalar expressions."""

    components: tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Matrix:
    """A 3x3 matrix of scalar expressions, row by row (a rotation matrix, an inertia tensor)."""

    rows: tuple[tuple[sympy.Expr, ...], ...]

    @property
    def components(self) -> tuple[sympy.Expr, ...]:
        return tuple(entry for row in self.rows for entry in row)

    def column(self, j: int) -> tuple[sympy.Expr, ...]:
        return tuple(row[j] for row in self.rows)


def is_array(value) -> bool:
    """A 3-vector or a 3x3 matrix, not a scalar."""
    return isinstance(value, (Vector, Matrix))


def kind_of(value) -> str:
    return "a 3-vector" if isinstance(value, Vector) else "a 3x3 matrix" if isinstance(value, Matrix) else "a scalar"


def map_value(value, function):
    """`function` applied to a scalar, or to each component of a vector or matrix."""
    if isinstance(value, Vector):
        return Vector(tuple(function(c) for c in value.components))
    if isinstance(value, Matrix):
        return matrix_of([function(c) for c in value.components])
    return function(value)


def matrix_of(entries) -> Matrix:
    """The 3x3 matrix of nine entries, row by row."""
    return Matrix(tuple(tuple(entries[3 * i:3 * i + 3]) for i in range(3)))


def dot(a, b) -> sympy.Expr:
    return sympy.Add(*(x * y for x, y in zip(a, b)))


def matrix_product(left: Matrix, right):
    """A*B or A*v, as in linear algebra."""
    if isinstance(right, Vector):
        return Vector(tuple(dot(row, right.components) for row in left.rows))
    return Matrix(tuple(tuple(dot(row, right.column(j)) for j in range(3)) for row in left.rows))


def rotation(axis: str, angle) -> Matrix:
    """The active rotation by `angle` about the x, y or z axis (right-handed): rotz(a)*{1, 0, 0}
    is {cos(a), sin(a), 0}. As the orientation of a body, it maps body to space components."""
    c, s = sympy.cos(angle), sympy.sin(angle)
    i = AXES.index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3
    entries = [[sympy.S.Zero] * 3 for _ in range(3)]
    entries[i][i] = sympy.S.One
    entries[j][j], entries[j][k], entries[k][j], entries[k][k] = c, -s, s, c
    return Matrix(tuple(tuple(row) for row in entries))


def body_rates(convention: str, angles, rates) -> Vector:
    """The angular velocity in body axes of R = euler_<convention>(angles), in closed form.

    zxz (Goldstein's x-convention, R = rotz(phi) rotx(theta) rotz(psi)):
        w1 = phi' sin(theta) sin(psi) + theta' cos(psi)
        w2 = phi' sin(theta) cos(psi) - theta' sin(psi)
        w3 = phi' cos(theta) + psi'
    zyx (yaw psi, pitch theta, roll phi, R = rotz(psi) roty(theta) rotx(phi)):
        w1 = phi' - psi' sin(theta)
        w2 = theta' cos(phi) + psi' cos(theta) sin(phi)
        w3 = psi' cos(theta) cos(phi) - theta' sin(phi)
    """
    sin, cos = sympy.sin, sympy.cos
    if convention == "zxz":
        (phi, theta, psi), (dphi, dtheta, dpsi) = angles, rates
        return Vector((dphi * sin(theta) * sin(psi) + dtheta * cos(psi),
                       dphi * sin(theta) * cos(psi) - dtheta * sin(psi),
                       dphi * cos(theta) + dpsi))
    (psi, theta, phi), (dpsi, dtheta, dphi) = angles, rates
    return Vector((dphi - dpsi * sin(theta),
                   dtheta * cos(phi) + dpsi * cos(theta) * sin(phi),
                   dpsi * cos(theta) * cos(phi) - dtheta * sin(phi)))


@dataclass(frozen=True)
class Binding:
    """What a name means: `value` is a scalar, Vector or Matrix; `family` maps indices to values;
    `dimension` is the dimension of the value (of each member), a Form or a tuple of Forms."""

    kind: str                       # parameter, coordinate, let, output, loop, time, constant, constraint
    span: Span | None
    value: object = None
    family: dict | None = None
    dimension: object = None


class PoisonedName(LagError):
    """A use of a name whose declaration already failed: reported once, at the declaration."""

    def __init__(self):
        super().__init__("poisoned")
        self.diagnostics = ()


class Scope:
    """Names visible at a point of the model, with lookups that suggest close matches.

    `observable`, set where outputs are built, gives the value of a built-in observable call
    such as multiplier(rod): observable(name, arguments, span). Elsewhere it is None.
    """

    def __init__(self, bindings: dict[str, Binding] | None = None, observable=None):
        self.bindings: dict[str, Binding] = dict(bindings or {})
        self.observable = observable

    def child(self, **loops: int) -> "Scope":
        """This scope with loop indices bound to numbers (plain numbers: dimensionless)."""
        scope = type(self)(self.bindings, self.observable)
        for name, value in loops.items():
            scope.bindings[name] = Binding("loop", None, sympy.Integer(value), dimension=Form())
        return scope

    def lookup(self, name: str, span: Span) -> Binding:
        if name not in self.bindings:
            raise LagError(f"undefined name '{name}'{suggest(name, self.bindings)}", span)
        return self.bindings[name]
