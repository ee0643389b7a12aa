"""Model -> TreeEquations: point masses on a tree of rigid links in joint coordinates (pendulum
chains, ropes, trees of pendulums), whose accelerations the generated code finds in O(n)
without forming the dense mass matrix.

A body is a point P_j whose components (lets x, y, z) are sums of joint terms,

    P_j = P_parent(j) + r_j(q_j),

each r_j depending on its own coordinate q_j alone: the lets write the sums out (as
`sum(l*sin(theta[j]), j in 1:i)` builds them) or refer to earlier lets. With s_j = ∂r_j/∂q_j,
w_j = (∂²r_j/∂q_j²) q_j'², the kinetic energy T = Σ_j Σ_a m_ja/2 (P_ja')² and the potential
U = Σ_j g_j·P_j + Σ_j V_j(q_j) (g_j free of the state: a uniform field such as gravity), the
Euler-Lagrange equation of q_j is the balance along its joint of the forces on its subtree:

    s_jᵀ F_j = τ_j = -V_j'(q_j) + Q_j - ∂D/∂q_j',   F_j = Σ_{k in the subtree of j} (m_k P_k'' + g_k),
    P_j'' = P_parent(j)'' + s_j q_j'' + w_j,

solved by the articulated-body recursion (the tree layout of codegen/structure.py): leaves to
root, F_j = A_j P_parent'' + c_j with the articulated inertia A_j = Â - (Â s)(Â s)ᵀ/D,
D = sᵀ Â s, Â = diag(m_j) + Σ_children A; then root to leaves,
q_j'' = (τ_j - sᵀ(Â (P_parent'' + w_j) + ĉ_j)) / D. Each link's record (m_j, s_j, w_j, g_j and
τ_j) is derived once per shape of link, in slot symbols as the local form's stencils are
(mechanics/families.py), and the generated code loops over the links. So does the energy,

    h = Σ_j (Σ_a m_ja/2 (P_ja')² + g_j·P_j + V_j(q_j)) + U_0    (U_0: U's constant terms),

from each link's terms r_j and r_j' = s_j q_j' made sums along the path from the root
(P_j = P_parent + r_j, P_j' = P_parent' + r_j'), a sweep root to leaves in the generated code.

Holonomic constraints g(q, t) = 0 close loops (a chain pinned at both ends): their rows
A = ∂g/∂q and γ are derived through the recursive lets (TreeEquations.close_loops), and the
generated code solves M q'' = f + Aᵀλ, A q'' = γ by the Schur complement A M⁻¹ Aᵀ with the one
factor of the recursion (docs/numerics.md). Forces Q_j and terms of the dissipation D that read
one joint's q_j and q_j' alone (joint dampers c_j q_j'²/2) add to its τ_j. The tree form is used
for a natural system without nonholonomic constraints, with at least TREE_MIN_COORDINATES
coordinates, each the joint of one body, every body with a mass on each of its parent's
components, and T and U exactly of the forms above. Everything else, and
what the tree form does not provide (`lagc eom`, implicit and symplectic integrators, momenta),
takes the expanded Equations of derive_equations, derived on first use.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy

from .. import ir
from ..calculus import Differentiator, partial_derivative
from .constraints import constraint_equations
from .families import PARAMETER, POSITION, VELOCITY, LocalEquations, Stencil, additive_terms, \
    parameter_members, slot, _runs
from .probe import Probe

TREE_MIN_COORDINATES = 8        # smaller chains are cheap in the dense form
POINT, POINT_RATE = "§P", "§R"  # slots of a body's P_a and P_a' in a link's energy (no user can write §)


@dataclass(frozen=True)
class Links:
    """Bodies of one shape: `placement` is a one-slot Stencil whose members are the bodies
    (count, first body, step, parameter members), whose forcing is their τ and whose energy is
    their term of h, Σ_a m_a/2 §R<a>² + g_a §P<a> + V_j; `record` is each body's m (d entries),
    s, w and g, and `kinematics` its r and r' = s q', in the slot symbols §x0, §v0 and §p<b> of
    mechanics/families.py."""

    placement: Stencil
    record: tuple[sympy.Expr, ...]
    kinematics: tuple[sympy.Expr, ...]


class TreeEquations(LocalEquations):
    """The tree form of a model's equations (see the module docstring); the expanded Equations
    are derived on first use for everything else."""

    def __init__(self, model: ir.Model, parents: tuple[int, ...], axes: int, links: tuple[Links, ...],
                 definitions: tuple[tuple[sympy.Symbol, sympy.Expr], ...], points: dict[sympy.Symbol, int],
                 energy_shift: sympy.Expr):
        # the energy: ENERGY, which the links' loops compute; conserved without forces and dissipation
        super().__init__(model, (), 0, not model.forces and model.dissipation is None)
        self.parents, self.axes, self.links = parents, axes, links
        self.definitions = definitions          # the bodies' components and velocities, link by link
        self.points = points                    # P_ja -> j·2d + a, P_ja' -> j·2d + d + a
        self.energy_shift = energy_shift        # U_0, the constant terms of U
        self.constraints = self.active_constraints = ()

    def close_loops(self) -> bool:
        """Derive the model's constraints through the tree's lets (a constraint on a body reads
        its path to the root); False where one is not holonomic, which the tree form leaves to
        the expanded equations. h stays conserved while no constraint depends on t."""
        if not self.model.constraints:
            return True
        calculus = self.calculus()
        probe = Probe(calculus, (*self.coordinates, *self.velocities, ir.TIME,
                                 *(p.symbol for p in self.model.parameters)))
        constraints = constraint_equations(self.model, calculus, probe)
        if any(c.kind != "holonomic" for c in constraints):
            return False
        self.constraints = constraints
        self.definitions = calculus.definitions()   # with the intermediates the constraints' rates made
        self.active_constraints = tuple(c for c in constraints if not c.dropped)
        if any(ir.TIME in calculus.dependencies(c.residual) for c in self.active_constraints):
            self.conserved = ()
        return True

    @property
    def velocity_in_accelerations(self) -> str:
        return f"der({self.model.coordinates[0].name})"        # w_j = r_j'' q_j'²

    def calculus(self) -> Differentiator:
        """The components as P_parent + r_j and their velocities as P_parent' + s_j q_j': each
        let costs one link's terms, so that the outputs stay linear in n."""
        return Differentiator(self.definitions, (*self.coordinates, *self.velocities, ir.TIME))


def derive_tree_equations(model: ir.Model) -> TreeEquations | None:
    """The tree form of `model`'s equations, or None where it does not apply (module docstring)."""
    n = len(model.coordinates)
    if n < TREE_MIN_COORDINATES or not model.lagrangian.is_natural:
        return None
    tree = _Tree(model)
    bodies = tree.bodies()
    if bodies is None:
        return None
    potential, drives = tree.potential(bodies), tree.drives()
    if potential is None or drives is None:
        return None
    equations = tree.equations(bodies, *potential, drives)
    return equations if equations.close_loops() else None


class _Tree:
    """The recognition of the bodies, their joints and their energies."""

    def __init__(self, model: ir.Model):
        self.model = model
        self.index = {c.symbol: k for k, c in enumerate(model.coordinates)}
        self.lets = {let.symbol: let for let in model.lets}
        self.joints = frozenset(self.index)
        self.moving = frozenset({*(c.velocity_symbol for c in model.coordinates), ir.TIME})
        self.let_symbols = frozenset(self.lets)
        self.varying = self.let_symbols | self.joints | self.moving
        self.members = parameter_members(model)
        self._parts: dict[sympy.Symbol, dict[int, sympy.Expr] | None] = {}
        self._split_all = False
        self._joints: dict[sympy.Expr, int | None] = {}

    def constant(self, expression: sympy.Expr) -> bool:
        """Free of the state and of the lets (which may hold it)."""
        return self.varying.isdisjoint(expression.free_symbols)

    def parts(self, symbol: sympy.Symbol) -> dict[int, sympy.Expr] | None:
        """A position let as {joint: r(q_joint)}, or None when it is not a sum of joint terms.
        The lets are split in their order on the first call: a member of a prefix sum refers to
        the member before it (frontend/prefix_sums.py), and asked out of order, each would
        recurse through all before it."""
        if not self._split_all:
            self._split_all = True
            for let in self.model.lets:
                if let.derivative_of is None:
                    self._parts[let.symbol] = self._split(let.expression)
        if symbol not in self._parts:
            self._parts[symbol] = self._split(self.lets[symbol].expression)
        return self._parts[symbol]

    def _split(self, expression: sympy.Expr) -> dict[int, sympy.Expr] | None:
        found: dict[int, sympy.Expr] = {}
        for term in sympy.Add.make_args(expression):
            if term in self.lets and self.lets[term].derivative_of is None:
                inner = self.parts(term)
                if inner is None or found.keys() & inner.keys():
                    return None
                found.update(inner)
                continue
            joint = self.joint_of(term)
            if joint is None:
                return None
            found[joint] = found[joint] + term if joint in found else term
        return found or None

    def joint_of(self, term: sympy.Expr) -> int | None:
        """The one coordinate a term of a position depends on (and no let, velocity or t), or
        None; memoised: a prefix sum repeats each link's term in every later let."""
        if term not in self._joints:
            free = term.free_symbols
            joints = free & self.joints
            alone = len(joints) == 1 and not free & (self.let_symbols | self.moving)
            self._joints[term] = self.index[next(iter(joints))] if alone else None
        return self._joints[term]

    def masses(self) -> dict[sympy.Symbol, sympy.Expr] | None:
        """Position let -> its mass m, from T = Σ m/2 (der X)², or None."""
        masses: dict[sympy.Symbol, sympy.Expr] = {}
        for term in additive_terms(self.model.lagrangian.kinetic, self.constant):
            found = self._kinetic_term(term)
            if found is None:
                return None
            masses[found[0]] = masses.get(found[0], sympy.S.Zero) + found[1]
        return masses

    def _kinetic_term(self, term: sympy.Expr) -> tuple[sympy.Symbol, sympy.Expr] | None:
        """(X, m) for a term m/2 (der X)², written with der(X) or with it inlined."""
        rates = [s for s in term.free_symbols if s in self.lets and self.lets[s].derivative_of is not None]
        if len(rates) == 1:
            factor, rest = term.as_independent(rates[0], as_Add=False)
            if rest == rates[0] ** 2 and self.constant(factor):
                return self.lets[rates[0]].derivative_of, 2 * factor
            return None
        joints = term.free_symbols & self.joints
        if rates or len(joints) != 1 or term.free_symbols & self.let_symbols:
            return None
        joint = self.index[next(iter(joints))]
        for symbol, let in self.lets.items():        # der X inlined: X of one joint term
            parts = self.parts(symbol) if let.derivative_of is None else None
            if parts and set(parts) == {joint}:
                q = self.model.coordinates[joint]
                rate = partial_derivative(parts[joint], q.symbol) * q.velocity_symbol
                ratio = sympy.cancel(term / rate ** 2)
                if self.constant(ratio) and ratio != 0:
                    return symbol, 2 * ratio
        return None

    def bodies(self) -> list[list[tuple[sympy.Symbol, sympy.Expr]]] | None:
        """Body j (of joint q_j) -> its components (X, m), in the order of its parent's; sets
        self.parents (the parent body of each, -1 at the root)."""
        masses = self.masses()
        if not masses or any(self.parts(x) is None for x in masses):
            return None
        n = len(self.model.coordinates)
        own: list[list[sympy.Symbol]] = [[] for _ in range(n)]
        parents = [-2] * n
        for x in masses:
            joints = sorted(self.parts(x))
            parent = joints[-2] if len(joints) > 1 else -1
            if parents[joints[-1]] not in (-2, parent):
                return None
            parents[joints[-1]] = parent
            own[joints[-1]].append(x)
        if -2 in parents or not self._paths_agree(masses, parents):
            return None
        self.parents = tuple(parents)
        ordered = self._order(own, parents)
        if ordered is None:
            return None
        return [[(x, masses[x]) for x in body] for body in ordered]

    def _paths_agree(self, masses, parents) -> bool:
        """Every component's joints are its body's path to the root."""
        for x in masses:
            joints = sorted(self.parts(x))
            path, j = [], joints[-1]
            while j >= 0:
                path.append(j)
                j = parents[j]
            if sorted(path) != joints:
                return False
        return True

    def _order(self, own, parents) -> list[list[sympy.Symbol]] | None:
        """Each body's components in the order of their parent components (X - r_j = X_parent)."""
        ordered: list[list[sympy.Symbol]] = []
        for j, body in enumerate(own):
            if parents[j] < 0:
                ordered.append(sorted(body, key=lambda x: list(self.lets).index(x)))
                continue
            above = ordered[parents[j]]
            inner = {frozenset(self.parts(x).items()): x for x in above}
            mine = {frozenset((k, r) for k, r in self.parts(x).items() if k != j): x for x in body}
            if len(body) != len(above) or set(mine) != set(inner):
                return None
            ordered.append([mine[frozenset(self.parts(x).items())] for x in above])
        axes = {len(body) for body in ordered}
        return ordered if len(axes) == 1 else None

    def potential(self, bodies) -> tuple[dict[sympy.Symbol, sympy.Expr], list[sympy.Expr], sympy.Expr] | None:
        """(component -> g, the field's constant gradient; joint -> V_j; U_0), or None."""
        components = {x for body in bodies for x, _ in body}
        fields: dict[sympy.Symbol, sympy.Expr] = {}
        torques = [sympy.S.Zero] * len(bodies)
        shift = sympy.S.Zero
        potential = self.model.lagrangian.potential
        for term in additive_terms(potential, self.constant) if potential is not None else ():
            if self.constant(term):
                shift += term           # shifts the energy only
                continue
            lets = term.free_symbols & self.let_symbols
            if len(lets) == 1 and lets <= components:
                x = next(iter(lets))
                factor, rest = term.as_independent(x, as_Add=False)
                if rest != x or not self.constant(factor):
                    return None
                fields[x] = fields.get(x, sympy.S.Zero) + factor
                continue
            joints = term.free_symbols & self.joints
            if lets or len(joints) != 1 or term.free_symbols & self.moving:
                return None
            torques[self.index[next(iter(joints))]] += term
        return fields, torques, shift

    def drives(self) -> list[sympy.Expr] | None:
        """Joint -> Q_j - ∂D/∂q_j', the forces and the dissipation on it, where each force and
        each term of D reads one joint's q_j and q_j' alone (no let, no t); else None."""
        names = {c.name: k for k, c in enumerate(self.model.coordinates)}
        drives = [sympy.S.Zero] * len(self.model.coordinates)
        for force in self.model.forces:
            k = names[force.coordinate]
            if self._joint_alone(force.expression) not in (k, -1):
                return None
            drives[k] += force.expression
        dissipation = self.model.dissipation
        for term in additive_terms(dissipation.expression, self.constant) if dissipation is not None else ():
            k = self._joint_alone(term)
            if k is None:
                return None
            if k >= 0:
                drives[k] -= partial_derivative(term, self.model.coordinates[k].velocity_symbol)
        return drives

    def _joint_alone(self, expression: sympy.Expr) -> int | None:
        """The one joint whose q_j and q_j' an expression reads (-1: none), or None when it
        reads several, a let or t."""
        free = expression.free_symbols & self.varying
        joints = {self.index[c.symbol] for c in self.model.coordinates if free & {c.symbol, c.velocity_symbol}}
        if len(joints) > 1 or free & (self.let_symbols | {ir.TIME}):
            return None
        return joints.pop() if joints else -1

    def equations(self, bodies, fields, torques, shift, drives) -> TreeEquations:
        shapes: dict[tuple, list[tuple[int, int]]] = {}
        for j, body in enumerate(bodies):
            q = self.model.coordinates[j]
            record = [m for _, m in body] + [self.parts(x)[j] for x, _ in body] + \
                     [fields.get(x, sympy.S.Zero) for x, _ in body] + [torques[j], drives[j]]
            renamed, parameter_base = self._in_slots(record, q)
            shapes.setdefault(tuple(renamed), []).append((j, parameter_base))
        links = tuple(_links(shape, run, len(bodies[0])) for shape, members in shapes.items() for run in _runs(members))
        return TreeEquations(self.model, self.parents, len(bodies[0]), links, *self._recursive(bodies), shift)

    def _in_slots(self, record, q: ir.Coordinate) -> tuple[list[sympy.Expr], int]:
        members = self.members
        used = sorted({members[s] for e in record for s in e.free_symbols if s in members})
        base = used[0] if used else 0
        rename = {q.symbol: slot(POSITION, 0), q.velocity_symbol: slot(VELOCITY, 0)}
        rename.update({p: slot(PARAMETER, k - base) for p, k in members.items() if k in used})
        return [e.xreplace(rename) for e in record], base

    def _recursive(self, bodies) -> tuple[tuple[tuple[sympy.Symbol, sympy.Expr], ...], dict[sympy.Symbol, int]]:
        """The components P_ja = P_parent,a + r_ja and their velocities, link by link, then the
        other lets; and each component's and velocity's place in a link's P, P' (TreeEquations.points)."""
        rates = {let.derivative_of: let.symbol for let in self.model.lets if let.derivative_of is not None}
        definitions, points, axes = [], {}, len(bodies[0])
        for j, body in enumerate(bodies):
            q = self.model.coordinates[j]
            for a, (x, _) in enumerate(body):
                above = bodies[self.parents[j]][a][0] if self.parents[j] >= 0 else None
                rate = rates.setdefault(x, sympy.Symbol(f"der({x.name})", real=True))
                r = self.parts(x)[j]
                definitions.append((x, r + (above if above is not None else 0)))
                slope = partial_derivative(r, q.symbol) * q.velocity_symbol
                definitions.append((rate, slope + (rates[above] if above is not None else 0)))
                points[x], points[rate] = 2 * axes * j + a, 2 * axes * j + axes + a
        others = [(let.symbol, let.expression) for let in self.model.lets if let.symbol not in points]
        return tuple(definitions + others), points


def _links(shape: tuple, run: list[tuple[int, int]], axes: int) -> Links:
    """The Links of one run of bodies of one shape: its record, with s and w derived from r."""
    (first, parameter_first), count = run[0], len(run)
    step, parameter_step = (run[1][0] - first, run[1][1] - parameter_first) if count > 1 else (0, 0)
    masses, joints, gradient = shape[:axes], shape[axes:2 * axes], shape[2 * axes:3 * axes]
    potential, drive = shape[-2:]
    x, v = slot(POSITION, 0), slot(VELOCITY, 0)
    slopes = [partial_derivative(r, x) for r in joints]
    bias = [partial_derivative(s, x) * v ** 2 for s in slopes]
    members = sorted({int(s.name[len(PARAMETER):]) for e in shape for s in e.free_symbols
                      if s.name.startswith(PARAMETER)})
    energy = sympy.Add(*(m / 2 * slot(POINT_RATE, a) ** 2 + g * slot(POINT, a)
                         for a, (m, g) in enumerate(zip(masses, gradient))), potential)
    placement = Stencil("lagrangian", (0,), count, first, step, (0,), parameter_first, parameter_step,
                        tuple(members), (), (drive - partial_derivative(potential, x),), energy)
    return Links(placement, (*masses, *slopes, *bias, *gradient), (*joints, *(s * v for s in slopes)))
