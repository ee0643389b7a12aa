"""A kernel block -> the graph of elementary operations whose Taylor coefficients a Taylor
integrator computes (the recurrences are in taylor.py, the C in c_taylor.py).

The block is the `system` block of the kernel (or `constant_mass` and `system`): after CSE, a
list of named intermediates and the entries of K and b in K x = b. Each intermediate becomes
either a constant (it reads only parameters: its coefficients beyond order 0 vanish, so it
costs nothing per order) or `scale · node`, a constant times a node of the graph. Nodes are

  state      y_i: q_k = q'_{k-1} / k and q'_k = x_{k-1} / k come from the order before
  time       t: (t0, 1, 0, 0, ...)
  lin        offset + Σ scale_i x_i (sums, and constant multiples that must be a series)
  solution   x_i of K x = b, order by order (c_taylor.py)
  RECURRENCES[kind]: products, quotients, powers and functions, with their companions

Products of several factors become a chain of Cauchy products over the numerator and one over
the denominator, joined by one quotient; x^2 is a square (half a product), x^3 = x^2 x,
x^4 = (x^2)^2, other powers the power recurrence; constants are gathered into the scale, so
`2*m*l*sin(q)` is one node, sin(q), with scale 2 m l. One identity is applied, since the
derivation leaves it in mass matrices written in Cartesian coordinates: s sin²a + s cos²a = s
(and s cosh²a - s sinh²a = s) inside a sum, which makes l²(sin²θ + cos²θ) the constant it is
instead of two squares per order.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import sympy

from ..errors import InternalError
from .taylor import RECURRENCES

FUNCTIONS = {sympy.sin: "sin", sympy.cos: "cos", sympy.tan: "tan", sympy.asin: "asin", sympy.acos: "acos",
             sympy.atan: "atan", sympy.sinh: "sinh", sympy.cosh: "cosh", sympy.tanh: "tanh", sympy.exp: "exp",
             sympy.log: "log", sympy.Abs: "abs", sympy.sign: "sign", sympy.Heaviside: "heaviside"}
# Companion series (taylor.py): built from the operation's argument `a` (or y, x) and its own value u.
_A, _X, _Y, _U = (sympy.Symbol(name, real=True) for name in ("a", "x", "y", "u"))
COMPANIONS = {
    "sin": {"c": sympy.cos(_A)}, "cos": {"s": sympy.sin(_A)},
    "sinh": {"c": sympy.cosh(_A)}, "cosh": {"s": sympy.sinh(_A)},
    "tan": {"w": _U**2}, "tanh": {"w": _U**2},
    "atan": {"d": 1 + _A**2}, "asin": {"w": sympy.sqrt(1 - _A**2)}, "acos": {"w": sympy.sqrt(1 - _A**2)},
    "atan2": {"d": _X**2 + _Y**2},
}
ARGUMENTS = {"atan2": (_Y, _X)}          # the operands a function's arguments bind (else a)


@dataclass(frozen=True)
class Node:
    kind: str                                   # "state", "time", "lin", "solution" or a RECURRENCES name
    operands: tuple[int, ...] = ()              # in the recurrence's operand order (lin: the terms' nodes)
    scales: tuple[sympy.Expr, ...] = ()         # lin: the terms' constant factors
    offset: sympy.Expr = sympy.S.Zero           # lin: the constant term
    parameters: tuple[sympy.Expr, ...] = ()     # the recurrence's instance constants (pow: alpha)
    index: int = -1                             # state, solution: which y_i or x_i


@dataclass(frozen=True)
class Scaled:
    """An expression in the graph: scale · node, or the constant `scale` when node is None."""

    scale: sympy.Expr
    node: int | None = None

    def __post_init__(self):
        if isinstance(self.scale, int):         # Scaled(1, node): exact, so that 1 ** -1 stays 1
            object.__setattr__(self, "scale", sympy.Integer(self.scale))


@dataclass(frozen=True)
class SeriesGraph:
    nodes: tuple[Node, ...]
    constants: tuple[tuple[str, sympy.Expr], ...]          # the block's constant intermediates, in order
    matrix: tuple[tuple[int, int, Scaled], ...]            # K's entries (row, column, value), both triangles
    stored: tuple[tuple[tuple[int, ...], Scaled], ...]     # K's stores as the system block makes them
    rhs: tuple[Scaled, ...]                                # b
    states: int                                            # nodes 0 .. states - 1 are y
    solution: tuple[int, ...]                              # the nodes of x
    inputs: tuple[tuple[str, str], ...]                    # the parameters the block reads: (name, "par[i]")

    def kinds(self) -> tuple[str, ...]:
        return tuple(sorted({node.kind for node in self.nodes} & set(RECURRENCES)))

    def cost(self) -> float:
        """The work per order, in Cauchy products: each node's recurrence (taylor.Recurrence.cost),
        a twentieth per term of a sum, one per entry of K that varies (its tail Σ K_j x_{k-j})."""
        work = sum(RECURRENCES[node.kind].cost if node.kind in RECURRENCES else
                   len(node.operands) / 20 for node in self.nodes)
        return work + sum(value.node is not None for _, _, value in self.matrix)


@dataclass
class GraphBuilder:
    """Builds the nodes of expressions one by one (memoised by expression and by node)."""

    constant_names: set = field(default_factory=set)
    nodes: list = field(default_factory=list)
    memo: dict = field(default_factory=dict)

    def add(self, node: Node) -> int:
        key = ("node", node)
        if key not in self.memo:
            self.nodes.append(node)
            self.memo[key] = len(self.nodes) - 1
        return self.memo[key]

    def is_constant(self, expr: sympy.Expr) -> bool:
        return all(s.name in self.constant_names for s in expr.free_symbols)

    def value(self, expr: sympy.Expr) -> Scaled:
        """expr as scale · node (memoised: a shared subexpression is one node)."""
        if self.is_constant(expr):
            return Scaled(expr)
        if expr not in self.memo:
            self.memo[expr] = self._decompose(expr)
        return self.memo[expr]

    def node(self, expr: sympy.Expr) -> int:
        """expr as a node of its own (a constant multiple becomes a one-term lin node)."""
        scaled = self.value(expr)
        if scaled.node is None:
            raise InternalError(f"the series graph needs a node for the constant {expr}")
        return scaled.node if scaled.scale == 1 else self.add(Node("lin", (scaled.node,), (scaled.scale,)))

    def _decompose(self, expr: sympy.Expr) -> Scaled:
        if expr.is_Add:
            return self.linear([self.value(term) for term in expr.args])
        if expr.is_Mul or expr.is_Pow and expr.exp.is_Integer:
            return self.product(expr.args if expr.is_Mul else (expr,))
        if expr.is_Pow:
            return Scaled(1, self.power(expr.base, expr.exp))
        if isinstance(expr, (sympy.Min, sympy.Max)):
            return Scaled(1, self.extremum(type(expr), expr.args))
        if expr.func == sympy.atan2:
            return Scaled(1, self.function("atan2", expr))
        if expr.func in FUNCTIONS:
            return Scaled(1, self.function(FUNCTIONS[expr.func], expr))
        if isinstance(expr, sympy.DiracDelta):
            return Scaled(sympy.S.Zero)                     # zero away from its argument's root, as printed
        raise InternalError(f"no Taylor recurrence for {expr.func.__name__} (in {expr})")

    def linear(self, terms: list[Scaled]) -> Scaled:
        offset, scales = sympy.S.Zero, {}
        for term in terms:
            if term.node is None:
                offset += term.scale
            else:
                scales[term.node] = scales.get(term.node, sympy.S.Zero) + term.scale
        offset += self.pythagoras(scales)
        scales = {node: scale for node, scale in scales.items() if scale != 0}
        if not scales:
            return Scaled(offset)
        if offset == 0 and len(scales) == 1:
            (node, scale), = scales.items()
            return Scaled(scale, node)
        order = sorted(scales)
        return Scaled(1, self.add(Node("lin", tuple(order), tuple(scales[n] for n in order), offset)))

    def pythagoras(self, scales: dict) -> sympy.Expr:
        """s sin²a + s cos²a -> s and s cosh²a - s sinh²a -> s: sets both terms' scales in
        `scales` to zero and returns the constant they sum to."""
        squares = {}
        for n in scales:
            root = self.nodes[self.nodes[n].operands[0]] if self.nodes[n].kind == "sq" else None
            if root is not None and root.kind in ("sin", "cos", "sinh", "cosh"):
                squares[(root.kind, root.operands[0])] = n
        found = sympy.S.Zero
        for first, second, sign in (("sin", "cos", 1), ("sinh", "cosh", -1)):
            for (kind, argument), n in squares.items():
                other = squares.get((second, argument))
                if kind == first and other is not None and sympy.expand(scales[n] - sign * scales[other]) == 0:
                    found += scales[other]
                    scales[n] = scales[other] = sympy.S.Zero
        return found

    def product(self, factors) -> Scaled:
        scale, powers = sympy.S.One, {}
        for factor in factors:
            base, exponent = (factor.base, int(factor.exp)) if factor.is_Pow and factor.exp.is_Integer else (factor, 1)
            term = self.value(base)
            scale *= term.scale ** exponent
            if term.node is not None:
                powers[term.node] = powers.get(term.node, 0) + exponent
        numerator = self.chain([self.integer_power(n, e) for n, e in sorted(powers.items()) if e > 0])
        denominator = self.chain([self.integer_power(n, -e) for n, e in sorted(powers.items()) if e < 0])
        if denominator is None:
            return Scaled(scale, numerator)
        if numerator is None:
            return Scaled(scale, self.add(Node("inv", (denominator,))))
        return Scaled(scale, self.add(Node("div", (numerator, denominator))))

    def chain(self, nodes: list[int]) -> int | None:
        if not nodes:
            return None
        result = nodes[0]
        for node in nodes[1:]:
            result = self.add(Node("mul", (result, node)))
        return result

    def integer_power(self, node: int, exponent: int) -> int:
        """node^exponent (exponent >= 1) by squares and products: x^3 = x^2 x, x^4 = (x^2)^2
        (the power recurrence would divide by the zeroth coefficient, which may vanish)."""
        if exponent == 1:
            return node
        if exponent % 2:
            return self.add(Node("mul", (self.integer_power(node, exponent - 1), node)))
        return self.add(Node("sq", (self.integer_power(node, exponent // 2),)))

    def power(self, base: sympy.Expr, exponent: sympy.Expr) -> int:
        if not self.is_constant(exponent):                  # a^b = exp(b log a)
            return self.node(sympy.exp(exponent * sympy.log(base)))
        if exponent == sympy.S.Half:
            return self.add(Node("sqrt", (self.node(base),)))
        return self.add(Node("pow", (self.node(base),), parameters=(exponent,)))

    def extremum(self, kind, args) -> int:
        result = self.node(args[0])
        for arg in args[1:]:
            result = self.add(Node("min" if kind is sympy.Min else "max", (result, self.node(arg))))
        return result

    def function(self, kind: str, expr: sympy.Expr) -> int:
        """expr = φ(args) with its companions: those built from the arguments first (read at
        order k), then the node, then those that read it (read below order k)."""
        args = expr.args[:2] if kind == "atan2" else expr.args[:1]
        bound = dict(zip(ARGUMENTS.get(kind, (_A,)), args))
        recurrence, companions = RECURRENCES[kind], COMPANIONS.get(kind, {})
        names = recurrence.operands[len(args):]
        early = {name: self.node(companions[name].xreplace(bound)) for name in names if name not in recurrence.lagging}
        operands = tuple(self.node(arg) for arg in args)
        if len(early) == len(names):
            return self.add(Node(kind, operands + tuple(early[name] for name in names)))
        # A lagging companion reads this node (tan: w = u^2) or is its partner (sin: cos a, whose
        # own companion is this sin a): the node is made first and known by its expression.
        self.nodes.append(Node(kind, operands))
        node = len(self.nodes) - 1
        self.memo[expr] = Scaled(1, node)
        late = {name: self.node(companions[name].xreplace({**bound, _U: expr})) for name in names if name not in early}
        self.nodes[node] = Node(kind, operands + tuple({**early, **late}[name] for name in names))
        self.memo[("node", self.nodes[node])] = node
        return node


def series_graph(kernel) -> SeriesGraph:
    """The graph of kernel.system, or of its rewriting by taylor_rewrite if that is cheaper:
    y as nodes 0 .. 2n - 1, the block's intermediates, K and b as scaled nodes or constants, x as
    the last nodes. (A constant M has a block of its own, kernel.constant_mass, which the series
    do not need: lag_system_prepare factors it.)"""
    from .taylor_rewrite import rewritten_block
    graphs = [block_graph(kernel, block) for block in (kernel.system, rewritten_block(kernel.system))
              if block is not None]
    return min(graphs, key=lambda graph: graph.cost())


def block_graph(kernel, block) -> SeriesGraph:
    """The graph of one system block (the kernel gives the sizes and K's layout)."""
    builder = GraphBuilder()
    inputs = tuple((name, source) for name, source in block.inputs if source.startswith("par["))
    builder.constant_names.update(name for name, _ in inputs)
    state_names = {source: name for name, source in block.inputs if source.startswith("y[")}
    for i in range(2 * kernel.n):
        node = builder.add(Node("state", index=i))
        if f"y[{i}]" in state_names:
            builder.memo[sympy.Symbol(state_names[f"y[{i}]"], real=True)] = Scaled(1, node)
    time = sympy.Symbol("t", real=True)
    if any(time in expr.free_symbols for expr in block_expressions(block)):
        builder.memo[time] = Scaled(1, builder.add(Node("time")))
    constants = []
    for name, expr in block.assignments:
        if builder.is_constant(expr):
            builder.constant_names.add(name)
            constants.append((name, expr))
        else:
            builder.memo[sympy.Symbol(name, real=True)] = builder.value(expr)
    stored = tuple((store.index, builder.value(store.value)) for store in block.stores if store.array == "K")
    rhs = {store.index[0]: builder.value(store.value) for store in block.stores if store.array == "b"}
    solution = tuple(builder.add(Node("solution", index=i)) for i in range(kernel.size))
    graph = SeriesGraph(tuple(builder.nodes), tuple(constants), _full_matrix(kernel, stored), stored,
                        tuple(rhs.get(i, Scaled(sympy.S.Zero)) for i in range(kernel.size)), 2 * kernel.n, solution,
                        inputs)
    return without_dead_nodes(graph)


def without_dead_nodes(graph: SeriesGraph) -> SeriesGraph:
    """The graph without the nodes neither K nor b needs (the squares an identity replaced),
    renumbered in the same order: y first, x last."""
    live = set(range(graph.states)) | set(graph.solution)
    work = [value.node for value in graph.rhs] + [value.node for _, value in graph.stored]
    while work:
        node = work.pop()
        if node is not None and node not in live:
            live.add(node)
            work.extend(graph.nodes[node].operands)
    number = {old: new for new, old in enumerate(sorted(live))}

    def renumbered(value: Scaled) -> Scaled:
        return value if value.node is None else Scaled(value.scale, number[value.node])
    nodes = tuple(replace(node, operands=tuple(number[o] for o in node.operands))
                  for old, node in enumerate(graph.nodes) if old in live)
    return SeriesGraph(nodes, graph.constants, tuple((r, c, renumbered(v)) for r, c, v in graph.matrix),
                       tuple((index, renumbered(v)) for index, v in graph.stored),
                       tuple(renumbered(v) for v in graph.rhs), graph.states, tuple(number[n] for n in graph.solution),
                       graph.inputs)


def _full_matrix(kernel, stored) -> tuple[tuple[int, int, Scaled], ...]:
    """K's nonzero entries, both triangles: a compact layout stores M's lower triangle (M is
    symmetric) and, with constraints, the rows A of [[M, -Aᵀ], [A, 0]], whose -Aᵀ is implied."""
    compact = kernel.layout is not None and kernel.layout.compact
    entries = []
    for (row, column), value in stored:
        if value.node is None and value.scale == 0:
            continue
        entries.append((row, column, value))
        if compact and row != column:
            mirrored = value if row < kernel.n else Scaled(-value.scale, value.node)
            entries.append((column, row, mirrored))
    return tuple(sorted(entries, key=lambda entry: (entry[0], entry[1])))


def block_expressions(block):
    return [expr for _, expr in block.assignments] + [store.value for store in block.stores]
