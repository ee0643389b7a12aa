"""The intermediate representation: plain immutable data, each node with its source Span.

Expressions are sympy expressions built node by node from the parse tree (never from text).
Their symbols are: parameters (`Parameter.symbol`), coordinates q and velocities q'
(`Coordinate.symbol`, `Coordinate.velocity_symbol`), time `TIME`, and named intermediates
(`Let.symbol`): the user's lets plus the time derivatives `der(x)` that the chain rule created
for them. Intermediates are defined in `Model.lets` in dependency order, so expressions stay
as shared and small as the user wrote them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import sympy

from .settings import IntegratorChoice, TimeGrid  # noqa: F401  (part of the IR)
from .source import Span

TIME = sympy.Symbol("t", real=True)


def multiplier_symbol(constraint: str) -> sympy.Symbol:
    """λ of a constraint, as it stands in output expressions and in the equations' display."""
    return sympy.Symbol(f"λ[{constraint}]", real=True)


@dataclass(frozen=True)
class Unit:
    """A physical unit as written, `[m/s^2]`, and as base factors {m: 1, s: -2}."""

    text: str
    factors: tuple[tuple[str, Fraction], ...]
    span: Span


@dataclass(frozen=True)
class Parameter:
    name: str
    symbol: sympy.Symbol
    expression: sympy.Expr      # in earlier parameters' symbols
    value: float                # the default, with every earlier default substituted
    unit: Unit | None
    description: str | None
    span: Span
    structural: bool = False    # used in an index range or dimension: fixed at compile time


@dataclass(frozen=True)
class Coordinate:
    name: str                   # as the user refers to it: "theta1" or "theta[2]"
    symbol: sympy.Symbol        # q
    velocity_symbol: sympy.Symbol   # q'
    start: sympy.Expr           # q(0), in parameters
    velocity: sympy.Expr        # q'(0), in parameters
    unit: Unit | None
    description: str | None
    span: Span


@dataclass(frozen=True)
class Let:
    """A named intermediate: a user's let (with its span), or der(x) of a let x (derivative_of).
    A member of a prefix-sum let (or its der) is the member before it plus one term, x[i] =
    x[i-1] + f(i) (frontend/prefix_sums.py): `extends` is that member x[i-1]."""

    name: str
    symbol: sympy.Symbol
    expression: sympy.Expr
    span: Span | None
    derivative_of: sympy.Symbol | None = None
    extends: sympy.Symbol | None = None


@dataclass(frozen=True)
class Lagrangian:
    """Either T and U (natural system, L = T - U) or a general L."""

    kinetic: sympy.Expr | None
    potential: sympy.Expr | None
    general: sympy.Expr | None
    span: Span

    @property
    def expression(self) -> sympy.Expr:
        if self.general is not None:
            return self.general
        return self.kinetic - (self.potential if self.potential is not None else 0)

    @property
    def is_natural(self) -> bool:
        return self.general is None


@dataclass(frozen=True)
class Dissipation:
    expression: sympy.Expr      # Rayleigh function D(q, q', t)
    span: Span


@dataclass(frozen=True)
class Force:
    coordinate: str
    expression: sympy.Expr
    span: Span


@dataclass(frozen=True)
class Constraint:
    name: str
    residual: sympy.Expr        # lhs - rhs, zero on the constraint
    span: Span


@dataclass(frozen=True)
class Output:
    name: str
    expression: sympy.Expr
    unit: Unit | None
    description: str | None
    span: Span


@dataclass(frozen=True)
class Draw:
    """A `draw` statement: a picture element of the animation (draws.KINDS says what each kind
    takes). Every entry is an expression of (q, q', t) and the parameters, in SI units.

    `points` are the kind's point arguments in order (a line's vertices), each a tuple of 2 or
    3 lengths; `rotation` is R's nine entries row by row (frame, box); `edges` the box's edge
    lengths; `values` the named scalars: a circle's radius, a point's radius, the mark's angle,
    a frame's size.
    """

    kind: str
    points: tuple[tuple[sympy.Expr, ...], ...]
    span: Span | None
    rotation: tuple[sympy.Expr, ...] | None = None
    edges: tuple[sympy.Expr, sympy.Expr, sympy.Expr] | None = None
    values: tuple[tuple[str, sympy.Expr], ...] = ()

    @property
    def dimension(self) -> int:
        return len(self.points[0])


@dataclass(frozen=True)
class ParameterOverride:
    name: str
    value: float
    span: Span | None


@dataclass(frozen=True)
class InitialOverride:
    coordinate: str
    start: float | None
    velocity: float | None
    span: Span | None


@dataclass(frozen=True)
class OutputRequest:
    """One column of a scene's output: `column` is the text as written (the CSV header).

    `kind` is "expression" (with `expression` set) or a built-in observable, "energy",
    "momentum", "multiplier" or "residual" (with `target`, a coordinate or constraint name).
    """

    column: str
    kind: str
    expression: sympy.Expr | None
    target: str | None
    span: Span | None


@dataclass(frozen=True)
class StopCondition:
    """`stop when a < b;` (or `a > b`): the run ends where the condition first holds.

    `function` is e(q, q', t) = a - b (or b - a), so that the condition is e < 0; the run stops at
    the start if it holds there, else at the first root of e where e changes sign to negative.
    """

    text: str                   # the condition as written, for the run summary
    function: sympy.Expr
    span: Span | None


@dataclass(frozen=True)
class Scene:
    name: str
    description: str | None
    time: TimeGrid
    integrator: IntegratorChoice
    parameter_overrides: tuple[ParameterOverride, ...]
    initial_overrides: tuple[InitialOverride, ...]
    outputs: tuple[OutputRequest, ...]
    span: Span | None
    stop: StopCondition | None = None
    draws: tuple[Draw, ...] = ()        # drawn in this scene, after the model's own


@dataclass(frozen=True)
class UnitReport:
    """What the dimensional analysis found (model_dimensions.py): the unit each quantity is computed in.

    `quantities` are (name, unit, inferred) of parameters, coordinates and outputs; `columns` are
    (scene, column, unit) of the scenes' output lists. A unit is SI ("kg*m/s^2", "N", "rad"), or
    the unit an output declares (its column is written in it); "?" where none could be inferred.
    `notes` are Diagnostics (severity "note") about what could not be checked.
    """

    quantities: tuple[tuple[str, str, bool], ...]
    columns: tuple[tuple[str, str, str], ...]
    notes: tuple = ()

    def unit_of(self, name: str) -> str:
        return next((unit for quantity, unit, _ in self.quantities if quantity == name), "?")

    def column_units(self, scene: str, columns) -> tuple[str, ...]:
        """The units of a scene's columns: its output list's, or the coordinates' (the default)."""
        listed = {column: unit for owner, column, unit in self.columns if owner == scene}
        return tuple(listed.get(column) or self.unit_of(column) for column in columns)


@dataclass(frozen=True)
class Model:
    name: str
    description: str | None
    parameters: tuple[Parameter, ...]
    coordinates: tuple[Coordinate, ...]
    lets: tuple[Let, ...]
    lagrangian: Lagrangian
    dissipation: Dissipation | None
    forces: tuple[Force, ...]
    constraints: tuple[Constraint, ...]
    outputs: tuple[Output, ...]
    scenes: tuple[Scene, ...]
    span: Span
    source_name: str = field(default="")
    units: UnitReport | None = None     # None: the model has no units, nothing was checked
    draws: tuple[Draw, ...] = ()        # drawn in every scene

    def written_out_lets(self) -> tuple[tuple[sympy.Symbol, sympy.Expr], ...]:
        """(symbol, expression) of each let, a prefix sum's members written out in full as the
        sum unrolls them (x[i] = f(a) + ... + f(i): sympy's Add flattens x[i-1]'s sum into it),
        for the derivations that expand the model (n²/2 terms for n members)."""
        full: dict[sympy.Symbol, sympy.Expr] = {}
        for let in self.lets:
            full[let.symbol] = let.expression if let.extends is None else \
                let.expression.xreplace({let.extends: full[let.extends]})
        return tuple(full.items())
