"""Equilibria: states where the accelerations vanish, found by Newton's method.

At fixed velocities q' (zero for a static equilibrium; the constant rates of cyclic
coordinates for a relative one, a steadily spinning rotor) a state is an equilibrium when
q'' = 0, that is when the forces balance the constraints' reactions on the constraints:

    F(q, λ) = [f(q, q', t) + A(q)ᵀλ; g(q, t)] = 0      (g: the holonomic constraints)

Newton's step solves J [δq; δλ] = -F with the exact Jacobian

    J = [[∂(f + Aᵀλ)/∂q, Aᵀ], [∂g/∂q, 0]] = [[Dq, Aᵀ], [A_holonomic, 0]],

Dq read from the generated code at q'' = 0. It is solved in the least-squares sense (minimum
norm): a cyclic coordinate, whose column of J is zero, keeps its value, and an equilibrium
that is not isolated (the rest positions of a free body) is reached where the guess was. The
step is halved while it does not decrease |F| (at most HALVINGS times), so that a guess on the
far side of a maximum of the potential does not leap past the equilibrium it was near.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import AnalysisError
from .point import Evaluator

MAX_NEWTON_STEPS = 60
STEP_TOLERANCE = 1e-12        # converged when |δq| <= STEP_TOLERANCE (1 + |q|), largest entries
HALVINGS = 12


@dataclass(frozen=True)
class Equilibrium:
    """A state with q'' = 0 (to `residual`), its multipliers and how it was found."""

    coordinates: tuple[str, ...]
    state: np.ndarray                 # (q, q')
    multipliers: np.ndarray           # λ of the active constraints
    residual: float                   # largest |q''| at the state (coordinate units / s²)
    constraint_residual: float        # largest |g| of the holonomic constraints
    iterations: int

    @property
    def at(self) -> dict[str, float]:
        """The state as `linearize(at=...)` takes it: {"q": value, "q.velocity": value}."""
        n = len(self.coordinates)
        return {**{q: float(self.state[k]) for k, q in enumerate(self.coordinates)},
                **{f"{q}.velocity": float(self.state[n + k]) for k, q in enumerate(self.coordinates)}}

    def __str__(self) -> str:
        point = ", ".join(f"{name} = {value:.12g}" for name, value in self.at.items() if value != 0
                          or "." not in name)
        return (f"equilibrium after {self.iterations} Newton steps: {point}\n"
                f"  largest |q''| = {self.residual:.3g}, largest constraint residual = {self.constraint_residual:.3g}")


def find_equilibrium(evaluator: Evaluator) -> Equilibrium:
    """Newton's method from the evaluator's start state (the guess), velocities held."""
    state = evaluator.state.copy()
    n = evaluator.n
    _, lam = evaluator.accelerations(state)
    residual, jacobian = _newton_system(evaluator, state, lam)
    for step in range(1, MAX_NEWTON_STEPS + 1):
        change = scipy.linalg.lstsq(jacobian, -residual, lapack_driver="gelsd")[0]
        state, lam, residual, jacobian, change = _damped_step(evaluator, state, lam, residual, jacobian, change)
        if not (np.all(np.isfinite(state)) and np.all(np.isfinite(lam))):
            break
        if np.max(np.abs(change[:n]), initial=0.0) <= STEP_TOLERANCE * (1 + np.max(np.abs(state[:n]))):
            return _equilibrium(evaluator, state, step)
    _fail(evaluator, state)


def _damped_step(evaluator: Evaluator, state, lam, residual, jacobian, change):
    """The Newton step, halved while |F| does not decrease; the new (state, λ, F, J, step)."""
    n = evaluator.n
    size = np.linalg.norm(residual)
    for _ in range(HALVINGS):
        trial = state.copy()
        trial[:n] += change[:n]
        trial_lam = lam + change[n:]
        if np.all(np.isfinite(trial)):
            trial_residual, trial_jacobian = _newton_system(evaluator, trial, trial_lam)
            if np.linalg.norm(trial_residual) < size or size == 0:
                break
        change = change / 2
    else:
        trial_residual, trial_jacobian = _newton_system(evaluator, trial, trial_lam) \
            if np.all(np.isfinite(trial)) else (residual, jacobian)
    return trial, trial_lam, trial_residual, trial_jacobian, change


def _newton_system(evaluator: Evaluator, state: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F and J of the module docstring at `state` and λ."""
    n, m = evaluator.n, len(lam)
    g, _, A = evaluator.constraint_rows(state)
    h = len(g)                                      # holonomic rows come first
    force = evaluator.forcing(state)[:n] + A.T @ lam
    Dq = evaluator.residual_jacobian(state, np.zeros(n), lam)[0]
    jacobian = np.zeros((n + h, n + m))
    jacobian[:n, :n] = Dq[:n, :n]
    jacobian[:n, n:] = A.T
    jacobian[n:, :n] = A[:h]
    return np.concatenate([force, g]), jacobian


def _equilibrium(evaluator: Evaluator, state: np.ndarray, steps: int) -> Equilibrium:
    acc, lam = evaluator.accelerations(state)
    g = evaluator.constraint_rows(state)[0]
    return Equilibrium(evaluator.coordinates, state, lam, float(np.max(np.abs(acc), initial=0.0)),
                       float(np.max(np.abs(g), initial=0.0)), steps)


def _fail(evaluator: Evaluator, state: np.ndarray):
    """No convergence: say so with the residual at the last iterate."""
    n = evaluator.n
    try:
        acc = np.abs(evaluator.accelerations(state)[0]) if np.all(np.isfinite(state)) else np.full(n, np.inf)
    except AnalysisError:
        acc = np.full(n, np.nan)
    raise AnalysisError(f"no equilibrium found near the guess: after {MAX_NEWTON_STEPS} Newton steps the "
                        f"largest acceleration is {np.max(acc, initial=0.0):.3g} (coordinate units per s^2)",
                        evaluator.named(state),
                        "start from another guess (--at q=VALUE); check that the forces can balance "
                        "(a constant torque larger than gravity's has no equilibrium)")
