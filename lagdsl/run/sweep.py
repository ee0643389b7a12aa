"""Many runs per call: `Model.sweep`, the batch paths of both backends, and Dask distribution.

A sweep integrates B members of one scene, each with its own parameters and initial state, on the
scene's common output grid. Member b's inputs are exactly those `simulate(set={k: v[b]})` would
plan, so on the C backend member b's rows equal that run's bit for bit: the batch entry point
`lag_run_batch` calls the same `lag_integrate` with the same inputs, in parallel over members
with OpenMP when the library was built with it. A failing member (singular mass matrix, NaN,
step-size collapse, step limit) is marked with its status and time and ends alone.
"""
from __future__ import annotations

import ctypes
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from ..abi import HOPELESS, INTERRUPTED, SummaryLayout, member_summary, plan_summary, settings_vector, status_of
from ..errors import LagError, SimulationError, SimulationInterrupted
from ..integrators import registry
from ..given_values import InputUnit, input_in_si
from ..settings import Overrides, RunPlan
from .interrupt import CtrlC, RunInterrupt, interruptible
from .numpy_backend import run_numpy
from .output import output_times
from .tables import csv_text, parquet_bytes
from .scipy_steps import SCIPY_RTOL_FLOOR, ScipyProblem, integrate_scipy

if TYPE_CHECKING:       # the scene's full plan needs sympy; a warm `lagc sweep` runs a stored plan (plans.py)
    from ..scene import ScenePlan

NUMPY_CHUNK = 256            # NumPy: members integrated as one stacked system
# (first member's plan, varied inputs) -> the parameter and coordinate names to put values in, or None
Placement = Callable[[RunPlan, dict], tuple[list[str], list[str], dict[str, InputUnit]] | None]


@dataclass(frozen=True)
class SweepSummary:
    """Totals of a sweep: members, how many failed and why, the work, the wall time."""

    members: int
    failures: tuple[tuple[str, int], ...]      # failure message -> how many members
    counters: tuple[tuple[str, int], ...]      # totals over members (accepted, rhs_evals, ...)
    wall_time: float
    backend: str
    integrator: str
    workers: str                               # "2 threads", "Dask, 4 chunks", ...

    @property
    def failed(self) -> int:
        return sum(count for _, count in self.failures)

    def render(self) -> str:
        totals = ", ".join(f"{value} {name}" for name, value in self.counters)
        lines = [f"sweep of {self.members} members, {self.integrator} ({self.backend}, {self.workers}): "
                 f"{self.members - self.failed} ok, {self.failed} failed; {totals}{', ' if totals else ''}"
                 f"{self.wall_time:.3g} s"]
        lines += [f"  {count} failed: {message}" for message, count in self.failures]
        return "\n".join(lines)


def merge(first: SweepSummary | None, then: SweepSummary) -> SweepSummary:
    """The summary of two parts of one sweep (`first` None: `then` alone)."""
    if first is None:
        return then
    failures = dict(first.failures)
    for message, count in then.failures:
        failures[message] = failures.get(message, 0) + count
    counters = dict(first.counters)
    for name, count in then.counters:
        counters[name] = counters.get(name, 0) + count
    return replace(first, members=first.members + then.members,
                   failures=tuple(sorted(failures.items(), key=lambda kv: -kv[1])),
                   counters=tuple(counters.items()), wall_time=first.wall_time + then.wall_time)


@dataclass(frozen=True)
class Sweep:
    """The runs of a sweep on their common grid `t` (T,).

    `values` is (B, T, C) for the `columns`; `sweep["theta1"]` is (B, T). `inputs` maps each name
    that was set to its B values. `status` (B,) is "ok" or the failure; a failed member's rows
    after its `failure_time` are NaN. `counters` maps each work counter to its B values.
    """

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray
    inputs: dict[str, np.ndarray]
    status: np.ndarray
    failure_time: np.ndarray
    counters: dict[str, np.ndarray]
    summary: SweepSummary
    rows: np.ndarray = field(repr=False)        # rows delivered per member
    first_member: int = 0                       # the number of member 0 in a larger sweep (a block)

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, column: str) -> np.ndarray:
        try:
            return self.values[:, :, self.columns.index(column)]
        except ValueError:
            raise KeyError(f"no column '{column}' (columns: {', '.join(self.columns)})") from None

    def tidy(self) -> dict[str, np.ndarray]:
        """One row per member and output time: member, the inputs, t, the columns, status."""
        members, times = len(self.values), len(self.t)
        table = {"member": np.repeat(np.arange(self.first_member, self.first_member + members), times)}
        table.update({name: np.repeat(values, times) for name, values in self.inputs.items()})
        table["t"] = np.tile(self.t, members)
        table.update({name: self.values[:, :, j].reshape(-1) for j, name in enumerate(self.columns)})
        table["status"] = np.repeat(self.status, times)
        return table

    def csv(self) -> str:
        """The tidy table as CSV (run.output.csv_text)."""
        table = self.tidy()
        return csv_text(table, table.values())

    def parquet(self) -> bytes:
        """The tidy table as a Parquet file (needs pyarrow)."""
        return parquet_bytes(self.tidy())

    def to_dataframe(self):
        """The tidy table as a pandas DataFrame (a dict of columns when pandas is not installed)."""
        try:
            import pandas
        except ImportError:
            return self.tidy()
        return pandas.DataFrame(self.tidy())


@dataclass(frozen=True)
class Members:
    """The inputs of B members: parameters (B, NP) and initial states (B, NY), as planned."""

    plan: RunPlan                 # member 0's plan (a ScenePlan, or a stored plan's): the grid, integrator and options of all
    parameters: np.ndarray
    initial: np.ndarray
    inputs: dict[str, np.ndarray]


def _values_in_si(name: str, given: np.ndarray, unit: InputUnit | None) -> np.ndarray | list[float]:
    """Each member's value of input `name` in SI (given_values.input_in_si): numbers in SI already (no
    unit, or one whose factor is 1) as they are, in one conversion of the array; any other value
    one by one (a text's own unit, a factor rounded once with the value)."""
    if given.dtype.kind in "fiu" and (unit is None or unit.factor == 1):
        return given.astype(float)
    return [input_in_si(name, value, unit) for value in given.tolist()]


def member_inputs(plan: Callable[[Overrides], RunPlan], base: Overrides, varied: dict,
                  placement: Placement | None = None) -> Members:
    """Plan every member. `plan(overrides)` plans one run; `varied` maps names simulate(set=...)
    takes to scalars or 1-D arrays of one length B.

    When nothing planned depends on a varied parameter (no parameter computed from others, no
    start value that is an expression), member b's inputs are member 0's with its values put in
    place, as plan_scene would put them; otherwise every member is planned. `placement(first,
    inputs)` says which: the names of the parameters and coordinates to put values in, or None
    (default: read from the ScenePlan `first`, scene_placement).
    """
    inputs = broadcast(varied)
    count = len(next(iter(inputs.values()))) if inputs else 1
    first = plan(_with_values(base, inputs, 0))
    parameters = np.tile(np.array(first.parameters, dtype=float), (count, 1))
    initial = np.tile(np.array(first.initial_state, dtype=float), (count, 1))
    names = (placement or scene_placement)(first, inputs)
    if names is None:
        for b in range(1, count):
            member = plan(_with_values(base, inputs, b))
            parameters[b], initial[b] = member.parameters, member.initial_state
        return Members(first, parameters, initial, inputs)
    _check_finite(inputs)
    parameter_names, coordinates, declared = names
    for name, given in inputs.items():
        values = _values_in_si(name, given, declared.get(name))
        coordinate, _, part = name.rpartition(".")
        if name in parameter_names:
            parameters[:, parameter_names.index(name)] = values
        elif part == "start":
            initial[:, coordinates.index(coordinate)] = values
        else:
            initial[:, len(coordinates) + coordinates.index(coordinate)] = values
    return Members(first, parameters, initial, inputs)


def scene_placement(plan: ScenePlan, inputs: dict) -> tuple[list[str], list[str], dict[str, InputUnit]] | None:
    """The names of the parameters and coordinates of `plan`'s model and the declared units of
    its inputs, or None when a varied parameter enters other values (every member is then planned)."""
    from ..scene import input_units      # the model's units: only where a ScenePlan, and so sympy, is there
    if _inputs_depend_on_parameters(plan, inputs):
        return None
    return ([p.name for p in plan.model.parameters], [c.name for c in plan.model.coordinates],
            dict(input_units(plan.model)))


def broadcast(varied: dict) -> dict[str, np.ndarray]:
    for name, value in varied.items():
        if isinstance(value, str):
            raise LagError(f"sweep: the values of '{name}' are numbers, each in its declared unit; '{value}' (a value with its unit) "
                           "is taken by run and bench only")
    arrays = {name: np.asarray(value, dtype=float) for name, value in varied.items()}
    for name, array in arrays.items():
        if array.ndim > 1:
            raise LagError(f"sweep: the values of '{name}' must be a number or a 1-D array, not an array of "
                           f"shape {array.shape}")
    lengths = sorted({len(a) for a in arrays.values() if a.ndim == 1})
    if len(lengths) > 1:
        given = ", ".join(f"{name}: {len(a)}" for name, a in arrays.items() if a.ndim == 1)
        raise LagError(f"sweep: the arrays of values must have one common length ({given})")
    count = lengths[0] if lengths else 1
    if count == 0:
        raise LagError("sweep: no members (the arrays of values are empty)")
    return {name: np.broadcast_to(array, (count,)).copy() for name, array in arrays.items()}


def _with_values(base: Overrides, inputs: dict[str, np.ndarray], member: int) -> Overrides:
    return replace(base, values=base.values + tuple((name, float(v[member])) for name, v in inputs.items()))


def _inputs_depend_on_parameters(plan: ScenePlan, inputs: dict) -> bool:
    names = {p.name for p in plan.model.parameters}
    if not names & inputs.keys():
        return False
    given = {name: (start, velocity) for name, start, velocity in plan.initial}
    derived = any(p.expression.free_symbols and p.name not in plan.fixed_parameters for p in plan.model.parameters)
    symbolic_start = any(expression.free_symbols and value is None
                         for c in plan.model.coordinates
                         for expression, value in zip((c.start, c.velocity), given.get(c.name, (None, None))))
    return derived or symbolic_start


def _check_finite(inputs: dict[str, np.ndarray]) -> None:
    for name, values in inputs.items():
        bad = np.flatnonzero(~np.isfinite(values))
        if len(bad):
            raise LagError(f"cannot set '{name}' to {values[bad[0]]} (member {bad[0]}): values must be finite numbers")


# ---- the C batch entry point -------------------------------------------------------------------
@dataclass(frozen=True)
class BatchLayout:
    """What lag_run_batch needs besides the members: shared settings, grid rows, the summaries."""

    settings: tuple[float, ...]
    rows: int
    columns: int
    summary: SummaryLayout

    @property
    def counters(self) -> tuple[str, ...]:
        return self.summary.counters


def batch_layout(plan: ScenePlan) -> BatchLayout:
    return BatchLayout(tuple(settings_vector(plan)), len(output_times(plan)), len(plan.columns), plan_summary(plan))


def run_c_batch(library: ctypes.CDLL, layout: BatchLayout, parameters: np.ndarray, initial: np.ndarray,
                threads: int, on_progress: Callable[[int], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(values (B, T, C), summaries (B records of layout.summary)) of lag_run_batch; rows not
    delivered are NaN.
    `on_progress(members finished)` is called every so often; Ctrl-C stops the members in flight."""
    count = len(initial)
    values = np.full((count, layout.rows, layout.columns), np.nan)
    summaries = layout.summary.empty(count)
    packed = np.ascontiguousarray(parameters if parameters.shape[1] else np.zeros((count, 0)))
    state = np.ascontiguousarray(initial)
    settings = np.array(layout.settings)
    entry = library.lag_run_batch
    double_p = ctypes.POINTER(ctypes.c_double)
    entry.argtypes = [ctypes.c_long, double_p, double_p, double_p, double_p, ctypes.c_long, double_p,
                      ctypes.c_long, ctypes.c_int]
    entry.restype = None
    pointer = lambda a: a.ctypes.data_as(double_p)   # noqa: E731
    done = ctypes.c_long.in_dll(library, "lag_batch_done")

    def call() -> int:
        entry(count, pointer(packed), pointer(state), pointer(settings), pointer(values), layout.rows,
              pointer(summaries), layout.summary.size, threads)
        return INTERRUPTED if np.any(summaries["status"] == INTERRUPTED) else 0

    interruptible(RunInterrupt(library), call, None if on_progress is None else lambda: on_progress(done.value))
    if on_progress is not None:
        on_progress(count)
    return values, summaries


def default_threads(workers: int | None) -> int:
    """`workers`, else OMP_NUM_THREADS, else the CPUs this process may use."""
    if workers is not None:
        if int(workers) < 1:
            raise LagError(f"sweep: workers must be at least 1, not {workers}")
        return int(workers)
    given = os.environ.get("OMP_NUM_THREADS", "").split(",")[0].strip()
    if given.isdigit() and int(given) > 0:
        return int(given)
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


# ---- reading the summaries ---------------------------------------------------------------------
def statuses(plan: ScenePlan, summaries: np.ndarray) -> np.ndarray:
    codes = summaries["status"].astype(int)
    messages = np.full(len(codes), "ok", dtype=object)
    for code in np.unique(codes[codes != 0]):
        messages[codes == code] = status_of(int(code)).describe(plan.max_steps)
    for member in np.flatnonzero(codes == HOPELESS):       # each with its own forecast
        messages[member] = status_of(HOPELESS).describe(plan.max_steps, forecast=float(summaries["forecast"][member]),
                                                        t_end=plan.time.stop)
    return messages


def assemble(plan: ScenePlan, members: Members, values: np.ndarray, summaries: np.ndarray, backend: str,
             counters: tuple[str, ...], wall_time: float, workers: str, first_member: int = 0) -> Sweep:
    """The Sweep of a batch run; raises SimulationInterrupted (with the sweep as `.partial`) after Ctrl-C."""
    status = statuses(plan, summaries)
    codes = summaries["status"].astype(int)
    failure_time = np.where(codes != 0, summaries["t_fail"], np.nan)
    counts = {name: summaries[name].astype(np.int64) for name in counters}
    failures = {}
    for message in status[codes != 0]:
        failures[message] = failures.get(message, 0) + 1
    summary = SweepSummary(len(codes), tuple(sorted(failures.items(), key=lambda kv: -kv[1])),
                           tuple((name, int(c.sum())) for name, c in counts.items()), wall_time, backend,
                           plan.integrator.name, workers)
    sweep = Sweep(output_times(plan), plan.columns, values, members.inputs, status, failure_time, counts, summary,
                  summaries["rows"].astype(np.int64), first_member)
    if np.any(codes == INTERRUPTED):
        first = int(np.flatnonzero(codes == INTERRUPTED)[0])
        raise SimulationInterrupted("interrupted", float(summaries["t_fail"][first]), {}, "", sweep, INTERRUPTED)
    return sweep


# ---- NumPy -------------------------------------------------------------------------------------
def run_numpy_batch(module, kernel, source, members: Members, on_progress: Callable[[int], None] | None = None
                    ) -> tuple[np.ndarray, np.ndarray, tuple[str, ...]]:
    """The NumPy backend's batch path: (values, summaries (abi.member_summary), counters).

    Chunks of NUMPY_CHUNK members of an explicit scipy method without constraints are integrated as one
    stacked system, states (n, B) through one vectorised right-hand side. scipy controls the
    error of the stacked state as one RMS norm, so the tolerances are divided by sqrt(B): each
    member's own RMS error norm then meets rtol and atol as in a single run, though the members
    share their steps (they do not equal simulate() bit for bit). A chunk that fails anywhere is
    rerun member by member, as simulate() runs them, so a failing member ends alone; so is a chunk
    whose divided tolerances scipy would not take as they are (atol = 0, rtol below its floor).
    """
    plan = members.plan
    count = len(members.initial)
    counters = ("accepted", "rhs_evals")
    values = np.full((count, len(output_times(plan)), len(plan.columns)), np.nan)
    summaries = member_summary(counters).empty(count)
    # (a stop condition ends each member at its own time: members run one at a time then)
    stacked = registry.get(plan.integrator.name).stacks_in_sweeps and not plan.constraints and plan.stop is None
    size = NUMPY_CHUNK if stacked else 1
    interrupted = False
    with CtrlC() as ctrl_c:
        try:
            for lo in range(0, count, size):
                hi = min(lo + size, count)
                if not (stacked and _stacked_chunk(module, members, lo, hi, values, summaries, ctrl_c)):
                    for b in range(lo, hi):
                        if not ctrl_c.pressed:
                            _single_member(module, kernel, source, members, b, values, summaries)
                if ctrl_c.pressed:
                    break
                if on_progress is not None:
                    on_progress(hi)
        except KeyboardInterrupt:
            interrupted = True
    if interrupted or ctrl_c.pressed:
        # Ctrl-C stops the sweep, as in C: the member it stopped keeps its rows and is marked
        # interrupted (by run_numpy or the stacked chunk), and so are the members not begun
        summaries["status"][(summaries["status"] == 0) & (summaries["rows"] == 0)] = INTERRUPTED
    return values, summaries, counters


def _stacked_chunk(module, members: Members, lo: int, hi: int, values: np.ndarray, summaries: np.ndarray,
                   ctrl_c: CtrlC) -> bool:
    """Integrate members lo..hi-1 as one system; False (nothing written) if it fails anywhere.
    After Ctrl-C the rows reached are written, the members marked interrupted, and
    KeyboardInterrupt raised again."""
    plan = members.plan
    times = output_times(plan)
    options = dict(plan.integrator.options)
    par = members.parameters[lo:hi].T
    y0 = members.initial[lo:hi].T
    n, count = y0.shape
    atol_each = plan.atol_vector(plan.coordinates)          # component i of member b is entry i*count + b
    atol = np.repeat(atol_each, count) if atol_each is not None else options["atol"]
    rtol, atol = options["rtol"] / math.sqrt(count), atol / math.sqrt(count)
    if not (np.all(atol > 0) and rtol >= SCIPY_RTOL_FLOOR):
        return False        # what scipy would change or cannot start with: as single runs

    @ctrl_c.checked
    def fun(t, y):
        return module.rhs(t, y.reshape(n, count), par).reshape(-1)

    problem = ScipyProblem.of(plan.integrator.name, fun, None, rtol, atol, options.get("max_step"), plan.max_steps,
                              watch=False)
    with np.errstate(all="ignore"):
        states, counts, failure = integrate_scipy(problem, times, y0.reshape(-1))
        if failure is not None and failure[0] != INTERRUPTED:
            return False
        rows = len(states)
        grid = np.array(states).reshape(rows, n, count)
        try:
            observed = [module.observables(times[:rows], grid[:, :, j].T, members.parameters[lo + j])[0]
                        for j in range(count)]
        except (np.linalg.LinAlgError, ValueError, ArithmeticError):
            return False
    values[lo:hi, :rows] = np.transpose(np.array(observed), (0, 2, 1))
    chunk = summaries[lo:hi]
    chunk["rows"], chunk["accepted"], chunk["rhs_evals"] = rows, counts["accepted"], counts["rhs_evals"]
    if failure is not None:
        chunk["status"], chunk["t_fail"] = INTERRUPTED, failure[1]
        raise KeyboardInterrupt
    return True


def _single_member(module, kernel, source, members: Members, b: int, values: np.ndarray,
                   summaries: np.ndarray) -> None:
    plan = replace(members.plan, parameters=tuple(members.parameters[b]),
                   initial_state=tuple(members.initial[b]))
    try:
        result, status, t_fail, forecast = run_numpy(kernel, source, plan, None, module), 0, 0.0, math.nan
    except SimulationError as error:
        result, status, t_fail, forecast = error.partial, error.status, error.time, error.forecast
    values[b, :len(result.t)] = result.values
    member = summaries[b:b + 1]
    member["status"], member["rows"], member["t_fail"], member["forecast"] = status, len(result.t), t_fail, forecast
    for counter in ("accepted", "rhs_evals"):
        member[counter] = result.summary.count(counter) or 0
