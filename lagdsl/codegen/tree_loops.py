"""TreeEquations + ScenePlan -> Kernel: each link's record as loops over the links, solved by
the articulated-body recursion of the tree layout (structure.py, templates/c/model.c.j2).

The system block stores link j's record m_j, s_j, w_j, g_j into K[j·4d ...] and τ_j into b[j],
one loop per run of links of one shape (mechanics/trees.py). The energy is loops too: each
link's r_j and r_j' into a scratch array KINEMATICS, a sweep root to leaves that makes them
P_j = P_parent + r_j and P_j' (kernel.PathSums), and each link's term of h summed from them. The
outputs other than the energy are ordinary blocks over the tree's recursive lets, linear in n.
"""
from __future__ import annotations

import dataclasses

import sympy

from ..mechanics.families import ENERGY, slot
from ..mechanics.trees import POINT, POINT_RATE, TreeEquations
from .kernel import Block, Loop, PathSums
from .loops import LocalLowering
from .structure import MassLayout, tree_layout

KINEMATICS = "kin"      # the outputs' scratch array: link j's P_j at [j·2d ...], P_j' at [j·2d + d ...]


class TreeLowering(LocalLowering):
    """The lowering of kernel.py with the system block made of the links' records."""

    eq: TreeEquations

    def linear_system(self) -> tuple[str, MassLayout]:
        """The recursion solves M; with constraints, the templates' Schur complement A M⁻¹ Aᵀ
        is positive definite while they are independent: Cholesky."""
        return "cholesky", self.mass_layout()

    def mass_layout(self) -> MassLayout:
        return tree_layout(self.eq.parents, self.eq.axes, len(self.active))

    def mass_is_constant(self) -> bool:
        return False

    def system_block(self) -> Block:
        loops = [self.links_loop(links) for links in self.eq.links]
        return self.looped_block(self.constraint_stores(), [loop for loop in loops if loop], cleared=("b", "K"))

    def constraint_stores(self) -> list[tuple[str, tuple[int, ...], sympy.Expr]]:
        """The rows of A, each of n reals after the links' records in K (their nonzero entries:
        those of the joints on the constrained bodies' paths), and γ after the torques in b."""
        n, start = self.n, self.n * self.layout.record
        rows = [("K", (start + i * n + k,), a) for i, c in enumerate(self.active)
                for k, a in enumerate(c.jacobian) if a != 0]
        return rows + [("b", (n + i,), c.gamma) for i, c in enumerate(self.active)]

    def links_loop(self, links):
        """Link records into K (entry (link, field)) and the torques into b."""
        placement = links.placement
        member = (placement.first, placement.step)
        targets = [("K", (member, (field, 0))) for field, value in enumerate(links.record) if value != 0]
        values = [value for value in links.record if value != 0]
        if placement.forcing[0] != 0:
            targets.append(("b", (member,)))
            values.append(placement.forcing[0])
        return self.member_loop(placement, targets, values)

    def outputs_block(self) -> Block:
        """The columns. Where they read the energy, h from the links' loops (module docstring)
        plus U_0; where they read the bodies' P or P' (directly or through other lets), those
        from KINEMATICS after the sweep, not each from the chain of lets to the root."""
        stores = self.output_stores()
        values = [value for _, _, value in stores]
        energy_read = any(ENERGY in value.free_symbols for value in values)
        if not energy_read and not any(s in self.eq.points for s, _ in self.calculus.needed(values)):
            return self.block(stores)
        total = ENERGY + self.eq.energy_shift
        stores = [(array, index, value.xreplace({ENERGY: total})) for array, index, value in stores]
        energy = self.table.names[ENERGY]
        kinematics = [loop for loop in map(self.kinematics_loop, self.eq.links) if loop]
        terms = [self.member_loop(links.placement, [(energy, ())], [links.placement.energy])
                 for links in self.eq.links] if energy_read else []
        read = {s: f"{KINEMATICS}[{k}]" for s, k in self.eq.points.items()}
        block = self.looped_block(stores, kinematics + [loop for loop in terms if loop],
                                  accumulators=(energy,) if energy_read else (), read=read)
        return dataclasses.replace(block, path_sums=PathSums(KINEMATICS, 2 * self.eq.axes, len(kinematics)))

    def kinematics_loop(self, links) -> Loop | None:
        """Each link's own r_j and r_j' = s_j q_j' into KINEMATICS, where the sweep adds its
        parent's P and P' to them."""
        placement, width = links.placement, 2 * self.eq.axes
        targets = [(KINEMATICS, ((placement.first * width + field, placement.step * width),))
                   for field, value in enumerate(links.kinematics) if value != 0]
        return self.member_loop(placement, targets, [value for value in links.kinematics if value != 0])

    def _slot_names(self, stencil, expressions):
        """The slots of kernel.LocalLowering, and a link's P and P' read from KINEMATICS (after
        the sweep) as point<a> and rate<a>."""
        rename, inputs = super()._slot_names(stencil, expressions)
        used = set().union(*(e.free_symbols for e in expressions))
        axes = self.eq.axes
        for part, (kind, name) in enumerate(((POINT, "point"), (POINT_RATE, "rate"))):
            for a in range(axes):
                if slot(kind, a) in used:
                    rename[slot(kind, a)] = sympy.Symbol(f"{name}{a}", real=True)
                    inputs.append((f"{name}{a}", KINEMATICS, (stencil.first * 2 + part) * axes + a,
                                   stencil.step * 2 * axes))
        return rename, inputs
