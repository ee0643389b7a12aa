"""The `draw` statements of a model and of its scenes -> ir.Draw (draws.KINDS says what each
kind takes):

    draw line({0, 0}, {x1, y1}, {x2, y2});          points {x, y} (2-D) or 3-vectors (3-D)
    draw line({0, 0}, {x[i], y[i]}, i in 1:n);      a range repeats the point written before it
    draw point(bob, radius = 0.05);                 options, `name = value`, after the arguments

A 2-D point is written as braces of two scalars; a 3-D point is any 3-vector (braces of three,
a vector let). All the points of a statement are 2-D or all 3-D, and so are all the statements
a scene draws (the model's, then its own): they make one picture.
"""
from __future__ import annotations

import lark
import sympy

from .. import ir
from ..errors import LagError, suggest
from .draws import KINDS, ROLES, DrawKind
from .expressions import ExpressionBuilder
from .model_dimensions import ModelDimensions
from .tree import subtrees
from .values import Matrix, Scope, Vector, kind_of


class DrawStatements:
    """Draw statements: a part of semantics._ModelBuilder, whose state it reads (expr, dims) and
    extends (draws), and whose helper it calls (output_scope); scene_statements.py calls `draw`
    for a scene's own."""

    def draw_statement(self, node) -> None:
        """A draw statement among the declarations: drawn in every scene."""
        self.draws.append(self.draw(node, self.draws))

    def draw(self, node, picture: list[ir.Draw]) -> ir.Draw:
        """A picture element of the animation, in the outputs' scope, 2-D or 3-D as the first
        element of the `picture` it joins."""
        drawn = build_draw(node, self.expr, self.output_scope(), self.dims)
        if picture and drawn.dimension != picture[0].dimension:
            raise LagError(f"this draw statement is {drawn.dimension}-D, but the picture it belongs to is "
                           f"{picture[0].dimension}-D (line {picture[0].span.line}): a scene draws in 2-D or "
                           "in 3-D", drawn.span)
        return drawn


def build_draw(node: lark.Tree, expressions: ExpressionBuilder, scope: Scope, dims: ModelDimensions) -> ir.Draw:
    """The ir.Draw of a `draw` statement, its expressions built in `scope`, their dimensions
    checked by `dims`."""
    name = node.children[1]
    kind = KINDS.get(str(name))
    if kind is None:
        raise LagError(f"there is no picture element '{name}'{suggest(str(name), KINDS)} "
                       f"(draw {', '.join(KINDS)})", expressions.span(name))
    arguments = subtrees(node)
    positional = [a for a in arguments if a.data != "draw_option"]
    options = [a for a in arguments if a.data == "draw_option"]
    if options and positional and arguments.index(options[0]) < arguments.index(positional[-1]):
        raise LagError(f"draw {kind.name}(): the options (name = value) come after the arguments",
                       expressions.span(options[0]))
    statement = _Statement(kind, node, expressions, scope, dims)
    return statement.build(_expand(positional, expressions, scope), options)


def _expand(positional: list, expressions: ExpressionBuilder, scope: Scope) -> list[tuple[lark.Tree, Scope, str]]:
    """The arguments as (node, scope, index), each range `i in a:b` replaced by the argument
    before it once for each i, read with i bound (index "i"; "" for an argument not repeated)."""
    items: list[tuple[lark.Tree, Scope, str]] = []
    repeatable = False
    for argument in positional:
        if argument.data != "iteration":
            items.append((argument, scope, ""))
            repeatable = True
            continue
        if not repeatable:
            raise LagError("a range 'i in a:b' repeats the point written before it, and there is none",
                           expressions.span(argument))
        body = items.pop()[0]
        variable, low, high = expressions.numbers.iteration(argument, scope)
        items += [(body, scope.child(**{variable: index}), variable) for index in range(low, high + 1)]
        repeatable = False
    return items


class _Statement:
    def __init__(self, kind: DrawKind, node: lark.Tree, expressions: ExpressionBuilder, scope: Scope,
                 dims: ModelDimensions):
        self.kind, self.node, self.expressions, self.scope, self.dims = kind, node, expressions, scope, dims
        self.span = expressions.span(node)

    def build(self, items: list[tuple[lark.Tree, Scope, str]], options: list[lark.Tree]) -> ir.Draw:
        listed = self.kind.arguments[0][1] == "points"      # then the kind's only argument
        if len(items) < self.kind.least_points if listed else len(items) != len(self.kind.arguments):
            raise LagError(f"draw {self.kind.name}() takes {self.signature()}, not {len(items)} argument"
                           f"{'s' if len(items) != 1 else ''}", self.span)
        points, values, rotation, edges = [], [], None, None
        for (argument_name, role), taken in zip(self.kind.arguments, self.split(items)):
            if role in ("point", "points"):
                points += [self.point(node, scope) for node, scope, _ in taken]
            elif role == "rotation":
                rotation = self.array(taken[0], Matrix, role)
            elif role == "edges":
                edges = self.array(taken[0], Vector, role)
            else:
                values.append((argument_name, self.scalar(taken[0], role)))
            what = "a point's coordinate" if "point" in role else f"the {argument_name}"
            checked = {id(node): (node, index) for node, _, index in taken}      # a range's body once
            for node, index in checked.values():
                self.dims.drawn(node, ROLES[role], what, index)
        self.check_dimensions(points, items)
        return ir.Draw(self.kind.name, tuple(points), self.span, rotation, edges,
                       tuple(values) + self.options(options))

    def signature(self) -> str:
        words = [f"{ROLES[role].words} ({name})" if role != "points" else
                 f"{self.kind.least_points} or more points" for name, role in self.kind.arguments]
        return ", ".join(words[:-1]) + (" and " if len(words) > 1 else "") + words[-1]

    def split(self, items: list) -> list[list]:
        """The items of each argument: all of them for a list of points (the kind's only argument)."""
        return [items] if self.kind.arguments[0][1] == "points" else [[item] for item in items]

    def point(self, node: lark.Tree, scope: Scope) -> tuple[sympy.Expr, ...]:
        """{x, y} (2-D), or a 3-vector (3-D)."""
        children = subtrees(node) if node.data == "braces" else []
        if len(children) == 2:
            return tuple(self.expressions.scalar(child, scope, "a scalar coordinate") for child in children)
        value = self.expressions.build(node, scope)
        if not isinstance(value, Vector):
            raise LagError(f"draw {self.kind.name}() takes points, {{x, y}} or {{x, y, z}}, but this is "
                           f"{kind_of(value)}", self.expressions.span(node))
        return value.components

    def array(self, item, expected, role: str) -> tuple[sympy.Expr, ...]:
        node, scope, _ = item
        value = self.expressions.build(node, scope)
        if not isinstance(value, expected):
            raise LagError(f"draw {self.kind.name}() takes {ROLES[role].words} here, but this is {kind_of(value)}",
                           self.expressions.span(node))
        return value.components

    def scalar(self, item, role: str) -> sympy.Expr:
        node, scope, _ = item
        return self.expressions.scalar(node, scope, f"{ROLES[role].words} (a scalar)")

    def options(self, options: list[lark.Tree]) -> tuple[tuple[str, sympy.Expr], ...]:
        allowed = dict(self.kind.options)
        given: dict[str, sympy.Expr] = {}
        for option in options:
            name, _, value = option.children
            if str(name) not in allowed:
                known = f" (it takes {', '.join(allowed)})" if allowed else " (it takes none)"
                raise LagError(f"draw {self.kind.name}() has no option '{name}'{suggest(str(name), allowed)}{known}",
                               self.expressions.span(name))
            if str(name) in given:
                raise LagError(f"the option '{name}' is given twice", self.expressions.span(name))
            role = allowed[str(name)]
            given[str(name)] = self.scalar((value, self.scope, ""), role)
            self.dims.drawn(value, ROLES[role], f"the {name}")
        return tuple(given.items())

    def check_dimensions(self, points: list, items: list) -> None:
        """One dimension for all the points, and one the kind is drawn in."""
        first = len(points[0])
        for point, (node, _, _) in zip(points, items):
            if len(point) != first:
                raise LagError(f"draw {self.kind.name}() mixes 2-D and 3-D points: the first has {first} "
                               f"coordinates, this one {len(point)}", self.expressions.span(node))
        if first not in self.kind.dimensions:
            shown = " or ".join(f"{d}-D" for d in self.kind.dimensions)
            raise LagError(f"draw {self.kind.name}() is drawn in {shown}, and its point has {first} coordinates",
                           self.expressions.span(items[0][0]))
