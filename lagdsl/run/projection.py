"""Projection of a state onto the constraints in the NumPy backend: the C driver's lag_project."""
from __future__ import annotations

import numpy as np


def project(program, par, t, y, iterations: int = 10) -> tuple[np.ndarray, float]:
    """y projected onto the constraints, and how far it moved: positions by Gauss-Newton on
    g(q, t) = 0 (q <- q - A_hᵀ (A_h A_hᵀ)⁻¹ g), then velocities onto A q' + b = 0
    (q' <- q' - Aᵀ (A Aᵀ)⁻¹ c); Hairer, Lubich, Wanner, GNI, IV.4. `program` is the generated
    module. Raises numpy's LinAlgError where A Aᵀ is singular."""
    y = np.array(y, dtype=float)
    n = len(y) // 2
    moved = 0.0
    h = program.HOLONOMIC
    eps, previous = np.finfo(float).eps, np.inf
    for _ in range(iterations if h else 0):
        g, _, A = program.constraint_rows(par, t, y)
        Ah = A[:h]
        dq = Ah.T @ np.linalg.solve(Ah @ Ah.T, g)
        y[:n] -= dq
        step, size = float(np.max(np.abs(dq))), 1 + float(np.max(np.abs(y[:n])))
        moved = max(moved, step)
        # converged within rounding of q, or at the rounding floor of g (as lag_project decides)
        if step <= 4 * eps * size or previous / 2 < step <= np.sqrt(eps) * size:
            break
        previous = step
    _, c, A = program.constraint_rows(par, t, y)
    dv = A.T @ np.linalg.solve(A @ A.T, c)
    y[n:] -= dv
    return y, max(moved, float(np.max(np.abs(dv), initial=0.0)))
