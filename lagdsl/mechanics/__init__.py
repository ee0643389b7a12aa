"""Model -> Equations: the Euler-Lagrange equations, constraints and conserved quantities."""
from __future__ import annotations

import numpy as np
import sympy

from .. import ir
from ..calculus import Differentiator
from ..errors import LagError
from .constraints import constraint_equations
from .definiteness import require_positive_diagonal
from .equations import ConservedQuantity, ConstraintEquation, Equations, lagrange_terms
from .invariants import conserved_quantities
from .probe import Probe

__all__ = ["derive_equations", "Equations", "ConstraintEquation", "ConservedQuantity"]


def derive_equations(model: ir.Model) -> Equations:
    """Euler-Lagrange equations in mass-matrix form (see `equations` for the formulas).

    Raises a LagError when the constraints are not holonomic or Pfaffian or are dependent,
    when the mass matrix (or the saddle-point matrix with the constraints) is singular at every
    state, and when a diagonal entry of M is negative at every state (`definiteness`).
    """
    if not model.coordinates:
        raise LagError(f"model {model.name} declares no coordinate: there is nothing to integrate", model.span)
    q = [c.symbol for c in model.coordinates]
    v = [c.velocity_symbol for c in model.coordinates]
    calculus = Differentiator(model.written_out_lets(), (*q, *v, ir.TIME))
    probe = Probe(calculus, (*q, *v, ir.TIME, *(p.symbol for p in model.parameters)))
    lagrangian, momenta, mass, gradient, forces, forcing, held = lagrange_terms(model, calculus)
    constraints = constraint_equations(model, calculus, probe)
    _require_derivatives(model, merged_definitions(calculus, held),
                         [*forcing, *(e for row in mass for e in row),
                          *(e for c in constraints for e in (*c.jacobian, c.gamma))])
    # M's entries may be intermediates of the carriers' table: probe over both tables.
    bases = (*q, *v, ir.TIME)
    mass_probe = Probe(Differentiator(merged_definitions(calculus, held), bases), probe.symbols)
    _require_regular(model, mass, constraints, mass_probe)
    require_positive_diagonal(model, mass, mass_probe)
    energy = sum((vk * pk for vk, pk in zip(v, momenta)), sympy.S.Zero) - lagrangian
    conserved = conserved_quantities(model, calculus, probe, lagrangian, momenta, gradient,
                                     constraints, energy)
    return Equations(model, tuple(q), tuple(v), merged_definitions(calculus, held), lagrangian,
                     tuple(tuple(row) for row in mass), tuple(forcing), tuple(gradient),
                     tuple(forces), tuple(momenta), energy, constraints, conserved)


def merged_definitions(calculus: Differentiator, held: Differentiator):
    """Both tables of intermediates in one dependency order: the full one, then what the
    carrier-held table added (it only refers to symbols defined before it)."""
    full = calculus.definitions()
    known = {s for s, _ in full}
    return full + tuple((s, e) for s, e in held.definitions() if s not in known)


def _require_derivatives(model: ir.Model, definitions, exprs) -> None:
    """sympy leaves a derivative it cannot take (sign(y^a) when y^a may be complex) unevaluated."""
    for expr in (*exprs, *(e for _, e in definitions)):
        derivative = next(iter(expr.atoms(sympy.Derivative)), None)
        if derivative is None:
            continue
        function = derivative.expr
        places = [*((let.expression, let.span) for let in model.lets),
                  (model.lagrangian.expression, model.lagrangian.span),
                  *((d.expression, d.span) for d in (model.dissipation,) if d is not None),
                  *((f.expression, f.span) for f in model.forces),
                  *((c.residual, c.span) for c in model.constraints)]
        span = next((span for e, span in places if span is not None and e.has(function)), model.lagrangian.span)
        variable = derivative.variables[0]
        raise LagError(f"cannot differentiate {sympy.sstr(function)} with respect to {variable}: its argument "
                       "is not known to be real", span)


def _require_regular(model: ir.Model, mass, constraints, probe: Probe) -> None:
    """The equations determine q'' only if M (or [[M, Aᵀ], [A, 0]]) is invertible."""
    active = [c for c in constraints if not c.dropped]
    n, m = len(mass), len(active)
    rows = [list(row) + [c.jacobian[k] for c in active] for k, row in enumerate(mass)]
    rows += [list(c.jacobian) + [sympy.S.Zero] * m for c in active]
    samples = [a for a in probe.matrices(rows) if np.all(np.isfinite(a))]
    if not samples:
        return
    ranks = [np.linalg.matrix_rank(a, tol=1e-10 * max(1.0, np.abs(a).max())) for a in samples]
    if max(ranks) == n + m:
        return
    energy = "kinetic energy" if model.lagrangian.is_natural else "Lagrangian"
    names = [c.name for c in model.coordinates]
    absent = [names[k] for k in range(n) if all(entry == 0 for entry in mass[k])]
    if absent:
        which = ", ".join(absent)
        verb = "does" if len(absent) == 1 else "do"
        message = (f"the mass matrix is singular: the velocity of {which} {verb} not appear in the {energy}, "
                   f"so {which} has no equation of motion")
    else:
        _, _, vt = np.linalg.svd(samples[0])
        null = vt[-1][:n]
        involved = ", ".join(names[k] for k in range(n) if abs(null[k]) > 1e-6 * np.abs(null).max())
        message = (f"the mass matrix is singular at every state: the velocities of {involved} "
                   f"enter the {energy} only in a fixed combination")
    raise LagError(message, model.lagrangian.span)
