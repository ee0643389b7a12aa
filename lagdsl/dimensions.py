"""Dimensional analysis: every expression of a model has a dimension, and the physics fixes many.

The rules (docs/language.md, "Units"): T, U, L and the energy function are energies; a force on
q has the dimension of an energy divided by q's; the dissipation function is a power; the sides
of a constraint agree, as do the terms of a sum and the arguments of min, max and atan2; the
arguments of sin, cos, exp, log, ... and exponents are dimensionless; der() divides by a time;
t is a time; indices and range bounds are plain numbers. A number is dimensionless, except 0,
which has every dimension (`x = 0`, `{x, y, 0}`).

The check walks the parse tree of a model that `build_model` accepted, so each mistake is
reported where it was written. A quantity declared without a unit (a parameter, a coordinate)
has an unknown dimension: an equation between dimensions is then a linear equation in the
unknowns' exponents, solved as the walk goes (`Solver`); what stays unknown is said in a note.
A model without any unit is not checked at all.

A value is a Form (a scalar), a 3-tuple of Forms (a vector) or a 3-tuple of rows, each a 3-tuple of
Forms (a 3x3 matrix). Rotations are dimensionless matrices, angular velocities vectors of 1/time,
and a product A*u or A*B sums products that must agree row by row, so `dot(w, I*w)` with I in
kg*m^2 is an energy.

To teach the check a new construct, add a method `_<tree node>` (expressions) or an entry of
`FUNCTION_RULES` (calls); a construct it does not know is not checked, and a note says so.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from fractions import Fraction

import lark

from . import ir
from .draw_dimensions import DRAWN, drawn_arguments
from .errors import Diagnostic, LagError
from .expressions import _factors, _signed_terms, number_value
from .semantics import expressions_of, subtree, tokens
from .source import SourceFile, Span
from .units import Dimension, dimension, is_angle, si_factor

ONE = Dimension()
TIME = Dimension.of(time=1)
ENERGY = Dimension.of(mass=1, length=2, time=-2)
POWER = ENERGY / TIME
TRANSCENDENTAL = ("sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log")


@dataclass(frozen=True)
class Form:
    """A dimension known up to unknowns: `known` times Π unknown^power. `wild`: the number 0."""

    known: Dimension = ONE
    unknowns: tuple[tuple[str, Fraction], ...] = ()
    wild: bool = False

    def __mul__(self, other: "Form") -> "Form":
        merged = dict(self.unknowns)
        for name, power in other.unknowns:
            merged[name] = merged.get(name, Fraction(0)) + power
        return Form(self.known * other.known, tuple(sorted((k, v) for k, v in merged.items() if v)),
                    self.wild or other.wild)

    def __pow__(self, power) -> "Form":
        power = Fraction(power)
        return Form(self.known ** power, tuple((k, v * power) for k, v in self.unknowns), self.wild)

    def __truediv__(self, other: "Form") -> "Form":
        return self * other ** -1

    @staticmethod
    def unknown(name: str) -> "Form":
        return Form(ONE, ((name, Fraction(1)),))


class Solver:
    """Equations between Forms, solved for the unknowns as they come (Gaussian elimination on the
    exponents; `solved` maps each eliminated unknown to a Form in the unknowns still free)."""

    def __init__(self) -> None:
        self.solved: dict[str, Form] = {}

    def resolve(self, form: Form) -> Form:
        result = Form(form.known, (), form.wild)
        for name, power in form.unknowns:
            result = result * self.solved.get(name, Form.unknown(name)) ** power
        return result

    def equate(self, a: Form, b: Form) -> bool:
        """Record a = b; False, and nothing recorded, when it contradicts what is known."""
        a, b = self.resolve(a), self.resolve(b)
        if a.wild or b.wild:
            return True
        difference = a / b
        if not difference.unknowns:
            return difference.known.dimensionless
        (name, power), rest = difference.unknowns[0], difference.unknowns[1:]
        self.solved[name] = Form(difference.known, rest) ** (Fraction(-1) / power)
        self.solved = {key: self.resolve(value) for key, value in self.solved.items()}
        return True


def check_dimensions(tree: lark.Tree, model: ir.Model, source: SourceFile) -> ir.Model:
    """The model with its UnitReport, values of outputs declared with a unit written in it.

    Raises one LagError with every dimensional mistake found."""
    if not any(q.unit for q in (*model.parameters, *model.coordinates, *model.outputs)):
        return model
    checker = _Checker(model, source)
    checker.model_node(tree.children[0])
    if checker.errors:
        error = LagError.combine(checker.errors)
        error.diagnostics = tuple(sorted(error.diagnostics, key=lambda d: d.span.start))
        raise error
    return dataclasses.replace(model, units=checker.report(), scenes=checker.scaled_scenes())


class _Checker:
    def __init__(self, model: ir.Model, source: SourceFile):
        self.model, self.source = model, source
        self.solver = Solver()
        self.errors: list[LagError] = []
        self.notes: list[Diagnostic] = []
        self.names: dict[str, object] = {}              # a Form, a vector or a matrix of Forms
        self.families: set[str] = set()                 # indexed names: x[i] is a member, not a component
        self.undeclared: dict[str, Span] = {}           # quantities declared without a unit
        self.moving: set[str] = set()                   # lets that depend on velocities
        self.constraints: dict[str, tuple[Form, bool]] = {}     # name -> (dimension, holonomic)
        self.columns: list[tuple[str, str, object]] = []        # scene, column, Form or unit text
        self.scaled: dict[tuple[str, str], object] = {}          # (scene, column) -> factor
        self.units = {q.name.split("[")[0]: q.unit for q in (*model.parameters, *model.coordinates,
                                                            *model.outputs) if q.unit}

    # -- reporting -------------------------------------------------------------------------------
    def span(self, node) -> Span:
        if isinstance(node, lark.Token):
            return Span(self.source, node.line, node.column, node.start_pos, node.end_pos)
        return Span(self.source, node.meta.line, node.meta.column, node.meta.start_pos, node.meta.end_pos)

    def quoted(self, node, otherwise: str) -> str:
        text = " ".join(self.span(node).text.split())
        return f"'{text}'" if len(text) <= 40 else otherwise

    def words(self, form: Form) -> str:
        form = self.solver.resolve(form)
        factors = [f"dim({name})" + ("" if power == 1 else f"^{power}") for name, power in form.unknowns]
        known = form.known.words()
        return "*".join(([known] if known != "1" or not factors else []) + factors)

    def has(self, subject: str, form: Form, short: bool = False) -> str:
        """'T has dimension mass*length' ('has mass*length' when `short`), or 'T is dimensionless'."""
        resolved = self.solver.resolve(form)
        if not resolved.unknowns and resolved.known.dimensionless:
            return f"{subject} is dimensionless"
        return f"{subject} has {'' if short else 'dimension '}{self.words(form)}"

    def require(self, a: Form, b: Form, node, message) -> bool:
        """a = b, else an error at `node` with message(): both dimensions in words."""
        if self.solver.equate(a, b):
            return True
        self.errors.append(LagError(message(), self.span(node)))
        return False

    def differ(self, a: Form, a_node, b: Form, b_node, a_name: str, b_name: str, context: str = "") -> bool:
        """Two expressions of one dimension (terms of a sum, sides of a constraint); blames `a`."""
        return self.require(a, b, a_node, lambda: f"{context}{self.has(self.quoted(a_node, a_name), a)} but "
                                                  f"{self.has(self.quoted(b_node, b_name), b, True)}")

    def dimensionless(self, node, what: str) -> None:
        form = self.scalar(node)
        self.require(form, Form(), node, lambda: f"{what} must be dimensionless, but "
                                                 f"{self.has(self.quoted(node, 'it'), form)}")

    # -- declarations --------------------------------------------------------------------------
    def model_node(self, node: lark.Tree) -> None:
        declarations = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "description"]
        # In the order the model is built: declarations, then what uses them, outputs, scenes.
        for kinds in (("parameter", "coordinate", "let"), ("force", "dissipation", "constraint"),
                      ("energy",), ("output",), ("draw",), ("scene",)):
            if kinds == ("energy",):
                self.energies([d for d in declarations if d.data == "energy"])
                continue
            for declaration in declarations:
                if declaration.data in kinds:
                    getattr(self, declaration.data)(declaration)
        for name, span in self.undeclared.items():
            if self.solver.resolve(Form.unknown(name)).unknowns:
                self.notes.append(Diagnostic(f"the unit of '{name}' could not be inferred, so what uses it "
                                             "was not checked; give it a unit", span, "note"))

    def declared(self, token, unit: ir.Unit | None) -> Form:
        """A quantity's dimension: its unit's, or an unknown to infer."""
        if unit is not None:
            return Form(dimension(unit))
        self.undeclared[str(token)] = self.span(token)
        return Form.unknown(str(token))

    def parameter(self, node) -> None:
        """A parameter, or a parameter array whose unit applies to every member: a number is in the
        unit, an expression of earlier parameters must have the unit's dimension."""
        token = tokens(node, "NAME")[0]
        name, unit = str(token), self.units.get(str(token))
        size = subtree(node, "dimension")
        if size is not None:
            self.dimensionless(size.children[1], "the number of parameters")
            self.families.add(name)
        members = self.members(expressions_of(node)[0])
        if not members:                              # numbers only, in the unit
            self.names[name] = self.declared(token, unit)
            return
        expected = Form(dimension(unit)) if unit is not None else members[0][1]
        self.names[name] = expected
        for item, value in members:
            if unit is not None:
                self.require(value, expected, item,
                             lambda value=value: f"{self.has(f'the value of {token}', value)} but its unit "
                                                 f"[{unit.text}] {self.has('', expected, True)[1:]}")
            elif item is not members[0][0]:
                self.differ(value, item, expected, members[0][0], "this member", "the first member",
                            f"the members of {token} differ: ")

    def members(self, node) -> list[tuple[lark.Tree, Form]]:
        """The members of a family's value that use names, with their dimensions: one value for
        all, a list {a, b, ...}, or a list given by its index {e, i in 1:n} (e read with i a plain
        number). A member written with numbers (and the index) only is a number in the unit."""
        items = [c for c in node.children if isinstance(c, lark.Tree)] if node.data == "braces" else [node]
        if items[-1].data == "iteration":
            variable, _, range_node = items[-1].children
            if not self.names_in(items[0], str(variable)):
                return []
            return [(items[0], self.within_range(variable, range_node, items[0]))]
        return [(item, self.scalar(item)) for item in items if self.names_in(item)]

    def coordinate(self, node) -> None:
        token = tokens(node, "NAME")[0]
        size = subtree(node, "dimension")
        if size is not None:
            self.dimensionless(size.children[1], "the number of coordinates")
            self.families.add(str(token))
        form = self.names[str(token)] = self.declared(token, self.units.get(str(token)))
        self.initial_values(node, str(token), form)

    def initial_values(self, node, name: str, form: Form) -> None:
        """start = ... and velocity = ...: a number is in the coordinate's unit, an expression of
        parameters must have the coordinate's dimension (its velocity's)."""
        block = subtree(node, "modifiers")
        for modifier in (block.children if block is not None else []):
            if not isinstance(modifier, lark.Tree):
                continue
            key, value_node = str(modifier.children[0]), modifier.children[2]
            expected, owner = (form, name) if key == "start" else (form / Form(TIME), f"der({name})")
            what = "the start value" if key == "start" else "the start velocity"
            for item, value in self.members(value_node):
                self.require(value, expected, item,
                             lambda value=value: f"{self.has(f'{what} of {name}', value)} but "
                                                 f"{self.has(owner, expected, True)}")

    def let(self, node) -> None:
        token = tokens(node, "NAME")[0]
        name = str(token)
        body = expressions_of(node)[0]
        members = subtree(node, "let_range")
        if members is None:
            self.names[name] = self.value(body)
        else:
            # x[i] may use x[i - 1]: the family's dimension is an unknown that its body must equal.
            self.families.add(name)
            self.names[name] = Form.unknown(f"{name}[i]")
            value = self.within_range(members.children[1], members.children[3], body)
            if isinstance(value, Form):
                self.require(value, self.names[name], body,
                             lambda: f"{self.has(self.quoted(body, 'the body'), value)} but the members it "
                                     f"uses {self.has('', self.names[name], True)[1:]}")
            self.names[name] = value
        if self.uses_velocities(body):
            self.moving.add(name)

    def energies(self, nodes) -> None:
        """T, U, L: energies; a mistake names the other energy's dimension when that one is right."""
        bodies = {str(tokens(n, "ENERGY")[0]): expressions_of(n)[0] for n in nodes}
        values = {kind: self.scalar(body) for kind, body in bodies.items()}
        for kind, body in bodies.items():
            other = {"T": "U", "U": "T"}.get(kind)

            def message(kind=kind, other=other):
                if other in values and self.solver.resolve(values[other]) == Form(ENERGY):
                    return f"{self.has(kind, values[kind])} but {self.has(other, values[other], True)}"
                what = "a Lagrangian is an energy" if kind == "L" else "an energy has dimension"
                return f"{self.has(kind, values[kind])}, but {what} {ENERGY.words()}"
            self.require(values[kind], Form(ENERGY), body, message)

    def dissipation(self, node) -> None:
        body = expressions_of(node)[0]
        value = self.scalar(body)
        self.require(value, Form(POWER), body,
                     lambda: f"{self.has('the dissipation function', value)}, but it must be a power, "
                             f"{POWER.words()}")

    def force(self, node) -> None:
        token, parts = tokens(node, "NAME")[0], expressions_of(node)
        if len(parts) == 2:
            self.dimensionless(parts[0], "an index")
        name = str(token) + (f"[{' '.join(self.span(parts[0]).text.split())}]" if len(parts) == 2 else "")
        value, expected = self.scalar(parts[-1]), Form(ENERGY) / _components(self.lookup(token, node))[0]
        self.require(value, expected, parts[-1],
                     lambda: f"{self.has(f'the force on {name}', value)}, but a force on {name} has "
                             f"{self.words(expected)} (an energy divided by the dimension of {name})")

    def constraint(self, node) -> None:
        names = tokens(node, "NAME") if tokens(node, "COLON") else []
        name = str(names[0]) if names else f"constraint{len(self.constraints) + 1}"
        lhs, rhs = expressions_of(node)[:2]
        left, right = self.scalar(lhs), self.scalar(rhs)
        self.differ(right, rhs, left, lhs, "the right side", "the left side",
                    f"the sides of constraint {name} differ: ")
        holonomic = not (self.uses_velocities(lhs) or self.uses_velocities(rhs))
        self.constraints[name] = (right if left.wild else left, holonomic)

    def output(self, node) -> None:
        token, body = tokens(node, "NAME")[0], expressions_of(node)[0]
        value = self.names[str(token)] = self.scalar(body)
        unit = self.units.get(str(token))
        if unit is not None:
            self.require(value, Form(dimension(unit)), body,
                         lambda: f"{self.has(f'the output {token}', value)} but its unit [{unit.text}] "
                                 f"{self.has('', Form(dimension(unit)), True)[1:]}")

    # -- scenes --------------------------------------------------------------------------------
    def scene(self, node) -> None:
        scene = str(tokens(node, "NAME")[0])
        for statement in node.children:
            if not isinstance(statement, lark.Tree):
                continue
            if statement.data == "scene_time":
                for modifier in subtree(statement, "modifiers").children:
                    if isinstance(modifier, lark.Tree) and self.names_in(modifier.children[2]):
                        self.is_time(modifier.children[2], f"time({modifier.children[0]} = ...)")
            elif statement.data == "scene_set":
                self.scene_set(statement)
            elif statement.data == "scene_stop":
                left, right = expressions_of(statement)
                self.differ(self.scalar(right), right, self.scalar(left), left, "the right side", "the left side",
                            "the sides of the stop condition differ: ")
            elif statement.data == "scene_output":
                for item in statement.children:
                    if isinstance(item, lark.Tree):
                        self.column(scene, item)
            elif statement.data == "draw":
                self.draw(statement)

    def draw(self, node) -> None:
        """A picture element: each argument and option of the dimension its role has."""
        for role, what, argument, iteration in drawn_arguments(node):
            value = self.within_range(iteration.children[0], iteration.children[2], argument) if iteration \
                else self.value(argument)
            self.drawn(value, argument, role, what)

    def drawn(self, value, node, role: str, what: str) -> None:
        """Every component of `value` of the role's dimension, blamed on its own braces entry; a
        plain number is taken in SI units (as a scene's time(stop = 20) is in seconds)."""
        expected, words = DRAWN[role]
        components = _components(value)
        children = [c for c in node.children if isinstance(c, lark.Tree)] if node.data == "braces" else []
        places = children if len(children) == len(components) else [node] * len(components)
        for component, place in zip(components, places):
            if self.names_in(place) and not self.require(
                    component, Form(expected), place,
                    lambda c=component, p=place: f"{what} must be {words}, but {self.has(self.quoted(p, 'this'), c)}"):
                return

    def is_time(self, node, what: str) -> None:
        value = self.scalar(node)
        self.require(value, Form(TIME), node, lambda: f"{what} must be a time, but "
                                                      f"{self.has(self.quoted(node, 'it'), value)}")

    def scene_set(self, node) -> None:
        token = tokens(node, "NAME")[0]
        parts = [c for c in node.children if isinstance(c, lark.Tree) and c.data != "modifiers"]
        form = _components(self.lookup(token, node))[0]
        if subtree(node, "modifiers") is not None:
            if parts:
                self.dimensionless(parts[0], "an index")
            self.initial_values(node, str(token), form)
        elif self.names_in(parts[-1]):
            value = self.scalar(parts[-1])
            self.require(value, form, parts[-1], lambda: f"{self.has(f'the value set for {token}', value)} "
                                                         f"but {self.has(str(token), form, True)}")

    def column(self, scene: str, node) -> None:
        """The unit of one column of a scene's output list (and the factor of an output's unit)."""
        column = " ".join(self.span(node).text.split())
        name = str(node.children[0]) if node.data in ("name", "index", "call") else None
        arguments = [a for c in node.children if isinstance(c, lark.Tree) for a in c.children
                     if isinstance(a, lark.Tree)] if node.data == "call" else []
        if node.data == "name" and name == "energy":
            self.columns.append((scene, column, Form(ENERGY)))
        elif name in ("momentum", "residual") and node.data == "call":
            target = arguments[0]
            if name == "momentum":
                if target.data == "index":
                    self.dimensionless(target.children[2], "an index")
                value = Form(ENERGY * TIME) / _components(self.lookup(target.children[0], target))[0]
            else:
                value = self.constraint_dimension(target)[0]
            self.columns.append((scene, column, value))
        elif node.data == "name" and name in self.units and name in {o.name for o in self.model.outputs}:
            self.columns.append((scene, column, self.units[name].text))     # written in its own unit
            self.scaled[(scene, column)] = si_factor(self.units[name])
        else:
            self.columns.append((scene, column, self.angle_unit(node) or self.scalar(node)))

    def angle_unit(self, node) -> str | None:
        """"rad" for a coordinate with an angle unit, "rad/s" for its der(): radians are shown."""
        if node.data == "call" and str(node.children[0]) == "der":
            inner = self.angle_unit(subtree(node, "arguments").children[0])
            return inner and inner + "/s"
        if node.data in ("name", "index"):
            unit = self.units.get(str(node.children[0]))
            coordinate = any(c.name.split("[")[0] == str(node.children[0]) for c in self.model.coordinates)
            return "rad" if coordinate and unit is not None and is_angle(unit) else None
        return None

    # -- expressions ---------------------------------------------------------------------------
    def value(self, node):
        """A Form, or a 3-tuple of Forms for a vector."""
        method = getattr(self, f"_{node.data}", None)
        return method(node) if method is not None else self.unchecked(node)

    def scalar(self, node) -> Form:
        return _components(self.value(node))[0]

    def unchecked(self, node) -> Form:
        """A construct this check does not know: an unknown dimension, and a note."""
        self.notes.append(Diagnostic(f"the unit check does not know {self.quoted(node, 'this expression')}; "
                                     "its dimension was not checked", self.span(node), "note"))
        return Form.unknown(" ".join(self.span(node).text.split()))

    def names_in(self, node, *numbers: str) -> bool:
        """Does the expression use a name (other than pi and `numbers`)? If not, it is a plain number."""
        return any(n.data in ("name", "index") and str(n.children[0]) not in ("pi", *numbers)
                   for n in node.iter_subtrees())

    def uses_velocities(self, node) -> bool:
        return any((n.data == "call" and str(n.children[0]) == "der")
                   or (n.data in ("name", "index") and str(n.children[0]) in self.moving)
                   for n in node.iter_subtrees())

    def within_range(self, variable, range_node, body):
        """The value of `body` with the index `variable` (a plain number) bound."""
        for bound in range_node.children[::2]:
            self.dimensionless(bound, "a range bound")
        saved = self.names.get(str(variable))
        self.names[str(variable)] = Form()
        try:
            return self.value(body)
        finally:
            if saved is None:
                del self.names[str(variable)]
            else:
                self.names[str(variable)] = saved

    def _number(self, node) -> Form:
        return Form(wild=number_value(str(node.children[0]), self.span(node)) == 0)

    def _name(self, node):
        name = str(node.children[0])
        if name in self.names:
            return self.names[name]
        return {"t": Form(TIME), "pi": Form()}.get(name) or self.unchecked(node)

    def lookup(self, token, node):
        """The dimension of a declared name; one this check did not see declared is not checked."""
        return self.names[str(token)] if str(token) in self.names else self.unchecked(node)

    def _index(self, node):
        """A member of a family, or a component r[1] .. r[3] of a vector let."""
        self.dimensionless(node.children[2], "an index")
        value = self.lookup(node.children[0], node)
        if str(node.children[0]) in self.families or not isinstance(value, tuple) or _is_matrix(value):
            return value
        position = _constant(node.children[2])
        if position in (1, 2, 3):
            return value[int(position) - 1]
        return self.common(value, node)          # any component: they must agree

    def _component(self, node):
        value = self.value(node.children[0])
        return value["xyz".index(str(node.children[2]))] if isinstance(value, tuple) else value

    def _braces(self, node):
        """A vector {a, b, c}, or the matrix {u, v, w} with rows u, v, w."""
        return tuple(self.value(c) for c in node.children if isinstance(c, lark.Tree))

    def _parenthesized(self, node):
        """A sum: every term of the first one's dimension (componentwise for vectors)."""
        terms = [(term, self.value(term)) for _, term in _signed_terms(node)]
        first_node, first = next(((n, v) for n, v in terms if not _wild(v)), terms[0])
        for term, value in terms:
            if term is not first_node and not _wild(value):
                for a, b in zip(_components(value), _components(first)):
                    if not self.differ(a, term, b, first_node, "this term", "the first term"):
                        break
        return first

    _pos = _neg = _add = _sub = _parenthesized

    def _mul(self, node):
        result = None
        for factor, divides in _factors(node):
            value = self.value(factor)
            if divides:                        # only by a scalar (the semantics makes sure)
                value = _map(value, lambda c: c ** -1)
            result = value if result is None else self.product(result, value, node)
        return result

    def product(self, a, b, node):
        """s*x, x*s, A*u and A*B; each entry of a matrix product sums products of one dimension."""
        if not isinstance(a, tuple):
            return _map(b, lambda c: a * c)
        if not isinstance(b, tuple):
            return _map(a, lambda c: c * b)
        if not _is_matrix(a):                  # u*v, u*A: refused by the semantics
            return a
        if not _is_matrix(b):
            return tuple(self.entry([row[k] * b[k] for k in range(3)], node) for row in a)
        return tuple(tuple(self.entry([row[k] * b[k][j] for k in range(3)], node) for j in range(3))
                     for row in a)

    def entry(self, terms: list[Form], node) -> Form:
        """One entry of a matrix product: its products (but the zeros) have one dimension."""
        known = [term for term in terms if not term.wild]
        for term in known[1:]:
            self.require(term, known[0], node,
                         lambda term=term: f"the products summed in {self.quoted(node, 'this product')} differ: "
                                           f"{self.words(known[0])} and {self.words(term)}")
        return known[0] if known else Form(wild=True)

    _div = _mul

    def _pow(self, node):
        base_node, _, exponent_node = node.children
        base, exponent = self.scalar(base_node), _constant(exponent_node)
        if exponent is not None:
            return base ** exponent
        self.dimensionless(exponent_node, "an exponent")
        self.require(base, Form(), base_node,
                     lambda: f"{self.has(self.quoted(base_node, 'the base'), base)}, so its exponent "
                             "must be a constant number")
        return Form()

    def _call(self, node):
        name = str(node.children[0])
        arguments = [a for c in node.children if isinstance(c, lark.Tree) and c.data == "arguments"
                     for a in c.children if isinstance(a, lark.Tree)]
        rule = FUNCTION_RULES.get(name)
        return rule(self, node, arguments) if rule is not None else self.unchecked(node)

    def transcendental(self, node, arguments) -> Form:
        self.dimensionless(arguments[0], f"the argument of {node.children[0]}()")
        return Form()

    def sign(self, node, arguments) -> Form:
        self.scalar(arguments[0])                 # checked inside; sign() itself is a plain number
        return Form()

    def alike(self, node, arguments) -> Form:
        """min, max, atan2: both arguments of one dimension (atan2 is then an angle)."""
        first, second = (self.scalar(a) for a in arguments)
        self.differ(second, arguments[1], first, arguments[0], "the second argument", "the first argument")
        return Form() if str(node.children[0]) == "atan2" else first

    def der(self, node, arguments):
        return _map(self.value(arguments[0]), lambda c: c / Form(TIME))

    def sum(self, node, arguments):
        variable, _, range_node = arguments[1].children
        return self.within_range(variable, range_node, arguments[0])

    def vector_function(self, node, arguments):
        """dot, cross, norm of vectors whose components share a dimension."""
        shared = [self.shared(a) for a in arguments]
        name = str(node.children[0])
        if name == "norm":
            return shared[0]
        product = shared[0] * shared[1]
        return product if name == "dot" else (product, product, product)

    def shared(self, node) -> Form:
        return self.common(self.value(node), node)

    def common(self, value, node) -> Form:
        """The one dimension of the components of a vector (0 has any)."""
        known = [c for c in _components(value) if not c.wild]
        for other in known[1:]:
            self.require(other, known[0], node, lambda: f"the components of {self.quoted(node, 'this vector')} "
                                                        f"differ: {self.words(known[0])} and {self.words(other)}")
        return known[0] if known else Form(wild=True)

    def diag(self, node, arguments):
        zero = Form(wild=True)
        values = [self.scalar(a) for a in arguments]
        return tuple(tuple(values[i] if i == j else zero for j in range(3)) for i in range(3))

    def transpose(self, node, arguments):
        value = self.value(arguments[0])
        return tuple(zip(*value)) if _is_matrix(value) else value

    def rotation(self, node, arguments):
        """rotx .. euler_zyx: a dimensionless matrix of angles."""
        for argument in arguments:
            self.dimensionless(argument, f"an angle of {node.children[0]}()")
        return ((Form(),) * 3,) * 3

    def angular_velocity(self, node, arguments):
        """omega_zxz, omega_zyx of three angles, omega_body of a rotation matrix: 1/time."""
        name = str(node.children[0])
        if name == "omega_body":
            value = self.value(arguments[0])
            for entry in _components(value):
                if not self.require(entry, Form(), arguments[0],
                                    lambda entry=entry: f"the rotation matrix of omega_body() must be "
                                                        f"dimensionless, but it has {self.words(entry)}"):
                    break
        else:
            for argument in arguments:
                self.dimensionless(argument, f"an angle of {name}()")
        return (Form(TIME) ** -1,) * 3

    def multiplier(self, node, arguments) -> Form:
        """λ of constraint c: Aᵀλ is a generalized force, A = ∂c/∂q (holonomic) or ∂c/∂q'."""
        value, holonomic = self.constraint_dimension(arguments[0])
        return Form(ENERGY) / value if holonomic else Form(POWER) / value

    def constraint_dimension(self, node) -> tuple[Form, bool]:
        """(dimension, holonomic) of the constraint named by `node`."""
        name = str(node.children[0])
        return self.constraints[name] if name in self.constraints else (self.unchecked(node), True)

    def report(self) -> ir.UnitReport:
        quantities = []
        for q in (*self.model.parameters, *self.model.coordinates):
            base = q.name.split("[")[0]
            unit = self.units.get(base)
            shown = "rad" if unit is not None and is_angle(unit) else self.si(self.names[base])
            quantities.append((q.name, shown, unit is None))
        for o in self.model.outputs:
            unit = self.units.get(o.name)
            quantities.append((o.name, unit.text if unit is not None else self.si(self.names[o.name]), unit is None))
        columns = tuple((scene, column, value if isinstance(value, str) else self.si(value))
                        for scene, column, value in self.columns)
        return ir.UnitReport(tuple(quantities), columns, tuple(self.notes))

    def si(self, form: Form) -> str:
        resolved = self.solver.resolve(form) if isinstance(form, Form) else self.solver.resolve(form[0])
        return "?" if resolved.unknowns else resolved.known.si()

    def scaled_scenes(self) -> tuple[ir.Scene, ...]:
        """Scenes whose output lists name an output declared with a unit: written in that unit."""
        scenes = []
        for scene in self.model.scenes:
            outputs = tuple(dataclasses.replace(o, expression=o.expression / self.scaled[(scene.name, o.column)])
                            if (scene.name, o.column) in self.scaled else o for o in scene.outputs)
            scenes.append(dataclasses.replace(scene, outputs=outputs))
        return tuple(scenes)


FUNCTION_RULES = {
    **{name: _Checker.transcendental for name in TRANSCENDENTAL},
    "sqrt": lambda checker, node, arguments: checker.scalar(arguments[0]) ** Fraction(1, 2),
    "abs": lambda checker, node, arguments: checker.scalar(arguments[0]),
    "sign": _Checker.sign,
    "min": _Checker.alike, "max": _Checker.alike, "atan2": _Checker.alike,
    "der": _Checker.der, "sum": _Checker.sum, "multiplier": _Checker.multiplier,
    "dot": _Checker.vector_function, "cross": _Checker.vector_function, "norm": _Checker.vector_function,
    "diag": _Checker.diag, "transpose": _Checker.transpose,
    **{name: _Checker.rotation for name in ("rotx", "roty", "rotz", "euler_zxz", "euler_zyx")},
    **{name: _Checker.angular_velocity for name in ("omega_zxz", "omega_zyx", "omega_body")},
}


def _wild(value) -> bool:
    return all(c.wild for c in _components(value))


def _is_matrix(value) -> bool:
    return isinstance(value, tuple) and isinstance(value[0], tuple)


def _components(value) -> tuple[Form, ...]:
    """The Forms of a scalar, a vector or (row by row) a matrix."""
    if not isinstance(value, tuple):
        return (value,)
    return tuple(c for row in value for c in row) if _is_matrix(value) else value


def _map(value, function):
    """`function` applied to each Form of a scalar, vector or matrix."""
    if not isinstance(value, tuple):
        return function(value)
    return tuple(_map(c, function) for c in value)


def _constant(node) -> Fraction | None:
    """The value of an exponent written with numbers only (2, -1, (1/2), 3/2), else None."""
    if not isinstance(node, lark.Tree):
        return None
    if node.data == "number":
        return Fraction(str(number_value(str(node.children[0]), None)))
    if node.data in ("neg", "pos", "parenthesized"):
        inner = _constant(node.children[1])
        return None if inner is None else (-inner if node.data == "neg" else inner)
    if node.data in ("add", "sub", "mul", "div", "pow"):
        left, right = _constant(node.children[0]), _constant(node.children[2])
        if left is None or right is None or (node.data == "div" and right == 0):
            return None
        if node.data == "pow":          # (2^2): a small whole power of a number is still a number
            return left ** right if right.denominator == 1 and abs(right) <= 64 and left else None
        return {"add": left + right, "sub": left - right, "mul": left * right,
                "div": left / right if right else None}[node.data]
    return None
