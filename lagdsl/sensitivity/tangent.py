"""The space the Lyapunov tangent vectors live in and the measure of their growth
(sensitivity/lyapunov.py).

Unconstrained (`Canonical`): every direction of y = (q, q') is a tangent direction, and the
growth is measured in canonical coordinates (q, p), p = ∂L/∂q', through the Legendre map's
derivative L = ∂(q, p)/∂(q, q'), where a Hamiltonian flow is symplectic: the frame starts at
L(y_0)⁻¹ times the canonical frame (e_q1 .. e_qn, e_pn .. e_p1), whose QR factors pair exactly
under a symplectic map (lyapunov.py's docstring).

Constrained (`OnConstraints`): the motion keeps to the manifold g(q, t) = 0, c = A q' + b = 0 of
dimension d = 2n - h - m (h holonomic rows among m), and its tangent vectors to the tangent
space {v : N v = 0}, N = [[A_h, 0], [C_q, A]] (C_q = ∂c/∂q): the variational equations with the
KKT rows (variational.py) keep N v constant along the motion, up to the integration's error. The
spectrum has d exponents, from an orthonormal basis of N's null space at the start (the largest:
their normalised sum). At each re-orthonormalisation the state is projected onto the
constraints as a run projects it (run/projection.py: positions by Gauss-Newton along A_hᵀ, then
velocities along Aᵀ), and the vectors by that projection's derivative at the projected state,
v_q ← v_q - A_hᵀ(A_h A_hᵀ)⁻¹ A_h v_q, v_v ← v_v - Aᵀ(A Aᵀ)⁻¹ (C_q v_q + A v_v): this only removes
the integration's error off the tangent space, which would otherwise grow linearly (N v'' = 0
for a holonomic row) and, after many QR steps, stand in for the contracting exponents. The
growth is measured in (q, q') (the ambient coordinates are bounded functions of any chart's, so
the exponents are the same; the pairs of a Hamiltonian spectrum then hold in the limit only, and
the report does not check them).
"""
from __future__ import annotations

import numpy as np
import scipy.linalg
import sympy

from .. import ir
from ..errors import SimulationError
from ..linear.constraints import linearized_constraints
from ..linear.symbolic import rate_jacobian_entries
from ..mechanics.families import expanded
from ..mechanics.probe import compiled_at, evaluate_at, to_float
from ..run.projection import project
from .variational import named_state


class Canonical:
    """The unconstrained measure: the frame and estimates in (q, p) (module docstring)."""

    def __init__(self, model, plan):
        self.legendre = Legendre(model, plan)
        self.n = len(plan.coordinates)

    def frame(self, y0: np.ndarray, t0: float, all: bool) -> np.ndarray:
        n = self.n
        canonical = lagrangian_frame(n) if all else np.full((2 * n, 1), 1 / np.sqrt(2 * n))
        return np.linalg.solve(self.legendre.at(y0[None], np.array([t0]))[0], canonical)

    def settle(self, t: float, y: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return y, V

    def estimates(self, times, sums, states, frames, start: float) -> np.ndarray:
        return canonical_estimates(self.legendre, times, sums, states, frames, start)


class OnConstraints:
    """The constrained measure: the tangent space of the constraint manifold (module docstring);
    `module` the generated functions (constraint_rows: g, c, A), `par` the parameter values."""

    def __init__(self, model, plan, module, par: np.ndarray):
        equations = expanded(model.equations)
        calculus = equations.calculus()
        symbols = (*equations.coordinates, *equations.velocities, ir.TIME, *(p.symbol for p in model.ir.parameters))
        self.entries = rate_jacobian_entries(equations, calculus)
        self.rates = compiled_at(calculus, self.entries, symbols)
        self.module, self.par, self.n = module, par, equations.size

    def rows(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(A_h, C_q, A) at (t, y)."""
        _, _, A = self.module.constraint_rows(self.par, t, y)
        values = self.rates((*y, t, *self.par))
        C_q = np.array([to_float(x) if e != 0 else 0.0 for x, e in zip(values, self.entries)]).reshape(-1, self.n)
        return A[:self.module.HOLONOMIC], C_q, A

    def frame(self, y0: np.ndarray, t0: float, all: bool) -> np.ndarray:
        basis = scipy.linalg.null_space(linearized_constraints(*self.rows(t0, y0)))
        return basis if all else basis.sum(axis=1, keepdims=True) / np.sqrt(basis.shape[1])

    def settle(self, t: float, y: np.ndarray, V: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The state projected onto the constraints and V onto their tangent space there;
        SimulationError where the constraints' rows are dependent (A Aᵀ singular)."""
        try:
            y, _ = project(self.module, self.par, t, y)
            holonomic, C_q, A = self.rows(t, y)
            n, V = self.n, np.array(V)
            if len(holonomic):
                V[:n] -= holonomic.T @ np.linalg.solve(holonomic @ holonomic.T, holonomic @ V[:n])
            V[n:] -= A.T @ np.linalg.solve(A @ A.T, C_q @ V[:n] + A @ V[n:])
        except np.linalg.LinAlgError:
            raise SimulationError("lyapunov: the constraints' rows are dependent here (A Aᵀ is singular), so their "
                                  "tangent space is not defined by them", float(t), named_state(self.module, y),
                                  "write the model without the redundant constraint") from None
        return y, V

    def estimates(self, times, sums, states, frames, start: float) -> np.ndarray:
        return sums / (times - start)[:, None]


class Legendre:
    """L(y, t) = ∂(q, p)/∂(q, q') = [[I, 0], [∂p/∂q, ∂p/∂q']], p = ∂L/∂q' (the momenta of the
    derived equations), evaluated from the symbolic equations at the plan's parameters."""

    def __init__(self, model, plan):
        equations = expanded(model.equations)
        self.calculus = equations.calculus()
        state = (*equations.coordinates, *equations.velocities)
        self.n = equations.size
        self.entries = [self.calculus.partial(p, x) if x in self.calculus.dependencies(p) else sympy.S.Zero
                        for p in equations.momenta for x in state]
        self.symbols = (*state, ir.TIME, *(p.symbol for p in model.ir.parameters))
        self.parameters = tuple(plan.parameters)

    def at(self, states: np.ndarray, times: np.ndarray) -> np.ndarray:
        """L at each (state, time): shape (points, 2n, 2n). Entries that are structurally zero are
        not evaluated, those that depend on neither state nor time once (a chain's ∂p/∂q' = M is
        constant, its ∂p/∂q zero: evaluating them at every point took a minute for 200 masses)."""
        n = self.n
        points = [(*y, t, *self.parameters) for y, t in zip(states, times)]
        lower = np.zeros((len(points), n * 2 * n))
        moving = set(self.symbols[:2 * n + 1])
        varying = [i for i, e in enumerate(self.entries) if e != 0 and self.calculus.dependencies(e) & moving]
        fixed = [i for i, e in enumerate(self.entries) if e != 0 and i not in varying]
        for indices, where in ((varying, points), (fixed, points[:1])):
            values = evaluate_at(self.calculus, [self.entries[i] for i in indices], self.symbols, where)
            lower[:, indices] = [[to_float(x) for x in row] for row in values]
        maps = np.zeros((len(points), 2 * n, 2 * n))
        maps[:, :n, :n] = np.eye(n)
        maps[:, n:, :] = lower.reshape(len(points), n, 2 * n)
        return maps


def lagrangian_frame(n: int) -> np.ndarray:
    """The canonical frame (e_q1 .. e_qn, e_pn .. e_p1): vector 2n+1-i is J e_i up to sign, the
    ordering under which the QR factors of a symplectic map pair exactly (module docstring)."""
    return np.eye(2 * n)[:, [*range(n), *range(2 * n - 1, n - 1, -1)]]


def canonical_estimates(legendre: Legendre, times, sums, states, frames, start: float) -> np.ndarray:
    """The running estimates measured in (q, p): the QR chain in (q, q') ends at V = Q_j R, and
    L(y_j) Q_j = Q' R' completes it to the QR factors of the tangent map in (q, p), whose diagonal
    is the product of the two."""
    maps = legendre.at(states, times)
    closing = np.array([np.abs(np.diag(np.linalg.qr(L @ Q, mode="r"))) for L, Q in zip(maps, frames)])
    return (sums + np.log(closing)) / (times - start)[:, None]
