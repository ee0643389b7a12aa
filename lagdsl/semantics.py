"""Tree -> ir.Model: declarations in order, name resolution, reserved words, indexed families.

Parameters, coordinates and lets are declared in source order, each usable after its
declaration. The energy (T, U or L), dissipation, forces, constraints and outputs are read
afterwards, with every declared name in scope, and scenes last. Independent errors are
collected and reported together; a declaration that failed leaves its name "poisoned", so
later uses of it do not produce follow-on errors.
"""
from __future__ import annotations

import lark
import sympy

from . import ir
from .calculus import TIME_DIRECTION, Differentiator
from .errors import ErrorCollector, InternalError, LagError
from .expressions import KIND_WORDS, MAX_MEMBERS, Binding, ExpressionBuilder, Matrix, Scope, Vector, suggest
from .integrators import registry
from .settings import DEFAULT_INTEGRATOR, DEFAULT_TIME, check_integrator_name, validate_integrator
from .source import SourceFile, Span
from .units import in_si, parse_unit

RESERVED = {"model", "end", "parameter", "coordinate", "let", "constraint", "force", "dissipation",
            "output", "scene", "time", "integrator", "set", "t", "T", "U", "L", "der", "pi", "sum", "in"}


class PoisonedName(LagError):
    """A use of a name whose declaration already failed: reported once, at the declaration."""

    def __init__(self):
        super().__init__("poisoned")
        self.diagnostics = ()


def build_model(tree: lark.Tree, source: SourceFile) -> ir.Model:
    """Tree -> ir.Model; raises one LagError carrying every independent error found."""
    return _ModelBuilder(source).build(tree.children[0])


def tokens(node: lark.Tree, kind: str) -> list[lark.Token]:
    return [c for c in node.children if isinstance(c, lark.Token) and c.type == kind]


def subtree(node: lark.Tree, data: str) -> lark.Tree | None:
    return next((c for c in node.children if isinstance(c, lark.Tree) and c.data == data), None)


def expressions_of(node: lark.Tree) -> list:
    """The expression children of a statement (everything but tokens and annotations)."""
    skip = {"unit", "description", "modifiers", "dimension", "let_index", "let_range"}
    return [c for c in node.children if isinstance(c, lark.Tree) and c.data not in skip]


class _ScopeWithPoison(Scope):
    """A scope in which names whose declaration failed, and outputs not yet built, are refused."""

    def lookup(self, name, span):
        binding = super().lookup(name, span)
        if binding.kind == "invalid":
            raise PoisonedName()
        if binding.kind == "pending output":
            raise LagError(f"'{name}' is an output (line {binding.span.line}); only later outputs and "
                           "scenes can use it", span)
        return binding


class _ModelBuilder:
    def __init__(self, source: SourceFile):
        self.source = source
        self.scope = _ScopeWithPoison()
        self.calculus = Differentiator((), (ir.TIME,))
        self.velocity_of: dict[sympy.Symbol, sympy.Symbol] = {}
        self.expr = ExpressionBuilder(source, self.calculus, self.velocity_of)
        self.errors = ErrorCollector()
        self.parameters: list[ir.Parameter] = []
        self.coordinates: list[ir.Coordinate] = []
        self.let_spans: dict[sympy.Symbol, Span] = {}
        self.energy: dict[str, tuple[sympy.Expr, Span]] = {}
        self.dissipation: ir.Dissipation | None = None
        self.forces: list[ir.Force] = []
        self.constraints: list[ir.Constraint] = []
        self.outputs: list[ir.Output] = []
        self.scenes: list[ir.Scene] = []
        self.scene_spans: dict[str, Span] = {}
        self.constraint_statements = 0

    def span(self, node) -> Span:
        return self.expr.span(node)

    # -- the model ---------------------------------------------------------------------------
    def build(self, node: lark.Tree) -> ir.Model:
        names = tokens(node, "NAME")
        name, end_name = names[0], names[-1]
        if str(end_name) != str(name):
            self.errors.errors.append(LagError(f"'end {end_name}' does not match model '{name}'; expected 'end {name};'",
                                               self.span(end_name)))
        declarations = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "description"]
        first_pass = {"parameter": self.parameter, "coordinate": self.coordinate, "let": self.let}
        later = {"energy": self.energy_statement, "dissipation": self.dissipation_statement,
                 "force": self.force, "constraint": self.constraint, "output": self.output}
        for declaration in declarations:
            if declaration.data in first_pass:
                self.errors.attempt(first_pass[declaration.data], declaration)
            elif declaration.data in later:
                self.declare_later_name(declaration)
        # Outputs last: they may use multiplier(c) of every constraint, and the equations may
        # not use an output (it could hold a multiplier).
        for declaration in sorted((d for d in declarations if d.data in later), key=lambda d: d.data == "output"):
            self.errors.attempt(later[declaration.data], declaration)
        lagrangian = self.errors.attempt(self.lagrangian, node, name)
        self.resolve_structural()
        for declaration in declarations:
            if declaration.data == "scene":
                self.errors.attempt(self.scene, declaration)
        if self.errors.errors:
            error = LagError.combine(self.errors.errors)
            if not error.diagnostics:
                raise InternalError("a model was rejected without a diagnostic")
            error.diagnostics = tuple(sorted(error.diagnostics, key=_position))   # in source order
            raise error
        return ir.Model(
            name=str(name), description=self.description(node),
            parameters=tuple(self.parameters), coordinates=tuple(self.coordinates),
            lets=self.lets(),
            lagrangian=lagrangian, dissipation=self.dissipation, forces=tuple(self.forces),
            constraints=tuple(self.constraints), outputs=tuple(self.outputs),
            scenes=tuple(self.scenes), span=self.span(name), source_name=self.source.name)

    def lets(self) -> tuple[ir.Let, ...]:
        """User lets and the der(x) intermediates the chain rule named for them."""
        sources = self.calculus.named_derivatives(TIME_DIRECTION)
        return tuple(ir.Let(s.name, s, e, self.let_spans.get(s), sources.get(s))
                     for s, e in self.calculus.definitions())

    def description(self, node) -> str | None:
        description = subtree(node, "description")
        return str(description.children[0])[1:-1] if description is not None else None

    def unit(self, node) -> ir.Unit | None:
        unit = subtree(node, "unit")
        return parse_unit(self.span(unit.children[0])) if unit is not None else None

    def declare(self, token: lark.Token, binding: Binding) -> None:
        self.require_new_name(token)
        self.scope.bindings[str(token)] = binding

    def require_new_name(self, token: lark.Token) -> None:
        name = str(token)
        if name in RESERVED:
            raise LagError(f"'{name}' is a reserved word and cannot be used as a name", self.span(token))
        if name in ir.BUILTIN_OBSERVABLES:
            raise LagError(f"'{name}' is the name of a built-in observable", self.span(token))
        existing = self.scope.bindings.get(name)
        if existing is not None and existing.kind != "invalid":
            what = f" as {KIND_WORDS[existing.kind]}" if existing.kind in KIND_WORDS else ""
            where = f" (line {existing.span.line})" if existing.span else ""
            raise LagError(f"'{name}' is already declared{what}{where}", self.span(token))

    def poison(self, token: lark.Token) -> None:
        existing = self.scope.bindings.get(str(token))
        if existing is None or existing.kind == "pending output":
            self.scope.bindings[str(token)] = Binding("invalid", self.span(token))

    def guarded(self, token, action):
        """Run a declaration; if it fails, its name stays declared but poisoned."""
        try:
            return action()
        except LagError:
            self.poison(token)
            raise

    # -- parameters ----------------------------------------------------------------------------
    def parameter(self, node):
        token = tokens(node, "NAME")[0]
        self.guarded(token, lambda: self._parameter(node, token))

    def _parameter(self, node, token):
        value_node = expressions_of(node)[0]
        dimension = subtree(node, "dimension")
        if dimension is None:
            symbol = self.new_parameter(str(token), value_node, self.scope, node, token)
            self.declare(token, Binding("parameter", self.span(token), symbol))
            return
        size = self.family_size(dimension, "parameters")
        nodes = self.listed(value_node, size, f"{token}[1] .. {token}[{size}]", "", "parameters")
        self.require_new_name(token)
        family = {i: self.new_parameter(f"{token}[{i}]", item, scope, node, token)
                  for i, (item, scope) in enumerate(nodes, 1)}
        self.declare(token, Binding("parameter", self.span(token), family=family))

    def new_parameter(self, name: str, value_node, scope, node, token) -> sympy.Symbol:
        value = self.expr.scalar(value_node, scope, "a scalar value")
        stray = value.free_symbols - set(self.expr.exact_parameters)
        if stray:
            raise LagError("a parameter's value may only use numbers and earlier parameters", self.span(value_node))
        unit = self.unit(node)
        value = in_si(value, unit)
        exact = self.expr.with_parameter_values(value)
        number = complex(exact.evalf(20))
        if number.imag != 0 or not abs(number.real) < float("inf"):
            raise LagError("the parameter's value is not a finite real number", self.span(value_node))
        symbol = sympy.Symbol(name, real=True)
        self.expr.exact_parameters[symbol] = exact
        self.parameters.append(ir.Parameter(name, symbol, value, number.real, unit,
                                            self.description(node), self.span(token)))
        return symbol

    def family_size(self, dimension, what: str) -> int:
        size = self.expr.integer(dimension.children[1], self.scope, f"the number of {what}")
        if size < 1:
            raise LagError(f"an indexed family of {what} needs at least one member", self.span(dimension))
        if size > MAX_MEMBERS:
            raise LagError(f"{size} {what} in one family; at most {MAX_MEMBERS} are allowed", self.span(dimension))
        return size

    def listed(self, node, size: int, members: str, kind: str, noun: str) -> list[tuple[lark.Tree, Scope]]:
        """The values of a family of `size` members, each as (expression, scope to read it in):
        one expression for all, a list {a, b, ...} of `size`, or {e, i in 1:n}, e read with i bound."""
        if node.data != "braces":
            return [(node, self.scope)] * size
        items = [c for c in node.children if not isinstance(c, lark.Token)]
        if items[-1].data == "iteration":
            if len(items) != 2:
                raise LagError("a list given by its index is written {expression, i in 1:n}", self.span(node))
            variable, low, high = self.expr.iteration(items[1], self.scope)
            if (low, high) != (1, size):
                raise LagError(f"the range {low}:{high} does not cover the members {members}; write "
                               f"{variable} in 1:{size}", self.span(items[1].children[2]))
            return [(items[0], self.scope.child(**{variable: i})) for i in range(1, size + 1)]
        if len(items) != size:
            what = f"{kind} values" if kind else "values"
            raise LagError(f"{len(items)} {what} for the {size} {noun} {members}; give one "
                           f"value for all, or a list of {size}", self.span(node))
        return [(item, self.scope) for item in items]

    def parameter_value(self, node, what: str, scope: Scope | None = None, unit: ir.Unit | None = None) -> float:
        """A number in a scene or modifier: parameters allowed, evaluated at their defaults (in SI;
        a plain number is in `unit`)."""
        value = in_si(self.expr.scalar(node, scope or self.scope, what), unit)
        if value.free_symbols - set(self.expr.exact_parameters):
            raise LagError(f"{what} may only use numbers and parameters", self.span(node))
        result = complex(self.expr.with_parameter_values(value).evalf(20))
        if result.imag != 0 or not abs(result.real) < float("inf"):
            raise LagError(f"{what} is not a finite real number", self.span(node))
        return result.real

    def resolve_structural(self):
        self.parameters = [
            ir.Parameter(p.name, p.symbol, p.expression, p.value, p.unit, p.description, p.span,
                         structural=p.symbol in self.expr.structural)
            for p in self.parameters]

    # -- coordinates ---------------------------------------------------------------------------
    def coordinate(self, node):
        token = tokens(node, "NAME")[0]
        self.guarded(token, lambda: self._coordinate(node, token))

    def _coordinate(self, node, token):
        name = str(token)
        dimension = subtree(node, "dimension")
        modifiers = self.modifiers(node, ("start", "velocity"), f"coordinate '{name}'")
        unit, description = self.unit(node), self.description(node)
        if dimension is None:
            start = in_si(self.initial_values(modifiers.get("start"), None), unit)
            velocity = in_si(self.initial_values(modifiers.get("velocity"), None), unit)
            coordinate = self.new_coordinate(name, start, velocity, unit, description, self.span(token))
            self.declare(token, Binding("coordinate", self.span(token), coordinate.symbol))
            return
        size = self.family_size(dimension, "coordinates")
        starts = self.initial_values(modifiers.get("start"), size, f"{name}[1] .. {name}[{size}]", "start")
        velocities = self.initial_values(modifiers.get("velocity"), size, f"{name}[1] .. {name}[{size}]",
                                         "velocity")
        family = {}
        for i in range(1, size + 1):
            member = self.new_coordinate(f"{name}[{i}]", in_si(starts[i - 1], unit),
                                         in_si(velocities[i - 1], unit), unit, description, self.span(token))
            family[i] = member.symbol
        self.declare(token, Binding("coordinate", self.span(token), family=family))

    def new_coordinate(self, name, start, velocity, unit, description, span) -> ir.Coordinate:
        q = sympy.Symbol(name, real=True)
        v = sympy.Symbol(name + "'", real=True)
        self.velocity_of[q] = v
        self.expr.rates[q] = v
        self.calculus.add_base(q, v)
        coordinate = ir.Coordinate(name, q, v, start, velocity, unit, description, span)
        self.coordinates.append(coordinate)
        return coordinate

    def modifiers(self, node, allowed, owner: str = "") -> dict[str, lark.Tree]:
        found: dict[str, lark.Tree] = {}
        block = subtree(node, "modifiers")
        for modifier in (block.children if block is not None else []):
            if not isinstance(modifier, lark.Tree):
                continue
            key = modifier.children[0]
            if str(key) not in allowed:
                options = ", ".join(allowed) if allowed else "none"
                owner_text = f" for {owner}" if owner else ""
                raise LagError(f"unknown option '{key}'{owner_text}{suggest(str(key), allowed)} (allowed: {options})",
                               self.span(key))
            if str(key) in found:
                raise LagError(f"'{key}' is given twice", self.span(key))
            found[str(key)] = modifier.children[2]
        return found

    def initial_values(self, node, size: int | None, members: str = "", kind: str = "initial"):
        """start/velocity: a parameter expression, or {a, b, ...} for an indexed family."""
        if node is None:
            return sympy.S.Zero if size is None else [sympy.S.Zero] * size
        if size is None:
            if node.data == "braces":
                raise LagError("a list of initial values needs an indexed coordinate", self.span(node))
            return self.initial_expression(node, self.scope)
        return [self.initial_expression(item, scope)
                for item, scope in self.listed(node, size, members, kind, "coordinates")]

    def initial_expression(self, node, scope) -> sympy.Expr:
        value = self.expr.scalar(node, scope, "an initial value")
        if value.free_symbols - set(self.expr.exact_parameters):
            raise LagError("an initial value may only use numbers and parameters", self.span(node))
        self.parameter_value(node, "an initial value", scope)
        return value

    # -- lets ------------------------------------------------------------------------------------
    def let(self, node):
        token = tokens(node, "NAME")[0]
        self.guarded(token, lambda: self._let(node, token))

    def _let(self, node, token):
        name = str(token)
        index, family_range = subtree(node, "let_index"), subtree(node, "let_range")
        body = expressions_of(node)[0]
        if index is None and family_range is None:
            value = self.expr.build(body, self.scope)
            self.declare(token, Binding("let", self.span(token), self.intermediate(name, value, token)))
            return
        if index is None or family_range is None:
            raise LagError(f"an indexed let is written 'let {name}[i] = ..., i in 1:n;'", self.span(token))
        variable = str(index.children[1])
        range_variable = str(family_range.children[1])
        if variable != range_variable:
            raise LagError(f"the index is '{variable}' but the range is over '{range_variable}'",
                           self.span(family_range.children[1]))
        iteration = lark.Tree("iteration", family_range.children[1:], family_range.meta)
        _, low, high = self.expr.iteration(iteration, self.scope)
        self.require_new_name(token)
        family = {}
        self.scope.bindings[name] = Binding("partial", self.span(token), family={})   # earlier members only
        try:
            for i in range(low, high + 1):
                value = self.expr.build(body, self.scope.child(**{variable: i}))
                family[i] = self.intermediate(f"{name}[{i}]", value, token)
                self.scope.bindings[name].family[i] = family[i]
        finally:
            del self.scope.bindings[name]
        self.declare(token, Binding("let", self.span(token), family=family))

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

    # -- energy, dissipation, forces, constraints, outputs --------------------------------------
    def declare_later_name(self, node):
        """Constraints and outputs have names too; declare them up front to catch clashes."""
        if node.data == "output":
            token = tokens(node, "NAME")[0]
            self.errors.attempt(self.declare, token, Binding("pending output", self.span(token)))
        elif node.data == "constraint":
            self.constraint_statements += 1
            if tokens(node, "NAME") and tokens(node, "COLON"):
                token = tokens(node, "NAME")[0]
                self.errors.attempt(self.declare, token, Binding("constraint", self.span(token)))

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
        self.forces.append(ir.Force(name, value, self.span(node)))

    def coordinate_member(self, token, binding: Binding, index_node, usage: str) -> str:
        """'q', or 'q[i]' for a member of an indexed coordinate (or parameter), with the index checked."""
        if binding.family is None:
            if index_node is not None:
                raise LagError(f"'{token}' is not indexed", self.span(token))
            return str(token)
        if index_node is None:
            raise LagError(f"'{token}' is indexed; write {usage}", self.span(token))
        index = self.expr.integer(index_node, self.scope, "an index")
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
        self.constraints.append(ir.Constraint(name, left - right, self.span(node)))

    def output(self, node):
        token = tokens(node, "NAME")[0]
        body = expressions_of(node)[0]
        value = self.guarded(token, lambda: self.expr.scalar(body, self.output_scope(), "a scalar output"))
        self.scope.bindings[str(token)] = Binding("output", self.span(token), value)
        self.outputs.append(ir.Output(str(token), value, self.unit(node), self.description(node),
                                      self.span(token)))

    # -- scenes --------------------------------------------------------------------------------
    def scene(self, node):
        names = tokens(node, "NAME")
        name, end_name = names[0], names[-1]
        errors = ErrorCollector()
        if str(end_name) != str(name):
            errors.errors.append(LagError(f"'end {end_name}' does not match scene '{name}'; expected 'end {name};'",
                                          self.span(end_name)))
        if str(name) in self.scene_spans:
            errors.errors.append(LagError(f"scene '{name}' is declared twice (first at line "
                                          f"{self.scene_spans[str(name)].line})", self.span(name)))
        else:
            self.scene_spans[str(name)] = self.span(name)
        statements = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "description"]
        time, integrator, stop = DEFAULT_TIME, None, None
        parameter_overrides, initial_overrides, outputs = [], [], []
        given: dict[str, Span] = {}
        for statement in statements:
            if statement.data in ("scene_time", "scene_integrator", "scene_stop"):
                word = {"scene_time": "time(...)", "scene_integrator": "integrator(...)",
                        "scene_stop": "a stop condition"}[statement.data]
                if word in given:
                    errors.errors.append(LagError(f"the scene gives {word} twice (first at line "
                                                  f"{given[word].line})", self.span(statement)))
                    continue
                given[word] = self.span(statement)
            if statement.data == "scene_time":
                time = errors.attempt(self.scene_time, statement) or time
            elif statement.data == "scene_integrator":
                integrator = errors.attempt(self.scene_integrator, statement) or integrator
            elif statement.data == "scene_stop":
                stop = errors.attempt(self.scene_stop, statement)
            elif statement.data == "scene_set":
                override = errors.attempt(self.scene_set, statement)
                if isinstance(override, ir.ParameterOverride):
                    parameter_overrides.append(override)
                elif override is not None:
                    initial_overrides.append(override)
            elif statement.data == "scene_output":
                for item in statement.children:
                    if isinstance(item, lark.Tree):
                        request = errors.attempt(self.output_request, item)
                        twice = next((o for o in outputs if request and o.column == request.column), None)
                        if twice is not None:
                            errors.errors.append(LagError(f"'{request.column}' is already in the output list",
                                                          request.span))
                        elif request is not None:
                            outputs.append(request)
        errors.raise_if_any()
        if integrator is None:
            integrator = DEFAULT_INTEGRATOR
        self.scenes.append(ir.Scene(str(name), self.description(node), time, integrator,
                                    tuple(parameter_overrides), tuple(initial_overrides),
                                    tuple(outputs), self.span(name), stop))

    def scene_time(self, node) -> ir.TimeGrid:
        options = self.modifiers(node, ("start", "stop", "interval"), "time(...)")
        values = {k: self.parameter_value(v, f"time({k})") for k, v in options.items()}
        start, stop = values.get("start", 0.0), values.get("stop", DEFAULT_TIME.stop)
        interval = values.get("interval", (stop - start) / 1000 if "stop" in values else DEFAULT_TIME.interval)
        if not stop > start:
            raise LagError(f"the stop time {stop:g} is not after the start time {start:g}", self.span(node))
        if not interval > 0:
            raise LagError("the output interval must be positive", self.span(options.get("interval", node)))
        return ir.TimeGrid(start, stop, interval, self.span(node))

    def scene_stop(self, node) -> ir.StopCondition:
        """`stop when a < b;`: e = a - b (for `>`, b - a), a function of q, q', t and parameters."""
        left, right = expressions_of(node)
        sides = [self.expr.scalar(side, self.output_scope(), "a scalar in the stop condition")
                 for side in (left, right)]
        function = sides[0] - sides[1] if tokens(node, "LESS") else sides[1] - sides[0]
        multipliers = {ir.multiplier_symbol(c.name) for c in self.constraints}
        if function.free_symbols & multipliers:
            raise LagError("a stop condition cannot use multiplier(...): it is evaluated after every step, "
                           "where the multipliers are not solved for", self.span(node))
        span = self.span(node)
        text = " ".join(self.source.text[self.span(left).start:self.span(right).end].split())
        return ir.StopCondition(text, function, span)

    def scene_integrator(self, node) -> ir.IntegratorChoice:
        token = tokens(node, "NAME")[0]
        name = str(token)
        check_integrator_name(name, self.span(token))
        options = self.modifiers(node, registry.get(name).options, f"integrator {name}")
        values = {k: self.parameter_value(v, k) for k, v in options.items()}
        return validate_integrator(name, values, self.span(node), {k: self.span(v) for k, v in options.items()})

    def scene_set(self, node):
        token = tokens(node, "NAME")[0]
        binding = self.scope.bindings.get(str(token))
        parts = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "modifiers"]
        if binding is not None and binding.kind == "invalid":
            raise PoisonedName()
        if subtree(node, "modifiers") is None:        # set p = value
            if binding is not None and binding.kind == "coordinate":
                raise LagError(f"'{token}' is a coordinate; set its initial values with "
                               f"set {token}(start = ..., velocity = ...)", self.span(token))
            if binding is None or binding.kind != "parameter":
                parameters = [p.name for p in self.parameters]
                raise LagError(f"'{token}' is not a parameter{suggest(str(token), parameters)}", self.span(token))
            name = self.coordinate_member(token, binding, parts[0] if len(parts) == 2 else None,
                                          f"set {token}[i] = ...")
            parameter = next(p for p in self.parameters if p.name == name)
            if parameter.symbol in self.expr.structural:
                raise LagError(f"'{name}' fixes the size of the model and cannot be changed by a scene",
                               self.span(token))
            return ir.ParameterOverride(name, self.parameter_value(parts[-1], "the value", unit=parameter.unit),
                                        self.span(node))
        if binding is not None and binding.kind == "parameter":
            raise LagError(f"'{token}' is a parameter; set it with set {token} = ...", self.span(token))
        if binding is None or binding.kind != "coordinate":
            coordinates = [c.name for c in self.coordinates]
            raise LagError(f"'{token}' is not a coordinate{suggest(str(token), coordinates)}", self.span(token))
        name = self.coordinate_member(token, binding, parts[0] if parts else None,
                                      f"set {token}[i](start = ...)")
        options = self.modifiers(node, ("start", "velocity"), f"set {name}")
        unit = next(c.unit for c in self.coordinates if c.name == name)
        values = {k: self.parameter_value(v, f"the {k} value", unit=unit) for k, v in options.items()}
        return ir.InitialOverride(name, values.get("start"), values.get("velocity"), self.span(node))

    def output_request(self, node) -> ir.OutputRequest:
        span = self.span(node)
        column = " ".join(span.text.split())
        if node.data == "name" and str(node.children[0]) == "energy":
            return ir.OutputRequest(column, "energy", None, None, span)
        if node.data == "call" and str(node.children[0]) in ("momentum", "multiplier", "residual"):
            kind = str(node.children[0])
            arguments = subtree(node, "arguments")
            items = [c for c in arguments.children if isinstance(c, lark.Tree)] if arguments else []
            if len(items) != 1 or items[0].data not in ("name", "index"):
                raise LagError(f"{kind}() takes one {'coordinate' if kind == 'momentum' else 'constraint'} name", span)
            return ir.OutputRequest(column, kind, None, self.target_name(kind, items[0]), span)
        value = self.expr.scalar(node, self.output_scope(), "a scalar output")
        return ir.OutputRequest(column, "expression", value, None, span)

    def output_scope(self) -> Scope:
        """The model's names, and multiplier(c) of its constraints: λ, solved for with q''."""
        return _ScopeWithPoison(self.scope.bindings, self.observable)

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
                index = self.expr.integer(node.children[2], self.scope, "an index")
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


def _position(diagnostic) -> tuple[int, int]:
    return (0, diagnostic.span.start) if diagnostic.span is not None else (1, 0)
