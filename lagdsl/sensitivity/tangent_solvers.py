"""What carries the state and the tangent vectors V from one re-orthonormalisation t_j to the next
(sensitivity/lyapunov.py): the augmented system Y = (y, V by rows) of the forward sensitivities
(variational.py) without parameter directions, J = 0, so that each tangent vector is a
sensitivity column with respect to the start values, integrated on the NumPy backend by the scipy
solver standing for the scene's integrator, for auto the switching of integrators/python/auto.py,
as run/scipy_steps.py starts them (`ScipySolver`), or on the C backend by the scene's C
integrator in the generated sensitivity program (`CSolver`, c_run.py). A scene whose integrator
has no error control (rk4, gauss) or steps by generated Taylor series of the equations of motion
alone (taylor) is run with FALLBACK_INTEGRATOR instead, with the options it takes.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..abi import SETTINGS
from ..errors import SimulationError
from ..integrators import registry
from ..run.scipy_steps import ScipyProblem, start_solver
from ..run.status import simulation_error
from ..settings import IntegratorChoice
from . import c_run
from .variational import VariationalSystem, named_state

FALLBACK_INTEGRATOR = "dop853"          # for a scene whose integrator has no error control (gauss, rk4)


def solver_for(backend: str, program, plan, system: VariationalSystem):
    """The ScipySolver ("numpy") or CSolver ("c") of `plan` for `system`."""
    return CSolver.of(program, plan, system) if backend == "c" else ScipySolver.of(plan, system)


def _options(plan, record: registry.Integrator) -> dict:
    """The integrator's defaults overridden by the plan's options that it takes."""
    return {**dict(record.defaults), **{k: v for k, v in plan.integrator.options if k in record.options}}


def _replaced(plan, unusable) -> tuple[registry.Integrator, str | None]:
    """The plan's integrator record, or FALLBACK_INTEGRATOR's where `unusable(record)`, and the name
    it stands in for (None when the scene's own is used)."""
    record = registry.get(plan.integrator.name)
    return (registry.get(FALLBACK_INTEGRATOR), record.name) if unusable(record) else (record, None)


def _instead(name: str | None) -> str:
    if name is None:
        return ""
    why = "whose Taylor series are generated for the equations of motion alone" if registry.get(name).series \
        else "which has no error control"
    return f", in place of the scene's {name}, {why}"


class ScipySolver:
    """scipy's solver standing for the scene's integrator, restarted at each re-orthonormalisation
    with the step size it had reached."""

    def __init__(self, system: VariationalSystem, record: registry.Integrator, options: dict, max_steps: int,
                 instead_of: str | None = None):
        self.system, self.name, self.solvers = system, record.name, " and ".join(record.scipy_solvers)
        self.instead_of = instead_of        # the scene's integrator, when it has no error control
        self.rtol, self.atol = float(options["rtol"]), float(options["atol"])
        self.problem = ScipyProblem.of(record.name, system.rhs, system.newton_matrix if record.implicit else None,
                                       self.rtol, self.atol, options.get("max_step"), max_steps, watch=False)
        self.step: float | None = None

    @classmethod
    def of(cls, plan, system: VariationalSystem) -> "ScipySolver":
        record, instead_of = _replaced(plan, lambda r: not r.scipy_solvers or r.fixed_step)
        return cls(system, record, _options(plan, record), plan.run_plan().max_steps, instead_of)

    def describe(self) -> str:
        return f"{self.name} (scipy {self.solvers}, rtol {self.rtol:g}, atol {self.atol:g}" \
               f"{_instead(self.instead_of)})"

    def advance(self, t: float, t_next: float, Y: np.ndarray) -> np.ndarray:
        """Y at t_next from Y at t; SimulationError naming where the integration failed."""
        first = self.step if self.step is not None and self.step < t_next - t else None
        solver = start_solver(self.problem, t, Y, t_next, first)
        while solver.status == "running":
            try:
                message = solver.step()
            except np.linalg.LinAlgError:
                message = "the mass matrix is singular"
            if solver.status == "failed" or message is not None:
                y, _ = self.system.split(solver.y)
                raise SimulationError(f"the variational equations' integration failed ({message})",
                                      float(solver.t), named_state(self.system.module, y),
                                      "lower rtol, or choose radau5 for a stiff model")
            if solver.t < t_next:       # the last step is cut short to land on t_next: not kept
                self.step = solver.step_size
        return solver.y


class CSolver:
    """The scene's C integrator in the generated sensitivity program (c_run.py), one call of
    lag_sensitivity_run from t_j to t_{j+1}; its first step is chosen anew at each call."""

    def __init__(self, loaded, plan, system: VariationalSystem, options: dict, instead_of: str | None):
        self.loaded, self.plan, self.system, self.instead_of = loaded, plan, system, instead_of
        self.options = options
        self.settings = c_run.settings_of(plan, options)

    @classmethod
    def of(cls, program, plan, system: VariationalSystem) -> "CSolver":
        record, instead_of = _replaced(plan, lambda r: r.fixed_step or r.series)
        if instead_of is not None:
            options = tuple((k, v) for k, v in _options(plan, record).items() if k in ("rtol", "atol", "max_step"))
            plan = replace(plan, integrator=IntegratorChoice(record.name, options, plan.integrator.span))
        loaded = c_run.library(program, plan.integrator, system.m)
        return cls(loaded, plan, system, _options(plan, record), instead_of)

    def describe(self) -> str:
        return f"{self.plan.integrator.name} (C, rtol {self.options['rtol']:g}, atol {self.options['atol']:g}" \
               f"{_instead(self.instead_of)})"

    def advance(self, t: float, t_next: float, Y: np.ndarray) -> np.ndarray:
        n, m = self.system.n, self.system.m
        settings = self.settings.copy()
        settings[SETTINGS.index("t_start")] = t
        status, values, summary = c_run.call(self.loaded, self.system, c_run.augmented(Y, n, m), settings,
                                             np.array([t_next]))
        if status != 0:
            at = {name: i for i, name in enumerate(c_run.SUMMARY_FIELDS)}
            reached = c_run.first_order(summary[at["y_reached"]:][None, :], n, m)[0]
            raise simulation_error(self.plan.run_plan(), status, float(summary[at["t_reached"]]), reached[:2 * n],
                                   None, None)
        return c_run.first_order(values, n, m)[0]
