"""Prefix sums kept as recurrences.

An indexed let whose value is a sum up to its own index,

    let x[i] = ±sum(f(j), j in a:i), i in lo:hi;

(the positions of a chain of links, models/pendulum_chain.lag) would unroll to n²/2 terms, and
its time derivatives and their squares in T after it. Each member after the first is the
previous member plus one term instead,

    x[i] = x[i-1] ± f(i),

which is the same value (x[i-1] is the intermediate holding the sum up to i-1): n terms in all,
and der(x[i]) = der(x[i-1]) ± der(f(i)) by the chain rule through the intermediates. The tree
layout (mechanics/trees.py) reads the chain from these references; the expanded derivation
writes each sum out again (ir.Model.written_out_lets), so its equations are those of the
unrolled sum.

The recurrence is used only where it is plainly the same sum: f and a do not use i, f does not
use x, the bound j is not i, and the new term is not a number (a sum of numbers is folded and
checked as the unrolled sum is).
"""
from __future__ import annotations

from dataclasses import dataclass

import lark
import sympy

from .tree import call_arguments, signed_terms
from .values import Vector, is_array, kind_of, matrix_of


@dataclass(frozen=True)
class PrefixSum:
    """`sign * sum(term, variable in low:i)`: the parts of a let's body that is a prefix sum."""

    sign: int
    term: lark.Tree
    variable: str
    range_node: lark.Tree


def prefix_sum(body: lark.Tree, index: str, family: str) -> PrefixSum | None:
    """The prefix sum that `body` (of the let family `family`, indexed by `index`) is, or None."""
    terms = signed_terms(body)
    if len(terms) != 1:
        return None
    sign, call = terms[0]
    if not isinstance(call, lark.Tree) or call.data != "call" or str(call.children[0]) != "sum":
        return None
    arguments = call_arguments(call)
    if len(arguments) != 2 or arguments[1].data != "iteration":
        return None
    term, (variable, _, range_node) = arguments[0], arguments[1].children
    low, _, high = range_node.children
    if str(variable) == index or not _is_name(high, index) or _uses(low, index) \
            or _uses(term, index) or _uses(term, family):
        return None
    return PrefixSum(sign, term, str(variable), range_node)


def _is_name(node, name: str) -> bool:
    return isinstance(node, lark.Tree) and node.data == "name" and str(node.children[0]) == name


def _uses(node: lark.Tree, name: str) -> bool:
    """Does the expression mention `name` (as a name, or as the family of an index)?"""
    return any(n.data in ("name", "index") and str(n.children[0]) == name for n in node.iter_subtrees())


def next_member(previous, term, sign: int):
    """previous ± term, componentwise for vectors and matrices; None where the unrolled sum must
    be built instead (kinds that differ, a term that is a number)."""
    if kind_of(previous) != kind_of(term):
        return None
    components = term.components if is_array(term) else (term,)
    if all(c.is_number for c in components):
        return None
    if not is_array(term):
        return previous + sign * term
    total = [p + sign * t for p, t in zip(previous.components, components)]
    return Vector(tuple(total)) if isinstance(term, Vector) else matrix_of(total)


def previous_members(previous, member) -> dict[sympy.Symbol, sympy.Symbol]:
    """Each intermediate of `member` -> the intermediate of `previous` it extends."""
    if is_array(member):
        return dict(zip(member.components, previous.components))
    return {member: previous}
