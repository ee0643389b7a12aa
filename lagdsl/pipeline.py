"""The whole chain on one screen.

    text ──parse──▶ lark Tree ──build_model──▶ ir.Model ──derive_equations──▶ Equations
         ──plan_scene──▶ ScenePlan ──lower──▶ codegen.Kernel ──render──▶ C or NumPy source
         ──build/run──▶ results

stage            input -> output                       module
parse            SourceFile -> lark.Tree               parser.py (grammar.lark)
build_model      Tree -> ir.Model                      semantics.py, expressions.py, units.py
derive_equations Model -> Equations (M, f, A, ...)     mechanics/
plan_scene       Model + scene + overrides -> plan     scene.py
lower            Equations + plan -> Kernel (CSE)      codegen/kernel.py
render           Kernel -> source text                 codegen/c.py, codegen/numpy.py
run              source -> trajectories                run/
"""
from __future__ import annotations

from pathlib import Path

from . import ir
from .mechanics import Equations, derive_equations
from .parser import parse
from .semantics import build_model
from .source import SourceFile


def load_model(path: str | Path) -> ir.Model:
    source = SourceFile.read(path)
    return model_from_source(source)


def model_from_source(source: SourceFile) -> ir.Model:
    tree = parse(source)                      # text -> lark Tree
    return build_model(tree, source)          # Tree -> ir.Model


def load_equations(path: str | Path) -> tuple[ir.Model, Equations]:
    model = load_model(path)
    return model, derive_equations(model)     # Model -> Equations
