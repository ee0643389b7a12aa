"""Calls in expressions: the built-in functions of functions.py, der(), sum() and the observables.

`der(e)` is the total time derivative by the chain rule, Σ_k ∂e/∂q_k q'_k + ∂e/∂t, taken
through the named intermediates by the `Differentiator`; it is defined for expressions of
(q, t) only, since L(q, q', t) may not depend on accelerations. `sum(e, i in a:b)` is unrolled,
each term built with i bound to a number.
"""
from __future__ import annotations

import sympy

from ..calculus import TIME_DIRECTION, Differentiator
from .constants import require_finite
from ..errors import LagError, suggest
from .functions import BUILTINS, FUNCTION_NAMES, Builtin
from .tree import call_arguments
from .values import KIND_WORDS, Matrix, Vector, is_array, kind_of, map_value, matrix_of

# What each kind of argument a function takes (Builtin.takes) accepts.
ACCEPTS = {"scalars": lambda value: not is_array(value),
           "3-vectors": lambda value: isinstance(value, Vector),
           "a 3x3 matrix": lambda value: isinstance(value, Matrix)}


class Calls:
    """The value of each call node, for an ExpressionBuilder (which builds the arguments)."""

    def __init__(self, builder, differentiator: Differentiator, velocities: dict[sympy.Symbol, sympy.Symbol]):
        self.builder = builder
        self.calculus = differentiator
        self.velocities = velocities          # q -> q'
        self.rates = dict(velocities)         # the direction of der(): q -> q', t -> 1
        self.rates[sympy.Symbol("t", real=True)] = sympy.S.One
        self._velocities_seen: frozenset = frozenset()
        self.observables: set[sympy.Symbol] = set()                   # multiplier(c) symbols used

    def declare_velocity(self, coordinate: sympy.Symbol, velocity: sympy.Symbol) -> None:
        self.velocities[coordinate] = velocity
        self.rates[coordinate] = velocity

    def value(self, node, scope):
        """The value of a call: a function of the table, der(), sum() or an observable."""
        token = node.children[0]
        name = str(token)
        arguments = call_arguments(node)
        span = self.builder.span(node)
        function = BUILTINS.get(name)
        if function is not None and function.kind == "observable":
            return self._observable(function, node, arguments, scope)
        if function is None:
            raise self._not_a_function(token, scope)
        if len(arguments) != function.arity:
            plural = "s" if function.arity != 1 else ""
            raise LagError(f"{name}() takes {function.arity} argument{plural}, got {len(arguments)}", span)
        if name == "sum":
            value = self._sum(arguments, scope, span)
        else:
            for argument in arguments:
                if argument.data == "iteration":
                    raise LagError("an 'i in a:b' range is only allowed as the second argument of sum()",
                                   self.builder.span(argument))
            value = self.rate(self.builder.build(arguments[0], scope), arguments[0]) if name == "der" else \
                self._function(function, node, arguments, scope)
        self.builder.dims.call(node, function, arguments)
        return value

    def _observable(self, function: Builtin, node, arguments, scope):
        if scope.observable is None:
            raise LagError(f"{function.name}(...) is a built-in observable: outputs may use it (an output "
                           "declaration or a scene's output list), the model's equations may not",
                           self.builder.span(node))
        value = scope.observable(function.name, arguments, self.builder.span(node))
        self.observables.add(value)
        self.builder.dims.call(node, function, arguments)
        return value

    def _not_a_function(self, token, scope) -> LagError:
        """What a call of a name that is no built-in function is."""
        name = str(token)
        span = self.builder.span(token)
        if name in scope.bindings:
            binding = scope.lookup(name, span)   # a failed declaration is reported there
            return LagError(f"'{name}' is {KIND_WORDS.get(binding.kind, 'a name')}, not a function", span)
        if name in ("t", "pi"):
            return LagError(f"'{name}' is {'the time' if name == 't' else 'a constant'}, not a function", span)
        return LagError(f"unknown function '{name}'{suggest(name, FUNCTION_NAMES)}", span)

    def _function(self, function: Builtin, node, arguments, scope):
        """A function of the table: its arguments built and checked, then its value."""
        values = [self.builder.build(a, scope) for a in arguments]
        for value, argument in zip(values, arguments):
            if not ACCEPTS[function.takes](value):
                raise LagError(f"{function.name}() takes {function.takes}, but this is {kind_of(value)}",
                               self.builder.span(argument))
        rates = [self.rate(value, argument) for value, argument in zip(values, arguments)] if function.rates else []
        return require_finite(function.value(*values, *rates), self.builder.span(node))

    def _velocity_symbols(self) -> frozenset:
        """The velocities declared so far, kept between calls: der() of each member of a long
        family would otherwise build the set anew, n² in all."""
        if len(self._velocities_seen) != len(self.velocities):
            self._velocities_seen = frozenset(self.velocities.values())
        return self._velocities_seen

    def rate(self, value, argument):
        """The time derivative of a value of (q, t), componentwise for vectors and matrices."""
        for component in (value.components if is_array(value) else (value,)):
            if component.free_symbols & self.observables:
                raise LagError("der() of a Lagrange multiplier: its rate is not computed", self.builder.span(argument))
            if self.calculus.dependencies(component) & self._velocity_symbols():
                raise LagError("der() of an expression that depends on velocities would need accelerations; "
                               "L, T, U and constraints are functions of q, q' and t", self.builder.span(argument))
        return map_value(value, lambda c: self.calculus.directional(c, TIME_DIRECTION, self.rates))

    def _sum(self, arguments, scope, span):
        body, iteration = arguments
        if iteration.data != "iteration":
            raise LagError("the second argument of sum() is a range: sum(expr, i in 1:n)", self.builder.span(iteration))
        variable, low, high = self.builder.numbers.iteration(iteration, scope)
        terms = [self.builder.build(body, scope.child(**{variable: index})) for index in range(low, high + 1)]
        return _added(terms, span) if terms else sympy.S.Zero


def _added(terms, span):
    """The terms added at once: sympy sorts an Add's arguments whenever it is built, so adding
    them one by one would cost n² in the number of terms."""
    first = terms[0]
    for term in terms[1:]:
        if kind_of(term) != kind_of(first):
            raise LagError(f"sum() terms mix {kind_of(first)[2:]}s and {kind_of(term)[2:]}s", span)
    if is_array(first):
        total = [sympy.Add(*parts) for parts in zip(*(term.components for term in terms))]
        return Vector(tuple(total)) if isinstance(first, Vector) else matrix_of(total)
    return sympy.Add(*terms)
