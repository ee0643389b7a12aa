"""Numbers the compiler fixes: parameter values, indices, range bounds and family sizes.

Indexed families and sums are unrolled, so their sizes and indices are integers known at
compile time: literals, or expressions of parameters evaluated at their exact values. A
parameter used so is structural (a scene cannot change it). The unrolled terms of all sums and
indexed lets together are bounded (MAX_UNROLLED), since each is derived symbolically.
"""
from __future__ import annotations

from fractions import Fraction

import sympy

from .. import ir
from ..errors import LagError
from ..given_values import scaled_to_si
from .tree import subtrees
from .units import si_factor
from .values import Scope

MAX_MEMBERS = 10000         # largest index range or indexed family: sizes are unrolled at compile time
MAX_UNROLLED = 100000       # all sums and indexed lets of a model together
HUGE_EXPONENT = 64          # a power of a parameter beyond this gets float values (with_parameter_values)


class CompileTime:
    """The numbers an ExpressionBuilder's expressions must evaluate to at compile time."""

    def __init__(self, builder):
        self.builder = builder
        self.exact_parameters: dict[sympy.Symbol, sympy.Expr] = {}   # parameter -> exact value
        self.structural: set[sympy.Symbol] = set()                    # parameters used as sizes
        self.unrolled = 0                                             # terms of sums and indexed lets

    def with_parameter_values(self, value: sympy.Expr) -> sympy.Expr:
        """`value` with the parameters' exact values put in. A power of a parameter with a large
        exponent (l^1e300) would be computed exactly, digit by digit, for hours: there the values
        go in as 30-digit floats, whose powers cost nothing (and overflow or underflow plainly)."""
        huge = any(p.exp.is_number and abs(p.exp) > HUGE_EXPONENT and p.base.free_symbols
                   for p in value.atoms(sympy.Pow))
        if not huge:
            return value.xreplace(self.exact_parameters)
        return value.xreplace({s: sympy.Float(v.evalf(30), 30) for s, v in self.exact_parameters.items()})

    def number(self, node, what: str, scope: Scope, unit: ir.Unit | None = None) -> float:
        """A number in a scene or modifier: parameters allowed, evaluated at their defaults, in SI.
        An expression of parameters is in SI already; one of numbers only is in `unit`, converted
        as a value set from outside the model file is (given_values.scaled_to_si), so that a scene's
        `set theta(start = 30)` runs bit for bit as `--set theta.start=30`."""
        value = self.builder.scalar(node, scope, what)
        if value.free_symbols - set(self.exact_parameters):
            raise LagError(f"{what} may only use numbers and parameters", self.builder.span(node))
        result = complex(self.with_parameter_values(value).evalf(20))
        if result.imag != 0 or not abs(result.real) < float("inf"):
            raise LagError(f"{what} is not a finite real number", self.builder.span(node))
        if unit is None or value.free_symbols:
            return result.real
        return scaled_to_si(float(value) if value.is_Rational else result.real, Fraction(si_factor(unit)))

    def integer(self, node, scope: Scope, what: str) -> int:
        """An index or range bound: parameters in it are fixed at compile time (structural), and
        it is a plain number (dimensionless)."""
        new = self.builder.dims.is_new(node)
        value = self.builder.scalar(node, scope)
        if new:
            self.builder.dims.dimensionless(node, what)
        if value.is_Integer:            # a literal or a loop index: the common case, nothing to put in
            return int(value)
        used = value.free_symbols & self.exact_parameters.keys()
        value = self.with_parameter_values(value)
        if not value.is_Integer:
            if value.is_number and value.is_real:
                raise LagError(f"{what} must be an integer, not {float(value):g}", self.builder.span(node))
            raise LagError(f"{what} must be an integer known at compile time "
                           "(a literal or a parameter with an integer value)", self.builder.span(node))
        self.structural |= used
        return int(value)

    def iteration(self, node, scope: Scope) -> tuple[str, int, int]:
        """`i in a:b` -> ("i", a, b)."""
        name_token, _, range_node = node.children
        low_node, _, high_node = range_node.children
        if str(name_token) in scope.bindings and scope.bindings[str(name_token)].kind != "loop":
            raise LagError(f"the index '{name_token}' hides the declared name '{name_token}'",
                           self.builder.span(name_token))
        low = self.integer(low_node, scope, "a range bound")
        high = self.integer(high_node, scope, "a range bound")
        if high - low + 1 > MAX_MEMBERS:
            raise LagError(f"the range {low}:{high} has {high - low + 1} members; at most {MAX_MEMBERS} "
                           "are unrolled", self.builder.span(range_node))
        self.count_unrolled(max(0, high - low + 1), range_node)
        return str(name_token), low, high

    def count_unrolled(self, terms: int, range_node) -> None:
        """Add `terms` built terms to the model's budget of MAX_UNROLLED; past it, an error at
        `range_node`."""
        self.unrolled += terms
        if self.unrolled > MAX_UNROLLED:
            error = LagError(f"the sums and indexed lets of the model unroll to more than {MAX_UNROLLED} terms, "
                             "too many to derive symbolically", self.builder.span(range_node))
            if self.unrolled - terms > MAX_UNROLLED:
                error.diagnostics = ()          # reported once, where the budget ran out
            raise error

    def family_size(self, dimension, scope: Scope, what: str) -> int:
        """The number of members of an indexed family `name[n]` of parameters or coordinates."""
        size = self.integer(dimension.children[1], scope, f"the number of {what}")
        if size < 1:
            raise LagError(f"an indexed family of {what} needs at least one member", self.builder.span(dimension))
        if size > MAX_MEMBERS:
            raise LagError(f"{size} {what} in one family; at most {MAX_MEMBERS} are allowed",
                           self.builder.span(dimension))
        return size

    def listed(self, node, scope: Scope, size: int, members: str, kind: str, noun: str) -> list[tuple[object, Scope]]:
        """The values of a family of `size` members, each as (expression, scope to read it in):
        one expression for all, a list {a, b, ...} of `size`, or {e, i in 1:n}, e read with i bound."""
        if node.data != "braces":
            return [(node, scope)] * size
        items = subtrees(node)
        if items[-1].data == "iteration":
            if len(items) != 2:
                raise LagError("a list given by its index is written {expression, i in 1:n}", self.builder.span(node))
            variable, low, high = self.iteration(items[1], scope)
            if (low, high) != (1, size):
                raise LagError(f"the range {low}:{high} does not cover the members {members}; write "
                               f"{variable} in 1:{size}", self.builder.span(items[1].children[2]))
            return [(items[0], scope.child(**{variable: i})) for i in range(1, size + 1)]
        if len(items) != size:
            what = f"{kind} values" if kind else "values"
            raise LagError(f"{len(items)} {what} for the {size} {noun} {members}; give one "
                           f"value for all, or a list of {size}", self.builder.span(node))
        return [(item, scope) for item in items]
