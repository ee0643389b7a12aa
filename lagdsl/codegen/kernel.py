"""Equations + ScenePlan -> Kernel: the one code model shared by the C and NumPy backends.

A kernel is a set of straight-line blocks. Each block reads named inputs (state entries,
parameters, accelerations, multipliers), computes temporaries (the named intermediates it
needs, after common-subexpression elimination) and stores expressions into output arrays.
The blocks are exactly what the scene needs:

  system       K and b of the linear system for q'' (and the multipliers λ):
                 without constraints  K = M,                   b = f
                 with constraints     K = [[M, -Aᵀ], [A, 0]],  b = [f; γ]
               so that M q'' = f + Aᵀλ and A q'' = γ. K is solved numerically, never inverted.
               Without constraints M is stored as `layout` says (structure.py): a compact
               layout stores each structurally nonzero entry once, at K[(k, j)] with k >= j.
               So does the compact layout of a large system with constraints (solver "ldl"):
               M's entries k >= j and A's, at K[(n + i, j)]; the upper block -Aᵀ is implied.
  constant_mass  M, in a block of its own, when it depends on the parameters alone and is
               stored in a compact layout (no constraints): the C program assembles and factors
               it once per run, and `system` then gives b alone
  outputs      the scene's columns and the conserved quantities (to report their drift), in
               one block so that what they share (the energy, say) is computed once
  constraints  residuals g (holonomic, position level), c (velocity level) and rows A, for
               projection onto the constraint manifold and the residual report
  jacobian     implicit integrators only: Dq = ∂R/∂q, Dv = ∂R/∂q' and Dz = ∂R/∂(q'', λ) = -K
               for R = [f - M q'' + Aᵀλ; γ - A q''] at fixed (q'', λ), stored as
               `jacobian_layout` says (dense, or a band); radau5 forms its iteration matrices
               from them (∂(q'', λ)/∂y = -Dz⁻¹ [Dq Dv] is never formed)
  canonical    gauss only: p = ∂L/∂q', M, and ṗ = ∂L/∂q + Q for Hamilton's equations
  initial      the initial state y0 from the start values (expressions of parameters)
  stop         a scene with `stop when ...` only: the function e(t, y) whose sign change to
               negative ends the run; where e reads multiplier(c), λ at (t, y) comes from the
               same solve for (q'', λ) as the outputs' (`stop_needs_multipliers`)
  parameter_jacobian, output_jacobian, initial_sensitivity
               a program for forward sensitivities only (lagdsl/sensitivity/lowering.py):
               Dp = ∂R/∂p, the outputs' ∂h/∂y and ∂h/∂p, and ∂y0/∂p

All symbols are renamed to target-safe names (p_m1, q_theta1, v_theta1, let_x1, c12, ...;
naming.py) that cannot collide with C or Python keywords, libm or POSIX names.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import sympy

from .. import ir
from ..calculus import Differentiator
from ..errors import InternalError, LagError
from ..mechanics import Equations
from ..mechanics.families import LocalEquations
from ..mechanics.trees import TreeEquations
from ..scene import ScenePlan, declared_inputs
from .cse import eliminate_common_subexpressions
from .naming import NameTable, check_target_names
from .structure import JacobianLayout, MassLayout, jacobian_layout, kkt_layout, mass_layout


@dataclass(frozen=True)
class Store:
    array: str
    index: tuple[int, ...]
    value: sympy.Expr


@dataclass(frozen=True)
class Loop:
    """The members of one stencil (mechanics/families.py): for i = 0 .. count - 1, read each input
    name = array[offset + stride·i], compute the assignments, and add each store's value into
    array[offset + stride·i] (one (offset, stride) per index; a 2-index store is an entry of M).
    A store with no index adds into the block's accumulator of that name (a sum over members)."""

    count: int
    inputs: tuple[tuple[str, str, int, int], ...]            # (name, array, offset, stride)
    assignments: tuple[tuple[str, sympy.Expr], ...]
    stores: tuple[tuple[str, tuple[tuple[int, int], ...], sympy.Expr], ...]


@dataclass(frozen=True)
class PathSums:
    """Root to leaves over the links of the tree layout (structure.py): for each link j with a
    parent, array[j·width + a] += array[parent(j)·width + a], a < width. The `after` loops before
    it store each link's own terms (r_j, r_j'); those after it read the sums along the path from
    the root (P_j, P_j'). The array, of n·width reals, is local to the block and starts at zero."""

    array: str
    width: int
    after: int


# The residual Jacobian's arrays (Dq, Dv, Dz): its block clears all three, whatever it stores (a
# model whose R does not depend on q has no store in Dq, and its readers sum over the layout).
JACOBIAN_ARRAYS = ("Dq", "Dv", "Dz")


@dataclass(frozen=True)
class Block:
    inputs: tuple[tuple[str, str], ...]          # (name, source such as "y[3]" or "par[0]")
    assignments: tuple[tuple[str, sympy.Expr], ...]
    stores: tuple[Store, ...]
    loops: tuple[Loop, ...] = ()                 # run after the inputs, before the assignments
    accumulators: tuple[str, ...] = ()           # scalars the loops sum into, zero before them
    cleared: tuple[str, ...] = ()                # arrays zeroed first: the loops add into them
    path_sums: PathSums | None = None            # between the loops: sums along a tree's paths


@dataclass(frozen=True)
class Kernel:
    model_name: str
    scene_name: str
    coordinates: tuple[str, ...]
    parameters: tuple[tuple[str, float], ...]    # name, value for this scene
    derived_parameters: tuple[tuple[int, sympy.Expr], ...]   # index, expression in par[j]
    constraints: tuple[str, ...]                 # active constraints
    holonomic: int                               # how many of them are holonomic (they come first)
    columns: tuple[str, ...]
    invariant_names: tuple[str, ...]
    integrator: ir.IntegratorChoice
    time: ir.TimeGrid
    solver: str                                  # "cholesky", "ldl" (sparse, constrained) or "lu"
    layout: MassLayout | None                    # how K is stored and factored (not lu)
    initial: Block
    system: Block | None                         # None for gauss, which uses the canonical form
    outputs: Block
    outputs_need_multipliers: bool
    constraint_rows: Block | None
    jacobian: Block | None
    momenta: Block | None
    mass: Block | None
    momentum_rate: Block | None
    stop: Block | None = None                    # e(t, y) of the scene's stop condition
    stop_text: str = ""                          # the condition as written
    stop_needs_multipliers: bool = False         # e reads multiplier(c): the stop solves for λ
    constant_mass: Block | None = None           # M from the parameters alone (system then gives b)
    jacobian_layout: JacobianLayout | None = None     # how the jacobian block stores Dq, Dv, Dz
    parameter_jacobian: Block | None = None           # Dp = ∂R/∂p (sensitivities only)
    output_jacobian: Block | None = None              # Cy = ∂h/∂y, Cp = ∂h/∂p of the columns
    initial_sensitivity: Block | None = None          # S0 = ∂y0/∂p
    input_units: tuple[ir.Unit | None, ...] = ()      # declared: each parameter, q.start, q.velocity

    @property
    def n(self) -> int:
        return len(self.coordinates)

    @property
    def size(self) -> int:
        """Order of the linear system K: coordinates plus active constraints."""
        return self.n + len(self.constraints)


def lower_to_kernel(equations: Equations | LocalEquations | TreeEquations, plan: ScenePlan) -> Kernel:
    """Build every block the scene needs (see the module docstring): from the tree form (loops
    over links) or the local form of the equations (loops over stencils) where the scene allows
    it, else from the expanded equations."""
    if isinstance(equations, TreeEquations):
        from .tree_loops import TreeLowering
        if local_form_serves(plan, False, bool(equations.active_constraints)):
            return TreeLowering(equations, plan).kernel()
        equations = equations.expanded
    if isinstance(equations, LocalEquations):
        from .loops import LocalLowering, mass_is_constant
        if local_form_serves(plan, mass_is_constant(equations)):
            return LocalLowering(equations, plan).kernel()
        equations = equations.expanded
    return _Lowering(equations, plan).kernel()


def local_form_serves(plan: ScenePlan, constant_mass: bool, constrained: bool = False) -> bool:
    """The local form gives M, f, their derivatives and the energy: enough for an integrator
    whose outputs need no momenta, multipliers or residuals (the tree form with constraints
    gives those two), other than gauss (the canonical form) and taylor (its series are built
    from straight-line blocks), and for an implicit one when M is constant (∂(M q'')/∂q = 0)."""
    kinds = ("expression", "energy", "multiplier", "residual") if constrained else ("expression", "energy")
    return (not plan.canonical and not plan.series and (constant_mass or not plan.implicit)
            and all(o.kind in kinds for o in plan.outputs))


class _Lowering:
    def __init__(self, equations: Equations, plan: ScenePlan):
        self.eq, self.plan = equations, plan
        self.model = equations.model
        self.calculus: Differentiator = self.differentiator()
        self.active = [c for c in equations.constraints if not c.dropped]
        self.active.sort(key=lambda c: c.kind != "holonomic")      # holonomic rows first
        self.n = equations.size
        self.solver, self.layout = self.linear_system()
        self.accelerations = [sympy.Symbol(f"{c.name}''", real=True) for c in self.model.coordinates]
        self.multipliers = [ir.multiplier_symbol(c.name) for c in self.active]
        self.table = NameTable(self.model, self.calculus, self.accelerations, self.active, self.multipliers)

    def differentiator(self) -> Differentiator:
        """The chain rule through the equations' intermediates, by the state and time."""
        return self.eq.calculus()

    def linear_system(self) -> tuple[str, MassLayout | None]:
        """How K is factored, and its layout: Cholesky or LDLᵀ for a positive definite M
        (structure.py), LU with partial pivoting where M may not be (a Lagrangian that is not
        natural) or a system with constraints is small or dense."""
        if not self.model.lagrangian.is_natural:
            return "lu", None
        if not self.active:
            return "cholesky", self.mass_layout()
        layout = kkt_layout(self.eq.mass_matrix, [c.jacobian for c in self.active])
        return ("ldl", layout) if layout is not None else ("lu", None)

    def mass_layout(self) -> MassLayout:
        return mass_layout(self.eq.mass_matrix)

    # -- blocks --------------------------------------------------------------------------------
    def block(self, stores: list[tuple[str, tuple[int, ...], sympy.Expr]],
              read: dict[sympy.Symbol, str] | None = None) -> Block:
        """The stores' block; the intermediates in `read` are inputs from the sources given there
        (an array the block's loops fill), not computed from their definitions."""
        values = [value for _, _, value in stores]
        read = read or {}
        needed = tuple((s, e) for s, e in self.calculus.needed(values) if s not in read)
        self.table.name_new_intermediates()
        names, sources = self.table.names, {**self.table.sources, **read}
        ordered, reduced = eliminate_common_subexpressions(needed, values)
        rename = {}
        for symbol, _ in ordered:                   # intermediates and CSE temporaries (c0, c1, ...)
            rename[symbol] = sympy.Symbol(names.get(symbol, symbol.name), real=True)
        used = set().union(*(e.free_symbols for _, e in ordered), *(e.free_symbols for e in reduced)) \
            if (ordered or reduced) else set()
        inputs = []
        for symbol in sorted(used - set(rename), key=lambda s: (self.table.input_order(s), names.get(s, s.name))):
            if symbol not in sources:
                raise InternalError(f"unbound symbol {symbol} in a kernel block")
            rename[symbol] = sympy.Symbol(names[symbol], real=True)
            if symbol != ir.TIME:
                inputs.append((names[symbol], sources[symbol]))
        check_target_names(rename)
        return Block(tuple(inputs),
                     tuple((rename[s].name, e.xreplace(rename)) for s, e in ordered),
                     tuple(Store(array, index, value.xreplace(rename))
                           for (array, index, _), value in zip(stores, reduced)))

    # -- the kernel ----------------------------------------------------------------------------
    def kernel(self) -> Kernel:
        plan = self.plan
        constant_mass, system = (None, None) if plan.canonical else self.system_blocks()
        return Kernel(
            model_name=self.model.name, scene_name=plan.scene_name,
            coordinates=tuple(c.name for c in self.model.coordinates),
            parameters=tuple((p.name, value) for p, value in zip(self.model.parameters, plan.parameters)),
            derived_parameters=self.derived_parameters(),
            constraints=tuple(c.name for c in self.active),
            holonomic=sum(c.kind == "holonomic" for c in self.active),
            columns=plan.columns, invariant_names=plan.invariants,
            integrator=plan.integrator, time=plan.time,
            solver=self.solver, layout=self.layout,
            initial=self.initial_block(), system=system, constant_mass=constant_mass,
            outputs=self.outputs_block(),
            outputs_need_multipliers=any(o.kind == "multiplier" or o.kind == "expression" and
                                         self.reads_multipliers(o.expression) for o in plan.outputs),
            constraint_rows=self.constraint_block() if self.active else None,
            **self.jacobian_fields(),
            **self.canonical_blocks(),
            stop=self.block([("ev", (0,), plan.stop.function)]) if plan.stop else None,
            stop_text=plan.stop.text if plan.stop else "",
            stop_needs_multipliers=bool(plan.stop and self.reads_multipliers(plan.stop.function)),
            input_units=tuple(unit for _, unit in declared_inputs(self.model)))

    def reads_multipliers(self, expression: sympy.Expr) -> bool:
        """Whether a value needs λ, solved for with q'' at its state (outputs, the stop condition)."""
        return bool(expression.free_symbols & set(self.multipliers))

    def derived_parameters(self):
        """Parameters defined by earlier ones, written in terms of the array par[] they live in."""
        in_array = {p.symbol: sympy.Symbol(f"par[{i}]") for i, p in enumerate(self.model.parameters)}
        return tuple((i, p.expression.xreplace(in_array)) for i, p in enumerate(self.model.parameters)
                     if p.expression.free_symbols and p.name not in self.plan.fixed_parameters)

    def initial_block(self) -> Block:
        # y0 starts as zeros: a chain of many masses at rest needs no statement per member.
        block = self.block([store for store in self.initial_stores() if store[2] != 0])
        return Block(block.inputs, block.assignments, block.stores, cleared=("y0",))

    def initial_stores(self) -> list[tuple[str, tuple[int, ...], sympy.Expr]]:
        overrides = {name: (start, velocity) for name, start, velocity in self.plan.initial}
        stores = []
        for k, c in enumerate(self.model.coordinates):
            start, velocity = overrides.get(c.name, (None, None))
            stores.append(("y0", (k,), sympy.Float(start) if start is not None else c.start))
            stores.append(("y0", (self.n + k,), sympy.Float(velocity) if velocity is not None else c.velocity))
        return stores

    def mass_stores(self, array: str) -> list[tuple[str, tuple[int, ...], sympy.Expr]]:
        """M into `array`: every entry (the dense layout), or each structurally nonzero entry
        once, (k, j) with k >= j (a compact layout)."""
        M, n = self.eq.mass_matrix, self.n
        if self.layout is None or not self.layout.compact:
            return [(array, (k, j), M[k][j]) for k in range(n) for j in range(n)]
        return [(array, (k, j), M[k][j]) for k in range(n) for j in range(k + 1) if M[k][j] != 0 or j == k]

    def system_blocks(self) -> tuple[Block | None, Block]:
        """(constant mass, system): M apart from f when it can be factored once per run (see
        the module docstring), else (None, the block of K and b)."""
        if self.active or self.layout is None or not self.layout.compact or not self.mass_is_constant():
            return None, self.system_block()
        return self.mass_block(), self.forces_block()

    def mass_is_constant(self) -> bool:
        """M depends on neither the state nor the time (Cartesian masses, springs, chains)."""
        varying = {ir.TIME, *self.eq.coordinates, *self.eq.velocities}
        return not any(self.calculus.dependencies(entry) & varying for row in self.eq.mass_matrix for entry in row)

    def mass_block(self) -> Block:
        return self.block(self.mass_stores("K"))

    def forces_block(self) -> Block:
        return self.block(self.force_stores())

    def force_stores(self) -> list[tuple[str, tuple[int, ...], sympy.Expr]]:
        return [("b", (k,), f) for k, f in enumerate(self.eq.forcing)]

    def system_block(self) -> Block:
        n, m = self.n, len(self.active)
        if not self.active:
            return self.block(self.mass_stores("K") + self.force_stores())
        gamma = [("b", (n + i,), c.gamma) for i, c in enumerate(self.active)]
        if self.layout is not None:
            rows = [("K", (n + i, j), a) for i, c in enumerate(self.active) for j, a in enumerate(c.jacobian) if a != 0]
            return self.block(self.mass_stores("K") + rows + self.force_stores() + gamma)
        stores = []
        for k in range(n):
            for j in range(n):
                stores.append(("K", (k, j), self.eq.mass_matrix[k][j]))
            for i, c in enumerate(self.active):
                stores.append(("K", (k, n + i), -c.jacobian[k]))
        for i, c in enumerate(self.active):
            for j in range(n):
                stores.append(("K", (n + i, j), c.jacobian[j]))
            for l in range(m):
                stores.append(("K", (n + i, n + l), sympy.S.Zero))
        return self.block(stores + self.force_stores() + gamma)

    def outputs_block(self) -> Block:
        return self.block(self.output_stores())

    def output_stores(self) -> list[tuple[str, tuple[int, ...], sympy.Expr]]:
        conserved = {q.name: q.expression for q in self.eq.conserved}
        coordinates = [c.name for c in self.model.coordinates]
        active = [c.name for c in self.active]
        by_name = {c.name: c for c in self.eq.constraints}
        stores = []
        for column, request in enumerate(self.plan.outputs):
            if request.kind == "expression":
                value = request.expression
            elif request.kind == "energy":
                value = conserved["energy"] if "energy" in conserved else self.eq.energy
            elif request.kind == "momentum":
                value = self.eq.momenta[coordinates.index(request.target)]
            elif request.kind == "multiplier":
                value = self.multipliers[active.index(request.target)]
            else:                                               # residual
                constraint = by_name[request.target]
                value = constraint.residual
            stores.append(("out", (column,), value))
        stores += [("inv", (i,), q.expression) for i, q in enumerate(self.eq.conserved)]
        return stores

    def constraint_block(self) -> Block:
        holonomic = [c for c in self.active if c.kind == "holonomic"]
        stores = [("g", (i,), c.residual) for i, c in enumerate(holonomic)]
        stores += [("c", (i,), c.velocity_residual) for i, c in enumerate(self.active)]
        stores += [("A", (i, k), a) for i, c in enumerate(self.active) for k, a in enumerate(c.jacobian)]
        return self.block(stores)

    def jacobian_block(self) -> tuple[Block, JacobianLayout]:
        """Dq, Dv and Dz (structure.JacobianLayout) at fixed (q'', λ): each structurally nonzero
        entry, in the layout their pattern allows."""
        stores = [store for store in self.residual_derivatives() if store[2] != 0]
        layout = jacobian_layout(self.n + len(self.active), bool(self.active),
                                 {index for _, index, _ in stores} | {(r, r) for r in range(self.n)})
        return replace(self.block(stores), cleared=JACOBIAN_ARRAYS), layout

    def residuals(self) -> list[sympy.Expr]:
        """R = [f - M q'' + Aᵀλ; γ - A q''] in the symbols of q'' and λ."""
        eq, n = self.eq, self.n
        residuals = []
        for k in range(n):
            r = eq.forcing[k] - sum((eq.mass_matrix[k][j] * self.accelerations[j] for j in range(n)), sympy.S.Zero)
            r += sum((lam * c.jacobian[k] for lam, c in zip(self.multipliers, self.active)), sympy.S.Zero)
            residuals.append(r)
        for c in self.active:
            residuals.append(c.gamma - sum((a * x for a, x in zip(c.jacobian, self.accelerations)), sympy.S.Zero))
        return residuals

    def residual_derivatives(self) -> list[tuple[str, tuple[int, int], sympy.Expr]]:
        """Dq = ∂R/∂q, Dv = ∂R/∂q' of R = [f - M q'' + Aᵀλ; γ - A q''], and Dz = ∂R/∂(q'', λ) = -K."""
        eq, n = self.eq, self.n
        stores = [(array, (r, j), self.calculus.partial(residual, x))
                  for r, residual in enumerate(self.residuals())
                  for array, variables in (("Dq", eq.coordinates), ("Dv", eq.velocities))
                  for j, x in enumerate(variables)]
        for k in range(n):
            stores += [("Dz", (k, j), -eq.mass_matrix[k][j]) for j in range(n)]
            stores += [("Dz", (k, n + i), c.jacobian[k]) for i, c in enumerate(self.active)]
        for i, c in enumerate(self.active):
            stores += [("Dz", (n + i, j), -a) for j, a in enumerate(c.jacobian)]
        return stores

    def jacobian_fields(self) -> dict:
        if not self.plan.implicit:
            return {"jacobian": None, "jacobian_layout": None}
        block, layout = self.jacobian_block()
        return {"jacobian": block, "jacobian_layout": layout}

    def canonical_blocks(self) -> dict:
        if not self.plan.canonical:
            return {"momenta": None, "mass": None, "momentum_rate": None}
        velocities = set(self.eq.velocities)
        for row in self.eq.mass_matrix:
            for entry in row:
                if self.calculus.dependencies(entry) & velocities:
                    raise LagError("the gauss integrator needs a Lagrangian quadratic in the velocities "
                                   "(a mass matrix independent of q'); use radau5 or dop853",
                                   self.plan.integrator.span)
        eq = self.eq
        return {
            "momenta": self.block([("p", (k,), p) for k, p in enumerate(eq.momenta)]),
            "mass": self.block(self.mass_stores("M")),
            "momentum_rate": self.block([("dp", (k,), g + f) for k, (g, f) in
                                         enumerate(zip(eq.lagrangian_gradient, eq.generalized_forces))]),
        }
