"""The C backend: the generated library called through ctypes, its run summary read back.

lag_run takes the parameters, the initial state and the settings (abi.SETTINGS) as arrays of
doubles and fills the output rows and the run summary, whose fields abi.SummaryLayout lays out.
"""
from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING

import numpy as np

from ..abi import SummaryLayout, plan_summary, settings_vector
from ..integrators import SWITCH_TIMES
from ..settings import RunPlan
from .interrupt import interruptible
from .loading import load
from .output import Result, RunSummary, Stiffness, Stop, Switches, output_times
from .scipy_steps import Progress
from .status import simulation_error

if TYPE_CHECKING:
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel


def run_c(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
          loaded: ctypes.CDLL | None = None) -> Result:
    library = loaded if loaded is not None else load(source)
    entry = library.lag_run
    double_p = ctypes.POINTER(ctypes.c_double)
    entry.argtypes = [double_p, double_p, double_p, double_p, ctypes.c_long, double_p]
    entry.restype = ctypes.c_int
    times = output_times(plan)
    settings = settings_vector(plan)
    parameters = np.array(plan.parameters or (0.0,), dtype=float)
    initial = np.array(plan.initial_state, dtype=float)
    rows = np.zeros((len(times), len(plan.columns) + 1))
    layout = plan_summary(plan)
    summary = np.zeros(layout.size)
    # an array of doubles over the array's memory: ctypes passes it as a double*, in a fifth of
    # the time of ndarray.ctypes.data_as, which a short run pays five times
    pointer = lambda a: (ctypes.c_double * a.size).from_buffer(a)   # noqa: E731
    reached = ctypes.c_double.in_dll(library, "lag_progress_t")
    poll = None if progress is None else lambda: progress(reached.value, plan.time.start, plan.time.stop)
    status, elapsed = interruptible(
        library, lambda: entry(pointer(parameters), pointer(initial), pointer(settings), pointer(rows),
                               len(times), pointer(summary)), poll)
    values, at = summary.tolist(), layout.offsets      # a list reads faster than a record, field by field
    used = int(values[at["rows"]])
    result = Result(rows[:used, 0].copy(), plan.columns, rows[:used, 1:].copy(),
                    _run_summary(plan, layout, values, elapsed))
    if status != 0:
        y_fail = values[at["y_fail"]:at["y_fail"] + len(plan.initial_state)]
        raise simulation_error(plan, status, values[at["t_fail"]], y_fail, result, values[at["rcond_fail"]],
                               values[at["forecast"]])
    return result


def _run_summary(plan: RunPlan, layout: SummaryLayout, values: list[float], elapsed: float) -> RunSummary:
    """The RunSummary of a summary's doubles, `values`, laid out as `layout`."""
    at = layout.offsets
    counts = {name: int(values[at[name]]) for name in layout.counters}
    invariants = tuple((name, values[at["invariant_start"] + i], values[at["invariant_drift"] + i])
                       for i, name in enumerate(plan.invariants))
    return RunSummary("c", plan.integrator.name, tuple(counts.items()), elapsed, invariants, plan.constraints,
                      values[at["residual"]] if plan.constraints else None,
                      values[at["projection"]] if plan.constraints else None,
                      plan.integrator.options,
                      stiffness=_stiffness(values, at, counts) if "stiff" in at else None,
                      switches=_switches(values, at) if "switches" in at else None,
                      stopped=Stop(plan.stop, values[at["t_stop"]]) if plan.stop and values[at["stopped"]] else None)


def _stiffness(values: list[float], at: dict[str, int], counts: dict) -> Stiffness | None:
    """The stiffness test's verdict: its kind, when, the fast mode, and the work done since."""
    if not values[at["stiff"]]:
        return None
    return Stiffness(int(values[at["stiff"]]), values[at["stiff_time"]], values[at["stiff_rate"]],
                     values[at["stiff_amplitude"]], int(counts["accepted"] - values[at["stiff_accepted"]]),
                     int(counts["rejected"] - values[at["stiff_rejected"]]),
                     int(counts["rhs_evals"] - values[at["stiff_rhs_evals"]]), counts["rhs_evals"])


def _switches(values: list[float], at: dict[str, int]) -> Switches:
    """auto's switches: how many, the times of the first ones logged, the span of t of each method."""
    count = int(values[at["switches"]])
    times = tuple(values[at["switch_times"]:at["switch_times"] + min(count, SWITCH_TIMES)])
    spans = (values[at["explicit_span"]], values[at["implicit_span"]])
    return Switches(("dop853", "radau5"), count, times, spans)
