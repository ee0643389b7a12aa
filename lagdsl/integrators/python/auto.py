"""`auto` on the NumPy backend: scipy's DOP853 while the problem is not stiff, its Radau while it
is, switching by the rule of `lagdsl/integrators/c/auto.c`, with the same constants
(`lagdsl.integrators`), so that both backends switch alike on the same scene.

To Radau: when the stiffness test of DOP853 (stiffness.py, the rule of stiffness_test.c) gives
the verdict stiff and DOP853 has taken `patience` accepted steps since it (re)started; Radau starts
from DOP853's proposed step. Back to DOP853, either of:
- measured work: after STIFF_STEPS steps of Radau, its mean step is not AUTO_GAIN times DOP853's
  mean step over the steps that made the verdict (scipy's Radau does not count its rejected steps,
  so its accepted steps stand for its trials);
- the stiffness has faded: h rho <= AUTO_CALM on STIFF_STEPS accepted steps of Radau in a row, rho
  the spectral radius of J = df/dy by one step of power iteration on J^2 per accepted step
  (continued from the previous vector; two evaluations of f).
Hysteresis: after each return to DOP853, its verdict is heeded only after twice as many accepted
steps as the time before (2 STIFF_STEPS, 4 STIFF_STEPS, ...). Each switch starts the other solver
at the current (t, y).
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import AUTO_CALM, AUTO_GAIN, STIFF_STEPS, SWITCH_TIMES, VERDICT_STIFF, registry
from .stiffness import StiffnessTest, jacobian_product

EXPLICIT, IMPLICIT = 0, 1
# (part, t, y, first step or None) -> a scipy OdeSolver integrating to the run's end, for the
# part (a registry name) at the tolerances it works to
SolverFactory = Callable[[str, float, np.ndarray, float | None], object]


class AutoSolver:
    """The two solvers behind scipy's OdeSolver interface, as scipy_steps steps it (step, t,
    t_old, y, status, dense_output, h_abs, and the counters nfev, njev, nlu, which the caller reads
    and sets to 0); `times` and `spans` are the switches' record (output.Switches)."""

    def __init__(self, parts: tuple[str, str], make: SolverFactory, t0: float, y0: np.ndarray,
                 first_step: float | None):
        self.parts, self.make = parts, make          # dop853, radau5: each one's scipy solver stands for it
        self.methods = tuple(registry.get(part).scipy for part in parts)
        self.times: list[float] = []
        self.count = 0
        self.spans = [0.0, 0.0]
        self.patience = 0
        self.finished = {"nfev": 0, "njev": 0, "nlu": 0}
        self.v = np.ones_like(np.asarray(y0, dtype=float))
        self.method = EXPLICIT
        self.solver = self.last = None
        self._start_explicit(t0, y0, first_step)

    # ---- scipy's interface -------------------------------------------------------------------
    def __getattr__(self, name: str):
        """t, t_old, y, status, the dense output and the step size are those of the solver that took
        the last step."""
        if name in ("t", "t_old", "y", "status", "dense_output", "step_size"):
            return getattr(self.last, name)
        raise AttributeError(name)

    @property
    def h_abs(self) -> float:
        return self.solver.h_abs

    def step(self) -> str | None:
        """One step of the solver in charge; its message (None, or why it failed), as scipy's step()."""
        t_before, evaluated = self.solver.t, self.solver.nfev
        message = self.solver.step()
        self.last = self.solver
        self.spans[self.method] += float(self.solver.t - t_before)
        if self.solver.status != "running":
            return message
        if self.method == EXPLICIT:
            self.trials += (self.solver.nfev - evaluated) // self.solver.n_stages   # each attempt costs n_stages
            self.accepted += 1
            self.test.record(self.solver, self.trials)
            if self.test.verdict is not None and self.test.verdict.kind == VERDICT_STIFF \
                    and self.accepted >= self.patience:
                self._to_implicit()
        elif self._back_to_explicit():
            self.patience = 2 * self.patience if self.patience > 0 else 2 * STIFF_STEPS
            self._switch()
            last = self.last
            self._start_explicit(last.t, last.y, min(last.t - last.t_old, last.t_bound - last.t))
        return message

    # ---- the counters, over both solvers and their earlier runs ------------------------------
    nfev = property(lambda self: self._count("nfev"), lambda self, value: self._reset("nfev"))
    njev = property(lambda self: self._count("njev"), lambda self, value: self._reset("njev"))
    nlu = property(lambda self: self._count("nlu"), lambda self, value: self._reset("nlu"))

    def _count(self, name: str) -> int:
        return self.finished[name] + getattr(self.solver, name)

    def _reset(self, name: str) -> None:
        self.finished[name] = 0
        setattr(self.solver, name, 0)

    # ---- the rule --------------------------------------------------------------------------------
    def _start_explicit(self, t: float, y: np.ndarray, first_step: float | None) -> None:
        self._begin(EXPLICIT, t, y, first_step)
        self.test = StiffnessTest(self.methods[EXPLICIT])
        self.accepted = self.trials = 0

    def _to_implicit(self) -> None:
        verdict = self.test.verdict
        self.switched_at, self.explicit_step = self.solver.t, verdict.step
        self._switch()
        self._begin(IMPLICIT, self.last.t, self.last.y, min(self.last.h_abs, self.last.t_bound - self.last.t))
        self.measured, self.calm_steps, self.radau_steps = False, 0, 0

    def _switch(self) -> None:
        if self.count < SWITCH_TIMES:
            self.times.append(float(self.solver.t))
        self.count += 1

    def _begin(self, method: int, t: float, y: np.ndarray, first_step: float | None) -> None:
        if self.solver is not None:
            for name in self.finished:
                self.finished[name] += getattr(self.solver, name)
        self.method = method
        self.solver = self.make(self.parts[method], t, y, first_step)
        self.last = self.last or self.solver

    def _back_to_explicit(self) -> bool:
        """Radau does not pay after STIFF_STEPS steps, or STIFF_STEPS calm steps in a row."""
        self.radau_steps += 1
        if not self.measured and self.radau_steps >= STIFF_STEPS:
            self.measured = True
            if self.solver.t - self.switched_at < AUTO_GAIN * self.explicit_step * self.radau_steps:
                return True
        h_rho = (self.solver.t - self.solver.t_old) * np.sqrt(self._spectral_radius_squared())
        self.calm_steps = self.calm_steps + 1 if h_rho <= AUTO_CALM else 0
        return self.calm_steps >= STIFF_STEPS

    def _spectral_radius_squared(self) -> float:
        """rho(J)^2 at Radau's (t, y) from one step of power iteration on J^2; 0 when nothing was
        learnt (the iteration then starts afresh)."""
        with np.errstate(all="ignore"):
            before = np.linalg.norm(self.v)
            v = jacobian_product(self.solver, jacobian_product(self.solver, self.v))
            size = np.linalg.norm(v)
        if not (size > 0 and np.isfinite(size)):
            self.v = np.ones_like(self.v)
            return 0.0
        self.v = v / size
        return float(size / before)
