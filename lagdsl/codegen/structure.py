"""The structure of the mass matrix, found when the code is generated.

M = ∂²L/∂q'∂q' is symmetric; which of its entries are structurally zero is known from the
derived expressions. A natural system (M positive definite, no constraints) is solved by one of

  diagonal  M has no off-diagonal entry: q''_k = f_k / M_kk, and only the diagonal is stored;
  sparse    a straight-line LDLᵀ over the pattern of M, after a fill-reducing ordering
            (minimum degree), storing only the entries of the factor L that are not
            structurally zero. Small dense systems (n <= 4) take this form too: their
            factorisation is a few statements, not a loop;
  dense     the Cholesky loops over the full n x n array, where the pattern is (nearly) full;
  banded    the loops of a banded LDLᵀ, for the local form of a large model (codegen/loops.py):
            M_ij is stored at i·(w + 1) + (i - j) for i - w <= j <= i, w the half-bandwidth, and
            a band factors without fill;
  tree      M is never formed: K holds each link's record (m, s, w, g, d reals each, at
            j·4d) of a tree of point masses (mechanics/trees.py) and b the joint torques τ; the
            articulated-body recursion, the LDLᵀ of M eliminating leaves first, solves in O(n d²).

A large system with constraints solves the saddle-point system [[M, -Aᵀ], [A, 0]] by the sparse
form too, with every multiplier eliminated after the coordinates (`kkt_layout`); a small one
keeps the dense LU with partial pivoting.

All three work on the equilibrated matrix (unit diagonal, see docs/numerics.md) and report the
same reciprocal condition estimate: min d_j / max d_j over the pivots of LDLᵀ, which is
(min l_jj / max l_jj)² of the Cholesky factor (the tree's pivots are D_j / M_jj).
"""
from __future__ import annotations

import heapq
from dataclasses import dataclass
from functools import cached_property

import sympy

# Largest order whose dense factorisation is written out straight-line.
STRAIGHT_LINE_DENSE = 4
# Largest number of multiplications a straight-line factorisation may take, a constant plus so
# many per coordinate: beyond it the generated code would grow faster than the model (the fill
# of an ordering that cannot keep M sparse), and the dense loops are used.
STRAIGHT_LINE_WORK = (2000, 50)


@dataclass(frozen=True)
class MassLayout:
    """How M is stored and factored in the generated code.

    `order[p]` is the coordinate eliminated p-th. `columns[p]` lists, in increasing order, the
    positions i > p where column p of L is not structurally zero (fill included). Storage:
    column by column, the pivot d_p first, then L_ip for i in columns[p]; `slot` finds an entry.
    """
    kind: str                                   # "diagonal", "sparse", "dense", "banded" or "tree"
    n: int
    order: tuple[int, ...]
    columns: tuple[tuple[int, ...], ...]
    original: frozenset[tuple[int, int]]        # positions (i, p), i >= p, that M itself fills
    bandwidth: int = 0                          # of the banded layout
    multipliers: int = 0                        # the last positions that are constraint rows (kkt_layout)
    parents: tuple[int, ...] = ()               # of the tree layout: each link's parent link, -1 at the root
    axes: int = 0                               # of the tree layout: the components of a body, d
    constraint_rows: int = 0                    # of the tree layout: the rows of A after the records

    @property
    def coordinates(self) -> int:
        """How many positions are coordinates (the others, last, are constraint rows)."""
        return self.n - self.multipliers

    @property
    def size(self) -> int:
        """How many reals hold M (and then its factor)."""
        if self.kind == "banded":
            return self.n * (self.bandwidth + 1)
        if self.kind == "tree":
            return self.n * (self.record + self.constraint_rows)
        return self.n * self.n if self.kind == "dense" else self.n + sum(len(c) for c in self.columns)

    @property
    def record(self) -> int:
        """Reals of one link's record in the tree layout: m, s, w and g."""
        return TREE_RECORD * self.axes

    @property
    def compact(self) -> bool:
        return self.kind != "dense"

    @cached_property
    def slots(self) -> dict[tuple[int, int], int]:
        """(i, p) in elimination positions, i >= p -> index in the stored array."""
        table, index = {}, 0
        for p, rows in enumerate(self.columns):
            table[(p, p)] = index
            index += 1
            for i in rows:
                table[(i, p)] = index
                index += 1
        return table

    def coordinate_slot(self, k: int, j: int) -> int:
        """Where entry (k, j) of M (coordinates) is stored."""
        if self.kind == "dense":
            return k * self.n + j
        i, p = sorted((self.position[k], self.position[j]), reverse=True)
        return self.slots[(i, p)]

    @cached_property
    def position(self) -> dict[int, int]:
        """coordinate -> its elimination position."""
        return {coordinate: p for p, coordinate in enumerate(self.order)}

    @cached_property
    def rows(self) -> tuple[tuple[int, ...], ...]:
        """rows[i]: the positions p < i where row i of L is not structurally zero."""
        rows: list[list[int]] = [[] for _ in range(self.n)]
        for p, column in enumerate(self.columns):
            for i in column:
                rows[i].append(p)
        return tuple(tuple(r) for r in rows)

    def work(self) -> int:
        """Multiplications of the straight-line factorisation (the sum over columns of the
        products L_ik d_k L_jk it forms)."""
        rows = [set(r) for r in self.rows]
        return sum(len(rows[p]) + sum(len(rows[i] & rows[p]) for i in column)
                   for p, column in enumerate(self.columns))


def local_layout(n: int, bandwidth: int) -> MassLayout:
    """The layout of the local form's M (mechanics/families.py): diagonal, or a band."""
    kind = "banded" if bandwidth else "diagonal"
    return MassLayout(kind, n, tuple(range(n)), ((),) * n, frozenset((p, p) for p in range(n)), bandwidth)


TREE_RECORD = 4         # vectors of a link's record in the tree layout: m, s, w, g


def tree_layout(parents: tuple[int, ...], axes: int, constraint_rows: int = 0) -> MassLayout:
    """The layout of the tree form (mechanics/trees.py): link records, no M, then the
    constraint rows of A, n reals each."""
    n = len(parents)
    return MassLayout("tree", n, tuple(range(n)), ((),) * n, frozenset(), parents=parents, axes=axes,
                      constraint_rows=constraint_rows)


def mass_layout(mass_matrix: tuple[tuple[sympy.Expr, ...], ...]) -> MassLayout:
    """Choose the storage and factorisation of M from its structurally nonzero entries."""
    n = len(mass_matrix)
    neighbours = _coupled(mass_matrix)
    if not any(neighbours):
        return MassLayout("diagonal", n, tuple(range(n)), ((),) * n,
                          frozenset((p, p) for p in range(n)))
    order, columns = minimum_degree(neighbours)
    layout = MassLayout("sparse", n, order, columns, _stored(order, neighbours, n))
    dense = 2 * layout.size - n >= n * n
    fixed, per_coordinate = STRAIGHT_LINE_WORK
    if (dense and n > STRAIGHT_LINE_DENSE) or layout.work() > fixed + per_coordinate * n:
        return MassLayout("dense", n, tuple(range(n)), tuple(tuple(range(p + 1, n)) for p in range(n)),
                          frozenset((i, p) for p in range(n) for i in range(p, n)))
    return layout


def _coupled(mass_matrix) -> list[set[int]]:
    """For each coordinate, the others it shares a structurally nonzero entry of M with."""
    n = len(mass_matrix)
    return [{j for j in range(n) if j != k and (mass_matrix[k][j] != 0 or mass_matrix[j][k] != 0)}
            for k in range(n)]


def _stored(order: tuple[int, ...], neighbours: list[set[int]], diagonals: int) -> frozenset[tuple[int, int]]:
    """The entries (i, p), i >= p, in elimination positions that the matrix itself fills: its
    off-diagonal couplings and the diagonals of the first `diagonals` unknowns (the coordinates;
    a constraint row's diagonal is 0)."""
    position = {unknown: p for p, unknown in enumerate(order)}
    return frozenset((max(position[k], position[j]), min(position[k], position[j]))
                     for k in range(len(order)) for j in neighbours[k] | ({k} if k < diagonals else set()))


def minimum_degree(neighbours: list[set[int]], last: frozenset[int] = frozenset()
                   ) -> tuple[tuple[int, ...], tuple[tuple[int, ...], ...]]:
    """Greedy minimum-degree ordering with its symbolic factorisation (ties: lowest index); the
    vertices in `last` are eliminated after all the others.

    Eliminating a vertex joins its remaining neighbours into a clique: those are the rows of
    its column of L, and the new edges are the fill. -> (order, columns in positions).
    """
    graph = [set(s) for s in neighbours]
    heap = [(k in last, len(s), k) for k, s in enumerate(graph)]
    heapq.heapify(heap)
    eliminated: dict[int, int] = {}
    pattern: list[set[int]] = []
    while heap:
        _, degree, k = heapq.heappop(heap)
        if k in eliminated or degree != len(graph[k]):
            continue                                  # a stale entry: k's degree changed
        eliminated[k] = len(pattern)
        clique = graph[k]
        pattern.append(set(clique))
        for j in clique:
            graph[j].discard(k)
            graph[j] |= clique - {j}
            heapq.heappush(heap, (j in last, len(graph[j]), j))
        graph[k] = set()
    order = tuple(sorted(eliminated, key=eliminated.__getitem__))
    columns = tuple(tuple(sorted(eliminated[j] for j in rows)) for rows in pattern)
    return order, columns


# The smallest saddle-point system (coordinates and constraints) solved in the sparse form: the
# library's mechanisms (Andrews' has 13 unknowns) keep the dense LU and its condition estimate.
SPARSE_KKT_ORDER = 16


def kkt_layout(mass_matrix: tuple[tuple[sympy.Expr, ...], ...],
               constraint_rows: list[tuple[sympy.Expr, ...]]) -> MassLayout | None:
    """The sparse layout of the saddle-point matrix K = [[M, -Aᵀ], [A, 0]] (M positive definite,
    the rows of A given), or None where the dense LU with partial pivoting serves.

    The generated code factors the symmetric Kₛ = [[M, -Aᵀ], [-A, 0]] (the constraint rows
    negated, and their right-hand sides) as LDLᵀ without pivoting. That is safe when every
    coordinate is eliminated before any multiplier: the coordinates' pivots are those of M's
    Cholesky factorisation (positive), and what is left for the multipliers is the Schur
    complement -A M⁻¹ Aᵀ, negative definite while the constraints are independent (a pivot that
    is not negative means they are not). Minimum degree orders each group.
    """
    n, m = len(mass_matrix), len(constraint_rows)
    size = n + m
    if m == 0 or size < SPARSE_KKT_ORDER:
        return None
    neighbours = _coupled(mass_matrix) + [set() for _ in range(m)]
    for i, row in enumerate(constraint_rows):
        for j, entry in enumerate(row):
            if entry != 0:
                neighbours[n + i].add(j)
                neighbours[j].add(n + i)
    order, columns = minimum_degree(neighbours, last=frozenset(range(n, size)))
    layout = MassLayout("sparse", size, order, columns, _stored(order, neighbours, n), multipliers=m)
    fixed, per_unknown = STRAIGHT_LINE_WORK
    return layout if layout.work() <= fixed + per_unknown * size else None


# A band LU of E pays when its width 2 lower + upper + 1 is at most this fraction of the order.
BANDED_JACOBIAN = 4


@dataclass(frozen=True)
class JacobianLayout:
    """How an implicit integrator stores the derivatives of the residual
    R = [f - M q'' + Aᵀλ; γ - A q''], Dq = ∂R/∂q, Dv = ∂R/∂q' and Dz = ∂R/∂(q'', λ) = -K, from
    which radau5 forms its iteration matrices E(g) = [g Dz_a + Dv + Dq/g | Dz_λ] (radau5.c).
    Each is a matrix of `order` = n + constraints rows, stored

      dense   row-major, order x order (the columns of Dq and Dv past n stay zero);
      banded  without constraints, when R couples near coordinates only (a chain): row r holds
              columns r - lower .. r + upper, at r·(lower + upper + 1) + c - r + lower.

    A dense layout has lower = upper = order - 1, so the band LU of radau5 covers it too."""
    kind: str                                   # "dense" or "banded"
    order: int
    lower: int
    upper: int

    @property
    def width(self) -> int:
        return self.lower + self.upper + 1 if self.kind == "banded" else self.order

    @property
    def size(self) -> int:
        """How many reals hold each of Dq, Dv and Dz."""
        return self.order * self.width

    def slot(self, row: int, column: int) -> int:
        if self.kind == "dense":
            return row * self.order + column
        return row * self.width + column - row + self.lower


def jacobian_layout(order: int, constrained: bool, pattern) -> JacobianLayout:
    """The layout for the structurally nonzero positions (row, column) of Dq, Dv and Dz."""
    lower = max((row - column for row, column in pattern), default=0)
    upper = max((column - row for row, column in pattern), default=0)
    lower, upper = max(lower, 0), max(upper, 0)
    if not constrained and BANDED_JACOBIAN * (2 * lower + upper + 1) <= order:
        return JacobianLayout("banded", order, lower, upper)
    return JacobianLayout("dense", order, order - 1, order - 1)
