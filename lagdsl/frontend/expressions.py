"""The expression language: parse-tree nodes -> sympy, node by node (never from text).

Values are scalars (sympy expressions), 3-vectors and 3x3 matrices (values.py). Names resolve
through a `Scope`; indexed families (`theta[i]`) and `sum(expr, i in a:b)` are unrolled, with
indices and range bounds evaluated to integers at compile time (compile_time.py); calls are
calls.py's. Each node is also given its dimension on the same walk: once its value is built,
its rule in dimensions.py combines the dimensions of its parts.
"""
from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction

import lark
import sympy

from ..calculus import Differentiator
from .calls import Calls
from .compile_time import CompileTime
from .constants import FOLDING_NODES, MAX_DOUBLE, require_finite, require_power_in_range, require_real_constants
from .dimensions import TIME, DimensionCheck, Form
from ..errors import LagError, suggest
from .functions import BUILTINS
from ..source import SourceFile, Span
from .tree import factors, signed_terms, span_of, through
from .values import AXES, Matrix, Scope, Vector, is_array, kind_of, map_value, matrix_of, matrix_product
from .values import body_rates, rotation  # noqa: F401  (re-exported: the rotations as the language defines them)

MAX_NUMBER_LENGTH = 100     # characters of a number literal (a double keeps 17 significant digits)
MAX_NESTING = 100           # nested calls, powers, products in sums...: see ExpressionBuilder.build


def number_value(text: str, where: Callable[[], Span]) -> sympy.Rational:
    """A decimal literal, exactly: 9.81 is 981/100, so no precision is lost before code.
    `where()` is its span, found only for a message."""
    if len(text) > MAX_NUMBER_LENGTH:
        raise LagError(f"a number of {len(text)} characters; at most {MAX_NUMBER_LENGTH} are read "
                       "(double precision keeps 17 significant digits)", where())
    mantissa, _, exponent = text.lower().partition("e")
    whole, _, fraction = mantissa.partition(".")
    if exponent and not (whole + fraction).strip("0"):
        return sympy.S.Zero
    if exponent:
        # The decimal exponent of the value, found before 10**exponent is computed exactly.
        magnitude = int(exponent) + (len(whole.lstrip("0")) - 1 if whole.strip("0")
                                     else -(len(fraction) - len(fraction.lstrip("0"))) - 1)
        if magnitude > 308:
            raise LagError(f"the number {text} is not finite in double precision", where())
        if magnitude < -330:
            raise LagError(f"the number {text} is smaller than the smallest double (about 5e-324)", where())
    value = sympy.Rational(Fraction(text))
    if abs(value) > MAX_DOUBLE:
        raise LagError(f"the number {text} is not finite in double precision", where())
    return value


class ExpressionBuilder:
    """Turns expression subtrees into sympy values within a Scope, with their dimensions."""

    def __init__(self, source: SourceFile, differentiator: Differentiator,
                 velocities: dict[sympy.Symbol, sympy.Symbol], dimensions: DimensionCheck):
        self.source = source
        self.dims = dimensions
        self.calls = Calls(self, differentiator, velocities)
        self.numbers = CompileTime(self)
        self.depth = 0                  # of the build below

    def span(self, node) -> Span:
        return span_of(node, self.source)

    # -- entry points ------------------------------------------------------------------------
    def scalar(self, node, scope: Scope, what: str = "a scalar") -> sympy.Expr:
        value = self.build(node, scope)
        if is_array(value):
            raise LagError(f"expected {what}, but this is {kind_of(value)}", self.span(node))
        return value

    # -- the tree walk -------------------------------------------------------------------------
    def build(self, node, scope: Scope):
        """The value of an expression node.

        Sums and product chains of any length are one level (they are walked iteratively); each
        call, power, index, vector or factor that is itself a sum nests one level deeper. Deeper
        than MAX_NESTING is an error: the derivation and the printers recurse through the
        expression, and Python's recursion limit must not be what stops them.
        """
        if isinstance(node, lark.Token):
            raise LagError(f"unexpected '{node}'", self.span(node))
        method = getattr(self, f"_{node.data}", None)
        if method is None:
            raise LagError("this is not an expression", self.span(node))
        if self.depth >= MAX_NESTING:
            raise LagError(f"the expression is nested more than {MAX_NESTING} levels deep (function calls, "
                           "powers, parenthesized sums in products); name inner parts with lets", self.span(node))
        self.depth += 1
        try:
            value = method(node, scope)
        finally:
            self.depth -= 1
        folds = node.data in FOLDING_NODES
        for component in (value.components if is_array(value) else (value,)):
            require_real_constants(component, lambda: self.span(node), folds)
        return value

    def _number(self, node, scope):
        value = number_value(str(node.children[0]), lambda: self.span(node))
        self.dims.number(node, value)
        return value

    def _name(self, node, scope):
        token = node.children[0]
        name = str(token)
        if name in ("pi", "t"):
            self.dims.leaf(node, Form() if name == "pi" else Form(TIME))
            return sympy.pi if name == "pi" else sympy.Symbol("t", real=True)
        if name not in scope.bindings:
            if name in BUILTINS:
                raise LagError(f"'{name}' is a function; call it as {name}(...)", self.span(token))
            if name in ("T", "U", "L"):
                raise LagError(f"{name} cannot be used in an expression; name the shared part with a let",
                               self.span(token))
            if name == "energy":
                raise LagError("energy is output on its own in a scene's output list (output x, energy;); "
                               "it cannot be part of an expression", self.span(token))
        binding = scope.lookup(name, self.span(token))
        if binding.family is not None:
            raise LagError(f"'{name}' is an indexed family; write {name}[i]", self.span(token))
        if binding.kind == "constraint":
            raise LagError(f"'{name}' is a constraint, not a value; use residual({name}) or multiplier({name}) in a scene's output",
                           self.span(token))
        self.dims.leaf(node, binding.dimension)
        return binding.value

    def _index(self, node, scope):
        token, _, index_node, _ = node.children
        if str(token) in ("t", "pi") and str(token) not in scope.bindings:
            raise LagError(f"'{token}' is not indexed", self.span(token))
        binding = scope.lookup(str(token), self.span(token))
        if binding.family is None and isinstance(binding.value, Vector):
            index = self.numbers.integer(index_node, scope, "an index")
            if index not in (1, 2, 3):
                raise LagError(f"index {index} is out of range for a 3-vector (1:3)", self.span(index_node))
            self.dims.component(node, binding.dimension, index_node, index)
            return binding.value.components[index - 1]
        if binding.family is None:
            raise LagError(f"'{token}' is not indexed", self.span(token))
        index = self.numbers.integer(index_node, scope, "an index")
        if binding.kind == "partial" and index not in binding.family:
            raise LagError(f"'{token}[{index}]' is used before it is defined; a member of an indexed let "
                           "may only use earlier members", self.span(node))
        if index not in binding.family:
            members = f"{min(binding.family)}:{max(binding.family)}" if binding.family else "it has no members"
            raise LagError(f"index {index} is out of range for '{token}' ({members})", self.span(index_node))
        self.dims.leaf(node, binding.dimension)
        return binding.family[index]

    def _component(self, node, scope):
        """v.x, v.y, v.z."""
        target, _, axis = node.children
        value = self.build(target, scope)
        if not isinstance(value, Vector):
            raise LagError(f".{axis} takes a component of a 3-vector, but this is {kind_of(value)}",
                           self.span(target))
        if str(axis) not in AXES:
            raise LagError(f"a 3-vector has the components x, y and z, not '{axis}'{suggest(str(axis), AXES)}",
                           self.span(axis))
        self.dims.axis(node, target, AXES.index(str(axis)))
        return value.components[AXES.index(str(axis))]

    def _braces(self, node, scope):
        """{a, b, c}: a 3-vector; {u, v, w} of three 3-vectors: the 3x3 matrix with those rows."""
        children = [child for child in node.children if not isinstance(child, lark.Token)]
        for child in children:
            if child.data == "iteration":
                raise LagError("a list '{e, i in a:b}' gives the start values of an indexed coordinate or "
                               "the values of a parameter array; it is not a value of an expression",
                               self.span(node))
        items = [self.build(child, scope) for child in children]
        if len(items) != 3:
            raise LagError(f"a vector has 3 components, not {len(items)}", self.span(node))
        self.dims.braces(node, children)
        if all(isinstance(item, Vector) for item in items):
            return Matrix(tuple(item.components for item in items))
        for item, child in zip(items, children):
            if is_array(item):
                raise LagError(f"expected a scalar component, but this is {kind_of(item)} (a matrix is "
                               "written {{a, b, c}, {d, e, f}, {g, h, i}}, row by row)", self.span(child))
        return Vector(tuple(items))

    def _parenthesized(self, node, scope):
        """A sum of terms with signs: through +, -, unary signs and parentheses, left to right
        (iteratively, tree.signed_terms)."""
        terms = signed_terms(node)
        values = [(sign, self.build(term, scope)) for sign, term in terms]
        kinds = {kind_of(value) for _, value in values}
        if len(kinds) > 1:
            words = {"a 3-vector": "a vector", "a 3x3 matrix": "a matrix", "a scalar": "a scalar"}
            raise LagError("cannot add " + " and ".join(words[kind] for kind in sorted(kinds)), self.span(node))
        self.dims.addition(node, [term for _, term in terms])
        first = values[0][1]
        if is_array(first):
            total = [sympy.Add(*(sign * v.components[k] for sign, v in values)) for k in range(len(first.components))]
            return Vector(tuple(total)) if isinstance(first, Vector) else matrix_of(total)
        return sympy.Add(*(sign * value for sign, value in values))

    _pos = _neg = _add = _sub = _parenthesized

    def _mul(self, node, scope):
        """A product chain a*b/c*d of scalars, 3-vectors and 3x3 matrices, no divisor an array or zero.

        Scalars scale; the arrays multiply left to right as in linear algebra (A*B, A*v), and
        at most one vector, the last array of the chain: u*v is dot or cross, v*A needs transpose.
        """
        chain = factors(node)
        array, scalars, denominators, partial = None, [], [], sympy.S.One
        for factor, divides in chain:
            if divides:
                divisor = self.scalar(factor, scope, "a scalar divisor")
                if divisor == 0:
                    raise LagError("division by zero", self.span(factor))
                denominators.append(divisor)
                partial /= divisor
            else:
                value = self.build(factor, scope)
                if not is_array(value):
                    scalars.append(value)
                    partial *= value
                else:
                    array = value if array is None else self._array_product(array, value, node)
            # The constants folded so far, reported where they overflow (the tree would: a*b/c is (a*b)/c).
            require_real_constants(partial, lambda: through(self.span(node), self.span(factor)), True)
        self.dims.product(node, chain)
        scale = sympy.Mul(*scalars) / sympy.Mul(*denominators)
        return map_value(array, lambda c: c * scale) if array is not None else scale

    _div = _mul

    def _array_product(self, left, right, node):
        if isinstance(left, Vector) and isinstance(right, Vector):
            raise LagError("the product of two vectors is ambiguous; use dot(a, b) or cross(a, b)",
                           self.span(node))
        if isinstance(left, Vector):
            raise LagError("a vector times a matrix is not defined; write transpose(A)*v", self.span(node))
        return matrix_product(left, right)

    def _pow(self, node, scope):
        left, _, right = node.children
        base = self.scalar(left, scope, "a scalar base")
        exponent = self.scalar(right, scope, "a scalar exponent")
        if base == 0 and exponent.is_number and exponent.is_negative:
            raise LagError("division by zero", self.span(node))
        require_power_in_range(base, exponent, self.span(node))
        self.dims.power(node, left, right, exponent)
        return require_finite(base ** exponent, self.span(node))

    def _call(self, node, scope):
        return self.calls.value(node, scope)

    def _iteration(self, node, scope):
        raise LagError("an 'i in a:b' range is only allowed as the second argument of sum()",
                       self.span(node))
