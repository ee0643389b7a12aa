"""Constraints in a linearization: the check that the point satisfies them, and the bases of the
directions that keep satisfying them.

At rest, holonomic constraints g(q) = 0 alone: the coordinates' directions A δq = 0, with the
null-space basis P (δq = P δq_i), give the second-order form (linear/linearize.py).

Otherwise (nonholonomic constraints, a moving state) the deviations of the state y = (q, q') keep
to the tangent space of the constraint manifold,

    A_h δq = 0                     (holonomic rows, position level)
    C_q δq + A δq' = 0             (every row, velocity level; C_q = ∂(A q' + b)/∂q),

whose basis T (δy = T δx) gives the first-order form x' = A_r x with A_r the rows of J T at the
independent entries, J = ∂(q', q'')/∂(q, q') the exact Jacobian of the index-1 equations. The
flow keeps the manifold, so J maps the tangent space into itself at a steady point: A_r loses no
information, and the constraints' spurious zero eigenvalues are gone.

Both bases come from one rule: QR with column pivoting on the constraint rows picks the
best-conditioned set of dependent entries, and the basis is the identity on the others.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import LagError, Setting
from .point import Evaluator

# The point is on the constraints when each |g_i| / |∇g_i| (a distance, in coordinate units) and
# |c_i| / |A_i| are below ON_CONSTRAINT (1 + |q|); a constraint row within RANK_TOLERANCE
# (relative) of the others' span is redundant.
ON_CONSTRAINT = 1e-9
RANK_TOLERANCE = 1e-12


def constraint_rows(evaluator: Evaluator, state: np.ndarray):
    """g, c and A at `state`; a LagError where the state does not satisfy them."""
    g, c, A = evaluator.constraint_rows(state)
    scale = 1 + np.max(np.abs(state[:evaluator.n]))
    for i, name in enumerate(evaluator.kernel.constraints):
        size = max(np.linalg.norm(A[i]), np.finfo(float).tiny)
        residual = g[i] if i < len(g) else 0.0
        if abs(residual) / size > ON_CONSTRAINT * scale or abs(c[i]) / size > ON_CONSTRAINT * scale:
            raise LagError(f"the state is not on constraint '{name}' (residual {residual:.3g}, velocity residual "
                           f"{c[i]:.3g}); give a point that satisfies it, or find one with --find", Setting("--at"))
    return g, c, A


def null_basis(rows: np.ndarray, dependent: list[int] | None = None) -> tuple[np.ndarray, list[int]]:
    """(N, dependent): rows N = 0 with N the identity on the entries not in `dependent` (by
    default the best-conditioned set, `dependent_entries(rows)`)."""
    size = rows.shape[1]
    dependent = dependent_entries(rows) if dependent is None else sorted(dependent)
    independent = [k for k in range(size) if k not in dependent]
    basis = np.zeros((size, len(independent)))
    basis[independent, range(len(independent))] = 1.0
    if dependent:
        basis[dependent] = -np.linalg.lstsq(rows[:, dependent], rows[:, independent], rcond=None)[0]
    return basis, dependent


def dependent_entries(rows: np.ndarray) -> list[int]:
    """The columns QR with column pivoting puts first, as many as the rank of `rows`."""
    if not rows.size:
        return []
    _, triangle, pivots = scipy.linalg.qr(rows, pivoting=True, mode="economic")
    diagonal = np.abs(np.diag(triangle))
    return sorted(pivots[:int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0]))])


def linearized_constraints(holonomic_rows: np.ndarray, rate_jacobian: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """N = [[A_h, 0], [C_q, A]]: the derivative by y = (q, q') of (g, c), whose null space is the
    tangent space of the constraint manifold."""
    return np.vstack([np.hstack([holonomic_rows, np.zeros_like(holonomic_rows)]), np.hstack([rate_jacobian, rows])])


def tangent_basis(holonomic_rows: np.ndarray, rate_jacobian: np.ndarray, rows: np.ndarray):
    """(T, dependent state entries) of the module docstring, rows [[A_h, 0], [C_q, A]]: the
    holonomic rows take dependent coordinates, every row a dependent velocity (so a rolling
    constraint eliminates a velocity, never a position)."""
    n = rows.shape[1]
    stacked = linearized_constraints(holonomic_rows, rate_jacobian, rows)
    dependent = dependent_entries(holonomic_rows) + [n + k for k in dependent_entries(rows)]
    return null_basis(stacked, dependent)
