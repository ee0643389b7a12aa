"""The Taylor series of LAG_LANES members at once, for the sweep's taylor in lanes
(integrators/c/taylor_lanes.c; templates/c/taylor_lanes.c.j2).

Built from the statements of the scalar series (c_taylor.series_context): order 0 of each member
(its sines and cosines are libm calls, its K factored and inverted) runs member by member, the
scalar statements with the member's inputs; each order k >= 1 is the straight-line order of
c_taylor_straight.py, every coefficient s[i][k] becoming the array s[i][k][l] of the lanes and
every statement the same, inside one loop over the lanes that the compiler vectorises. A lane
computes what the scalar series computes, operation for operation and in the same order, so a
member's series equals its scalar series bit for bit (C99: no fma contraction, no reassociation).

Offered where the scalar series is the simple one: K factored in the compact layout (lag_factor)
with its inverse formed at order 0, and every order of a double build written out.
"""
from __future__ import annotations

import re

from . import template_environment
from .c_taylor import DOUBLE_DIGITS, MAX_ORDER, max_order, series_context

COEFFICIENT = re.compile(r"\bs\[(\d+)\]\[(\d+)\]")
RIGHT_SIDE = re.compile(r"\br\[(\d+)\]")
CONSTANT = re.compile(r"\bc->(\w+)")


def lane_statement(line: str) -> str:
    """A statement of a straight-line order with each coefficient, entry of r and constant read
    from lane l: s[5][2] -> s[5][2][l], r[0] -> r[0][l], c->e3 -> c->e3[l]."""
    line = COEFFICIENT.sub(r"s[\1][\2][l]", line)
    line = RIGHT_SIDE.sub(r"r[\1][l]", line)
    return CONSTANT.sub(r"c->\1[l]", line)


def lane_input(source: str) -> str:
    """"par[3]" -> "par[3][l]": the input of lane l."""
    return f"{source}[l]"


def lane_series(kernel, printer, positions: list[str]) -> dict | None:
    """{"series": lag_lane_taylor_series and its pieces for kernel.system, "switch": the C condition
    for LAG_HAS_LANES}, or None where the series is not the simple one (another solver, no inverse,
    orders that keep their loops). The switch holds in a double build, whose every order the lanes
    write out, not in an extended-precision one (whose sweep runs member by member)."""
    context = series_context(kernel, printer, positions)
    straight = context["taylor_straight"]
    if (context["taylor_solver"] != "compact" or not context["taylor_inverse"]
            or len(straight) < max_order(DOUBLE_DIGITS) - 1):
        return None
    lanes = {
        "lane_inputs": [(name, lane_input(source)) for name, source in context["taylor_inputs"]],
        "lane_straight": [(k, [lane_statement(line) for line in prologue], [lane_statement(line) for line in lines])
                          for k, prologue, lines in straight]}
    return {"series": template_environment().get_template("c/taylor_lanes.c.j2").render({**context, **lanes}),
            "switch": f"({MAX_ORDER} - 1 <= {len(straight)})"}
