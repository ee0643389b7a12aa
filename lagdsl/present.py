"""Human-readable output of `lagc check` and `lagc eom` (plain text and LaTeX).

Display is the one place where expressions are expanded: intermediates are inlined and small
results are tidied, so that a textbook system reads like the textbook (m2*l1*l2*cos(theta1 -
theta2), not a sum of products of sines and cosines). The tidying is a fixed sequence of cheap
rewrites (expand, sin² + cos² = 1, the sum and difference formulas read backwards, common
factors pulled out), not trigsimp: trigsimp factors polynomials, which costs seconds per
expression on a 12-link chain. An expression too large to inline readably is shown as derived,
in terms of its named intermediates, which are listed after the equations (`where`), each after
the ones it uses, as the generated code computes them.
"""
from __future__ import annotations

import re
from collections import Counter

import sympy
from sympy.simplify.fu import TR10i

from . import ir
from .calculus import Differentiator
from .escape import visible
from .mechanics import Equations

TIDY_LIMIT = 400          # tree nodes once inlined; larger expressions are shown as derived
EXPANSION_LIMIT = 2000    # terms of the expanded form; more and an expression is shown untidied
NUMBER_LIMIT = 10**100    # numerators and denominators of the numbers tidied (physical constants fit)
EXPONENT_LIMIT = 100      # numerators and denominators of the numeric exponents tidied


def format_number(value: float) -> str:
    return f"{value:.12g}"


def describe_model(model: ir.Model, equations: Equations) -> str:
    """The report of `lagc check`."""
    title = f'model {model.name}' + (f' "{model.description}"' if model.description else "")
    lines = [f"{title}  ({model.source_name})", f"degrees of freedom: {degrees_of_freedom(equations)}"]
    for c in model.coordinates:
        lines.append(f"  {c.name}{shown_unit(model, c.name)}" + (f"  {c.description}" if c.description else ""))
    if model.parameters:
        lines.append("parameters: " + ", ".join(
            f"{p.name} = {format_number(p.value)}{shown_unit(model, p.name)}" for p in model.parameters))
    if model.outputs:
        lines.append("outputs: " + ", ".join(f"{o.name}{shown_unit(model, o.name)}" for o in model.outputs))
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
    if not equations.active_constraints and not equations.velocity_in_accelerations:
        lines.append("accelerations: independent of the velocities, q'' = a(t, q): the Nystrom integrator rkn8 applies")
    lines.append("scenes:" + ("" if model.scenes else " none (lagc run uses the default set-up)"))
    for s in model.scenes:
        options = ", ".join(f"{k} = {format_number(v)}" for k, v in s.integrator.options)
        lines.append(f"  {s.name}" + (f' "{s.description}"' if s.description else "")
                     + f": t = {format_number(s.time.start)} .. {format_number(s.time.stop)}"
                     f" every {format_number(s.time.interval)}, {s.integrator.name}({options}); "
                     f"outputs: {', '.join(o.column for o in s.outputs) or 'the coordinates'}"
                     + (f"; stop when {s.stop.text}" if s.stop else ""))
    return "\n".join(visible(line) for line in lines)      # descriptions and units are free text


def shown_unit(model: ir.Model, name: str) -> str:
    """` [kg*m/s^2]`: the unit a quantity is computed in (SI; an output's own), `, inferred` when
    the dimensional analysis found it, `[?]` when it could not; without units, the unit as written."""
    if model.units is None:
        unit = next((q.unit for q in (*model.parameters, *model.coordinates, *model.outputs)
                     if q.name == name), None)
        return f" [{unit.text}]" if unit else ""
    unit, inferred = next((u, i) for q, u, i in model.units.quantities if q == name)
    return f" [{unit}{', inferred' if inferred and unit != '?' else ''}]"


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


def shown(expr: sympy.Expr, calculus: Differentiator) -> sympy.Expr:
    """`expr` inlined and tidied when that is small, else as derived (through intermediates)."""
    if calculus.inlined_size(expr, TIDY_LIMIT) > TIDY_LIMIT:
        return expr
    return tidy(calculus.inline(expr))


def tidy(expr: sympy.Expr) -> sympy.Expr:
    """Cheap trigonometric tidying: every step is polynomial in the size of the expanded form.

    expand → sin(x)² + cos(x)² = 1 → cos a cos b + sin a sin b = cos(a - b) and its kin (fu's
    TR10i) → common factors out. Skipped when expanding would multiply out too many terms, and
    for numbers out of the ordinary (1e-320 or x^(4e9) read exactly), which sympy's expansion and
    factoring would spend minutes or all memory on.
    """
    if not ordinary_numbers(expr) or expanded_terms(expr) > EXPANSION_LIMIT:
        return expr
    return sympy.factor_terms(TR10i(pythagoras(sympy.expand(expr))))


def ordinary_numbers(expr: sympy.Expr) -> bool:
    """Every rational in `expr` has a numerator and denominator below NUMBER_LIMIT, every numeric
    exponent below EXPONENT_LIMIT (model numbers are exact rationals: 1e-320 is 1/10^320)."""
    for number in expr.atoms(sympy.Rational):
        if abs(number.p) >= NUMBER_LIMIT or number.q >= NUMBER_LIMIT:
            return False
    for power in expr.atoms(sympy.Pow):
        if power.exp.is_Rational and (abs(power.exp.p) > EXPONENT_LIMIT or power.exp.q > EXPONENT_LIMIT):
            return False
    return True


def expanded_terms(expr: sympy.Expr) -> int:
    """An upper bound on the number of terms of sympy.expand(expr) (at its top level), counted up
    to just past EXPANSION_LIMIT (the count of (a + b)^(10^9) is not worth computing)."""
    if expr.is_Add:
        count = sum(expanded_terms(a) for a in expr.args)
    elif expr.is_Mul:
        count = 1
        for factor in expr.args:
            count = min(count * expanded_terms(factor), EXPANSION_LIMIT + 1)
    elif expr.is_Pow and expr.exp.is_Integer:     # expand multiplies out 1/(a + b)^n too
        base, count = expanded_terms(expr.base), 1
        for _ in range(min(abs(int(expr.exp)), EXPANSION_LIMIT + 1) if base > 1 else 0):
            count = min(count * base, EXPANSION_LIMIT + 1)
    else:
        count = 1
    return min(count, EXPANSION_LIMIT + 1)


def pythagoras(expr: sympy.Expr) -> sympy.Expr:
    """In an expanded sum, each pair c·sin(x)² + c·cos(x)² replaced by c."""
    terms = Counter(sympy.Add.make_args(expr))
    for term in list(terms):
        for factor in sympy.Mul.make_args(term):
            if factor.is_Pow and factor.exp == 2 and isinstance(factor.base, sympy.sin):
                rest = term / factor
                partner = rest * sympy.cos(factor.base.args[0]) ** 2
                pairs = min(terms[term], terms[partner])
                terms[term] -= pairs
                terms[partner] -= pairs
                terms[rest] += pairs
    return sympy.Add(*(term * count for term, count in terms.items() if count))


def accelerations(equations: Equations) -> list[sympy.Symbol]:
    return [sympy.Symbol(q.name + "''", real=True) for q in equations.coordinates]


def multipliers(equations: Equations) -> list[sympy.Symbol]:
    return [ir.multiplier_symbol(c.name) for c in equations.active_constraints]


def equation_rows(equations: Equations, calculus: Differentiator) -> list[tuple[str, sympy.Expr, sympy.Expr]]:
    """(label, lhs, rhs) per coordinate, M q'' = f + Aᵀλ, then A q'' = gamma per constraint."""
    a = accelerations(equations)
    lam = multipliers(equations)
    active = equations.active_constraints
    tidied: dict[sympy.Expr, sympy.Expr] = {}

    def show(expr: sympy.Expr) -> sympy.Expr:       # M is symmetric: each entry tidied once
        if expr not in tidied:
            tidied[expr] = shown(expr, calculus)
        return tidied[expr]

    rows = []
    for k, q in enumerate(equations.coordinates):
        lhs = sympy.Add(*(show(m) * a[j] for j, m in enumerate(equations.mass_matrix[k])))
        rhs = sympy.Add(show(equations.forcing[k]), *(lam[i] * show(c.jacobian[k]) for i, c in enumerate(active)))
        rows.append((q.name, lhs, rhs))
    for c in active:
        lhs = sympy.Add(*(show(x) * a[j] for j, x in enumerate(c.jacobian)))
        rows.append((c.name, lhs, show(c.gamma)))
    return rows


def format_equations(equations: Equations, latex: bool = False) -> str:
    """The report of `lagc eom`: the equations, then the intermediates they are shown with."""
    calculus = equations.calculus()
    rows = equation_rows(equations, calculus)
    where = calculus.needed(side for _, lhs, rhs in rows for side in (lhs, rhs))
    n = equations.size
    if latex:
        names = latex_names(equations, (s for s, _ in where))
        body = [rf"{_latex(lhs, names)} &= {_latex(rhs, names)} \\" for _, lhs, rhs in rows]
        if where:
            body.append(r"&\text{where} \\")
            body.extend(rf"{names[s]} &= {_latex(e, names)} \\" for s, e in where)
        return "\\begin{aligned}\n" + "\n".join(body) + "\n\\end{aligned}"
    lines = [f"equations of motion of {equations.model.name}"
             + (" (M q'' = f + A^T λ, then the constraint rows A q'' = γ)" if len(rows) > n else "")]
    width = max(len(label) for label, _, _ in rows) if rows else 0
    for k, (label, lhs, rhs) in enumerate(rows):
        kind = "" if k < n else " (constraint)"
        lines.append(f"  {label.ljust(width)}{kind}:  {_text(lhs)} = {_text(rhs)}")
    if where:
        lines.append("where")
        lines.extend(f"  {symbol} = {_text(e)}" for symbol, e in where)
    return "\n".join(visible(line) for line in lines)


def _text(expr: sympy.Expr) -> str:
    return sympy.sstr(expr).replace("**", "^")


def _latex(expr: sympy.Expr, names: dict) -> str:
    return sympy.latex(expr, symbol_names=names)


def latex_names(equations: Equations, intermediates=()) -> dict[sympy.Symbol, str]:
    """theta1 -> \\theta_{1}, theta1' -> \\dot{\\theta}_{1}, theta[2]'' -> \\ddot{\\theta}_{2};
    an intermediate der(x[2]) -> \\operatorname{der}(x_{2}), δL/δtheta[1] -> \\delta L/\\delta \\theta_{1}."""
    names = {}
    for q, a in zip(equations.coordinates, accelerations(equations)):
        base = _latex_identifier(q.name)
        names[q] = base
        names[sympy.Symbol(q.name + "'", real=True)] = rf"\dot{{{base}}}"
        names[a] = rf"\ddot{{{base}}}"
    for lam in multipliers(equations):
        names[lam] = rf"\lambda_{{\mathrm{{{lam.name[2:-1]}}}}}".replace("_", r"\_").replace(r"\lambda\_", r"\lambda_")
    for symbol in intermediates:
        names[symbol] = _LATEX_NAME_PART.sub(_latex_name_part, symbol.name)
    return names


_LATEX_NAME_PART = re.compile(r"der\(|[δ∂]|[A-Za-z_][A-Za-z0-9_]*(?:\[[0-9, ]*\])?")
_LATEX_MARKS = {"der(": r"\operatorname{der}(", "δ": r"\delta ", "∂": r"\partial "}


def _latex_name_part(match: re.Match) -> str:
    part = match.group()
    return _LATEX_MARKS.get(part) or _latex_identifier(part)


def _latex_identifier(name: str) -> str:
    """x -> x, theta[2] -> \\theta_{2}, theta1 -> \\theta_{1} (sympy's reading of a trailing number)."""
    return sympy.latex(sympy.Symbol(name.replace("[", "_").replace("]", "")))
