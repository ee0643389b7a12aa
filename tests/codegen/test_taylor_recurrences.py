"""The Taylor recurrences of codegen/taylor.py, through the graph builder of taylor_graph.py,
against sympy's expansion of each elementary function, to order 30.

Exact: the argument a(t) = a0 + t/3 - t^2/5 + t^3/7 has rational coefficients, and a0 is
chosen where the function's derivatives are rational (sin, exp, tan at 0, log at 1, sqrt at
9/4, asin at 3/5, ...): every coefficient beyond order 0 is then an exact rational, compared
with ==, and order 0 (atan(1/2), say) symbolically. At a0 = 7/10, where the coefficients hold
sin(7/10) and the like, they are compared to 50 digits.

The expansion: f(a0 + δ) = Σ_m f^(m)(a0)/m! δ^m, the derivatives by sympy, composed with
δ(t) = a(t) - a0 in exact truncated power-series arithmetic.
"""
from __future__ import annotations

import pytest
import sympy

from lagdsl.codegen.taylor import OWN, RECURRENCES, Coefficient, coefficient
from lagdsl.codegen.taylor_graph import GraphBuilder, Node, Scaled

ORDER = 30
A, B = sympy.symbols("A B", real=True)
SHAPE = (sympy.Rational(1, 3), sympy.Rational(-1, 5), sympy.Rational(1, 7))     # a(t) - a0


def argument(a0, shape=SHAPE, order: int = ORDER) -> list:
    return [sympy.sympify(a0), *shape] + [sympy.S.Zero] * (order - len(shape))


def graph_series(expr: sympy.Expr, inputs: dict, order: int = ORDER) -> list:
    """The coefficients of expr, order 0 .. `order`, by the graph's recurrences; `inputs` maps
    each free symbol to its coefficients."""
    builder = GraphBuilder()
    for i, symbol in enumerate(inputs):
        builder.memo[symbol] = Scaled(1, builder.add(Node("state", index=i)))
    result = builder.value(expr)
    values: list[list] = [[] for _ in builder.nodes]
    given = list(inputs.values())
    for k in range(order + 1):
        for n, node in enumerate(builder.nodes):
            values[n].append(node_coefficient(node, n, values, given, k))
    return [result.scale * c for c in values[result.node]]


def node_coefficient(node: Node, own: int, values: list, given: list, k: int):
    if node.kind == "state":
        return given[node.index][k]
    if node.kind == "lin":
        return (node.offset if k == 0 else 0) + sum(s * values[o][k] for s, o in zip(node.scales, node.operands))
    recurrence = RECURRENCES[node.kind]
    series = {name: values[o] for name, o in zip(recurrence.operands, node.operands)}
    series[OWN] = values[own]
    parameters = dict(zip(recurrence.parameters, node.parameters))
    return sympy.expand(coefficient(recurrence, series, k, parameters))


def expansion(f, a0, shape=SHAPE, order: int = ORDER) -> list:
    """f(a(t)) to t^order: Σ_m c_m δ^m with f(a0 + h) = Σ_m c_m h^m (sympy's series) and
    δ = a(t) - a0."""
    return compose(f, a0, argument(0, shape, order))


def compose(f, a0, delta: list) -> list:
    """f(a0 + δ(t)) for a series δ with δ(0) = 0, as long as δ is."""
    order, h = len(delta) - 1, sympy.Symbol("h")
    series = sympy.series(f(a0 + h), h, 0, order + 1).removeO()
    result, power = [sympy.S.Zero] * (order + 1), [sympy.S.One] + [sympy.S.Zero] * order
    for m in range(order + 1):
        c = series.coeff(h, m) if m else series.subs(h, 0)
        result = [r + c * p for r, p in zip(result, power)]
        power = multiply(power, delta, order)
    return result


def multiply(p: list, q: list, order: int) -> list:
    return [sum((p[j] * q[k - j] for j in range(k + 1)), sympy.S.Zero) for k in range(order + 1)]


def assert_exact(got: list, expected: list) -> None:
    assert sympy.simplify(got[0] - expected[0]) == 0, (got[0], expected[0])
    for k in range(1, len(expected)):
        assert got[k] == expected[k], f"order {k}: {got[k]} != {expected[k]}"


# (name, f as a sympy function of one argument, a0 where its derivatives are rational)
EXACT = [
    ("sin", sympy.sin, 0), ("cos", sympy.cos, 0), ("tan", sympy.tan, 0),
    ("sinh", sympy.sinh, 0), ("cosh", sympy.cosh, 0), ("tanh", sympy.tanh, 0),
    ("exp", sympy.exp, 0), ("log", sympy.log, 1), ("sqrt", sympy.sqrt, sympy.Rational(9, 4)),
    ("atan", sympy.atan, 0), ("asin", sympy.asin, 0), ("acos", sympy.acos, 0),
    ("power -3/2", lambda x: x ** sympy.Rational(-3, 2), 4), ("power 7/3", lambda x: x ** sympy.Rational(7, 3), 8),
    ("square", lambda x: x**2, sympy.Rational(2, 3)), ("cube", lambda x: x**3, 0), ("power 7", lambda x: x**7, 0),
    ("inverse", lambda x: 1 / x, sympy.Rational(3, 2)), ("inverse square", lambda x: x**-2, 2),
    ("abs", sympy.Abs, sympy.Rational(-1, 2)),
]


@pytest.mark.parametrize("name, f, a0", EXACT, ids=[case[0] for case in EXACT])
def test_exact_against_sympy(name, f, a0):
    assert_exact(graph_series(f(A), {A: argument(a0)}), expansion(f, a0))


# At a generic point (sympy's series there is slow for the inverse functions: order 10).
NUMERIC = [("sin", sympy.sin, 20), ("cos", sympy.cos, 20), ("tan", sympy.tan, 10), ("sinh", sympy.sinh, 20),
           ("cosh", sympy.cosh, 20), ("tanh", sympy.tanh, 10), ("exp", sympy.exp, 20), ("log", sympy.log, 20),
           ("atan", sympy.atan, 8), ("asin", sympy.asin, 8), ("acos", sympy.acos, 8)]


# tan, tanh and exp cost sympy a second each here: slow (their exact checks above, to order 30, stay
# in the default run, and sin, cos, log and the inverse functions keep a generic point).
SLOW_NUMERIC = {"tan", "tanh", "exp"}


@pytest.mark.parametrize("name, f, order", [
    pytest.param(*case, marks=pytest.mark.slow if case[0] in SLOW_NUMERIC else ()) for case in NUMERIC],
    ids=[case[0] for case in NUMERIC])
def test_at_a_generic_point(name, f, order):
    a0 = sympy.Rational(7, 10)
    got = graph_series(f(A), {A: argument(sympy.Float(a0, 60), order=order)}, order)
    expected = expansion(f, a0, order=order)
    for k, (g, e) in enumerate(zip(got, expected)):
        assert abs(sympy.N(g - e, 60)) <= sympy.Float(1e-50) * (1 + abs(sympy.N(e, 60))), f"order {k}"


def test_products_and_quotients():
    """a b, a / b and a^b (= exp(b log a)) of two series, exactly."""
    a, b = argument(2), argument(sympy.Rational(1, 2), (sympy.Rational(-1, 4), sympy.Rational(2, 3)))
    assert graph_series(A * B, {A: a, B: b}) == multiply(a, b, ORDER)
    quotient = graph_series(A / B, {A: a, B: b})
    assert multiply(quotient, b, ORDER) == a
    base = argument(1)                       # log a(0) = 0: every coefficient of a^b is rational
    exponent = multiply(b, compose(sympy.log, 1, [0, *base[1:]]), ORDER)
    assert graph_series(A**B, {A: base, B: b}) == compose(sympy.exp, 0, exponent)


def test_atan2_two_series():
    """atan2(y, x) = atan(y / x) for x > 0, exactly."""
    y, x = argument(sympy.Rational(3, 4)), argument(1, (sympy.Rational(1, 2), sympy.Rational(-2, 3)))
    got = graph_series(sympy.atan2(A, B), {A: y, B: x})
    ratio = graph_series(A / B, {A: y, B: x})
    composed = graph_series(sympy.atan(A), {A: ratio})
    assert_exact(got, composed)


def test_min_max_follow_the_smaller_at_order_zero():
    a, b = argument(1), argument(2, (sympy.Rational(5, 3),))
    assert graph_series(sympy.Min(A, B), {A: a, B: b}) == a
    assert graph_series(sympy.Max(A, B), {A: a, B: b}) == b


def test_piecewise_constant_functions():
    a = argument(sympy.Rational(-1, 3))
    assert graph_series(sympy.sign(A), {A: a}) == [-1] + [0] * ORDER
    assert graph_series(sympy.Heaviside(A), {A: a}) == [0] + [0] * ORDER


def test_pythagoras():
    """l (sin²a + cos²a) is the constant l, not two squares per order."""
    builder = GraphBuilder()
    builder.memo[A] = Scaled(1, builder.add(Node("state", index=0)))
    builder.constant_names.add("B")
    assert builder.value(B * sympy.sin(A) ** 2 + B * sympy.cos(A) ** 2 + 1) == Scaled(B + 1)
    assert builder.value(B * sympy.cosh(A) ** 2 - B * sympy.sinh(A) ** 2) == Scaled(B)


@pytest.mark.parametrize("name", sorted(RECURRENCES))
def test_recurrences_read_only_known_orders(name):
    """u_k reads its own series and its lagging companions below order k only."""
    recurrence = RECURRENCES[name]
    for operand in (OWN, *recurrence.lagging):
        assert recurrence.highest_read(operand) < 0, operand
    for _, term in recurrence.terms:
        if isinstance(term, Coefficient):
            assert term.operand not in (OWN, *recurrence.lagging)
