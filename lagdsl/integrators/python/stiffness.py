"""Stiffness detection for scipy's explicit pairs (RK45, DOP853): the test of the C integrators.

The same rule as `lagdsl/integrators/c/stiffness_test.c` (Hairer, Norsett, Wanner, Solving ODEs
I, IV.2, with a verdict on the kind of fast mode), with the same constants
(`lagdsl.integrators`): after an accepted step of size h, the last stage and the FSAL derivative
both evaluate f at t + h, at the stage argument y_s and at the new solution y_1, so
h lambda = h |f(t+h, y_1) - f(t+h, y_s)| / |y_1 - y_s| estimates h times the dominant eigenvalue
of df/dy (scipy keeps the stages of the last step in `solver.K`: no evaluation of f). STIFF_STEPS
accepted steps beyond the stability boundary, without CALM_STEPS non-stiff ones in a row in
between, call for a verdict (`fast_mode`): the spectral radius rho of J = df/dy by power
iteration on J^2, and the fast mode's amplitude in tolerances,
sqrt((|y''|^2 + |J y''|^2 / rho^2) / 2n) / rho^2 with y'' the time derivative of f along the
solution and |.| weighting component i by 1 / (atol + rtol |y_i|) (J y'' / rho is the fast mode
a quarter period on: the sum does not depend on its phase). Above EXCITED_AMPLITUDE the mode is
an excited fast oscillation that every method must resolve; below, it is damped or not excited,
and an implicit method steps over it: stiff. A stiff verdict is final; after an oscillation the
test calls for the next verdict after twice as many stiff steps.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import (CALM_STEPS, EXCITED_AMPLITUDE, FAST_ITERATIONS, FAST_PROBE, STIFF_STEPS, VERDICT_OSCILLATION,
                VERDICT_STIFF, registry)

STABILITY_BOUNDARY = {record.scipy: record.stability_boundary
                      for record in map(registry.get, registry.names()) if record.stiffness_test}


@dataclass(frozen=True)
class FastMode:
    """A verdict of the test at `time`: its kind (VERDICT_STIFF or VERDICT_OSCILLATION), the
    spectral radius `rate` of df/dy (1/s) and the fast mode's amplitude in tolerances."""

    kind: int
    time: float
    rate: float
    amplitude: float
    step: float = 0.0           # the mean step (per trial) over the steps that made the verdict


class StiffnessTest:
    """Feed it every accepted step (`record(solver, trials)`); `verdict` is the verdict the summary keeps."""

    def __init__(self, method: str):
        self.boundary = STABILITY_BOUNDARY[method]
        self.stiff_steps = self.calm_steps = 0
        self.patience = STIFF_STEPS
        self.verdict: FastMode | None = None
        self.window = (0.0, 0)          # (t, trials) at the first stiff step of the count

    def record(self, solver, trials: int = 0) -> bool:
        """Count the step the solver has just accepted (`trials`: its attempts so far, accepted or
        rejected, for the verdict's mean step); True when it gives the verdict to keep."""
        if self.verdict is not None and self.verdict.kind == VERDICT_STIFF:
            return False
        if self.h_lambda(solver) <= self.boundary:
            self.calm_steps += 1
            if self.calm_steps == CALM_STEPS:
                self.stiff_steps = 0
            return False
        self.calm_steps = 0
        if self.stiff_steps == 0:
            self.window = (float(solver.t), trials)
        self.stiff_steps += 1
        if self.stiff_steps < self.patience:
            return False
        self.stiff_steps = 0
        mode = fast_mode(solver)
        if mode is not None and mode.kind == VERDICT_OSCILLATION:
            self.patience *= 2
        if mode is None or (self.verdict is not None and mode.kind == VERDICT_OSCILLATION):
            return False
        start, before = self.window
        self.verdict = replace(mode, step=(mode.time - start) / max(trials - before, 1))
        return True

    @staticmethod
    def h_lambda(solver) -> float:
        s, h = solver.n_stages, solver.t - solver.t_old
        # the last stage's argument, y_old + h sum_j a_sj k_j (its node c_s is 1)
        y_stage = solver.y_old + h * (solver.K[:s - 1].T @ solver.A[s - 1, :s - 1])
        dy = np.linalg.norm(solver.y - y_stage)
        return float(h * np.linalg.norm(solver.K[s] - solver.K[s - 1]) / dy) if dy > 0 else 0.0


def fast_mode(solver) -> FastMode | None:
    """The verdict at the solver's (t, y), f = solver.f (the rule above); None when a probe failed.
    Costs 2 FAST_ITERATIONS + 2 evaluations of f (counted in solver.nfev)."""
    t, y, f = solver.t, solver.y, solver.f
    with np.errstate(all="ignore"):
        v, rho2 = f, 0.0
        for _ in range(FAST_ITERATIONS):
            before = np.linalg.norm(v)
            v = jacobian_product(solver, jacobian_product(solver, v))
            size = np.linalg.norm(v)
            if not (size > 0 and np.isfinite(size)):
                return None
            rho2, v = size / before, v / size
        rho = np.sqrt(rho2)
        d = FAST_PROBE / rho
        second = (solver.fun(t + d, y + d * f) - f) / d
        scale = solver.atol + solver.rtol * np.abs(y)
        turned = jacobian_product(solver, second) / rho      # a quarter period on
        amplitude = float(np.sqrt(np.mean((second / scale) ** 2 + (turned / scale) ** 2) / 2) / rho2)
    if not np.isfinite(amplitude):
        return None
    kind = VERDICT_OSCILLATION if amplitude > EXCITED_AMPLITUDE else VERDICT_STIFF
    return FastMode(kind, float(t), float(rho), amplitude)


def jacobian_product(solver, u: np.ndarray) -> np.ndarray:
    """J u ~ (f(t, y + delta u) - f) / delta, delta = sqrt(eps) (1 + |y|) / |u|."""
    delta = np.sqrt(np.finfo(float).eps) * (1 + np.linalg.norm(solver.y)) / np.linalg.norm(u)
    return (solver.fun(solver.t, solver.y + delta * u) - solver.f) / delta
