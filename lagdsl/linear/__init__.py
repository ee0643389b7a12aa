"""Linear analysis of a model: equilibria, linearization, modes.

    at, set ──point──▶ Evaluator (the generated functions and their exact Jacobians)
            ──equilibrium──▶ Equilibrium (Newton on the accelerations, constraints kept)
            ──linearize──▶ LinearModel (M, D, G, K, N, Bq; A, B, C, Dm; constraints eliminated)
            ──modes──▶ Modes (eigenvalues, frequencies, damping ratios, shapes, verdicts)
            ──export──▶ JSON, .npz, .mat, the modes CSV and table

api.Model.equilibrium and api.Model.linearize, and `lagc modes` and `lagc linearize`
(cli/modes.py), are built on these.
"""
from .equilibrium import Equilibrium, find_equilibrium
from .linearize import linearize, linearize_model
from .model import LinearModel
from .modes import Modes, analyse
from .point import evaluator

__all__ = ["Equilibrium", "LinearModel", "Modes", "analyse", "evaluator", "find_equilibrium", "linearize",
           "linearize_model"]
