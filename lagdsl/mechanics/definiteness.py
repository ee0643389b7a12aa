"""Is the kinetic energy positive? A sign slip found before any run.

T = ½ q'ᵀ M q' is positive for every motion only if M is positive definite, and so only if each
M_kk > 0: the motion of q_k alone has T = ½ M_kk q_k'². A diagonal entry that is negative at the
declared parameter values and every probe state is a modelling error (a negative mass, moment
of inertia or length squared, or L written as U - T), which the generated code would meet as a
failed factorization of M. Where flipping the sign of one negative parameter makes every such
entry positive, that parameter is named at its declaration.
"""
from __future__ import annotations

import mpmath
import sympy

from .. import ir
from ..errors import LagError
from .probe import Probe


def require_positive_diagonal(model: ir.Model, mass, probe: Probe) -> None:
    """Raises a located LagError when some M_kk < 0 at the declared parameter values and every
    probe state (a diagonal entry of either sign across the states is left to the run)."""
    declared = {p.symbol: p.value for p in model.parameters}
    diagonal = [mass[k][k] for k in range(len(mass))]
    negative = _negative_everywhere(probe, diagonal, declared)
    if not negative:
        return
    names = [model.coordinates[k].name for k in negative]
    motion = f"a motion of {names[0]} alone" if len(names) == 1 else f"motions of {', '.join(names)} alone"
    entries = ", ".join(f"M[{name}, {name}]" for name in names)
    cause = next((p for p in model.parameters if p.value < 0
                  and not _negative_everywhere(probe, diagonal, {**declared, p.symbol: -p.value})), None)
    if cause is not None:
        raise LagError(f"the mass matrix is not positive definite: with {cause.name} = {cause.value:g} the kinetic "
                       f"energy of {motion} is negative ({entries} < 0 at every state tried); a mass, inertia or "
                       f"length must be positive: give {cause.name} a positive value", cause.span)
    energy = "kinetic energy" if model.lagrangian.is_natural else "Lagrangian (L = T - U)"
    raise LagError(f"the mass matrix is not positive definite: the kinetic energy of {motion} is negative "
                   f"({entries} < 0 at every state tried); check the signs in the {energy}", model.lagrangian.span)


def _negative_everywhere(probe: Probe, diagonal, values: dict[sympy.Symbol, float]) -> list[int]:
    """The k whose diagonal entry is negative at every probe state with the parameters at `values`."""
    candidates = [k for k, entry in enumerate(diagonal) if entry != 0 and not (entry.is_number and entry > 0)]
    if not candidates:
        return []
    points = probe.evaluate([diagonal[k] for k in candidates], values)
    return [k for column, k in enumerate(candidates) if all(_is_negative(point[column]) for point in points)]


def _is_negative(value) -> bool:
    try:
        return bool(mpmath.im(value) == 0 and value < 0)
    except TypeError:
        return False
