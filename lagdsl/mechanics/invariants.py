"""Conserved quantities: momenta of cyclic coordinates and the energy function.

- p_k = ∂L/∂q'_k is conserved when q_k is cyclic (∂L/∂q_k = 0) and nothing else pushes on
  q_k: no force on it, no dissipation through q'_k, and no active constraint involving it
  (a constraint force Σ_j λ_j A_jk would change p_k).
- h = Σ_k q'_k p_k - L obeys dh/dt = -∂L/∂t + Σ_k q'_k (Q_k - ∂D/∂q'_k) + λᵀ A q', so h is
  conserved when ∂L/∂t = 0, there are no forces or dissipation, and every active constraint
  is scleronomic and homogeneous in the velocities (A q' = 0 on the motion, ∂A/∂t = 0).
"""
from __future__ import annotations

import sympy

from .. import ir
from ..calculus import Differentiator
from .equations import ENERGY_CONSERVED, ConservedQuantity, ConstraintEquation
from .probe import Probe


def conserved_quantities(model: ir.Model, calculus: Differentiator, probe: Probe,
                         lagrangian, momenta, gradient, constraints: tuple[ConstraintEquation, ...],
                         energy: sympy.Expr) -> tuple[ConservedQuantity, ...]:
    active = [c for c in constraints if not c.dropped]
    found = []
    forced = {f.coordinate for f in model.forces}
    cyclic = probe.zeros(gradient)
    for k, coordinate in enumerate(model.coordinates):
        if not cyclic[k] or coordinate.name in forced:
            continue
        if model.dissipation is not None and not probe.is_zero(
                calculus.partial(model.dissipation.expression, coordinate.velocity_symbol)):
            continue
        if active and not all(probe.zeros([c.jacobian[k] for c in active])):
            continue
        found.append(ConservedQuantity(f"momentum({coordinate.name})", momenta[k],
                                       f"{coordinate.name} is cyclic"))
    if _energy_conserved(model, calculus, probe, lagrangian, active):
        found.append(ConservedQuantity("energy", energy, ENERGY_CONSERVED))
    return tuple(found)


def _energy_conserved(model, calculus, probe, lagrangian, active) -> bool:
    if model.forces or model.dissipation is not None:
        return False
    checks = [calculus.partial(lagrangian, ir.TIME)]
    for constraint in active:
        velocities = [c.velocity_symbol for c in model.coordinates]
        homogeneous = constraint.velocity_residual - sum(a * v for a, v in zip(constraint.jacobian, velocities))
        checks += [homogeneous] + [calculus.partial(a, ir.TIME) for a in constraint.jacobian]
    return all(probe.zeros(checks))
