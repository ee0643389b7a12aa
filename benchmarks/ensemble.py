"""Many runs per call: 10^4 double pendulums with model.sweep against loops of single runs.

    python benchmarks/ensemble.py [--side 100] [--workers 2] [--scipy-sample 20] [--loop-sample 200]
                                  [--picture benchmarks/ensemble_basin.png] [--no-matched | --matched-only]
                                  [--error-sample 20] [--rounds 7]

Model models/double_pendulum.lag, scene `chaos` with t = 0 .. 10, dop853 at rtol = atol = 1e-8,
output at t = 0 and t = 10 only. The members are a side x side grid of starting angles
theta1, theta2 in [-pi, pi] (at rest), 10^4 for side = 100. Measured in one run:

  (a) lagdsl `model.sweep(...)`: the C batch entry point, members in parallel on --workers
      OpenMP threads (best of 3 by wall-clock; its CPU time, all threads), and on one thread;
  (b) a loop of `model.simulate(set=...)` over --loop-sample members, scaled to all members;
  (c) a loop of scipy's solve_ivp(DOP853) on the hand-written right-hand side (the textbook
      accelerations, math.sin/cos) over --scipy-sample members, scaled;
  (d) a loop of CyRK's nbsolve_ivp (DOP853, numba right-hand side) over --loop-sample members,
      scaled, if CyRK is installed;
  (e) at matched accuracy (ensemble_heyoka.py): the sweep (taylor and dop853 in lanes) against heyoka's batch mode
      (taylor_adaptive_batch, one thread) and ensemble_propagate_until_batch (all threads), each at
      the loosest tolerance whose error at t = 10 is at most 1e-6 on --error-sample random members
      against lagdsl's extended-precision reference; heyoka optional (--no-matched skips it);
      then --rounds alternating rounds of the two one-thread loops (lagdsl, heyoka, lagdsl, ...)
      and the median ratio of their CPU times.

The loops run on one core; the sweep on --workers cores. Times are compared as CPU seconds of
the process (all its threads), which a loaded machine does not inflate; wall-clock times are
printed beside them. Every member of (b) is checked to equal
the sweep's bit for bit. The basin picture (the final theta2 against the two starting angles) is
written with matplotlib when it is installed. The machine's load average is printed with the
results: the benchmark machine is shared, and a loaded machine makes wall-clock times longer.
"""
from __future__ import annotations

import benchtools  # noqa: F401  (first: one BLAS thread before NumPy is imported)

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

import ensemble_heyoka
import lagdsl
from benchtools import MODELS, machine_description, markdown_table

SCENE = "chaos"
GRID = dict(stop=10.0, interval=10.0, integrator="dop853", rtol=1e-8, atol=1e-8)


def members(side: int) -> dict[str, np.ndarray]:
    angles = np.linspace(-math.pi, math.pi, side)
    theta1, theta2 = np.meshgrid(angles, angles, indexing="ij")
    return {"theta1.start": theta1.reshape(-1), "theta2.start": theta2.reshape(-1)}


def wall_and_cpu(function):
    wall, cpu = time.perf_counter(), time.process_time()
    result = function()
    return time.perf_counter() - wall, time.process_time() - cpu, result


def measure_sweep(model, varied, workers: int, repeat: int = 3):
    """(best wall seconds, its CPU seconds, the sweep) of model.sweep on `workers` threads."""
    model.sweep(SCENE, set={k: v[:2] for k, v in varied.items()}, **GRID)      # build outside the timing
    best = None
    for _ in range(repeat):
        wall, cpu, sweep = wall_and_cpu(lambda: model.sweep(SCENE, set=varied, workers=workers, **GRID))
        if best is None or wall < best[0]:
            best = (wall, cpu, sweep)
    return best


def sample(count: int, total: int) -> np.ndarray:
    return np.linspace(0, total - 1, min(count, total)).astype(int)


def measure_simulate_loop(model, varied, chosen, sweep):
    """CPU seconds per member of a simulate() loop; every member checked against the sweep."""
    started = time.process_time()
    for b in chosen:
        result = model.simulate(SCENE, set={k: v[b] for k, v in varied.items()}, **GRID)
        if not np.array_equal(result.values, sweep.values[b]):
            raise AssertionError(f"member {b}: simulate() and sweep differ")
    return (time.process_time() - started) / len(chosen)




def starts_of(varied, b) -> np.ndarray:
    return np.array([varied["theta1.start"][b], varied["theta2.start"][b], 0.0, 0.0])


def measure_scipy_loop(varied, chosen, par):
    from scipy.integrate import solve_ivp
    started = time.process_time()
    for b in chosen:
        solve_ivp(benchtools.hand_rhs, (0.0, GRID["stop"]), starts_of(varied, b), method="DOP853", t_eval=[0.0, GRID["stop"]],
                  rtol=GRID["rtol"], atol=GRID["atol"], args=par)
    return (time.process_time() - started) / len(chosen)


def measure_cyrk_loop(varied, chosen, par):
    cyrk = benchtools.cyrk_double_pendulum()
    if cyrk is None:
        return None
    _, nbsolve_ivp, rhs = cyrk

    def solve(b):
        return nbsolve_ivp(rhs, (0.0, GRID["stop"]), starts_of(varied, b), args=par, rtol=GRID["rtol"],
                           atol=GRID["atol"], rk_method=2, t_eval=np.array([0.0, GRID["stop"]]), warnings=False)

    solve(chosen[0])                                            # numba compiles here, not timed
    started = time.process_time()
    for b in chosen:
        solve(b)
    return (time.process_time() - started) / len(chosen)


def draw_basin(sweep, side: int, path: Path) -> str:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return "matplotlib is not installed: no picture"
    final = np.angle(np.exp(1j * sweep["theta2"][:, -1])).reshape(side, side)   # wrapped to (-pi, pi]
    figure, axes = plt.subplots(figsize=(6, 5), dpi=100)
    image = axes.imshow(final.T, origin="lower", extent=(-math.pi, math.pi, -math.pi, math.pi), cmap="twilight",
                        vmin=-math.pi, vmax=math.pi, interpolation="nearest")
    axes.set_xlabel("theta1 at t = 0 [rad]")
    axes.set_ylabel("theta2 at t = 0 [rad]")
    axes.set_title(f"double pendulum: theta2 at t = {GRID['stop']:g} s ({side}x{side} members)")
    figure.colorbar(image, ax=axes, label="theta2(10 s), wrapped [rad]")
    figure.tight_layout()
    figure.savefig(path)
    return f"basin picture: {path}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--side", type=int, default=100, help="members per starting angle (side^2 in all)")
    parser.add_argument("--workers", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--scipy-sample", type=int, default=20)
    parser.add_argument("--loop-sample", type=int, default=200)
    parser.add_argument("--picture", type=Path, default=Path(__file__).resolve().parent / "ensemble_basin.png")
    parser.add_argument("--error-sample", type=int, default=20, help="random members whose error is measured (e)")
    parser.add_argument("--rounds", type=int, default=7,
                        help="alternating rounds of lagdsl's taylor and heyoka's batch mode after (e), one thread each")
    parser.add_argument("--no-matched", action="store_true", help="leave out (e), the comparison at matched accuracy")
    parser.add_argument("--matched-only", action="store_true", help="only (e), the comparison at matched accuracy")
    args = parser.parse_args()
    model = lagdsl.load(MODELS / "double_pendulum.lag")
    varied = members(args.side)
    if args.matched_only:
        print(machine_description())
        print_matched(model, varied, args)
        return 0
    total = len(varied["theta1.start"])
    plan = model.plan(SCENE)
    par = tuple(plan.parameters)
    load_before = os.getloadavg()
    print(f"sweep of {total} members on {args.workers} threads ...", file=sys.stderr)
    wall, cpu, sweep = measure_sweep(model, varied, args.workers)
    wall_one, cpu_one, _ = measure_sweep(model, varied, 1, repeat=1)
    print("loops ...", file=sys.stderr)
    per_simulate = measure_simulate_loop(model, varied, sample(args.loop_sample, total), sweep)
    per_scipy = measure_scipy_loop(varied, sample(args.scipy_sample, total), par)
    per_cyrk = measure_cyrk_loop(varied, sample(args.loop_sample, total), par)
    load_after = os.getloadavg()
    rows = [
        (f"(a) model.sweep, {args.workers} threads", f"{cpu:.3g} s", f"{wall:.3g} s", "1"),
        ("(a) model.sweep, 1 thread", f"{cpu_one:.3g} s", f"{wall_one:.3g} s", f"{cpu_one / cpu:.2g}"),
        (f"(b) simulate() loop ({min(args.loop_sample, total)} members, scaled)", f"{per_simulate * total:.3g} s",
         "", f"{per_simulate * total / cpu:.3g}"),
        (f"(c) scipy solve_ivp DOP853 loop ({min(args.scipy_sample, total)} members, scaled)",
         f"{per_scipy * total:.3g} s", "", f"{per_scipy * total / cpu:.3g}"),
        ("(d) CyRK nbsolve_ivp loop" + ("" if per_cyrk is None else f" ({min(args.loop_sample, total)} members, scaled)"),
         "not installed" if per_cyrk is None else f"{per_cyrk * total:.3g} s", "",
         "" if per_cyrk is None else f"{per_cyrk * total / cpu:.3g}"),
    ]
    print(machine_description())
    print(f"\n{total} members, t = 0 .. 10, dop853 rtol = atol = 1e-8; load average before {load_before[0]:.1f}, "
          f"after {load_after[0]:.1f} (1 min) on {os.cpu_count()} CPUs\n")
    print(markdown_table(("what", "CPU time", "wall-clock", "CPU / the sweep's"), rows))
    print(f"\nOn {args.workers} idle cores the sweep would take about {cpu / args.workers:.3g} s of wall-clock time "
          "(its CPU time over the threads; the members are independent).")
    print(f"\n{sweep.summary.render()}")
    print(f"every sampled simulate() member equals its sweep member bit for bit; {draw_basin(sweep, args.side, args.picture)}")
    if not args.no_matched:
        print_matched(model, varied, args)
    return 0


def print_matched(model, varied, args) -> None:
    """(e): the sweep and heyoka's batch mode at matched accuracy on all members."""
    total = len(varied["theta1.start"])
    chosen = np.sort(np.random.default_rng(35).choice(total, min(args.error_sample, total), replace=False))
    load_before = os.getloadavg()
    rows, note = ensemble_heyoka.matched_rows(model, varied, chosen, args.workers)
    load_after = os.getloadavg()
    print(f"\n(e) {total} members at matched accuracy: error at t = 10 at most {ensemble_heyoka.TARGET:g} on "
          f"{len(chosen)} random members (against lagdsl's extended-precision reference); lagdsl's lanes hold "
          f"{lane_width(model)}; load average before {load_before[0]:.1f}, after {load_after[0]:.1f}\n")
    print(markdown_table(("what", "tol", "sampled error", "wall-clock", "CPU time", "CPU / the least"),
                         ensemble_heyoka.table_rows(rows)))
    if note:
        print(note)
    print(f"\nalternating rounds ({args.rounds}), CPU seconds of all {total} members:", flush=True)
    times = ensemble_heyoka.alternated(model, varied, rows, args.rounds)
    if times is None:
        print("no alternating rounds: they need lagdsl's taylor and heyoka's batch rows")
        return
    table, ratio = ensemble_heyoka.alternated_table(times)
    print(f"load average after the rounds {os.getloadavg()[0]:.1f}\n\n{table}\n\n{ratio}")


def lane_width(model) -> str:
    """LAG_LANES as the compiler of the sweep's library chose it (the widest vector register; taylor's
    lanes hold c_taylor_lanes.VECTORS of them)."""
    import subprocess
    from lagdsl.codegen.c_taylor_lanes import VECTORS
    from lagdsl.run.toolchain import LIBRARY_FLAGS, find_compiler
    flags = [flag for flag in LIBRARY_FLAGS if flag.startswith("-m")]
    macros = subprocess.run([find_compiler(), *flags, "-dM", "-E", "-x", "c", "/dev/null"], capture_output=True,
                            text=True).stdout
    width = 8 if "__AVX512F__" in macros else 4 if "__AVX__" in macros else 2
    return (f"{width} members in dop853's, {VECTORS * width} in taylor's (LAG_LANES; {width * 64}-bit vectors of "
            f"doubles, {VECTORS} of them per row in taylor's)")


if __name__ == "__main__":
    sys.exit(main())
