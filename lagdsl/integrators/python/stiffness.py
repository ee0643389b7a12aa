"""Stiffness detection for scipy's explicit pairs (RK45, DOP853): the test of the C integrators.

The same test as `lagdsl/integrators/c/explicit_control.c` (Hairer, Norsett, Wanner, Solving ODEs
I, IV.2): after an accepted step of size h, the last stage and the FSAL derivative both evaluate
f at t + h, at the stage argument y_s and at the new solution y_1, so
h lambda = h |f(t+h, y_1) - f(t+h, y_s)| / |y_1 - y_s| estimates h times the dominant eigenvalue
of df/dy. 15 accepted steps beyond the stability boundary (3.25 for RK45, 6.1 for DOP853),
without 6 non-stiff ones in a row in between, make the verdict. scipy keeps the stages of the
last step in `solver.K`, so the test costs no evaluation of f.
"""
from __future__ import annotations

import numpy as np

STABILITY_BOUNDARY = {"RK45": 3.25, "DOP853": 6.1}
STIFF_STEPS = 15
CALM_STEPS = 6


class StiffnessTest:
    """Feed it every accepted step (`record(solver)`); `time` is set when the test first fires."""

    def __init__(self, method: str):
        self.boundary = STABILITY_BOUNDARY[method]
        self.stiff_steps = self.calm_steps = 0
        self.time: float | None = None

    def record(self, solver) -> bool:
        """Count the step the solver has just accepted; True when this step makes the verdict."""
        if self.h_lambda(solver) <= self.boundary:
            self.calm_steps += 1
            if self.calm_steps == CALM_STEPS:
                self.stiff_steps = 0
            return False
        self.calm_steps = 0
        self.stiff_steps += 1
        if self.stiff_steps == STIFF_STEPS and self.time is None:
            self.time = float(solver.t)
            return True
        return False

    @staticmethod
    def h_lambda(solver) -> float:
        s, h = solver.n_stages, solver.t - solver.t_old
        # the last stage's argument, y_old + h sum_j a_sj k_j (its node c_s is 1)
        y_stage = solver.y_old + h * (solver.K[:s - 1].T @ solver.A[s - 1, :s - 1])
        dy = np.linalg.norm(solver.y - y_stage)
        return float(h * np.linalg.norm(solver.K[s] - solver.K[s - 1]) / dy) if dy > 0 else 0.0


class SwitchLog:
    """The method switches of scipy's LSODA (Adams while non-stiff, BDF while stiff), read from
    its work array after every step (ODEPACK's MUSED, the method of the last step)."""

    METHODS = ("Adams", "BDF")

    def __init__(self):
        self.times: list[float] = []
        self.spans = [0.0, 0.0]
        self.method = 0

    def record(self, solver) -> None:
        used = self._method_used(solver)
        if used != self.method:
            self.times.append(float(solver.t_old))
            self.method = used
        self.spans[used] += float(solver.t - solver.t_old)

    @staticmethod
    def _method_used(solver) -> int:
        integrator = getattr(getattr(solver, "_lsoda_solver", None), "_integrator", None)
        work = getattr(integrator, "iwork", None)
        return 1 if work is not None and work[19] == 2 else 0
