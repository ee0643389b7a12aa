"""Large systems: how generation, compilation and integration grow with the number of coordinates.

    python benchmarks/large_systems.py [--fpu 50 200 1000 5000] [--accuracy 200] [--chain 8 16 32 64]
                                       [--implicit 50 200 1000] [--kane-max 12] [--dense-max 32] [--limit 900]

Two families, each size measured in its own process (so that peak memory is that size's own):

  FPU chain   the stiff Fermi-Pasta-Ulam chain of Hairer, Lubich and Wanner (GNI I.5) with n unit
              masses (`coordinate q[n]`, T a sum of squares, stiff linear springs within pairs,
              soft quartic ones between them and to the walls): an identity, so diagonal, mass
              matrix. lagdsl's C backend against scipy's DOP853 on a vectorised NumPy right-hand
              side (a few array operations), 10 s of motion at rtol 1e-8, atol 1e-10.
  accuracy    the FPU chain at equal accuracy: lagdsl's rkn8 (the Nystrom pair for q'' = a(q)),
              lagdsl's dop853 and SciPy's DOP853, each at the loosest rtol whose largest error
              of q[1] over the output grid is at most 1e-9 (against dop853 at rtol 1e-13).
  implicit    the FPU chain with radau5 (rtol 1e-6, atol 1e-8), whose Newton matrices are banded
              (radau5.c), against scipy's Radau given the sparsity of the Jacobian (jac_sparsity,
              so that it estimates J by grouped differences and factors it with sparse LU).
  n-link      models/pendulum_chain.lag with n links and unequal masses (`m[n] = {1 + 1/i}`):
              a dense mass matrix in the joint angles, which lagdsl solves by the tree form
              (mechanics/trees.py, the articulated-body recursion in O(n)). Against the dense
              path (the same model's expanded equations, up to --dense-max links), against
              Pinocchio's `aba` called from Python (the optional dependency `pin`; the same
              planar chain of revolute joints and point masses, per call, its binding overhead
              measured on a 1-link model and subtracted), and against
              sympy.physics.mechanics.KanesMethod + lambdify + scipy DOP853 up to --kane-max
              links (Kane's derivation grows fast). Also the whole cold `lagc run` (10 s).

For each: CPU seconds to generate (parse, derive, lower, print the C), to compile it (cc -O2,
the flags of the build cache), one right-hand side (integration time / evaluations), one
simulated second (the fastest of 3 calls of `simulate`, CPU seconds of the whole call, the
Python around the C included; SciPy's the same way, CPU seconds of `solve_ivp`), the peak
resident memory of the process, and the difference of q[1] at t = 10 from scipy's; for the FPU
chain and the n-link chain also the whole cold `lagc run` (an empty build cache, the compiler included). Growth exponents are fitted between the two largest sizes measured.
"""
from __future__ import annotations

import benchtools  # noqa: F401  (first: one BLAS thread before NumPy is imported)

import argparse
import json
import math
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RTOL, ATOL, STOP, INTERVAL = 1e-8, 1e-10, 10.0, 0.1
IMPLICIT_RTOL, IMPLICIT_ATOL = 1e-6, 1e-8
REPEAT = 3          # integrations of each kind; the fastest counts (the machine is shared)


def fpu_text(n: int) -> str:
    """The FPU chain with n = 2m unit masses, omega = 50; q[1] starts at 1 (FPU's first mode)."""
    m = n // 2
    return f"""model FPU{n} "stiff FPU chain of {n} unit masses"
  parameter omega = 50;
  coordinate q[{n}](start = {{1{", 0" * (n - 1)}}});
  T = sum(der(q[i])^2/2, i in 1:{n});
  U = omega^2/4*sum((q[2*i] - q[2*i - 1])^2, i in 1:{m})
    + q[1]^4 + sum((q[2*i + 1] - q[2*i])^4, i in 1:{m - 1}) + q[{n}]^4;
  scene run
    time(stop = {STOP}, interval = {INTERVAL});
    integrator dop853(rtol = {RTOL}, atol = {ATOL});
    output q[1], energy;
  end run;
end FPU{n};
"""


def fpu_rhs(n: int):
    """The vectorised NumPy right-hand side a user would write for the same chain."""
    import numpy as np
    omega2 = 50.0 ** 2

    def rhs(t, y):
        q, v = y[:n], y[n:]
        force = np.zeros(n)
        stiff = omega2 / 2 * (q[1::2] - q[0::2])          # the pairs (q[2i-1], q[2i]), 1-based
        force[0::2] += stiff
        force[1::2] -= stiff
        soft = 4 * (q[2::2] - q[1:-1:2]) ** 3             # between pairs: (q[2i+1] - q[2i])^4
        force[1:-1:2] += soft
        force[2::2] -= soft
        force[0] -= 4 * q[0] ** 3
        force[-1] -= 4 * q[-1] ** 3
        return np.concatenate([v, force])
    return rhs


def cpu_call(function, *args, **options):
    """(CPU seconds, result) of one call: both sides are timed by CPU, so that a loaded machine
    (time descheduled) favours neither."""
    started = benchtools.cpu_seconds()
    result = function(*args, **options)
    return benchtools.cpu_seconds() - started, result


def measure_lagdsl(path: Path, scene: str) -> dict:
    """Generate, compile and run one scene; CPU seconds for the first two, lagdsl's own
    integration time for the run."""
    from lagdsl.codegen.c import render_c
    from lagdsl.codegen.kernel import lower_to_kernel
    from lagdsl.pipeline import compile_model, plan
    from lagdsl.run.toolchain import LIBRARY_FLAGS, find_compiler
    from lagdsl.scene import Overrides
    from lagdsl.source import SourceFile
    import lagdsl

    started = benchtools.cpu_seconds()
    model, equations = compile_model(SourceFile.read(path))                   # as lagc does
    derived = benchtools.cpu_seconds()
    kernel = lower_to_kernel(equations, plan(model, equations, scene, Overrides()))
    source = render_c(kernel, path.name).text
    generated = benchtools.cpu_seconds()
    with tempfile.TemporaryDirectory() as work:
        c_file = Path(work) / "model.c"
        c_file.write_text(source)
        wall = time.perf_counter()
        done = subprocess.run([find_compiler(), *LIBRARY_FLAGS, str(c_file), "-o", str(Path(work) / "m.so"), "-lm"],
                              capture_output=True)
        compile_seconds = time.perf_counter() - wall
        compile_cpu = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    loaded = lagdsl.load(path)
    result = loaded.simulate(scene)                            # compiles into the build cache
    runs = [cpu_call(loaded.simulate, scene) for _ in range(REPEAT)]
    integration = min(seconds for seconds, _ in runs)
    summary = result.summary
    return {"derive": derived - started, "generate": generated - started, "compile": compile_cpu,
            "compile_wall": compile_seconds, "compiled": done.returncode == 0, "kb": len(source) / 1024,
            "layout": (kernel.layout.kind if kernel.layout else "lu") + (" loops" if kernel.system and kernel.system.loops
                                                                         else "")
            + (f", {kernel.jacobian_layout.kind} E" if kernel.jacobian_layout else ""),
            "integration": integration, "rhs": summary.count("rhs_evals"),
            "final": [float(result.values[-1, 0])]}


def cold_run(path: Path) -> tuple[float, float]:
    """(CPU seconds, wall seconds) of the whole `lagc run` process with an empty build cache,
    the compiler included, as a user meets it the first time."""
    with tempfile.TemporaryDirectory() as cache:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        subprocess.run([str(Path(sys.executable).with_name("lagc")), "run", str(path), "-o", str(Path(cache) / "out.csv")],
                       env={**os.environ, "LAGDSL_CACHE": cache}, capture_output=True, check=True)
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime, wall


def one_fpu(n: int) -> dict:
    import numpy as np
    from scipy.integrate import solve_ivp
    with tempfile.TemporaryDirectory() as work:
        path = Path(work) / f"fpu{n}.lag"
        path.write_text(fpu_text(n))
        row = measure_lagdsl(path, "run")
        row["cold_cpu"], row["cold_wall"] = cold_run(path)
    y0 = np.zeros(2 * n)
    y0[0] = 1.0
    rhs = fpu_rhs(n)
    times = np.arange(0, STOP + INTERVAL / 2, INTERVAL)
    runs = [cpu_call(solve_ivp, rhs, (0, STOP), y0, method="DOP853", rtol=RTOL, atol=ATOL, t_eval=times)
            for _ in range(REPEAT)]
    row["scipy"], reference = min(runs, key=lambda run: run[0])
    row["scipy_rhs"] = reference.nfev
    row["difference"] = abs(reference.y[0, -1] - row["final"][0])
    return row


ACCURACY = 1e-9                          # the error of q[1] over the grid that each method must reach
LADDER = [10 ** (-7 - k / 4) for k in range(21)]     # rtol 1e-7 .. 1e-12, atol = rtol / 100
REFERENCE_RTOL = 1e-13


def one_fpu_accuracy(n: int) -> dict:
    """Each method at the loosest rtol of LADDER whose largest error of q[1] over the output grid
    is at most ACCURACY, against dop853 at rtol 1e-13: SciPy's DOP853, lagdsl's dop853 and
    lagdsl's rkn8 (the Nystrom pair for q'' = a(q)); CPU seconds of the whole call (the fastest
    of REPEAT for lagdsl, one call for SciPy), as in one_fpu."""
    import numpy as np
    import lagdsl
    from scipy.integrate import solve_ivp
    with tempfile.TemporaryDirectory() as work:
        path = Path(work) / f"fpu{n}.lag"
        path.write_text(fpu_text(n))
        loaded = lagdsl.load(path)
        reference = loaded.simulate("run", rtol=REFERENCE_RTOL, atol=REFERENCE_RTOL / 100).values[:, 0]

        def lagdsl_run(method, rtol):
            loaded.simulate("run", integrator=method, rtol=rtol, atol=rtol / 100)      # compiles
            seconds, result = min((cpu_call(loaded.simulate, "run", integrator=method, rtol=rtol, atol=rtol / 100)
                                   for _ in range(REPEAT)), key=lambda run: run[0])
            return seconds, result.values[:, 0], result.summary.count("rhs_evals")

        y0 = np.zeros(2 * n)
        y0[0] = 1.0
        times = np.arange(0, STOP + INTERVAL / 2, INTERVAL)

        def scipy_run(rtol):
            seconds, solution = cpu_call(solve_ivp, fpu_rhs(n), (0, STOP), y0, method="DOP853", rtol=rtol,
                                         atol=rtol / 100, t_eval=times)
            return seconds, solution.y[0], solution.nfev

        row = {}
        for name, run in (("rkn8", lambda rtol: lagdsl_run("rkn8", rtol)),
                          ("dop853", lambda rtol: lagdsl_run("dop853", rtol)), ("scipy", scipy_run)):
            for rtol in LADDER:
                seconds, q1, evaluations = run(rtol)
                error = float(np.max(np.abs(q1 - reference)))
                if error <= ACCURACY:
                    row[name] = {"rtol": rtol, "error": error, "seconds": seconds, "evaluations": evaluations}
                    break
    return row


def report_accuracy(sizes, rows) -> None:
    headers = ["n", "method", "rtol needed", "error of q[1]", "evaluations", "CPU", "SciPy / this"]
    table = []
    for n, row in zip(sizes, rows):
        if not isinstance(row, dict):
            table.append([n, row] + [""] * (len(headers) - 2))
            continue
        scipy = row.get("scipy", {}).get("seconds")
        for name, label in (("rkn8", "lagdsl rkn8"), ("dop853", "lagdsl dop853"), ("scipy", "SciPy DOP853")):
            r = row.get(name)
            if r is None:
                table.append([n, label, f"none down to {LADDER[-1]:.0e}"] + [""] * (len(headers) - 3))
                continue
            table.append([n, label, f"{r['rtol']:.2g}", f"{r['error']:.1e}", r["evaluations"],
                          benchtools.seconds(r["seconds"]), benchtools.ratio(scipy, r["seconds"]) if scipy else "n/a"])
    print(f"equal accuracy: each method at the loosest rtol whose error of q[1] is at most {ACCURACY:g}")
    print(benchtools.markdown_table(headers, table))


def one_fpu_implicit(n: int) -> dict:
    import numpy as np
    from scipy import sparse
    from scipy.integrate import solve_ivp
    text = fpu_text(n).replace(f"dop853(rtol = {RTOL}, atol = {ATOL})",
                               f"radau5(rtol = {IMPLICIT_RTOL}, atol = {IMPLICIT_ATOL})")
    with tempfile.TemporaryDirectory() as work:
        path = Path(work) / f"fpu{n}.lag"
        path.write_text(text)
        row = measure_lagdsl(path, "run")
        row["cold_cpu"], row["cold_wall"] = cold_run(path)
    y0 = np.zeros(2 * n)
    y0[0] = 1.0
    # J = [[0, I], [T, 0]], T tridiagonal (each force involves the neighbours)
    pattern = sparse.bmat([[None, sparse.identity(n)], [sparse.diags([1, 1, 1], [-1, 0, 1], shape=(n, n)), None]])
    times = np.arange(0, STOP + INTERVAL / 2, INTERVAL)
    runs = [cpu_call(solve_ivp, fpu_rhs(n), (0, STOP), y0, method="Radau", rtol=IMPLICIT_RTOL, atol=IMPLICIT_ATOL,
                     t_eval=times, jac_sparsity=pattern) for _ in range(REPEAT)]
    row["scipy"], reference = min(runs, key=lambda run: run[0])
    row["scipy_rhs"] = reference.nfev
    row["difference"] = abs(reference.y[0, -1] - row["final"][0])
    return row


def chain_text(n: int) -> str:
    """models/pendulum_chain.lag with n links of unequal masses m[i] = 1 + 1/i."""
    source = (benchtools.MODELS / "pendulum_chain.lag").read_text()
    return (source.replace('parameter n = 12 ', f'parameter n = {n} ')
            .replace('parameter m = 1.0 [kg]      "mass of each bob";',
                     'parameter m[n] = {1 + 1/i, i in 1:n} [kg] "mass of each bob";')
            .replace("m/2*", "m[i]/2*").replace("m*g*y", "m[i]*g*y"))


def one_chain(n: int, kane: bool, dense: bool) -> dict:
    with tempfile.TemporaryDirectory() as work:
        path = Path(work) / "chain.lag"
        path.write_text(chain_text(n))
        row = measure_lagdsl(path, "swing")
        row["cold_cpu"], row["cold_wall"] = cold_run(path)
        if dense:
            row["dense"] = measure_dense(path, "swing")
    row.update(pinocchio_chain(n))
    if kane:
        row.update(kane_chain(n))
    return row


def measure_dense(path: Path, scene: str) -> dict:
    """The same scene through the expanded equations (derive_equations, the dense M): CPU
    seconds to generate and per right-hand side."""
    from lagdsl.mechanics import derive_equations
    from lagdsl.pipeline import execute, generate, load_model, plan
    from lagdsl.scene import Overrides
    started = benchtools.cpu_seconds()
    model = load_model(path)
    equations = derive_equations(model)
    scene_plan = plan(model, equations, scene, Overrides())
    _, source = generate(equations, scene_plan, "c", path.name)
    generated = benchtools.cpu_seconds() - started
    execute(source, scene_plan)                                 # compiles
    seconds, result = min((cpu_call(execute, source, scene_plan) for _ in range(REPEAT)),
                          key=lambda run: run[0])
    return {"generate": generated, "rhs": seconds / result.summary.count("rhs_evals"),
            "final": float(result.values[-1, 0])}


# Pinocchio's Data holds second-order derivative tensors of nv³ reals whatever is called: 1.1 GB
# at 256 links, and at 1024 links 22 GB, when the kernel killed the benchmark (out of memory).
PINOCCHIO_MAX = 256


def pinocchio_chain(n: int) -> dict:
    """Pinocchio's aba on the same chain (revolute joints about z, point masses m_i = 1 + 1/i
    at the ends of unit links, gravity -9.81 y), seconds per call from Python less the call
    overhead (a 1-link model's); {} when pinocchio is not installed or n > PINOCCHIO_MAX."""
    if n > PINOCCHIO_MAX:
        return {}
    try:
        import pinocchio
    except ImportError:
        return {}
    import timeit
    import numpy as np

    def per_call(links: int) -> float:
        model = pinocchio.Model()
        model.gravity.linear = np.array([0.0, -9.81, 0.0])
        parent, offset = 0, np.zeros(3)
        for i in range(1, links + 1):
            parent = model.addJoint(parent, pinocchio.JointModelRZ(), pinocchio.SE3(np.eye(3), offset), f"j{i}")
            model.appendBodyToJoint(parent, pinocchio.Inertia(1 + 1 / i, np.array([0.0, -1.0, 0.0]), np.zeros((3, 3))),
                                    pinocchio.SE3.Identity())
            offset = np.array([0.0, -1.0, 0.0])
        data = model.createData()
        q, v, tau = np.full(links, 0.5), np.full(links, 0.1), np.zeros(links)
        calls = max(200, 200000 // links)
        return min(timeit.repeat(lambda: pinocchio.aba(model, data, q, v, tau), number=calls, repeat=5,
                                 timer=time.process_time)) / calls

    overhead = per_call(1)
    return {"aba": per_call(n) - overhead, "aba_overhead": overhead}


def kane_chain(n: int) -> dict:
    """KanesMethod + lambdify + DOP853 for the same chain (m = l = 1, g = 9.81, theta = 0.5)."""
    import numpy as np
    import sympy
    from scipy.integrate import solve_ivp
    from sympy.physics import mechanics as me
    started = benchtools.cpu_seconds()
    q, u = me.dynamicsymbols(f"q:{n}"), me.dynamicsymbols(f"u:{n}")
    frame, origin = me.ReferenceFrame("N"), me.Point("O")
    origin.set_vel(frame, 0)
    point, bodies, loads = origin, [], []
    for i in range(n):
        link = frame.orientnew(f"A{i}", "Axis", [q[i], frame.z])
        link.set_ang_vel(frame, u[i] * frame.z)
        point = point.locatenew(f"P{i}", -1.0 * link.y)
        point.v2pt_theory(origin if i == 0 else previous, frame, link)
        bodies.append(me.Particle(f"m{i}", point, 1.0))
        loads.append((point, -9.81 * frame.y))
        previous = point
    kane = me.KanesMethod(frame, q_ind=q, u_ind=u, kd_eqs=[qd - ud for qd, ud in zip(me.dynamicsymbols(f"q:{n}", 1), u)])
    kane.kanes_equations(bodies, loads)
    mass = sympy.lambdify([q, u], kane.mass_matrix, "numpy", cse=True)
    forcing = sympy.lambdify([q, u], kane.forcing, "numpy", cse=True)
    generated = benchtools.cpu_seconds() - started

    def rhs(t, y):
        return np.concatenate([y[n:], np.linalg.solve(mass(y[:n], y[n:]), forcing(y[:n], y[n:]).ravel())])

    y0 = np.concatenate([np.full(n, 0.5), np.zeros(n)])
    seconds, solution = cpu_call(solve_ivp, rhs, (0, 10.0), y0, method="DOP853", rtol=1e-8, atol=1e-10)
    return {"kane_generate": generated, "kane_run": seconds, "kane_rhs": solution.nfev}


def child(kind: str, n: int, kane: bool, dense: bool) -> None:
    row = {"fpu": one_fpu, "accuracy": one_fpu_accuracy, "implicit": one_fpu_implicit}.get(
        kind, lambda n: one_chain(n, kane, dense))(n)
    row["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(row))


def measure(kind: str, n: int, kane: bool, limit: float, dense: bool = False) -> dict | str:
    command = [sys.executable, __file__, "--child", kind, str(n)] + (["--kane"] if kane else []) \
        + (["--dense"] if dense else [])
    # its own session, so that a size over the limit takes its C compiler down with it (a 1024-link
    # chain's cc1 went on for 13 CPU minutes and 6 GB after its parent was killed)
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True)
    try:
        stdout, stderr = child.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        os.killpg(child.pid, signal.SIGKILL)
        child.communicate()
        return f"over {limit:.0f} s"
    if child.returncode != 0:
        return "failed: " + (stderr.strip().splitlines() or [f"exit status {child.returncode}"])[-1]
    return json.loads(stdout.strip().splitlines()[-1])


def exponent(sizes, values) -> str:
    """log(v2/v1) / log(n2/n1) between the two largest sizes with a value."""
    points = [(n, v) for n, v in zip(sizes, values) if isinstance(v, (int, float)) and v > 0]
    if len(points) < 2:
        return "n/a"
    (n1, v1), (n2, v2) = points[-2:]
    return f"{math.log(v2 / v1) / math.log(n2 / n1):.2f}"


def report(kind: str, sizes, rows) -> None:
    ok = [r if isinstance(r, dict) else {} for r in rows]
    per_rhs = [r["integration"] / r["rhs"] if r.get("rhs") else None for r in ok]
    headers = ["n", "layout", "generate", "compile", "C KB", "per rhs", "per sim. s", "peak MB"]
    if kind != "chain":
        headers += ["scipy per sim. s", "speed-up", "|q1 - scipy|", "cold lagc run"]
    else:
        headers += ["cold lagc run", "dense generate", "dense per rhs", "Pinocchio aba", "aba / rhs",
                    "Kane generate", "Kane per sim. s"]
    table = []
    for n, r, rhs in zip(sizes, rows, per_rhs):
        if not isinstance(r, dict):
            table.append([n, r] + [""] * (len(headers) - 2))
            continue
        line = [n, r["layout"], benchtools.seconds(r["generate"]), benchtools.seconds(r["compile"]),
                f"{r['kb']:.0f}", f"{rhs * 1e6:.3g} us" if rhs else "n/a",
                benchtools.seconds(r["integration"] / STOP), f"{r['peak_mb']:.0f}"]
        if kind != "chain":
            line += [benchtools.seconds(r["scipy"] / STOP), benchtools.ratio(r["scipy"], r["integration"]),
                     f"{r['difference']:.1e}",
                     f"{benchtools.seconds(r['cold_cpu'])} CPU, {benchtools.seconds(r['cold_wall'])} wall"]
        else:
            dense = r.get("dense", {})
            line += [f"{benchtools.seconds(r['cold_cpu'])} CPU, {benchtools.seconds(r['cold_wall'])} wall",
                     benchtools.seconds(dense.get("generate")),
                     f"{dense['rhs'] * 1e6:.3g} us" if dense else "n/a",
                     f"{r['aba'] * 1e6:.3g} us (+{r['aba_overhead'] * 1e6:.2g})" if "aba" in r else "n/a",
                     f"{r['aba'] / rhs:.2f}" if "aba" in r and rhs else "n/a",
                     benchtools.seconds(r.get("kane_generate")), benchtools.seconds(
                         r["kane_run"] / 10 if "kane_run" in r else None)]
        table.append(line)
    print(benchtools.markdown_table(headers, table))
    print(f"growth exponents ({kind}): generate {exponent(sizes, [r.get('generate') for r in ok])}, "
          f"compile {exponent(sizes, [r.get('compile') for r in ok])}, "
          f"per rhs {exponent(sizes, per_rhs)}, C size {exponent(sizes, [r.get('kb') for r in ok])}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fpu", type=int, nargs="*", default=[50, 200, 1000, 5000])
    parser.add_argument("--chain", type=int, nargs="*", default=[8, 16, 32, 64])
    parser.add_argument("--accuracy", type=int, nargs="*", default=[200])
    parser.add_argument("--implicit", type=int, nargs="*", default=[50, 200, 1000])
    parser.add_argument("--kane-max", type=int, default=12)
    parser.add_argument("--dense-max", type=int, default=32, help="largest chain also run through the dense M")
    parser.add_argument("--limit", type=float, default=900, help="seconds allowed for one size")
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--kane", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--dense", action="store_true", help=argparse.SUPPRESS)
    arguments = parser.parse_args()
    if arguments.child:
        child(arguments.child[0], int(arguments.child[1]), arguments.kane, arguments.dense)
        return
    print(benchtools.machine_description())
    if arguments.fpu:
        report("fpu", arguments.fpu, [measure("fpu", n, False, arguments.limit) for n in arguments.fpu])
    if arguments.accuracy:
        report_accuracy(arguments.accuracy, [measure("accuracy", n, False, arguments.limit)
                                             for n in arguments.accuracy])
    if arguments.implicit:
        report("implicit", arguments.implicit, [measure("implicit", n, False, arguments.limit)
                                                for n in arguments.implicit])
    if arguments.chain:
        report("chain", arguments.chain, [measure("chain", n, n <= arguments.kane_max, arguments.limit,
                                                  n <= arguments.dense_max) for n in arguments.chain])


if __name__ == "__main__":
    main()
