"""The system block rewritten for the Taylor series: sums of products with the products of sines
and cosines turned into sines and cosines of sums of angles, when the entries are small.

The derivation writes a pendulum's mass matrix and forces from Cartesian positions, and so
leaves M_12 = m2 l1 l2 (sin θ1 sin θ2 + cos θ1 cos θ2) and forces in which terms cancel
(the double pendulum's v1² sin θ1 cos θ1 in f_1). As numbers this costs nothing; as Taylor
series each product is a Cauchy product at every order. Expanding each entry of K and b
(CSE's intermediates substituted back), applying the product-to-sum identities
2 sin a cos b = sin(a + b) + sin(a - b) and the like (Fu et al.'s rule TR8, sympy.simplify.fu),
and expanding again gives M_12 = m2 l1 l2 cos(θ1 - θ2) and f_1 = -(m1 + m2) g l1 sin θ1
- m2 l1 l2 θ2'² sin(θ1 - θ2): the textbook form, with half the series. Every step is an
identity, so the equations are the same; only where an entry would expand to more than
EXPANDED_TERMS terms is the block kept as it is (no simplification of large expressions).
The graph builder (taylor_graph.series_graph) builds both and keeps the cheaper.
"""
from __future__ import annotations

import sympy
from sympy.simplify.fu import TR8

from .cse import eliminate_common_subexpressions
from .kernel import Block, Store

EXPANDED_TERMS = 200       # the most terms an entry may expand to (an estimate, before expanding)


def rewritten_block(block: Block) -> Block | None:
    """The block with its stores expanded through the product-to-sum identities and CSE'd
    again, or None when an entry is too large to expand."""
    definitions = {sympy.Symbol(name, real=True): expr for name, expr in block.assignments}
    estimates: dict = {}
    values = []
    for store in block.stores:
        if _terms(store.value, definitions, estimates) > EXPANDED_TERMS:
            return None
        inlined = _inlined(store.value, definitions, {})
        values.append(sympy.expand(TR8(sympy.expand(inlined))))
    ordered, reduced = eliminate_common_subexpressions([], values, prefix="e")
    used = set().union(*(value.free_symbols for _, value in ordered), *(value.free_symbols for value in reduced))
    inputs = tuple((name, source) for name, source in block.inputs if sympy.Symbol(name, real=True) in used)
    return Block(inputs, tuple((symbol.name, value) for symbol, value in ordered),
                 tuple(Store(store.array, store.index, value) for store, value in zip(block.stores, reduced)))


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
