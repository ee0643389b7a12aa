"""The model's right-hand side over SIMD lanes: the system block for LAG_LANES members at once.

The sweep's lane path (integrators/c/dop853_lanes.c) evaluates f for LAG_LANES members side by
side, entry [i][l] of each array for member l. Every statement is printed exactly as in the
scalar lag_assemble (so each lane computes the same operations in the same order, bit for bit),
inside loops over the lanes that the compiler vectorises. A call into libm (r_sin, r_pow, ...)
keeps a loop from vectorising (there is no vector libm without -ffast-math, and its results
would differ from the scalar path's), so the statements are scheduled into alternating groups:
arithmetic, then the calls whose arguments are ready, then the arithmetic that reads them, ...;
each group is one loop over the lanes, and a value that a later group reads is kept in an array
of the lanes. r_sqrt is arithmetic: it is one instruction (-fno-math-errno) and vectorises.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from .kernel import Block

LIBM_CALL = re.compile(r"\br_(?!sqrt\()\w+\(")


@dataclass(frozen=True)
class LaneGroup:
    """One loop over the lanes: the names it reads from earlier groups or the inputs, its
    statements (target, value; a target without [ is a new temporary) and the temporaries it
    keeps for later groups."""

    reads: tuple[tuple[str, str], ...]        # (name, lane source such as "y[0][l]")
    statements: tuple[tuple[str, str], ...]
    keeps: tuple[str, ...]


def lane_groups(block: Block, printed: dict) -> tuple[tuple[str, ...], tuple[LaneGroup, ...]]:
    """(the temporaries kept across groups, the groups) of a block without loops, `printed` being
    its printed form (codegen.c._print_block: assignments and stores as C text)."""
    inputs = {"t": "t_lanes[l]", **{name: _lane_source(source) for name, source in block.inputs}}
    statements = [(name, text, {s.name for s in value.free_symbols})
                  for (name, text), (_, value) in zip(printed["assignments"], block.assignments)]
    statements += [(_lane_source(target), text, {s.name for s in store.value.free_symbols})
                   for (target, text), store in zip(printed["stores"], _printed_stores(block))]
    group_of: dict[str, int] = {}
    placed: list[tuple[int, str, str, set[str]]] = []
    for target, text, reads in statements:
        base = max((group_of[name] for name in reads if name in group_of), default=0)
        call = bool(LIBM_CALL.search(text))
        group = base + (base % 2 != int(call))       # arithmetic in even groups, calls in odd ones
        group_of[target] = group
        placed.append((group, target, text, reads))
    kept = [name for name in group_of
            if any(name in reads and group_of[name] < group for group, _, _, reads in placed)]
    groups = []
    for number in sorted({group for group, *_ in placed}):
        members = [(target, text, reads) for group, target, text, reads in placed if group == number]
        defined = {target for target, _, _ in members}
        needed = {name for _, _, reads in members for name in reads} - defined
        reads = tuple((name, inputs[name]) for name in inputs if name in needed)
        reads += tuple((name, f"{name}_lanes[l]") for name in kept if name in needed)
        groups.append(LaneGroup(reads, tuple((target, text) for target, text, _ in members),
                                tuple(target for target, _, _ in members if target in kept)))
    return tuple(kept), tuple(groups)


def _printed_stores(block: Block):
    """The stores codegen.c._print_block prints (it leaves out a cleared array's zeros)."""
    from .c import CLEARED
    return [s for s in block.stores if not (s.array in CLEARED and s.value == 0)]


def _lane_source(source: str) -> str:
    """"y[3]" -> "y[3][l]": the entry of lane l."""
    return f"{source}[l]"
