"""Derivation speed and code size on the planar n-link pendulum: lagdsl against sympy.physics.mechanics.

    python benchmarks/derivation_scaling.py [--sizes 4,8,12,16,24,32] [--max-n N] [--timeout 120]
                                            [--repeat 3] [--quick]

The system is models/pendulum_chain.lag (n point masses on light rigid links, absolute angles
from the downward vertical), its parameter n replaced for each size. For each n, in this one
process on one core, each measurement starting from an empty SymPy cache, in CPU seconds of
the process (the machine is shared; see benchtools.cpu_seconds):

  lagdsl derive   parse + build_model + derive_equations, from the .lag text (best of --repeat)
  lagdsl eom      the same, then format_equations: the text `lagc eom` prints (best of --repeat)
  lagdsl .lag->C  the same, then plan_scene + lower_to_kernel (CSE) + render_c: the generated C
                  text (best of --repeat)
  Lagrange        sympy.physics.mechanics.LagrangesMethod on the same positions (x_i = sum of
                  l sin(theta_j), y_i = -sum of l cos(theta_j)), velocities by d/dt:
                  Lagrangian, form_lagranges_equations, mass_matrix_full, forcing_full
  Kane            KanesMethod, the way SymPy's examples build a chain: one frame per link
                  (orientnew about N.z), particles located by -l A_i.y, v2pt_theory, q' = u:
                  kanes_equations, mass_matrix_full, forcing_full (--kane-cartesian: the
                  .lag's positions in N's components instead, velocities by d/dt, q' -> u)

and the size of the right-hand side after common-subexpression elimination:

  lagdsl ops      sum of sympy.count_ops over the assignments and stores of kernel.system (the
                  block that assembles M and f for the generated code, after lagdsl's CSE)
  Kane ops        sympy.cse of Kane's mass_matrix_full and forcing_full (after replacing q_i(t),
                  u_i(t) by plain symbols, as any code generator must), then count_ops of the
                  replacements plus the reduced expressions

Each SymPy method has a time limit per n (--timeout); once it runs over, larger n are skipped.

Targets (issue: derivation that scales): n = 12 derived, and its equations printed by
`lagc eom`, at least 20x faster than LagrangesMethod; n = 32 from .lag to C "in seconds" (read here as under 10 s); no more
operations after CSE than KanesMethod's equations.
"""
from __future__ import annotations

import benchtools  # noqa: F401  (first: one BLAS thread before NumPy is imported)

import argparse
import re
import sys
from dataclasses import dataclass, field

import sympy

from benchtools import (MODELS, TimeLimitExceeded, best_of, cpu_seconds, machine_description, markdown_table,
                        pin_to_one_core, ratio, seconds, time_limit, timed)

CHAIN = MODELS / "pendulum_chain.lag"
DEFAULT_SIZES = (4, 8, 12, 16, 24, 32)
QUICK_SIZES = (4, 8, 12)
QUICK_TIMEOUT = 60.0
C_SECONDS = 10.0          # what "n = 32 from .lag to C in seconds" is taken to mean


# ---- the model text --------------------------------------------------------------------------
def chain_source(n: int) -> str:
    """models/pendulum_chain.lag with its size parameter set to n."""
    text, count = re.subn(r"(parameter n = )\d+", rf"\g<1>{n}", CHAIN.read_text(encoding="utf-8"))
    if count != 1:
        raise SystemExit(f"{CHAIN}: expected one 'parameter n = <integer>' to replace, found {count}")
    return text


# ---- lagdsl ----------------------------------------------------------------------------------
def lagdsl_derive(text: str, n: int):
    """.lag text -> (ir.Model, Equations)."""
    from lagdsl.mechanics import derive_equations
    from lagdsl.pipeline import model_from_source
    from lagdsl.source import SourceFile
    model = model_from_source(SourceFile(f"pendulum_chain_{n}.lag", text))
    return model, derive_equations(model)


def lagdsl_eom(text: str, n: int) -> str:
    """.lag text -> the equations of motion as `lagc eom` prints them."""
    from lagdsl.present import format_equations
    return format_equations(lagdsl_derive(text, n)[1])


def lagdsl_to_c(text: str, n: int) -> dict:
    """.lag text -> generated C text, timing each stage."""
    from lagdsl.codegen.c import render_c
    from lagdsl.codegen.kernel import lower_to_kernel
    from lagdsl.mechanics import derive_equations
    from lagdsl.pipeline import model_from_source
    from lagdsl.scene import plan_scene
    from lagdsl.source import SourceFile
    clock = [cpu_seconds()]

    def lap():
        clock.append(cpu_seconds())
        return clock[-1] - clock[-2]

    model = model_from_source(SourceFile(f"pendulum_chain_{n}.lag", text))
    parse = lap()
    equations = derive_equations(model)
    derive = lap()
    kernel = lower_to_kernel(equations, plan_scene(model, equations))
    lower = lap()
    c_text = render_c(kernel, f"pendulum_chain_{n}.lag").text
    render = lap()
    return {"parse": parse, "derive": derive, "lower": lower, "render": render,
            "kernel": kernel, "c_bytes": len(c_text)}


def kernel_operations(kernel) -> int:
    """Operations of the generated right-hand side: count_ops over kernel.system after CSE."""
    block = kernel.system
    return (sum(sympy.count_ops(value) for _, value in block.assignments)
            + sum(sympy.count_ops(store.value) for store in block.stores))


# ---- sympy.physics.mechanics -----------------------------------------------------------------
def lagranges_equations(n: int):
    """LagrangesMethod on the chain written as in the .lag file -> (M_full, F_full)."""
    from sympy.physics import mechanics as me
    q = me.dynamicsymbols(f"q1:{n + 1}")
    m, l, g = sympy.symbols("m l g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    previous, bobs = O, []
    for i in range(n):
        P = previous.locatenew(f"P{i + 1}", l * sympy.sin(q[i]) * N.x - l * sympy.cos(q[i]) * N.y)
        P.set_vel(N, P.pos_from(O).dt(N))
        bob = me.Particle(f"B{i + 1}", P, m)
        bob.potential_energy = m * g * P.pos_from(O).dot(N.y)
        bobs.append(bob)
        previous = P
    method = me.LagrangesMethod(me.Lagrangian(N, *bobs), q)
    method.form_lagranges_equations()
    return method.mass_matrix_full, method.forcing_full


def kanes_equations(n: int, cartesian: bool = False):
    """KanesMethod on the chain, q' = u -> (M_full, F_full, q, u).

    By default one frame per link, as SymPy's examples build a chain; with `cartesian`, the
    positions of the .lag file in N's components, velocities by d/dt with q' replaced by u.
    """
    from sympy.physics import mechanics as me
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g = sympy.symbols("m l g", positive=True)
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    speeds = {qi.diff(): ui for qi, ui in zip(q, u)}
    previous, bobs, loads = O, [], []
    for i in range(n):
        if cartesian:
            P = previous.locatenew(f"P{i + 1}", l * sympy.sin(q[i]) * N.x - l * sympy.cos(q[i]) * N.y)
            P.set_vel(N, P.pos_from(O).dt(N).xreplace(speeds))
        else:
            link = N.orientnew(f"A{i + 1}", "Axis", [q[i], N.z])
            link.set_ang_vel(N, u[i] * N.z)
            P = previous.locatenew(f"P{i + 1}", -l * link.y)
            P.v2pt_theory(previous, N, link)
        bobs.append(me.Particle(f"B{i + 1}", P, m))
        loads.append((P, -m * g * N.y))
        previous = P
    method = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    method.kanes_equations(bobs, loads)
    return method.mass_matrix_full, method.forcing_full, q, u


def kane_operations(equations) -> int:
    """count_ops after sympy.cse of M_full and F_full, with q(t), u(t) as plain symbols."""
    M, F, q, u = equations
    plain = {f: sympy.Symbol(f.func.__name__, real=True) for f in (*q, *u)}
    expressions = [e.xreplace(plain) for e in (*M, *F)]
    replacements, reduced = sympy.cse(expressions)
    return (sum(sympy.count_ops(value) for _, value in replacements)
            + sum(sympy.count_ops(e) for e in reduced))


# ---- measuring -------------------------------------------------------------------------------
@dataclass
class Row:
    n: int
    derive: float | None = None
    eom: float | None = None
    to_c: float | None = None
    stages: dict = field(default_factory=dict)
    lagdsl_ops: int | None = None
    lagrange: float | str | None = None
    kane: float | str | None = None
    kane_cse: float | str | None = None
    kane_ops: int | str | None = None


class Limits:
    """Per-method time limits: once a method runs over at some n, it is skipped for larger n."""

    def __init__(self, timeout: float):
        self.timeout = timeout
        self.exceeded: dict[str, int] = {}

    def run(self, method: str, n: int, function, *args):
        """(seconds, result), or ("reason", None) when over the limit or skipped."""
        if method in self.exceeded:
            return f"skipped (> {self.timeout:g} s at n = {self.exceeded[method]})", None
        try:
            with time_limit(self.timeout):
                return timed(function, *args)
        except TimeLimitExceeded:
            self.exceeded[method] = n
            benchtools.fresh_start()
            return f"> {self.timeout:g} s (stopped)", None


def warm_up() -> None:
    """Run every method once at n = 2, untimed, so that no measurement pays for imports or lark's tables."""
    text = chain_source(2)
    lagdsl_derive(text, 2)
    lagdsl_eom(text, 2)
    lagdsl_to_c(text, 2)
    kane_operations(kanes_equations(2))
    kane_operations(kanes_equations(2, cartesian=True))
    lagranges_equations(2)


def measure(n: int, repeat: int, limits: Limits, kane_cartesian: bool) -> Row:
    text = chain_source(n)
    row = Row(n)
    row.derive, _ = best_of(repeat, lagdsl_derive, text, n)
    row.eom, _ = best_of(repeat, lagdsl_eom, text, n)
    row.to_c, stages = best_of(repeat, lagdsl_to_c, text, n)
    row.stages = stages
    row.lagdsl_ops = kernel_operations(stages["kernel"])
    row.kane, equations = limits.run("Kane", n, kanes_equations, n, kane_cartesian)
    if equations is not None:
        row.kane_cse, row.kane_ops = limits.run("Kane CSE", n, kane_operations, equations)
    else:
        row.kane_cse = row.kane_ops = "n/a"
    row.lagrange, _ = limits.run("Lagrange", n, lagranges_equations, n)
    return row


# ---- the report ------------------------------------------------------------------------------
def main_table(rows) -> str:
    body = [[r.n, seconds(r.derive), seconds(r.eom), seconds(r.to_c),
             seconds(r.lagrange), ratio(r.lagrange, r.derive), ratio(r.lagrange, r.eom), seconds(r.kane), ratio(r.kane, r.derive),
             r.lagdsl_ops, r.kane_ops, ratio(r.kane_ops, r.lagdsl_ops)] for r in rows]
    return markdown_table(["n", "lagdsl derive", "lagdsl eom", "lagdsl .lag->C", "LagrangesMethod",
                           "Lagrange / lagdsl", "Lagrange / lagdsl eom",
                           "KanesMethod", "Kane / lagdsl", "lagdsl ops", "Kane ops", "Kane ops / lagdsl ops"],
                          body)


def stage_table(rows) -> str:
    body = [[r.n, seconds(r.stages["parse"]), seconds(r.stages["derive"]), seconds(r.stages["lower"]),
             seconds(r.stages["render"]), r.stages["c_bytes"], seconds(r.kane_cse)] for r in rows]
    return markdown_table(["n", "parse + build", "derive_equations", "plan + lower (CSE)", "render_c",
                           "C bytes", "Kane: cse + count_ops"], body)


def targets(rows) -> list[str]:
    """The three targets, each 'met', 'NOT met' or 'not measured', with the number."""
    by_n = {r.n: r for r in rows}
    lines = []
    r12 = by_n.get(12)
    if r12 and isinstance(r12.lagrange, float):
        x = r12.lagrange / r12.derive
        lines.append(f"n = 12 derived >= 20x faster than LagrangesMethod: {x:.0f}x, {'met' if x >= 20 else 'NOT met'}")
        x = r12.lagrange / r12.eom
        lines.append(f"n = 12 equations printed (lagc eom) >= 20x faster than LagrangesMethod: {x:.0f}x, "
                     f"{'met' if x >= 20 else 'NOT met'}")
    else:
        lines.append("n = 12 derived >= 20x faster than LagrangesMethod: not measured")
    r32 = by_n.get(32)
    if r32:
        lines.append(f"n = 32 from .lag to C in seconds (< {C_SECONDS:g} s): {r32.to_c:.2f} s, "
                     f"{'met' if r32.to_c < C_SECONDS else 'NOT met'}")
    else:
        lines.append("n = 32 from .lag to C in seconds: not measured")
    compared = [r for r in rows if isinstance(r.kane_ops, int)]
    if compared:
        worst = max(compared, key=lambda r: r.lagdsl_ops / r.kane_ops)
        verdict = "met" if all(r.lagdsl_ops <= r.kane_ops for r in compared) else "NOT met"
        lines.append(f"operations after CSE <= KanesMethod's: worst lagdsl/Kane = "
                     f"{worst.lagdsl_ops / worst.kane_ops:.2f} at n = {worst.n}, {verdict}")
    else:
        lines.append("operations after CSE <= KanesMethod's: not measured")
    return lines


def parse_arguments(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", default=",".join(map(str, DEFAULT_SIZES)),
                        help="comma-separated chain lengths (default %(default)s)")
    parser.add_argument("--max-n", type=int, default=None, help="leave out sizes above this")
    parser.add_argument("--timeout", type=float, default=None,
                        help="seconds per SymPy method and n (default 120, --quick 60)")
    parser.add_argument("--repeat", type=int, default=None, help="lagdsl runs per n, best counts (default 3, --quick 1)")
    parser.add_argument("--quick", action="store_true", help="n = 4, 8, 12 only, shorter time limits, one run")
    parser.add_argument("--kane-cartesian", action="store_true",
                        help="KanesMethod on the .lag's Cartesian positions instead of one frame per link")
    args = parser.parse_args(argv)
    sizes = QUICK_SIZES if args.quick else tuple(int(s) for s in args.sizes.split(",") if s.strip())
    if args.max_n is not None:
        sizes = tuple(n for n in sizes if n <= args.max_n)
    args.sizes = sizes
    args.timeout = args.timeout or (QUICK_TIMEOUT if args.quick else 120.0)
    args.repeat = args.repeat or (1 if args.quick else 3)
    return args


def main(argv=None) -> int:
    args = parse_arguments(argv)
    core = pin_to_one_core()
    print(f"# Planar n-link pendulum: {machine_description()}; pinned to CPU {core}")
    print(f"# sizes {', '.join(map(str, args.sizes))}; SymPy time limit {args.timeout:g} s per method and n; "
          f"lagdsl best of {args.repeat}; KanesMethod on "
          f"{'Cartesian positions' if args.kane_cartesian else 'one frame per link'}\n", flush=True)
    limits = Limits(args.timeout)
    rows = []
    warm_up()
    for n in args.sizes:
        rows.append(measure(n, args.repeat, limits, args.kane_cartesian))
        r = rows[-1]
        print(f"n = {n}: lagdsl {seconds(r.derive)} (eom {seconds(r.eom)}, to C {seconds(r.to_c)}), Lagrange {seconds(r.lagrange)}, "
              f"Kane {seconds(r.kane)}, ops lagdsl {r.lagdsl_ops} / Kane {r.kane_ops}", file=sys.stderr, flush=True)
    print(main_table(rows))
    print()
    print(stage_table(rows))
    print("\nTargets:")
    for line in targets(rows):
        print(f"- {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
