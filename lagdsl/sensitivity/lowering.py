"""The generated functions forward sensitivities need, besides those of the equations of motion.

With R(q, q', q'', λ, p) = [f - M q'' + Aᵀλ; γ - A q''] the residual of the equations of motion
(codegen/kernel.py), the trajectory's derivative S = ∂y/∂p = (∂q/∂p, ∂q'/∂p) by a parameter p
obeys the variational equations, R's total derivative by p along the motion:

    Dq Sq + Dv Sv + Dz (Sq'', Sλ) + Dp = 0,   i.e.   K (Sq'', Sλ) = Dq Sq + Dv Sv + Dp,

K = -Dz the matrix of the equations' own linear system (M without constraints). Dq, Dv and Dz
are the jacobian block radau5 already uses; this lowering adds, from the same symbolic
equations and by the same chain rule through their intermediates (calculus.Differentiator,
with the parameters among the independent symbols, as linear/symbolic.py takes B_q = ∂R/∂u):

    Dp = ∂R/∂p                      the variational equations' forcing
    Cy = ∂h/∂y, Cl = ∂h/∂λ, Cp = ∂h/∂p   the output columns' derivatives (variational.py)
    S0 = ∂y0/∂p                     start values written in terms of the parameters

for every parameter of the model (a few numbers per entry: which parameters a run follows is
chosen at run time, sensitivity/run.py). K is never inverted: the generated code solves with it.
"""
from __future__ import annotations

from dataclasses import replace

import sympy

from .. import ir
from ..calculus import Differentiator
from ..codegen.kernel import Kernel, _Lowering
from ..mechanics import Equations
from ..mechanics.families import expanded
from ..scene import ScenePlan


class SensitivityLowering(_Lowering):
    """The kernel of an implicit integrator (with its jacobian block), and Dp, Cy, Cp, S0."""

    def differentiator(self) -> Differentiator:
        eq = self.eq
        return Differentiator(eq.intermediates, (*eq.coordinates, *eq.velocities, ir.TIME,
                                                 *(p.symbol for p in eq.model.parameters)))

    def kernel(self) -> Kernel:
        return replace(super().kernel(), parameter_jacobian=self.parameter_jacobian(),
                       output_jacobian=self.output_jacobian(), initial_sensitivity=self.initial_sensitivity())

    def parameter_stores(self, array: str, rows, values) -> list:
        """∂value/∂p of each value, stored as array[row, j] for parameter j (nonzero ones only)."""
        symbols = [p.symbol for p in self.model.parameters]
        stores = [(array, (row, j), self.calculus.partial(value, p))
                  for row, value in zip(rows, values) for j, p in enumerate(symbols)
                  if p in self.calculus.dependencies(value)]
        return [store for store in stores if store[2] != 0]

    def parameter_jacobian(self):
        residuals = self.residuals()
        return self.block(self.parameter_stores("Dp", range(len(residuals)), residuals))

    def output_jacobian(self):
        """Cy = ∂h/∂y, Cl = ∂h/∂λ (the multipliers appear in outputs as themselves, never in an
        intermediate) and Cp = ∂h/∂p of the scene's columns."""
        outputs = [value for _, _, value in self.output_stores()[:len(self.plan.outputs)]]
        state = (*self.eq.coordinates, *self.eq.velocities)
        stores = [("Cy", (c, k), self.calculus.partial(h, x)) for c, h in enumerate(outputs)
                  for k, x in enumerate(state) if x in self.calculus.dependencies(h)]
        stores += [("Cl", (c, i), sympy.diff(h, lam)) for c, h in enumerate(outputs)
                   for i, lam in enumerate(self.multipliers) if lam in h.free_symbols]
        rows = range(len(outputs))
        return self.block([s for s in stores if s[2] != 0] + self.parameter_stores("Cp", rows, outputs))

    def initial_sensitivity(self):
        stores = self.initial_stores()
        return self.block(self.parameter_stores("S0", [index[0] for _, index, _ in stores],
                                                [value for _, _, value in stores]))


def lower_for_sensitivities(equations: Equations, plan: ScenePlan) -> Kernel:
    """The kernel of `plan` (an implicit integrator's, so with Dq, Dv, Dz) with Dp, Cy, Cl, Cp, S0."""
    return SensitivityLowering(expanded(equations), plan).kernel()
