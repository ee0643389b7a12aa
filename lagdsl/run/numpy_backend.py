"""The NumPy backend: the generated module integrated by scipy's solvers or our Python methods.

It fails as the C driver does, with the same statuses (status.py): a SimulationError naming the
time, the state and a remedy, with the rows reached in `error.partial`.
"""
from __future__ import annotations

import importlib
import time as clock
import warnings
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..abi import NONFINITE, PROJECTION_FAILED, SINGULAR
from ..errors import LagError, LagWarning
from ..integrators import registry
from ..integrators.python import IntegrationFailure, PythonRun
from ..settings import RunPlan
from .interrupt import CtrlC
from .loading import load
from .output import Result, RunSummary, Stop, output_times
from .projection import project
from .scipy_steps import SCIPY_RTOL_FLOOR, Progress, ScipyProblem, integrate_scipy
from .status import simulation_error
from .stop import StopCondition

if TYPE_CHECKING:
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel


def run_numpy(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
              loaded=None) -> Result:
    """Integrate with the generated module; it fails as the C driver does (the same statuses).

    numpy's floating-point warnings are silenced: overflow and NaN are found by checking the
    states, and reported as a SimulationError like every other failure.
    """
    refusal = registry.get(plan.integrator.name).refusal("numpy", bool(plan.constraints))
    if refusal is not None:
        raise LagError(refusal, plan.integrator.span)
    plan = _within_scipy_tolerances(plan)
    module = loaded if loaded is not None else load(source)
    par = np.array(plan.parameters, dtype=float)
    times = output_times(plan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        y0, projection, failure = _checked_start(module, par, times[0], np.array(plan.initial_state, dtype=float), plan)
        # As in the C driver, the initial row is written unless y0 could not be projected.
        states = [y0] if failure is not None and failure[0] != PROJECTION_FAILED else []
        counts, elapsed = {}, 0.0
        stop = StopCondition(lambda t, y: float(module.stop_function(t, y, par))) if plan.stop else None
        if failure is None and stop is not None and stop.holds_at_start(times[0], y0):
            states = [y0]
        elif failure is None:
            started = clock.perf_counter()
            with CtrlC() as ctrl_c:
                states, counts, failure = _integrate(module, par, times, y0, plan, progress, stop, ctrl_c)
            elapsed = clock.perf_counter() - started
        states = np.array(states).reshape(len(states), len(y0))
        stopped = Stop(plan.stop, stop.time) if stop is not None and stop.time is not None else None
        if stopped is not None:           # the last row is at the stop time
            times = np.append(times[:len(states) - 1], stopped.time)
        rows = _rows_with_outputs(module, par, times, states)
        if rows < len(states) and failure is None:
            failure = (SINGULAR, times[rows], states[rows])
        result = _numpy_result(module, par, times[:rows], states[:rows], plan, counts, elapsed, projection,
                               stopped)
    if failure is not None:
        status, t_fail, y_fail, *forecast = failure        # the work forecast follows HOPELESS
        with np.errstate(all="ignore"):
            try:
                rcond = float(module.reciprocal_condition(t_fail, y_fail, par))
            except (np.linalg.LinAlgError, ArithmeticError):     # K itself cannot be formed there
                rcond = float("nan")
        raise simulation_error(plan, status, t_fail, y_fail, result, rcond, *forecast)
    return result


def _integrate(module, par, times, y0, plan: RunPlan, progress: Progress | None, stop: StopCondition | None,
               ctrl_c: CtrlC):
    """(states at the output times reached, counters, failure or None) of the plan's method: its
    scipy equivalent stepped by scipy_steps, or its own Python stepper."""
    record = registry.get(plan.integrator.name)
    constrained = (lambda t, y: project(module, par, t, y)[0]) if plan.constraints else None
    options = dict(plan.integrator.options)
    atol_each = plan.atol_vector(plan.coordinates)
    if atol_each is not None:
        options["atol"] = np.array(atol_each)
    if record.scipy_solvers:
        jacobian = (lambda t, y: module.jacobian(t, y, par)) if plan.implicit else None
        problem = ScipyProblem.of(record.name, ctrl_c.checked(lambda t, y: module.rhs(t, y, par)), jacobian,
                                  options["rtol"], options["atol"], options.get("max_step"), plan.max_steps,
                                  project=constrained, stop=stop)
        return integrate_scipy(problem, times, y0, *(() if progress is None else (progress,)))
    module_name, function = record.python.split(":")
    stepper = getattr(importlib.import_module(f"lagdsl.integrators.python.{module_name}"), function)
    run = PythonRun(module, par, times, y0, options, plan.max_steps, stop, ctrl_c.checked,
                    constrained)
    try:
        Y, stats = stepper(run)
    except IntegrationFailure as failure:
        return list(failure.Y[:failure.completed]), {}, (failure.status, failure.t, failure.y, failure.forecast)
    return list(Y), stats, None


def _within_scipy_tolerances(plan: RunPlan) -> RunPlan:
    """scipy's solvers raise rtol below 100 eps themselves (with a warning of their own): raise it
    here, say so in our words, and let the summary print the tolerance the run used."""
    options = dict(plan.integrator.options)
    if not registry.get(plan.integrator.name).scipy_solvers or options["rtol"] >= SCIPY_RTOL_FLOOR:
        return plan
    warnings.warn(f"rtol = {options['rtol']:g} is below what scipy's solvers accept; the NumPy backend "
                  f"runs at rtol = {SCIPY_RTOL_FLOOR:.3g}", LagWarning, stacklevel=3)
    options["rtol"] = SCIPY_RTOL_FLOOR
    return replace(plan, integrator=replace(plan.integrator, options=tuple(sorted(options.items()))))


def _checked_start(module, par, t0, y0, plan):
    """(y0 projected onto the constraints, how far it moved, failure or None): the initial
    state must be finite, the constraints regular and the system for q'' regular there."""
    if not np.all(np.isfinite(y0)):
        return y0, 0.0, (NONFINITE, t0, y0)
    moved = 0.0
    try:
        if plan.constraints:
            y0, moved = project(module, par, t0, y0)
    except np.linalg.LinAlgError:
        return y0, 0.0, (PROJECTION_FAILED, t0, y0)
    try:
        derivative = module.hamilton_rhs(t0, module.to_canonical(t0, y0, par), par) if plan.canonical \
            else module.rhs(t0, y0, par)
    except np.linalg.LinAlgError:
        return y0, moved, (SINGULAR, t0, y0)
    except ArithmeticError:         # Python float arithmetic (a constant let) overflowed: not finite
        return y0, moved, (NONFINITE, t0, y0)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(derivative))):
        return y0, moved, (NONFINITE, t0, y0)
    return y0, moved, None


def _rows_with_outputs(module, par, times, states) -> int:
    """How many leading rows have outputs. Outputs with multipliers solve the system for q'' at
    each row; where it is singular (the state at which the run failed) the row has none, and,
    as in the C driver, which delivers no row it cannot evaluate, it is left out."""
    try:
        if len(states):
            module.observables(times[:len(states)], states.T, par)
        return len(states)
    except (np.linalg.LinAlgError, ArithmeticError):
        for row, state in enumerate(states):
            try:
                module.observables(times[row:row + 1], state[:, None], par)
            except (np.linalg.LinAlgError, ArithmeticError):
                return row
        return len(states)


def _numpy_result(module, par, times, states, plan, counts, elapsed, projection, stopped=None) -> Result:
    Y = states.T
    values, watched = module.observables(times, Y, par) if len(times) else (np.zeros((len(plan.columns), 0)), None)
    values = values.T
    invariants = ()
    if plan.invariants and len(times):
        invariants = tuple((name, float(watched[i, 0]), float(np.max(np.abs(watched[i] - watched[i, 0]))))
                           for i, name in enumerate(plan.invariants))
    residual = None
    if plan.constraints and len(times):
        g, c, _ = module.constraint_rows(par, times, Y)
        residual = float(max(np.max(np.abs(g), initial=0.0), np.max(np.abs(c), initial=0.0)))
    record = registry.get(plan.integrator.name)
    kept = tuple((name, int(counts[name])) for name in record.counters if counts.get(name) is not None)
    solvers = " and ".join(record.scipy_solvers)
    uncounted = tuple((name, f"not counted by scipy's {solvers}") for name in record.counters
                      if counts.get(name) is None and solvers and counts)
    summary = RunSummary("numpy", plan.integrator.name, kept, elapsed, invariants, plan.constraints, residual,
                         projection if plan.constraints else None, plan.integrator.options,
                         atol_each=plan.integrator.atol_each,
                         stiffness=counts.get("stiffness"), switches=counts.get("switches"), stopped=stopped,
                         uncounted=uncounted)
    return Result(np.asarray(times, dtype=float), plan.columns, np.asarray(values, dtype=float), summary)
