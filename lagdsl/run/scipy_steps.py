"""scipy's solvers stepped one step at a time: the NumPy backend's adaptive runs, stacked sweeps and
sensitivities.

The loop takes scipy's steps itself rather than calling solve_ivp, so that it can count them
against the step limit, stop a run whose steps have collapsed (scipy's own floor, 10 ulp of t, is
no floor at t = 0) or that cannot reach its stop time (the work forecast, integrators/forecast.py), check Ctrl-C between
steps, project onto the constraints after each one, and check a stop condition after each one
as the C driver does: its row ends the run.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..abi import HOPELESS, INTERRUPTED, MAX_STEPS, NONFINITE, SINGULAR, STEP_TOO_SMALL
from ..integrators import registry
from ..integrators.forecast import WorkForecast
from ..integrators.python.auto import AutoSolver
from ..integrators.python.stiffness import STABILITY_BOUNDARY, StiffnessTest
from ..settings import START_STEP_FRACTION, min_step, start_step_floor
from .output import Stiffness, Switches
from .stop import StopCondition

SCIPY_RTOL_FLOOR = 100 * float(np.finfo(float).eps)    # scipy raises a smaller rtol itself, with a warning
# scipy's explicit Runge-Kutta pairs evaluate the right-hand side n_stages times per attempted step
# (the stages and the end point; dense output is extra, after the step), so the evaluations a
# step() call made tell how many attempts it rejected. Radau (and auto, which steps Radau part of
# the time) reports no such count.
EXPLICIT_PAIRS = ("RK45", "DOP853")
Progress = Callable[[float, float, float], None]     # (t reached, start, stop)
# (status, last time reached, the state there), and after HOPELESS the steps forecast
Failure = tuple[int, float, np.ndarray] | tuple[int, float, np.ndarray, float]


@dataclass(frozen=True)
class ScipyProblem:
    """y' = fun(t, y) for scipy solver `method`, with what the loop checks after each step."""

    method: str                                         # "DOP853", "RK45", "Radau"; "auto": AutoSolver over `parts`
    fun: Callable[[float, np.ndarray], np.ndarray]
    jac: Callable[[float, np.ndarray], np.ndarray] | None
    rtol: float
    atol: float | np.ndarray                # one, or one per component of y
    max_step: float | None
    max_steps: int
    project: Callable[[float, np.ndarray], np.ndarray] | None = None   # onto the constraints
    stop: StopCondition | None = None
    watch: bool = True                                  # the stiffness test or auto's switches
    parts: tuple[str, ...] = ()                         # auto: the methods it switches between (registry names)

    @classmethod
    def of(cls, integrator: str, fun: Callable[[float, np.ndarray], np.ndarray],
           jac: Callable[[float, np.ndarray], np.ndarray] | None, rtol: float, atol: float | np.ndarray,
           max_step: float | None, max_steps: int, **extra) -> ScipyProblem:
        """The problem as scipy steps `integrator` (a registry name): by its scipy solver, or a
        composite by AutoSolver over its parts' (integrators/python/auto.py), on every NumPy path,
        at the tolerances the method works to; `extra` sets project, stop and watch."""
        record = registry.get(integrator)
        rtol, atol = record.working_tolerances(rtol, atol)          # auto: each part's own (_part)
        return cls("auto" if record.parts else record.scipy, fun, jac, rtol, atol, max_step, max_steps,
                   parts=record.parts, **extra)


def _no_progress(t: float, start: float, stop: float) -> None:
    pass


def integrate_scipy(problem: ScipyProblem, times: np.ndarray, y0: np.ndarray,
                    progress: Progress = _no_progress) -> tuple[list[np.ndarray], dict, Failure | None]:
    """(the states at the output times reached, the work counters, the failure or None)."""
    counts = {"accepted": 0, "rejected": 0 if problem.method in EXPLICIT_PAIRS else None, "rhs_evals": 0,
              "jac_evals": 0, "lu_decomps": 0}
    watch = _StepWatch(problem.method if problem.watch else None, counts)
    forecast = WorkForecast(times[0], times[-1], problem.max_steps)
    states, solver = [y0], None
    try:
        solver = start_solver(problem, times[0], y0, times[-1])   # its choice of the first step evaluates the model
        while len(states) < len(times):
            failure = _step(problem, solver, times, counts, watch, forecast, progress)
            if failure is not None:
                return states, watch.finish(_tally(counts, solver)), failure
            if _deliver(problem, solver, times, states):
                break
            if problem.project is not None and solver.status == "running":
                solver = _restart_projected(problem, solver, counts, times[-1])
    except np.linalg.LinAlgError:
        return _stopped(states, counts, solver, times[0], y0, SINGULAR, watch)
    except (ValueError, ArithmeticError):
        # The inputs were checked before the run, so scipy's own finiteness checks (lu_factor of
        # an iteration matrix with inf or NaN in the Jacobian) fire only on values the model
        # produced on the way: the same failure as a non-finite state. So does an overflow in
        # Python float arithmetic (a power of a constant let), which raises where NumPy's gives inf.
        return _stopped(states, counts, solver, times[0], y0, NONFINITE, watch)
    except KeyboardInterrupt:
        return _stopped(states, counts, solver, times[0], y0, INTERRUPTED, watch)
    return states, watch.finish(_tally(counts, solver)), None


def start_solver(problem: ScipyProblem, t: float, y: np.ndarray, t_end: float, first_step: float | None = None):
    """scipy's solver at (t, y), with its own first step (which evaluates the model) unless
    `first_step` is given; a first step that is not a number or lies below the floor
    (settings.START_STEP_MIN_STEPS: a tiny atol on a component at 0 makes it tiny) is replaced,
    as the C integrators do."""
    solver = _solver(problem, t, y, t_end, first_step)
    if first_step is not None:
        return solver
    floor = start_step_floor(t, t_end - t)
    chosen = solver.h_abs
    if np.isfinite(chosen) and chosen >= floor:
        return solver
    # scipy's choice of the first step divides by atol + rtol |y|, which is 0 for a component at 0
    # under pure relative error control (atol = 0): h is NaN, and the step loop, which stops when h
    # falls below a floor, never ends. Hairer's fallback.
    first = floor if np.isfinite(chosen) else max(floor, START_STEP_FRACTION * (t_end - t))
    return _solver(problem, t, y, t_end, min(first, t_end - t))


def _solver(problem: ScipyProblem, t: float, y: np.ndarray, t_end: float, first_step: float | None):
    if problem.method == "auto":
        return AutoSolver(problem.parts, lambda part, t, y, first: _solver(_part(problem, part), t, y, t_end, first),
                          t, y, first_step)
    from scipy import integrate
    method = getattr(integrate, problem.method)
    extra = {"jac": problem.jac} if problem.jac is not None and problem.method not in EXPLICIT_PAIRS else {}
    if problem.max_step:
        extra["max_step"] = problem.max_step
    return method(problem.fun, t, y, t_end, rtol=problem.rtol, atol=problem.atol, first_step=first_step, **extra)


def _part(problem: ScipyProblem, name: str) -> ScipyProblem:
    """auto's part `name` (a registry name): its scipy solver, at the tolerances that method works to."""
    record = registry.get(name)
    rtol, atol = record.working_tolerances(problem.rtol, problem.atol)
    return replace(problem, method=record.scipy, rtol=rtol, atol=atol, parts=())


def _step(problem: ScipyProblem, solver, times, counts: dict, watch: _StepWatch, forecast: WorkForecast,
          progress: Progress) -> Failure | None:
    """One step of `solver`; the failure it ran into, or None."""
    if counts["accepted"] >= problem.max_steps:
        return MAX_STEPS, solver.t, solver.y
    t_before, y_before, evaluated = solver.t, solver.y, solver.nfev
    solver.step()
    if counts["rejected"] is not None:      # every attempt of an explicit pair costs n_stages evaluations
        counts["rejected"] += (solver.nfev - evaluated) // solver.n_stages - (solver.status != "failed")
    progress(solver.t, times[0], times[-1])
    collapsed = solver.status == "running" and solver.t - t_before < min_step(solver.t, times[-1] - times[0])
    if solver.status == "failed" or collapsed:
        return STEP_TOO_SMALL, t_before, y_before
    counts["accepted"] += 1
    watch.record(solver)
    if forecast.hopeless(solver.t - t_before, solver.t):
        return HOPELESS, solver.t, solver.y, forecast.steps
    if not np.all(np.isfinite(solver.y)):
        return NONFINITE, solver.t, solver.y
    return None


def _deliver(problem: ScipyProblem, solver, times: np.ndarray, states: list) -> bool:
    """Append the states at the output times the step passed, from its dense output (projected
    onto the constraints), and at the stop condition's time; True if the condition ended the run."""
    dense = solver.dense_output()
    stop = problem.stop
    end = stop.crossed(solver.t_old, solver.t, solver.y, dense) if stop is not None else None
    while len(states) < len(times) and times[len(states)] <= solver.t and (end is None or times[len(states)] < end):
        states.append(_state_at(problem, solver, dense, times[len(states)]))
    if end is not None:
        states.append(_state_at(problem, solver, dense, end))
    return end is not None


def _state_at(problem: ScipyProblem, solver, dense, t: float) -> np.ndarray:
    state = solver.y.copy() if t == solver.t else dense(t)
    return state if problem.project is None else problem.project(t, state)


def _restart_projected(problem: ScipyProblem, solver, counts: dict, t_end: float):
    """A solver restarted from the projected state with the step the last one would take next
    (h_abs; scipy's solvers keep it there), so that step-size growth is not lost."""
    projected = problem.project(solver.t, solver.y)
    _tally(counts, solver)
    proposed = getattr(solver, "h_abs", solver.step_size)
    return start_solver(problem, solver.t, projected, t_end, first_step=min(proposed, t_end - solver.t))


class _StepWatch:
    """What the summary reports beyond the counts: the stiffness test of the explicit pairs
    (with the counts when it fired) or auto's switches (AutoSolver's record). `method` None
    watches nothing."""

    def __init__(self, method: str | None, counts: dict):
        self.counts = counts
        self.stiffness = StiffnessTest(method) if method in STABILITY_BOUNDARY else None
        self.auto = method == "auto"
        self.switches: AutoSolver | None = None
        self.at_detection: tuple[int, int, int] | None = None

    def record(self, solver) -> None:
        if self.stiffness is not None and self.stiffness.record(solver):
            counts = self.counts
            self.at_detection = (counts["accepted"], counts["rejected"], counts["rhs_evals"] + solver.nfev)
        if self.auto:
            self.switches = solver

    def finish(self, counts: dict) -> dict:
        if self.at_detection is not None:
            accepted, rejected, rhs_evals = self.at_detection
            verdict = self.stiffness.verdict
            counts["stiffness"] = Stiffness(verdict.kind, verdict.time, verdict.rate, verdict.amplitude,
                                            counts["accepted"] - accepted, counts["rejected"] - rejected,
                                            counts["rhs_evals"] - rhs_evals, counts["rhs_evals"])
        if self.switches is not None:
            log = self.switches
            counts["switches"] = Switches(log.parts, log.count, tuple(log.times), tuple(log.spans))
        return counts


def _stopped(states, counts, solver, t0, y0, status, watch) -> tuple[list, dict, Failure]:
    """The run so far, stopped with `status` after the solver's last step (or at the start)."""
    if solver is None:
        return states, watch.finish(counts), (status, t0, y0)
    return states, watch.finish(_tally(counts, solver)), (status, solver.t, solver.y)


def _tally(counts: dict, solver) -> dict:
    counts["rhs_evals"] += solver.nfev
    counts["jac_evals"] += solver.njev
    counts["lu_decomps"] += solver.nlu
    solver.nfev = solver.njev = solver.nlu = 0
    return counts
