"""(a) Stiff problems: lagdsl's radau5 against SciPy's Radau, BDF and LSODA at equal error.

    python benchmarks/stability/stiff_speed.py [--short-span 1.0] [--budget 60]

Two problems, each solved by every method in the same run, on one core:

  the stiff spring: models/elastic_pendulum.lag at k = 1e8 (the spring vibrates at 1e4 rad/s),
  10 s from phi = 1 at rest with the spring at its static extension; lagdsl's radau5 at
  rtol 1e-6, atol 1e-9. The error of a run is max |phi(t) - phi_ref(t)| over the output rows
  (every 0.1 s), phi_ref from lagdsl's radau5 at rtol 1e-12 (checked against rtol 1e-11).
  SciPy integrates the same equations in the same coordinates (s, phi), hand-written with
  math.sin/cos, with the analytic Jacobian for Radau, BDF and LSODA.

  the car axis: models/car_axis.lag, 3 s; lagdsl's radau5 at rtol 1e-6, atol 1e-8 (and dop853
  at the same tolerances). The error is the largest relative error of the four positions at
  t = 3 against the Test Set for IVP Solvers' reference. SciPy integrates the same index-1
  equations (the saddle-point system [[M, -A^T], [A, 0]] solved by numpy.linalg.solve in every
  call), without projection onto the constraints, with finite-difference Jacobians.

CasADi's cvodes (SUNDIALS' BDF code), when CasADi is installed, integrates the same equations
written as CasADi SX expressions (with the automatic Jacobian; the car axis's saddle-point
system solved symbolically).

Equal error: each SciPy method (and cvodes) is run at rtol = 1e-3, 10^-3.5, 1e-4, ... (atol =
rtol * 1e-3); the loosest rtol whose error is at most radau5's is the one compared. So that a
slow method cannot hold up the run, every run on the stiff spring is first made on the first
--short-span seconds (and compared with radau5's error over the same span); when the chosen run would take
longer than --budget seconds over the whole span, its time is the short-span time scaled
linearly to the whole span (the solution is periodic, the work per second of simulated time
about constant) and the table says so. Otherwise it is rerun and timed over the whole span, and
must reach radau5's error over the whole span too (else the ladder goes on).

Times: lagdsl's own `summary.wall_time` (integration and output rows, best of 15; the build is
cached), SciPy's CPU time of solve_ivp. Goal: radau5 at least 100x faster than the fastest SciPy
method at equal error.
"""
from __future__ import annotations

import stabilitytools  # noqa: F401  (first: one BLAS thread)

import math
import sys
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

try:
    import casadi
except ImportError:        # optional: the CasADi row is left out
    casadi = None

import lagdsl
from stabilitytools import command_line, MODELS, cpu_seconds, lagdsl_seconds, markdown_table

SCIPY_METHODS = ("Radau", "BDF", "LSODA")
LADDER = tuple(10.0 ** (-e / 2) for e in range(6, 23))     # 1e-3, 3.2e-4, ... 1e-11

# ---- the stiff spring ---------------------------------------------------------------------
SPRING = dict(m=1.0, l=1.0, k=1e8, g=9.81, phi0=1.0)
SPRING_STOP, SPRING_INTERVAL = 10.0, 0.1


def spring_rhs(t, y, m=SPRING["m"], l=SPRING["l"], k=SPRING["k"], g=SPRING["g"], lib=math):
    """The equations of motion in (s, phi); `lib` gives sin and cos (math, or casadi for CasADi)."""
    s, phi, ds, dphi = (y[i] for i in range(4))
    return [ds, dphi, (l + s) * dphi * dphi - k / m * s + g * lib.cos(phi),
            -(2 * ds * dphi + g * lib.sin(phi)) / (l + s)]


def spring_jacobian(t, y, m=SPRING["m"], l=SPRING["l"], k=SPRING["k"], g=SPRING["g"]):
    s, phi, ds, dphi = y
    r = l + s
    return [[0, 0, 1, 0], [0, 0, 0, 1],
            [dphi * dphi - k / m, -g * math.sin(phi), 0, 2 * r * dphi],
            [(2 * ds * dphi + g * math.sin(phi)) / r ** 2, -g * math.cos(phi) / r, -2 * dphi / r, -2 * ds / r]]


def spring_start():
    p = SPRING
    return [p["m"] * p["g"] * math.cos(p["phi0"]) / p["k"], p["phi0"], 0.0, 0.0]


def spring_lagdsl(stop, **options):
    return lagdsl.load(MODELS / "elastic_pendulum.lag").simulate(
        "stiff", k=SPRING["k"], stop=stop, interval=SPRING_INTERVAL, **options)


# ---- the car axis -------------------------------------------------------------------------
CAR = dict(m=10 * 0.01 ** 2 / 2, l=1.0, l0=0.5, r=0.1, w=10.0, g=1.0)
CAR_STOP = 3.0
CAR_REFERENCE = np.array([0.04934557842755629, 0.4969894602303324, 1.041742524885400, 0.3739110272652214])


def car_saddle_point(t, y, p=CAR, lib=math):
    """The index-1 equations: the matrix [[m I, -A^T], [A, 0]] (as rows) and the right-hand side
    [f; gamma] whose solution is (q'', lambda); `lib` gives sin, cos and sqrt."""
    xl, yl, xr, yr, vxl, vyl, vxr, vyr = (y[i] for i in range(8))
    wt = p["w"] * t
    yb, dyb, ddyb = p["r"] * lib.sin(wt), p["r"] * p["w"] * lib.cos(wt), -p["r"] * p["w"] ** 2 * lib.sin(wt)
    xb = lib.sqrt(p["l"] ** 2 - yb * yb)
    dxb = -yb * dyb / xb
    ddxb = -(dyb * dyb + yb * ddyb + dxb * dxb) / xb
    left, right = lib.sqrt(xl * xl + yl * yl), lib.sqrt((xr - xb) ** 2 + (yr - yb) ** 2)
    force = [(p["l0"] - left) * xl / left, (p["l0"] - left) * yl / left - p["m"] * p["g"],
             (p["l0"] - right) * (xr - xb) / right, (p["l0"] - right) * (yr - yb) / right - p["m"] * p["g"]]
    rows = [[xb, yb, 0, 0], [2 * (xl - xr), 2 * (yl - yr), -2 * (xl - xr), -2 * (yl - yr)]]
    gamma = [-(2 * (dxb * vxl + dyb * vyl) + ddxb * xl + ddyb * yl),
             -2 * ((vxl - vxr) ** 2 + (vyl - vyr) ** 2)]
    matrix = [[p["m"] * (i == j) for j in range(4)] + [-rows[0][i], -rows[1][i]] for i in range(4)]
    matrix += [row + [0, 0] for row in rows]
    return matrix, force + gamma, [vxl, vyl, vxr, vyr]


def car_rhs(t, y):
    matrix, right, velocities = car_saddle_point(t, y)
    return [*velocities, *np.linalg.solve(np.array(matrix, dtype=float), right)[:4]]


def car_start(p=CAR):
    return [0.0, p["l0"], p["l"], p["l0"], -p["l0"] / p["l"], 0.0, -p["l0"] / p["l"], 0.0]


def car_lagdsl(integrator, **options):
    return lagdsl.load(MODELS / "car_axis.lag").simulate("bumps", integrator=integrator, **options)


def car_error(positions) -> float:
    return float(np.max(np.abs(np.asarray(positions) - CAR_REFERENCE) / np.abs(CAR_REFERENCE)))


# ---- measuring ----------------------------------------------------------------------------
def best_lagdsl(run, repeat=15):
    """(best wall time, result) of `repeat` runs of a lagdsl simulation."""
    results = [run() for _ in range(repeat)]
    best = min(results, key=lagdsl_seconds)
    return lagdsl_seconds(best), best


@dataclass
class Run:
    """One integration: CPU seconds, the states on the output grid (one column per time),
    and the work: right-hand sides, Jacobians, LU decompositions (None where not reported)."""
    seconds: float
    success: bool
    states: np.ndarray
    fevals: int | None
    jacobians: int | None
    lus: int | None


def scipy_solver(method):
    def run(problem, rtol, stop):
        options = dict(method=method, rtol=rtol, atol=rtol * 1e-3, t_eval=problem["grid"](stop))
        if problem["jac"]:
            options["jac"] = problem["jac"]
        started = cpu_seconds()
        solution = solve_ivp(problem["rhs"], (0.0, stop), problem["start"](), **options)
        return Run(cpu_seconds() - started, solution.success, solution.y, solution.nfev, solution.njev,
                   solution.nlu)
    return run


def cvodes_solver(problem, rtol, stop):
    """CasADi's cvodes (SUNDIALS BDF with Newton) on the same equations as SX expressions; the
    symbolic set-up is not timed."""
    y, t = casadi.SX.sym("y", len(problem["start"]())), casadi.SX.sym("t")
    grid = problem["grid"](stop)
    integrator = casadi.integrator("F", "cvodes", {"x": y, "t": t, "ode": problem["casadi_rhs"](t, y)},
                                   0.0, list(grid[1:]),
                                   {"reltol": rtol, "abstol": rtol * 1e-3, "max_num_steps": 10 ** 8})
    start = problem["start"]()
    started = cpu_seconds()
    try:
        final = integrator(x0=start)["xf"]
    except RuntimeError:
        return Run(cpu_seconds() - started, False, np.empty((0, 0)), None, None, None)
    seconds = cpu_seconds() - started
    stats = integrator.stats()
    states = np.hstack([np.array(start)[:, None], np.array(final)])
    return Run(seconds, True, states, stats["nfevals"], stats["n_call_jacF"], stats["nlinsetups"])


def solvers():
    table = [(f"SciPy {method}", scipy_solver(method)) for method in SCIPY_METHODS]
    if casadi is not None:
        table.append(("CasADi cvodes", cvodes_solver))
    return table


def equal_error_row(problem, name, solver, targets, short_span, budget):
    """Find the loosest rtol of the ladder at which the solver reaches radau5's error: first
    over the short span (targets[0]); then over the whole span (targets[1]), where it is timed,
    or, when that would take over the budget, with the short-span time scaled to the span."""
    for rtol in LADDER:
        run = solver(problem, rtol, short_span)
        if not run.success:
            continue
        error = problem["error"](run.states)
        print(f"  {problem['name']} {name} rtol {rtol:.1e}: error {error:.3g} on {short_span:g} s, "
              f"{run.seconds:.3g} s", file=sys.stderr)
        if error > targets[0]:
            continue
        scaled = run.seconds * problem["stop"] / short_span
        if short_span < problem["stop"] and scaled > budget:
            return dict(name=name, rtol=rtol, error=error, seconds=scaled, how=f"scaled from {short_span:g} s",
                        run=run)
        if short_span < problem["stop"]:
            run = solver(problem, rtol, problem["stop"])
            error = problem["error"](run.states)
            if not run.success or error > targets[1]:
                continue
        return dict(name=name, rtol=rtol, error=error, seconds=run.seconds, how="measured", run=run)
    return dict(name=name, rtol=None, error=None, seconds=None, how="no rtol down to 1e-11 reached it",
                run=None)


def spring_problem(reference):
    return dict(name="stiff spring", rhs=spring_rhs, jac=spring_jacobian, start=spring_start,
                grid=lambda stop: np.linspace(0.0, stop, int(round(stop / SPRING_INTERVAL)) + 1),
                casadi_rhs=lambda t, y: casadi.vertcat(*spring_rhs(t, y, lib=casadi)),
                error=lambda states: float(np.max(np.abs(states[1] - reference[:states.shape[1]]))),
                stop=SPRING_STOP)


def car_casadi_rhs(t, y):
    matrix, right, velocities = car_saddle_point(t, y, lib=casadi)
    solution = casadi.solve(casadi.blockcat([[casadi.SX(entry) for entry in row] for row in matrix]),
                            casadi.vertcat(*right))
    return casadi.vertcat(*velocities, solution[:4])


def car_problem():
    return dict(name="car axis", rhs=car_rhs, jac=None, start=car_start, grid=lambda stop: np.array([0.0, stop]),
                casadi_rhs=car_casadi_rhs, error=lambda states: car_error(states[:4, -1]), stop=CAR_STOP)


def format_row(row, radau):
    def num(x, fmt):
        return "n/a" if x is None else format(x, fmt)
    run = row["run"]
    work = [num(run.fevals, "d"), num(run.jacobians, "d"), num(run.lus, "d")] if run else ["n/a"] * 3
    speed = f"{row['seconds'] / radau:.0f}x" if row["seconds"] else "n/a"
    return [row["name"], num(row["rtol"], ".1e"), num(row["error"], ".2g"), *work,
            num(row["seconds"], ".3g") + " s" if row["seconds"] else "n/a", row["how"], speed]


HEADERS = ["method", "rtol", "error", "f evals", "Jacobians", "LU", "time", "time is", "radau5 faster by"]


def lagdsl_row(name, rtol, error, seconds, result):
    s = result.summary
    return [name, f"{rtol:.0e}", f"{error:.2g}", str(s.count("rhs_evals")), str(s.count("jac_evals") or 0),
            str(s.count("lu_decomps") or 0), f"{seconds * 1e3:.3g} ms", "measured", ""]


def stiff_spring_section(short_span, budget) -> str:
    reference_run = spring_lagdsl(SPRING_STOP, rtol=1e-12, atol=1e-15)
    reference = reference_run["phi"]
    check = spring_lagdsl(SPRING_STOP, rtol=1e-11, atol=1e-14)["phi"]
    rtol = 1e-6
    radau_time, radau = best_lagdsl(lambda: spring_lagdsl(SPRING_STOP, rtol=rtol, atol=1e-9))
    radau_error = float(np.max(np.abs(radau["phi"] - reference)))
    short = spring_lagdsl(short_span, rtol=rtol, atol=1e-9)
    target_short = float(np.max(np.abs(short["phi"] - reference[:len(short.t)])))
    print(f"stiff spring: radau5 error {radau_error:.3g} (over {short_span:g} s: {target_short:.3g})",
          file=sys.stderr)
    problem = spring_problem(reference)
    rows = [lagdsl_row("lagdsl radau5 (C)", rtol, radau_error, radau_time, radau)]
    results = [equal_error_row(problem, name, solver, (target_short, radau_error), short_span, budget)
               for name, solver in solvers()]
    rows += [format_row(r, radau_time) for r in results]
    return "\n".join([f"Reference: radau5 at rtol 1e-12 (differs from rtol 1e-11 by "
                      f"{np.max(np.abs(reference - check)):.2g}). radau5's error over the first {short_span:g} s, "
                      f"the target of the ladders: {target_short:.2g}.", "", markdown_table(HEADERS, rows), "",
                      verdict(results, {"radau5": radau_time})])


def car_axis_section(short_span, budget) -> str:
    rtol = 1e-6
    rows, times, errors = [], {}, {}
    for integrator in ("radau5", "dop853"):
        seconds, result = best_lagdsl(lambda: car_lagdsl(integrator, rtol=rtol, atol=1e-8))
        errors[integrator] = car_error(result.values[-1, :4])
        rows.append(lagdsl_row(f"lagdsl {integrator} (C)", rtol, errors[integrator], seconds, result))
        times[integrator] = seconds
    radau_time, radau_error = times["radau5"], errors["radau5"]
    print(f"car axis: radau5 error {radau_error:.3g}", file=sys.stderr)
    problem = car_problem()
    results = [equal_error_row(problem, name, solver, (radau_error, radau_error), CAR_STOP, budget)
               for name, solver in solvers()]
    rows += [format_row(r, radau_time) for r in results]
    return "\n".join([markdown_table(HEADERS, rows), "", verdict(results, times)])


def verdict(results, lagdsl_times) -> str:
    """How many times faster each lagdsl method is than the fastest SciPy method and than cvodes."""
    scipy = min((r["seconds"] for r in results if r["seconds"] and r["name"].startswith("SciPy")), default=None)
    cvodes = next((r["seconds"] for r in results if r["seconds"] and r["name"] == "CasADi cvodes"), None)
    sentences = []
    for integrator, seconds in lagdsl_times.items():
        against = [f"{scipy / seconds:.0f}x faster than the fastest SciPy method"] if scipy else []
        against += [f"{cvodes / seconds:.0f}x faster than cvodes"] if cvodes else []
        if against:
            sentences.append(f"lagdsl's {integrator} is " + " and ".join(against) + ".")
    return " ".join(sentences) + " Goal: radau5 at least 100x faster than the fastest SciPy method."


def casadi_note() -> str:
    if casadi is None:
        return "CasADi is not installed here, so there is no cvodes row (`pip install casadi` to add one)."
    return (f"CasADi {casadi.__version__}: cvodes runs SX expressions of the same equations in CasADi's "
            "virtual machine (not compiled to C); its set-up is not timed.")


def section(short_span=1.0, budget=60.0) -> str:
    return "\n".join([
        "### (a) Stiff problems at equal error", "",
        "#### The stiff spring (elastic pendulum, k = 1e8, 10 s)", "",
        "SciPy integrates the same equations in the same coordinates with the analytic Jacobian; "
        "the `time is` column says whether a SciPy time was measured over the whole span or scaled "
        f"from the first {short_span:g} s (only when the whole span would take over {budget:g} s).", "",
        stiff_spring_section(short_span, budget), "",
        "#### The car axis (3 s)", "",
        car_axis_section(short_span, budget), "",
        "The car axis is only mildly stiff at this tolerance: its springs vibrate at 45 rad/s, about "
        "20 periods in 3 s, which every method has to follow, and LSODA runs it in its non-stiff "
        "(Adams) mode without a single Jacobian. An implicit method has little advantage there, and "
        "LSODA, with few but expensive (Python) steps, is the SciPy method to beat.", "",
        casadi_note(),
    ])


if __name__ == "__main__":
    sys.exit(command_line(section, __doc__, short_span=1.0, budget=60.0))
