"""The whole chain on one screen.

    text ──parse──▶ lark Tree ──build_model──▶ ir.Model (+ units: dimensions checked on the same walk)
         ──derive_equations──▶ Equations (or LocalEquations: per shape, for large local models;
                               TreeEquations: per link, for trees of rigid links)
         ──plan_scene──▶ ScenePlan ──lower──▶ codegen.Kernel ──render──▶ C or NumPy source
         ──build/run──▶ results

stage            input -> output                       module
parse            SourceFile -> lark.Tree               frontend/parser.py (grammar.lark)
build_model      Tree -> ir.Model (+ UnitReport)       frontend/ (semantics.py and the modules it walks with)
derive_equations Model -> Equations (M, f, A, ...)     mechanics/ (families.py: the local form; trees.py)
plan_scene       Model + scene + overrides -> plan     scene.py
lower            Equations + plan -> Kernel (CSE)      codegen/kernel.py (loops.py, tree_loops.py)
render           Kernel -> source text                 codegen/c.py, codegen/numpy.py
run              source -> trajectories                run/
linearize        Kernel's Jacobians at a state ->      linear/ (equilibria, M D G K N, A B C D, modes)
                 LinearModel, Modes
animate          Result with its drawing (the draw      animation/ (the page, GIF, MP4)
                 statements' columns) -> page, video
"""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from . import ir
from .mechanics import Equations, derive_equations
from .mechanics.families import LocalEquations, derive_local_equations
from .mechanics.trees import TreeEquations, derive_tree_equations
from .frontend.parser import parse
from .scene import Overrides, ScenePlan, plan_scene
from .frontend.semantics import build_model
from .source import SourceFile

if TYPE_CHECKING:       # lowering and running are imported when first used: loading a model needs neither
    from .codegen import GeneratedSource
    from .codegen.kernel import Kernel
    from .run.output import Result


def load_model(path: str | Path) -> ir.Model:
    source = SourceFile.read(path)
    return model_from_source(source)


def model_from_source(source: SourceFile) -> ir.Model:
    tree = parse(source)                      # text -> lark Tree
    return build_model(tree, source)          # Tree -> ir.Model, units checked (UnitReport)


def compile_model(source: SourceFile) -> tuple[ir.Model, Equations | LocalEquations]:
    model = model_from_source(source)         # text -> ir.Model
    return model, (derive_tree_equations(model) or derive_local_equations(model)
                   or derive_equations(model))                                   # Model -> Equations


def plan(model: ir.Model, equations: Equations, scene: str | None, overrides: Overrides,
         draw: bool = False) -> ScenePlan:
    return plan_scene(model, equations, scene, overrides, draw)    # + scene, overrides -> ScenePlan


def generate(equations: Equations, scene_plan: ScenePlan, backend: str, source_name: str) -> tuple[Kernel, GeneratedSource]:
    from .codegen.c import render_c             # the printers and templates, imported when first rendered
    from .codegen.kernel import lower_to_kernel
    from .codegen.numpy import render_numpy
    if backend != "c" and isinstance(equations, TreeEquations):
        equations = equations.expanded          # the tree's recursion is written in C only
    kernel = lower_to_kernel(equations, scene_plan)                 # -> Kernel (CSE applied)
    render = {"c": render_c, "numpy": render_numpy}[backend]
    return kernel, render(kernel, source_name)                      # -> C or NumPy source


def execute(source: GeneratedSource, scene_plan: ScenePlan,
            progress: Callable[[float, float, float], None] | None = None, loaded=None) -> Result:
    """Run the scene; `loaded` is runner.load(source) when the caller kept it from an earlier run."""
    from .run.runner import run
    return run(scene_plan.run_plan(), source.language, loaded, progress, source)   # -> Result
