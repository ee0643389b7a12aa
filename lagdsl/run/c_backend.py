"""The C backend: the generated library called through ctypes, its run summary read back.

lag_run takes the parameters, the initial state and the settings as arrays of doubles and fills
the output rows and the run summary (driver.c.j2 documents both layouts).
"""
from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING

import numpy as np

from ..integrators import SWITCH_TIMES, registry, summary_extras
from ..integrators.registry import OPTION_ORDER
from ..settings import RunPlan
from .interrupt import interruptible
from .loading import load
from .output import Result, RunSummary, Stiffness, Stop, Switches, output_times
from .scipy_steps import Progress
from .status import simulation_error

if TYPE_CHECKING:
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel


def settings_array(plan: RunPlan) -> tuple[float, ...]:
    """lag_run's settings: t0, t1, dt, then the options in lag_options order (0: not given), the
    step limit last."""
    options = dict(plan.integrator.options)
    return (plan.time.start, plan.time.stop, plan.time.interval,
            *(float(options.get(k, 0.0)) for k in OPTION_ORDER if k != "max_steps"), float(plan.max_steps))


def run_c(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
          loaded: ctypes.CDLL | None = None) -> Result:
    library = loaded if loaded is not None else load(source)
    entry = library.lag_run
    double_p = ctypes.POINTER(ctypes.c_double)
    entry.argtypes = [double_p, double_p, double_p, double_p, ctypes.c_long, double_p]
    entry.restype = ctypes.c_int
    times = output_times(plan)
    settings = np.array(settings_array(plan))
    parameters = np.array(plan.parameters or (0.0,), dtype=float)
    initial = np.array(plan.initial_state, dtype=float)
    ncols = len(plan.columns)
    rows = np.zeros((len(times), ncols + 1))
    counters = registry.get(plan.integrator.name).counters
    head = 6 + len(counters)        # status, rows, t_fail, rcond_fail, residual, projection, counters
    extras = head + summary_extras(plan.integrator.name)     # the stiffness verdict, the switches
    failure_state = extras + 2 * len(plan.invariants)
    summary = np.zeros(failure_state + len(initial) + (2 if plan.stop else 0))
    pointer = lambda a: a.ctypes.data_as(double_p)   # noqa: E731
    reached = ctypes.c_double.in_dll(library, "lag_progress_t")
    poll = None if progress is None else lambda: progress(reached.value, plan.time.start, plan.time.stop)
    status, elapsed = interruptible(
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
                        if registry.get(name).stiffness_test else None,
                        switches=_c_switches(summary[head:]) if name == "auto" else None,
                        stopped=Stop(plan.stop, float(summary[-1])) if plan.stop and summary[-2] else None)
    result = Result(rows[:used, 0].copy(), plan.columns, rows[:used, 1:].copy(), report)
    if status != 0:
        raise simulation_error(plan, status, float(summary[2]), summary[failure_state:failure_state + len(initial)], result,
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
