"""The derivatives by the inputs and of the outputs: B, C and D of the linear model.

The generated Jacobians differentiate by the state only. The inputs u (parameters named as
inputs) and the outputs y = h(q, q', t, u) are few, so their derivatives are taken here from the
symbolic equations, by the chain rule through the shared intermediates (calculus.Differentiator,
with u among the independent symbols), and evaluated at the point in 50-digit arithmetic
(mechanics/probe.evaluate_at):

    B_q = ∂R/∂u = ∂f/∂u - (∂M/∂u) q''* + (∂A/∂u)ᵀ λ*      (R = f - M q'' + Aᵀλ at the point)
    C_q = ∂h/∂q,  C_v = ∂h/∂q',  D = ∂h/∂u.

So are the derivatives ∂c/∂q of the constraints' velocity residuals c = A q' + b, which the
tangent space of a moving or nonholonomic constraint needs (linear/constraints.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy

from .. import ir
from ..calculus import Differentiator
from ..errors import LagError, Setting, suggest
from ..mechanics.families import expanded
from ..mechanics.probe import evaluate_at, to_float


@dataclass(frozen=True)
class InputOutput:
    """The full-coordinate derivatives at the point (before constraints are eliminated)."""

    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    Bq: np.ndarray          # n x inputs
    Cq: np.ndarray          # outputs x n
    Cv: np.ndarray          # outputs x n
    D: np.ndarray           # outputs x inputs
    values: np.ndarray      # the outputs at the point


def input_output(model, plan, input_indices, output_names, state, acc, lam) -> InputOutput:
    """B_q, C_q, C_v and D of the module docstring for `model` (an api.Model) at `state` with
    the scene plan's parameters, q''* = `acc` and λ* = `lam`."""
    if not input_indices and outputs_given(output_names) == 0:      # `lagc modes`: no symbolic work
        n = len(model.ir.coordinates)
        return InputOutput((), (), np.zeros((n, 0)), np.zeros((0, n)), np.zeros((0, n)), np.zeros((0, 0)),
                           np.zeros(0))
    equations = expanded(model.equations)
    parameters = [model.ir.parameters[i] for i in input_indices]
    inputs = [p.symbol for p in parameters]
    calculus = Differentiator(equations.intermediates,
                              (*equations.coordinates, *equations.velocities, ir.TIME, *inputs))
    _refuse_inputs_in_constraints(equations, calculus, parameters)
    outputs = resolve_outputs(model, plan, equations, output_names)
    n = equations.size
    residuals = _residuals(equations, acc, lam) if inputs else []
    variables = (*equations.coordinates, *equations.velocities, *inputs)
    derivatives = [[_partial(calculus, r, u) for u in inputs] for r in residuals]
    derivatives += [[_partial(calculus, h, x) for x in variables] for _, h in outputs]
    flat = [e for row in derivatives for e in row] + [h for _, h in outputs]
    values = _evaluate(calculus, flat, model.ir, equations, plan, state)
    p, r = len(inputs), len(outputs)
    Bq = values[:n * p].reshape(n, p)
    rows = values[n * p:n * p + r * (2 * n + p)].reshape(r, 2 * n + p)
    return InputOutput(tuple(p.name for p in parameters), tuple(name for name, _ in outputs), Bq,
                       rows[:, :n], rows[:, n:2 * n], rows[:, 2 * n:], values[n * p + r * (2 * n + p):])


def rate_jacobian(model, plan, state) -> np.ndarray:
    """∂c/∂q of the active constraints (holonomic rows first, as the kernel orders them) at `state`."""
    equations = expanded(model.equations)
    calculus = equations.calculus()
    exprs = rate_jacobian_entries(equations, calculus)
    return _evaluate(calculus, exprs, model.ir, equations, plan, state).reshape(-1, equations.size)


def rate_jacobian_entries(equations, calculus: Differentiator) -> list[sympy.Expr]:
    """The entries of ∂c/∂q, c = A q' + b the velocity residuals of the active constraints in the
    kernel's order (holonomic rows first), row by row (the expanded `equations`)."""
    active = sorted(equations.active_constraints, key=lambda c: c.kind != "holonomic")
    return [_partial(calculus, c.velocity_residual, q) for c in active for q in equations.coordinates]


def constraint_parameter_jacobian(model, plan, state) -> tuple[np.ndarray, np.ndarray]:
    """∂g/∂p of the holonomic rows and ∂c/∂p of every active row (kernel order) at `state`, for
    every parameter of the model (sensitivity/variational.py)."""
    equations = expanded(model.equations)
    symbols = [p.symbol for p in model.ir.parameters]
    calculus = Differentiator(equations.intermediates,
                              (*equations.coordinates, *equations.velocities, ir.TIME, *symbols))
    active = sorted(equations.active_constraints, key=lambda c: c.kind != "holonomic")
    rows = [c.residual for c in active if c.kind == "holonomic"] + [c.velocity_residual for c in active]
    exprs = [_partial(calculus, row, p) for row in rows for p in symbols]
    values = _evaluate(calculus, exprs, model.ir, equations, plan, state).reshape(len(rows), len(symbols))
    holonomic = len(rows) - len(active)
    return values[:holonomic], values[holonomic:]


def outputs_given(names) -> int | None:
    """How many outputs were named; None: the scene's columns, the default."""
    return None if names is None else len(names)


def _partial(calculus: Differentiator, expr: sympy.Expr, variable: sympy.Symbol) -> sympy.Expr:
    return calculus.partial(expr, variable) if variable in calculus.dependencies(expr) else sympy.S.Zero


def _residuals(equations, acc, lam) -> list[sympy.Expr]:
    """R_k = f_k - Σ_j M_kj q''*_j + Σ_i λ*_i A_ik with the numbers of the point."""
    active = sorted(equations.active_constraints, key=lambda c: c.kind != "holonomic")
    rows = []
    for k in range(equations.size):
        r = equations.forcing[k] - sum((entry * sympy.Float(a) for entry, a in zip(equations.mass_matrix[k], acc)
                                        if entry != 0 and a != 0), sympy.S.Zero)
        r += sum((sympy.Float(multiplier) * c.jacobian[k] for multiplier, c in zip(lam, active)), sympy.S.Zero)
        rows.append(r)
    return rows


def _evaluate(calculus, exprs, model: ir.Model, equations, plan, state) -> np.ndarray:
    """Values of `exprs` at the state, the plan's parameters and its start time."""
    symbols = (*equations.coordinates, *equations.velocities, ir.TIME, *(p.symbol for p in model.parameters))
    point = (*state, plan.time.start, *plan.parameters)
    pending = [i for i, e in enumerate(exprs) if e != 0]
    values = np.zeros(len(exprs))
    if pending:
        values[pending] = [to_float(x) for x in evaluate_at(calculus, [exprs[i] for i in pending], symbols,
                                                            [point])[0]]
    return values


def _refuse_inputs_in_constraints(equations, calculus, parameters) -> None:
    """An input in a constraint would move the constraint surface itself: not a force."""
    for c in equations.active_constraints:
        for p in parameters:
            if p.symbol in calculus.dependencies(c.residual) | calculus.dependencies(c.velocity_residual):
                raise LagError(f"input '{p.name}' appears in constraint '{c.name}': an input must act as a "
                               "force or a parameter of the energies, not move a constraint", c.span)


def resolve_outputs(model, plan, equations, names) -> list[tuple[str, sympy.Expr]]:
    """(name, expression) of each output: the names given (a scene column, a model `output`, a
    coordinate, `energy`, `momentum(q)`), or else the scene's columns."""
    requests = {r.column: r for r in plan.outputs}
    declared = {o.name: o.expression for o in model.ir.outputs}
    coordinates = {c.name: k for k, c in enumerate(model.ir.coordinates)}
    if names is None:       # the scene's columns that are functions of the state
        names = [name for name, r in requests.items() if r.kind != "multiplier" and not (
            r.kind == "expression" and _multipliers(equations) & r.expression.free_symbols)]
    chosen = []
    for name in names:
        if name in requests:
            chosen.append((name, _request_expression(requests[name], equations, coordinates)))
        elif name in declared:
            chosen.append((name, _state_only(name, declared[name], None, equations)))
        elif name in coordinates:
            chosen.append((name, equations.coordinates[coordinates[name]]))
        elif name == "energy":
            chosen.append((name, equations.energy))
        elif name.startswith("momentum(") and name.endswith(")") and name[9:-1] in coordinates:
            chosen.append((name, equations.momenta[coordinates[name[9:-1]]]))
        else:
            known = [*requests, *declared, *coordinates, "energy"]
            raise LagError(f"no output '{name}' in model {model.ir.name}{suggest(name, known)} (outputs: a scene "
                           "column, a declared output, a coordinate, energy or momentum(q))", Setting("--output"))
    return chosen


def _request_expression(request: ir.OutputRequest, equations, coordinates) -> sympy.Expr:
    if request.kind == "expression":
        return _state_only(request.column, request.expression, request.span, equations)
    if request.kind == "energy":
        return equations.energy
    if request.kind == "momentum":
        return equations.momenta[coordinates[request.target]]
    if request.kind == "residual":
        return next(c.residual for c in equations.constraints if c.name == request.target)
    raise LagError(f"output '{request.column}' is a constraint multiplier, which the linear model does not "
                   "give (its outputs are functions of the state and the inputs); name others with --output",
                   request.span or Setting("--output"))


def _multipliers(equations) -> set[sympy.Symbol]:
    return {ir.multiplier_symbol(c.name) for c in equations.constraints}


def _state_only(name: str, expression: sympy.Expr, span, equations) -> sympy.Expr:
    if expression.free_symbols & _multipliers(equations):
        raise LagError(f"output '{name}' reads a constraint multiplier, which the linear model does not give "
                       "(its outputs are functions of the state and the inputs)", span or Setting("--output"))
    return expression
