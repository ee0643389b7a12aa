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

This holds at an equilibrium at rest (q'* = 0, q''* = 0), the only kind of point a constrained
model is linearized about. The first-order form, x = (δq_i, δq_i'), is

    x' = [[0, I], [-M⁻¹(K + N), -M⁻¹(D + G)]] x + [[0], [M⁻¹ B_q]] u,   y = C x + D_m u,

with M⁻¹ applied by a solve, never formed.
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg

from ..errors import LagError, LagWarning, Setting
from .model import LinearModel, Structure
from .equilibrium import Equilibrium, find_equilibrium
from .point import Evaluator, check_inputs, evaluator
from .symbolic import input_output

# The point counts as an equilibrium when no acceleration exceeds this (coordinate units / s²),
# and as on the constraints when each |g_i| / |∇g_i| (a distance, coordinate units) is below
# ON_CONSTRAINT (1 + |q|).
EQUILIBRIUM_TOLERANCE = 1e-8
ON_CONSTRAINT = 1e-9
RANK_TOLERANCE = 1e-12  # a constraint row within this (relative) of the others' span is redundant
WARNING_LEVEL = 5       # a warning names the caller of Model.linearize


def linearize_model(model, scene: str | None = None, at: dict | None = None, set: dict | None = None,
                    inputs=(), outputs=None, find: bool = False) -> tuple[LinearModel, Equilibrium | None]:
    """The linear model of `model` (an api.Model) about `at` in `scene` with `set` applied, or,
    with `find`, about the equilibrium found from `at` as the guess; and that equilibrium."""
    point = evaluator(model, scene, at, set)
    found = find_equilibrium(point) if find else None
    return linearize(model, point.moved_to(found.state) if found else point, inputs, outputs), found


def linearize(model, evaluator: Evaluator, inputs=(), outputs=None) -> LinearModel:
    """The linear model of `model` (an api.Model) at the evaluator's start state."""
    indices = check_inputs(model.ir, inputs)
    state = evaluator.state
    acc, lam = evaluator.accelerations(state)
    basis, eliminated = _constraint_basis(model, evaluator, state, acc)
    n = evaluator.n
    Dq, Dv, Dz = evaluator.residual_jacobian(state, acc, lam)
    mass, damping, stiffness = (-block[:n, :n] for block in (Dz, Dv, Dq))
    io = input_output(model, evaluator.plan, indices, outputs, state, acc, lam)
    if basis is None:
        _warn_if_moving(evaluator, state, acc, Dq)
        basis, reduced, Bq, C = np.eye(n), (mass, damping, stiffness), io.Bq, np.hstack([io.Cq, io.Cv])
    else:
        reduced = [basis.T @ matrix @ basis for matrix in (mass, damping, stiffness)]
        Bq, C = basis.T @ io.Bq, np.hstack([io.Cq @ basis, io.Cv @ basis])
    kept = tuple(name for name in evaluator.coordinates if name not in eliminated)
    return LinearModel.from_second_order(
        *reduced, Bq, C, io.D,
        coordinates=kept, eliminated=eliminated, basis=basis, inputs=io.inputs, outputs=io.outputs,
        output_values=io.values, point=evaluator.named(state), parameters=_parameters(model, evaluator),
        time=evaluator.time, structure=_structure(evaluator) if not eliminated else Structure())


def _constraint_basis(model, evaluator: Evaluator, state, acc):
    """(P, eliminated coordinate names) of the module docstring, or (None, ()) without constraints."""
    g, c, A = evaluator.constraint_rows(state)
    if not len(A):
        return None, ()
    names = evaluator.coordinates
    active = {e.name: e for e in model.equations.constraints}
    for name in evaluator.kernel.constraints[len(g):]:
        raise LagError(f"constraint '{name}' is nonholonomic: linearizing a model with nonholonomic constraints is "
                       "not supported (they restrict the velocities but not the positions, and the linear state "
                       "would have fewer velocities than coordinates)", active[name].span)
    n = evaluator.n
    scale = 1 + np.max(np.abs(state[:n]))
    for name, residual, row, rate in zip(evaluator.kernel.constraints, g, A, c):
        size = max(np.linalg.norm(row), np.finfo(float).tiny)
        if abs(residual) / size > ON_CONSTRAINT * scale or abs(rate) / size > ON_CONSTRAINT * scale:
            raise LagError(f"the state is not on constraint '{name}' (residual {residual:.3g}, velocity residual "
                           f"{rate:.3g}); give a point that satisfies it, or find one with --find", Setting("--at"))
    if np.any(state[n:] != 0):
        raise LagError("a model with constraints is linearized about a state at rest only: give every velocity "
                       "as 0", Setting("--at"))
    if np.max(np.abs(acc), initial=0.0) > EQUILIBRIUM_TOLERANCE:
        raise LagError(f"the state is not an equilibrium (largest |q''| = {np.max(np.abs(acc)):.3g}): a model "
                       "with constraints is linearized about an equilibrium only; find one with --find",
                       Setting("--at"))
    _, triangle, pivots = scipy.linalg.qr(A, pivoting=True, mode="economic")
    diagonal = np.abs(np.diag(triangle))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * diagonal[0]))        # redundant constraints drop out
    dependent = sorted(pivots[:rank])
    independent = [k for k in range(n) if k not in dependent]
    basis = np.zeros((n, len(independent)))
    basis[independent, range(len(independent))] = 1.0
    basis[dependent] = -np.linalg.lstsq(A[:, dependent], A[:, independent], rcond=None)[0]
    return basis, tuple(names[k] for k in dependent)


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
