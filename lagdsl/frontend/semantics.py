"""Tree -> ir.Model: declarations in order, name resolution, reserved words, indexed families.

Parameters, coordinates and lets are declared in source order, each usable after its
declaration (declarations.py). The energy (T, U or L), dissipation, forces, constraints,
outputs and draw statements (draw_statements.py) are read afterwards, with every declared name
in scope, and scenes last (scene_statements.py). Independent errors are collected and reported
together; a declaration that failed leaves its name "poisoned", so later uses of it do not
produce follow-on errors.

This is the one walk of the tree: expressions are built by expressions.py, which gives each
node its dimension as it goes, and each statement adds what the physics fixes about its
dimensions (model_dimensions.py). Once the model is built without error, the equations between
dimensions are solved and the model gets its UnitReport.
"""
from __future__ import annotations

import lark
import sympy

from .. import ir
from ..calculus import TIME_DIRECTION, Differentiator
from .declarations import Declarations
from .draw_statements import DrawStatements
from .equation_statements import EquationStatements
from ..errors import ErrorCollector, InternalError, LagError, suggest
from .expressions import ExpressionBuilder
from .functions import OBSERVABLES
from .model_dimensions import ModelDimensions
from .scene_statements import SceneStatements
from ..source import SourceFile, Span
from .tree import span_of, subtree, tokens
from .units import parse_unit
from .values import KIND_WORDS, Binding, PoisonedName, Scope

RESERVED = {"model", "end", "parameter", "coordinate", "let", "constraint", "force", "dissipation",
            "output", "draw", "scene", "time", "integrator", "set", "t", "T", "U", "L", "der", "pi", "sum", "in"}

# The statements of a model, by their rule in grammar.lark, and the method of _ModelBuilder that
# reads each (a new kind of statement is a rule, a row here and its method). Declarations are
# read first, in source order; the statements that may use any declared name after them (outputs
# last, then the draw statements, which may use them); scenes (scene_statements.py, with their
# own table of parts) at the end.
DECLARATIONS = {"parameter": "parameter", "coordinate": "coordinate", "let": "let"}
STATEMENTS = {"energy": "energy_statement", "dissipation": "dissipation_statement", "force": "force",
              "constraint": "constraint", "output": "output", "draw": "draw_statement"}
READ_LAST = ("output", "draw")      # of STATEMENTS, in this order after the others


def build_model(tree: lark.Tree, source: SourceFile) -> ir.Model:
    """Tree -> ir.Model; raises one LagError carrying every independent error found."""
    return _ModelBuilder(source).build(tree.children[0])


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


class _ModelBuilder(Declarations, EquationStatements, SceneStatements, DrawStatements):
    """The walk of a model's tree: the state of the model being built, its names, and the order
    of the statements; each kind of statement is read by the part named after it."""

    def __init__(self, source: SourceFile):
        self.source = source
        self.scope = _ScopeWithPoison()
        self.calculus = Differentiator((), (ir.TIME,))
        self.velocity_of: dict[sympy.Symbol, sympy.Symbol] = {}
        self.dims = ModelDimensions(source)
        self.expr = ExpressionBuilder(source, self.calculus, self.velocity_of, self.dims.check)
        self.numbers = self.expr.numbers
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
        self.draws: list[ir.Draw] = []
        self.scene_spans: dict[str, Span] = {}
        self.constraint_statements = 0

    def span(self, node) -> Span:
        return span_of(node, self.source)

    # -- the model ---------------------------------------------------------------------------
    def build(self, node: lark.Tree) -> ir.Model:
        names = tokens(node, "NAME")
        name, end_name = names[0], names[-1]
        if str(end_name) != str(name):
            self.errors.errors.append(LagError(f"'end {end_name}' does not match model '{name}'; expected 'end {name};'",
                                               self.span(end_name)))
        declarations = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "description"]
        first_pass = {rule: getattr(self, method) for rule, method in DECLARATIONS.items()}
        later = {rule: getattr(self, method) for rule, method in STATEMENTS.items()}
        for declaration in declarations:
            if declaration.data in first_pass:
                self.dims.start(declaration.data)
                token = tokens(declaration, "NAME")[0]
                self.errors.attempt(self.guarded, token, lambda: first_pass[declaration.data](declaration, token))
            elif declaration.data in later:
                self.declare_later_name(declaration)
        # Outputs last: they may use multiplier(c) of every constraint, and the equations may
        # not use an output (it could hold a multiplier).
        for declaration in sorted((d for d in declarations if d.data in later), key=_reading_order):
            self.dims.start(declaration.data)
            self.errors.attempt(later[declaration.data], declaration)
        lagrangian = self.errors.attempt(self.lagrangian, node, name)
        self.resolve_structural()
        self.dims.start("scene")
        for declaration in declarations:
            if declaration.data == "scene":
                self.errors.attempt(self.scene, declaration)
        if self.errors.errors:
            error = LagError.combine(self.errors.errors)
            if not error.diagnostics:
                raise InternalError("a model was rejected without a diagnostic")
            error.diagnostics = tuple(sorted(error.diagnostics, key=_position))   # in source order
            raise error
        model = ir.Model(
            name=str(name), description=self.description(node),
            parameters=tuple(self.parameters), coordinates=tuple(self.coordinates),
            lets=self.lets(),
            lagrangian=lagrangian, dissipation=self.dissipation, forces=tuple(self.forces),
            constraints=tuple(self.constraints), outputs=tuple(self.outputs),
            scenes=tuple(self.scenes), span=self.span(name), source_name=self.source.name,
            draws=tuple(self.draws))
        return self.dims.finish(model, lambda name: self.scope.bindings[name].dimension)

    def lets(self) -> tuple[ir.Let, ...]:
        """User lets and the der(x) intermediates the chain rule named for them."""
        sources = self.calculus.named_derivatives(TIME_DIRECTION)
        rates = {source: rate for rate, source in sources.items()}
        extends = dict(self.calculus.extends)
        extends.update({rate: rates.get(self.calculus.extends.get(source)) for rate, source in sources.items()})
        return tuple(ir.Let(s.name, s, e, self.let_spans.get(s), sources.get(s), extends.get(s))
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
        if name == "energy" or name in OBSERVABLES:
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

    def resolve_structural(self):
        self.parameters = [
            ir.Parameter(p.name, p.symbol, p.expression, p.value, p.unit, p.description, p.span,
                         structural=p.symbol in self.numbers.structural)
            for p in self.parameters]

    def modifiers(self, node, allowed, owner: str = "", with_units: bool = False) -> dict[str, lark.Tree]:
        """The value of each `(key = value, ...)` of `node`; a unit after a value only `with_units`
        (a scene's values: written_units)."""
        found: dict[str, lark.Tree] = {}
        block = subtree(node, "modifiers")
        for modifier in (block.children if block is not None else []):
            if not isinstance(modifier, lark.Tree):
                continue
            key = modifier.children[0]
            if modifier.data == "component_modifier":
                raise LagError(f"{key}(...) = ... sets an option for one coordinate, which only an integrator's "
                               f"atol takes{f', not {owner}' if owner else ''}", self.span(modifier))
            if str(key) not in allowed:
                options = ", ".join(allowed) if allowed else "none"
                owner_text = f" for {owner}" if owner else ""
                raise LagError(f"unknown option '{key}'{owner_text}{suggest(str(key), allowed)} (allowed: {options})",
                               self.span(key))
            if str(key) in found:
                raise LagError(f"'{key}' is given twice", self.span(key))
            unit = subtree(modifier, "unit")
            if unit is not None and not with_units:
                raise LagError(f"{key} takes a plain number here, in the unit declared after the parentheses",
                               self.span(unit))
            found[str(key)] = modifier.children[2]
        return found

    def written_units(self, node) -> dict[str, ir.Unit]:
        """The unit written after the value of each `(key = value [unit], ...)` of `node` that has one."""
        block = subtree(node, "modifiers")
        modifiers = [m for m in (block.children if block is not None else []) if isinstance(m, lark.Tree)]
        return {str(m.children[0]): self.unit(m) for m in modifiers if subtree(m, "unit") is not None}

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



def _reading_order(statement: lark.Tree) -> int:
    return READ_LAST.index(statement.data) + 1 if statement.data in READ_LAST else 0


def _position(diagnostic) -> tuple[int, int]:
    return (0, diagnostic.span.start) if diagnostic.span is not None else (1, 0)
