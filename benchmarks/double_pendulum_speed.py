"""Simulation speed on the chaotic double pendulum: lagdsl's C backend against the usual Python ways.

    python benchmarks/double_pendulum_speed.py [--repeat 5] [--calls 10000000] [--skip-c-harness]

Model models/double_pendulum.lag, scene `chaos`: t = 0 .. 20, output every 0.01 (2001 rows),
dop853 at rtol 1e-10, atol 1e-12, from theta1 = 1, theta2 = 2 at rest. Measured in one process
on one core (CPU seconds of the process, best of --repeat, except where lagdsl reports the time):

  (a) lagdsl C backend: `lagdsl.load(path).simulate("chaos")`, its `summary.wall_time` (the
      integration and the output rows only, wall-clock, as lagdsl measures it around the call
      into the compiled library; compiling is cached and not counted), best of --repeat;
  (a') lagdsl NumPy backend, the same scene (scipy's DOP853 stepping the generated NumPy code),
      its `summary.wall_time` too;
  (b) scipy.integrate.solve_ivp(method="DOP853") on a right-hand side from sympy.lambdify:
      LagrangesMethod gives M and F, each call evaluates them and solves M q'' = F with
      numpy.linalg.solve, the way a SymPy user would write it;
  (c) solve_ivp DOP853 on a hand-written right-hand side (the textbook closed-form
      accelerations, math.sin/math.cos);
  (e) CyRK's nbsolve_ivp (DOP853) with a numba right-hand side, if CyRK is installed;
  (d) the cost of ONE generated right-hand-side call (lag_rhs of the emitted C file) against a
      hand-written C function by Cramer's rule (benchmarks/c/double_pendulum_hand.c), both timed
      by benchmarks/c/rhs_timing_main.c in one binary, at -O2 and at -O3 -march=native.

Every integration uses the same tolerances and output grid; the final angles of each are
compared with a reference (solve_ivp DOP853 at rtol 1e-13, atol 1e-15 on the hand-written
right-hand side), so that speeds are compared at the same accuracy.

Goals: lagdsl C at least 100x faster than scipy + lambdify; a generated rhs call within 1.5x of
the hand-written C.
"""
from __future__ import annotations

import benchtools  # noqa: F401  (first: one BLAS thread before NumPy is imported)

import argparse
import math
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
REFERENCE_TOLERANCES = (1e-13, 1e-15)
C_FLAG_SETS = (("-O2",), ("-O3", "-march=native"))


# ---- the problem, as lagdsl plans it ---------------------------------------------------------
class Problem:
    """The scene's grid, tolerances, parameters and initial state, read from lagdsl's plan."""

    def __init__(self, model):
        from lagdsl.run.runner import output_times
        plan = model.plan(SCENE)
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
def hand_rhs(t, y, m1, m2, l1, l2, g):
    """The textbook equations of the plane double pendulum solved for the accelerations by hand."""
    th1, th2, w1, w2 = y
    d = th1 - th2
    c, s = math.cos(d), math.sin(d)
    a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
    b1 = -m2 * l1 * l2 * s * w2 * w2 - (m1 + m2) * g * l1 * math.sin(th1)
    b2 = m2 * l1 * l2 * s * w1 * w1 - m2 * g * l2 * math.sin(th2)
    det = a11 * a22 - a12 * a12
    return np.array([w1, w2, (b1 * a22 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det])


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
    """solve_ivp DOP853 on the scene's grid; -> the states on the grid (4 x len(times))."""
    from scipy.integrate import solve_ivp
    times = problem.times
    solution = solve_ivp(rhs, (times[0], times[-1]), problem.y0, method="DOP853", t_eval=times,
                         rtol=rtol or problem.rtol, atol=atol or problem.atol, args=args)
    if solution.status != 0:
        raise RuntimeError(f"solve_ivp failed: {solution.message}")
    return solution.y


def final_angles_from_states(states) -> np.ndarray:
    return np.asarray(states)[:2, -1]


def measure_scipy(rhs, problem: Problem, repeat: int, args=()):
    """(best seconds, final angles) of solve_ivp DOP853 with `rhs`."""
    elapsed, states = best_of(repeat, solve_with_scipy, rhs, problem, None, None, args)
    return elapsed, final_angles_from_states(states)


def measure_lagdsl(model, backend: str, repeat: int):
    """(best summary.wall_time, final angles) of `simulate("chaos")`; the first run compiles."""
    model.simulate(SCENE, backend=backend)                       # build (cached) outside the timing
    best, angles = None, None
    for _ in range(repeat):
        result = model.simulate(SCENE, backend=backend)
        if best is None or result.summary.wall_time < best:
            best = result.summary.wall_time
            angles = np.array([result["theta1"][-1], result["theta2"][-1]])
    return best, angles


def measure_cyrk(problem: Problem, repeat: int):
    """(best seconds, final angles) of CyRK's nbsolve_ivp DOP853 with a numba rhs, or a reason."""
    try:
        import numba
        from CyRK import nbsolve_ivp
    except ImportError:
        return "not installed", None

    @numba.njit(cache=False)
    def rhs(t, y, m1, m2, l1, l2, g):
        d = y[0] - y[1]
        c, s = np.cos(d), np.sin(d)
        a11, a12, a22 = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c, m2 * l2 * l2
        b1 = -m2 * l1 * l2 * s * y[3] * y[3] - (m1 + m2) * g * l1 * np.sin(y[0])
        b2 = m2 * l1 * l2 * s * y[2] * y[2] - m2 * g * l2 * np.sin(y[1])
        det = a11 * a22 - a12 * a12
        dy = np.empty(4)
        dy[0], dy[1] = y[2], y[3]
        dy[2] = (b1 * a22 - a12 * b2) / det
        dy[3] = (a11 * b2 - a12 * b1) / det
        return dy

    times = problem.times

    def solve():
        result = nbsolve_ivp(rhs, (times[0], times[-1]), problem.y0, args=problem.par,
                             rtol=problem.rtol, atol=problem.atol, rk_method=2, t_eval=times,
                             warnings=False)
        if not result.success:
            raise RuntimeError(f"nbsolve_ivp failed: {result.message}")
        return result.y

    solve()                                                     # numba compiles here, not timed
    elapsed, states = best_of(repeat, solve)
    return elapsed, final_angles_from_states(states)


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


def integration_table(rows, reference) -> str:
    """rows: (name, seconds or reason, final angles or None); ratios are to lagdsl C."""
    lagdsl_c = rows[0][1]
    body = []
    for name, elapsed, angles in rows:
        body.append([name, seconds(elapsed),
                     ratio(elapsed, lagdsl_c) if isinstance(elapsed, float) else "n/a",
                     difference(angles, reference)])
    return markdown_table(["integration, t = 0..20 (2001 output rows)", "time (best)",
                           "time / lagdsl C", "final angles: max abs. error (rad)"], body)


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
    reference = final_angles_from_states(
        solve_with_scipy(hand_rhs, problem, *REFERENCE_TOLERANCES, args=problem.par))
    print(f"reference (solve_ivp DOP853, rtol {REFERENCE_TOLERANCES[0]:g}, atol {REFERENCE_TOLERANCES[1]:g}): "
          f"theta1(20) = {reference[0]:.12f}, theta2(20) = {reference[1]:.12f} "
          f"({cpu_seconds() - started:.2f} s)\n")

    rows = []
    rows.append(("(a) lagdsl C backend", *measure_lagdsl(model, "c", args.repeat)))
    rows.append(("(a') lagdsl NumPy backend (scipy DOP853)", *measure_lagdsl(model, "numpy", args.repeat)))
    rows.append(("(b) solve_ivp DOP853 + lambdify(M, F) + numpy.linalg.solve",
                 *measure_scipy(lambdified_rhs(problem.par), problem, max(1, args.repeat // 2))))
    rows.append(("(c) solve_ivp DOP853 + hand-written rhs (math)",
                 *measure_scipy(hand_rhs, problem, args.repeat, args=problem.par)))
    rows.append(("(e) CyRK nbsolve_ivp DOP853 + numba rhs", *measure_cyrk(problem, args.repeat)))
    print(integration_table(rows, reference))

    lagdsl_c, lambdify_time = rows[0][1], rows[2][1]
    if isinstance(lagdsl_c, float):
        verdict = "met" if lambdify_time / lagdsl_c >= 100 else "NOT met"
        print(f"\ngoal: lagdsl C >= 100x faster than scipy + lambdify: {lambdify_time / lagdsl_c:.0f}x, {verdict}")
    else:
        print(f"\ngoal: lagdsl C >= 100x faster than scipy + lambdify: not measured ({lagdsl_c})")

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
