"""Common-subexpression elimination over a straight-line block, deterministically.

The block's assignments (named intermediates, in dependency order) and its stores are passed
to sympy.cse together, so a subexpression shared by an intermediate and an output becomes one
temporary. The result is re-ordered so that each assignment comes right before its first
use, which keeps generated code readable and keeps live ranges short. The same input always
gives the same temporaries in the same order.
"""
from __future__ import annotations

from collections.abc import Sequence

import sympy


def eliminate_common_subexpressions(assignments: Sequence[tuple[sympy.Symbol, sympy.Expr]],
                                    values: Sequence[sympy.Expr], prefix: str = "c"):
    """-> (assignments in use order, reduced values)."""
    expressions = [e for _, e in assignments] + list(values)
    taken = {s.name for e in expressions for s in e.free_symbols} | {s.name for s, _ in assignments}
    fresh = (sympy.Symbol(f"{prefix}{i}", real=True) for i in range(10**9) if f"{prefix}{i}" not in taken)
    replacements, reduced = sympy.cse(expressions, symbols=fresh, order="none")
    named = [(symbol, reduced[i]) for i, (symbol, _) in enumerate(assignments)]
    outputs = reduced[len(assignments):]
    ordered = order_by_first_use(list(replacements) + named, outputs)
    return ordered, outputs


def order_by_first_use(assignments, roots):
    """Topological order of `assignments`, each placed just before the first root that needs it.

    Assignments that no root needs are dropped.
    """
    definition = dict(assignments)

    def needs(expr):
        return sorted((s for s in expr.free_symbols if s in definition), key=sympy.default_sort_key)

    emitted: set = set()
    order = []
    for root in roots:
        stack = [(symbol, False) for symbol in reversed(needs(root))]
        while stack:
            symbol, ready = stack.pop()
            if symbol in emitted:
                continue
            if ready:
                emitted.add(symbol)
                order.append((symbol, definition[symbol]))
                continue
            stack.append((symbol, True))
            stack.extend((s, False) for s in reversed(needs(definition[symbol])) if s not in emitted)
    return order
