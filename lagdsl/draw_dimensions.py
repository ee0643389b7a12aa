"""What a `draw` statement's arguments must be in units (dimensions.py checks them): a point's
coordinates, a radius, a size and a box's edges are lengths; an angle and a rotation matrix are
dimensionless. The role of each argument is its kind's (draws.KINDS)."""
from __future__ import annotations

from collections.abc import Iterator

import lark

from .draws import KINDS
from .units import Dimension

LENGTH = Dimension.of(length=1)
# what an argument of each role must be: a dimension and its words
DRAWN = {"point": (LENGTH, "a length"), "points": (LENGTH, "a length"), "length": (LENGTH, "a length"),
         "edges": (LENGTH, "a length"), "angle": (Dimension(), "dimensionless"),
         "rotation": (Dimension(), "dimensionless")}


def drawn_arguments(node: lark.Tree) -> Iterator[tuple[str, str, lark.Tree, lark.Tree | None]]:
    """(role, what it is called in a message, the argument, the range `i in a:b` repeating it or
    None) for each argument and known option of a draw statement of a known kind."""
    kind = KINDS.get(str(node.children[1]))
    if kind is None:
        return
    items: list[tuple[lark.Tree, lark.Tree | None]] = []
    previous = None
    for argument in (c for c in node.children if isinstance(c, lark.Tree) and c.data != "draw_option"):
        if argument.data == "iteration" and previous is not None:
            items[-1] = (previous, argument)
        else:
            items.append((argument, None))
        previous = argument if argument.data != "iteration" else None
    arguments = kind.arguments * len(items) if kind.arguments[0][1] == "points" else kind.arguments
    for (name, role), (argument, iteration) in zip(arguments, items):
        yield role, "a point's coordinate" if "point" in role else f"the {name}", argument, iteration
    options = dict(kind.options)
    for option in (c for c in node.children if isinstance(c, lark.Tree) and c.data == "draw_option"):
        name = str(option.children[0])
        if name in options:
            yield options[name], f"the {name}", option.children[2], None
