"""Prefix sums kept as recurrences (frontend/prefix_sums.py) and the partial derivatives of
calculus.partial_derivative: the same expressions as the unrolled sums and as sympy's diff."""
from __future__ import annotations

import pytest
import sympy

from lagdsl.calculus import partial_derivative
from lagdsl.frontend.compile_time import MAX_UNROLLED
from lagdsl.pipeline import model_from_source
from lagdsl.source import SourceFile

CHAIN = """model Chain
  parameter n = {n};  parameter l = 1.5;  parameter g = 9.81;
  coordinate theta[n](start = 0.5);
  let x[i] = {x}, i in 1:n;
  let y[i] = {y}, i in 1:n;
  T = sum((der(x[i])^2 + der(y[i])^2)/2, i in 1:n);
  U = sum(g*y[i], i in 1:n);
  scene swing
    time(stop = 1, interval = 0.1);
  end swing;
end Chain;
"""
PREFIX = {"x": "sum(l*sin(theta[j]), j in 1:i)", "y": "-sum(l*cos(theta[j]), j in 1:i)"}
# The same sums written so that they are not recognised (a second term): unrolled as written.
UNROLLED = {"x": "sum(l*sin(theta[j]), j in 1:i) + 0*i", "y": "-sum(l*cos(theta[j]), j in 1:i) + 0*i"}


def chain(n: int, forms: dict[str, str]):
    return model_from_source(SourceFile("chain.lag", CHAIN.format(n=n, **forms)))


def test_each_member_after_the_first_adds_one_term_to_the_one_before():
    model = chain(4, PREFIX)
    lets = {let.name: let for let in model.lets}
    x2, x3 = lets["x[2]"].symbol, lets["x[3]"].symbol
    theta3, l = model.coordinates[2].symbol, model.parameters[1].symbol
    assert lets["x[3]"].expression == x2 + l * sympy.sin(theta3)
    assert lets["x[3]"].extends == x2 and lets["x[1]"].extends is None
    assert lets["der(x[4])"].extends == lets["der(x[3])"].symbol
    assert lets["der(x[4])"].expression.has(lets["der(x[3])"].symbol)


@pytest.mark.parametrize("n", [2, 5, 9])
def test_written_out_the_lets_are_the_unrolled_sums(n):
    """Member by member, the same sympy expressions as the sums unrolled term by term, the
    derivatives der(x[i]) included: the expanded derivation sees the model as it did."""
    recurrent, unrolled = chain(n, PREFIX), chain(n, UNROLLED)
    assert recurrent.written_out_lets() == tuple((let.symbol, let.expression) for let in unrolled.lets)
    assert recurrent.lagrangian.expression == unrolled.lagrangian.expression


def test_a_chain_longer_than_the_unrolled_budget_is_read():
    """Unrolled, 2 x n²/2 terms would exceed MAX_UNROLLED; as recurrences they are 2n."""
    n = 320
    assert n * n > MAX_UNROLLED
    model = chain(n, PREFIX)
    assert len([let for let in model.lets if let.derivative_of is None]) == 2 * n


def test_a_sum_that_uses_the_index_otherwise_is_built_as_written():
    model = chain(3, {"x": "sum(i*l*sin(theta[j]), j in 1:i)", "y": "-sum(l*cos(theta[j]), j in 1:i - 1) - l"})
    assert all(let.extends is None for let in model.lets)


X, Y, Z = sympy.symbols("x y z", real=True)
A = sympy.Symbol("a", positive=True)
F = sympy.Function("f", real=True)
EXPRESSIONS = [
    3 * X, -X, X * Y * Z + X ** 2 / Y, -A * sympy.cos(X) * sympy.cos(Y), (X + Y) ** 3 * Z / 2,
    X ** 2 * Y * sympy.exp(Z * X), sympy.sqrt(X ** 2 + Y ** 2) * Z, sympy.atan2(Y, X) * X, X ** Y, 2 ** X,
    X ** sympy.Rational(1, 3), sympy.log(X * Y) ** 2, sympy.sin(sympy.cos(X * Y)) / (1 + X ** 2),
    sympy.Abs(X) * Y, sympy.sign(X) * X * Y, sympy.Max(X, Y) * X, sympy.Piecewise((X, Y > 0), (X ** 2, True)),
    sympy.besselj(0, X), sympy.erf(X * Y), sympy.Heaviside(X) * X, X * F(Y), F(X * Y) + F(X) ** 2,
]


@pytest.mark.parametrize("expression", EXPRESSIONS, ids=str)
def test_partial_derivatives_are_sympys(expression):
    for symbol in (X, Y, Z, A):
        assert partial_derivative(expression, symbol) == expression.diff(symbol)
