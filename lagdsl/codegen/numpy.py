"""Kernel -> an importable Python module over NumPy arrays (batched states)."""
from __future__ import annotations

from .. import __version__
from . import GeneratedSource, template_environment
from .c import FUNCTION_PARAMETERS
from .kernel import Block, Kernel
from .printers import PythonPrinter


def render_numpy(kernel: Kernel, source_name: str = "model.lag") -> GeneratedSource:
    printer = PythonPrinter()
    blocks = {name: _print_block(getattr(kernel, name), printer)
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
        "t_interval": repr(kernel.time.interval), "solver": kernel.solver,
        "derived": [(i, printer.doprint(expr)) for i, expr in kernel.derived_parameters],
        "jacobian": kernel.jacobian is not None, "canonical": kernel.momenta is not None,
        "outputs_need_multipliers": kernel.outputs_need_multipliers,
        "stop_text": kernel.stop_text, "stop": None,      # the stop block, when there is one (below)
        **blocks,
    }
    text = template_environment().get_template("numpy/model.py.j2").render(context)
    return GeneratedSource("numpy", text, f"{kernel.model_name}_{kernel.scene_name}")


def _print_block(block: Block, printer: PythonPrinter) -> dict:
    stores = [(f"{s.array}[{', '.join(str(i) for i in s.index)}]", printer.doprint(s.value))
              for s in block.stores]
    return {"inputs": block.inputs,
            "assignments": [(name, printer.doprint(value)) for name, value in block.assignments],
            "stores": stores}
