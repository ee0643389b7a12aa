"""The Taylor series of LAG_LANES members at once, for the sweep's taylor in lanes
(integrators/c/taylor_lanes.c; templates/c/taylor_lanes.c.j2).

Built from the statements of the scalar series (c_taylor.series_context): order 0 runs in one loop
over the lanes, the scalar statements with lag_sin_near and lag_cos_near for the series' own lag_sin
and lag_cos (integrators/c/taylor_functions.c: the same arithmetic, NaN beyond their range, where
the lane takes the scalar statements instead), then each member's K is factored and inverted member
by member; each order k >= 1 is the straight-line order of
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
from .c_taylor import DOUBLE_DIGITS, MAX_ORDER, max_order

# Vector registers per row of the lanes (LAG_LANES = VECTORS x the doubles of one): each order of
# the series depends on the last, so with one register per statement the statements of an order wait
# on each other's latency; two independent halves overlap (10^4 double pendulums: 0.65 s against
# 0.95 s of CPU, benchmarks/README.md), and more bring no more.
VECTORS = 2
VECTORS_WHY = "each order of the series waits on the last; two independent halves overlap"
COEFFICIENT = re.compile(r"\bs\[(\d+)\]\[(\d+)\]")
RIGHT_SIDE = re.compile(r"\br\[(\d+)\]")
CONSTANT = re.compile(r"\bc->(\w+)")
MATRIX = re.compile(r"\bK\[(\d+)\]")
TRIGONOMETRY = re.compile(r"\blag_(sin|cos)\(")


def lane_statement(line: str) -> str:
    """A statement of a straight-line order with each coefficient, entry of r and constant read
    from lane l: s[5][2] -> s[5][2][l], r[0] -> r[0][l], c->e3 -> c->e3[l]."""
    line = COEFFICIENT.sub(r"s[\1][\2][l]", line)
    line = RIGHT_SIDE.sub(r"r[\1][l]", line)
    line = MATRIX.sub(r"K[\1][l]", line)
    return CONSTANT.sub(r"c->\1[l]", line)


def lane_zeroth(line: str) -> str:
    """A statement of order 0 in lane l, a row's lag_sin and lag_cos as lag_sin_near and lag_cos_near
    (a row that is not finite sends the lane to the scalar statements; any other statement keeps
    them, and its loop may then not vectorise)."""
    line = lane_statement(line)
    return TRIGONOMETRY.sub(r"lag_\1_near(", line) if line.startswith("s[") else line


def lane_input(source: str) -> str:
    """"par[3]" -> "par[3][l]": the input of lane l."""
    return f"{source}[l]"


def lane_series(context: dict) -> dict | None:
    """{"series": lag_lane_taylor_series and its pieces, from the statements of the scalar series
    (`context`: c_taylor.series_context), "switch": the C condition
    for LAG_HAS_LANES}, or None where the series is not the simple one (another solver, no inverse,
    orders that keep their loops). The switch holds in a double build, whose every order the lanes
    write out, not in an extended-precision one (whose sweep runs member by member)."""
    straight = context["taylor_straight"]
    if (context["taylor_solver"] != "compact" or not context["taylor_inverse"]
            or len(straight) < max_order(DOUBLE_DIGITS) - 1):
        return None
    lanes = {
        "lane_inputs": [(name, lane_input(source)) for name, source in context["taylor_inputs"]],
        "lane_zeroth": [lane_zeroth(line) for line in context["taylor_zeroth"]],
        "lane_rhs_zero": [lane_statement(line) for line in context["taylor_rhs_zero"]],
        "lane_assemble": [lane_statement(line) for line in context["taylor_assemble"]],
        "lane_straight": [(k, [lane_statement(line) for line in prologue], [lane_statement(line) for line in lines])
                          for k, prologue, lines in straight]}
    return {"series": template_environment().get_template("c/taylor_lanes.c.j2").render({**context, **lanes}),
            "switch": f"({MAX_ORDER} - 1 <= {len(straight)})", "vectors": VECTORS, "vectors_why": VECTORS_WHY}
