"""The ensemble at matched accuracy: lagdsl's sweep (SIMD lanes) against heyoka's batch mode.

Part of ensemble.py (run there). The members are ensemble.py's grid of double pendulums, t = 0
.. 10, state at t = 10. The accuracy of a method at a tolerance tol (rtol = atol = tol for
lagdsl's taylor and dop853, heyoka's tol) is its sampled error: the largest |theta1(10) - ref|,
|theta2(10) - ref| over --error-sample members spread over the grid, ref being lagdsl's
extended-precision reference of the member (lagdsl.reference: __float128, cached). Each method
runs at the loosest tolerance of its ladder whose sampled error is at most TARGET, and is timed on
all members:

  lagdsl   model.sweep(..., workers=1) and workers=all: the C batch entry point, dop853 in lanes of
           LAG_LANES members (integrators/c/dop853_lanes.c)
  heyoka   taylor_adaptive_batch of hy.recommended_simd_size() members, one chunk after another
           on one thread (its batch mode), and ensemble_propagate_until_batch on all threads
           (heyoka.set_nthreads); the integrator's construction (JIT compilation) is not timed.

Then the two one-thread loops are timed again in alternating rounds (lagdsl, heyoka, lagdsl,
heyoka, ...; ensemble.py --rounds), and the median ratio of their CPU times is printed.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from lagdsl.reference import reference_solution
from lagdsl.settings import Overrides

TARGET = 1e-6
STOP = 10.0
# Every method's ladder, loosest first: 3e-9, 1e-9, 3e-10, ..., 1e-15.
TOLERANCES = tuple(float(f"{mantissa}e-{exponent}") for exponent in range(9, 16) for mantissa in (3, 1))
LAGDSL_METHODS = ("taylor", "dop853")


@dataclass(frozen=True)
class Matched:
    method: str
    tol: float
    error: float            # the sampled error at tol
    cpu: float              # CPU seconds on all members (all threads)
    wall: float


def references(model, varied: dict, chosen) -> np.ndarray:
    """(len(chosen), 2): theta1 and theta2 at t = 10 of each chosen member, extended precision."""
    finals = []
    for b in chosen:
        values = tuple((name, float(v[b])) for name, v in varied.items())
        plan = model.plan("chaos", Overrides(values=values, stop=STOP, interval=STOP))
        reference = reference_solution(model.equations, plan, model.source.name)
        finals.append([reference.values[-1, reference.columns.index(c)] for c in ("theta1", "theta2")])
    return np.array(finals)


def wall_and_cpu(function):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function()
    return time.perf_counter() - wall, time.process_time() - cpu, result


def loosest(tolerances, error_of) -> tuple[float, float] | None:
    """(tol, sampled error) of the loosest tolerance whose error is at most TARGET, or None."""
    for tol in tolerances:
        error = error_of(tol)
        print(f"    tol {tol:g}: sampled error {error:.2g}", flush=True)
        if error <= TARGET:
            return tol, error
    return None


# ---- lagdsl ------------------------------------------------------------------------------------
def lagdsl_finals(model, varied: dict, method: str, tol: float, workers: int, chosen=None):
    chosen = np.arange(len(next(iter(varied.values())))) if chosen is None else chosen
    sweep = model.sweep("chaos", set={k: v[chosen] for k, v in varied.items()}, stop=STOP, interval=STOP,
                        integrator=method, rtol=tol, atol=tol, workers=workers)
    return np.column_stack([sweep["theta1"][:, -1], sweep["theta2"][:, -1]])


def lagdsl_matched(model, varied: dict, chosen, reference: np.ndarray, workers: int) -> list[Matched]:
    rows = []
    for method in LAGDSL_METHODS:
        print(f"  lagdsl {method} (lanes):", flush=True)
        found = loosest(TOLERANCES, lambda tol: float(np.max(np.abs(
            lagdsl_finals(model, varied, method, tol, workers, chosen) - reference))))
        if found is None:
            continue
        tol, error = found
        for threads in sorted({1, workers}):
            wall, cpu, _ = min((wall_and_cpu(lambda: lagdsl_finals(model, varied, method, tol, threads))
                                for _ in range(2)), key=lambda m: m[0])
            rows.append(Matched(f"lagdsl model.sweep, {method} in lanes, {threads} thread{'s' * (threads > 1)}",
                                tol, error, cpu, wall))
    return rows


# ---- heyoka ------------------------------------------------------------------------------------
def heyoka_batch(tol: float):
    import heyoka as hy
    from heyoka_systems import double_pendulum
    system, state, _ = double_pendulum()
    width = hy.recommended_simd_size()
    return hy.taylor_adaptive_batch(system, np.tile(np.array(state)[:, None], (1, width)), tol=tol), width


def _starts(varied: dict, members) -> np.ndarray:
    """(4, len(members)): theta1, theta2 and the velocities (at rest) of the members."""
    count = len(members)
    return np.vstack([varied["theta1.start"][members], varied["theta2.start"][members], np.zeros(count),
                      np.zeros(count)])


def heyoka_batch_finals(integrator, width: int, varied: dict, members) -> np.ndarray:
    """theta1, theta2 at t = 10 of the members, `width` at a time through one batch integrator."""
    finals = np.empty((len(members), 2))
    for at in range(0, len(members), width):
        chunk = np.asarray(members[at:at + width])
        padded = np.concatenate([chunk, np.full(width - len(chunk), chunk[-1])])
        integrator.set_time(np.zeros(width))
        integrator.state[:] = _starts(varied, padded)
        integrator.propagate_until(STOP)
        finals[at:at + len(chunk)] = integrator.state[:2, :len(chunk)].T
    return finals


def heyoka_ensemble_finals(integrator, width: int, varied: dict, members) -> np.ndarray:
    """The same through ensemble_propagate_until_batch, one batch of `width` members per iteration."""
    import heyoka as hy
    chunks = [np.asarray(members[at:at + width]) for at in range(0, len(members), width)]

    def generate(copy, i):
        chunk = chunks[i]
        copy.set_time(np.zeros(width))
        copy.state[:] = _starts(varied, np.concatenate([chunk, np.full(width - len(chunk), chunk[-1])]))
        return copy

    results = hy.ensemble_propagate_until_batch(integrator, STOP, len(chunks), generate)
    return np.vstack([result[0].state[:2, :len(chunk)].T for result, chunk in zip(results, chunks)])


def heyoka_matched(varied: dict, chosen, reference: np.ndarray, workers: int) -> list[Matched]:
    import heyoka as hy
    print(f"  heyoka batch mode (batch size {hy.recommended_simd_size()}):", flush=True)
    integrators = {}

    def error_of(tol):
        integrators[tol] = heyoka_batch(tol)
        return float(np.max(np.abs(heyoka_batch_finals(*integrators[tol], varied, chosen) - reference)))

    found = loosest(TOLERANCES, error_of)
    if found is None:
        return []
    tol, error = found
    integrator, width = integrators[tol]
    members = np.arange(len(varied["theta1.start"]))
    wall, cpu, _ = min((wall_and_cpu(lambda: heyoka_batch_finals(integrator, width, varied, members))
                        for _ in range(2)), key=lambda m: m[0])
    rows = [Matched(f"heyoka taylor_adaptive_batch (batch {width}), 1 thread", tol, error, cpu, wall)]
    hy.set_nthreads(workers)
    wall, cpu, _ = min((wall_and_cpu(lambda: heyoka_ensemble_finals(integrator, width, varied, members))
                        for _ in range(2)), key=lambda m: m[0])
    rows.append(Matched(f"heyoka ensemble_propagate_until_batch, {workers} threads", tol, error, cpu, wall))
    return rows


def matched_rows(model, varied: dict, chosen, workers: int) -> tuple[list[Matched], str]:
    """The rows of the matched-accuracy table, and a note on what is missing."""
    print(f"references of {len(chosen)} sampled members (extended precision, cached) ...", flush=True)
    reference = references(model, varied, chosen)
    rows = lagdsl_matched(model, varied, chosen, reference, workers)
    try:
        import heyoka  # noqa: F401
    except ImportError:
        return rows, "heyoka is not installed (pip install heyoka): no heyoka rows"
    return rows + heyoka_matched(varied, chosen, reference, workers), ""


def alternated(model, varied: dict, rows: list[Matched], rounds: int) -> dict[str, list[float]] | None:
    """CPU seconds of `rounds` rounds on all members, each round lagdsl's taylor in lanes on one
    thread then heyoka's batch mode, each at its matched tolerance (from `rows`): on a shared
    machine a load that comes and goes falls on both alike, which two timings minutes apart do
    not ensure. None without both rows."""
    lagdsl_tol = next((row.tol for row in rows if row.method == "lagdsl model.sweep, taylor in lanes, 1 thread"), None)
    heyoka_tol = next((row.tol for row in rows if row.method.startswith("heyoka taylor_adaptive_batch")), None)
    if lagdsl_tol is None or heyoka_tol is None or rounds < 1:
        return None
    integrator, width = heyoka_batch(heyoka_tol)
    members = np.arange(len(varied["theta1.start"]))
    runs = {"lagdsl": lambda: lagdsl_finals(model, varied, "taylor", lagdsl_tol, 1),
            "heyoka": lambda: heyoka_batch_finals(integrator, width, varied, members)}
    times: dict[str, list[float]] = {name: [] for name in runs}
    for round_ in range(rounds):
        for name, run in runs.items():
            times[name].append(wall_and_cpu(run)[1])
        print(f"    round {round_ + 1}: lagdsl {times['lagdsl'][-1]:.3f} s, heyoka {times['heyoka'][-1]:.3f} s", flush=True)
    return times


def alternated_table(times: dict[str, list[float]]) -> tuple[str, str]:
    """The rounds as a Markdown table, and the median ratio heyoka / lagdsl of the CPU times."""
    from benchtools import markdown_table
    rounds = len(times["lagdsl"])
    rows = [(name, *(f"{cpu:.3f}" for cpu in cpus), f"{min(cpus):.3f}", f"{np.median(cpus):.3f}")
            for name, cpus in (("lagdsl taylor in lanes, 1 thread", times["lagdsl"]),
                               ("heyoka batch mode, 1 thread", times["heyoka"]))]
    table = markdown_table(("round", *(str(r + 1) for r in range(rounds)), "min", "median"), rows)
    ratios = np.array(times["heyoka"]) / np.array(times["lagdsl"])
    return table, (f"heyoka / lagdsl CPU time: {np.median(times['heyoka']) / np.median(times['lagdsl']):.2f} (medians), "
                   f"{np.median(ratios):.2f} (median of the rounds' ratios)")


def table_rows(rows: list[Matched]) -> list[tuple[str, ...]]:
    """The rows, with each one's CPU time over the least: on a shared machine, CPU time is what
    another process's load does not inflate (ensemble.py)."""
    least = min((row.cpu for row in rows), default=math.nan)
    return [(row.method, f"{row.tol:g}", f"{row.error:.2g}", f"{row.wall:.3g} s", f"{row.cpu:.3g} s",
             f"{row.cpu / least:.2g}") for row in rows]
