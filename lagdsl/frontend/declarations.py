"""The declarations of a model: parameters, coordinates and lets, in source order.

A parameter's value is a number or an expression of earlier parameters, kept exact (9.81 is
981/100) and converted to SI; a coordinate q brings its velocity q' and start values; a let
becomes a named intermediate (a vector or matrix let one per component), so the derivation keeps
the structure the user gave the model. An indexed family (`theta[n]`, `let x[i] = ..., i in 1:n`)
declares one of each per member. Each name is bound with its value and its dimension.
"""
from __future__ import annotations

import lark
import sympy

from .. import ir
from ..errors import LagError
from .prefix_sums import PrefixSum, next_member, prefix_sum, previous_members
from .tree import expressions_of, subtree
from .units import in_si
from .values import Binding, Matrix, Vector


class Declarations:
    """Parameters, coordinates and lets: a part of semantics._ModelBuilder, whose state it reads
    and extends (scope, expr, numbers, dims, calculus, parameters, coordinates, let_spans) and
    whose helpers it calls (declare, require_new_name, modifiers, unit, description, span). Each
    declaration is given its node and its name's token; the builder poisons the name if it fails."""

    def parameter(self, node, token):
        value_node = expressions_of(node)[0]
        dimension = subtree(node, "dimension")
        if dimension is None:
            symbol = self.new_parameter(str(token), value_node, self.scope, node, token)
            form = self.dims.parameter(token, self.parameters[-1].unit, value_node)
            self.declare(token, Binding("parameter", self.span(token), symbol, dimension=form))
            return
        size = self.numbers.family_size(dimension, self.scope, "parameters")
        nodes = self.numbers.listed(value_node, self.scope, size, f"{token}[1] .. {token}[{size}]", "", "parameters")
        self.require_new_name(token)
        family = {i: self.new_parameter(f"{token}[{i}]", item, scope, node, token)
                  for i, (item, scope) in enumerate(nodes, 1)}
        form = self.dims.parameter(token, self.parameters[-1].unit, value_node)
        self.declare(token, Binding("parameter", self.span(token), family=family, dimension=form))

    def new_parameter(self, name: str, value_node, scope, node, token) -> sympy.Symbol:
        value = self.expr.scalar(value_node, scope, "a scalar value")
        stray = value.free_symbols - set(self.numbers.exact_parameters)
        if stray:
            raise LagError("a parameter's value may only use numbers and earlier parameters", self.span(value_node))
        unit = self.unit(node)
        value = in_si(value, unit)
        exact = self.numbers.with_parameter_values(value)
        number = complex(exact.evalf(20))
        if number.imag != 0 or not abs(number.real) < float("inf"):
            raise LagError("the parameter's value is not a finite real number", self.span(value_node))
        symbol = sympy.Symbol(name, real=True)
        self.numbers.exact_parameters[symbol] = exact
        self.parameters.append(ir.Parameter(name, symbol, value, number.real, unit,
                                            self.description(node), self.span(token)))
        return symbol

    def coordinate(self, node, token):
        name = str(token)
        dimension = subtree(node, "dimension")
        modifiers = self.modifiers(node, ("start", "velocity"), f"coordinate '{name}'")
        unit, description = self.unit(node), self.description(node)
        if dimension is None:
            start = in_si(self.initial_values(modifiers.get("start"), None), unit)
            velocity = in_si(self.initial_values(modifiers.get("velocity"), None), unit)
            coordinate = self.new_coordinate(name, start, velocity, unit, description, self.span(token))
            form = self.dims.coordinate(token, unit, node)
            self.declare(token, Binding("coordinate", self.span(token), coordinate.symbol, dimension=form))
            return
        size = self.numbers.family_size(dimension, self.scope, "coordinates")
        starts = self.initial_values(modifiers.get("start"), size, f"{name}[1] .. {name}[{size}]", "start")
        velocities = self.initial_values(modifiers.get("velocity"), size, f"{name}[1] .. {name}[{size}]",
                                         "velocity")
        family = {}
        for i in range(1, size + 1):
            member = self.new_coordinate(f"{name}[{i}]", in_si(starts[i - 1], unit),
                                         in_si(velocities[i - 1], unit), unit, description, self.span(token))
            family[i] = member.symbol
        form = self.dims.coordinate(token, unit, node)
        self.declare(token, Binding("coordinate", self.span(token), family=family, dimension=form))

    def new_coordinate(self, name, start, velocity, unit, description, span) -> ir.Coordinate:
        q = sympy.Symbol(name, real=True)
        v = sympy.Symbol(name + "'", real=True)
        self.expr.calls.declare_velocity(q, v)
        self.calculus.add_base(q, v)
        coordinate = ir.Coordinate(name, q, v, start, velocity, unit, description, span)
        self.coordinates.append(coordinate)
        return coordinate

    def initial_values(self, node, size: int | None, members: str = "", kind: str = "initial"):
        """start/velocity: a parameter expression, or {a, b, ...} for an indexed family."""
        if node is None:
            return sympy.S.Zero if size is None else [sympy.S.Zero] * size
        if size is None:
            if node.data == "braces":
                raise LagError("a list of initial values needs an indexed coordinate", self.span(node))
            return self.initial_expression(node, self.scope)
        return [self.initial_expression(item, scope)
                for item, scope in self.numbers.listed(node, self.scope, size, members, kind, "coordinates")]

    def initial_expression(self, node, scope) -> sympy.Expr:
        value = self.expr.scalar(node, scope, "an initial value")
        if value.free_symbols - set(self.numbers.exact_parameters):
            raise LagError("an initial value may only use numbers and parameters", self.span(node))
        self.numbers.number(node, "an initial value", scope)
        return value

    def let(self, node, token):
        name = str(token)
        index, family_range = subtree(node, "let_index"), subtree(node, "let_range")
        body = expressions_of(node)[0]
        if index is None and family_range is None:
            value = self.expr.build(body, self.scope)
            self.declare(token, Binding("let", self.span(token), self.intermediate(name, value, token),
                                        dimension=self.dims.of(body)))
            return
        if index is None or family_range is None:
            raise LagError(f"an indexed let is written 'let {name}[i] = ..., i in 1:n;'", self.span(token))
        variable = str(index.children[1])
        range_variable = str(family_range.children[1])
        if variable != range_variable:
            raise LagError(f"the index is '{variable}' but the range is over '{range_variable}'",
                           self.span(family_range.children[1]))
        iteration = lark.Tree("iteration", family_range.children[1:], family_range.meta)
        _, low, high = self.numbers.iteration(iteration, self.scope)
        self.require_new_name(token)
        family = {}
        self.scope.bindings[name] = Binding("partial", self.span(token), family={},   # earlier members only
                                            dimension=self.dims.family(name))
        prefix = prefix_sum(body, variable, name)
        try:
            for i in range(low, high + 1):
                value = self.prefix_step(prefix, family.get(i - 1), i) if prefix is not None else None
                member = self.intermediate(f"{name}[{i}]", value if value is not None else
                                           self.expr.build(body, self.scope.child(**{variable: i})), token)
                if value is not None:
                    self.calculus.extends.update(previous_members(family[i - 1], member))
                family[i] = self.scope.bindings[name].family[i] = member
        finally:
            del self.scope.bindings[name]
        self.declare(token, Binding("let", self.span(token), family=family,
                                    dimension=self.dims.family_body(name, body)))

    def prefix_step(self, prefix: PrefixSum, previous, i: int):
        """Member i of a prefix-sum let as the previous member plus its one new term
        (frontend/prefix_sums.py), or None where it is built as written."""
        if previous is None:
            return None
        term = self.expr.build(prefix.term, self.scope.child(**{prefix.variable: i}))
        self.numbers.count_unrolled(1, prefix.range_node)
        return next_member(previous, term, prefix.sign)

    def intermediate(self, name: str, value, token):
        if isinstance(value, Vector):
            return Vector(tuple(self.intermediate(f"{name}.{axis}", c, token)
                                for axis, c in zip("xyz", value.components)))
        if isinstance(value, Matrix):
            return Matrix(tuple(tuple(self.intermediate(f"{name}[{i},{j}]", c, token) for j, c in enumerate(row, 1))
                                for i, row in enumerate(value.rows, 1)))
        symbol = sympy.Symbol(name, real=True)
        self.let_spans[symbol] = self.span(token)
        return self.calculus.define(symbol, value)
