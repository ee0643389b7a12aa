"""Helpers for comparing derived equations with closed forms."""
from __future__ import annotations

import sympy

from lagdsl.mechanics import derive_equations
from lagdsl.frontend.parser import parse
from lagdsl.pipeline import load_model
from lagdsl.frontend.semantics import build_model
from lagdsl.source import SourceFile
from tests.conftest import MODELS


def equations_of(name: str):
    return derive_equations(load_model(MODELS / f"{name}.lag"))


def equations_from_text(text: str):
    source = SourceFile("test.lag", text)
    return derive_equations(build_model(parse(source), source))


def symbols_of(equations):
    """name -> symbol for coordinates, velocities ("x'"), accelerations ("x''") and parameters."""
    table = {p.name: p.symbol for p in equations.model.parameters}
    for c in equations.model.coordinates:
        table[c.name] = c.symbol
        table[c.name + "'"] = c.velocity_symbol
        table[c.name + "''"] = sympy.Symbol(c.name + "''", real=True)
    table["t"] = sympy.Symbol("t", real=True)
    return table


def residual_rows(equations):
    """Row k: sum_j M_kj q_j'' - f_k, with intermediates inlined (the Euler-Lagrange expression)."""
    calculus = equations.calculus()
    accelerations = [sympy.Symbol(q.name + "''", real=True) for q in equations.coordinates]
    return [calculus.inline(sum((m * a for m, a in zip(row, accelerations)), sympy.S.Zero) - f)
            for row, f in zip(equations.mass_matrix, equations.forcing)]


def is_zero(expr) -> bool:
    return sympy.simplify(sympy.expand_trig(expr)) == 0


def solve_accelerations(equations):
    """Accelerations and multipliers from the (small) augmented system, solved symbolically."""
    calculus = equations.calculus()
    n = equations.size
    active = equations.active_constraints
    m = len(active)
    big = sympy.zeros(n + m, n + m)
    rhs = sympy.zeros(n + m, 1)
    for k in range(n):
        for j in range(n):
            big[k, j] = calculus.inline(equations.mass_matrix[k][j])
        for i, c in enumerate(active):
            big[k, n + i] = -calculus.inline(c.jacobian[k])
        rhs[k] = calculus.inline(equations.forcing[k])
    for i, c in enumerate(active):
        for j in range(n):
            big[n + i, j] = calculus.inline(c.jacobian[j])
        rhs[n + i] = calculus.inline(c.gamma)
    solution = big.LUsolve(rhs)
    return [sympy.simplify(x) for x in solution]
