"""The Euler-Lagrange equations in mass-matrix form.

For each coordinate q_k, with p_k = ∂L/∂q'_k,

    d/dt(∂L/∂q'_k) - ∂L/∂q_k = Q_k - ∂D/∂q'_k + Σ_j λ_j A_jk,

assembled as M(q, q', t) q'' = f(q, q', t) + Aᵀλ. M is never inverted: the generated code
solves the system numerically.

The velocities enter L only through *carriers* c: the velocities q'_j themselves and the time
derivatives der(x) = Σ_k ∂x/∂q_k q'_k + ∂x/∂t of velocity-free lets x. Write L = L̃(q, t, c)
with the carriers held fixed (∂̃), J_ck = ∂c/∂q'_k (= ∂x/∂q_k), π_c = ∂̃L/∂c. By Lagrange's
identity d/dt(∂x/∂q_k) = ∂(der x)/∂q_k, the terms π_c ∂c/∂q_k of d/dt(∂L/∂q'_k) and of ∂L/∂q_k
cancel exactly, and

    M_kl = Σ_c Σ_c' J_ck (∂̃π_c/∂c') J_c'l,
    f_k  = ∂̃L/∂q_k + Q_k - ∂D/∂q'_k - Σ_c J_ck [Σ_c' (∂̃π_c/∂c') D(c') + D̃(π_c)],

where D is the time derivative at zero acceleration (D(c') is the convective acceleration of
x', `calculus.time_rates`) and D̃ the same with the carriers held fixed. For T = Σ m/2 |r_i'|²
this is d'Alembert's form M = Σ m Jᵀ J, f = -Σ m Jᵀ (J' q') - ∂U/∂q: the cancelling terms of
the textbook formula are never generated, which keeps the kernels as small as Kane's.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

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

ENERGY_CONSERVED = "L does not depend on t and no work is done on the system"     # why h is conserved


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

    @cached_property
    def velocity_in_accelerations(self) -> str:
        """The first velocity, as der(q), that M or f depends on ("" if none: q'' = a(t, q)).
        Planning a scene asks at every simulate(); the answer is the model's."""
        calculus = self.calculus()
        entries = (*self.forcing, *(entry for row in self.mass_matrix for entry in row))
        read = set().union(*(calculus.dependencies(entry) for entry in entries))
        return next((f"der({c.name})" for c in self.model.coordinates if c.velocity_symbol in read), "")


def lagrange_terms(model: ir.Model, calculus: Differentiator):
    """L, p, M, ∂L/∂q, the generalized forces and f for `model`, as intermediates of `calculus`.

    Returns them with the carriers' table of intermediates, which the caller merges.
    """
    q = [c.symbol for c in model.coordinates]
    v = [c.velocity_symbol for c in model.coordinates]
    n = len(q)
    lagrangian = calculus.define(sympy.Symbol("L", real=True), model.lagrangian.expression)
    carriers = velocity_carriers(model)
    held = Differentiator(((s, e) for s, e in calculus.definitions() if s not in carriers),
                          (*q, *v, ir.TIME, *carriers), mark="δ")
    rates = time_rates(q, v, ir.TIME)
    slope = {c: held.partial(lagrangian, c) for c in carriers}                  # π_c
    slope = {c: x for c, x in slope.items() if x != 0}
    curvature = {c: {d: held.partial(slope[c], d) for d in slope if d in held.dependencies(slope[c])}
                 for c in slope}                                               # ∂̃π_c/∂c'
    rows = {c: carrier_row(calculus, c, v) for c in slope}                     # J_c·
    mass = _mass_matrix(n, rows, curvature)
    rate = {c: sum((w * calculus.directional(d, TIME_DIRECTION, rates) for d, w in curvature[c].items()),
                   sympy.S.Zero) + held.directional(slope[c], ("der̃",), rates) for c in slope}
    forces = generalized_forces(model, calculus, v)
    forcing = [held.partial(lagrangian, q[k]) + forces[k]
               - sum((row[k] * rate[c] for c, row in rows.items() if k in row), sympy.S.Zero)
               for k in range(n)]
    momenta = [sum((slope[c] * row[k] for c, row in rows.items() if k in row), sympy.S.Zero) for k in range(n)]
    gradient = [calculus.partial(lagrangian, qk) for qk in q]
    return lagrangian, momenta, mass, gradient, forces, forcing, held


def _mass_matrix(n: int, rows, curvature) -> list[list[sympy.Expr]]:
    """M_kl = Σ_c Σ_d J_ck (∂̃π_c/∂d') J_dl, symmetric: each entry's terms gathered and added once
    (adding them one by one re-sorts a growing sum each time: O(n⁴) for a chain of n links)."""
    terms: dict[tuple[int, int], list[sympy.Expr]] = {}
    for c, row in rows.items():
        for d, weight in curvature[c].items():
            for k, a in row.items():
                for l, b in rows[d].items():
                    if l <= k:
                        terms.setdefault((k, l), []).append(a * weight * b)
    mass = [[sympy.S.Zero] * n for _ in range(n)]
    for (k, l), entry in terms.items():
        mass[k][l] = mass[l][k] = sympy.Add(*entry)
    return mass


def velocity_carriers(model: ir.Model) -> list[sympy.Symbol]:
    """The symbols through which velocities enter L: q'_k and the der(x) of lets."""
    return ([c.velocity_symbol for c in model.coordinates]
            + [let.symbol for let in model.lets if let.derivative_of is not None])


def carrier_row(calculus: Differentiator, carrier: sympy.Symbol, velocities) -> dict[int, sympy.Expr]:
    """J_c· = ∂c/∂q' as {k: entry}, nonzero entries only."""
    row = {k: calculus.partial(carrier, vk) for k, vk in enumerate(velocities)
           if vk in calculus.dependencies(carrier)}
    return {k: x for k, x in row.items() if x != 0}


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
