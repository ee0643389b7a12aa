"""Linearization about a state (q*, q'*): the second-order and the first-order linear models.

With R = f - M q'' + Aᵀλ the residual of the equations of motion and Dq, Dv, Dz its exact
derivatives at the point (linear/point.py), a small deviation (δq, δq', δq'', δλ) obeys

    M δq'' + C δq' + S δq = Aᵀ δλ + B_q δu,      C = -Dv,  S = -Dq,  M = -Dz (its q'' block),

where Dq is taken at the point's q''* and λ*: the curvature of the constraints times their
reaction (the rod's tension) is part of the stiffness. C and S are split into their symmetric
and skew parts,

    D = (C + Cᵀ)/2 (damping),  G = (C - Cᵀ)/2 (gyroscopic),
    K = (S + Sᵀ)/2 (stiffness), N = (S - Sᵀ)/2 (circulatory).

Holonomic constraints are eliminated on the constraint manifold, as sympy's Linearizer does:
A δq = 0 splits the coordinates into dependent ones, chosen by QR with column pivoting on A
(the best-conditioned set), and independent ones q_i, so δq = P δq_i with the null-space basis
P = [I; -A_d⁻¹ A_i] (rows in the model's order). Premultiplying by Pᵀ removes δλ (A P = 0):

    (PᵀMP) δq_i'' + (PᵀCP) δq_i' + (PᵀSP) δq_i = PᵀB_q δu.

This holds at an equilibrium at rest (q'* = 0, q''* = 0). Elsewhere, and for nonholonomic
constraints (which restrict the velocities but not the positions), the first-order form is taken
on the tangent space of the constraint manifold (linear/constraints.py): x holds the independent
entries of the state y = (q, q') and x' = (J T x) at them, J the exact Jacobian of the index-1
equations and T the tangent space's basis. The first-order form, x = (δq_i, δq_i'), is

    x' = [[0, I], [-M⁻¹(K + N), -M⁻¹(D + G)]] x + [[0], [M⁻¹ B_q]] u,   y = C x + D_m u,

with M⁻¹ applied by a solve, never formed.
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg

from ..errors import LagWarning
from .constraints import constraint_rows, null_basis, tangent_basis
from .equilibrium import Equilibrium, find_equilibrium
from .model import LinearModel, Structure
from .point import Evaluator, check_inputs, evaluator
from .symbolic import input_output, rate_jacobian

# The point counts as an equilibrium when no acceleration exceeds this (coordinate units / s²).
EQUILIBRIUM_TOLERANCE = 1e-8
WARNING_LEVEL = 5       # a warning names the caller of Model.linearize


def linearize_model(model, scene: str | None = None, at: dict | None = None, set: dict | None = None,
                    inputs=(), outputs=None, find: bool = False) -> tuple[LinearModel, Equilibrium | None]:
    """The linear model of `model` (an api.Model) about `at` in `scene` with `set` applied, or,
    with `find`, about the equilibrium found from `at` as the guess; and that equilibrium."""
    point = evaluator(model, scene, at, set)
    found = find_equilibrium(point) if find else None
    return linearize(model, point.moved_to(found.state) if found else point, inputs, outputs), found


def linearize(model, evaluator: Evaluator, inputs=(), outputs=None) -> LinearModel:
    """The linear model of `model` (an api.Model) at the evaluator's state."""
    indices = check_inputs(model.ir, inputs)
    state = evaluator.state
    acc, lam = evaluator.accelerations(state)
    g, _, A = constraint_rows(evaluator, state)
    n = evaluator.n
    Dq, Dv, Dz = evaluator.residual_jacobian(state, acc, lam)
    io = input_output(model, evaluator.plan, indices, outputs, state, acc, lam)
    names = dict(inputs=io.inputs, outputs=io.outputs, output_values=io.values, point=evaluator.named(state),
                 parameters=_parameters(model, evaluator), time=evaluator.time)
    second_order = [-block[:n, :n] for block in (Dz, Dv, Dq)]          # M, C, S
    if len(A) and (len(g) < len(A) or np.any(state[n:] != 0) or np.max(np.abs(acc)) > EQUILIBRIUM_TOLERANCE):
        _warn_if_moving(evaluator, state, acc, Dq)
        return _on_tangent_space(model, evaluator, io, A[:len(g)], A, Dq, Dv, Dz, names)
    if not len(A):
        _warn_if_moving(evaluator, state, acc, Dq)
        return LinearModel.from_second_order(*second_order, io.Bq, np.hstack([io.Cq, io.Cv]), io.D,
                                             coordinates=evaluator.coordinates, eliminated=(), basis=None,
                                             structure=_structure(evaluator), **names)
    P, dependent = null_basis(A)
    reduced = [P.T @ matrix @ P for matrix in second_order]
    eliminated = tuple(evaluator.coordinates[k] for k in dependent)
    return LinearModel.from_second_order(
        *reduced, P.T @ io.Bq, np.hstack([io.Cq @ P, io.Cv @ P]), io.D,
        coordinates=tuple(q for q in evaluator.coordinates if q not in eliminated), eliminated=eliminated,
        basis=scipy.linalg.block_diag(P, P), **names)


def _on_tangent_space(model, evaluator: Evaluator, io, holonomic_rows, rows, Dq, Dv, Dz, names) -> LinearModel:
    """The first-order form on the tangent space of the constraint manifold (module docstring):
    J = [[0, I], [dq''/dq, dq''/dq']] and B = [0; dq''/du] from the KKT system, dz = -Dz⁻¹ dR."""
    n = evaluator.n
    factor = scipy.linalg.lu_factor(Dz)
    rates = -scipy.linalg.lu_solve(factor, np.hstack([Dq[:, :n], Dv[:, :n]]))[:n]
    forced = -scipy.linalg.lu_solve(factor, np.vstack([io.Bq, np.zeros((len(Dz) - n, len(io.inputs)))]))[:n]
    J = np.block([[np.zeros((n, n)), np.eye(n)], [rates]])
    T, dependent = tangent_basis(holonomic_rows, rate_jacobian(model, evaluator.plan, evaluator.state), rows)
    kept = [k for k in range(2 * n) if k not in dependent]
    entries = (*evaluator.coordinates, *(f"{q}.velocity" for q in evaluator.coordinates))
    return LinearModel((J @ T)[kept] + 0.0, np.vstack([np.zeros((n, len(io.inputs))), forced])[kept],
                       np.hstack([io.Cq, io.Cv]) @ T, io.D,
                       coordinates=tuple(entries[k] for k in kept if k < n),
                       states=tuple(entries[k] for k in kept),
                       eliminated=tuple(entries[k] for k in dependent if k < n), basis=T, **names)


def _warn_if_moving(evaluator: Evaluator, state, acc, Dq) -> None:
    """Without constraints any state may be linearized about; say when it is not a steady one."""
    largest = np.max(np.abs(acc), initial=0.0)
    if largest > EQUILIBRIUM_TOLERANCE:
        warnings.warn(f"the point is not an equilibrium (largest |q''| = {largest:.3g}): the linear model holds "
                      "for deviations from the motion through it, at this instant only", LagWarning,
                      stacklevel=WARNING_LEVEL)
    n = evaluator.n
    for k, name in enumerate(evaluator.coordinates):
        if state[n + k] != 0 and np.any(Dq[:, k] != 0):
            warnings.warn(f"{name} moves at the point and the equations depend on it: the linear model's "
                          "coefficients hold at this instant only (a steady motion moves cyclic coordinates)",
                          LagWarning, stacklevel=WARNING_LEVEL)


def _structure(evaluator: Evaluator) -> Structure:
    """What the kernel found of M and of the Jacobian (codegen/structure.py)."""
    layout, jacobian = evaluator.kernel.layout, evaluator.kernel.jacobian_layout
    diagonal = layout is not None and layout.kind == "diagonal"
    band = max(jacobian.lower, jacobian.upper) if jacobian is not None and jacobian.kind == "banded" else None
    return Structure(diagonal, band)


def _parameters(model, evaluator: Evaluator) -> dict[str, float]:
    return {p.name: float(v) for p, v in zip(model.ir.parameters, evaluator.parameters)}
