"""The C backend: the generated library called through ctypes, its run summary read back.

lag_run takes the parameters, the initial state and the settings (abi.SETTINGS) as arrays of
doubles and fills the output rows and the run summary, whose fields abi.SummaryLayout lays out.
"""
from __future__ import annotations

import ctypes
import sys
from typing import TYPE_CHECKING

import numpy as np

from ..abi import SummaryLayout, plan_summary, settings_vector
from ..integrators import SWITCH_TIMES
from ..settings import RunPlan, grid_rows
from .interrupt import RunInterrupt, interruptible
from .loading import load
from .output import Deferred, Result, RunSummary, Stiffness, Stop, Switches
from .scipy_steps import Progress
from .status import simulation_error

if TYPE_CHECKING:
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel

SPARE_ROWS = 2              # row arrays a repeated run keeps: the one its caller holds during the next call, and one more
SPARE_ROWS_BYTES = 2 ** 20  # kept only up to this size: a larger array is made in a small part of its run's time


def run_c(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
          loaded: ctypes.CDLL | None = None) -> Result:
    return CRun(loaded if loaded is not None else load(source), plan)(progress)


class CRun:
    """A run of `plan` with the loaded library, its arrays and pointers made once: a repeated
    simulate() with the same inputs (api.Model keeps it) pays only the call and its result, whose
    columns carry `units` and `origin` (api._description)."""

    def __init__(self, library: ctypes.CDLL, plan: RunPlan, units: tuple[str, ...] | None = None, origin: str = ""):
        self.plan, self._description = plan, (units, origin)
        self._entry, self._guarded = _entries(library)
        self._layout = plan_summary(plan)
        self._rows_at = self._layout.offsets["rows"]
        self._shape = (grid_rows(plan.time.start, plan.time.stop, plan.time.interval), len(plan.columns) + 1)
        self._rows = _RowArrays(self._shape)
        self._summary_type = ctypes.c_double * self._layout.size
        self._input_types = (ctypes.c_double * max(len(plan.parameters), 1), ctypes.c_double * len(plan.initial_state))
        self._settings = _doubles(settings_vector(plan))      # keeps the vector alive (from_buffer holds it)
        self._take_inputs(plan.parameters, plan.initial_state)
        self._interrupt = RunInterrupt(library)
        self._reached = ctypes.c_double.in_dll(library, "lag_progress_t")

    def with_inputs(self, parameters: tuple[float, ...], initial_state: tuple[float, ...]) -> CRun:
        """This run with other parameter values and initial state: the same program, grid,
        integrator and settings vector, new input arrays (a fit's next call). The run and its plan are copied by their __dict__:
        copy.copy and dataclasses.replace took a tenth of a short call."""
        run = object.__new__(CRun)
        run.__dict__.update(self.__dict__)
        run.plan = object.__new__(RunPlan)      # a frozen dataclass without __post_init__: its fields copied
        run.plan.__dict__.update(self.plan.__dict__, parameters=parameters, initial_state=initial_state)
        run._take_inputs(parameters, initial_state)
        return run

    def _take_inputs(self, parameters: tuple[float, ...], initial_state: tuple[float, ...]) -> None:
        """The input arrays, made once (a call only reads them; the rows and the summary are
        each call's own, as calls may come from several threads)."""
        parameter_array, state_array = self._input_types
        self._pointers = (parameter_array(*(parameters or (0.0,))), state_array(*initial_state), self._settings)

    def __call__(self, progress: Progress | None = None) -> Result:
        """The run's Result, whose t and values are views of a rows' array that no held result
        shares (_RowArrays), so that no copy follows the run and no later call touches them; its
        summary is made from the summary's doubles (a ctypes array of this call's) when first
        asked for (a fit reads only the values).

        NumPy is used as little as a call allows, two views (and an array with its buffer where
        none is free): after a long integration each costs several microseconds more than warm,
        where the caches have been emptied (benchmarks/simulate_overhead.py); so does all
        Python, and the summary's doubles are read whole (a slice to a list) only where a
        summary or an error is made."""
        plan, entry, capacity = self.plan, self._entry, self._shape[0]
        rows, view = taken = self._rows.take()
        summary = self._summary_type()
        arguments = (*self._pointers, view, capacity, summary)
        poll = None if progress is None else lambda: progress(self._reached.value, plan.time.start, plan.time.stop)
        status, elapsed = interruptible(self._interrupt, entry, poll, arguments, self._guarded)
        self._rows.keep(taken)
        used = int(summary[self._rows_at])
        result = Result.of_run(rows[:used, 0], plan.columns, rows[:used, 1:],
                               Deferred(_run_summary, plan, self._layout, summary, elapsed),
                               *self._description)
        if status != 0:
            values, at = summary[:], self._layout.offsets      # a list reads faster than a record, field by field
            y_fail = values[at["y_fail"]:at["y_fail"] + len(plan.initial_state)]
            raise simulation_error(plan, status, values[at["t_fail"]], y_fail, result, values[at["rcond_fail"]],
                                   values[at["forecast"]])
        return result


class _RowArrays:
    """The arrays of `shape` a repeated run's rows go to, each with its ctypes view (what lag_run
    is given): one that an earlier call made and that no result holds any more, else a new one.
    After a long integration, making the array and its view (np.empty, from_buffer) costs a
    repeated simulate() a fifth of its overhead, where the caches have been emptied. An array is
    held while anything outside (a result, its t or values, a view of them) refers to it, which
    sys.getrefcount tells: then it is left as it is, and a later call takes another."""

    def __init__(self, shape: tuple[int, int]):
        self._shape, self._view_type = shape, ctypes.c_double * (shape[0] * shape[1])
        small = shape[0] * shape[1] * 8 <= SPARE_ROWS_BYTES
        self._spare: list[tuple[np.ndarray, ctypes.Array]] | None = [] if small else None

    def take(self) -> tuple[np.ndarray, ctypes.Array]:
        """An array no result holds, and its view (list.pop and append are atomic: calls from
        several threads each take their own)."""
        spare = self._spare
        for _ in range(len(spare) if spare else 0):     # oldest first; one held goes to the back
            try:
                kept = spare.pop(0)
            except IndexError:          # another thread took the last
                break
            if sys.getrefcount(kept[0]) == _UNHELD:
                return kept
            spare.append(kept)
        rows = np.empty(self._shape)
        return rows, self._view_type.from_buffer(rows)

    def keep(self, taken: tuple[np.ndarray, ctypes.Array]) -> None:
        """Keep `taken` for a later call, once its result is no longer held (the last SPARE_ROWS)."""
        spare = self._spare
        if spare is not None:
            spare.append(taken)
            if len(spare) > SPARE_ROWS:
                try:
                    spare.pop(0)
                except IndexError:
                    pass


def _unheld() -> int:
    """sys.getrefcount of a kept array that nothing outside holds: the pair that keeps it, the
    buffer of its ctypes view, the call's argument."""
    rows = np.empty(1)
    kept = (rows, (ctypes.c_double * 1).from_buffer(rows))
    del rows
    return sys.getrefcount(kept[0])


_UNHELD = _unheld()


def _entries(library: ctypes.CDLL) -> tuple:
    """The library's lag_run, and lag_run_guarded (lag_run within its Ctrl-C guard, interrupt.py)
    or None where it has none, their argument types set."""
    double_p = ctypes.POINTER(ctypes.c_double)
    arguments = [double_p, double_p, double_p, double_p, ctypes.c_long, double_p]
    entry, guarded = library.lag_run, getattr(library, "lag_run_guarded", None)
    entry.argtypes, entry.restype = arguments, ctypes.c_int
    if guarded is not None:
        guarded.argtypes, guarded.restype = [ctypes.c_int, ctypes.POINTER(ctypes.c_int), *arguments], ctypes.c_int
    return entry, guarded


def _doubles(array: np.ndarray):
    """An array of doubles over `array`'s memory: ctypes passes it as a double*, in a fifth of the
    time of ndarray.ctypes.data_as."""
    return (ctypes.c_double * array.size).from_buffer(array)


def _run_summary(plan: RunPlan, layout: SummaryLayout, summary: ctypes.Array, elapsed: float) -> RunSummary:
    """The RunSummary of a summary's doubles, laid out as `layout`."""
    values, at = summary[:], layout.offsets      # a list reads faster than a record, field by field
    counts = {name: int(values[at[name]]) for name in layout.counters}
    invariants = tuple((name, values[at["invariant_start"] + i], values[at["invariant_drift"] + i])
                       for i, name in enumerate(plan.invariants))
    return RunSummary("c", plan.integrator.name, tuple(counts.items()), elapsed, invariants, plan.constraints,
                      values[at["residual"]] if plan.constraints else None,
                      values[at["projection"]] if plan.constraints else None,
                      plan.integrator.options, atol_each=plan.integrator.atol_each,
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
