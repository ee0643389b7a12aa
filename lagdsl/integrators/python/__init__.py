"""The NumPy backend's own integrators (rk4, gauss, rkn8) and the Gauss-Legendre coefficients.

Each method's record (integrators/registry.py) names its stepper here: a function of one
`PythonRun`, returning the states at the output times and the work counters, or raising
IntegrationFailure with the rows computed so far.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .fixed_step import IntegrationFailure, integrate_gauss, integrate_rk4
from .gauss_coefficients import gauss_legendre_tableau

__all__ = ["IntegrationFailure", "PythonRun", "gauss_legendre_tableau", "integrate_gauss", "integrate_rk4"]


@dataclass(frozen=True)
class PythonRun:
    """What a Python stepper integrates: the generated module's equations with parameters `par`
    from y0 over the output times, with the run's options and limits."""

    program: Any                                    # the generated NumPy module
    par: np.ndarray
    times: np.ndarray
    y0: np.ndarray
    options: dict[str, Any]                         # atol: a number, or an array of one per component
    max_steps: int
    stop: Any                                       # run.stop.StopCondition, or None
    checked: Callable[[Callable], Callable]         # wraps a function to check for Ctrl-C before each call
    project: Callable[[float, np.ndarray], np.ndarray] | None     # onto the constraints, or None

    def rhs(self) -> Callable[[float, np.ndarray], np.ndarray]:
        """y' = f(t, y), Ctrl-C checked."""
        return self.checked(lambda t, y: self.program.rhs(t, y, self.par))
