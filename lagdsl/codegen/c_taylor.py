"""SeriesGraph -> the C that computes the Taylor coefficients of the state (for integrators/c/taylor.c).

Printed into the model part of a generated file (templates/c/taylor_series.c.j2):

  lag_taylor_KIND      one function per recurrence the model uses, u_k for k >= 1, printed from
                       its entry in taylor.RECURRENCES (so the C is the table, not a copy of it)
  lag_taylor_series    the coefficients s[i][0 .. order] of every node at (t, y), order by order:
                       loops over the order k, straight-line over the nodes within an order

The accelerations come order by order from M(t) x(t) = f(t) (with constraints K = [[M, -Aᵀ],
[A, 0]] and x = (q'', λ)): with K = Σ K_j τ^j and x = Σ x_k τ^k,

    K_0 x_k = f_k - Σ_{j=1..k} K_j x_{k-j},

so K_0 is factored once per step, with the factorisation the model's layout already uses, and
each order costs one substitution. A constant M (factored once per run) and a diagonal one
cost nothing beyond that. Then q_{k+1} = q'_k / (k+1) and q'_{k+1} = x_k / (k+1).
"""
from __future__ import annotations

import re

import sympy

from . import template_environment
from .taylor import J, K, OWN, RECURRENCES, Coefficient, Convolution, Recurrence, zeroth
from .c_taylor_straight import StraightPrinter, straight_orders
from .taylor_graph import Node, Scaled, SeriesGraph, series_graph

# The series of node i is the row s[i] of the work array; the order lives in the column.
ROW = "s[{}]"
# The highest order of a build whose `real` has REAL_DIG digits: Jorba and Zou's order for a
# tolerance of the precision's epsilon, -ln(eps)/2 + 1 = 1.15 digits + 1, and a margin (22 in
# double, 27 in long double, 42 in __float128).
MAX_ORDER = "((116 * REAL_DIG) / 100 + 3)"
DOUBLE_DIGITS = 17


def max_order(digits: int) -> int:
    """MAX_ORDER for `digits` (what the C macro computes)."""
    return (116 * digits) // 100 + 3


# The largest K whose inverse lag_taylor_series forms at order 0 (from the factor, column by
# column) and multiplies by at every order: a substitution's steps wait on one another and
# divide by the pivots, a product with the inverse does not; beyond this order, n² per order
# costs more than the factor's sparse substitution.
INVERSE_LARGEST = 4


def helper_name(kind: str) -> str:
    return f"lag_taylor_{kind}"


def helper_arrays(recurrence: Recurrence) -> tuple[str, ...]:
    """The series a helper reads: its operands, and its own earlier orders if a term reads them."""
    read = {t.operand for _, t in recurrence.terms if isinstance(t, Coefficient)}
    read |= {name for _, t in recurrence.terms if isinstance(t, Convolution) for name in (t.left, t.right)}
    return recurrence.operands + ((OWN,) if OWN in read else ())


def helper(recurrence: Recurrence, printer) -> str:
    """The C function that returns u_k (k >= 1) by `recurrence`. The caller passes `factor`,
    1 / divisor (the reciprocals of k and of the zeroth coefficients are taken once, not per
    node and order), when the divisor is not 1."""
    arrays = helper_arrays(recurrence)
    signature = ", ".join([f"const real *{name}" for name in arrays] + ["int k"]
                          + [f"real {name}" for name in recurrence.parameters]
                          + (["real factor"] if recurrence.divisor != 1 else []))
    lines = [f"/* u = {recurrence.name}({', '.join(recurrence.operands)}): {recurrence.ode} */",
             f"static inline real {helper_name(recurrence.name)}({signature})", "{"]
    if not recurrence.terms:
        lines += [f"    (void){name};" for name in arrays] + ["    (void)k;", "    return 0;", "}"]
        return "\n".join(lines)
    if any(isinstance(term, Convolution) for _, term in recurrence.terms):
        lines += ["    real s0 = 0, s1 = 0, s2 = 0, s3 = 0;", "    int j;"]
    lines.append("    real sum = 0;")
    for sign, term in recurrence.terms:
        lines += _term_lines(sign, term, printer)
    if any(isinstance(term, Convolution) for _, term in recurrence.terms):
        lines.append("    sum += (s0 + s1) + (s2 + s3);")
    lines += ["    return sum * factor;" if recurrence.divisor != 1 else "    return sum;", "}"]
    return "\n".join(lines)


def _c(expr: sympy.Expr, printer) -> str:
    """A weight or divisor: the zeroth coefficient a0 as a[0], j and k as the C ints."""
    names = {symbol: sympy.Symbol(f"{symbol.name[:-1]}[0]") for symbol in expr.free_symbols
             if symbol.name.endswith("0")}
    names.update({J: sympy.Symbol("j"), K: sympy.Symbol("k")})
    return printer.doprint(expr.xreplace(names))


def _term_lines(sign: int, term, printer) -> list[str]:
    """A term added into sum (a coefficient) or into the four partial sums s0 .. s3 (a
    convolution, four products at a time: the additions into one partial sum wait for each
    other, the four do not, so a sum of k products takes about k/4 of the adder's latency)."""
    add = "+=" if sign > 0 else "-="
    if isinstance(term, Coefficient):
        weight = "" if term.weight == 1 else f"{_c(term.weight, printer)} * "
        return [f"    sum {add} {weight}{term.operand}[k];"]

    def product(offset: int) -> str:
        j = "j" if offset == 0 else f"j + {offset}"
        weight = term.weight.xreplace({J: J + offset})
        factor = "" if weight == 1 else f"{_c(weight, printer)} * " if weight.is_Atom else f"({_c(weight, printer)}) * "
        right = "k - j" if offset == 0 else f"k - j - {offset}"
        return f"{factor}{term.left}[{j}] * {term.right}[{right}]"
    if term.left == term.right and term.weight == 1 and term.first == term.gap:
        # Σ_j x_j x_{k-j} over a symmetric range: each pair once, doubled, and the middle term.
        x = term.left
        return [f"    for (j = {term.first}; 2 * j + 6 < k; j += 4) {{",
                *(f"        s{i} {add} 2 * {product(i)};" for i in range(4)), "    }",
                "    for (; 2 * j < k; ++j)", f"        s0 {add} 2 * {product(0)};",
                "    if (k % 2 == 0)", f"        s1 {add} {x}[k / 2] * {x}[k / 2];"]
    last = "k" if term.gap == 0 else f"k - {term.gap}"
    return [f"    for (j = {term.first}; j + 3 <= {last}; j += 4) {{",
            *(f"        s{i} {add} {product(i)};" for i in range(4)), "    }",
            f"    for (; j <= {last}; ++j)", f"        s0 {add} {product(0)};"]


def tail_helper() -> str:
    return "\n".join([
        "/* Σ_{j=1..k} a_j b_{k-j}: what the terms of order >= 1 of a matrix entry a contribute to",
        " * order k of its product with b (b's order k is the unknown). */",
        "static inline real lag_taylor_tail(const real *a, const real *b, int k)", "{",
        "    real s0 = 0, s1 = 0, s2 = 0, s3 = 0;", "    int j;",
        "    for (j = 1; j + 3 <= k; j += 4) {",
        *(f"        s{i} += a[j + {i}] * b[k - j - {i}];".replace(" + 0]", "]").replace(" - 0]", "]")
          for i in range(4)), "    }",
        "    for (; j <= k; ++j)", "        s0 += a[j] * b[k - j];",
        "    return (s0 + s1) + (s2 + s3);", "}"])


class SeriesPrinter:
    """The statements of lag_taylor_series for one graph."""

    def __init__(self, graph: SeriesGraph, printer):
        self.graph, self.printer = graph, printer
        self.hoisted: dict[sympy.Expr, str] = {}

    def constant(self, expr: sympy.Expr) -> str:
        """A constant as C: a number or a name as itself, anything else hoisted into a `kN`."""
        if expr.is_Number or expr.is_Symbol or (-expr).is_Symbol:
            return self.printer.doprint(expr)
        if expr not in self.hoisted:
            self.hoisted[expr] = f"k{len(self.hoisted)}"
        return self.hoisted[expr]

    def term(self, scale: sympy.Expr, node: int, order: str) -> str:
        row = f"{ROW.format(node)}[{order}]"
        if scale == 1:
            return row
        if scale == -1:
            return f"-{row}"
        return f"{self.constant(scale)} * {row}"

    def scaled(self, value: Scaled, order: str) -> str:
        """A Scaled at `order` ("0" includes a constant, higher orders drop it)."""
        if value.node is None:
            return self.constant(value.scale) if order == "0" else "0"
        return self.term(value.scale, value.node, order)

    def linear(self, node: Node, order: str) -> str:
        terms = [self.term(scale, operand, order) for scale, operand in zip(node.scales, node.operands)]
        if order == "0" and node.offset != 0:
            terms.insert(0, self.constant(node.offset))
        return " + ".join(terms).replace("+ -", "- ")

    def zeroth(self, index: int, node: Node) -> list[str]:
        """The statements for order 0 of a node: its value, and the reciprocal zN of the part of
        its divisor that holds zeroth coefficients (none for the state, time and solution rows)."""
        if node.kind in ("state", "time", "solution"):
            return []
        if node.kind == "lin":
            return [f"{ROW.format(index)}[0] = {self.linear(node, '0')};"]
        recurrence = RECURRENCES[node.kind]
        names = {zeroth(name): sympy.Symbol(f"{ROW.format(operand)}[0]")
                 for name, operand in zip(recurrence.operands, node.operands)}
        names[zeroth(OWN)] = sympy.Symbol(f"{ROW.format(index)}[0]")
        names.update({sympy.Symbol(name, real=True): value
                      for name, value in zip(recurrence.parameters, node.parameters)})
        lines = [f"{ROW.format(index)}[0] = {self.printer.doprint(recurrence.value.xreplace(names))};"]
        _, rest = recurrence.split_divisor()
        if rest != 1:
            lines.append(f"const real z{index} = 1 / ({self.printer.doprint(rest.xreplace(names))});")
        return lines

    def at_order(self, index: int, node: Node) -> list[str]:
        """The statements for order k >= 1 of a node (none for the state and solution rows)."""
        if node.kind in ("state", "solution"):
            return []
        if node.kind == "time":
            value = "k == 1"
        elif node.kind == "lin":
            value = self.linear(node, "k")
        else:
            value = self.call(index, node)
        return [f"{ROW.format(index)}[k] = {value};"]

    def call(self, index: int, node: Node) -> str:
        recurrence = RECURRENCES[node.kind]
        rows = dict(zip(recurrence.operands, node.operands))
        rows[OWN] = index
        arguments = [ROW.format(rows[name]) for name in helper_arrays(recurrence)]
        arguments += ["k"] + [self.constant(value) for value in node.parameters]
        if recurrence.divisor != 1:
            power, rest = recurrence.split_divisor()
            arguments.append(" * ".join(["inv_k"] * power + ([f"z{index}"] if rest != 1 else [])))
        return f"{helper_name(node.kind)}({', '.join(arguments)})"

    def right_side(self, order: str) -> list[str]:
        """r = b at `order`, less Σ_{j>=1} K_j x_{order-j} for the entries of K that vary."""
        lines = [f"r[{i}] = {self.scaled(value, order)};" for i, value in enumerate(self.graph.rhs)]
        if order == "0":
            return lines
        for row, column, value in self.graph.matrix:
            if value.node is not None:
                tail = f"lag_taylor_tail({ROW.format(value.node)}, {ROW.format(self.graph.solution[column])}, k)"
                scale = "" if value.scale == 1 else f"{self.constant(value.scale)} * "
                lines.append(f"r[{row}] -= {scale}{tail};")
        return lines


def series_text(context: dict) -> str:
    """The model part's Taylor series (templates/c/taylor_series.c.j2) from its statements
    (series_context)."""
    return template_environment().get_template("c/taylor_series.c.j2").render(context)


def series_context(kernel, printer, positions: list[str]) -> dict:
    """The statements of the series for kernel.system, as templates/c/taylor_series.c.j2 reads them
    (and the sweep's lanes, c_taylor_lanes.py). `positions` are the C indices of K's stores in the
    system block, in order."""
    graph = series_graph(kernel)
    series = SeriesPrinter(graph, printer)
    zeroth_lines = zeroth_statements(graph, series)
    order_lines = [line for i, node in enumerate(graph.nodes) for line in series.at_order(i, node)]
    assemble = [f"K[{position}] = {series.scaled(value, '0')};" for position, (_, value) in zip(positions, graph.stored)]
    rhs_zero, rhs_k = series.right_side("0"), series.right_side("k")
    straight = StraightPrinter(series)
    highest = straight_orders(graph, max_order(DOUBLE_DIGITS) - 1)
    fused = None if not highest else "inverse" if kernel.size <= INVERSE_LARGEST else (
        "constant" if solver_kind(kernel) == "constant" else None)
    orders = [(k, straight.order(k)) for k in range(1, highest + 1)]
    body = zeroth_lines + order_lines + assemble + rhs_zero + rhs_k + [line for _, lines in orders for line in lines]
    declarations = [(name, f"{printer.doprint(expr)}") for name, expr in graph.constants]
    declarations += [(name, printer.doprint(expr)) for expr, name in series.hoisted.items()]
    inputs = list(graph.inputs)
    used = _used(body, inputs + declarations)
    local = [name for name, _ in inputs + declarations if name in used]
    local += [line.split()[2] for line in zeroth_lines if line.startswith("const real z")]
    fields = [name for name in local if any(_reads(line, name) for _, lines in orders for line in lines)]
    time = [i for i, node in enumerate(graph.nodes) if node.kind == "time"]
    helpers = [helper(RECURRENCES[kind], printer) for kind in graph.kinds()]
    if any(value.node is not None for _, _, value in graph.matrix):
        helpers.append(tail_helper())
    return {
        "taylor_helpers": helpers, "taylor_nodes": len(graph.nodes), "taylor_solution": graph.solution[0],
        "taylor_time": time[0] if time else None, "taylor_solver": solver_kind(kernel),
        "taylor_inverse": kernel.size <= INVERSE_LARGEST,
        "taylor_inputs": [(name, source) for name, source in inputs if name in used],
        "taylor_constants": [f"const real {name} = {value};" for name, value in declarations if name in used],
        "taylor_hoisted": [], "taylor_zeroth": zeroth_lines, "taylor_order": order_lines,
        "taylor_assemble": assemble, "taylor_rhs_zero": rhs_zero, "taylor_rhs": rhs_k,
        "taylor_max_order": MAX_ORDER, "taylor_fields": fields, "taylor_fused": fused,
        "taylor_struct": bool(fields) or fused is not None,
        "taylor_next": [straight.next_order(k, fused) if fused else [] for k, _ in orders],
        "taylor_straight": [(k, [f"const real {name} = c->{name};" for name in fields
                                 if any(_reads(line, name) for line in lines)]
                             + (["const real inv_k = (real)1 / %d;" % k] if any(_reads(line, "inv_k") for line in lines)
                                else []), lines) for k, lines in orders],
        "constraints": kernel.constraints}


def zeroth_statements(graph: SeriesGraph, series: SeriesPrinter) -> list[str]:
    """Order 0 of every node, each after the nodes it reads. sin(a ± b) and cos(a ± b) come from
    the sines and cosines of a and b when the graph has those (the double pendulum's θ1 - θ2):
    sin(a ± b) = sin a cos b ± cos a sin b, cos(a ± b) = cos a cos b ∓ sin a sin b, two products
    and a sum where libm's sin and cos take tens of ns a step; their absolute error is a few eps,
    as that of a ± b itself. Such a node may read nodes numbered after it: it is printed after them."""
    angles = {(node.kind, node.operands[0]): i for i, node in enumerate(graph.nodes) if node.kind in ("sin", "cos")}
    statements, reads = {}, {}
    for i, node in enumerate(graph.nodes):
        identity = _angle_sum(graph, angles, node)
        if identity is not None:
            statements[i], reads[i] = [f"{ROW.format(i)}[0] = {identity[0]};"], identity[1]
        else:
            statements[i], reads[i] = series.zeroth(i, node), [o for o in node.operands if o < i]
    printed: set[int] = set()
    lines: list[str] = []

    def emit(i: int) -> None:
        if i not in printed:
            printed.add(i)
            for operand in reads[i]:
                emit(operand)
            lines.extend(statements[i])
    for i in range(len(graph.nodes)):
        emit(i)
    return lines


def _angle_sum(graph: SeriesGraph, angles: dict, node: Node) -> tuple[str, tuple[int, ...]] | None:
    """(C, the rows it reads) for order 0 of sin or cos of a + b or a - b from the sines and
    cosines of a and b, or None when node is not that or the graph lacks one of them."""
    if node.kind not in ("sin", "cos"):
        return None
    argument = graph.nodes[node.operands[0]]
    if argument.kind != "lin" or argument.offset != 0 or len(argument.operands) != 2:
        return None
    if set(argument.scales) == {1, -1}:
        a, b = argument.operands if argument.scales[0] == 1 else reversed(argument.operands)
        plus = False
    elif tuple(argument.scales) == (1, 1):
        (a, b), plus = argument.operands, True
    else:
        return None
    rows = [angles.get((kind, operand)) for operand in (a, b) for kind in ("sin", "cos")]
    if None in rows:
        return None
    sa, ca, sb, cb = (f"{ROW.format(row)}[0]" for row in rows)
    if node.kind == "sin":
        return f"{sa}*{cb} {'+' if plus else '-'} {ca}*{sb}", tuple(rows)
    return f"{ca}*{cb} {'-' if plus else '+'} {sa}*{sb}", tuple(rows)


def solver_kind(kernel) -> str:
    """How lag_taylor_series solves K_0 x_k = r: with M factored once per run ("constant"), with the
    compact layout's lag_factor and lag_substitute, or the dense Cholesky or LU."""
    if kernel.constant_mass is not None:
        return "constant"
    if kernel.layout is not None and kernel.layout.compact:
        return "compact"
    return "cholesky" if kernel.solver == "cholesky" else "lu"


def _reads(line: str, name: str) -> bool:
    return re.search(rf"\b{name}\b", line) is not None


def _used(body: list[str], declarations: list[tuple[str, str]]) -> set[str]:
    """The declared names the body reads, directly or through other declarations: the graph may
    leave a constant unread (a sum the identities removed), and C warns of unused variables."""
    words = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", " ".join(body)))
    used: set[str] = set()
    for name, value in reversed(declarations):
        if name in words:
            used.add(name)
            words |= set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", value))
    return used
