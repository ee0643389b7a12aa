"""Holonomic and nonholonomic (Pfaffian) constraints: classification and the rows of A.

A constraint lhs = rhs has the residual c = lhs - rhs.
- No velocities in c: holonomic, g(q, t) = 0. Differentiated once, A q' + ∂g/∂t = 0 with
  A = ∂g/∂q; twice, A q'' = -(d/dt)(A q' + ∂g/∂t)|_{q''=0}.
- Linear in the velocities, c = A(q, t) q' + b(q, t): nonholonomic. It is never substituted
  into the Lagrangian (that is wrong in general); it enters through a multiplier, with the
  acceleration row A q'' = -(d/dt c)|_{q''=0}.
- Anything else is an error. A residual that vanishes identically (the rod lengths of a
  pendulum written in angles) is reported and dropped.
"""
from __future__ import annotations

import numpy as np

from .. import ir
from ..calculus import TIME_DIRECTION, Differentiator, time_rates
from ..errors import LagError
from .equations import ConstraintEquation
from .probe import Probe


def constraint_equations(model: ir.Model, calculus: Differentiator, probe: Probe) -> tuple[ConstraintEquation, ...]:
    q = [c.symbol for c in model.coordinates]
    v = [c.velocity_symbol for c in model.coordinates]
    rates = time_rates(q, v, ir.TIME)
    equations = []
    for constraint in model.constraints:
        residual = constraint.residual
        dependencies = calculus.dependencies(residual)
        if dependencies & set(v):
            row = [calculus.partial(residual, vk) for vk in v]
            _require_linear_in_velocities(constraint, row, v, calculus, probe)
            kind, velocity_residual = "nonholonomic", residual
        else:
            row = [calculus.partial(residual, qk) for qk in q]
            kind = "holonomic"
            velocity_residual = calculus.directional(residual, TIME_DIRECTION, rates)
        dropped = probe.is_zero(residual)
        if not dropped and not dependencies & (set(q) | set(v)):
            raise LagError(f"constraint '{constraint.name}' does not involve any coordinate and is not "
                           "identically satisfied, so no motion can satisfy it", constraint.span)
        gamma = -calculus.directional(velocity_residual, TIME_DIRECTION, rates)
        equations.append(ConstraintEquation(constraint.name, kind, dropped, residual, velocity_residual,
                                            tuple(row), gamma, constraint.span))
    _require_independent([e for e in equations if not e.dropped], probe)
    return tuple(equations)


def _require_linear_in_velocities(constraint, row, v, calculus, probe):
    second = [calculus.partial(a, vj) for a in row for vj in v if calculus.dependencies(a) & set(v)]
    if second and not all(probe.zeros(second)):
        raise LagError(f"constraint '{constraint.name}' is neither holonomic (a relation between coordinates "
                       "and t) nor linear in the velocities (A(q,t) q' + b(q,t) = 0)", constraint.span)


def _require_independent(active: list[ConstraintEquation], probe: Probe) -> None:
    if not active:
        return
    for count in range(1, len(active) + 1):
        rows = [list(c.jacobian) for c in active[:count]]
        ranks = [np.linalg.matrix_rank(a, tol=1e-9 * max(1.0, np.abs(a).max())) for a in probe.matrices(rows)
                 if np.all(np.isfinite(a))]
        if ranks and max(ranks) < count:
            constraint = active[count - 1]
            raise LagError(f"constraint '{constraint.name}' is not independent of the constraints before it "
                           "(its row of the constraint Jacobian is a combination of theirs)", constraint.span)
