"""Run a scene: the C backend through ctypes, the NumPy backend with scipy or our Python methods.

Both deliver the same `Result`: rows at the output grid t0, t0 + dt, ... < t1 and t1 itself
(`settings.grid_rows`), the scene's columns, and a `RunSummary`. A numerical failure raises
SimulationError naming the time, the state and a remedy, with the rows computed so far in
`error.partial`. Every run is bounded by the plan's step limit, and Ctrl-C stops it between two
steps with SimulationInterrupted, which keeps the rows computed so far as well. `progress`, if
given, is called as progress(t reached, start, stop) every POLL_SECONDS in the C backend, after
every step of scipy's solvers in the NumPy backend.
"""
from __future__ import annotations

import collections

import ctypes
import hashlib
import importlib.abc
import importlib.util
import signal
import threading
import time as clock
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InternalError, LagError, LagWarning, SimulationError, SimulationInterrupted
from ..integrators import COUNTERS, STIFFNESS_TESTED, SWITCH_TIMES, summary_extras
from ..integrators.python.fixed_step import IntegrationFailure, integrate_gauss, integrate_rk4
from ..integrators.python.nystrom import integrate_rkn8
from ..integrators.python.stiffness import STABILITY_BOUNDARY, StiffnessTest, SwitchLog
from ..settings import RunPlan, check_step_count, grid_rows
from .cache import cached_entry
from .output import SETTINGS_ORDER, Result, RunSummary, Stiffness, Stop, Switches
from .stop import StopCondition
from .toolchain import shared_library

if TYPE_CHECKING:       # the code generators import sympy; running generated code does not need it
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel

# K (M, or the saddle-point matrix of a constrained system) counts as singular below this
# reciprocal condition estimate: q'' would keep fewer than about 3 correct digits. The generated
# code of both backends uses the same threshold (LAG_RCOND_MIN, RCOND_MIN).
RCOND_MIN = 1000 * float(np.finfo(float).eps)
STATUS = {
    1: ("the mass matrix is singular at this state",
        "the coordinates are singular here (e.g. Euler angles at theta = 0, spherical coordinates at a "
        "pole, a link of zero length) or the constraints are dependent; use coordinates that do not pass "
        "through this configuration, or start away from it"),
    2: ("the state or its derivative became infinite or NaN",
        "check the parameters and initial values; a stiff model may need --integrator radau5"),
    3: ("the step size collapsed below the resolution of t",
        "the solution may be singular near this time (a collision, a coordinate singularity), "
        "or the problem is stiff: try --integrator radau5 or a looser --rtol"),
    4: ("the step limit of {max_steps} steps was reached",
        "raise --max-steps, or the problem is stiff: try --integrator radau5 (or loosen --rtol)"),
    5: ("the implicit iteration did not converge",
        "reduce the step (gauss: step = ...), or loosen the tolerances"),
    6: ("projection onto the constraints did not converge",
        "the constraints may be singular at this state; check the initial values"),
    7: ("interrupted", ""),
    8: ("at its pace so far, the run would need more steps than the step limit of {max_steps} allows",
        "the solution may be singular near this time, or the problem is stiff: try --integrator "
        "radau5, or raise --max-steps"),
}
PROJECTION_FAILED = 6
INTERRUPTED = 7
SCIPY_METHODS = {"dopri5": "RK45", "dop853": "DOP853", "radau5": "Radau", "auto": "LSODA"}
SCIPY_RTOL_FLOOR = 100 * float(np.finfo(float).eps)    # scipy raises a smaller rtol itself, with a warning
POLL_SECONDS = 0.1      # how often the main thread looks at a C run: Ctrl-C and progress
Progress = Callable[[float, float, float], None]     # (t reached, start, stop)


def output_times(plan: RunPlan) -> np.ndarray:
    """start + k*interval while below stop, then stop (the rule of settings.grid_rows)."""
    start, stop, interval = plan.time.start, plan.time.stop, plan.time.interval
    times = start + interval * np.arange(grid_rows(start, stop, interval))
    times[-1] = stop
    return times


def _state_names(plan: RunPlan) -> list[str]:
    names = list(plan.coordinates)
    return names + [f"{n}'" for n in names]


def _failure(plan: RunPlan, status: int, t_fail: float, y_fail, partial: Result,
             rcond: float) -> SimulationError:
    """The error for a failed run; `rcond` is the reciprocal condition estimate of K at y_fail."""
    message, remedy = STATUS.get(status, ("unknown failure", "please report this"))
    if status == 1:
        message += f" (reciprocal condition estimate {rcond:.3g}, below {RCOND_MIN:.3g})"
    kind = SimulationInterrupted if status == INTERRUPTED else SimulationError
    state = dict(zip(_state_names(plan), map(float, y_fail)))
    return kind(message.format(max_steps=plan.max_steps), t_fail, state, remedy, partial)


def run(plan: RunPlan, language: str, loaded=None, progress: Progress | None = None,
        source: GeneratedSource | None = None) -> Result:
    """Run `plan` with `loaded`, what load() returned (a shared library or a NumPy module), or
    else with `source`, loaded once the plan's step count has been checked."""
    check_step_count(plan)
    return {"c": run_c, "numpy": run_numpy}[language](None, source, plan, progress, loaded)


# ---- C ---------------------------------------------------------------------------------------
def load(source: GeneratedSource):
    """What runs `source`: its shared library (C, compiled on first use) or its module (NumPy).

    A caller that keeps it passes it back as `loaded` to run_c or run_numpy, which then go
    straight to the integration: no hashing of the source, no compiler, no dlopen or import.
    """
    if source.language == "c":
        return load_library(shared_library(source.text, source.suggested_name))
    return load_module(source)


def run_c(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
          loaded: ctypes.CDLL | None = None) -> Result:
    library = loaded if loaded is not None else load(source)
    entry = library.lag_run
    double_p = ctypes.POINTER(ctypes.c_double)
    entry.argtypes = [double_p, double_p, double_p, double_p, ctypes.c_long, double_p]
    entry.restype = ctypes.c_int
    times = output_times(plan)
    options = dict(plan.integrator.options)
    settings = np.array([plan.time.start, plan.time.stop, plan.time.interval,
                         *(float(options.get(k, 0.0)) for k in SETTINGS_ORDER), float(plan.max_steps)])
    parameters = np.array(plan.parameters or (0.0,), dtype=float)
    initial = np.array(plan.initial_state, dtype=float)
    ncols = len(plan.columns)
    rows = np.zeros((len(times), ncols + 1))
    counters = COUNTERS[plan.integrator.name]
    head = 6 + len(counters)        # status, rows, t_fail, rcond_fail, residual, projection, counters
    extras = head + summary_extras(plan.integrator.name)     # the stiffness verdict, the switches
    failure_state = extras + 2 * len(plan.invariants)
    summary = np.zeros(failure_state + len(initial) + (2 if plan.stop else 0))
    pointer = lambda a: a.ctypes.data_as(double_p)   # noqa: E731
    reached = ctypes.c_double.in_dll(library, "lag_progress_t")
    poll = None if progress is None else lambda: progress(reached.value, plan.time.start, plan.time.stop)
    status, elapsed = _interruptible(
        library, lambda: entry(pointer(parameters), pointer(initial), pointer(settings), pointer(rows),
                               len(times), pointer(summary)), poll)
    used = int(summary[1])
    invariants = tuple((name, float(summary[extras + 2 * i]), float(summary[extras + 1 + 2 * i]))
                       for i, name in enumerate(plan.invariants))
    name = plan.integrator.name
    report = RunSummary("c", name, tuple(zip(counters, map(int, summary[6:head]))), elapsed,
                        invariants, plan.constraints, float(summary[4]) if plan.constraints else None,
                        float(summary[5]) if plan.constraints else None,
                        plan.integrator.options,
                        stiffness=_c_stiffness(summary[head:], dict(zip(counters, summary[6:head])))
                        if name in STIFFNESS_TESTED else None,
                        switches=_c_switches(summary[head:]) if name == "auto" else None,
                        stopped=Stop(plan.stop, float(summary[-1])) if plan.stop and summary[-2] else None)
    result = Result(rows[:used, 0].copy(), plan.columns, rows[:used, 1:].copy(), report)
    if status != 0:
        raise _failure(plan, status, float(summary[2]), summary[failure_state:failure_state + len(initial)], result,
                       float(summary[3]))
    return result


def _c_stiffness(extras: np.ndarray, counts: dict) -> Stiffness | None:
    """The summary's entries after the counters: stiff, its time, and accepted, rejected, rhs_evals then."""
    if not extras[0]:
        return None
    return Stiffness(float(extras[1]), int(counts["accepted"] - extras[2]), int(counts["rejected"] - extras[3]),
                     int(counts["rhs_evals"] - extras[4]), int(counts["rhs_evals"]))


def _c_switches(extras: np.ndarray) -> Switches:
    """The summary's entries after the counters: the number of switches, the spans of t of dop853
    and radau5, then the times of the first SWITCH_TIMES switches."""
    count = int(extras[0])
    times = tuple(float(t) for t in extras[3:3 + min(count, SWITCH_TIMES)])
    return Switches(("dop853", "radau5"), count, times, (float(extras[1]), float(extras[2])))


def load_library(path: Path) -> ctypes.CDLL:
    try:
        return ctypes.CDLL(str(path))
    except OSError as error:
        # The cache entry was verified, so this is the system refusing it (a cache directory on a
        # file system mounted noexec, say); ctypes gives dlopen's message without an errno.
        raise LagError(f"cannot load the compiled model '{path}': {error}") from None


def _interruptible(library: ctypes.CDLL, call: Callable[[], int],
                   poll: Callable[[], None] | None) -> tuple[int, float]:
    """Make the C call in a worker thread, so that the main thread stays free for Ctrl-C and
    `poll` (called every POLL_SECONDS: progress reports).
    Returns its status and its duration, timed in the worker: the main thread notices the end
    only at its next poll, up to POLL_SECONDS later.

    ctypes releases the GIL during the call, and a blocked foreign call would otherwise hold back
    KeyboardInterrupt until the whole run is over. Ctrl-C sets the library's lag_interrupt flag,
    which the driver reads after each step (status LAG_ERR_INTERRUPTED, the rows so far kept);
    further Ctrl-Cs while it winds down change nothing.
    """
    interrupt = ctypes.c_int.in_dll(library, "lag_interrupt")
    interrupt.value = 0
    outcome: list[tuple[int, float]] = []
    done = threading.Event()

    def work() -> None:
        try:
            started = clock.perf_counter()
            status = call()
            outcome.append((status, clock.perf_counter() - started))
        finally:
            done.set()

    threading.Thread(target=work, name="lagdsl-c-run", daemon=True).start()
    # Waits on the event, not join(timeout): a KeyboardInterrupt inside Thread.join can leave
    # the thread looking finished while it still runs. The wait ends as soon as the run does, so
    # a run of milliseconds does not wait out a poll interval. Ctrl-C is caught wherever the
    # main thread is in the loop, in the wait, the test of the event or the poll: Python raises
    # KeyboardInterrupt at whichever bytecode it reaches next (and CtrlC has set the flag even
    # if that bytecode was a finaliser's, which drops the exception).
    with CtrlC(lambda: setattr(interrupt, "value", 1)):
        while True:
            try:
                while not done.is_set():
                    done.wait(POLL_SECONDS)
                    if poll is not None:
                        poll()
                break
            except KeyboardInterrupt:
                interrupt.value = 1
    if not outcome:
        raise InternalError("the C run ended without a status")
    return outcome[0]


class CtrlC:
    """Ctrl-C during a run, never lost.

    Python's SIGINT handler raises KeyboardInterrupt at the next bytecode the main thread runs,
    and when that bytecode belongs to a finaliser (the __del__ of some object the cyclic
    collector frees just then) Python prints "Exception ignored" and drops it: the press is lost
    and the run goes on. Within this context, in the main thread and if SIGINT has Python's
    default handler, a press first calls `on_press` and sets `pressed`, which the run's loops
    test between steps (`check`), and then raises as usual. A context within another (a run of
    a NumPy sweep) leaves the handler to the outer one, which presses for every open context.
    """

    _innermost: CtrlC | None = None      # the context of the main thread that is open now

    def __init__(self, on_press: Callable[[], None] = lambda: None):
        self.pressed = False
        self._on_press = on_press
        self._previous = None
        self._outer: CtrlC | None = None

    def __enter__(self) -> CtrlC:
        if threading.current_thread() is threading.main_thread():
            self._outer, CtrlC._innermost = CtrlC._innermost, self
            if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
                self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *exception) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
        if CtrlC._innermost is self:
            CtrlC._innermost = self._outer

    def _handle(self, signal_number, frame) -> None:
        context = CtrlC._innermost
        while context is not None:
            context.pressed = True
            context._on_press()
            context = context._outer
        raise KeyboardInterrupt

    def check(self) -> None:
        """Raise KeyboardInterrupt if Ctrl-C was pressed (its own exception may have been dropped)."""
        if self.pressed:
            raise KeyboardInterrupt

    def checked(self, function: Callable) -> Callable:
        """`function`, checking for Ctrl-C before each call: the right-hand side of a Python loop."""
        def checked_function(*arguments):
            self.check()
            return function(*arguments)
        return checked_function


# ---- NumPy -----------------------------------------------------------------------------------
def load_module(source: GeneratedSource):
    """Import generated NumPy code; it is kept in the build cache so that tracebacks point at a file.

    The module is executed from the generated text itself (the cache entry is verified to hold the
    same bytes), and no bytecode is written beside it: a damaged .pyc could not be told apart.
    """
    name, key = module_entry(source)
    path = cached_entry(name, key, lambda entry: _write_module(source.text, entry))
    return import_module(source.text, path, key)


def module_entry(source: GeneratedSource) -> tuple[str, str]:
    """The cache entry's name and key of a generated NumPy module."""
    key = hashlib.sha256(source.text.encode()).hexdigest()
    return f"{source.suggested_name}_{key[:20]}.py", key


def import_module(text: str, path: Path, key: str):
    """The module of generated `text`, held in the cache at `path` under `key`."""
    spec = importlib.util.spec_from_file_location(f"lagdsl_generated_{key[:20]}", path,
                                                  loader=_GeneratedLoader(text, path))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _write_module(text: str, entry: Path) -> None:
    try:
        compile(text, str(entry), "exec")     # never cache a module that cannot load
    except SyntaxError as error:
        raise InternalError(f"the generated Python does not parse: {error}") from None
    entry.write_text(text, encoding="utf-8")


class _GeneratedLoader(importlib.abc.InspectLoader):
    """Loads a module from text held in memory, compiled under the name of its file in the cache."""

    def __init__(self, text: str, path: Path):
        self.text, self.path = text, path

    def get_source(self, fullname: str) -> str:
        return self.text

    def get_code(self, fullname: str):
        return self.source_to_code(self.text, str(self.path))


def run_numpy(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
              loaded=None) -> Result:
    """Integrate with the generated module; it fails as the C driver does (the same statuses).

    numpy's floating-point warnings are silenced: overflow and NaN are found by checking the
    states, and reported as a SimulationError like every other failure.
    """
    if plan.integrator.name == "auto" and plan.constraints:
        # the solver restarts after every projection, and LSODA restarts at order 1
        raise LagError("auto on the NumPy backend is scipy's LSODA, which restarts at order 1 after every "
                       "projection onto the constraints and crawls; use --backend c, or --integrator dop853 "
                       "or radau5", plan.integrator.span)
    plan = _within_scipy_tolerances(plan)
    module = loaded if loaded is not None else load(source)
    par = np.array(plan.parameters, dtype=float)
    times = output_times(plan)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        y0, projection, failure = _start(module, par, times[0], np.array(plan.initial_state, dtype=float), plan)
        # As in the C driver, the initial row is written unless y0 could not be projected.
        states = [y0] if failure is not None and failure[0] != PROJECTION_FAILED else []
        counts, elapsed = {}, 0.0
        stop = StopCondition(lambda t, y: float(module.stop_function(t, y, par))) if plan.stop else None
        if failure is None and stop is not None and stop.holds_at_start(times[0], y0):
            states = [y0]
        elif failure is None:
            started = clock.perf_counter()
            with CtrlC() as ctrl_c:
                if plan.integrator.name in SCIPY_METHODS:
                    states, counts, failure = _run_scipy(module, par, times, y0, plan, progress or _no_progress,
                                                         stop, ctrl_c)
                else:
                    states, counts, failure = _run_bundled(module, par, times, y0, plan, stop, ctrl_c)
            elapsed = clock.perf_counter() - started
        states = np.array(states).reshape(len(states), len(y0))
        stopped = Stop(plan.stop, stop.time) if stop is not None and stop.time is not None else None
        if stopped is not None:           # the last row is at the stop time
            times = np.append(times[:len(states) - 1], stopped.time)
        rows = _rows_with_outputs(module, par, times, states)
        if rows < len(states) and failure is None:
            failure = (1, times[rows], states[rows])
        result = _numpy_result(module, par, times[:rows], states[:rows], plan, counts, elapsed, projection,
                               stopped)
    if failure is not None:
        status, t_fail, y_fail = failure
        with np.errstate(all="ignore"):
            try:
                rcond = float(module.reciprocal_condition(t_fail, y_fail, par))
            except (np.linalg.LinAlgError, ArithmeticError):     # K itself cannot be formed there
                rcond = float("nan")
        raise _failure(plan, status, t_fail, y_fail, result, rcond)
    return result


def _within_scipy_tolerances(plan: RunPlan) -> RunPlan:
    """scipy's solvers raise rtol below 100 eps themselves (with a warning of their own): raise it
    here, say so in our words, and let the summary print the tolerance the run used."""
    options = dict(plan.integrator.options)
    if plan.integrator.name not in SCIPY_METHODS or options["rtol"] >= SCIPY_RTOL_FLOOR:
        return plan
    warnings.warn(f"rtol = {options['rtol']:g} is below what scipy's solvers accept; the NumPy backend "
                  f"runs at rtol = {SCIPY_RTOL_FLOOR:.3g}", LagWarning, stacklevel=3)
    options["rtol"] = SCIPY_RTOL_FLOOR
    return replace(plan, integrator=replace(plan.integrator, options=tuple(sorted(options.items()))))


def _start(module, par, t0, y0, plan):
    """(y0 projected onto the constraints, how far it moved, failure or None): the initial
    state must be finite, the constraints regular and the system for q'' regular there."""
    if not np.all(np.isfinite(y0)):
        return y0, 0.0, (2, t0, y0)
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
        return y0, moved, (1, t0, y0)
    except ArithmeticError:         # Python float arithmetic (a constant let) overflowed: not finite
        return y0, moved, (2, t0, y0)
    if not (np.all(np.isfinite(y0)) and np.all(np.isfinite(derivative))):
        return y0, moved, (2, t0, y0)
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
    kept = tuple((name, int(counts[name])) for name in COUNTERS[plan.integrator.name]
                 if counts.get(name) is not None)
    summary = RunSummary("numpy", plan.integrator.name, kept, elapsed, invariants, plan.constraints, residual,
                         projection if plan.constraints else None, plan.integrator.options,
                         stiffness=counts.get("stiffness"), switches=counts.get("switches"), stopped=stopped)
    return Result(np.asarray(times, dtype=float), plan.columns, np.asarray(values, dtype=float), summary)


def _no_progress(t: float, start: float, stop: float) -> None:
    pass


def _run_scipy(module, par, times, y0, plan, progress, stop: StopCondition | None, ctrl_c: CtrlC):
    """scipy's solver step by step: rows from its dense output, the step limit and a step-size floor
    counted here (scipy's own floor, 10 ulp of t, is no floor at t = 0), Ctrl-C between steps.
    A stop condition is checked after every step, as the C driver does (not with solve_ivp's
    events, which need solve_ivp's own loop): its row ends the run."""
    from scipy import integrate
    options = dict(plan.integrator.options)
    method = getattr(integrate, SCIPY_METHODS[plan.integrator.name])
    extra = {"jac": lambda t, y: module.jacobian(t, y, par)} if plan.implicit else {}
    if options.get("max_step"):
        extra["max_step"] = options["max_step"]

    @ctrl_c.checked
    def fun(t, y):
        return module.rhs(t, y, par)

    def start(t, y, first_step=None):
        solver = method(fun, t, y, times[-1], rtol=options["rtol"], atol=options["atol"],
                        first_step=first_step, **extra)
        if not np.isfinite(getattr(solver, "h_abs", 0.0)):
            # scipy's choice of the first step divides by atol + rtol |y|, which is 0 for a
            # component at 0 under pure relative error control (atol = 0): h is NaN, and the
            # step loop, which stops when h falls below a floor, never ends. Hairer's fallback.
            solver = method(fun, t, y, times[-1], rtol=options["rtol"], atol=options["atol"],
                            first_step=1e-6 * abs(times[-1] - t), **extra)
        return solver

    counts = {"accepted": 0, "rejected": None, "rhs_evals": 0, "jac_evals": 0, "lu_decomps": 0}
    watch = _StepWatch(method.__name__, counts)
    forecast = _WorkForecast(times[0], times[-1], plan.max_steps)
    states, solver, k = [y0], None, 1
    span = times[-1] - times[0]
    try:
        solver = start(times[0], y0)        # its choice of the first step evaluates the model too
        while k < len(times):
            if counts["accepted"] >= plan.max_steps:
                return states, watch.finish(_tally(counts, solver)), (4, solver.t, solver.y)
            t_before, y_before = solver.t, solver.y
            solver.step()
            progress(solver.t, times[0], times[-1])
            collapsed = solver.status == "running" and solver.t - t_before < _min_step(solver.t, span)
            if solver.status == "failed" or collapsed:
                return states, watch.finish(_tally(counts, solver)), (3, t_before, y_before)
            counts["accepted"] += 1
            watch.record(solver)
            if forecast.hopeless(solver.t - t_before, solver.t, counts["accepted"]):
                return states, watch.finish(_tally(counts, solver)), (8, solver.t, solver.y)
            if not np.all(np.isfinite(solver.y)):
                return states, watch.finish(_tally(counts, solver)), (2, solver.t, solver.y)
            dense = solver.dense_output()
            end = stop.crossed(solver.t_old, solver.t, solver.y, dense) if stop is not None else None
            while k < len(times) and times[k] <= solver.t and (end is None or times[k] < end):
                state = solver.y.copy() if times[k] == solver.t else dense(times[k])
                states.append(project(module, par, times[k], state)[0] if plan.constraints else state)
                k += 1
            if end is not None:
                state = solver.y.copy() if end == solver.t else dense(end)
                states.append(project(module, par, end, state)[0] if plan.constraints else state)
                break
            if plan.constraints and solver.status == "running":
                projected, _ = project(module, par, solver.t, solver.y)
                counts = _tally(counts, solver)
                # Restart from the projected state with the step the solver would take next
                # (h_abs; scipy's solvers keep it there), so step-size growth is not lost.
                proposed = getattr(solver, "h_abs", solver.step_size)
                solver = start(solver.t, projected, first_step=min(proposed, times[-1] - solver.t))
    except np.linalg.LinAlgError:
        return _stopped(states, counts, solver, times[0], y0, 1, watch)
    except (ValueError, ArithmeticError):
        # The inputs were checked before the run, so scipy's own finiteness checks (lu_factor of
        # an iteration matrix with inf or NaN in the Jacobian) fire only on values the model
        # produced on the way: the same failure as a non-finite state. So does an overflow in
        # Python float arithmetic (a power of a constant let), which raises where NumPy's gives inf.
        return _stopped(states, counts, solver, times[0], y0, 2, watch)
    except KeyboardInterrupt:
        return _stopped(states, counts, solver, times[0], y0, INTERRUPTED, watch)
    return states, watch.finish(_tally(counts, solver)), None


class _WorkForecast:
    """Stops a run early that cannot end within its step limit.

    A NumPy step costs about a millisecond, so a run whose steps have shrunk to near the
    resolution of t (an extreme parameter, a singularity) or that needs more steps than allowed
    would grind through the whole step limit for minutes. From `JUDGED_AFTER` steps on, the run
    is hopeless when two forecasts of the steps still needed both exceed the steps still allowed:
    the average pace since the start, (stop - t) x taken / (t - start), which a passing burst of
    small steps (a close approach) barely moves, and the largest of the last `WINDOW` steps,
    (stop - t) / h, which forgives a fast transient at the start. Steps that shrink on towards a
    singularity end here too, before the step-size floor would. (A C step costs microseconds;
    there the step limit itself ends such runs within a second.)
    """

    JUDGED_AFTER, WINDOW = 1000, 100

    def __init__(self, start: float, stop: float, max_steps: int):
        self.start, self.stop, self.max_steps = start, stop, max_steps
        self.recent: collections.deque = collections.deque(maxlen=self.WINDOW)

    def hopeless(self, step: float, t: float, taken: int) -> bool:
        self.recent.append(abs(step))
        if taken < self.JUDGED_AFTER:
            return False
        largest = max(self.recent)
        left, allowed = abs(self.stop - t), self.max_steps - taken
        by_average = left * taken > allowed * abs(t - self.start)
        by_recent = left > allowed * largest
        return by_average and by_recent


class _StepWatch:
    """What the summary reports beyond the counts: the stiffness test of the explicit pairs
    (with the counts when it fired) or LSODA's switches."""

    def __init__(self, method: str, counts: dict):
        self.counts = counts
        self.stiffness = StiffnessTest(method) if method in STABILITY_BOUNDARY else None
        self.switches = SwitchLog() if method == "LSODA" else None
        self.at_detection: tuple[int, int] | None = None

    def record(self, solver) -> None:
        if self.stiffness is not None and self.stiffness.record(solver):
            self.at_detection = (self.counts["accepted"], self.counts["rhs_evals"] + solver.nfev)
        if self.switches is not None:
            self.switches.record(solver)

    def finish(self, counts: dict) -> dict:
        if self.at_detection is not None:
            accepted, rhs_evals = self.at_detection
            counts["stiffness"] = Stiffness(self.stiffness.time, counts["accepted"] - accepted, None,
                                            counts["rhs_evals"] - rhs_evals, counts["rhs_evals"])
        if self.switches is not None:
            log = self.switches
            counts["switches"] = Switches(SwitchLog.METHODS, len(log.times), tuple(log.times), tuple(log.spans))
        return counts


def _stopped(states, counts, solver, t0, y0, status, watch):
    """The run so far, stopped with `status` after the solver's last step (or at the start)."""
    if solver is None:
        return states, watch.finish(counts), (status, t0, y0)
    return states, watch.finish(_tally(counts, solver)), (status, solver.t, solver.y)


def _min_step(t: float, span: float) -> float:
    """The C integrators' LAG_MIN_STEP: 10 eps max(|t|, length of the run)."""
    return 10 * np.finfo(float).eps * max(abs(t), span)


def _tally(counts, solver):
    counts["rhs_evals"] += solver.nfev
    counts["jac_evals"] += solver.njev
    counts["lu_decomps"] += solver.nlu
    solver.nfev = solver.njev = solver.nlu = 0
    return counts


def _run_bundled(module, par, times, y0, plan, stop: StopCondition | None, ctrl_c: CtrlC):
    """The NumPy backend's own integrators (lagdsl/integrators/python), for the methods scipy lacks:
    rk4, gauss and rkn8."""
    options = dict(plan.integrator.options)
    checked = ctrl_c.checked
    try:
        if plan.integrator.name == "rk4" and plan.constraints:
            Y, stats = _rk4_projected(module, par, times, y0, options["step"], plan.time.stop, stop, checked)
        elif plan.integrator.name == "rk4":
            Y, stats = integrate_rk4(checked(lambda t, y: module.rhs(t, y, par)), times, y0, options["step"], stop)
        elif plan.integrator.name == "rkn8":
            Y, stats = integrate_rkn8(checked(lambda t, y: module.accelerations(par, t, y)[0]),
                                      checked(lambda t, y: module.rhs(t, y, par)), times, y0, options["rtol"],
                                      options["atol"], options.get("max_step", 0.0), plan.max_steps, stop)
        else:
            Y, stats = integrate_gauss(checked(lambda t, z: module.hamilton_rhs(t, z, par)),
                                       lambda t, y: module.to_canonical(t, y, par),
                                       lambda t, z: module.from_canonical(t, z, par),
                                       times, y0, options["step"], int(options["stages"]), stop)
    except IntegrationFailure as failure:
        return list(failure.Y[:failure.completed]), {}, (failure.status, failure.t, failure.y)
    return list(Y), stats, None


def _rk4_projected(module, par, times, y0, step, t_stop, stop: StopCondition | None, checked: Callable):
    """rk4 step by step, projecting onto the constraints after each step as the C driver does;
    output rows inside a step come from that step's dense output (and the stop condition's row)."""
    rows, stats, k, n, y = [y0], {"accepted": 0, "rejected": 0, "rhs_evals": 0}, 1, 0, y0
    try:
        while k < len(times):
            start, end = times[0] + n * step, min(times[0] + (n + 1) * step, t_stop)
            inside = [t for t in times[k:] if t <= end]
            grid = np.array([start, *inside] + ([] if inside and inside[-1] == end else [end]))
            try:
                Y, counts = integrate_rk4(checked(lambda t, x: module.rhs(t, x, par)), grid, y, end - start, stop)
                if stop is not None and stop.time is not None:     # the last row is at the stop time
                    inside = [*inside[:len(Y) - 2], stop.time]
                projected = [project(module, par, t, row)[0] for t, row in zip(inside, Y[1:1 + len(inside)])]
                y_end, _ = project(module, par, end, Y[-1])
            except IntegrationFailure as failure:       # with the rows of this run, not of the one step
                raise IntegrationFailure(str(failure), failure.t, failure.y, np.array(rows), len(rows),
                                         failure.status) from None
            except np.linalg.LinAlgError:
                raise IntegrationFailure("projection failed", start, y, np.array(rows), len(rows),
                                         PROJECTION_FAILED) from None
            rows.extend(projected)
            for key in stats:
                stats[key] += counts.get(key, 0)
            if stop is not None and stop.time is not None:
                break
            y = y_end
            k, n = k + len(inside), n + 1
    except KeyboardInterrupt:
        raise IntegrationFailure("rk4: interrupted", times[0] + n * step, y, np.array(rows),
                                 status=INTERRUPTED) from None
    return np.array(rows), stats


def project(module, par, t, y, iterations: int = 10):
    """Project y onto the constraints (the same Gauss-Newton/least-norm steps as the C driver)."""
    y = np.array(y, dtype=float)
    n = len(y) // 2
    moved = 0.0
    h = module.HOLONOMIC
    for _ in range(iterations if h else 0):
        g, _, A = module.constraint_rows(par, t, y)
        Ah = A[:h]
        dq = Ah.T @ np.linalg.solve(Ah @ Ah.T, g)
        y[:n] -= dq
        moved = max(moved, float(np.max(np.abs(dq))))
        if np.max(np.abs(dq)) <= 4 * np.finfo(float).eps * (1 + np.max(np.abs(y[:n]))):
            break
    _, c, A = module.constraint_rows(par, t, y)
    dv = A.T @ np.linalg.solve(A @ A.T, c)
    y[n:] -= dv
    return y, max(moved, float(np.max(np.abs(dv), initial=0.0)))
