"""LocalEquations + ScenePlan -> Kernel: M, f and the energy as loops over stencils.

The local form of a large model (mechanics/families.py) gives, for each stencil, the
contributions of one member to f, M and the energy h in slot symbols. Each becomes one Loop:
its slots are read from y (and from par, for members of parameter arrays) at
offset + stride·i, its expressions are reduced by common-subexpression elimination once,
for the shape, and its results are added into b, K or an accumulator. The code grows with the
number of shapes, not with the number of coordinates.

Everything else (the initial state, the outputs other than the energy, the stop condition) is
lowered as in kernel.py.
"""
from __future__ import annotations

import sympy

from .. import ir
from ..mechanics.families import ENERGY, PARAMETER, POSITION, VELOCITY, LocalEquations, Stencil
from .cse import eliminate_common_subexpressions
from .kernel import JACOBIAN_ARRAYS, Block, Loop, _Lowering
from .structure import JacobianLayout, MassLayout, jacobian_layout, local_layout

LOOPS = "loops"         # the source of a value the block's loops compute


class LocalLowering(_Lowering):
    """The lowering of kernel.py with the system block and the energy taken from the stencils."""

    def __init__(self, equations: LocalEquations, plan):
        super().__init__(equations, plan)
        self.table.sources[ENERGY] = LOOPS
        self.table.claim(ENERGY, "energy")

    def mass_layout(self) -> MassLayout:
        return local_layout(self.n, self.eq.bandwidth)

    def system_block(self) -> Block:
        return self.stencils_block(("b", "K"))

    def mass_block(self) -> Block:
        return self.stencils_block(("K",))

    def forces_block(self) -> Block:
        return self.stencils_block(("b",))

    def mass_is_constant(self) -> bool:
        return mass_is_constant(self.eq)

    def jacobian_block(self) -> tuple[Block, JacobianLayout]:
        """Dq, Dv and Dz = -M (M is constant here) from the stencils: each member's forcing
        differentiated by its own slots, in a band as wide as the widest stencil."""
        loops = [loop for stencil in self.eq.stencils for loop in [self.jacobian_loop(stencil)] if loop]
        reach = max([self.eq.bandwidth, *(max(s.offsets) - min(s.offsets) for s in self.eq.stencils)])
        layout = jacobian_layout(self.n, False, {(reach, 0), (0, reach)})
        return self.looped_block([], loops, cleared=JACOBIAN_ARRAYS), layout

    def jacobian_loop(self, stencil: Stencil) -> Loop | None:
        targets, values = [], []
        for a, force in enumerate(stencil.forcing):
            for b, offset in enumerate(stencil.offsets):
                for array, kind in (("Dq", POSITION), ("Dv", VELOCITY)):
                    slope = force.diff(sympy.Symbol(f"{kind}{offset}", real=True)) if force != 0 else 0
                    if slope != 0:
                        targets.append((array, (self._member(stencil, a), self._member(stencil, b))))
                        values.append(slope)
        for a, b, entry in stencil.mass:
            for row, column in [(a, b), (b, a)][:1 if a == b else 2]:
                targets.append(("Dz", (self._member(stencil, row), self._member(stencil, column))))
                values.append(-entry)
        return self.member_loop(stencil, targets, values)

    def stencils_block(self, arrays: tuple[str, ...]) -> Block:
        """The stencils' contributions to the arrays named (b, K or both), each array zeroed first."""
        loops = [loop for stencil in self.eq.stencils for loop in [self.stencil_loop(stencil, arrays)] if loop]
        return self.looped_block([], loops, cleared=arrays)

    def outputs_block(self) -> Block:
        stores = self.output_stores()
        if not any(ENERGY in value.free_symbols for _, _, value in stores):
            return self.block(stores)
        loops = [loop for stencil in self.eq.stencils for loop in [self.stencil_loop(stencil, ("energy",))] if loop]
        return self.looped_block(stores, loops, accumulators=(self.table.names[ENERGY],))

    def looped_block(self, stores, loops: list[Loop], cleared=(), accumulators=(), read=None) -> Block:
        """A block whose loops run first; the inputs are the plain part's (`read`: as in
        kernel.py's block) and those the loop bodies read outside y and par (scalar parameters,
        in the order of par)."""
        plain = self.block(stores, read) if stores else Block((), (), ())
        inputs = {name: source for name, source in plain.inputs if source != LOOPS}
        read = {x.name for loop in loops for value in (*(v for _, v in loop.assignments),
                                                       *(v for _, _, v in loop.stores)) for x in value.free_symbols}
        for symbol, source in self.table.sources.items():
            if self.table.names.get(symbol) in read and source not in (LOOPS, "t"):
                inputs[self.table.names[symbol]] = source
        order = {name: self.table.input_order(symbol) for symbol, name in self.table.names.items()}
        return Block(tuple(sorted(inputs.items(), key=lambda item: order.get(item[0], (9, 0)))),
                     plain.assignments, plain.stores, tuple(loops), accumulators, cleared)

    def stencil_loop(self, stencil: Stencil, arrays: tuple[str, ...]) -> Loop | None:
        """The loop of one stencil: its contributions to the arrays named, among b, K and the
        energy ("energy")."""
        targets, values = [], []
        if "b" in arrays:
            for a, value in enumerate(stencil.forcing):
                if value != 0:
                    targets.append(("b", (self._member(stencil, a),)))
                    values.append(value)
        if "K" in arrays:
            for a, b, value in stencil.mass:
                targets.append(("K", (self._member(stencil, a), self._member(stencil, b))))
                values.append(value)
        if "energy" in arrays and stencil.energy != 0:
            targets.append((self.table.names[ENERGY], ()))
            values.append(stencil.energy)
        return self.member_loop(stencil, targets, values)

    def member_loop(self, stencil: Stencil, targets, values: list[sympy.Expr]) -> Loop | None:
        """The loop over the stencil's members that adds each value into its target."""
        if not values:
            return None
        bases, values = name_power_bases(values)
        ordered, reduced = eliminate_common_subexpressions(bases, values, prefix="s")
        rename, inputs = self._slot_names(stencil, [*values, *(e for _, e in ordered)])
        rename.update({s: sympy.Symbol(s.name, real=True) for s, _ in ordered})
        rename.update({s: sympy.Symbol(self.table.names[s], real=True) for e in values for s in e.free_symbols
                       if s in self.table.names})
        return Loop(stencil.count, tuple(inputs),
                    tuple((rename[s].name, e.xreplace(rename)) for s, e in ordered),
                    tuple((array, index, value.xreplace(rename)) for (array, index), value in zip(targets, reduced)))

    @staticmethod
    def _member(stencil: Stencil, a: int) -> tuple[int, int]:
        """(offset, stride) of slot a's coordinate over the members."""
        return stencil.first + stencil.offsets[a], stencil.step

    def _slot_names(self, stencil: Stencil, expressions):
        """Slot symbol -> its name in the loop (x<offset>, v<offset>, pm<offset>), and the loop's
        inputs (name, array, offset, stride) for the slots the expressions use."""
        used = set().union(*(e.free_symbols for e in expressions))
        rename, inputs = {}, []
        for a, offset in enumerate(stencil.offsets):
            first = stencil.first + offset
            for kind, name, start in ((POSITION, "x", first), (VELOCITY, "v", self.n + first)):
                symbol = sympy.Symbol(f"{kind}{offset}", real=True)
                if symbol in used:
                    rename[symbol] = sympy.Symbol(f"{name}{offset}", real=True)
                    inputs.append((f"{name}{offset}", "y", start, stencil.step))
        for offset in stencil.parameter_offsets:
            symbol = sympy.Symbol(f"{PARAMETER}{offset}", real=True)
            if symbol in used:
                rename[symbol] = sympy.Symbol(f"pm{offset}", real=True)
                inputs.append((f"pm{offset}", "par", stencil.parameter_first + offset, stencil.parameter_step))
        return rename, inputs


def mass_is_constant(equations: LocalEquations) -> bool:
    """No stencil's M reads a position, a velocity or the time."""
    return not any(symbol == ir.TIME or symbol.name.startswith((POSITION, VELOCITY))
                   for stencil in equations.stencils for _, _, entry in stencil.mass
                   for symbol in entry.free_symbols)


def name_power_bases(values: list[sympy.Expr]) -> tuple[list[tuple[sympy.Symbol, sympy.Expr]], list[sympy.Expr]]:
    """Name the compound bases of small integer powers, (x1 - x0)^3 -> b0^3 with b0 = x1 - x0, so
    that the printers write b0*b0*b0 rather than a call of pow() in the loop body."""
    named: dict[sympy.Expr, sympy.Symbol] = {}

    def small_power(e) -> bool:
        return e.is_Pow and e.exp.is_Integer and 2 <= abs(int(e.exp)) <= 4 and not e.base.is_Symbol

    def rename(e):
        base = named.setdefault(e.base, sympy.Symbol(f"b{len(named)}", real=True))
        return sympy.Pow(base, e.exp)

    rewritten = [value.replace(small_power, rename) for value in values]
    return [(symbol, base) for base, symbol in named.items()], rewritten
