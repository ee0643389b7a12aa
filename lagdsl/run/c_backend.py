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
from .interrupt import RunInterrupt, called_here, interruptible
from .loading import load
from .output import Deferred, Result, RunSummary, Stiffness, Stop, Switches
from .scipy_steps import Progress
from .status import simulation_error

if TYPE_CHECKING:
    from ..codegen import GeneratedSource
    from ..codegen.kernel import Kernel

_new = object.__new__
SPARE_ROWS = 2              # row arrays a repeated run keeps: the one its caller holds during the next call, and one more
SPARE_ROWS_BYTES = 2 ** 20  # kept only up to this size: a larger array is made in a small part of its run's time


def run_c(kernel: Kernel, source: GeneratedSource, plan: RunPlan, progress: Progress | None = None,
          loaded: ctypes.CDLL | None = None) -> Result:
    return CRun(loaded if loaded is not None else load(source), plan)(progress)


class CRun:
    """A run of `plan` with the loaded library, its arrays and pointers made once: a repeated
    simulate() with the same inputs (api.Model keeps it) pays only the call and its result, whose
    columns carry `units` and `origin` (model_runs.description)."""

    def __init__(self, library: ctypes.CDLL, plan: RunPlan, units: tuple[str, ...] | None = None, origin: str = ""):
        self.plan = plan
        self._fields = Result.run_fields(plan.columns, units, origin)
        self._entry, self._guarded = _entries(library)
        self._layout = plan_summary(plan)
        self._rows_at = self._layout.offsets["rows"]
        shape = (grid_rows(plan.time.start, plan.time.stop, plan.time.interval), len(plan.columns) + 1)
        self._capacity, self._capacity_long = shape[0], ctypes.c_long(shape[0])     # lag_run_guarded's type
        self._rows = _RowArrays(shape, ctypes.c_double * self._layout.size)
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
        summary is made from the summary's doubles (a ctypes array kept with the rows) when first
        asked for (a fit reads only the values).

        After a long integration every Python operation costs several times what it costs warm,
        where the caches have been emptied (benchmarks/simulate_overhead.py): a call that fills
        its grid makes no NumPy array and no ctypes object (the views and the summary's array
        come with the rows), and the summary's doubles are read whole (a slice to a list) only
        where a summary or an error is made."""
        plan = self.plan
        taken = self._rows.take()
        rows, t, values, view, summary = taken
        arguments = (*self._pointers, view, self._capacity_long, summary)
        done = called_here(self._interrupt, self._entry, arguments, self._guarded) if progress is None else None
        if done is None:
            poll = None if progress is None else lambda: progress(self._reached.value, plan.time.start, plan.time.stop)
            done = interruptible(self._interrupt, self._entry, poll, arguments, self._guarded)
        status, elapsed = done
        used = int(summary[self._rows_at])
        if used != self._capacity:          # a stop condition, a failure: the rows made
            t, values = rows[:used, 0], rows[:used, 1:]
        result = _new(Result)           # as Result.run_fields says: no dataclass __init__, which sets
        fields = result.__dict__        # each field through object.__setattr__
        fields.update(self._fields)
        fields["t"], fields["values"] = t, values
        fields["summary"] = Deferred(_run_summary, plan, self._layout, summary, elapsed)
        if status != 0:
            numbers, at = summary[:], self._layout.offsets      # a list reads faster than a record, field by field
            y_fail = numbers[at["y_fail"]:at["y_fail"] + len(plan.initial_state)]
            raise simulation_error(plan, status, numbers[at["t_fail"]], y_fail, result, numbers[at["rcond_fail"]],
                                   numbers[at["forecast"]])
        return result


class _RowArrays:
    """The arrays of `shape` a repeated run's rows go to, each with its views (t, the values: a
    run that fills its grid returns them as they are), its ctypes view (what lag_run is given) and
    its summary's doubles (of `summary_type`): those of an earlier call that no result holds any
    more, else new ones. After a long integration, making an array or a view costs a repeated
    simulate() microseconds each, where the caches have been emptied. An array is held while
    anything outside (a result, its t or values, a view of them) refers to it or to its views,
    which sys.getrefcount tells: then it is left as it is, and a later call takes another. The
    summary goes with them: only the result of its rows reads it."""

    def __init__(self, shape: tuple[int, int], summary_type: type):
        self._shape, self._view_type, self._summary_type = shape, ctypes.c_double * (shape[0] * shape[1]), summary_type
        small = shape[0] * shape[1] * 8 <= SPARE_ROWS_BYTES
        self._spare: list[tuple] | None = [] if small else None

    def take(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, ctypes.Array, ctypes.Array]:
        """Rows no result holds, their views of t and the values, their ctypes view and summary,
        kept at once for a later call (the last SPARE_ROWS), which will take them once their result
        is no longer held. Rows are looked at while out of the list and the tuple is counted too
        (its caller holds it during the call): list.pop and append are atomic, so that calls from
        several threads each take their own."""
        spare = self._spare
        if spare is None:
            return _rows(self._shape, self._view_type, self._summary_type)
        for _ in range(len(spare)):     # oldest first; one held goes to the back
            try:
                kept = spare.pop(0)
            except IndexError:          # another thread took the last
                break
            free = (sys.getrefcount(kept) == _UNHELD_TUPLE and sys.getrefcount(kept[0]) == _UNHELD_ROWS
                    and sys.getrefcount(kept[1]) == _UNHELD_VIEW and sys.getrefcount(kept[2]) == _UNHELD_VIEW)
            spare.append(kept)
            if free:
                return kept
        taken = _rows(self._shape, self._view_type, self._summary_type)
        spare.append(taken)
        if len(spare) > SPARE_ROWS:
            try:
                spare.pop(0)
            except IndexError:
                pass
        return taken


def _rows(shape: tuple[int, int], view_type: type, summary_type: type) -> tuple:
    """New rows of `shape`, as _RowArrays.take gives them."""
    rows = np.empty(shape)
    return rows, rows[:, 0], rows[:, 1:], view_type.from_buffer(rows), summary_type()


def _unheld() -> tuple[int, int, int]:
    """sys.getrefcount of kept rows (the tuple, the rows, their views) that nothing outside holds,
    out of the list: the loop's variable and the call's argument; the tuple, the ctypes view's
    buffer, the views' base."""
    kept = _rows((1, 2), ctypes.c_double * 2, ctypes.c_double * 1)
    return sys.getrefcount(kept), sys.getrefcount(kept[0]), sys.getrefcount(kept[1])


_UNHELD_TUPLE, _UNHELD_ROWS, _UNHELD_VIEW = _unheld()


def _entries(library: ctypes.CDLL) -> tuple:
    """The library's lag_run, its argument types set, and lag_run_guarded (lag_run within its
    Ctrl-C guard, interrupt.py) or None where it has none. lag_run_guarded, called once a
    repeated run, is given exactly its C types (ints, ctypes arrays, a c_long, a pointer, as
    CRun.__call__ and interrupt._Guarded pass them), without argtypes: converting its eight
    arguments by argtypes took 3.3 us of a call, 1 us without (warm, timeit)."""
    double_p = ctypes.POINTER(ctypes.c_double)
    entry = library.lag_run
    entry.argtypes, entry.restype = [double_p, double_p, double_p, double_p, ctypes.c_long, double_p], ctypes.c_int
    guarded = library["lag_run_guarded"] if hasattr(library, "lag_run_guarded") else None   # its own function object
    if guarded is not None:
        guarded.restype = ctypes.c_int
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
