"""Kernel -> an importable Python module over NumPy arrays (batched states)."""
from __future__ import annotations

from .. import __version__
from ..settings import RCOND_MIN_EPS
from . import GeneratedSource, template_environment
from .c import FUNCTION_PARAMETERS, layout_kind
from .kernel import Block, Kernel, Loop, Store
from .printers import PythonPrinter


def render_numpy(kernel: Kernel, source_name: str = "model.lag") -> GeneratedSource:
    printer = PythonPrinter()
    blocks = {name: _print_block(getattr(kernel, name), layout_kind(kernel), printer, kernel.n)
              for name in FUNCTION_PARAMETERS if getattr(kernel, name) is not None}
    context = {
        "title": f"{kernel.model_name}, scene {kernel.scene_name}: generated NumPy functions",
        "version": __version__, "source_name": source_name, "scene": kernel.scene_name,
        "model": kernel.model_name, "n": kernel.n, "size": kernel.size,
        "parameters": kernel.parameters, "columns": kernel.columns,
        "coordinates": kernel.coordinates, "constraints": kernel.constraints,
        "holonomic": kernel.holonomic, "invariant_names": kernel.invariant_names,
        "invariants": bool(kernel.invariant_names),
        "integrator": kernel.integrator.name, "options": kernel.integrator.options,
        "t_start": repr(kernel.time.start), "t_stop": repr(kernel.time.stop),
        "t_interval": repr(kernel.time.interval), "solver": kernel.solver, "layout": layout_kind(kernel),
        "derived": [(i, printer.doprint(expr)) for i, expr in kernel.derived_parameters],
        "jacobian": kernel.jacobian is not None, "canonical": kernel.momenta is not None,
        "outputs_need_multipliers": kernel.outputs_need_multipliers,
        "stop_needs_multipliers": kernel.stop_needs_multipliers,
        "stop_text": kernel.stop_text, "stop": None, "constant_mass": None, "parameter_jacobian": None,      # blocks a scene may not have (below)
        "totals": any(block["accumulators"] for block in blocks.values()), "rcond_min_eps": RCOND_MIN_EPS,
        **blocks,
    }
    text = template_environment().get_template("numpy/model.py.j2").render(context)
    return GeneratedSource("numpy", text, f"{kernel.model_name}_{kernel.scene_name}")


# Matrices that the generated functions create as zeros: their zero entries need no statement.
ZEROED = ("K", "M", "Dq", "Dv", "Dz", "Dp", "Cy", "Cl", "Cp", "S0")


def _print_block(block: Block, layout: str, printer: PythonPrinter, coordinates: int) -> dict:
    stores = [(_target(s, layout, coordinates), printer.doprint(s.value))
              for s in block.stores if not (s.array in ZEROED and s.value == 0)]
    return {"inputs": block.inputs,
            "assignments": [(name, printer.doprint(value)) for name, value in block.assignments],
            "stores": stores, "accumulators": block.accumulators,
            "loops": [_print_loop(loop, layout, printer) for loop in block.loops]}


def _print_loop(loop: Loop, layout: str, printer: PythonPrinter) -> dict:
    """A Loop as array operations on all members at once: each input is a strided slice of y or
    par, each store adds into one (the members of one slot never share an entry). A diagonal M
    is the vector K[k]; any other M is a full matrix, set on both sides of the diagonal; Dq, Dv
    and Dz are full matrices with every entry stored."""
    def members(offset: int, stride: int) -> str:
        if loop.count == 1:
            return str(offset)
        stop = offset + stride * (loop.count - 1) + 1
        return f"{offset}:{stop}" + (f":{stride}" if stride != 1 else "")

    def stores(array, index, value):
        if not index:
            return [f"{array} += {value}" if loop.count == 1 else f"{array} += _total({value}, {loop.count})"]
        if len(index) == 1 or layout == "diagonal" and array == "K":
            return [f"{array}[{members(*index[0])}] += {value}"]
        (row, stride), (column, _) = index
        rows, columns = _indices(row, stride, loop.count), _indices(column, stride, loop.count)
        lines = [f"{array}[{rows}, {columns}] += {value}"]
        mirrored = array == "K" and row != column          # M is stored once per pair; Dq, Dv, Dz whole
        return lines + ([f"{array}[{columns}, {rows}] += {value}"] if mirrored else [])

    def read(array, offset, stride):
        if array == "par" and loop.count > 1:       # one value per member, against a batch of states
            return f"par[{members(offset, stride)}].reshape((-1,) + (1,) * (numpy.ndim(y) - 1))"
        return f"{array}[{members(offset, stride)}]"

    return {"inputs": [(name, read(array, offset, stride)) for name, array, offset, stride in loop.inputs],
            "assignments": [(name, printer.doprint(value)) for name, value in loop.assignments],
            "stores": [line for array, index, value in loop.stores for line in stores(array, index, printer.doprint(value))]}


def _indices(offset: int, stride: int, count: int) -> str:
    return str(offset) if count == 1 else f"numpy.arange({offset}, {offset + stride * (count - 1) + 1}, {stride})"


def _target(store: Store, layout: str, coordinates: int) -> str:
    """The array element(s) a store sets. A diagonal M is held as the vector of its diagonal; a
    sparse one is stored once per pair (k, j), k >= j, and set on both sides of the diagonal.
    A compact K with constraints stores A (rows from `coordinates` on) once: assemble() sets
    the block -Aᵀ from it."""
    if store.array in ("K", "M") and layout != "dense":
        row, column = store.index
        if layout == "diagonal":
            return f"{store.array}[{row}]"
        if row != column and row < coordinates:
            return f"{store.array}[{row}, {column}] = {store.array}[{column}, {row}]"
    return f"{store.array}[{', '.join(str(i) for i in store.index)}]"
