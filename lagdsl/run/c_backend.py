"""The C backend: the generated library called through ctypes, its run summary read back.

lag_run takes the parameters, the initial state and the settings (abi.SETTINGS) as arrays of
doubles and fills the output rows and the run summary, whose fields abi.SummaryLayout lays out.
"""
from __future__ import annotations

import ctypes
from typing import TYPE_CHECKING

import numpy as np

from ..abi import plan_summary, settings_vector
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
    summary = layout.empty(1)
    pointer = lambda a: a.ctypes.data_as(double_p)   # noqa: E731
    reached = ctypes.c_double.in_dll(library, "lag_progress_t")
    poll = None if progress is None else lambda: progress(reached.value, plan.time.start, plan.time.stop)
    status, elapsed = interruptible(
        library, lambda: entry(pointer(parameters), pointer(initial), pointer(settings), pointer(rows),
                               len(times), pointer(summary)), poll)
    record = summary[0]
    used = int(record["rows"])
    result = Result(rows[:used, 0].copy(), plan.columns, rows[:used, 1:].copy(),
                    _run_summary(plan, layout.counters, record, elapsed))
    if status != 0:
        raise simulation_error(plan, status, float(record["t_fail"]), record["y_fail"], result,
                               float(record["rcond_fail"]))
    return result


def _run_summary(plan: RunPlan, counters: tuple[str, ...], record: np.void, elapsed: float) -> RunSummary:
    """The RunSummary of a summary record (of the layout abi.plan_summary(plan))."""
    names = record.dtype.names
    counts = {name: int(record[name]) for name in counters}
    invariants = tuple((name, float(record["invariant_start"][i]), float(record["invariant_drift"][i]))
                       for i, name in enumerate(plan.invariants))
    return RunSummary("c", plan.integrator.name, tuple(counts.items()), elapsed, invariants, plan.constraints,
                      float(record["residual"]) if plan.constraints else None,
                      float(record["projection"]) if plan.constraints else None,
                      plan.integrator.options,
                      stiffness=_stiffness(record, counts) if "stiff" in names else None,
                      switches=_switches(record) if "switches" in names else None,
                      stopped=Stop(plan.stop, float(record["t_stop"])) if plan.stop and record["stopped"] else None)


def _stiffness(record: np.void, counts: dict) -> Stiffness | None:
    """The stiffness test's verdict: when it fired, and the work done since."""
    if not record["stiff"]:
        return None
    return Stiffness(float(record["stiff_time"]), int(counts["accepted"] - record["stiff_accepted"]),
                     int(counts["rejected"] - record["stiff_rejected"]),
                     int(counts["rhs_evals"] - record["stiff_rhs_evals"]), int(counts["rhs_evals"]))


def _switches(record: np.void) -> Switches:
    """auto's switches: how many, the times of the first ones logged, the span of t of each method."""
    count = int(record["switches"])
    times = tuple(float(t) for t in record["switch_times"][:count])
    spans = (float(record["explicit_span"]), float(record["implicit_span"]))
    return Switches(("dop853", "radau5"), count, times, spans)
