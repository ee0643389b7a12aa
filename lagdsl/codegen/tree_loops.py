"""TreeEquations + ScenePlan -> Kernel: each link's record as loops over the links, solved by
the articulated-body recursion of the tree layout (structure.py, templates/c/model.c.j2).

The system block stores link j's record m_j, s_j, w_j, g_j into K[j·4d ...] and τ_j into b[j],
one loop per run of links of one shape (mechanics/trees.py); the outputs and the energy are
ordinary blocks over the tree's recursive lets (P_j = P_parent + r_j), linear in n.
"""
from __future__ import annotations

from ..mechanics.trees import TreeEquations
from .kernel import Block, _Lowering
from .loops import LocalLowering
from .structure import MassLayout, tree_layout


class TreeLowering(LocalLowering):
    """The lowering of kernel.py with the system block made of the links' records."""

    eq: TreeEquations

    def mass_layout(self) -> MassLayout:
        return tree_layout(self.eq.parents, self.eq.axes)

    def mass_is_constant(self) -> bool:
        return False

    def system_block(self) -> Block:
        loops = [self.links_loop(links) for links in self.eq.links]
        return self.looped_block([], [loop for loop in loops if loop], cleared=("b", "K"))

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
        return _Lowering.outputs_block(self)
