"""Differentiation through named intermediates (forward-mode, by the chain rule).

Expressions refer to intermediates, symbols s with definitions s = e(base symbols, earlier
intermediates). The derivative of an expression E with respect to a base symbol x is

    dE/dx = ∂E/∂x + Σ_s ∂E/∂s · ds/dx,

and ds/dx is itself kept as a new intermediate ("∂s/∂x") unless it is tiny, so every
intermediate and each of its derivatives is computed once and shared. A directional
derivative Σ_x (dE/dx) r_x along given rates r (the time derivative along (q', 1) is
`der`) is built the same way. This keeps expressions the size the user wrote them: the
derivation cost grows with the physics instead of with the expanded formula. (Differentiating
the expanded Lagrangian of an n-link pendulum takes time growing like n^3, and the common-
subexpression elimination after it dominates; benchmarks/README.md measures both ways.)

The Differentiator is a memo table, not shared state: one is made per pass and its
definitions are read out with `definitions()`.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping

import sympy

INLINE_SIZE = 6   # derivatives with at most this many tree nodes are inlined, not named
# A product or power with more free symbols than this is differentiated through the gradients
# of its parts (linear in its size); a smaller one by sympy's diff per symbol, whose forms the
# printed equations of small models keep.
SPLIT_SYMBOLS = 8


def tree_size(expr: sympy.Basic, limit: int = 1 << 30, weights: dict | None = None) -> int:
    """Number of nodes of the expression tree, counting no further than `limit`; a symbol in
    `weights` counts as that many (the size of what it stands for, as if inlined)."""
    count = 0
    stack = [expr]
    weights = weights or {}
    while stack and count <= limit:
        node = stack.pop()
        count += weights.get(node, 1)
        stack.extend(node.args)
    return count


class Differentiator:
    """Chain-rule derivatives through an ordered set of intermediate definitions.

    `base` are the independent symbols (coordinates, velocities, time); symbols that are
    neither base nor intermediates (parameters) are constants.
    """

    def __init__(self, definitions: Iterable[tuple[sympy.Symbol, sympy.Expr]],
                 base: Iterable[sympy.Symbol], mark: str = "∂"):
        self.base = set(base)
        self.mark = mark          # names derivatives ∂x/∂q; another mark keeps two tables apart
        self._definitions: dict[sympy.Symbol, sympy.Expr] = {}
        self._depends: dict[sympy.Symbol, frozenset] = {}
        self._memo: dict[tuple, sympy.Expr] = {}
        self._gradients: dict[sympy.Expr, dict[sympy.Symbol, sympy.Expr]] = {}
        self._dependencies: dict[sympy.Basic, frozenset] = {}
        self._intermediates: dict[sympy.Expr, list[sympy.Symbol]] = {}
        # A member of a prefix sum -> the member before it (x[i] = x[i-1] + f(i),
        # frontend/prefix_sums.py): its derivative is named whenever the one before it is, as the
        # written-out sum's derivative would be (it is at least as large).
        self.extends: dict[sympy.Symbol, sympy.Symbol] = {}
        for symbol, expr in definitions:
            self.define(symbol, expr)

    # -- the table of intermediates ----------------------------------------------------------
    def add_base(self, *symbols: sympy.Symbol) -> None:
        """Declare more independent symbols (before any intermediate uses them)."""
        self.base.update(symbols)
        self._dependencies.clear()

    def define(self, symbol: sympy.Symbol, expr: sympy.Expr) -> sympy.Symbol:
        self._definitions[symbol] = expr
        self._depends[symbol] = self.dependencies(expr)
        return symbol

    def definitions(self) -> tuple[tuple[sympy.Symbol, sympy.Expr], ...]:
        """All intermediates, each after the ones it uses."""
        return tuple(self._definitions.items())

    def named_derivatives(self, direction: tuple) -> dict[sympy.Symbol, sympy.Symbol]:
        """Intermediates created as derivatives along `direction`: derivative -> source."""
        return {value: symbol for (symbol, kind), value in self._memo.items()
                if kind == direction and value in self._definitions}

    def dependencies(self, expr: sympy.Basic) -> frozenset:
        """The base symbols `expr` depends on, directly or through intermediates.

        Cached: sympy walks the whole tree for free_symbols, and the derivation asks about the
        same Lagrangian once per coordinate, which would make a long sum cost n² (an
        intermediate is never used before its definition, so a cached answer stays right).
        """
        if expr not in self._dependencies:
            found = set()
            for symbol in expr.free_symbols:
                if symbol in self.base:
                    found.add(symbol)
                elif symbol in self._depends:
                    found |= self._depends[symbol]
            self._dependencies[expr] = frozenset(found)
        return self._dependencies[expr]

    # -- derivatives -------------------------------------------------------------------------
    def partial(self, expr: sympy.Expr, variable: sympy.Symbol) -> sympy.Expr:
        """d expr / d variable, for a base symbol `variable`, through all intermediates."""
        return self.directional(expr, ("∂", variable), {variable: sympy.S.One})

    def directional(self, expr: sympy.Expr, direction: tuple,
                    rates: Mapping[sympy.Symbol, sympy.Expr]) -> sympy.Expr:
        """Σ_x (d expr/dx) · rates[x]; `direction` names the rates for the memo table."""
        if not (self.dependencies(expr) & rates.keys()):
            return sympy.S.Zero
        gradient = self.gradient(expr)
        # Scan the smaller of the gradient and the rates: a partial derivative of a Lagrangian
        # with n coordinates would otherwise cost n per coordinate, and so would the time
        # derivative der(q[i]) of one member of a long family. (The order of the terms is
        # immaterial: sympy.Add sorts them.)
        if len(gradient) < len(rates):
            terms = [derivative * rates[symbol] for symbol, derivative in gradient.items() if symbol in rates]
        else:
            terms = [gradient[symbol] * rate for symbol, rate in rates.items() if symbol in gradient]
        for symbol in self._intermediates_in(expr):
            if self._depends[symbol] & rates.keys():
                terms.append(gradient[symbol] * self._derivative_of(symbol, direction, rates))
        return sympy.Add(*terms)

    def _intermediates_in(self, expr: sympy.Expr) -> list[sympy.Symbol]:
        """The intermediates among the symbols of expr's gradient, in the gradient's order."""
        if expr not in self._intermediates:
            self._intermediates[expr] = [s for s in self.gradient(expr) if s in self._definitions]
        return self._intermediates[expr]

    def gradient(self, expr: sympy.Expr) -> dict[sympy.Symbol, sympy.Expr]:
        """Explicit partial derivatives of `expr` w.r.t. each of its free symbols (cached).

        Every direction needs the same ∂e/∂s of a definition e, so they are computed once;
        a sum is split term by term, so a long sum costs one pass, not one per symbol.
        """
        if expr not in self._gradients:
            slopes: dict[sympy.Symbol, sympy.Expr] = {}
            if expr.is_Add:
                parts: dict[sympy.Symbol, list[sympy.Expr]] = {}
                for term in expr.args:
                    for symbol, slope in self.gradient(term).items():
                        parts.setdefault(symbol, []).append(slope)
                # One Add per symbol: adding term by term would re-sort the growing sum each time.
                slopes = {symbol: sympy.Add(*terms) for symbol, terms in parts.items()}
            elif expr.is_Mul and all(_is_power_of_symbol(f) or f.is_number for f in expr.args):
                slopes = _monomial_gradient(expr)
            elif len(expr.free_symbols) > SPLIT_SYMBOLS and (expr.is_Mul or expr.is_Pow and expr.exp.is_number):
                slopes = self._split_gradient(expr)
            else:
                for symbol in expr.free_symbols:
                    slopes[symbol] = partial_derivative(expr, symbol)
            self._gradients[expr] = {s: slopes[s] for s in sorted(slopes, key=sympy.default_sort_key)
                                     if slopes[s] != 0}
        return self._gradients[expr]

    def _split_gradient(self, expr: sympy.Expr) -> dict[sympy.Symbol, sympy.Expr]:
        """The gradient of a product or a constant power from the gradients of its parts:
        ∂(a b)/∂s = b ∂a/∂s + a ∂b/∂s, ∂(a^e)/∂s = e a^(e-1) ∂a/∂s. A factor that is a long sum
        (omega^2/4 sum(...)) is then differentiated once, not once per symbol."""
        if expr.is_Pow:
            outer = expr.exp * expr.base ** (expr.exp - 1)
            return {symbol: outer * slope for symbol, slope in self.gradient(expr.base).items()}
        parts: dict[sympy.Symbol, list[sympy.Expr]] = {}
        for i, factor in enumerate(expr.args):
            rest = sympy.Mul(*expr.args[:i], *expr.args[i + 1:])
            for symbol, slope in self.gradient(factor).items():
                parts.setdefault(symbol, []).append(rest * slope)
        return {symbol: sympy.Add(*terms) for symbol, terms in parts.items()}

    def _derivative_of(self, symbol: sympy.Symbol, direction: tuple,
                       rates: Mapping[sympy.Symbol, sympy.Expr]) -> sympy.Expr:
        key = (symbol, direction)
        if key not in self._memo:
            derivative = self.directional(self._definitions[symbol], direction, rates)
            before = self._memo.get((self.extends.get(symbol), direction))
            if tree_size(derivative, INLINE_SIZE) > INLINE_SIZE or before in self._definitions:
                derivative = self.define(self._name(symbol, direction), derivative)
            self._memo[key] = derivative
        return self._memo[key]

    def _name(self, symbol: sympy.Symbol, direction: tuple) -> sympy.Symbol:
        kind, *about = direction
        if kind == "∂":
            return sympy.Symbol(f"{self.mark}{symbol.name}/{self.mark}{about[0].name}", real=True)
        return sympy.Symbol(f"{kind}({symbol.name})", real=True)

    # -- evaluation helpers ------------------------------------------------------------------
    def inline(self, expr: sympy.Expr) -> sympy.Expr:
        """`expr` with every intermediate replaced by its definition (for display and tests)."""
        cache: dict[sympy.Symbol, sympy.Expr] = {}

        def expand(symbol):
            if symbol not in cache:
                definition = self._definitions[symbol]
                cache[symbol] = definition.xreplace(
                    {s: expand(s) for s in definition.free_symbols if s in self._definitions})
            return cache[symbol]

        return expr.xreplace({s: expand(s) for s in expr.free_symbols if s in self._definitions})

    def needed(self, exprs: Iterable[sympy.Basic]) -> tuple[tuple[sympy.Symbol, sympy.Expr], ...]:
        """The definitions that `exprs` use, directly or indirectly, in dependency order."""
        wanted: set[sympy.Symbol] = set()
        stack = [s for e in exprs for s in e.free_symbols if s in self._definitions]
        while stack:
            symbol = stack.pop()
            if symbol not in wanted:
                wanted.add(symbol)
                stack.extend(s for s in self._definitions[symbol].free_symbols
                             if s in self._definitions)
        return tuple((s, e) for s, e in self._definitions.items() if s in wanted)


def partial_derivative(expr: sympy.Expr, symbol: sympy.Symbol) -> sympy.Expr:
    """∂expr/∂symbol, exactly as sympy's diff gives it, by sympy's own first-derivative rules
    applied directly: a sum term by term; a product by the Leibniz rule ∂(a b)/∂s = (∂a/∂s) b +
    a ∂b/∂s; a function by the chain rule Σ_i f_i(args) ∂arg_i/∂s; a power as Pow does. diff
    reaches the same rules through its n-th derivative machinery, at the cost of a Derivative
    and an assumptions query per factor; what the rules here do not cover goes to diff."""
    if symbol not in expr.free_symbols:
        return sympy.S.Zero
    if expr == symbol:
        return sympy.S.One
    args = expr.args
    if expr.is_Mul:
        return sympy.Add(*(sympy.Mul(*args[:k], partial_derivative(factor, symbol), *args[k + 1:])
                           for k, factor in enumerate(args)))
    if expr.is_Add:
        return sympy.Add(*(partial_derivative(term, symbol) for term in args))
    if expr.is_Pow:
        rate_of_base, rate_of_exponent = (partial_derivative(part, symbol) for part in args)
        return expr * (rate_of_exponent * sympy.log(expr.base) + rate_of_base * expr.exp / expr.base)
    if expr.is_Function and type(expr)._eval_derivative is sympy.Function._eval_derivative:
        terms = []
        for i, argument in enumerate(args, 1):
            rate = partial_derivative(argument, symbol)
            if not rate.is_zero:
                outer = expr.fdiff(i)       # its own derivative, or a Derivative (canonicalised by diff)
                if outer.has(sympy.Derivative, sympy.Subs):
                    return expr.diff(symbol)
                terms.append(outer * rate)
        return sympy.Add(*terms)
    return expr.diff(symbol)


def time_rates(coordinates: Iterable[sympy.Symbol], velocities: Iterable[sympy.Symbol],
               time: sympy.Symbol) -> dict[sympy.Symbol, sympy.Expr]:
    """Rates of the time derivative at zero acceleration: q -> q', t -> 1.

    For an expression of (q, t) this is its total time derivative (`der`); for one that also
    depends on q' it is the total derivative without the q'' terms, which is what the
    Euler-Lagrange forcing and the constraint acceleration rows need.
    """
    rates: dict[sympy.Symbol, sympy.Expr] = dict(zip(coordinates, velocities))
    rates[time] = sympy.S.One
    return rates


TIME_DIRECTION = ("der",)


def _is_power_of_symbol(factor: sympy.Expr) -> bool:
    base, exponent = factor.as_base_exp()
    return base.is_Symbol and exponent.is_number


def _monomial_gradient(expr: sympy.Expr) -> dict[sympy.Symbol, sympy.Expr]:
    """∂(c Π_i s_i^e_i)/∂s_k = e_k s_k^(e_k - 1) c Π_(i≠k) s_i^e_i, written down rather than found by
    sympy's diff (a dense T of n² terms q'_i q'_j c_ij has n² of these; diff costs a millisecond
    each). A flattened product has each base once."""
    factors = expr.args
    slopes = {}
    for i, factor in enumerate(factors):
        base, exponent = factor.as_base_exp()
        if base.is_Symbol:
            slopes[base] = sympy.Mul(exponent, base ** (exponent - 1), *factors[:i], *factors[i + 1:])
    return slopes

