"""The Taylor-coefficient recurrences of the elementary operations: one table, read by the C
emitter (c_taylor.py) and by the exact evaluator below (the tests check it against sympy).

A Taylor integrator needs the coefficients u_k of u(t) = Σ_k u_k (t - t0)^k for every
intermediate of the equations, order by order. Each elementary operation u = φ(a, b, ...)
gets them from its operands' by a recurrence that follows from an ODE u satisfies
(automatic differentiation, Moore 1966; the forms of Jorba and Zou, Experimental Math. 14
(2005) 99-117, section 3):

    u = a b          u_k = Σ_{j=0..k} a_j b_{k-j}                          (Cauchy product)
    u = a / b        b u = a:        u_k = (a_k - Σ_{j=1..k} b_j u_{k-j}) / b_0
    u = a^α          a u' = α a' u:  u_k = Σ_{j=0..k-1} (α (k-j) - j) a_{k-j} u_j / (k a_0)
    u = exp(a)       u' = a' u:      u_k = Σ_{j=1..k} j a_j u_{k-j} / k
    u = sin a, c = cos a             u_k = Σ j a_j c_{k-j} / k,  c_k = -Σ j a_j u_{k-j} / k

and so on for every function the language has (the table RECURRENCES). Written with the
coefficient of the derivative, (u')_m = (m+1) u_{m+1}, each is a sum of terms, each term either
weight(k) · x_k or a convolution Σ_j weight(j, k) x_j y_{k-j}, divided by a divisor that holds
the operands' zeroth coefficients: exactly what `Recurrence` records.

Some operations carry a companion series: tan a and tanh a need w = u² (u' = (1 ± w) a'), atan
needs d = 1 + a², asin and acos need w = sqrt(1 - a²), atan2(y, x) needs d = x² + y²; sin and
cos (sinh and cosh) are each the other's companion. The graph builder (taylor_graph.py) makes
the companion a node of its own; a companion computed after u at the same order (`lagging`)
is read only at orders below k.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import sympy

J, K = sympy.symbols("j k", integer=True)
ALPHA = sympy.Symbol("alpha", real=True)
OWN = "u"                       # a recurrence's name for the series it computes


def zeroth(operand: str) -> sympy.Symbol:
    """The symbol of an operand's coefficient of order 0 (a0, b0, u0) in values and weights."""
    return sympy.Symbol(f"{operand}0", real=True)


@dataclass(frozen=True)
class Coefficient:
    """weight(k) · x_k."""

    operand: str
    weight: sympy.Expr = sympy.S.One


@dataclass(frozen=True)
class Convolution:
    """Σ_{j = first .. k - gap} weight(j, k) · left_j · right_{k-j}."""

    left: str
    right: str
    weight: sympy.Expr = sympy.S.One
    first: int = 0
    gap: int = 0


@dataclass(frozen=True)
class Recurrence:
    """How u = φ(operands) gets its coefficients: u_0 = value, and for k >= 1
    u_k = (Σ sign · term) / divisor, in the operands' coefficients and their zeroth values."""

    name: str
    operands: tuple[str, ...]
    value: sympy.Expr                                         # u_0, in the operands' zeroth symbols
    terms: tuple[tuple[int, Coefficient | Convolution], ...]
    divisor: sympy.Expr = sympy.S.One
    lagging: tuple[str, ...] = ()          # companions computed after u: read below order k only
    parameters: tuple[str, ...] = ()       # constants of the instance (the exponent alpha)
    ode: str = ""                          # the equation the recurrence comes from

    def split_divisor(self) -> tuple[int, sympy.Expr]:
        """divisor = k^e · D0: (e, D0), D0 in the zeroth coefficients (or a number)."""
        rest, power = self.divisor.as_independent(K, as_Add=False)
        return (0 if power == 1 else int(sympy.degree(power, K))), rest

    @property
    def cost(self) -> float:
        """The products per order, in Cauchy products of the same length: one per convolution,
        half for one over a symmetric range (each pair of a square once)."""
        return sum(0.5 if term.left == term.right else 1.0
                   for _, term in self.terms if isinstance(term, Convolution))

    def highest_read(self, operand: str) -> int:
        """The highest order of `operand` the terms read, as an offset from k (0: order k itself)."""
        highest = -10**9
        for _, term in self.terms:
            if isinstance(term, Coefficient) and term.operand == operand:
                highest = max(highest, 0)
            elif isinstance(term, Convolution) and operand in (term.left, term.right):
                if operand == term.left:
                    highest = max(highest, -term.gap)
                if operand == term.right:
                    highest = max(highest, -term.first)
        return highest


a0, b0, u0, d0, w0, x0, y0 = (zeroth(name) for name in ("a", "b", "u", "d", "w", "x", "y"))
_LESS = sympy.Piecewise((1, a0 <= b0), (0, True))    # min and max follow the smaller operand at order 0

RECURRENCES: dict[str, Recurrence] = {r.name: r for r in (
    Recurrence("mul", ("a", "b"), a0 * b0, ((1, Convolution("a", "b")),), ode="u = a b"),
    Recurrence("sq", ("a",), a0**2, ((1, Convolution("a", "a")),), ode="u = a^2"),
    Recurrence("div", ("a", "b"), a0 / b0, ((1, Coefficient("a")), (-1, Convolution("b", OWN, first=1))), b0,
               ode="b u = a"),
    Recurrence("inv", ("b",), 1 / b0, ((-1, Convolution("b", OWN, first=1)),), b0, ode="b u = 1"),
    Recurrence("pow", ("a",), a0**ALPHA, ((1, Convolution(OWN, "a", ALPHA * K - (ALPHA + 1) * J, gap=1)),),
               K * a0, parameters=("alpha",), ode="a u' = alpha a' u"),
    Recurrence("sqrt", ("a",), sympy.sqrt(a0), ((1, Coefficient("a")), (-1, Convolution(OWN, OWN, first=1, gap=1))),
               2 * u0, ode="u^2 = a"),
    Recurrence("exp", ("a",), sympy.exp(a0), ((1, Convolution("a", OWN, J, first=1)),), K, ode="u' = a' u"),
    Recurrence("log", ("a",), sympy.log(a0), ((1, Coefficient("a", K)), (-1, Convolution(OWN, "a", J, first=1, gap=1))),
               K * a0, ode="a u' = a'"),
    Recurrence("sin", ("a", "c"), sympy.sin(a0), ((1, Convolution("a", "c", J, first=1)),), K, lagging=("c",),
               ode="u' = a' cos a"),
    Recurrence("cos", ("a", "s"), sympy.cos(a0), ((-1, Convolution("a", "s", J, first=1)),), K, lagging=("s",),
               ode="u' = -a' sin a"),
    Recurrence("sinh", ("a", "c"), sympy.sinh(a0), ((1, Convolution("a", "c", J, first=1)),), K, lagging=("c",),
               ode="u' = a' cosh a"),
    Recurrence("cosh", ("a", "s"), sympy.cosh(a0), ((1, Convolution("a", "s", J, first=1)),), K, lagging=("s",),
               ode="u' = a' sinh a"),
    Recurrence("tan", ("a", "w"), sympy.tan(a0), ((1, Coefficient("a", K)), (1, Convolution("a", "w", J, first=1))),
               K, lagging=("w",), ode="u' = (1 + w) a', w = u^2"),
    Recurrence("tanh", ("a", "w"), sympy.tanh(a0), ((1, Coefficient("a", K)), (-1, Convolution("a", "w", J, first=1))),
               K, lagging=("w",), ode="u' = (1 - w) a', w = u^2"),
    Recurrence("atan", ("a", "d"), sympy.atan(a0),
               ((1, Coefficient("a", K)), (-1, Convolution("d", OWN, K - J, first=1, gap=1))), K * d0,
               ode="d u' = a', d = 1 + a^2"),
    Recurrence("asin", ("a", "w"), sympy.asin(a0),
               ((1, Coefficient("a", K)), (-1, Convolution("w", OWN, K - J, first=1, gap=1))), K * w0,
               ode="w u' = a', w = sqrt(1 - a^2)"),
    Recurrence("acos", ("a", "w"), sympy.acos(a0),
               ((-1, Coefficient("a", K)), (-1, Convolution("w", OWN, K - J, first=1, gap=1))), K * w0,
               ode="w u' = -a', w = sqrt(1 - a^2)"),
    Recurrence("atan2", ("y", "x", "d"), sympy.atan2(y0, x0),
               ((1, Convolution("x", "y", K - J, gap=1)), (-1, Convolution("y", "x", K - J, gap=1)),
                (-1, Convolution("d", OWN, K - J, first=1, gap=1))), K * d0,
               ode="d u' = x y' - y x', d = x^2 + y^2"),
    Recurrence("abs", ("a",), sympy.Abs(a0), ((1, Coefficient("a", sympy.sign(a0))),),
               ode="u = sign(a_0) a while a keeps its sign"),
    Recurrence("min", ("a", "b"), sympy.Min(a0, b0), ((1, Coefficient("a", _LESS)), (1, Coefficient("b", 1 - _LESS))),
               ode="u = a or b, whichever is smaller at order 0"),
    Recurrence("max", ("a", "b"), sympy.Max(a0, b0), ((1, Coefficient("a", 1 - _LESS)), (1, Coefficient("b", _LESS))),
               ode="u = a or b, whichever is larger at order 0"),
    # Piecewise constant: their value holds over a step (it changes only where an operand
    # crosses zero, as for any method that steps over a discontinuity).
    Recurrence("sign", ("a",), sympy.sign(a0), (), ode="u' = 0"),
    Recurrence("heaviside", ("a",), sympy.Heaviside(a0), (), ode="u' = 0"),
    Recurrence("diracdelta", ("a",), sympy.DiracDelta(a0), (), ode="u' = 0"),
)}


def coefficient(recurrence: Recurrence, series: Mapping[str, Sequence], k: int,
                parameters: Mapping[str, object] = {}) -> object:
    """u_k from the operands' coefficients (`series[name]`, with series["u"] holding u_0 ..
    u_{k-1}), in whatever arithmetic they carry: sympy Rationals for the exact checks."""
    symbols = {zeroth(name): values[0] for name, values in series.items() if len(values)}
    symbols.update({sympy.Symbol(name, real=True): value for name, value in parameters.items()})
    if k == 0:
        return recurrence.value.xreplace(symbols)
    total = sympy.S.Zero
    for sign, term in recurrence.terms:
        if isinstance(term, Coefficient):
            total += sign * term.weight.xreplace({**symbols, K: k}) * series[term.operand][k]
            continue
        weight = term.weight.xreplace({**symbols, K: k})
        total += sign * sum((weight.xreplace({J: j}) * series[term.left][j] * series[term.right][k - j]
                             for j in range(term.first, k - term.gap + 1)), sympy.S.Zero)
    return total / recurrence.divisor.xreplace({**symbols, K: k})
