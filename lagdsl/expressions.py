"""The expression language: parse-tree nodes -> sympy, node by node (never from text).

Values are scalars (sympy expressions) or 3-vectors (`Vector`). Names resolve through a
`Scope`; indexed families (`theta[i]`) and `sum(expr, i in a:b)` are unrolled here, with
index bounds evaluated to integers at compile time. `der(e)` is the total time derivative by
the chain rule, Σ_k ∂e/∂q_k q'_k + ∂e/∂t, taken through the named intermediates by the
`Differentiator`; it is defined for expressions of (q, t) only, since L(q, q', t) may not
depend on accelerations.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction

import lark
import sympy

from .calculus import TIME_DIRECTION, Differentiator
from .errors import LagError, suggest  # noqa: F401  (suggest: re-exported)
from .source import SourceFile, Span

FUNCTIONS = {
    "sin": (sympy.sin, 1), "cos": (sympy.cos, 1), "tan": (sympy.tan, 1),
    "asin": (sympy.asin, 1), "acos": (sympy.acos, 1), "atan": (sympy.atan, 1),
    "atan2": (sympy.atan2, 2), "sinh": (sympy.sinh, 1), "cosh": (sympy.cosh, 1),
    "tanh": (sympy.tanh, 1), "exp": (sympy.exp, 1), "log": (sympy.log, 1),
    "sqrt": (sympy.sqrt, 1), "abs": (sympy.Abs, 1), "sign": (sympy.sign, 1),
    "min": (sympy.Min, 2), "max": (sympy.Max, 2),
}
VECTOR_FUNCTIONS = {"dot": 2, "cross": 2, "norm": 1}
SPECIAL_FORMS = {"der": 1, "sum": 2}
BUILTIN_CALLS = {"momentum", "multiplier", "residual"}
ALL_FUNCTION_NAMES = sorted(set(FUNCTIONS) | set(VECTOR_FUNCTIONS) | set(SPECIAL_FORMS))
MAX_DOUBLE = sympy.Rational(1.7976931348623157e308)
NON_FINITE = (sympy.zoo, sympy.nan, sympy.oo, sympy.S.NegativeInfinity)
FOLDING_NODES = ("mul", "div", "pow", "neg", "add", "sub")   # where exact constants combine and may overflow
MAX_MEMBERS = 10000         # largest index range or indexed family: sizes are unrolled at compile time
MAX_UNROLLED = 100000       # all sums and indexed lets of a model together
MAX_NUMBER_LENGTH = 100     # characters of a number literal (a double keeps 17 significant digits)
MAX_NESTING = 100           # nested calls, powers, products in sums...: see ExpressionBuilder.build
KIND_WORDS = {"parameter": "a parameter", "coordinate": "a coordinate", "let": "a let",
              "output": "an output", "pending output": "an output", "constraint": "a constraint",
              "loop": "an index", "partial": "a let", "invalid": "a name whose declaration failed"}


@dataclass(frozen=True)
class Vector:
    """A 3-vector {x, y, z} of scalar expressions."""

    components: tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Binding:
    """What a name means: `value` is a scalar or Vector; `family` maps indices to values."""

    kind: str                       # parameter, coordinate, let, output, loop, time, constant, constraint
    span: Span | None
    value: object = None
    family: dict | None = None


class Scope:
    """Names visible at a point of the model, with lookups that suggest close matches.

    `observable`, set where outputs are built, gives the value of a built-in observable call
    such as multiplier(rod): observable(name, arguments, span). Elsewhere it is None.
    """

    def __init__(self, bindings: dict[str, Binding] | None = None, observable=None):
        self.bindings: dict[str, Binding] = dict(bindings or {})
        self.observable = observable

    def child(self, **loops: int) -> "Scope":
        scope = type(self)(self.bindings, self.observable)
        for name, value in loops.items():
            scope.bindings[name] = Binding("loop", None, sympy.Integer(value))
        return scope

    def lookup(self, name: str, span: Span) -> Binding:
        if name not in self.bindings:
            raise LagError(f"undefined name '{name}'{suggest(name, self.bindings)}", span)
        return self.bindings[name]


def number_value(text: str, span: Span) -> sympy.Rational:
    """A decimal literal, exactly: 9.81 is 981/100, so no precision is lost before code."""
    if len(text) > MAX_NUMBER_LENGTH:
        raise LagError(f"a number of {len(text)} characters; at most {MAX_NUMBER_LENGTH} are read "
                       "(double precision keeps 17 significant digits)", span)
    mantissa, _, exponent = text.lower().partition("e")
    whole, _, fraction = mantissa.partition(".")
    if exponent and not (whole + fraction).strip("0"):
        return sympy.S.Zero
    if exponent:
        # The decimal exponent of the value, found before 10**exponent is computed exactly.
        magnitude = int(exponent) + (len(whole.lstrip("0")) - 1 if whole.strip("0")
                                     else -(len(fraction) - len(fraction.lstrip("0"))) - 1)
        if magnitude > 308:
            raise LagError(f"the number {text} is not finite in double precision", span)
        if magnitude < -330:
            raise LagError(f"the number {text} is smaller than the smallest double (about 5e-324)", span)
    value = sympy.Rational(Fraction(text))
    if abs(value) > MAX_DOUBLE:
        raise LagError(f"the number {text} is not finite in double precision", span)
    return value


class ExpressionBuilder:
    """Turns expression subtrees into sympy values within a Scope."""

    def __init__(self, source: SourceFile, differentiator: Differentiator,
                 velocities: dict[sympy.Symbol, sympy.Symbol]):
        self.source = source
        self.calculus = differentiator
        self.velocities = velocities          # q -> q'
        self.rates = dict(velocities)
        self.rates[sympy.Symbol("t", real=True)] = sympy.S.One
        self.exact_parameters: dict[sympy.Symbol, sympy.Expr] = {}   # parameter -> exact value
        self.structural: set[sympy.Symbol] = set()                    # parameters used as sizes
        self.unrolled = 0                                             # terms of sums and indexed lets
        self.depth = 0                                                # of the build below
        self.observables: set[sympy.Symbol] = set()                   # multiplier(c) symbols used

    def span(self, node) -> Span:
        if isinstance(node, lark.Token):
            return Span(self.source, node.line, node.column, node.start_pos, node.end_pos)
        meta = node.meta
        return Span(self.source, meta.line, meta.column, meta.start_pos, meta.end_pos)

    # -- entry points ------------------------------------------------------------------------
    def scalar(self, node, scope: Scope, what: str = "a scalar") -> sympy.Expr:
        value = self.build(node, scope)
        if isinstance(value, Vector):
            raise LagError(f"expected {what}, but this is a 3-vector", self.span(node))
        return value

    def integer(self, node, scope: Scope, what: str) -> int:
        """An index or range bound: parameters in it are fixed at compile time (structural)."""
        value = self.scalar(node, scope)
        used = value.free_symbols & self.exact_parameters.keys()
        value = value.xreplace(self.exact_parameters)
        if not value.is_Integer:
            if value.is_number and value.is_real:
                raise LagError(f"{what} must be an integer, not {float(value):g}", self.span(node))
            raise LagError(f"{what} must be an integer known at compile time "
                           "(a literal or a parameter with an integer value)", self.span(node))
        self.structural |= used
        return int(value)

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
        for component in (value.components if isinstance(value, Vector) else (value,)):
            self._require_real_number(component, node)
        return value

    def _require_finite(self, value, node):
        """A function or power of finite arguments may still be infinite: tan(atan2(x, 0)) is zoo*x."""
        for component in (value.components if isinstance(value, Vector) else (value,)):
            if not component.is_number and component.has(*NON_FINITE):
                text = " ".join(self.span(node).text.split())
                raise LagError(f"{text if len(text) <= 40 else 'this expression'} has no finite value",
                               self.span(node))
        return value

    def _require_real_number(self, value, node) -> None:
        self._require_real_constants(value, self.span(node), node.data in FOLDING_NODES)

    def _require_real_constants(self, value, span: Span, folds: bool) -> None:
        """A constant part of an expression must be a finite real double (tan(pi/2) is not, nor
        the factor 1/1e-310 = 1e310 that m/1e-310 folds into: `folds`, where constants combine)."""
        text = " ".join(span.text.split())
        this = text if len(text) <= 40 else "this constant"
        if not value.is_number:
            if folds and any(abs(n) > MAX_DOUBLE for n in value.atoms(sympy.Rational)):
                raise LagError(f"{this} has a constant factor out of the range of double precision", span)
            return
        if value.has(*NON_FINITE):
            raise LagError(f"{this} has no finite value", span)
        if value.is_real is False:
            raise LagError(f"{this} is not a real number", span)
        if value.is_Rational and abs(value) > MAX_DOUBLE:
            raise LagError(f"{this} is not finite in double precision", span)

    def _number(self, node, scope):
        return number_value(str(node.children[0]), self.span(node))

    def _name(self, node, scope):
        token = node.children[0]
        name = str(token)
        if name == "pi":
            return sympy.pi
        if name == "t":
            return sympy.Symbol("t", real=True)
        if name not in scope.bindings:
            if name in ALL_FUNCTION_NAMES or name in BUILTIN_CALLS:
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
        return binding.value

    def _index(self, node, scope):
        token, _, index_node, _ = node.children
        if str(token) in ("t", "pi") and str(token) not in scope.bindings:
            raise LagError(f"'{token}' is not indexed", self.span(token))
        binding = scope.lookup(str(token), self.span(token))
        if binding.family is None:
            raise LagError(f"'{token}' is not indexed", self.span(token))
        index = self.integer(index_node, scope, "an index")
        if binding.kind == "partial" and index not in binding.family:
            raise LagError(f"'{token}[{index}]' is used before it is defined; a member of an indexed let "
                           "may only use earlier members", self.span(node))
        if index not in binding.family:
            members = f"{min(binding.family)}:{max(binding.family)}" if binding.family else "it has no members"
            raise LagError(f"index {index} is out of range for '{token}' ({members})", self.span(index_node))
        return binding.family[index]

    def _braces(self, node, scope):
        items = [self.scalar(child, scope, "a scalar component") for child in node.children
                 if not isinstance(child, lark.Token)]
        if len(items) != 3:
            raise LagError(f"a vector has 3 components, not {len(items)}", self.span(node))
        return Vector(tuple(items))

    # Sums and products are walked iteratively, not by recursion: the grammar makes `a + b + c`
    # a left-deep tree, so a 330-term sum (or 500 nested parentheses, or 500 unary minuses)
    # would otherwise be as deep as it is long and exhaust Python's recursion limit.
    def _parenthesized(self, node, scope):
        return self._signed_sum(node, scope)

    _pos = _neg = _add = _sub = _parenthesized

    def _signed_sum(self, node, scope):
        """A sum of terms with signs: through +, -, unary signs and parentheses, left to right."""
        values = [(sign, self.build(term, scope)) for sign, term in _signed_terms(node)]
        if len({isinstance(value, Vector) for _, value in values}) > 1:
            raise LagError("cannot add a vector and a scalar", self.span(node))
        if isinstance(values[0][1], Vector):
            return Vector(tuple(sympy.Add(*(sign * v.components[k] for sign, v in values)) for k in range(3)))
        return sympy.Add(*(sign * value for sign, value in values))

    def _mul(self, node, scope):
        """A product chain a*b/c*d: at most one factor a vector, no divisor a vector or zero."""
        numerators, denominators, partial = [], [], sympy.S.One
        for factor, divides in _factors(node):
            if divides:
                divisor = self.scalar(factor, scope, "a scalar divisor")
                if divisor == 0:
                    raise LagError("division by zero", self.span(factor))
                denominators.append(divisor)
                partial /= divisor
            else:
                numerators.append(self.build(factor, scope))
                partial *= numerators[-1] if not isinstance(numerators[-1], Vector) else 1
            # The constants folded so far, reported where they overflow (the tree would: a*b/c is (a*b)/c).
            self._require_real_constants(partial, self._through(node, factor), True)
        vectors = [value for value in numerators if isinstance(value, Vector)]
        if len(vectors) > 1:
            raise LagError("the product of two vectors is ambiguous; use dot(a, b) or cross(a, b)",
                           self.span(node))
        scalars = [value for value in numerators if not isinstance(value, Vector)]
        scale = sympy.Mul(*scalars) / sympy.Mul(*denominators)
        return _map(vectors[0], lambda c: c * scale) if vectors else scale

    _div = _mul

    def _through(self, node, last) -> Span:
        """The span from the start of `node` to the end of `last`, a part of it."""
        start, end = self.span(node), self.span(last)
        return Span(self.source, start.line, start.column, start.start, end.end)

    def _pow(self, node, scope):
        left, _, right = node.children
        base = self.scalar(left, scope, "a scalar base")
        exponent = self.scalar(right, scope, "a scalar exponent")
        if base == 0 and exponent.is_number and exponent.is_negative:
            raise LagError("division by zero", self.span(node))
        if base.is_Rational and exponent.is_Rational and abs(base) not in (0, 1) and abs(exponent) > 1:
            # Rational powers are computed exactly: check their size first (2^(10^9) is not a double).
            p, q = abs(base.p), base.q
            bits = abs(float(exponent)) * abs(math.log2(p) - math.log2(q))
            work = abs(float(exponent)) * max(math.log2(p), math.log2(q))
            if bits > 1100 or work > 100000:
                raise LagError(f"{base}^{exponent} is out of the range of double precision", self.span(node))
        return self._require_finite(base ** exponent, node)

    def _call(self, node, scope):
        token = node.children[0]
        name = str(token)
        arguments = next(([a for a in c.children if isinstance(a, lark.Tree)]
                          for c in node.children if isinstance(c, lark.Tree) and c.data == "arguments"), [])
        span = self.span(node)
        if name in BUILTIN_CALLS:
            if scope.observable is None:
                raise LagError(f"{name}(...) is a built-in observable: outputs may use it (an output "
                               "declaration or a scene's output list), the model's equations may not", span)
            value = scope.observable(name, arguments, span)
            self.observables.add(value)
            return value
        expected = {**{k: v[1] for k, v in FUNCTIONS.items()}, **VECTOR_FUNCTIONS,
                    **SPECIAL_FORMS}.get(name)
        if expected is None:
            if name in scope.bindings:
                binding = scope.lookup(name, self.span(token))   # a failed declaration is reported there
                raise LagError(f"'{name}' is {KIND_WORDS.get(binding.kind, 'a name')}, not a function",
                               self.span(token))
            if name in ("t", "pi"):
                raise LagError(f"'{name}' is {'the time' if name == 't' else 'a constant'}, not a function",
                               self.span(token))
            raise LagError(f"unknown function '{name}'{suggest(name, ALL_FUNCTION_NAMES)}",
                           self.span(token))
        if len(arguments) != expected:
            plural = "s" if expected != 1 else ""
            raise LagError(f"{name}() takes {expected} argument{plural}, got {len(arguments)}", span)
        if name == "sum":
            return self._sum(arguments, scope, span)
        for argument in arguments:
            if isinstance(argument, lark.Tree) and argument.data == "iteration":
                raise LagError("an 'i in a:b' range is only allowed as the second argument of sum()",
                               self.span(argument))
        if name == "der":
            return self._der(arguments[0], scope)
        values = [self.build(a, scope) for a in arguments]
        if name in VECTOR_FUNCTIONS:
            return self._vector_function(name, values, arguments)
        for value, argument in zip(values, arguments):
            if isinstance(value, Vector):
                raise LagError(f"{name}() takes scalars, but this is a 3-vector", self.span(argument))
        return self._require_finite(FUNCTIONS[name][0](*values), node)

    def _vector_function(self, name, values, arguments):
        for value, argument in zip(values, arguments):
            if not isinstance(value, Vector):
                raise LagError(f"{name}() takes 3-vectors, but this is a scalar", self.span(argument))
        if name == "norm":
            return sympy.sqrt(sum(c**2 for c in values[0].components))
        a, b = values[0].components, values[1].components
        if name == "dot":
            return sum(x * y for x, y in zip(a, b))
        return Vector((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))

    def _der(self, argument, scope):
        value = self.build(argument, scope)
        for component in (value.components if isinstance(value, Vector) else (value,)):
            if component.free_symbols & self.observables:
                raise LagError("der() of a Lagrange multiplier: its rate is not computed", self.span(argument))
            if self.calculus.dependencies(component) & set(self.velocities.values()):
                raise LagError("der() of an expression that depends on velocities would need accelerations; "
                               "L, T, U and constraints are functions of q, q' and t", self.span(argument))
        return _map(value, lambda c: self.calculus.directional(c, TIME_DIRECTION, self.rates))

    def _sum(self, arguments, scope, span):
        body, iteration = arguments
        if not (isinstance(iteration, lark.Tree) and iteration.data == "iteration"):
            raise LagError("the second argument of sum() is a range: sum(expr, i in 1:n)",
                           self.span(iteration) if isinstance(iteration, lark.Tree) else span)
        variable, low, high = self.iteration(iteration, scope)
        total = None
        for index in range(low, high + 1):
            term = self.build(body, scope.child(**{variable: index}))
            total = term if total is None else self._sum_terms(total, term, span)
        return total if total is not None else sympy.S.Zero

    def iteration(self, node, scope) -> tuple[str, int, int]:
        """`i in a:b` -> ("i", a, b)."""
        name_token, _, range_node = node.children
        low_node, _, high_node = range_node.children
        if str(name_token) in scope.bindings and scope.bindings[str(name_token)].kind != "loop":
            raise LagError(f"the index '{name_token}' hides the declared name '{name_token}'",
                           self.span(name_token))
        low = self.integer(low_node, scope, "a range bound")
        high = self.integer(high_node, scope, "a range bound")
        if high - low + 1 > MAX_MEMBERS:
            raise LagError(f"the range {low}:{high} has {high - low + 1} members; at most {MAX_MEMBERS} "
                           "are unrolled", self.span(range_node))
        self.unrolled += max(0, high - low + 1)
        if self.unrolled > MAX_UNROLLED:
            error = LagError(f"the sums and indexed lets of the model unroll to more than {MAX_UNROLLED} terms, "
                             "too many to derive symbolically", self.span(range_node))
            if self.unrolled - (high - low + 1) > MAX_UNROLLED:
                error.diagnostics = ()          # reported once, where the budget ran out
            raise error
        return str(name_token), low, high

    def _sum_terms(self, a, b, span):
        if isinstance(a, Vector) != isinstance(b, Vector):
            raise LagError("sum() terms mix vectors and scalars", span)
        if isinstance(a, Vector):
            return Vector(tuple(x + y for x, y in zip(a.components, b.components)))
        return a + b

    def _iteration(self, node, scope):
        raise LagError("an 'i in a:b' range is only allowed as the second argument of sum()",
                       self.span(node))


def _signed_terms(node) -> list[tuple[int, lark.Tree]]:
    """The terms of a sum, in source order, each with its sign (+1 or -1)."""
    terms, pending = [], [(1, node)]
    while pending:
        sign, node = pending.pop()
        kind = node.data if isinstance(node, lark.Tree) else None
        if kind in ("add", "sub"):
            left, _, right = node.children
            pending.append((sign if kind == "add" else -sign, right))
            pending.append((sign, left))
        elif kind in ("pos", "neg", "parenthesized"):
            pending.append((-sign if kind == "neg" else sign, node.children[1]))
        else:
            terms.append((sign, node))
    return terms


def _factors(node) -> list[tuple[lark.Tree, bool]]:
    """The factors of a product chain a*b/c in source order, each with `divides` (it is a divisor).

    Only the chain itself is flattened, not parentheses: in a/(b/c) the c divides b, and a
    division by zero there must still be reported.
    """
    factors = []
    while node.data in ("mul", "div"):
        left, _, right = node.children
        factors.append((right, node.data == "div"))
        node = left
    factors.append((node, False))
    return factors[::-1]


def _map(value, function):
    if isinstance(value, Vector):
        return Vector(tuple(function(c) for c in value.components))
    return function(value)
