"""Human-readable output of `lagc check` and `lagc eom` (plain text and LaTeX).

Display is the one place where expressions are expanded: intermediates are inlined and small
results are tidied (tidying.py), so that a textbook system reads like the textbook
(m2*l1*l2*cos(theta1 - theta2), not a sum of products of sines and cosines). Each intermediate
is inlined and reduced once, in dependency order (`Display`), so a rotation matrix's entries,
reduced, make its angular velocity small, and that makes T small. An entry too large to write
out is shown in terms of the model's own names (its lets, der(x) of them, L), which are listed
after the equations (`where`), each after the ones it uses; the derivation's bookkeeping
(∂x/∂q, δ..., der̃) is never shown.
"""
from __future__ import annotations

import re
import sympy

from . import ir
from .frontend import units
from .integrators.registry import OPTIONS
from .calculus import Differentiator, tree_size
from .escape import visible
from .mechanics import Equations
from .mechanics.families import expanded
from .tidying import reduced, written
from .typeset import typeset

SHOW_LIMIT = 400          # tree nodes of a row's entry, tidied; larger ones are shown through named intermediates
INLINE_LIMIT = 40         # tree nodes of a tidied definition that is written out where it is used
TIDY_LIMIT = 20000        # tree nodes of an expression tidied (tidying bounds the terms of its expansion too)


def format_number(value: float) -> str:
    return f"{value:.12g}"


def describe_model(model: ir.Model, equations: Equations) -> str:
    """The report of `lagc check`."""
    title = f'model {model.name}' + (f' "{model.description}"' if model.description else "")
    lines = [f"{title}  ({model.source_name})", f"degrees of freedom: {degrees_of_freedom(equations)}"]
    for c in model.coordinates:
        lines.append(f"  {c.name}{shown_unit(model, c.name)}" + (f"  {c.description}" if c.description else ""))
    if model.parameters:
        lines.append("parameters: " + ", ".join(shown_parameter(model, p) for p in model.parameters))
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
        options = ", ".join([f"{k} = {OPTIONS[k].word(v) if OPTIONS[k].choices else format_number(v)}"
                             for k, v in s.integrator.options]
                            + [f"atol({k}) = {format_number(v)}" for k, v in s.integrator.atol_each])
        lines.append(f"  {s.name}" + (f' "{s.description}"' if s.description else "")
                     + f": t = {format_number(s.time.start)} .. {format_number(s.time.stop)}"
                     f" every {format_number(s.time.interval)}, {s.integrator.name}({options}); "
                     f"outputs: {', '.join(o.column for o in s.outputs) or 'the coordinates'}"
                     + (f"; stop when {s.stop.text}" if s.stop else ""))
    return "\n".join(visible(line) for line in lines)      # descriptions and units are free text


def shown_unit(model: ir.Model, name: str) -> str:
    """` [N/m] (= kg/s^2)`: the unit as declared, with the SI unit it is computed in beside it where
    that reads differently (` [cm] (= 0.01 m)` where it is a multiple); ` [kg*m/s^2, inferred]` when
    the dimensional analysis found it, `[?]` when it could not; without units, the unit as written."""
    declared = declared_unit(model, name)
    if model.units is None or declared is not None:
        return f" [{declared.text}]{_si_beside(declared)}" if declared else ""
    unit, inferred = next((u, i) for q, u, i in model.units.quantities if q == name)
    return f" [{unit}{', inferred' if inferred and unit != '?' else ''}]"


def shown_parameter(model: ir.Model, parameter: ir.Parameter) -> str:
    """`k = 40 [N/m] (= kg/s^2)`, `m = 50 [g] (= 0.05 kg)`: the value in the declared unit."""
    unit = parameter.unit
    if unit is None or model.units is None:
        return f"{parameter.name} = {format_number(parameter.value)}{shown_unit(model, parameter.name)}"
    factor = float(units.si_factor(unit))
    si = f" (= {format_number(parameter.value)} {units.si_text(unit)})" if factor != 1 else _si_beside(unit)
    return f"{parameter.name} = {format_number(parameter.value / factor)} [{unit.text}]{si}"


def invariant_unit(model: ir.Model, name: str) -> str:
    """The SI unit of a conserved quantity: the energy's, `J`, or an energy times a time over q's
    for `momentum(q)`; "?" where the model has no units or q's unit was inferred, not declared."""
    if model.units is None:
        return "?"
    action = units.unit_dimension("J") * units.unit_dimension("s")
    if name == "energy":
        return "J"
    coordinate = declared_unit(model, name[len("momentum("):-1])
    return (action / units.dimension(coordinate)).si() if coordinate is not None else "?"


def declared_unit(model: ir.Model, name: str) -> ir.Unit | None:
    """The unit written on a parameter, coordinate (any member of a family) or output, or None."""
    return next((q.unit for q in (*model.parameters, *model.coordinates, *model.outputs) if q.name == name), None)


def _si_beside(unit: ir.Unit) -> str:
    """` (= 0.01 m)` for a multiple of the SI unit, ` (= kg/s^2)` for a product written otherwise,
    ` (= 0.01)` for a multiple of a pure number (`%`)."""
    factor, si = float(units.si_factor(unit)), units.si_text(unit)
    if factor != 1:
        return f" (= {format_number(factor)}{'' if si == '1' else ' ' + si})"
    return f" (= {si})" if si != unit.text else ""


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


class Display:
    """What `lagc eom` writes for each intermediate of `calculus`, computed once, in dependency order.

    `full` maps every intermediate to its definition with all intermediates inlined and reduced
    (multiplied out, sin² + cos² = 1): an entry of a row that is small so is shown so. `partial`
    keeps the model's own names (its lets, their der(...), L) for definitions that are not small
    once reduced; `named` holds those definitions, for the `where` list. The derivation's own
    intermediates (partial derivatives, derivatives with the der(x) held fixed) are always
    inlined: their names are its bookkeeping.
    """

    def __init__(self, calculus: Differentiator):
        self.full: dict[sympy.Symbol, sympy.Expr | None] = {}
        self.sizes: dict[sympy.Symbol, int] = {}
        self.partial: dict[sympy.Symbol, sympy.Expr] = {}
        self.named: dict[sympy.Symbol, sympy.Expr] = {}
        self.state = frozenset(calculus.base)
        for symbol, definition in calculus.definitions():
            uses = [s for s in definition.free_symbols if s in self.full]
            self.full[symbol] = self._inlined(symbol, definition, uses)
            if all(self.partial[s] is self.full[s] for s in uses):
                value = self.full[symbol]
            else:
                value = _reduced(definition.xreplace({s: self.partial[s] for s in uses}))
            if _bookkeeping(symbol) or tree_size(value, INLINE_LIMIT) <= INLINE_LIMIT:
                self.partial[symbol] = value
            else:
                self.partial[symbol] = symbol
                self.named[symbol] = value

    def _inlined(self, symbol: sympy.Symbol, definition: sympy.Expr, uses) -> sympy.Expr | None:
        """The definition with every intermediate inlined, reduced; None when it would exceed
        TIDY_LIMIT nodes, sized before it is built (lets that each use the one before twice double
        at every link, and sympy's constructors walk what they are given)."""
        if tree_size(definition, TIDY_LIMIT, self.sizes) > TIDY_LIMIT:
            self.sizes[symbol] = TIDY_LIMIT + 1
            return None
        inlined = _reduced(definition.xreplace({s: self.full[s] for s in uses}))
        self.sizes[symbol] = tree_size(inlined, TIDY_LIMIT)
        return inlined

    def show(self, expr: sympy.Expr) -> sympy.Expr:
        """`expr` fully inlined and tidied when that is small, else through the named intermediates."""
        uses = [s for s in expr.free_symbols if s in self.full]
        if tree_size(expr, TIDY_LIMIT, self.sizes) <= TIDY_LIMIT:      # else too large to build
            inlined = _reduced(expr.xreplace({s: self.full[s] for s in uses}))
            if tree_size(inlined, SHOW_LIMIT) <= SHOW_LIMIT:
                return written(inlined, self.state)
        return written(_reduced(expr.xreplace({s: self.partial[s] for s in uses})), self.state)

    def where(self, exprs) -> list[tuple[sympy.Symbol, sympy.Expr]]:
        """The named intermediates that `exprs` use, directly or through others, each after the
        ones it uses."""
        named = Differentiator(self.named.items(), self.state)
        return [(s, written(e, self.state)) for s, e in named.needed(exprs)]


def _reduced(expr: sympy.Expr) -> sympy.Expr:
    return reduced(expr) if tree_size(expr, TIDY_LIMIT) <= TIDY_LIMIT else expr


# The names calculus.Differentiator and mechanics.equations give the intermediates they create:
# ∂x/∂q, δx/δq (a partial derivative with the der(...) held fixed), der̃(x) (a time derivative
# with them held). A model's own names are ASCII identifiers, so these marks set them apart.
_BOOKKEEPING = re.compile("[∂δ]|der̃")


def _bookkeeping(symbol: sympy.Symbol) -> bool:
    return _BOOKKEEPING.search(symbol.name) is not None


def accelerations(equations: Equations) -> list[sympy.Symbol]:
    return [sympy.Symbol(q.name + "''", real=True) for q in equations.coordinates]


def multipliers(equations: Equations) -> list[sympy.Symbol]:
    return [ir.multiplier_symbol(c.name) for c in equations.active_constraints]


def equation_rows(equations: Equations, display: Display) -> list[tuple[str, sympy.Expr, sympy.Expr]]:
    """(label, lhs, rhs) per coordinate, M q'' = f + Aᵀλ, then A q'' = gamma per constraint."""
    a = accelerations(equations)
    lam = multipliers(equations)
    active = equations.active_constraints
    tidied: dict[sympy.Expr, sympy.Expr] = {}

    def show(expr: sympy.Expr) -> sympy.Expr:       # M is symmetric: each entry tidied once
        if expr not in tidied:
            tidied[expr] = display.show(expr)
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
    """The report of `lagc eom`: the equations, then the intermediates they are shown with
    (always of the expanded equations, whichever form the run uses)."""
    equations = expanded(equations)
    display = Display(equations.calculus())
    rows = equation_rows(equations, display)
    where = display.where(side for _, lhs, rhs in rows for side in (lhs, rhs))
    n = equations.size
    if latex:
        return typeset(rows, where)
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
