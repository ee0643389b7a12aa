"""Human-readable output of `lagc check` and `lagc eom` (plain text and LaTeX).

Display is the one place where expressions are expanded: intermediates are inlined and
small results are tidied with trigsimp, so that a textbook system reads like the textbook
(m2*l1*l2*cos(theta1 - theta2), not a sum of products of sines and cosines). Large
expressions are shown as derived, since simplifying them does not scale.
"""
from __future__ import annotations

import sympy

from . import ir
from .calculus import Differentiator, tree_size
from .escape import visible
from .mechanics import Equations

TIDY_LIMIT = 400     # tree nodes; larger expressions are printed without trigsimp


def format_number(value: float) -> str:
    return f"{value:.12g}"


def describe_model(model: ir.Model, equations: Equations) -> str:
    """The report of `lagc check`."""
    title = f'model {model.name}' + (f' "{model.description}"' if model.description else "")
    lines = [f"{title}  ({model.source_name})", f"degrees of freedom: {degrees_of_freedom(equations)}"]
    for c in model.coordinates:
        unit = f" [{c.unit.text}]" if c.unit else ""
        lines.append(f"  {c.name}{unit}" + (f"  {c.description}" if c.description else ""))
    if model.parameters:
        lines.append("parameters: " + ", ".join(
            f"{p.name} = {format_number(p.value)}" + (f" [{p.unit.text}]" if p.unit else "")
            for p in model.parameters))
    lines.append("energy: " + ("T and U (natural system)" if model.lagrangian.is_natural else "general Lagrangian L"))
    if model.forces or model.dissipation:
        pushed = [f.coordinate for f in model.forces]
        lines.append("non-conservative: " + ", ".join(
            ([f"forces on {', '.join(pushed)}"] if pushed else []) +
            (["Rayleigh dissipation"] if model.dissipation else [])))
    lines.append("constraints:" + ("" if equations.constraints else " none"))
    for c in equations.constraints:
        status = ("identically satisfied by the coordinates: dropped" if c.dropped
                  else "enforced with a Lagrange multiplier")
        lines.append(f"  {c.name}: {c.kind}, {status}")
    lines.append("conserved quantities:" + ("" if equations.conserved else " none found"))
    for q in equations.conserved:
        lines.append(f"  {q.name}: {q.reason}")
    lines.append("scenes:" + ("" if model.scenes else " none (lagc run uses the default set-up)"))
    for s in model.scenes:
        options = ", ".join(f"{k} = {format_number(v)}" for k, v in s.integrator.options)
        lines.append(f"  {s.name}" + (f' "{s.description}"' if s.description else "")
                     + f": t = {format_number(s.time.start)} .. {format_number(s.time.stop)}"
                     f" every {format_number(s.time.interval)}, {s.integrator.name}({options}); "
                     f"outputs: {', '.join(o.column for o in s.outputs) or 'the coordinates'}")
    return "\n".join(visible(line) for line in lines)      # descriptions and units are free text


def degrees_of_freedom(equations: Equations) -> str:
    """n coordinates less the holonomic constraints; nonholonomic ones restrict only velocities."""
    n = equations.size
    holonomic = sum(c.kind == "holonomic" for c in equations.active_constraints)
    nonholonomic = len(equations.active_constraints) - holonomic
    if not holonomic and not nonholonomic:
        return str(n)
    parts = [f"{n} coordinates"]
    if holonomic:
        parts.append(f"{holonomic} holonomic constraint{'s' if holonomic > 1 else ''}")
    if nonholonomic:
        parts.append(f"{nonholonomic} nonholonomic constraint{'s' if nonholonomic > 1 else ''}")
        return f"{n - holonomic} in position, {n - holonomic - nonholonomic} in velocity ({', '.join(parts)})"
    return f"{n - holonomic} ({', '.join(parts)})"


def tidy(expr: sympy.Expr, calculus: Differentiator) -> sympy.Expr:
    expr = calculus.inline(expr)
    if tree_size(expr, TIDY_LIMIT) <= TIDY_LIMIT:
        expr = sympy.trigsimp(expr)
    return expr


def accelerations(equations: Equations) -> list[sympy.Symbol]:
    return [sympy.Symbol(q.name + "''", real=True) for q in equations.coordinates]


def multipliers(equations: Equations) -> list[sympy.Symbol]:
    return [sympy.Symbol(f"λ[{c.name}]", real=True) for c in equations.active_constraints]


def equation_rows(equations: Equations) -> list[tuple[str, sympy.Expr, sympy.Expr]]:
    """(label, lhs, rhs) per coordinate, M q'' = f + Aᵀλ, then A q'' = gamma per constraint."""
    calculus = equations.calculus()
    a = accelerations(equations)
    lam = multipliers(equations)
    active = equations.active_constraints
    rows = []
    for k, q in enumerate(equations.coordinates):
        lhs = sum((tidy(m, calculus) * a[j] for j, m in enumerate(equations.mass_matrix[k])), sympy.S.Zero)
        rhs = tidy(equations.forcing[k], calculus) + sum(
            (lam[i] * tidy(c.jacobian[k], calculus) for i, c in enumerate(active)), sympy.S.Zero)
        rows.append((q.name, lhs, rhs))
    for c in active:
        lhs = sum((tidy(x, calculus) * a[j] for j, x in enumerate(c.jacobian)), sympy.S.Zero)
        rows.append((c.name, lhs, tidy(c.gamma, calculus)))
    return rows


def format_equations(equations: Equations, latex: bool = False) -> str:
    """The report of `lagc eom`."""
    rows = equation_rows(equations)
    n = equations.size
    if latex:
        names = latex_names(equations)
        body = [rf"{_latex(lhs, names)} &= {_latex(rhs, names)} \\" for _, lhs, rhs in rows]
        return "\\begin{aligned}\n" + "\n".join(body) + "\n\\end{aligned}"
    lines = [f"equations of motion of {equations.model.name}"
             + (" (M q'' = f + A^T λ, then the constraint rows A q'' = γ)" if len(rows) > n else "")]
    width = max(len(label) for label, _, _ in rows) if rows else 0
    for k, (label, lhs, rhs) in enumerate(rows):
        kind = "" if k < n else " (constraint)"
        lines.append(f"  {label.ljust(width)}{kind}:  {_text(lhs)} = {_text(rhs)}")
    return "\n".join(visible(line) for line in lines)


def _text(expr: sympy.Expr) -> str:
    return sympy.sstr(expr).replace("**", "^")


def _latex(expr: sympy.Expr, names: dict) -> str:
    return sympy.latex(expr, symbol_names=names)


def latex_names(equations: Equations) -> dict[sympy.Symbol, str]:
    """theta1 -> \\theta_{1}, theta1' -> \\dot{\\theta}_{1}, theta[2]'' -> \\ddot{\\theta}_{2}."""
    names = {}
    for q, a in zip(equations.coordinates, accelerations(equations)):
        base = sympy.latex(sympy.Symbol(q.name.replace("[", "_").replace("]", "")))
        names[q] = base
        names[sympy.Symbol(q.name + "'", real=True)] = rf"\dot{{{base}}}"
        names[a] = rf"\ddot{{{base}}}"
    for lam in multipliers(equations):
        names[lam] = rf"\lambda_{{\mathrm{{{lam.name[2:-1]}}}}}".replace("_", r"\_").replace(r"\lambda\_", r"\lambda_")
    return names
