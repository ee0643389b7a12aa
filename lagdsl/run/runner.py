"""Run a scene: the C backend through ctypes (c_backend.py), the NumPy backend with scipy or our
Python methods (numpy_backend.py).

Both deliver the same `Result`: rows at the output grid t0, t0 + dt, ... < t1 and t1 itself
(`settings.grid_rows`), the scene's columns, and a `RunSummary`. A numerical failure raises
SimulationError naming the time, the state and a remedy (abi.py, status.py), with the rows computed so
far in `error.partial`. Every run is bounded by the plan's step limit, and Ctrl-C stops it
between two steps with SimulationInterrupted, which keeps the rows computed so far as well
(interrupt.py). `progress`, if given, is called as progress(t reached, start, stop) every
POLL_SECONDS in the C backend, after every step of scipy's solvers in the NumPy backend.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from ..settings import RunPlan, check_step_count, grid_rows
from .c_backend import CRun, run_c
from .memory import SMALL_RESULT, check_fits, run_bytes
from .loading import load  # noqa: F401  (what runs a GeneratedSource: part of this module's interface)
from .numpy_backend import run_numpy
from .output import Result
from .scipy_steps import Progress

if TYPE_CHECKING:
    from ..codegen import GeneratedSource


def run(plan: RunPlan, language: str, loaded=None, progress: Progress | None = None,
        source: GeneratedSource | None = None) -> Result:
    """Run `plan` with `loaded`, what load() returned (a shared library or a NumPy module), or
    else with `source`, loaded once the plan's step count has been checked."""
    _check(plan, language)
    return {"c": run_c, "numpy": run_numpy}[language](None, source, plan, progress, loaded)


def prepared(plan: RunPlan, language: str, loaded, units: tuple[str, ...] | None,
             origin: str) -> Callable[[Progress | None], Result]:
    """`plan` checked and made ready to run with `loaded`: a function of `progress` that runs it,
    as often as called (C: its arrays made once, c_backend.CRun), its result's columns in `units`
    and its `origin` the model and scene (model_runs.description)."""
    _check(plan, language)
    if language == "c":
        return CRun(loaded, plan, units, origin)
    return lambda progress=None: replace(run_numpy(None, None, plan, progress, loaded), units=units, origin=origin)


def _check(plan: RunPlan, language: str) -> None:
    """Refuse a fixed-step run over the step limit, and a result that would not fit in memory."""
    check_step_count(plan)
    rows = grid_rows(plan.time.start, plan.time.stop, plan.time.interval)
    size = run_bytes(rows, len(plan.columns), len(plan.coordinates), language)
    if size > SMALL_RESULT:         # asking the system what memory is left costs more than a small run
        check_fits(size, f"the result ({rows} rows of {len(plan.columns) + 1} columns)",
                   "choose a larger --interval or fewer outputs, or run the standalone program (lagc MODEL --emit "
                   "c), which writes its rows as it goes")
