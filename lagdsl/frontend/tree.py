"""The parse tree as the front end reads it: where a node is, and the parts of statements and
expressions (the node names are grammar.lark's aliases).

Every module that walks or inspects the tree (semantics.py, expressions.py, the dimension checks)
reads it through these helpers, so the shape of the grammar is known in one place.
"""
from __future__ import annotations

import lark

from ..source import SourceFile, Span

SHORT_TEXT = 40     # longest expression quoted in a message; a longer one is named in words
ARITHMETIC = ("number", "neg", "pos", "parenthesized", "add", "sub", "mul", "div", "pow")


def span_of(node, source: SourceFile) -> Span:
    """The source region of a tree node or a token."""
    if isinstance(node, lark.Token):
        return Span(source, node.line, node.column, node.start_pos, node.end_pos)
    meta = node.meta
    return Span(source, meta.line, meta.column, meta.start_pos, meta.end_pos)


def through(first: Span, last: Span) -> Span:
    """The span from the start of `first` to the end of `last`."""
    return Span(first.source, first.line, first.column, first.start, last.end)


def written(span: Span) -> str:
    """The text of a span on one line, as a message quotes it."""
    return " ".join(span.text.split())


def excerpt(span: Span, otherwise: str, quote: bool = False) -> str:
    """The text of a short span (quoted when `quote`), or `otherwise` for a long one."""
    text = written(span)
    if len(text) > SHORT_TEXT:
        return otherwise
    return f"'{text}'" if quote else text


def tokens(node: lark.Tree, kind: str) -> list[lark.Token]:
    return [c for c in node.children if isinstance(c, lark.Token) and c.type == kind]


def subtree(node: lark.Tree, data: str) -> lark.Tree | None:
    return next((c for c in node.children if isinstance(c, lark.Tree) and c.data == data), None)


def subtrees(node: lark.Tree) -> list[lark.Tree]:
    """The children of a node that are trees (the items of a list, the statements of a scene)."""
    return [c for c in node.children if isinstance(c, lark.Tree)]


def expressions_of(node: lark.Tree) -> list:
    """The expression children of a statement (everything but tokens and annotations)."""
    skip = {"unit", "description", "modifiers", "dimension", "let_index", "let_range"}
    return [c for c in node.children if isinstance(c, lark.Tree) and c.data not in skip]


def call_arguments(node: lark.Tree) -> list[lark.Tree]:
    """The arguments of a call node f(a, b), in order."""
    arguments = subtree(node, "arguments")
    return subtrees(arguments) if arguments is not None else []


def modifier_items(node: lark.Tree) -> list[tuple[lark.Token, lark.Tree]]:
    """The (key, value) pairs of a statement's `(key = value, ...)` block, as written."""
    block = subtree(node, "modifiers")
    return [(m.children[0], m.children[2]) for m in (subtrees(block) if block is not None else [])
            if m.data == "modifier"]


def uses_names(node: lark.Tree, *numbers: str) -> bool:
    """Does the expression use a name other than pi and `numbers` (an index bound to a number)?
    If not, it is a plain number."""
    return any(n.data in ("name", "index") and str(n.children[0]) not in ("pi", *numbers)
               for n in node.iter_subtrees())


def is_numeral(node: lark.Tree) -> bool:
    """Is the expression written with numbers and arithmetic only (2, -1, (1/2), 3/2, 2^3), so
    that it has one value wherever it stands (an exponent, an index)?"""
    return all(n.data in ARITHMETIC for n in node.iter_subtrees())


def signed_terms(node) -> list[tuple[int, lark.Tree]]:
    """The terms of a sum, in source order, each with its sign (+1 or -1).

    Walked iteratively: the grammar makes `a + b + c` a left-deep tree, so a 330-term sum (or 500
    nested parentheses or unary minuses) would otherwise exhaust Python's recursion limit."""
    terms, pending = [], [(1, node)]
    while pending:
        sign, node = pending.pop()
        kind = node.data if isinstance(node, lark.Tree) else None
        if kind in ("add", "sub"):
            left, _, right = node.children
            pending.append((sign if kind == "add" else -sign, right))
            pending.append((sign, left))
        elif kind in ("pos", "neg", "parenthesized"):
            pending.append((-sign if kind == "neg" else sign, node.children[1]))
        else:
            terms.append((sign, node))
    return terms


def factors(node) -> list[tuple[lark.Tree, bool]]:
    """The factors of a product chain a*b/c in source order, each with `divides` (it is a divisor).

    Only the chain itself is flattened, not parentheses: in a/(b/c) the c divides b, and a
    division by zero there must still be reported.
    """
    found = []
    while node.data in ("mul", "div"):
        left, _, right = node.children
        found.append((right, node.data == "div"))
        node = left
    found.append((node, False))
    return found[::-1]
