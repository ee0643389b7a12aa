"""One sweep's members, run all at once (Model.sweep) or block by block into a file
(Model.sweep_to_file, `lagc sweep`), on C threads, a Dask cluster or the NumPy backend.

A block holds as many members as fit in BLOCK_SHARE of the memory budget (their values, the tidy
table and its text), so a sweep of any size runs in bounded memory: the size of one block plus a
constant. Member b of a block is planned exactly as in a sweep of all members at once, so the file
holds the same numbers as Model.sweep's table.
"""
from __future__ import annotations

import contextlib
import time as clock
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import SimulationInterrupted
from ..settings import Overrides, RunPlan, check_step_count
from . import sweep as batch
from .memory import budget, check_fits, sweep_bytes
from .output import output_times
from .tables import TableFile

if TYPE_CHECKING:
    from ..scene import ScenePlan

BLOCK_SHARE = 0.25              # of the memory budget, what one block may take
BLOCK_CEILING = 256 * 2 ** 20   # bytes: larger blocks gain nothing and delay the first rows on disk
BYTES_PER_CELL = 64             # a value, its copy in the tidy table and its text in the CSV
Advance = Callable[[int], None] | None


class SweepJob:
    """The members of a sweep: `varied` (names simulate(set=...) takes, numbers or 1-D arrays of
    one length) over the `base` overrides. `plan(overrides)` plans one run and `program(plan)`
    gives its generated, loaded code (model_runs.Program, or a StoredProgram); `placement` is
    member_inputs'."""

    def __init__(self, plan: Callable[[Overrides], RunPlan], program: Callable[[RunPlan], Any],
                 base: Overrides, varied: dict, backend: str, placement: batch.Placement | None = None):
        self.plan, self.base, self.backend, self.placement = plan, base, backend, placement
        self.inputs = batch.broadcast(varied)
        self.count = len(next(iter(self.inputs.values()))) if self.inputs else 1
        self.scene_plan = self.members(0, 1).plan
        check_step_count(self.scene_plan)
        self.rows, self.columns = len(output_times(self.scene_plan)), len(self.scene_plan.columns)
        self.program = program(self.scene_plan)

    def members(self, lo: int, hi: int) -> batch.Members:
        return batch.member_inputs(self.plan, self.base, {name: values[lo:hi] for name, values in self.inputs.items()},
                                   self.placement)

    def check_fits(self) -> None:
        """Refuse a sweep whose table would not fit in memory, before running it."""
        check_fits(sweep_bytes(self.count, self.rows, self.columns),
                   f"the sweep's table ({self.count} members x {self.rows} rows x {self.columns} columns)",
                   "write it to a file as it goes with Model.sweep_to_file(path, ...) or `lagc sweep -o FILE`, "
                   "or choose a larger interval or fewer outputs")

    def run(self, lo: int, hi: int, workers: int | None, client, advance: Advance) -> batch.Sweep:
        """Members lo..hi-1 as a Sweep; raises SimulationInterrupted (the Sweep as `.partial`) after Ctrl-C."""
        members = self.members(lo, hi)
        step = None if advance is None else (lambda finished: advance(lo + finished))
        started = clock.perf_counter()
        values, summaries, counters, how = run_members(self.program, members, self.backend, workers, client, step)
        return batch.assemble(members.plan, members, values, summaries, self.backend, counters,
                              clock.perf_counter() - started, how, first_member=lo)

    def blocks(self) -> list[tuple[int, int]]:
        cells = self.rows * (self.columns + len(self.inputs) + 3)      # + member, t, status
        size = max(1, int(min(BLOCK_SHARE * budget(), BLOCK_CEILING) // (cells * BYTES_PER_CELL)))
        return [(lo, min(lo + size, self.count)) for lo in range(0, self.count, size)]

    def stream(self, table: TableFile, workers: int | None, client, advance: Advance) -> batch.SweepSummary:
        """Every member, block by block, into `table`; the summary of all. After Ctrl-C the
        members run so far are written and SimulationInterrupted carries that summary."""
        summary = None
        for lo, hi in self.blocks():
            try:
                sweep = self.run(lo, hi, workers, client, advance)
            except SimulationInterrupted as stopped:
                table.write(stopped.partial.tidy())
                table.commit()
                raise SimulationInterrupted("interrupted", stopped.time, {}, "",
                                            batch.merge(summary, stopped.partial.summary)) from None
            table.write(sweep.tidy())
            summary = batch.merge(summary, sweep.summary)
        return summary


@dataclass(frozen=True)
class StoredProgram:
    """The program of a stored plan (run/plans.py): its loaded library, all that C threads need."""

    loaded: object


def stored_job(stored, base: Overrides, varied: dict) -> SweepJob | None:
    """The job of a C sweep run from a stored plan (plans.StoredPlan) without sympy, as a warm
    `lagc run` runs; None where the stored plan cannot serve it: a varied value that other values
    are computed from, overrides that need the model, a program no longer in the cache."""
    if set(varied) & stored.computed_from or stored.resolve(base) is None:
        return None
    loaded = stored.program.load()
    if loaded is None:
        return None
    names = list(stored.settings.parameters), list(stored.settings.coordinates), dict(stored.settings.units)
    return SweepJob(stored.resolve, lambda plan: StoredProgram(loaded), base, varied, "c",
                    placement=lambda first, inputs: names)


def stream_to_file(job: SweepJob, path: str | Path, workers: int | None, client,
                   progress: bool) -> batch.SweepSummary:
    """The members of `job` into the table at `path` (see Model.sweep_to_file)."""
    with TableFile(path) as table, progress_bar(progress, job.count) as advance:
        return job.stream(table, workers, client, advance)


@contextlib.contextmanager
def progress_bar(show: bool, members: int):
    """A progress bar over the members when `show`; yields a callable(members finished)."""
    if not show:
        yield None
        return
    from ..progress import bar
    with bar(members, "member") as shown:
        yield lambda finished: shown.update(max(0, finished - shown.n))


def run_members(program, members: batch.Members, backend: str, workers: int | None, client, advance: Advance):
    """(values, summaries, counters, how they ran) of the members: NumPy, a Dask cluster, or C threads."""
    if backend == "numpy":
        return (*batch.run_numpy_batch(program.loaded, program.kernel, program.source, members, advance),
                "one process")
    layout = batch.batch_layout(members.plan)
    if client is not None:
        from .dask_sweep import run_dask
        values, summaries, chunks = run_dask(client, program.library_bytes(), program.source.text,
                                             program.source.suggested_name, layout, members.parameters,
                                             members.initial, advance)
        return values, summaries, layout.counters, f"Dask, {chunks} chunks"
    threads = batch.default_threads(workers)
    values, summaries = batch.run_c_batch(program.loaded, layout, members.parameters, members.initial, threads,
                                          advance)
    return values, summaries, layout.counters, f"{threads} thread{'s' if threads > 1 else ''}"
