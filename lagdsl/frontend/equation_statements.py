"""The statements that make the equations of motion, and the outputs observed of them: T and U
or L, the dissipation function, generalized forces, constraints, and output declarations, each
read with every declared name in scope.
"""
from __future__ import annotations

import sympy

from .. import ir
from ..errors import LagError, suggest
from ..source import Span
from .tree import expressions_of, tokens
from .values import KIND_WORDS, Binding, PoisonedName, Scope


class EquationStatements:
    """Energies, dissipation, forces, constraints and outputs: a part of semantics._ModelBuilder,
    whose state it reads (scope, expr, numbers, dims, calculus, velocity_of) and extends (energy,
    dissipation, forces, constraints, outputs), and whose helpers it calls (guarded, unit,
    description, span)."""

    def velocity_free(self, value, node, what):
        if self.calculus.dependencies(value) & set(self.velocity_of.values()):
            raise LagError(f"{what} must not depend on velocities; write a general L = ... instead",
                           self.span(node))

    def energy_statement(self, node):
        kind = str(tokens(node, "ENERGY")[0])
        body = expressions_of(node)[0]
        if kind in self.energy:
            raise LagError(f"{kind} is given twice (first at line {self.energy[kind][1].line})", self.span(node))
        self.energy[kind] = (None, self.span(node))     # declared, even if its value fails
        value = self.expr.scalar(body, self.scope, f"a scalar {kind}")
        if kind == "U":
            self.velocity_free(value, body, "U")
        self.energy[kind] = (value, self.span(node))
        self.dims.energy(kind, body)

    def lagrangian(self, node, name_token) -> ir.Lagrangian:
        e = self.energy
        if any(value is None for value, _ in e.values()):
            raise PoisonedName()
        if "L" in e and ("T" in e or "U" in e):
            other = "T" if "T" in e else "U"
            raise LagError(f"give either T and U, or L, not both (L and {other} are given)", e["L"][1])
        if "L" in e:
            return ir.Lagrangian(None, None, e["L"][0], e["L"][1])
        if "T" in e:
            return ir.Lagrangian(e["T"][0], e["U"][0] if "U" in e else None, None, e["T"][1])
        if "U" in e:
            raise LagError("U is given without a kinetic energy T; add T = ..., or write the Lagrangian "
                           "as L = ...", e["U"][1])
        raise LagError(f"model '{name_token}' has neither a kinetic energy T nor a Lagrangian L",
                       self.span(name_token))

    def dissipation_statement(self, node):
        if self.dissipation is not None:
            raise LagError(f"dissipation is given twice (first at line {self.dissipation.span.line})", self.span(node))
        body = expressions_of(node)[0]
        self.dissipation = ir.Dissipation(self.expr.scalar(body, self.scope, "a scalar dissipation function"),
                                          self.span(node))
        self.dims.dissipation(body)

    def force(self, node):
        token = tokens(node, "NAME")[0]
        parts = expressions_of(node)
        binding = self.scope.bindings.get(str(token))
        if binding is None or binding.kind != "coordinate":
            coordinates = [n for n, b in self.scope.bindings.items() if b.kind == "coordinate"]
            what = f"{KIND_WORDS.get(binding.kind, 'a name')}, not a coordinate" if binding else "not a coordinate"
            raise LagError(f"force on '{token}', which is {what}{suggest(str(token), coordinates)}",
                           self.span(token))
        name = self.coordinate_member(token, binding, parts[0] if len(parts) == 2 else None,
                                      f"force {token}[i] = ...")
        value = self.expr.scalar(parts[-1], self.scope, "a scalar force")
        self.dims.force(token, parts[0] if len(parts) == 2 else None, binding.dimension, parts[-1])
        self.forces.append(ir.Force(name, value, self.span(node)))

    def coordinate_member(self, token, binding: Binding, index_node, usage: str) -> str:
        """'q', or 'q[i]' for a member of an indexed coordinate (or parameter), with the index checked."""
        if binding.family is None:
            if index_node is not None:
                raise LagError(f"'{token}' is not indexed", self.span(token))
            return str(token)
        if index_node is None:
            raise LagError(f"'{token}' is indexed; write {usage}", self.span(token))
        index = self.numbers.integer(index_node, self.scope, "an index")
        if index not in binding.family:
            raise LagError(f"index {index} is out of range for '{token}' (1:{len(binding.family)})",
                           self.span(index_node))
        return f"{token}[{index}]"

    def constraint(self, node):
        names = tokens(node, "NAME") if tokens(node, "COLON") else []
        name = str(names[0]) if names else f"constraint{len(self.constraints) + 1}"
        lhs, rhs = expressions_of(node)[:2]
        left = self.expr.scalar(lhs, self.scope, "a scalar on the left of the constraint")
        right = self.expr.scalar(rhs, self.scope, "a scalar on the right of the constraint")
        holonomic = not self.calculus.dependencies(left - right) & set(self.velocity_of.values())
        self.dims.constraint(name, lhs, rhs, holonomic)
        self.constraints.append(ir.Constraint(name, left - right, self.span(node)))

    def output(self, node):
        token = tokens(node, "NAME")[0]
        body = expressions_of(node)[0]
        value = self.guarded(token, lambda: self.expr.scalar(body, self.output_scope(), "a scalar output"))
        # Bound before its unit is read: a mistake in the unit is reported once, not at each use.
        self.scope.bindings[str(token)] = Binding("output", self.span(token), value, dimension=self.dims.of(body))
        unit = self.unit(node)
        self.dims.output(token, unit, body)
        self.outputs.append(ir.Output(str(token), value, unit, self.description(node), self.span(token)))

    def output_scope(self) -> Scope:
        """The model's names, and multiplier(c) of its constraints: λ, solved for with q''."""
        return type(self.scope)(self.scope.bindings, self.observable)

    def observable(self, kind: str, arguments: list, span: Span) -> sympy.Symbol:
        if kind != "multiplier":
            raise LagError(f"{kind}(...) is output on its own in a scene's output list (output x, {kind}(...);); "
                           "it cannot be part of an expression", span)
        if len(arguments) != 1 or arguments[0].data not in ("name", "index"):
            raise LagError("multiplier() takes one constraint name", span)
        return ir.multiplier_symbol(self.target_name(kind, arguments[0]))

    def target_name(self, kind: str, node) -> str:
        token = node.children[0]
        binding = self.scope.bindings.get(str(token))
        if kind == "momentum":
            if binding is None or binding.kind != "coordinate":
                coordinates = [n for n, b in self.scope.bindings.items() if b.kind == "coordinate"]
                what = f"{KIND_WORDS.get(binding.kind, 'a name')}, not a coordinate" if binding else "not one"
                raise LagError(f"momentum() takes a coordinate, and '{token}' is {what}"
                               f"{suggest(str(token), coordinates)}", self.span(token))
            if node.data == "index":
                index = self.numbers.integer(node.children[2], self.scope, "an index")
                if binding.family is None or index not in binding.family:
                    raise LagError(f"'{token}[{index}]' is not a coordinate", self.span(node))
                return f"{token}[{index}]"
            if binding.family is not None:
                raise LagError(f"'{token}' is indexed; write momentum({token}[i])", self.span(token))
            return str(token)
        names = [c.name for c in self.constraints]
        if binding is not None and binding.kind == "constraint" and str(token) not in names:
            raise PoisonedName()                 # the constraint itself failed, and was reported
        if node.data != "name" or str(token) not in names:
            known = suggest(str(token), names) or (f" (constraints: {', '.join(names)})" if names
                                                    else "; the model has no constraints"
                                                    if not self.constraint_statements else "")
            raise LagError(f"{kind}() takes a constraint, and '{str(token)}' is not one{known}", self.span(node))
        return str(token)
