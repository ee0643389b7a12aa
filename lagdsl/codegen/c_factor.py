"""MassLayout -> the C text of a factorisation specialised to the structure of M.

For the sparse layout the LDLᵀ factorisation and the substitutions are written out
statement by statement, touching only the entries of L that are not structurally zero
(structure.py chose the elimination order and found the fill). Column p of the factor:

    d_p  = 1 - Σ_{k in row p} L_pk² d_k                       (the equilibrated M has unit diagonal)
    L_ip = (a_ip - Σ_{k in row p ∩ row i} L_ik d_k L_pk) / d_p    for i in column p

where a_ip is the equilibrated entry of M, or 0 where L_ip is fill (fill always has terms: it
arises from some k in both rows). Where row p is empty, d_p = 1 and L_ip = a_ip are left as they are.

In a saddle-point layout (structure.kkt_layout) the last positions are constraint rows, factored
as those of Kₛ = [[M, -Aᵀ], [-A, 0]]: each is equilibrated by its largest scaled entry (its
diagonal is 0), its stored entries of A are negated as they are scaled, and its pivot is
d_p = -Σ_{k in row p} L_pk² d_k, which must be negative.
"""
from __future__ import annotations

from .structure import MassLayout


def factorisation_text(layout: MassLayout | None) -> dict:
    """Template variables: `tables` (static index arrays), `scale`, `columns` (the factor),
    `forward` and `backward` (the substitutions), each a list of C statements; empty unless the
    layout is sparse. `closed`: for a full 2 x 2 M (no constraints), the slots of its inverse in
    closed form, which the template writes instead (one division; the factor takes two square
    roots and four); None otherwise."""
    if layout is None or layout.kind != "sparse":
        return {"tables": [], "scale": [], "columns": [], "forward": [], "backward": [], "closed": None}
    if layout.n == 2 and not layout.multipliers and (1, 0) in layout.original:
        return {"tables": [], "scale": [], "columns": [], "forward": [], "backward": [],
                "closed": _closed_form_2x2(layout)}
    slot, rows = layout.slots, layout.rows
    pivots = [slot[(p, p)] for p in range(layout.n)]
    tables = [f"static const int lag_order[LAG_NK] = {{ {_list(layout.order)} }};",
              f"static const int lag_pivots[LAG_NK] = {{ {_list(pivots)} }};"]
    off_diagonal = sorted((entry for entry in layout.original if entry[0] != entry[1]), key=slot.__getitem__)
    scale = _constraint_row_scales(layout, off_diagonal)
    scale += [f"K[{slot[(i, p)]}] *= {'-' if i >= layout.coordinates else ''}scale[{i}] * scale[{p}];"
              for i, p in off_diagonal]
    columns = []
    for p, column in enumerate(layout.columns):
        pivot = pivots[p]
        products = [f"K[{slot[(p, k)]}] * K[{slot[(p, k)]}] * K[{pivots[k]}]" for k in rows[p]]
        terms = "".join(f" - {product}" for product in products)
        if p >= layout.coordinates:                 # a constraint row: its diagonal is 0
            columns.append(f"K[{pivot}] = -({' + '.join(products) or '0'});")
            columns.append(f"if (!(K[{pivot}] < 0))\n        return LAG_ERR_SINGULAR;")
        else:
            columns.append(f"K[{pivot}] = 1{terms};")
            if terms:                               # else d_p = 1 and L_ip = a_ip: nothing to compute
                columns.append(f"if (!(K[{pivot}] > 0))\n        return LAG_ERR_SINGULAR;")
        for i in column:
            shared = sorted(set(rows[i]) & set(rows[p]))
            start = f"K[{slot[(i, p)]}]" if (i, p) in layout.original else "0"
            terms_i = "".join(f" - K[{slot[(i, k)]}] * K[{pivots[k]}] * K[{slot[(p, k)]}]" for k in shared)
            if terms_i:
                columns.append(f"K[{slot[(i, p)]}] = ({start}{terms_i}) / K[{pivot}];")
            elif terms:
                columns.append(f"K[{slot[(i, p)]}] /= K[{pivot}];")
    forward = [f"x[{i}] -= {' + '.join(f'K[{slot[(i, k)]}] * x[{k}]' for k in rows[i])};"
               for i in range(layout.n) if rows[i]]
    backward = [f"x[{p}] -= {' + '.join(f'K[{slot[(i, p)]}] * x[{i}]' for i in layout.columns[p])};"
                for p in reversed(range(layout.n)) if layout.columns[p]]
    return {"tables": tables, "scale": scale, "columns": columns, "forward": forward, "backward": backward,
            "closed": None}


def _closed_form_2x2(layout: MassLayout) -> dict:
    """Where K holds a full 2 x 2 M = [[a, c], [c, d]]: `diagonal` and `off` (its slots) and
    `rows` (the coordinates of positions 0 and 1), for the inverse adj(M) / det M in place."""
    slot = layout.slots
    return {"a": slot[(0, 0)], "c": slot[(1, 0)], "d": slot[(1, 1)], "rows": layout.order}


def _constraint_row_scales(layout: MassLayout, off_diagonal: list[tuple[int, int]]) -> list[str]:
    """scale[p] of each constraint row p: 1 / its largest entry |A_pj| scale[j] (1 if there is
    none, or it is not finite: the pivot then shows what is wrong)."""
    columns_of: dict[int, list[int]] = {}
    for i, j in off_diagonal:
        columns_of.setdefault(i, []).append(j)
    statements = []
    for p in range(layout.coordinates, layout.n):
        statements.append(f"scale[{p}] = 0;")
        statements += [f"scale[{p}] = r_fmax(scale[{p}], r_fabs(K[{layout.slots[(p, j)]}] * scale[{j}]));"
                       for j in columns_of.get(p, [])]
        statements.append(f"scale[{p}] = scale[{p}] > 0 && r_isfinite(scale[{p}]) ? 1 / scale[{p}] : 1;")
    return statements


def _list(values) -> str:
    return ", ".join(str(v) for v in values)
