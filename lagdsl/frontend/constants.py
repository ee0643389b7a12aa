"""The constants of an expression must be finite real doubles.

sympy computes with exact numbers: 9.81 is 981/100, exp(1000) and 2^(10^9) are exact too. A
constant the generated code cannot hold (a NaN, an infinity, a complex number, a number beyond
the range of double precision) is reported where it is written, before sympy spends hours on
it: each node's value is checked as the ExpressionBuilder builds it.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import sympy

from ..errors import LagError
from ..source import Span
from .tree import excerpt
from .values import is_array

MAX_DOUBLE = sympy.Rational(1.7976931348623157e308)
NON_FINITE = (sympy.zoo, sympy.nan, sympy.oo, sympy.S.NegativeInfinity)
FOLDING_NODES = ("mul", "div", "pow", "neg", "add", "sub")   # where exact constants combine and may overflow


def require_finite(value, span: Span):
    """A function or power of finite arguments may still be infinite: tan(atan2(x, 0)) is zoo*x."""
    for component in (value.components if is_array(value) else (value,)):
        if not component.is_number and component.has(*NON_FINITE):
            raise LagError(f"{excerpt(span, 'this expression')} has no finite value", span)
    return value


def require_real_constants(value, where: Callable[[], Span], folds: bool) -> None:
    """A constant part of an expression must be a finite real double (tan(pi/2) is not, nor
    the factor 1/1e-310 = 1e310 that m/1e-310 folds into: `folds`, where constants combine).
    `where()` is the span of the expression: it is found only for a message."""
    if value.is_Symbol:
        return
    if not value.is_number:
        if folds and any(abs(n) > MAX_DOUBLE for n in _large_rationals(value)):
            _fail("has a constant factor out of the range of double precision", where())
        return
    if value.has(*NON_FINITE):
        _fail("has no finite value", where())
    if value.is_real is False:
        _fail("is not a real number", where())
    if value.is_Rational and abs(value) > MAX_DOUBLE:
        _fail("is not finite in double precision", where())
    if not value.is_Rational and _magnitude(value) > MAX_DOUBLE:
        # exp(1000) is exact to sympy; checked here, node by node, no constant beyond a double
        # ever reaches a power, where 2^2^exp(1000) would make evalf's precision explode
        _fail("is out of the range of double precision", where())


def _large_rationals(value: sympy.Expr):
    """The rationals p/q of `value` with |p| of more than 1023 bits: the only ones that may
    exceed MAX_DOUBLE (< 2^1024), found by a plain walk (sympy's atoms() is a generator walk
    several times slower, and this runs on every node of every expression)."""
    stack = [value]
    while stack:
        node = stack.pop()
        if node.is_Rational:
            if node.p.bit_length() > 1023:
                yield node
        else:
            stack.extend(node.args)


def _fail(what: str, span: Span):
    raise LagError(f"{excerpt(span, 'this constant')} {what}", span)


def require_power_in_range(base: sympy.Expr, exponent: sympy.Expr, span: Span) -> None:
    """Rational powers are computed exactly: their size is checked first (2^(10^9) is not a
    double). sympy also raises the rational factor of a product to an integer power ((x/2)^n is
    x^n/2^n), so the factor is checked too."""
    coefficient = base if base.is_Rational else base.as_coeff_Mul()[0]
    if coefficient.is_Rational and exponent.is_Rational and abs(coefficient) not in (0, 1) and abs(exponent) > 1:
        p, q = abs(coefficient.p), coefficient.q
        bits = abs(float(exponent)) * abs(math.log2(p) - math.log2(q))
        work = abs(float(exponent)) * max(math.log2(p), math.log2(q))
        if bits > 1100 or work > 100000:
            power = f"^{float(exponent):.6g}"
            what = f"{base}{power}" if base.is_Rational else \
                f"the power {power} of an expression with the factor {coefficient}"
            raise LagError(f"{what} is out of the range of double precision", span)


def _magnitude(number: sympy.Expr) -> sympy.Expr:
    """|number| to 17 digits; infinite when sympy cannot evaluate it (its working precision
    overflows on a value far beyond any float)."""
    try:
        return abs(number.evalf(17))
    except (OverflowError, ValueError, ZeroDivisionError, RecursionError):
        return sympy.oo
