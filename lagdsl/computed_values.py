"""The values a model computes from its parameters, as numbers: a parameter defined by an
expression of earlier ones (`parameter w = sqrt(k/m)`) and the coordinates' start values and
velocities (`coordinate s(start = m*g*cos(phi0)/k)`).

Each expression is compiled once per model (`computed_values(model)`) into a Python function
of the parameter values: sympy.lambdify over the math module, of the IR's expression (built node
by node from the parse tree, never from text). They are kept beside the model, not in it: an
ir.Model stays picklable. A scene's plan then costs microseconds where
sympy's evalf cost 0.7 to 2 ms, which a fit varying such an input pays on every call.

What a computed value is (the contract, tests/test_computed_values.py): the IEEE double
evaluation of its expression, one rounding per operation, as the generated program evaluates it
(lag_derive_parameters, lag_initial_state); every constant in it (the pi/180 of a unit written
in degrees, a 1/3) is first rounded once, correctly, from its exact value, so that a unit
conversion stays exact; a value that is a constant is that correctly rounded constant. A
computed value may thus differ by a few units in the last place from the exact value of the
expression rounded once (what evalf(30) gave before): both are within the rounding that the
integration then adds, and a run is now the same whether planned anew or repeated. A value that
cannot be computed (a division by zero, the square root of a negative number, an overflow) is
not finite, and scene.py says which one and why.
"""
from __future__ import annotations

import functools
import math
import weakref
from typing import Callable, Sequence

import sympy

from . import ir

# an integer of this size or more is not exact as a double: it is rounded like other constants
EXACT_INTEGER = 2 ** 53
# what a value whose evaluation fails is (the message then calls it not finite)
FAILED = {ZeroDivisionError: math.inf, OverflowError: math.inf}
_COMPILED: dict[int, "ComputedValues"] = {}     # by id of a live model


def computed_values(model: ir.Model) -> ComputedValues:
    """The model's computed values, compiled when first asked for and kept while it lives."""
    compiled = _COMPILED.get(id(model))
    if compiled is None:
        compiled = ComputedValues([(p.symbol, p.expression, p.value) for p in model.parameters],
                                  [c.start for c in model.coordinates] + [c.velocity for c in model.coordinates])
        _COMPILED[id(model)] = compiled
        weakref.finalize(model, _COMPILED.pop, id(model), None)
    return compiled


class ComputedValues:
    """A model's computed parameters and start values as compiled functions of its parameters."""

    def __init__(self, parameters: Sequence[tuple[sympy.Symbol, sympy.Expr, float]],
                 initial: Sequence[sympy.Expr]):
        """`parameters`: each parameter's (symbol, expression, value of a constant expression) in
        declaration order; `initial`: the starts, then the velocities, of the coordinates."""
        symbols = tuple(symbol for symbol, _, _ in parameters)
        self._parameters = tuple(_compiled([expression], symbols[:i]) if expression.free_symbols else value
                                 for i, (_, expression, value) in enumerate(parameters))
        self._constant_initial = tuple(_constant(e) if not e.free_symbols else None for e in initial)
        varying = [e for e in initial if e.free_symbols]
        self._initial = _compiled(varying, symbols) if varying else None

    def parameters(self, names: Sequence[str], set_values: dict[str, float]) -> list[float]:
        """Every parameter's value (`names`: theirs, in order): the set ones as given, the others
        their constant or computed from the ones before."""
        values: list[float] = []
        for name, computed in zip(names, self._parameters):
            if name in set_values:
                values.append(float(set_values[name]))
            else:
                values.append(computed(values)[0] if callable(computed) else float(computed))
        return values

    def initial(self, parameters: Sequence[float]) -> list[float]:
        """Each coordinate's start value, then each one's velocity, as the model defines them."""
        varying = iter(self._initial(parameters) if self._initial is not None else ())
        return [value if value is not None else next(varying) for value in self._constant_initial]


def _compiled(expressions: list[sympy.Expr], symbols: tuple[sympy.Symbol, ...]) -> Callable[[Sequence[float]], list]:
    """A function of the values of `symbols` (a sequence, perhaps longer) giving `expressions`'
    values in double precision, their constants bound as correctly rounded numbers."""
    constants: dict[sympy.Symbol, float] = {}
    bound = [_bind_constants(e, constants) for e in expressions]
    function = sympy.lambdify(tuple(constants) + symbols, bound, modules="math", docstring_limit=0)
    with_constants = functools.partial(function, *constants.values())
    count = len(symbols)

    def evaluated(values: Sequence[float]) -> list:
        try:
            return with_constants(*values[:count])
        except (ZeroDivisionError, OverflowError, ValueError) as failure:
            return [FAILED.get(type(failure), math.nan)] * len(expressions)
    return evaluated


def _bind_constants(expression: sympy.Expr, constants: dict[sympy.Symbol, float]) -> sympy.Expr:
    """`expression` with each constant part (a sum's or product's terms free of symbols, a constant
    argument) replaced by a symbol bound in `constants` to its correctly rounded value; exact
    integers and rational exponents (x**2, sqrt) are kept as written."""
    if not expression.free_symbols and isinstance(expression, sympy.Expr):     # not a condition's true
        if expression.is_Integer and abs(expression) < EXACT_INTEGER:
            return expression
        symbol = sympy.Dummy(f"c{len(constants)}")
        constants[symbol] = _constant(expression)
        return symbol
    if expression.is_Atom or not expression.args:
        return expression
    if expression.is_Pow and expression.exp.is_Rational:
        return sympy.Pow(_bind_constants(expression.base, constants), expression.exp, evaluate=False)
    if expression.is_Add or expression.is_Mul:
        constant, rest = expression.as_independent(*expression.free_symbols, as_Add=expression.is_Add)
        terms = [_bind_constants(term, constants) for term in expression.make_args(rest)]
        identity = sympy.S.Zero if expression.is_Add else sympy.S.One
        leading = [] if constant == identity else [_bind_constants(constant, constants)]
        return expression.func(*leading, *terms, evaluate=False)
    return expression.func(*[_bind_constants(argument, constants) for argument in expression.args])


def _constant(expression: sympy.Expr) -> float:
    """The correctly rounded value of a constant expression (nan where it has no real value)."""
    if expression.is_Number:
        return float(expression)
    try:
        return float(expression.evalf(30))
    except TypeError:       # complex or undefined (zoo)
        return math.nan
