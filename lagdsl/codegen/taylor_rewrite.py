"""The system block rewritten for the Taylor series: sums of products with the products of sines
and cosines turned into sines and cosines of sums of angles, when the entries are small.

The derivation writes a pendulum's mass matrix and forces from Cartesian positions, and so
leaves M_12 = m2 l1 l2 (sin θ1 sin θ2 + cos θ1 cos θ2) and forces in which terms cancel
(the double pendulum's v1² sin θ1 cos θ1 in f_1). As numbers this costs nothing; as Taylor
series each product is a Cauchy product at every order. Expanding each entry of K and b
(CSE's intermediates substituted back), applying the product-to-sum identities
2 sin a cos b = sin(a + b) + sin(a - b) and the like (Fu et al.'s rule TR8, here for products
of whole powers of sines and cosines, term by term), and expanding again gives M_12 = m2 l1 l2 cos(θ1 - θ2) and f_1 = -(m1 + m2) g l1 sin θ1
- m2 l1 l2 θ2'² sin(θ1 - θ2): the textbook form, with half the series. Every step is an
identity, so the equations are the same; only where an entry would expand to more than
EXPANDED_TERMS terms, or the block to more than BLOCK_TERMS, is the block kept as it is (no
simplification of large expressions).
The graph builder (taylor_graph.series_graph) builds both and keeps the cheaper.
"""
from __future__ import annotations

import sympy

from .cse import eliminate_common_subexpressions
from .kernel import Block, Store

EXPANDED_TERMS = 200       # the most terms an entry may expand to (an estimate, before expanding)
BLOCK_TERMS = 2000         # and all entries together (the 12-link chain's 1600 take a second)


def rewritten_block(block: Block) -> Block | None:
    """The block with its stores expanded through the product-to-sum identities and CSE'd
    again, or None when it has no sine or cosine or an entry is too large to expand."""
    definitions = {sympy.Symbol(name, real=True): expr for name, expr in block.assignments}
    if not any(expr.has(sympy.sin, sympy.cos) for expr in definitions.values()) \
            and not any(store.value.has(sympy.sin, sympy.cos) for store in block.stores):
        return None
    estimates: dict = {}
    sizes = [_terms(store.value, definitions, estimates) for store in block.stores]
    if max(sizes, default=0) > EXPANDED_TERMS or sum(sizes) > BLOCK_TERMS:
        return None
    values, inlined = [], {}
    for store in block.stores:
        expanded = _products_expanded(_inlined(store.value, definitions, inlined))
        values.append(_products_expanded(sympy.Add(*map(_product_to_sum, sympy.Add.make_args(expanded)))))
    ordered, reduced = eliminate_common_subexpressions([], values, prefix="e")
    used = set().union(*(value.free_symbols for _, value in ordered), *(value.free_symbols for value in reduced))
    inputs = tuple((name, source) for name, source in block.inputs if sympy.Symbol(name, real=True) in used)
    return Block(inputs, tuple((symbol.name, value) for symbol, value in ordered),
                 tuple(Store(store.array, store.index, value) for store, value in zip(block.stores, reduced)))


def _products_expanded(expr: sympy.Expr) -> sympy.Expr:
    """Products (and whole powers) of sums multiplied out, at every depth; powers of products,
    sums in exponents and logarithms are left as they are."""
    return sympy.expand(expr, power_base=False, power_exp=False, log=False)


def _product_to_sum(term: sympy.Expr) -> sympy.Expr:
    """A product with its sines and cosines (whole powers of them) folded pairwise into sines
    and cosines of sums and differences of their arguments."""
    trig, others = [], []
    for factor in sympy.Mul.make_args(term):
        base, exponent = factor.as_base_exp()
        if isinstance(base, (sympy.sin, sympy.cos)) and exponent.is_Integer and exponent > 0:
            trig += [base] * int(exponent)
        else:
            others.append(factor)
    if len(trig) < 2:
        return term
    total = trig[0]
    for factor in trig[1:]:
        total = sympy.Add(*(_pair(part, factor) for part in sympy.Add.make_args(sympy.expand(total))))
    return sympy.Mul(*others) * total


def _pair(part: sympy.Expr, factor: sympy.Expr) -> sympy.Expr:
    """part · factor, part a constant times a sine or cosine (or a constant), factor a sine or
    cosine: 2 sin a sin b = cos(a - b) - cos(a + b), 2 cos a cos b = cos(a - b) + cos(a + b),
    2 sin a cos b = sin(a + b) + sin(a - b)."""
    coefficient, function = part.as_independent(sympy.sin, sympy.cos, as_Add=False)
    if not isinstance(function, (sympy.sin, sympy.cos)):
        return part * factor
    a, b = function.args[0], factor.args[0]
    half = coefficient / 2
    if isinstance(function, sympy.sin) and isinstance(factor, sympy.sin):
        return half * (sympy.cos(a - b) - sympy.cos(a + b))
    if isinstance(function, sympy.cos) and isinstance(factor, sympy.cos):
        return half * (sympy.cos(a - b) + sympy.cos(a + b))
    if isinstance(function, sympy.sin):
        return half * (sympy.sin(a + b) + sympy.sin(a - b))
    return half * (sympy.sin(a + b) - sympy.sin(a - b))


def _inlined(expr: sympy.Expr, definitions: dict, done: dict) -> sympy.Expr:
    """expr with every intermediate replaced by its definition, recursively (memoised)."""
    replacements = {}
    for symbol in expr.free_symbols & definitions.keys():
        if symbol not in done:
            done[symbol] = _inlined(definitions[symbol], definitions, done)
        replacements[symbol] = done[symbol]
    return expr.xreplace(replacements)


def _terms(expr: sympy.Expr, definitions: dict, memo: dict) -> int:
    """An upper estimate of the terms expr expands to: sums add, products multiply, a whole
    power of a sum multiplies as often; anything else counts as one term."""
    if expr in memo:
        return memo[expr]
    if expr.is_Symbol and expr in definitions:
        count = _terms(definitions[expr], definitions, memo)
    elif expr.is_Add:
        count = sum(_terms(arg, definitions, memo) for arg in expr.args)
    elif expr.is_Mul:
        count = 1
        for arg in expr.args:
            count *= _terms(arg, definitions, memo)
    elif expr.is_Pow and expr.exp.is_Integer and expr.exp > 0:
        count = _terms(expr.base, definitions, memo) ** int(expr.exp)
    else:
        count = 1
    memo[expr] = min(count, 10 * EXPANDED_TERMS)
    return memo[expr]
