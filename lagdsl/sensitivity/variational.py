"""The augmented system Y = (y, S) of sensitivity/run.py, evaluated by the generated functions.

With constraints the equations of motion are the index-1 system K (q'', λ) = (f, γ),
K = [[M, -Aᵀ], [A, 0]], and R = [f - M q'' + Aᵀλ; γ - A q''] has a row per constraint; its total
derivative by θ gives the same variational equations with the constraint rows,

    K (Sq'', Sλ) = Dq Sq + Dv Sv + Dp ∂p/∂θ,

solved with K as (q'', λ) are. The sensitivities of the multipliers, Sλ, come with them: an output
that reads λ has ∂h/∂θ = Cy S + Cλ Sλ + Cp ∂p/∂θ.

S then keeps to the constraints' linearization, A_h Sq + ∂g/∂θ = 0 (holonomic rows) and
C_q Sq + A Sv + ∂c/∂θ = 0 (every row; c = A q' + b, C_q = ∂c/∂q), if it starts on it. A start
moved off the constraints (a coordinate's start alone, a parameter that changes the constraint)
is projected back by the run, orthogonally (run/projection.py, z <- z - Aᵀ(AAᵀ)⁻¹ r); the
derivative of that projection at a consistent point is the orthogonal projector onto the
linearization, which S(0) gets here (`onto_constraints`). During the run S keeps to it as the state
keeps to the constraints: by the index-1 equations, up to the integration's error.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg

from ..linear.symbolic import constraint_parameter_jacobian, rate_jacobian


class VariationalSystem:
    """y' and S' at the parameters `par`; J = ∂par/∂θ (parameters x directions)."""

    def __init__(self, module, par: np.ndarray, J: np.ndarray, n: int):
        self.module, self.par, self.J = module, par, J
        self.n, self.m = n, J.shape[1]

    def split(self, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return Y[:2 * self.n], Y[2 * self.n:].reshape(2 * self.n, self.m)

    def rates(self, t: float, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """x = (q'', λ) and its sensitivities (Sq'', Sλ), both from K's solves."""
        module, par, n = self.module, self.par, self.n
        y, S = self.split(Y)
        K, b = module.assemble(par, t, y)
        x = module.solve(K, b)
        Dq, Dv, _ = module.residual_jacobian(par, t, y, x[:n], x[n:])
        forcing = Dq[:, :n] @ S[:n] + Dv[:, :n] @ S[n:] + module.parameter_jacobian(par, t, y, x[:n], x[n:]) @ self.J
        return x, module.solve_columns(K, forcing)

    def rhs(self, t: float, Y: np.ndarray) -> np.ndarray:
        y, S = self.split(Y)
        x, Sx = self.rates(t, Y)
        return np.concatenate([y[self.n:], x[:self.n], S[self.n:].ravel(), Sx[:self.n].ravel()])

    def newton_matrix(self, t: float, Y: np.ndarray) -> np.ndarray:
        """The implicit methods' iteration matrix: ∂f/∂y on each of the 1 + m diagonal blocks (the
        coupling ∂(S')/∂y below them is left out, as CVODES's staggered corrector does)."""
        return scipy.linalg.block_diag(*[self.module.jacobian(t, Y[:2 * self.n], self.par)] * (1 + self.m))

    def output_derivatives(self, t: float, Y: np.ndarray, constrained: bool) -> np.ndarray:
        """∂h/∂θ of every column at (t, Y): Cy S + Cλ Sλ + Cp J (columns x directions)."""
        y, S = self.split(Y)
        x, Sx = self.rates(t, Y) if constrained else (np.zeros(self.n), np.zeros((self.n, self.m)))
        Cy, Cl, Cp = self.module.output_jacobian(self.par, t, y, x[self.n:])
        return Cy @ S + Cl @ Sx[self.n:] + Cp @ self.J


def onto_constraints(model, plan, module, par: np.ndarray, y0: np.ndarray, S0: np.ndarray,
                     J: np.ndarray) -> np.ndarray:
    """S(0) projected orthogonally onto the constraints' linearization (module docstring)."""
    n, t = len(plan.coordinates), float(plan.time.start)
    _, _, A = module.constraint_rows(par, t, y0)
    holonomic = A[:module.HOLONOMIC]
    g_p, c_p = constraint_parameter_jacobian(model, plan, y0)
    S = np.array(S0)
    if len(holonomic):
        S[:n] -= holonomic.T @ np.linalg.solve(holonomic @ holonomic.T, holonomic @ S[:n] + g_p @ J)
    residual = rate_jacobian(model, plan, y0) @ S[:n] + A @ S[n:] + c_p @ J
    S[n:] -= A.T @ np.linalg.solve(A @ A.T, residual)
    return S


def named_state(module, y: np.ndarray) -> dict[str, float]:
    """y = (q, q') by name ("q", "q.velocity"), for a failure's message; `module` the generated functions."""
    names = module.COORDINATES
    n = len(names)
    return {**{q: float(y[k]) for k, q in enumerate(names)},
            **{q + ".velocity": float(y[n + k]) for k, q in enumerate(names)}}
