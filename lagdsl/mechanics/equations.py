"""The Euler-Lagrange equations in mass-matrix form.

For each coordinate q_k, with p_k = ∂L/∂q'_k,

    d/dt(∂L/∂q'_k) - ∂L/∂q_k = Q_k - ∂D/∂q'_k + Σ_j λ_j A_jk,

and d/dt p_k = Σ_j (∂p_k/∂q'_j) q''_j + [Σ_j (∂p_k/∂q_j) q'_j + ∂p_k/∂t], so

    M(q, q', t) q'' = f(q, q', t) + Aᵀλ,   M_kj = ∂²L/∂q'_k∂q'_j,
    f_k = ∂L/∂q_k - Σ_j (∂p_k/∂q_j) q'_j - ∂p_k/∂t + Q_k - ∂D/∂q'_k.

The bracket is one directional derivative of p_k along (q', 1) (`calculus.time_rates`), so f
costs one pass per coordinate, not one per pair. M is never inverted: the generated code
solves M q'' = f (or the saddle-point system with the constraint rows) numerically.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from .. import ir
from ..calculus import TIME_DIRECTION, Differentiator, time_rates


@dataclass(frozen=True)
class ConstraintEquation:
    """A constraint at the three levels the solver needs.

    holonomic g(q, t) = 0:       residual g, velocity residual A q' + ∂g/∂t, A = ∂g/∂q
    nonholonomic A q' + b = 0:   residual and velocity residual both A q' + b, A = ∂c/∂q'
    In both cases the acceleration row is A q'' = gamma, gamma = -(d/dt velocity residual at q'' = 0).
    """

    name: str
    kind: str                              # "holonomic" or "nonholonomic"
    dropped: bool                          # identically satisfied by the coordinates
    residual: sympy.Expr
    velocity_residual: sympy.Expr
    jacobian: tuple[sympy.Expr, ...]       # the row A_k
    gamma: sympy.Expr
    span: object


@dataclass(frozen=True)
class ConservedQuantity:
    name: str                              # "energy" or "momentum(q)"
    expression: sympy.Expr
    reason: str


@dataclass(frozen=True)
class Equations:
    """M(q, q', t) q'' = f(q, q', t) (+ Aᵀλ, A q'' = gamma), over shared intermediates."""

    model: ir.Model
    coordinates: tuple[sympy.Symbol, ...]
    velocities: tuple[sympy.Symbol, ...]
    intermediates: tuple[tuple[sympy.Symbol, sympy.Expr], ...]
    lagrangian: sympy.Symbol
    mass_matrix: tuple[tuple[sympy.Expr, ...], ...]
    forcing: tuple[sympy.Expr, ...]
    lagrangian_gradient: tuple[sympy.Expr, ...]     # ∂L/∂q_k
    generalized_forces: tuple[sympy.Expr, ...]      # Q_k - ∂D/∂q'_k
    momenta: tuple[sympy.Expr, ...]
    energy: sympy.Expr                              # h = Σ q'_k p_k - L
    constraints: tuple[ConstraintEquation, ...]
    conserved: tuple[ConservedQuantity, ...]

    @property
    def size(self) -> int:
        return len(self.coordinates)

    @property
    def active_constraints(self) -> tuple[ConstraintEquation, ...]:
        return tuple(c for c in self.constraints if not c.dropped)

    def calculus(self) -> Differentiator:
        """A differentiator over these equations' intermediates, for later passes."""
        return Differentiator(self.intermediates, (*self.coordinates, *self.velocities, ir.TIME))


def lagrange_terms(model: ir.Model, calculus: Differentiator):
    """L, p, M, ∂L/∂q, the generalized forces and f for `model`, as intermediates of `calculus`."""
    q = [c.symbol for c in model.coordinates]
    v = [c.velocity_symbol for c in model.coordinates]
    n = len(q)
    lagrangian = calculus.define(sympy.Symbol("L", real=True), model.lagrangian.expression)
    momenta = [calculus.partial(lagrangian, vk) for vk in v]
    mass = [[sympy.S.Zero] * n for _ in range(n)]
    for k in range(n):
        for j in range(k + 1):
            mass[k][j] = mass[j][k] = calculus.partial(momenta[k], v[j])
    gradient = [calculus.partial(lagrangian, qk) for qk in q]
    forces = generalized_forces(model, calculus, v)
    rates = time_rates(q, v, ir.TIME)
    forcing = [gradient[k] - calculus.directional(momenta[k], TIME_DIRECTION, rates) + forces[k]
               for k in range(n)]
    return lagrangian, momenta, mass, gradient, forces, forcing


def generalized_forces(model: ir.Model, calculus: Differentiator, v) -> list[sympy.Expr]:
    """Q_k from the `force` declarations, minus ∂D/∂q'_k of the Rayleigh dissipation D."""
    names = [c.name for c in model.coordinates]
    forces = [sympy.S.Zero] * len(names)
    for force in model.forces:
        k = names.index(force.coordinate)
        forces[k] += force.expression
    if model.dissipation is not None:
        for k, vk in enumerate(v):
            forces[k] -= calculus.partial(model.dissipation.expression, vk)
    return forces
