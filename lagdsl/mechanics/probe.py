"""Numerical identity tests: is an expression zero for every state?

Deciding whether `x1^2 + y1^2 - l1^2` vanishes identically, or whether ∂L/∂q_k = 0, by
symbolic simplification does not scale. Instead the expression (with its intermediates) is
evaluated in 50-digit arithmetic at a few random states and random parameter values: a
nonzero analytic expression vanishes at a random point with probability zero, and the
extended precision separates true zeros (round-off ~1e-50) from small values.
Points are drawn from a fixed seed, so the answers are deterministic.

The test is for analytic expressions. A piecewise one can vanish at every probe point without
vanishing identically: the second velocity derivative of abs(der(x)) is zero away from x' = 0,
so `abs(der(x)) = 1` passes as linear in the velocities.
"""
from __future__ import annotations

import random
from collections.abc import Callable, Sequence

import mpmath
import numpy as np
import sympy

from ..calculus import Differentiator

DIGITS = 50
POINTS = 3
ZERO_TOLERANCE = mpmath.mpf(10) ** -35


def _heaviside(x, at_zero=0.5):
    return mpmath.mpf(0) if x < 0 else mpmath.mpf(1) if x > 0 else mpmath.mpf(at_zero)


def _dirac_delta(x, order=0):
    return mpmath.inf if x == 0 else mpmath.mpf(0)


# Beyond this magnitude 50 digits no longer resolve the phase of sin, cos or tan, and mpmath's
# argument reduction would compute pi to as many bits as the argument's exponent (1e30 bits for
# sin(exp(exp(exp(x + 2))))): such a value is unknown (NaN), never a reason to hang.
PHASE_LIMIT = mpmath.mpf(10) ** 30
# exp overflows a double beyond this: the generated code gets inf there, and so does the probe
# (a tower of exponentials would otherwise grow numbers of astronomical exponent).
EXP_LIMIT = mpmath.mpf("709.782712893384")


def _periodic(function):
    def bounded(x):
        return mpmath.nan if abs(x) > PHASE_LIMIT else function(x)
    return bounded


def _exponential(function, sign=1):
    def bounded(x):
        if mpmath.re(x) > EXP_LIMIT:
            return mpmath.inf
        if mpmath.re(x) < -EXP_LIMIT:
            return sign * mpmath.inf if function is not mpmath.exp else mpmath.mpf(0)
        return function(x)
    return bounded


# Derivatives of abs, sign, min and max bring in Heaviside and DiracDelta, which mpmath lacks;
# the functions whose cost grows with their argument's magnitude are bounded as above.
MPMATH_EXTRAS = {"Heaviside": _heaviside, "DiracDelta": _dirac_delta,
                 **{name: _periodic(getattr(mpmath, name)) for name in ("sin", "cos", "tan", "sec", "csc", "cot")},
                 "exp": _exponential(mpmath.exp), "cosh": _exponential(mpmath.cosh),
                 "sinh": _exponential(mpmath.sinh, sign=-1)}


class Probe:
    """Evaluates expressions over intermediates at fixed random points."""

    def __init__(self, calculus: Differentiator, symbols: Sequence[sympy.Symbol], seed: int = 20261123):
        self.calculus = calculus
        self.symbols = tuple(sorted(symbols, key=sympy.default_sort_key))
        generator = random.Random(seed)
        self.points = [[mpmath.mpf(0.3 + generator.random()) for _ in self.symbols] for _ in range(POINTS)]

    def evaluate(self, exprs: Sequence[sympy.Expr], fixed: dict[sympy.Symbol, float] | None = None) -> list[list]:
        """Values of `exprs` at each probe point: a list (one per point) of mpmath numbers. The
        symbols in `fixed` take the values given there instead of the point's."""
        points = self.points
        if fixed:
            points = [[mpmath.mpf(fixed[s]) if s in fixed else x for s, x in zip(self.symbols, point)]
                      for point in points]
        return evaluate_at(self.calculus, exprs, self.symbols, points, fill=mpmath.mpf(0.5))

    def zeros(self, exprs: Sequence[sympy.Expr]) -> list[bool]:
        """For each expression: does it vanish identically (at every probe point)?"""
        pending = [i for i, e in enumerate(exprs) if e != 0]
        answer = [True] * len(exprs)
        values = self.evaluate([exprs[i] for i in pending])
        for column, index in enumerate(pending):
            answer[index] = all(_is_tiny(point[column]) for point in values)
        return answer

    def is_zero(self, expr: sympy.Expr) -> bool:
        return self.zeros([expr])[0]

    def matrices(self, rows: Sequence[Sequence[sympy.Expr]]) -> list[np.ndarray]:
        """A matrix of expressions evaluated at each probe point, as float arrays.

        Only the entries that are not structurally zero are evaluated: a large mass matrix is
        mostly zeros (the FPU chain's is the identity), and printing them for lambdify would
        cost n² however sparse it is."""
        flat = [e for row in rows for e in row]
        shape = (len(rows), len(rows[0]) if rows else 0)
        nonzero = [i for i, e in enumerate(flat) if e != 0]
        matrices = []
        for point in self.evaluate([flat[i] for i in nonzero]):
            values = np.zeros(len(flat))
            values[nonzero] = [to_float(x) for x in point]
            matrices.append(values.reshape(shape))
        return matrices


def evaluate_at(calculus: Differentiator, exprs: Sequence[sympy.Expr], symbols: Sequence[sympy.Symbol],
                points: Sequence[Sequence], fill=mpmath.nan) -> list[list]:
    """Values of `exprs` (over the intermediates of `calculus`) at each point, in DIGITS-digit
    arithmetic: a list (one per point) of mpmath numbers. A point gives the values of `symbols`
    in order; any other free symbol takes the value `fill`."""
    at = compiled_at(calculus, exprs, symbols, fill)
    return [at(point) for point in points]


def compiled_at(calculus: Differentiator, exprs: Sequence[sympy.Expr], symbols: Sequence[sympy.Symbol],
                fill=mpmath.nan) -> Callable[[Sequence], list]:
    """evaluate_at's evaluation of one point, built once for points given one at a time."""
    if not exprs:
        return lambda point: []
    definitions = calculus.needed(exprs)
    stray = set().union(*(e.free_symbols for e in exprs)) | set().union(
        *(e.free_symbols for _, e in definitions))
    stray -= set(symbols) | {s for s, _ in definitions}
    symbols = tuple(symbols) + tuple(sorted(stray, key=sympy.default_sort_key))
    # lambdify prints names as Python identifiers; ours ("theta1'", "∂L/∂x'") are not.
    safe = {s: sympy.Symbol(f"_p{i}") for i, s in enumerate((*symbols, *(d for d, _ in definitions)))}
    try:
        function = sympy.lambdify(
            [safe[s] for s in symbols], [e.xreplace(safe) for e in exprs], modules=[MPMATH_EXTRAS, "mpmath"],
            cse=lambda e: ([(safe[d], x.xreplace(safe)) for d, x in definitions], e))
    except (ValueError, KeyError, TypeError, NotImplementedError):
        # Not printable for mpmath (an unevaluated Derivative, say): unknown, so never "zero".
        # derive_equations reports an underivable expression itself.
        return lambda point: [mpmath.nan] * len(exprs)

    def at(point: Sequence) -> list:
        extra = [fill] * (len(symbols) - len(point))
        with mpmath.workdps(DIGITS):
            try:
                return function(*[mpmath.mpf(x) for x in point], *extra)
            except (ArithmeticError, ValueError, TypeError, AttributeError):   # a pole, an overflow, or
                # a complex value where mpmath wants a real one (atan2 of sqrt(log(0.5)))
                return [mpmath.nan] * len(exprs)
    return at


def _is_tiny(value) -> bool:
    try:
        return bool(abs(value) < ZERO_TOLERANCE)
    except TypeError:
        return False


def to_float(value) -> float:
    """An mpmath number as a float: nan for a complex or non-numeric value."""
    try:
        value = complex(value)
    except OverflowError:                   # an exact integer beyond double range
        return float("inf")
    except TypeError:
        return float("nan")
    return value.real if value.imag == 0 else float("nan")
