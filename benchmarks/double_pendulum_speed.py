"""Simulation speed on the chaotic double pendulum: lagdsl's C backend against the usual Python ways.

    python benchmarks/double_pendulum_speed.py [--repeat 5] [--calls 10000000] [--skip-c-harness]

Model models/double_pendulum.lag, scene `chaos` run over t = 0 .. 50 with an output every 0.5
(101 rows), dop853 at rtol 1e-10, atol 1e-12, from theta1 = 1, theta2 = 2 at rest (the problem
of issue 15). Measured on one core (CPU seconds, best of --repeat, except where lagdsl reports
the time), with the right-hand sides each spends:

  (a) lagdsl C backend: `model.simulate("chaos", stop=50, interval=0.5)`, its
      `summary.wall_time` (the integration and the output rows only, wall-clock, as lagdsl
      measures it around the call into the compiled library; compiling is cached and not
      counted), best of --repeat;
  (a1) the whole repeated `simulate()` call on the loaded model (CPU seconds of the process:
      planning, filling the inputs, the call, building the Result);
  (a2) the whole `lagc run` process with a warm build cache (CPU seconds of the child process,
      from os.wait4; the CSV goes to a temporary file);
  (a') lagdsl NumPy backend, the same problem (scipy's DOP853 stepping the generated NumPy code),
      its `summary.wall_time` too;
  (b) scipy.integrate.solve_ivp(method="DOP853") on a right-hand side from sympy.lambdify:
      LagrangesMethod gives M and F, each call evaluates them and solves M q'' = F with
      numpy.linalg.solve, the way a SymPy user would write it;
  (c) solve_ivp DOP853 on a hand-written right-hand side (the textbook closed-form
      accelerations, math.sin/math.cos);
  (e) CyRK's nbsolve_ivp (DOP853) with a numba right-hand side, if CyRK is installed;
  (d) the cost of ONE generated right-hand-side call (lag_rhs of the emitted C file) against a
      hand-written C function by Cramer's rule (benchmarks/c/double_pendulum_hand.c), both timed
      by benchmarks/c/rhs_timing_main.c in one binary, at -O2, at -O3 -march=native and with
      the flags of lagdsl's build cache.

Every integration uses the same tolerances and output grid; the final angles of each are
compared with a reference (solve_ivp DOP853 at rtol 1e-13, atol 1e-15 on the hand-written
right-hand side), so that speeds are compared at the same accuracy.

Goals: lagdsl C at least 100x faster than scipy + lambdify and at least 2x faster than CyRK;
a repeated simulate() within 1.25x of its integration; a generated rhs call within 1.5x of the
hand-written C.
"""
from __future__ import annotations

import benchtools  # noqa: F401  (first: one BLAS thread before NumPy is imported)

import argparse
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from benchtools import (BENCHMARKS, MODELS, best_of, cpu_seconds, machine_description, markdown_table,
                        pin_to_one_core, ratio, seconds)

MODEL = MODELS / "double_pendulum.lag"
SCENE = "chaos"
STOP, INTERVAL = 50.0, 0.5      # the problem of issue 15 (the scene itself runs 0..20 every 0.01)
REFERENCE_TOLERANCES = (1e-13, 1e-15)
# -O2, the naive aggressive set, and the flags of lagdsl's build cache (lagdsl.run.toolchain)
C_FLAG_SETS = (("-O2",), ("-O3", "-march=native"),
               ("-O3", "-march=native", "-fno-tree-slp-vectorize", "-fno-math-errno"))


# ---- the problem, as lagdsl plans it ---------------------------------------------------------
class Problem:
    """The scene's grid, tolerances, parameters and initial state, read from lagdsl's plan."""

    def __init__(self, model):
        from lagdsl.run.output import output_times
        from lagdsl.scene import Overrides
        plan = model.plan(SCENE, Overrides(stop=STOP, interval=INTERVAL))
        options = dict(plan.integrator.options)
        self.times = output_times(plan)
        self.rtol, self.atol = options["rtol"], options["atol"]
        self.parameters = dict(zip((p.name for p in plan.model.parameters), plan.parameters))
        self.y0 = np.array(plan.initial_state, dtype=float)

    @property
    def par(self) -> tuple[float, ...]:
        p = self.parameters
        return p["m1"], p["m2"], p["l1"], p["l2"], p["g"]


# ---- right-hand sides ------------------------------------------------------------------------
def lambdified_rhs(par):
    """A SymPy user's right-hand side: LagrangesMethod, lambdify(M, F), numpy.linalg.solve per call."""
    import sympy
    from sympy.physics import mechanics as me

    q1, q2 = me.dynamicsymbols("theta1 theta2")
    m1, m2, l1, l2, g = sympy.symbols("m1 m2 l1 l2 g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P1 = O.locatenew("P1", l1 * sympy.sin(q1) * N.x + l1 * sympy.cos(q1) * N.y)   # y points down
    P2 = P1.locatenew("P2", l2 * sympy.sin(q2) * N.x + l2 * sympy.cos(q2) * N.y)
    bobs = []
    for name, point, mass in (("B1", P1, m1), ("B2", P2, m2)):
        point.set_vel(N, point.pos_from(O).dt(N))
        bob = me.Particle(name, point, mass)
        bob.potential_energy = -mass * g * point.pos_from(O).dot(N.y)
        bobs.append(bob)
    method = me.LagrangesMethod(me.Lagrangian(N, *bobs), [q1, q2])
    method.form_lagranges_equations()
    state = sympy.symbols("th1 th2 w1 w2")
    plain = {q1.diff(): state[2], q2.diff(): state[3], q1: state[0], q2: state[1]}
    arguments = (*state, m1, m2, l1, l2, g)
    mass_matrix = sympy.lambdify(arguments, method.mass_matrix.xreplace(plain), modules="numpy")
    forcing = sympy.lambdify(arguments, method.forcing.xreplace(plain), modules="numpy")

    def rhs(t, y):
        acc = np.linalg.solve(mass_matrix(*y, *par), forcing(*y, *par)).ravel()
        return np.concatenate((y[2:], acc))
    return rhs


# ---- integrations ----------------------------------------------------------------------------
def solve_with_scipy(rhs, problem: Problem, rtol=None, atol=None, args=()):
    """solve_ivp DOP853 on the problem's grid; -> (states on the grid (4 x len(times)), nfev)."""
    from scipy.integrate import solve_ivp
    times = problem.times
    solution = solve_ivp(rhs, (times[0], times[-1]), problem.y0, method="DOP853", t_eval=times,
                         rtol=rtol or problem.rtol, atol=atol or problem.atol, args=args)
    if solution.status != 0:
        raise RuntimeError(f"solve_ivp failed: {solution.message}")
    return solution.y, solution.nfev


def final_angles_from_states(states) -> np.ndarray:
    return np.asarray(states)[:2, -1]


def measure_scipy(rhs, problem: Problem, repeat: int, args=()):
    """(best seconds, final angles, right-hand sides) of solve_ivp DOP853 with `rhs`."""
    elapsed, (states, nfev) = best_of(repeat, solve_with_scipy, rhs, problem, None, None, args)
    return elapsed, final_angles_from_states(states), nfev


def simulate(model, backend: str):
    return model.simulate(SCENE, backend=backend, stop=STOP, interval=INTERVAL)


def measure_lagdsl(model, backend: str, repeat: int):
    """((best summary.wall_time, final angles, rhs), (best CPU seconds of the whole call, ...))
    of the problem's `simulate()`; the first run builds (cached) outside the timing. SymPy's
    cache is kept between the calls, as in a user's loop of simulate() calls."""
    simulate(model, backend)
    integration = call = None
    for _ in range(repeat):
        started = cpu_seconds()
        result = simulate(model, backend)
        elapsed = cpu_seconds() - started
        angles = np.array([result["theta1"][-1], result["theta2"][-1]])
        rhs = result.summary.count("rhs_evals")
        if integration is None or result.summary.wall_time < integration[0]:
            integration = (result.summary.wall_time, angles, rhs)
        if call is None or elapsed < call[0]:
            call = (elapsed, angles, rhs)
    return integration, call


def lagc_run_once(output: Path) -> tuple[float, str]:
    """(CPU seconds of the child, its standard error) of one `lagc run` process on the problem."""
    command = [sys.executable, "-m", "lagdsl", "run", str(MODEL), "--scene", SCENE, "--stop", str(STOP),
               "--interval", str(INTERVAL), "-o", str(output)]
    with tempfile.TemporaryFile() as stderr:
        child = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr)
        _, status, usage = os.wait4(child.pid, 0)
        child.returncode = os.waitstatus_to_exitcode(status)
        stderr.seek(0)
        text = stderr.read().decode()
    if child.returncode != 0:
        raise RuntimeError(f"lagc run failed: {text}")
    return usage.ru_utime + usage.ru_stime, text


def measure_lagc_run(repeat: int):
    """(best CPU seconds, final angles, rhs) of a whole warm `lagc run` process."""
    with tempfile.TemporaryDirectory() as work:
        output = Path(work) / "out.csv"
        lagc_run_once(output)                                   # warms the build cache
        best, text = min(lagc_run_once(output) for _ in range(repeat))
        last = output.read_text().splitlines()[-1].split(",")
    columns = [float(value) for value in last[1:3]]             # t, theta1, theta2, energy
    rhs = int(re.search(r"(\d+) right-hand sides", text).group(1))
    return best, np.array(columns), rhs


def measure_cyrk(problem: Problem, repeat: int):
    """(best seconds, final angles, rhs) of CyRK's nbsolve_ivp DOP853 with a numba rhs, or a reason."""
    cyrk = benchtools.cyrk_double_pendulum()
    if cyrk is None:
        return "not installed", None, None
    numba, nbsolve_ivp, rhs = cyrk

    @numba.njit(cache=False)
    def counting_rhs(t, y, m1, m2, l1, l2, g, calls):
        calls[0] += 1
        return rhs(t, y, m1, m2, l1, l2, g)

    times = problem.times

    def solve(function=rhs, extra=()):
        result = nbsolve_ivp(function, (times[0], times[-1]), problem.y0, args=(*problem.par, *extra),
                             rtol=problem.rtol, atol=problem.atol, rk_method=2, t_eval=times,
                             warnings=False)
        if not result.success:
            raise RuntimeError(f"nbsolve_ivp failed: {result.message}")
        return result.y

    solve()                                                     # numba compiles here, not timed
    calls = np.zeros(1, dtype=np.int64)
    solve(counting_rhs, (calls,))                               # a separate run counts the calls
    elapsed, states = best_of(repeat, solve)
    return elapsed, final_angles_from_states(states), int(calls[0])


# ---- one right-hand-side call in C -----------------------------------------------------------
def harness_source(model) -> str:
    """The generated C file + the hand-written rhs + the timing main."""
    parts = [model.emit("c", SCENE).text,
             (BENCHMARKS / "c" / "double_pendulum_hand.c").read_text(encoding="utf-8"),
             (BENCHMARKS / "c" / "rhs_timing_main.c").read_text(encoding="utf-8")]
    return "\n".join(parts)


class CompileError(Exception):
    pass


def time_rhs_calls(source: str, flags, calls: int) -> dict:
    """Compile the harness with `flags`, run it, and parse its key=value line."""
    with tempfile.TemporaryDirectory() as work:
        path, binary = Path(work) / "rhs_timing.c", Path(work) / "rhs_timing"
        path.write_text(source, encoding="utf-8")
        command = ["cc", "-std=c99", *flags, "-D_POSIX_C_SOURCE=199309L", "-Dmain=lag_generated_main",
                   f"-DRHS_CALLS={calls}L", str(path), "-o", str(binary), "-lm"]
        build = subprocess.run(command, capture_output=True, text=True)
        if build.returncode != 0:
            raise CompileError(build.stderr)
        output = subprocess.run([str(binary)], check=True, capture_output=True, text=True).stdout
    return {key: float(value) for key, value in re.findall(r"(\w+)=(\S+)", output)}


def measure_rhs_calls(model, calls: int):
    """[(flags, timings)] for each flag set."""
    source = harness_source(model)
    return [(flags, time_rhs_calls(source, flags, calls)) for flags in C_FLAG_SETS]


# ---- the report ------------------------------------------------------------------------------
def difference(angles, reference) -> str:
    if angles is None:
        return "n/a"
    return f"{np.max(np.abs(angles - reference)):.2e}"


def integration_table(rows, reference, times) -> str:
    """rows: (name, seconds or reason, final angles or None, rhs or None); ratios are to lagdsl C."""
    lagdsl_c = rows[0][1]
    body = []
    for name, elapsed, angles, rhs in rows:
        body.append([name, seconds(elapsed), f"{rhs:,}" if rhs is not None else "n/a",
                     ratio(elapsed, lagdsl_c) if isinstance(elapsed, float) else "n/a",
                     difference(angles, reference)])
    return markdown_table([f"t = 0..{STOP:g}, output every {INTERVAL:g} ({len(times)} rows)",
                           "time (best)", "right-hand sides", "time / lagdsl C integration",
                           "final angles: max abs. error (rad)"], body)


def goal(text: str, value: float, met: bool) -> str:
    return f"goal: {text}: {value:.2f}x, {'met' if met else 'NOT met'}"


def goals(rows) -> list[str]:
    """The issue's goals, from the rows of integration_table (in main's order)."""
    named = {name.split(")")[0] + ")": elapsed for name, elapsed, _, _ in rows}
    c, call, lambdify, cyrk = named["(a)"], named["(a1)"], named["(b)"], named["(e)"]
    lines = [goal("lagdsl C >= 100x faster than scipy + lambdify", lambdify / c, lambdify / c >= 100)]
    if isinstance(cyrk, float):
        lines.append(goal("lagdsl C integration >= 2x faster than CyRK", cyrk / c, cyrk / c >= 2))
    else:
        lines.append(f"goal: lagdsl C integration >= 2x faster than CyRK: not measured ({cyrk})")
    lines.append(goal("repeated simulate() <= 1.25x its integration", call / c, call / c <= 1.25))
    return lines


def rhs_table(timings) -> str:
    body = []
    for flags, t in timings:
        body.append([" ".join(flags), f"{t['generated_ns']:.1f} ns", f"{t['hand_ns']:.1f} ns",
                     f"{t['generated_ns'] / t['hand_ns']:.2f}x", f"{t['max_rhs_difference']:.1e}"])
    return markdown_table(["cc flags", "generated lag_rhs", "hand-written (Cramer)",
                           "generated / hand", "max abs. difference of dy/dt"], body)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5, help="runs of each integration; the best counts")
    parser.add_argument("--calls", type=int, default=10_000_000, help="rhs calls per timing loop in C")
    parser.add_argument("--skip-c-harness", action="store_true", help="do not time single rhs calls in C")
    args = parser.parse_args(argv)

    core = pin_to_one_core()
    import lagdsl
    print(f"# Double pendulum, scene {SCENE}: {machine_description()}; pinned to CPU {core}\n")
    model = lagdsl.load(MODEL)
    problem = Problem(model)

    started = cpu_seconds()
    states, _ = solve_with_scipy(benchtools.hand_rhs, problem, *REFERENCE_TOLERANCES, args=problem.par)
    reference = final_angles_from_states(states)
    print(f"reference (solve_ivp DOP853, rtol {REFERENCE_TOLERANCES[0]:g}, atol {REFERENCE_TOLERANCES[1]:g}): "
          f"theta1({STOP:g}) = {reference[0]:.12f}, theta2({STOP:g}) = {reference[1]:.12f} "
          f"({cpu_seconds() - started:.2f} s)\n")

    c_integration, c_call = measure_lagdsl(model, "c", 10 * args.repeat)     # a few ms each
    rows = [("(a) lagdsl C backend: integration (summary.wall_time)", *c_integration),
            ("(a1) lagdsl C backend: the whole repeated simulate() call", *c_call),
            ("(a2) lagdsl C backend: the whole `lagc run` process, warm cache", *measure_lagc_run(args.repeat)),
            ("(a') lagdsl NumPy backend (scipy DOP853)", *measure_lagdsl(model, "numpy", args.repeat)[0]),
            ("(b) solve_ivp DOP853 + lambdify(M, F) + numpy.linalg.solve",
             *measure_scipy(lambdified_rhs(problem.par), problem, max(1, args.repeat // 2))),
            ("(c) solve_ivp DOP853 + hand-written rhs (math)",
             *measure_scipy(benchtools.hand_rhs, problem, args.repeat, args=problem.par)),
            ("(e) CyRK nbsolve_ivp DOP853 + numba rhs", *measure_cyrk(problem, args.repeat))]
    print(integration_table(rows, reference, problem.times))
    print()
    print("\n".join(goals(rows)))

    if args.skip_c_harness:
        return 0
    timings = measure_rhs_calls(model, args.calls)
    print(f"\n(d) one right-hand-side call, {args.calls:.0e} calls per loop, best of 5 alternating rounds\n")
    print(rhs_table(timings))
    worst = max(t["generated_ns"] / t["hand_ns"] for _, t in timings)
    print(f"\ngoal: generated rhs call within 1.5x of hand-written C: worst {worst:.2f}x, "
          f"{'met' if worst <= 1.5 else 'NOT met'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
