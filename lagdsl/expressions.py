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
# Matrices, rotations and rigid bodies (docs/language.md, "Rigid bodies"): name -> arity.
MATRIX_FUNCTIONS = {"rotx": 1, "roty": 1, "rotz": 1, "diag": 3, "transpose": 1, "euler_zxz": 3,
                    "euler_zyx": 3, "omega_body": 1, "omega_zxz": 3, "omega_zyx": 3}
SPECIAL_FORMS = {"der": 1, "sum": 2}
BUILTIN_CALLS = {"momentum", "multiplier", "residual"}
ALL_FUNCTION_NAMES = sorted(set(FUNCTIONS) | set(VECTOR_FUNCTIONS) | set(MATRIX_FUNCTIONS) | set(SPECIAL_FORMS))
AXES = ("x", "y", "z")
MAX_DOUBLE = sympy.Rational(1.7976931348623157e308)
NON_FINITE = (sympy.zoo, sympy.nan, sympy.oo, sympy.S.NegativeInfinity)
FOLDING_NODES = ("mul", "div", "pow", "neg", "add", "sub")   # where exact constants combine and may overflow
MAX_MEMBERS = 10000         # largest index range or indexed family: sizes are unrolled at compile time
MAX_UNROLLED = 100000       # all sums and indexed lets of a model together
MAX_NUMBER_LENGTH = 100     # characters of a number literal (a double keeps 17 significant digits)
MAX_NESTING = 100           # nested calls, powers, products in sums...: see ExpressionBuilder.build
HUGE_EXPONENT = 64          # a power of a parameter beyond this gets float values (with_parameter_values)
KIND_WORDS = {"parameter": "a parameter", "coordinate": "a coordinate", "let": "a let",
              "output": "an output", "pending output": "an output", "constraint": "a constraint",
              "loop": "an index", "partial": "a let", "invalid": "a name whose declaration failed"}


@dataclass(frozen=True)
class Vector:
    """A 3-vector {x, y, z} of scalar expressions."""

    components: tuple[sympy.Expr, sympy.Expr, sympy.Expr]


@dataclass(frozen=True)
class Matrix:
    """A 3x3 matrix of scalar expressions, row by row (a rotation matrix, an inertia tensor)."""

    rows: tuple[tuple[sympy.Expr, ...], ...]

    @property
    def components(self) -> tuple[sympy.Expr, ...]:
        return tuple(entry for row in self.rows for entry in row)

    def column(self, j: int) -> tuple[sympy.Expr, ...]:
        return tuple(row[j] for row in self.rows)


def is_array(value) -> bool:
    """A 3-vector or a 3x3 matrix, not a scalar."""
    return isinstance(value, (Vector, Matrix))


def kind_of(value) -> str:
    return "a 3-vector" if isinstance(value, Vector) else "a 3x3 matrix" if isinstance(value, Matrix) else "a scalar"


@dataclass(frozen=True)
class Binding:
    """What a name means: `value` is a scalar, Vector or Matrix; `family` maps indices to values."""

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
        self._velocities_seen: frozenset = frozenset()
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
        if is_array(value):
            raise LagError(f"expected {what}, but this is {kind_of(value)}", self.span(node))
        return value

    def with_parameter_values(self, value: sympy.Expr) -> sympy.Expr:
        """`value` with the parameters' exact values put in. A power of a parameter with a large
        exponent (l^1e300) would be computed exactly, digit by digit, for hours: there the values
        go in as 30-digit floats, whose powers cost nothing (and overflow or underflow plainly)."""
        huge = any(p.exp.is_number and abs(p.exp) > HUGE_EXPONENT and p.base.free_symbols
                   for p in value.atoms(sympy.Pow))
        if not huge:
            return value.xreplace(self.exact_parameters)
        return value.xreplace({s: sympy.Float(v.evalf(30), 30) for s, v in self.exact_parameters.items()})

    def integer(self, node, scope: Scope, what: str) -> int:
        """An index or range bound: parameters in it are fixed at compile time (structural)."""
        value = self.scalar(node, scope)
        used = value.free_symbols & self.exact_parameters.keys()
        value = self.with_parameter_values(value)
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
        for component in (value.components if is_array(value) else (value,)):
            self._require_real_number(component, node)
        return value

    def _require_finite(self, value, node):
        """A function or power of finite arguments may still be infinite: tan(atan2(x, 0)) is zoo*x."""
        for component in (value.components if is_array(value) else (value,)):
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
        if not value.is_Rational and _magnitude(value) > MAX_DOUBLE:
            # exp(1000) is exact to sympy; checked here, node by node, no constant beyond a double
            # ever reaches a power, where 2^2^exp(1000) would make evalf's precision explode
            raise LagError(f"{this} is out of the range of double precision", span)

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
        if binding.family is None and isinstance(binding.value, Vector):
            return self._component_at(binding.value, self.integer(index_node, scope, "an index"), index_node)
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

    def _component_at(self, vector: Vector, index: int, index_node):
        """v[1], v[2], v[3]: the components x, y, z (1-based, like every index of the language)."""
        if index not in (1, 2, 3):
            raise LagError(f"index {index} is out of range for a 3-vector (1:3)", self.span(index_node))
        return vector.components[index - 1]

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
        if all(isinstance(item, Vector) for item in items):
            return Matrix(tuple(item.components for item in items))
        for item, child in zip(items, children):
            if is_array(item):
                raise LagError(f"expected a scalar component, but this is {kind_of(item)} (a matrix is "
                               "written {{a, b, c}, {d, e, f}, {g, h, i}}, row by row)", self.span(child))
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
        kinds = {kind_of(value) for _, value in values}
        if len(kinds) > 1:
            words = {"a 3-vector": "a vector", "a 3x3 matrix": "a matrix", "a scalar": "a scalar"}
            raise LagError("cannot add " + " and ".join(words[kind] for kind in sorted(kinds)), self.span(node))
        first = values[0][1]
        if is_array(first):
            total = [sympy.Add(*(sign * v.components[k] for sign, v in values)) for k in range(len(first.components))]
            return Vector(tuple(total)) if isinstance(first, Vector) else _matrix_of(total)
        return sympy.Add(*(sign * value for sign, value in values))

    def _mul(self, node, scope):
        """A product chain a*b/c*d of scalars, 3-vectors and 3x3 matrices, no divisor an array or zero.

        Scalars scale; the arrays multiply left to right as in linear algebra (A*B, A*v), and
        at most one vector, the last array of the chain: u*v is dot or cross, v*A needs transpose.
        """
        array, scalars, denominators, partial = None, [], [], sympy.S.One
        for factor, divides in _factors(node):
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
            self._require_real_constants(partial, self._through(node, factor), True)
        scale = sympy.Mul(*scalars) / sympy.Mul(*denominators)
        return _map(array, lambda c: c * scale) if array is not None else scale

    def _array_product(self, left, right, node):
        if isinstance(left, Vector) and isinstance(right, Vector):
            raise LagError("the product of two vectors is ambiguous; use dot(a, b) or cross(a, b)",
                           self.span(node))
        if isinstance(left, Vector):
            raise LagError("a vector times a matrix is not defined; write transpose(A)*v", self.span(node))
        if isinstance(right, Vector):
            return Vector(tuple(_dot(row, right.components) for row in left.rows))
        return Matrix(tuple(tuple(_dot(row, right.column(j)) for j in range(3)) for row in left.rows))

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
        # Rational powers are computed exactly: check their size first (2^(10^9) is not a double).
        # sympy also raises the rational factor of a product to an integer power ((x/2)^n is
        # x^n/2^n), so the factor is checked too.
        coefficient = base if base.is_Rational else base.as_coeff_Mul()[0]
        if coefficient.is_Rational and exponent.is_Rational and abs(coefficient) not in (0, 1) and abs(exponent) > 1:
            p, q = abs(coefficient.p), coefficient.q
            bits = abs(float(exponent)) * abs(math.log2(p) - math.log2(q))
            work = abs(float(exponent)) * max(math.log2(p), math.log2(q))
            if bits > 1100 or work > 100000:
                power = f"^{float(exponent):.6g}"
                what = f"{base}{power}" if base.is_Rational else \
                    f"the power {power} of an expression with the factor {coefficient}"
                raise LagError(f"{what} is out of the range of double precision", self.span(node))
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
        expected = {**{k: v[1] for k, v in FUNCTIONS.items()}, **VECTOR_FUNCTIONS, **MATRIX_FUNCTIONS,
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
        if name in ("transpose", "omega_body"):
            return self._matrix_function(name, values[0], arguments[0])
        for value, argument in zip(values, arguments):
            if is_array(value):
                raise LagError(f"{name}() takes scalars, but this is {kind_of(value)}", self.span(argument))
        if name in MATRIX_FUNCTIONS:
            return self._rotation_function(name, values, arguments)
        return self._require_finite(FUNCTIONS[name][0](*values), node)

    def _matrix_function(self, name, value, argument):
        """transpose(A); omega_body(R), the angular velocity in the body frame of the rotation R
        (body to space): the axial vector of the skew matrix R^T R'."""
        if not isinstance(value, Matrix):
            raise LagError(f"{name}() takes a 3x3 matrix, but this is {kind_of(value)}", self.span(argument))
        if name == "transpose":
            return Matrix(tuple(value.column(j) for j in range(3)))
        rate = self._rate(value, argument)
        skew = [[_dot(value.column(i), rate.column(j)) for j in range(3)] for i in range(3)]
        return Vector((skew[2][1], skew[0][2], skew[1][0]))

    def _rotation_function(self, name, values, arguments):
        """Rotation matrices (active, body to space), inertia tensors, Euler-angle rates: see
        rotation() and body_rates()."""
        if name == "diag":
            return Matrix(tuple(tuple(values[i] if i == j else sympy.S.Zero for j in range(3)) for i in range(3)))
        if name.startswith("omega_"):
            rates = [self._rate(value, argument) for value, argument in zip(values, arguments)]
            return body_rates(name[len("omega_"):], values, rates)
        if name.startswith("euler_"):
            first, second, third = (rotation(axis, angle) for axis, angle in zip(name[-3:], values))
            return self._array_product(self._array_product(first, second, None), third, None)
        return rotation(name[-1], values[0])

    def _vector_function(self, name, values, arguments):
        for value, argument in zip(values, arguments):
            if not isinstance(value, Vector):
                raise LagError(f"{name}() takes 3-vectors, but this is {kind_of(value)}", self.span(argument))
        if name == "norm":
            return sympy.sqrt(sum(c**2 for c in values[0].components))
        a, b = values[0].components, values[1].components
        if name == "dot":
            return sum(x * y for x, y in zip(a, b))
        return Vector((a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]))

    def _der(self, argument, scope):
        return self._rate(self.build(argument, scope), argument)

    def _velocity_symbols(self) -> frozenset:
        """The velocities declared so far, kept between calls: der() of each member of a long
        family would otherwise build the set anew, n² in all."""
        if len(self._velocities_seen) != len(self.velocities):
            self._velocities_seen = frozenset(self.velocities.values())
        return self._velocities_seen

    def _rate(self, value, argument):
        """The time derivative of a value of (q, t), componentwise for vectors and matrices."""
        for component in (value.components if is_array(value) else (value,)):
            if component.free_symbols & self.observables:
                raise LagError("der() of a Lagrange multiplier: its rate is not computed", self.span(argument))
            if self.calculus.dependencies(component) & self._velocity_symbols():
                raise LagError("der() of an expression that depends on velocities would need accelerations; "
                               "L, T, U and constraints are functions of q, q' and t", self.span(argument))
        return _map(value, lambda c: self.calculus.directional(c, TIME_DIRECTION, self.rates))

    def _sum(self, arguments, scope, span):
        body, iteration = arguments
        if not (isinstance(iteration, lark.Tree) and iteration.data == "iteration"):
            raise LagError("the second argument of sum() is a range: sum(expr, i in 1:n)",
                           self.span(iteration) if isinstance(iteration, lark.Tree) else span)
        variable, low, high = self.iteration(iteration, scope)
        terms = [self.build(body, scope.child(**{variable: index})) for index in range(low, high + 1)]
        return self._sum_terms(terms, span) if terms else sympy.S.Zero

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

    def _sum_terms(self, terms, span):
        """The terms added at once: sympy sorts an Add's arguments whenever it is built, so adding
        them one by one would cost n² in the number of terms."""
        first = terms[0]
        for term in terms[1:]:
            if kind_of(term) != kind_of(first):
                raise LagError(f"sum() terms mix {kind_of(first)[2:]}s and {kind_of(term)[2:]}s", span)
        if is_array(first):
            total = [sympy.Add(*parts) for parts in zip(*(term.components for term in terms))]
            return Vector(tuple(total)) if isinstance(first, Vector) else _matrix_of(total)
        return sympy.Add(*terms)

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
    if isinstance(value, Matrix):
        return _matrix_of([function(c) for c in value.components])
    return function(value)


def _matrix_of(entries) -> Matrix:
    """The 3x3 matrix of nine entries, row by row."""
    return Matrix(tuple(tuple(entries[3 * i:3 * i + 3]) for i in range(3)))


def _dot(a, b) -> sympy.Expr:
    return sympy.Add(*(x * y for x, y in zip(a, b)))


def rotation(axis: str, angle) -> Matrix:
    """The active rotation by `angle` about the x, y or z axis (right-handed): rotz(a)*{1, 0, 0}
    is {cos(a), sin(a), 0}. As the orientation of a body, it maps body to space components."""
    c, s = sympy.cos(angle), sympy.sin(angle)
    i = AXES.index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3
    entries = [[sympy.S.Zero] * 3 for _ in range(3)]
    entries[i][i] = sympy.S.One
    entries[j][j], entries[j][k], entries[k][j], entries[k][k] = c, -s, s, c
    return Matrix(tuple(tuple(row) for row in entries))


def body_rates(convention: str, angles, rates) -> Vector:
    """The angular velocity in body axes of R = euler_<convention>(angles), in closed form.

    zxz (Goldstein's x-convention, R = rotz(phi) rotx(theta) rotz(psi)):
        w1 = phi' sin(theta) sin(psi) + theta' cos(psi)
        w2 = phi' sin(theta) cos(psi) - theta' sin(psi)
        w3 = phi' cos(theta) + psi'
    zyx (yaw psi, pitch theta, roll phi, R = rotz(psi) roty(theta) rotx(phi)):
        w1 = phi' - psi' sin(theta)
        w2 = theta' cos(phi) + psi' cos(theta) sin(phi)
        w3 = psi' cos(theta) cos(phi) - theta' sin(phi)
    """
    sin, cos = sympy.sin, sympy.cos
    if convention == "zxz":
        (phi, theta, psi), (dphi, dtheta, dpsi) = angles, rates
        return Vector((dphi * sin(theta) * sin(psi) + dtheta * cos(psi),
                       dphi * sin(theta) * cos(psi) - dtheta * sin(psi),
                       dphi * cos(theta) + dpsi))
    (psi, theta, phi), (dpsi, dtheta, dphi) = angles, rates
    return Vector((dphi - dpsi * sin(theta),
                   dtheta * cos(phi) + dpsi * cos(theta) * sin(phi),
                   dpsi * cos(theta) * cos(phi) - dtheta * sin(phi)))


def _magnitude(number: sympy.Expr) -> sympy.Expr:
    """|number| to 17 digits; infinite when sympy cannot evaluate it (its working precision
    overflows on a value far beyond any float)."""
    try:
        return abs(number.evalf(17))
    except (OverflowError, ValueError, ZeroDivisionError, RecursionError):
        return sympy.oo
