"""Model -> LocalEquations: the equations of a large model made of many small terms of few
shapes (chains, lattices, discretised strings and beams), derived once per shape.

A model written with indexed families, say T = Σ_i m/2 q'_i², U = Σ_i k/2 (q_{i+1} - q_i)², is a
sum of *local* terms, each touching a few coordinates. Write a term as g(x, v, t) of its own
slots, x_a = q_{k_a} and v_a = q'_{k_a}; its *members* are the translates of one shape: member
m touches q_{first + step·m + offset_a} in slot a. The Euler-Lagrange operator is linear in L, so

    M_kl = Σ ∂²g/∂v_a∂v_b                                   over the members with k_a = k, k_b = l
    f_k  = Σ [∂g/∂x_a - Σ_b ∂²g/∂v_a∂x_b v_b - ∂²g/∂v_a∂t]  over the members with k_a = k
           - Σ ∂d/∂v_a (terms d of the Rayleigh function) + the forces on q_k
    h    = Σ [Σ_a v_a ∂g/∂v_a - g]                           (the energy function)

and each derivative is taken once per shape, not once per member: the generated code loops over
the members (codegen/kernel.py, Loop). This is the scatter form of finite-element assembly.

The terms are found in the expanded expressions the front end built: T, U (or L) and D are
split into their additive terms (constant factors distributed), and two terms have the same
shape when they are equal after their coordinates are renumbered from their lowest index (and
the members of parameter arrays from theirs). Members of one shape form a Stencil wherever their
indices advance in equal steps.

The local form is used when it pays and is safe: a natural system (T and U) without
constraints, at least FAMILY_MIN_COORDINATES coordinates, every term touching at most
LOCAL_WIDTH coordinates, most terms in stencils of at least MIN_MEMBERS members, a diagonal or
banded mass matrix (half-bandwidth at most MAX_BANDWIDTH in the declared order), a mass entry
on every diagonal position, and no cyclic coordinate (its conserved momentum would need the
expanded equations). Otherwise, and for everything the local form does not provide (`lagc eom`,
implicit and symplectic integrators, momenta), the expanded Equations of derive_equations are
used: LocalEquations derives them on first use.
"""
from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import sympy

from .. import ir
from ..calculus import Differentiator
from .equations import ENERGY_CONSERVED, ConservedQuantity

FAMILY_MIN_COORDINATES = 16     # smaller models are unrolled: their code is small anyway
LOCAL_WIDTH = 8                 # most coordinates one term may touch
MIN_MEMBERS = 4                 # a shape with fewer members is written out, not looped
MAX_BANDWIDTH = 8               # widest half-bandwidth of M the banded factorisation takes
ENERGY = sympy.Symbol("§h", real=True)      # the energy function, as the stencils' loops compute it (no user can write §)

POSITION, VELOCITY, PARAMETER = "§x", "§v", "§p"     # slot names no user can write


def slot(kind: str, index: int) -> sympy.Symbol:
    return sympy.Symbol(f"{kind}{index}", real=True)


@dataclass(frozen=True)
class Stencil:
    """`count` members of one local term: member m (0-based) puts slot a on coordinate
    first + step·m + offsets[a] and parameter slot b on parameter
    parameter_first + parameter_step·m + parameter_offsets[b] (0-based indices into the model's
    coordinates and parameters).

    `mass` holds the nonzero ∂²g/∂v_a∂v_b as (a, b, entry) with offsets[a] >= offsets[b];
    `forcing` the contribution to f of each slot; `energy` the contribution to h (zero for the
    terms of D and the forces). All are expressions in the slot symbols §x<a>, §v<a>, §p<b>, the
    scalar parameters and t. `kind` is "lagrangian", "dissipation" or "force"; `moving` lists the
    slots whose coordinate (a term of L) or velocity (a term of D) the term depends on, and a
    force's slot.
    """

    kind: str
    moving: tuple[int, ...]
    count: int
    first: int
    step: int
    offsets: tuple[int, ...]
    parameter_first: int
    parameter_step: int
    parameter_offsets: tuple[int, ...]
    mass: tuple[tuple[int, int, sympy.Expr], ...]
    forcing: tuple[sympy.Expr, ...]
    energy: sympy.Expr

    def coordinate(self, member: int, slot_index: int) -> int:
        return self.first + self.step * member + self.offsets[slot_index]


@dataclass(frozen=True)
class _Shape:
    """One additive term in slot symbols: which of L, D or a force it belongs to."""

    kind: str                   # "lagrangian", "dissipation" or "force"
    expression: sympy.Expr
    offsets: tuple[int, ...]
    parameter_offsets: tuple[int, ...]
    target: int | None = None   # a force's slot


class LocalEquations:
    """The local form of a model's equations (see the module docstring).

    It answers what planning a scene needs (constraints, conserved quantities, size) itself;
    every other attribute of Equations is taken from the expanded equations, derived on first
    use (derive_equations).
    """

    constraints: tuple = ()
    active_constraints: tuple = ()

    def __init__(self, model: ir.Model, stencils: tuple[Stencil, ...], bandwidth: int, energy_conserved: bool):
        self.model = model
        self.stencils = stencils
        self.bandwidth = bandwidth                  # 0: M is diagonal
        self.coordinates = tuple(c.symbol for c in model.coordinates)
        self.velocities = tuple(c.velocity_symbol for c in model.coordinates)
        self.energy = ENERGY           # computed by the loops (codegen/loops.py)
        self.conserved = (ConservedQuantity("energy", ENERGY, ENERGY_CONSERVED),
                          ) if energy_conserved else ()

    @property
    def size(self) -> int:
        return len(self.coordinates)

    @cached_property
    def velocity_in_accelerations(self) -> str:
        """The first velocity, as der(q) of its first member, that a stencil's M or f reads ("" if
        none: q'' = a(t, q))."""
        for stencil in self.stencils:
            for expression in (*stencil.forcing, *(entry for _, _, entry in stencil.mass)):
                offsets = sorted(int(s.name[len(VELOCITY):]) for s in expression.free_symbols
                                 if s.name.startswith(VELOCITY))
                if offsets:
                    return f"der({self.model.coordinates[stencil.first + offsets[0]].name})"
        return ""

    def calculus(self) -> Differentiator:
        """A differentiator over the model's lets (the outputs and the stop condition use them)."""
        return Differentiator(self.model.written_out_lets(), (*self.coordinates, *self.velocities, ir.TIME))

    @cached_property
    def expanded(self):
        from . import derive_equations
        return derive_equations(self.model)

    def __getattr__(self, name: str):
        if name.startswith("__") or name == "expanded":
            raise AttributeError(name)
        return getattr(self.expanded, name)


def expanded(equations):
    """The expanded Equations, whichever form `equations` is in (`lagc eom` prints every one)."""
    return equations.expanded if isinstance(equations, LocalEquations) else equations


def derive_local_equations(model: ir.Model) -> LocalEquations | None:
    """The local form of `model`'s equations, or None where it does not apply (module docstring)."""
    n = len(model.coordinates)
    if n < FAMILY_MIN_COORDINATES or model.constraints or not model.lagrangian.is_natural:
        return None
    terms = _Terms(model)
    shapes = terms.shapes()
    if shapes is None:
        return None
    stencils, looped = [], 0
    for shape, members in shapes.items():
        derived = _derive(shape)                    # once per shape, for all its members
        for run in _runs(members):
            stencils.append(_stencil(shape, run, *derived))
            looped += len(run) if len(run) >= MIN_MEMBERS else 0
    total = sum(len(members) for members in shapes.values())
    if 2 * looped < total:
        return None
    bandwidth = _bandwidth(stencils)
    if bandwidth is None or not _every_diagonal_filled(stencils, n) or _has_cyclic(stencils, n):
        return None
    if not _positive_definite(stencils, model, n, bandwidth):
        return None         # derive_equations says why M is singular
    energy_conserved = not (model.forces or model.dissipation is not None or terms.time_dependent)
    return LocalEquations(model, tuple(stencils), bandwidth, energy_conserved)


class _Terms:
    """The additive terms of T, U, D and the forces, with their lets written out, in slot symbols."""

    def __init__(self, model: ir.Model):
        self.model = model
        self.coordinate_index = {}
        for k, c in enumerate(model.coordinates):
            self.coordinate_index[c.symbol] = (k, POSITION)
            self.coordinate_index[c.velocity_symbol] = (k, VELOCITY)
        self.member_index = parameter_members(model)
        self.lets = dict(model.written_out_lets())
        self.calculus = Differentiator(self.lets.items(), tuple(self.coordinate_index) + (ir.TIME,))
        self.time_dependent = False
        self._inlined: dict[sympy.Symbol, sympy.Expr] = {}

    def shapes(self) -> dict[_Shape, list[tuple[int, int]]] | None:
        """shape -> its members' (first coordinate, first parameter), or None when a term is not local."""
        lagrangian = self.model.lagrangian
        sources = [("lagrangian", lagrangian.kinetic, 1), ("lagrangian", lagrangian.potential, -1)]
        if self.model.dissipation is not None:
            sources.append(("dissipation", self.model.dissipation.expression, 1))
        shapes: dict[_Shape, list[tuple[int, int]]] = defaultdict(list)
        for kind, expression, sign in sources:
            if expression is None:
                continue
            for term in additive_terms(expression, self._constant):
                if not self._add(shapes, kind, sign * term, None):
                    return None
        names = [c.name for c in self.model.coordinates]
        for force in self.model.forces:
            if not self._add(shapes, "force", force.expression, names.index(force.coordinate)):
                return None
        return shapes

    def _constant(self, expression: sympy.Expr) -> bool:
        """Free of the state (q, q'); t is allowed: a factor t·Σ... stays with each term."""
        return not (self.calculus.dependencies(expression) - {ir.TIME})

    def _add(self, shapes, kind: str, term: sympy.Expr, target: int | None) -> bool:
        """Put `term` under its shape; False when it touches too many coordinates."""
        touched = {self.coordinate_index[s][0] for s in self.calculus.dependencies(term) if s != ir.TIME}
        if target is not None:
            touched.add(target)
        if len(touched) > LOCAL_WIDTH:
            return False
        if not touched and kind != "lagrangian":
            return True                 # a term of D free of the velocities pushes on nothing
        term = self._inline(term)
        self.time_dependent |= kind == "lagrangian" and ir.TIME in term.free_symbols
        base = min(touched, default=0)  # a term of L free of the state only shifts the energy h by -term
        members = sorted(self.member_index[s] for s in term.free_symbols if s in self.member_index)
        parameter_base = members[0] if members else 0
        renamed = {s: slot(self.coordinate_index[s][1], self.coordinate_index[s][0] - base)
                   for s in term.free_symbols if s in self.coordinate_index}
        renamed.update({s: slot(PARAMETER, self.member_index[s] - parameter_base)
                        for s in term.free_symbols if s in self.member_index})
        offsets = tuple(sorted(k - base for k in touched))
        shape = _Shape(kind, term.xreplace(renamed), offsets,
                       tuple(j - parameter_base for j in members),
                       None if target is None else target - base)
        shapes[shape].append((base, parameter_base))
        return True

    def _inline(self, expression: sympy.Expr) -> sympy.Expr:
        """`expression` with every let replaced by its definition (they are few per local term)."""
        lets = [s for s in expression.free_symbols if s in self.lets]
        if not lets:
            return expression
        for symbol in lets:
            if symbol not in self._inlined:
                self._inlined[symbol] = self._inline(self.lets[symbol])
        return expression.xreplace({s: self._inlined[s] for s in lets})


_ARRAY_MEMBER = re.compile(r"^.+\[\d+\]$")


def parameter_members(model: ir.Model) -> dict[sympy.Symbol, int]:
    """The members of parameter arrays (m[3]) -> their index among the model's parameters."""
    return {p.symbol: j for j, p in enumerate(model.parameters) if _ARRAY_MEMBER.match(p.name)}


def additive_terms(expression: sympy.Expr, constant) -> list[sympy.Expr]:
    """The terms of `expression` as a sum, with constant factors distributed over sums:
    omega²/4·((q2 - q1)² + (q4 - q3)²) -> [omega²/4·(q2 - q1)², omega²/4·(q4 - q3)²]."""
    if expression.is_Add:
        return [term for argument in expression.args for term in additive_terms(argument, constant)]
    if expression.is_Mul:
        sums = [factor for factor in expression.args if factor.is_Add]
        others = [factor for factor in expression.args if not factor.is_Add]
        if len(sums) == 1 and all(constant(factor) for factor in others):
            factor = sympy.Mul(*others)
            return [factor * term for term in additive_terms(sums[0], constant)]
    return [expression]


def _derive(shape: _Shape):
    """(mass, forcing, energy) of one shape, in its slot symbols (module docstring)."""
    positions = [slot(POSITION, offset) for offset in shape.offsets]
    velocities = [slot(VELOCITY, offset) for offset in shape.offsets]
    g = shape.expression
    if shape.kind == "force":
        forcing = [g if offset == shape.target else sympy.S.Zero for offset in shape.offsets]
        return (), tuple(forcing), sympy.S.Zero
    slopes = [sympy.diff(g, v) for v in velocities]
    if shape.kind == "dissipation":
        return (), tuple(-slope for slope in slopes), sympy.S.Zero
    mass = []
    for a, slope in enumerate(slopes):
        for b in range(a + 1):
            entry = sympy.diff(slope, velocities[b])
            if entry != 0:
                mass.append((a, b, entry))          # offsets are sorted: offsets[a] >= offsets[b]
    forcing = []
    for a, (x, slope) in enumerate(zip(positions, slopes)):
        convective = sum((sympy.diff(slope, y) * w for y, w in zip(positions, velocities)), sympy.S.Zero)
        forcing.append(sympy.diff(g, x) - convective - sympy.diff(slope, ir.TIME))
    energy = sum((w * slope for w, slope in zip(velocities, slopes)), sympy.S.Zero) - g
    return tuple(mass), tuple(forcing), energy


def _runs(members: list[tuple[int, int]]) -> list[list[tuple[int, int]]]:
    """Split the members of one shape into runs whose indices advance in equal steps."""
    members = sorted(members)       # a repeated member (k·(a + b) + k·(b + c)) starts a run of its own
    runs: list[list[tuple[int, int]]] = []
    for member in members:
        run = runs[-1] if runs else None
        if run and (len(run) == 1 and member[0] > run[0][0]
                    or len(run) > 1 and _step(run[-2], run[-1]) == _step(run[-1], member)):
            run.append(member)
        else:
            runs.append([member])
    return runs


def _step(a: tuple[int, int], b: tuple[int, int]) -> tuple[int, int]:
    return b[0] - a[0], b[1] - a[1]


def _stencil(shape: _Shape, run, mass, forcing, energy) -> Stencil:
    (first, parameter_first), count = run[0], len(run)
    step, parameter_step = _step(run[0], run[1]) if count > 1 else (0, 0)
    return Stencil(shape.kind, _moving(shape), count, first, step, shape.offsets, parameter_first, parameter_step,
                   shape.parameter_offsets, mass, forcing, energy)


def _moving(shape: _Shape) -> tuple[int, ...]:
    if shape.kind == "force":
        return (shape.offsets.index(shape.target),)
    kind = POSITION if shape.kind == "lagrangian" else VELOCITY
    return tuple(a for a, offset in enumerate(shape.offsets) if slot(kind, offset) in shape.expression.free_symbols)


def _bandwidth(stencils) -> int | None:
    """The half-bandwidth of M, or None when it is wider than MAX_BANDWIDTH."""
    width = max((s.offsets[a] - s.offsets[b] for s in stencils for a, b, _ in s.mass), default=0)
    return width if width <= MAX_BANDWIDTH else None


def _every_diagonal_filled(stencils, n: int) -> bool:
    """Every q'_k enters T (else M is singular: derive_equations says which)."""
    filled = set()
    for s in stencils:
        for a, b, _ in s.mass:
            if a == b:
                filled.update(s.coordinate(m, a) for m in range(s.count))
    return len(filled) == n


def _has_cyclic(stencils, n: int) -> bool:
    """Some q_k that L does not depend on and that neither a force nor D acts on: its momentum is
    conserved, and derive_equations reports it (invariants.py)."""
    reached = set()
    for s in stencils:
        for a in s.moving:
            reached.update(s.coordinate(m, a) for m in range(s.count))
    return len(reached) < n


def _positive_definite(stencils, model: ir.Model, n: int, bandwidth: int) -> bool:
    """M, assembled at a random state with the default parameters, has a Cholesky factor.

    A singular M (T = Σ (q'_i - q'_{i+1})²/2, say) is a modelling error that derive_equations
    explains; the generated code would only find it when the run starts."""
    rng = np.random.default_rng(0)
    state = rng.uniform(-1, 1, size=(2, n))
    band = np.zeros((bandwidth + 1, n))                 # band[i - j, j] = M_ij, scipy's lower form
    values = {p.symbol: p.value for p in model.parameters}
    values[ir.TIME] = 0.3
    for s in stencils:
        members = np.arange(s.count)
        slots = {}
        for a, offset in enumerate(s.offsets):
            rows = s.coordinate(members, a)
            slots[slot(POSITION, offset)], slots[slot(VELOCITY, offset)] = state[0, rows], state[1, rows]
        for offset in s.parameter_offsets:
            indices = s.parameter_first + s.parameter_step * members + offset
            slots[slot(PARAMETER, offset)] = np.array([model.parameters[j].value for j in indices])
        for a, b, entry in s.mass:
            symbols = sorted(entry.free_symbols, key=str)
            try:
                with np.errstate(all="ignore"):
                    if any(x in slots for x in symbols):
                        value = sympy.lambdify(symbols, entry, "numpy")(*(slots.get(x, values.get(x)) for x in symbols))
                    else:                               # the usual case: constant masses
                        value = float(entry.xreplace({x: values[x] for x in symbols}))
                    band[s.offsets[a] - s.offsets[b], s.coordinate(members, b)] += value
            except (TypeError, ValueError, ArithmeticError):    # complex or not a number: let
                return False                                    # derive_equations judge it
    if not np.all(np.isfinite(band)):
        return False
    import scipy.linalg         # here: a model without families never needs scipy (a tenth of a second to import)
    try:
        scipy.linalg.cholesky_banded(band, lower=True)
    except (np.linalg.LinAlgError, ValueError):
        return False
    return True
