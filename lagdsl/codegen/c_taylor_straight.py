"""The first orders of the Taylor series straight-line: one C function per order k, every
convolution written out with its indices and weights as constants.

The loops of lag_taylor_series (c_taylor.py) are short (k + 1 products at order k) and each
ends at another k: for a small graph their branches, not the products, take the time. Written
out, order k of the double pendulum is a hundred products and sums with nothing to predict,
and the whole series costs 0.6 µs a step instead of 1.05 µs (benchmarks/README.md). The code
grows like the graph times k², and gcc's time with it (the Pleiades to order 21: 20 s), so
orders are written out while the products so far stay within STRAIGHT_TERMS, and the higher
orders of a large graph (and the orders beyond double's of an extended-precision build) keep
the loops. Each order is a function of its own, called through a table, so that the compiler
optimises each apart: one function with every order took it twice as long.

Sums are added pairwise, (a + b) + (c + d), which the processor overlaps.

A convolution weighted by j over a coordinate, Σ j a_j c_{k-j} / k (sin, cos, exp, ... of q or
of a sum of q's), reads j a_j as what it is, the velocity's coefficient (a')_{j-1}: q_j = q'_{j-1}
/ j, so that j q_j = q'_{j-1}. Its terms then all carry the weight 1/k, multiplied once after the
sum: k + 1 multiplications an order where the weights took 2k (the double pendulum's six sines
and cosines are half its products).
"""
from __future__ import annotations

from dataclasses import replace

import sympy

from .taylor import J, K, OWN, RECURRENCES, Coefficient, Convolution, zeroth
from .taylor_graph import Node

# At most so many products over all straight-line orders (the double pendulum's 21 orders take
# 2,600 and compile in 1.7 s). The Pleiades' graph (21 pairs) takes about 100 k products at order
# k: 8,000 writes out its orders 1 .. 10, all that tolerances down to 1e-8 use (order 11), where 4,000
# wrote out 1 .. 7; its steps then cost a fifth less at 1e-8 and 15% less at 1e-12, and gcc takes
# 8.4 s instead of 5.5 s (AMD EPYC, benchmarks/README.md, issue 34).
STRAIGHT_TERMS = 8000
ROW = "s[{}][{}]"


def order_products(graph, k: int) -> int:
    """About how many products order k takes: each node's convolutions have k + 1 terms."""
    return int(round(graph.cost() * (k + 1)))


def straight_orders(graph, highest: int) -> int:
    """The orders 1 .. S written out: the most whose products stay within STRAIGHT_TERMS."""
    total, orders = 0, 0
    for k in range(1, highest + 1):
        total += order_products(graph, k)
        if total > STRAIGHT_TERMS:
            break
        orders = k
    return orders


def pairwise(terms: list[str]) -> str:
    """The sum of terms as a balanced tree of additions."""
    if len(terms) == 1:
        return terms[0]
    half = len(terms) // 2
    return f"({pairwise(terms[:half])} + {pairwise(terms[half:])})"


class StraightPrinter:
    """The statements of order k of every node, with k a number."""

    def __init__(self, series):
        self.series = series                  # the SeriesPrinter: constants, sums, the graph
        self.graph, self.printer = series.graph, series.printer

    def node(self, index: int, node: Node, k: int) -> str | None:
        if node.kind in ("state", "solution"):
            return None
        if node.kind == "time":
            return f"{ROW.format(index, k)} = {1 if k == 1 else 0};"
        if node.kind == "lin":
            return f"{ROW.format(index, k)} = {self.series.linear(node, str(k))};"
        return f"{ROW.format(index, k)} = {self.recurrence(index, node, k)};"

    def recurrence(self, index: int, node: Node, k: int) -> str:
        recurrence = RECURRENCES[node.kind]
        rows = dict(zip(recurrence.operands, node.operands))
        rows[OWN] = index
        known = {zeroth(name): sympy.Symbol(ROW.format(row, 0)) for name, row in rows.items()}
        known.update({sympy.Symbol(name, real=True): value
                      for name, value in zip(recurrence.parameters, node.parameters)})
        known[K] = sympy.Integer(k)
        power, rest = recurrence.split_divisor()
        inverse = sympy.Rational(1, k ** power)     # 1/k is folded into the weights, numbers here
        products = []
        for sign, term in recurrence.terms:
            if isinstance(term, Coefficient):
                products.append((sign * inverse * term.weight.xreplace(known), ROW.format(rows[term.operand], k)))
                continue
            if self.velocity_term(term, rows[term.left], 1) is not None:
                products += [(sign * inverse, f"{self.velocity_term(term, rows[term.left], j)}*"
                                              f"{ROW.format(rows[term.right], k - j)}")
                             for j in range(term.first, k - term.gap + 1)]
                continue
            for j in range(term.first, k - term.gap + 1):
                if term.left == term.right and term.weight == 1 and term.first == term.gap and 2 * j > k:
                    break                    # a square: each pair once, doubled
                weight = sign * inverse * term.weight.xreplace({**known, J: sympy.Integer(j)})
                if term.left == term.right and term.weight == 1 and term.first == term.gap and 2 * j < k:
                    weight *= 2
                factors = f"{ROW.format(rows[term.left], j)}*{ROW.format(rows[term.right], k - j)}"
                products.append((weight, factors))
        value = self.weighted_sum([(weight, factors) for weight, factors in products if weight != 0])
        return value if rest == 1 else f"{value} * z{index}"

    def velocity_term(self, term, operand: int, j: int) -> str | None:
        """j a_j as (a')_{j-1} (C) when `term` is Σ j a_j c_{k-j} (a = left) and a a coordinate or
        a sum of coordinates, whose derivative is the velocities' rows (y = (q, q')); else None."""
        if not (isinstance(term, Convolution) and term.weight == J and term.first >= 1):
            return None
        coordinates, node = self.graph.states // 2, self.graph.nodes[operand]
        if node.kind == "state" and operand < coordinates:
            return ROW.format(operand + coordinates, j - 1)
        if node.kind == "lin" and all(self.graph.nodes[o].kind == "state" and o < coordinates for o in node.operands):
            velocity = replace(node, operands=tuple(o + coordinates for o in node.operands), offset=sympy.S.Zero)
            return f"({self.series.linear(velocity, str(j - 1))})"
        return None

    def weighted_sum(self, products: list[tuple[sympy.Expr, str]]) -> str:
        """Σ weight · factors, pairwise; one weight common to several terms multiplies their sum."""
        if not products:
            return "0"
        weights = {weight for weight, _ in products}
        if len(products) > 1 and len(weights) == 1 and abs(products[0][0]) != 1:
            return f"{pairwise([factors for _, factors in products])}*{self.printer.parenthesize(products[0][0], 50)}"
        return pairwise([self.weighted(weight, factors) for weight, factors in products])

    def weighted(self, weight: sympy.Expr, factors: str) -> str:
        if weight == 1:
            return factors
        if weight == -1:
            return f"-{factors}"
        return f"{self.printer.parenthesize(weight, 50)}*{factors}"

    def right_side(self, k: int) -> list[str]:
        """r = b_k - Σ_{j=1..k} K_j x_{k-j} for the entries of K that vary."""
        lines = [f"r[{i}] = {self.series.scaled(value, str(k))};" for i, value in enumerate(self.graph.rhs)]
        for row, column, value in self.graph.matrix:
            if value.node is None:
                continue
            x = self.graph.solution[column]
            tail = pairwise([f"{ROW.format(value.node, j)}*{ROW.format(x, k - j)}" for j in range(1, k + 1)])
            scale = "" if value.scale == 1 else f"{self.series.constant(value.scale)} * "
            lines.append(f"r[{row}] -= {scale}{tail};")
        return lines

    def order(self, k: int) -> list[str]:
        """The body of lag_taylor_order_K."""
        lines = [line for i, node in enumerate(self.graph.nodes) if (line := self.node(i, node, k))]
        return lines + self.right_side(k)

    def next_order(self, k: int, fused: str) -> list[str]:
        """The end of lag_taylor_order_K when the solve is fused into it (`fused` "inverse": the
        product with K_0^-1 that lag_taylor_series keeps in c; "constant": the constant M's
        substitution): x_k = K_0^-1 r, then q_{k+1} = q'_k / (k+1) and q'_{k+1} = x_k / (k+1), what
        the loop of lag_taylor_series does after an order, the same operations in the same order."""
        solution, coordinates = self.graph.solution, self.graph.states // 2
        if fused == "inverse":
            x = [f"x{i}" for i in range(len(solution))]
            lines = [f"const real x{i} = " + " + ".join(f"c->inverse[{i}][{j}] * r[{j}]" for j in range(len(solution)))
                     + ";" for i in range(len(solution))]
        else:
            x = [f"r[{i}]" for i in range(len(solution))]
            lines = ["lag_substitute(c->sys->mass, c->sys->mass_scale, r);"]
        lines.append(f"const real inv_next = (real)1 / {k + 1};")
        lines += [f"{ROW.format(row, k)} = {x[i]};" for i, row in enumerate(solution)]
        for i in range(coordinates):
            lines += [f"{ROW.format(i, k + 1)} = {ROW.format(coordinates + i, k)} * inv_next;",
                      f"{ROW.format(coordinates + i, k + 1)} = {ROW.format(solution[i], k)} * inv_next;"]
        return lines
