"""Dimensional analysis: every expression node has a dimension, computed as it is built.

The rules (docs/language.md, "Units"): the terms of a sum agree, as do the arguments of min, max
and atan2; the arguments of sin, cos, exp, log, ... and exponents are dimensionless; der() divides
by a time; t is a time; indices and range bounds are plain numbers. A number is dimensionless,
except 0, which has every dimension (`x = 0`, `{x, y, 0}`). What the physics fixes for each
statement (T is an energy, a force on q an energy divided by q's, ...) is `model_dimensions.py`.

There is one walk of the tree: `ExpressionBuilder` calls the rule of each node (`number`,
`leaf`, `addition`, `product`, `power`, `call`, ...) once the node's value is built, and the rule
combines the dimensions of its parts. A node built many times (the body of a sum, or of an
indexed let, once per index) gets its dimension the first time: the members of a family share one.
A built-in function's rule is in its record (functions.py).

A quantity declared without a unit (a parameter, a coordinate) has an unknown dimension: an
equation between dimensions is then a linear equation in the unknowns' exponents. The equations
are recorded as the model is built and solved once it is complete (`Solver`, `solve`), so that
each mistake is reported where it was written, naming both dimensions as the solution so far
knows them.

A dimension is a Form (a scalar), a 3-tuple of Forms (a vector) or a 3-tuple of rows, each a
3-tuple of Forms (a 3x3 matrix). Rotations are dimensionless matrices, angular velocities
vectors of 1/time, and a product A*u or A*B sums products that must agree row by row, so
`dot(w, I*w)` with I in kg*m^2 is an energy.
"""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction

import sympy

from ..errors import LagError
from ..source import SourceFile
from .tree import excerpt, is_numeral, span_of
from .units import Dimension

ONE = Dimension()
TIME = Dimension.of(time=1)
ENERGY = Dimension.of(mass=1, length=2, time=-2)
POWER = ENERGY / TIME
# The order in which the recorded equations are solved, by the statement they come from:
# declarations in source order, then forces, dissipation and constraints, the energies (their
# parts, then that each is an energy, so that a wrong T is named next to a right U), and last
# the outputs and scenes, whose unknowns the equations of motion have inferred by then.
ORDER = ("declaration", "force", "energy", "energy total", "output", "scene")


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


WILD = Form(wild=True)


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


@dataclass(frozen=True)
class Requirement:
    """Pairs of dimensions that must be equal, taken in order: the first pair that is not is
    reported at `node` with message(a, b), and the rest are not looked at."""

    pairs: tuple[tuple[Form, Form], ...]
    node: object
    message: Callable[[Form, Form], str]


def _first_build(rule):
    """Run a node's rule the first time the node is built, and keep its dimension.

    A sum over an empty range is 0 (`sum(e, j in 1:i - 1)` for i = 1): its body is not built, so
    its dimension, and that of what contains it, is provisional and found again at the next
    build, when the body may be built; the equations recorded with it are then set aside."""
    @functools.wraps(rule)
    def once(self, node, *args):
        key = id(node)
        if key in self.forms and key not in self.provisional:
            return
        self.discarded.update(map(id, self.provisional.pop(key, ())))
        recorded, self.recording, self.reads_provisional = self.recording, [], False
        self.forms[key] = rule(self, node, *args)
        if self.reads_provisional:
            self.provisional[key] = self.recording
        self.recording = recorded
    return once


class DimensionCheck:
    """The dimension of each expression node, and the equations between dimensions to solve."""

    def __init__(self, source: SourceFile):
        self.source = source
        self.solver = Solver()
        self.forms: dict[int, object] = {}          # id(node) -> Form, or a vector or matrix of Forms
        self.requirements: dict[str, list[Requirement]] = {group: [] for group in ORDER}
        self.group = ORDER[0]                         # where requirements are recorded now
        self.constraints: dict[str, tuple[Form, bool]] = {}     # name -> (dimension, holonomic)
        # nodes whose dimension is provisional, with the requirements their rule recorded
        self.provisional: dict[int, list[Requirement]] = {}
        self.discarded: set[int] = set()            # ids of requirements recorded provisionally
        self.recording: list[Requirement] | None = None     # by the rule running now, if one runs
        self.reads_provisional = False              # the rule running now read a provisional dimension

    # -- dimensions of nodes ------------------------------------------------------------------
    def form(self, node):
        if id(node) in self.provisional:
            self.reads_provisional = True
        return self.forms[id(node)]

    def scalar(self, node) -> Form:
        return components(self.form(node))[0]

    def built_form(self, node):
        """The dimension of a node that may not be built: the body of a sum over an empty range,
        whose sum is 0 (provisionally: see _first_build)."""
        if id(node) in self.forms:
            return self.form(node)
        self.reads_provisional = True
        return WILD

    def is_new(self, node) -> bool:
        return id(node) not in self.forms

    # -- recording equations -------------------------------------------------------------------
    def require_each(self, pairs, node, message: Callable[[Form, Form], str], group: str | None = None) -> None:
        """Each pair equal, else an error at `node` with message(a, b) of the first pair that is not."""
        requirement = Requirement(tuple(pairs), node, message)
        self.requirements[group or self.group].append(requirement)
        if self.recording is not None:
            self.recording.append(requirement)

    def require(self, a: Form, b: Form, node, message: Callable[[], str], group: str | None = None) -> None:
        """a = b, else an error at `node` with message(): both dimensions in words."""
        self.require_each(((a, b),), node, lambda _a, _b: message(), group)

    def differ(self, a: Form, a_node, b: Form, b_node, a_name: str, b_name: str, context: str = "") -> None:
        """Two expressions of one dimension (terms of a sum, sides of a constraint); blames `a`."""
        self.require(a, b, a_node, lambda: f"{context}{self.has(self.quoted(a_node, a_name), a)} but "
                                           f"{self.has(self.quoted(b_node, b_name), b, True)}")

    def dimensionless(self, node, what: str) -> None:
        form = self.scalar(node)
        self.require(form, Form(), node, lambda: f"{what} must be dimensionless, but "
                                                 f"{self.has(self.quoted(node, 'it'), form)}")

    def common(self, value, node) -> Form:
        """The one dimension of the components of a vector (0 has any)."""
        known = [c for c in components(value) if not c.wild]
        for other in known[1:]:
            self.require(other, known[0], node,
                         lambda other=other: f"the components of {self.quoted(node, 'this vector')} "
                                             f"differ: {self.words(known[0])} and {self.words(other)}")
        return known[0] if known else WILD

    # -- messages ------------------------------------------------------------------------------
    def quoted(self, node, otherwise: str) -> str:
        return excerpt(span_of(node, self.source), otherwise, quote=True)

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

    # -- the rules of expression nodes, called by ExpressionBuilder ------------------------------
    @_first_build
    def leaf(self, node, form):
        """A number, a name, a member of a family: a dimension known beforehand."""
        return form

    def number(self, node, value: sympy.Expr) -> None:
        self.leaf(node, WILD if value == 0 else Form())

    @_first_build
    def component(self, node, vector, index_node, position: int):
        """r[position] of a vector; with an index that varies (r[i]), any component: they must agree.
        (A vector of any dimension, 0, has it in every component.)"""
        if not isinstance(vector, tuple):
            return vector
        return vector[position - 1] if is_numeral(index_node) else self.common(vector, node)

    @_first_build
    def axis(self, node, target, position: int):
        """v.x, v.y, v.z."""
        vector = self.form(target)
        return vector[position] if isinstance(vector, tuple) else vector

    @_first_build
    def braces(self, node, children):
        """A vector {a, b, c}, or the matrix {u, v, w} with rows u, v, w."""
        return tuple(self.form(child) for child in children)

    @_first_build
    def addition(self, node, terms):
        """A sum of terms (through +, -, signs, parentheses): every term of the first one's
        dimension (componentwise for vectors)."""
        values = [(term, self.form(term)) for term in terms]
        first_node, first = next(((n, v) for n, v in values if not _wild(v)), values[0])
        for term, value in values:
            if term is not first_node and not _wild(value):
                self.require_each(zip(components(value), components(first)), term,
                                  lambda a, b, term=term: f"{self.has(self.quoted(term, 'this term'), a)} but "
                                                          f"{self.has(self.quoted(first_node, 'the first term'), b, True)}")
        return first

    @_first_build
    def product(self, node, chain):
        """A product chain: `chain` lists (factor, divides); divisors are scalars (the semantics
        makes sure)."""
        result = None
        for factor, divides in chain:
            value = self.form(factor)
            if divides:
                value = map_forms(value, lambda c: c ** -1)
            result = value if result is None else self._times(result, value, node)
        return result

    def _times(self, a, b, node):
        """s*x, x*s, A*u and A*B; each entry of a matrix product sums products of one dimension."""
        if not isinstance(a, tuple):
            return map_forms(b, lambda c: a * c)
        if not isinstance(b, tuple):
            return map_forms(a, lambda c: c * b)
        if not is_matrix(a):                  # u*v, u*A: refused by the semantics
            return a
        if not is_matrix(b):
            return tuple(self._entry([row[k] * b[k] for k in range(3)], node) for row in a)
        return tuple(tuple(self._entry([row[k] * b[k][j] for k in range(3)], node) for j in range(3))
                     for row in a)

    def _entry(self, terms: list[Form], node) -> Form:
        """One entry of a matrix product: its products (but the zeros) have one dimension."""
        known = [term for term in terms if not term.wild]
        for term in known[1:]:
            self.require(term, known[0], node,
                         lambda term=term: f"the products summed in {self.quoted(node, 'this product')} differ: "
                                           f"{self.words(known[0])} and {self.words(term)}")
        return known[0] if known else WILD

    @_first_build
    def power(self, node, base_node, exponent_node, exponent: sympy.Expr):
        """A power of a dimension to a constant number (written with numbers only: x^i varies with
        i); to any other exponent, of a plain number."""
        base = self.scalar(base_node)
        if exponent.is_Rational and is_numeral(exponent_node):
            return base ** Fraction(int(exponent.p), int(exponent.q))
        self.dimensionless(exponent_node, "an exponent")
        self.require(base, Form(), base_node,
                     lambda: f"{self.has(self.quoted(base_node, 'the base'), base)}, so its exponent "
                             "must be a constant number")
        return Form()

    @_first_build
    def call(self, node, function, arguments):
        """A built-in function: the rule of its record (functions.py)."""
        return function.dimension(self, node, arguments)

    def constraint_dimension(self, node) -> tuple[Form, bool]:
        """(dimension, holonomic) of the constraint named by `node`."""
        return self.constraints[str(node.children[0])]

    # -- solving -------------------------------------------------------------------------------
    def solve(self) -> list[LagError]:
        """Solve the recorded equations in ORDER; one error for each that contradicts the others."""
        errors = []
        for group in ORDER:
            for requirement in self.requirements[group]:
                if id(requirement) in self.discarded:
                    continue
                for a, b in requirement.pairs:
                    if not self.solver.equate(a, b):
                        errors.append(LagError(requirement.message(a, b), span_of(requirement.node, self.source)))
                        break
        return errors

    def si(self, form) -> str:
        """The SI unit of a dimension (of a vector's first component), "?" where it is not known."""
        resolved = self.solver.resolve(components(form)[0])
        return "?" if resolved.unknowns else resolved.known.si()


def _wild(value) -> bool:
    return all(c.wild for c in components(value))


def is_matrix(value) -> bool:
    return isinstance(value, tuple) and isinstance(value[0], tuple)


def components(value) -> tuple[Form, ...]:
    """The Forms of a scalar, a vector or (row by row) a matrix."""
    if not isinstance(value, tuple):
        return (value,)
    return tuple(c for row in value for c in row) if is_matrix(value) else value


def map_forms(value, function):
    """`function` applied to each Form of a scalar, vector or matrix."""
    if not isinstance(value, tuple):
        return function(value)
    return tuple(map_forms(c, function) for c in value)
