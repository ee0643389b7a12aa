"""The state a linear analysis is about, and the model's generated functions evaluated there.

The equations are evaluated by the scene's generated NumPy module, built for the radau5
integrator: its kernel carries the exact derivatives (codegen/kernel.py, block `jacobian`)

    Dq = ∂R/∂q,  Dv = ∂R/∂q',  Dz = ∂R/∂(q'', λ)   of   R = [f - M q'' + Aᵀλ; γ - A q''],

compiled from the symbolic equations, never differenced. For a large model of many small terms
they are loops over stencils (codegen/loops.py), so the 200 x 200 Jacobians of a chain cost
microseconds.

A point is given as `at` = {"q": value, "q.velocity": value} and `set` = {parameter: value}:
what is not given is the scene's start, as with `lagc run --set`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import AnalysisError, LagError, Setting, suggest
from ..settings import Overrides

# The integrator whose kernel has the Jacobian block: only the code it selects matters here.
JACOBIAN_INTEGRATOR = "radau5"
VELOCITY_SUFFIX = ".velocity"


@dataclass(frozen=True)
class Evaluator:
    """The generated functions of one scene at fixed parameters and time (the run's start)."""

    module: object
    kernel: object                      # codegen.Kernel: the structure of M and of the Jacobian
    plan: object                        # scene.ScenePlan with the overrides applied
    parameters: np.ndarray
    time: float
    state: np.ndarray                   # (q, q'): the scene's start with `at` applied, or an equilibrium found

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.kernel.coordinates

    @property
    def n(self) -> int:
        return self.kernel.n

    def moved_to(self, state: np.ndarray) -> "Evaluator":
        return replace(self, state=np.array(state, dtype=float))

    def named(self, state: np.ndarray) -> dict[str, float]:
        """{"q": value, "q.velocity": value}: the form `at` takes."""
        n = self.n
        return {**{name: float(state[k]) for k, name in enumerate(self.coordinates)},
                **{name + VELOCITY_SUFFIX: float(state[n + k]) for k, name in enumerate(self.coordinates)}}

    def accelerations(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q'', λ) at `state`; AnalysisError where M (with the constraints: K) is singular."""
        try:
            acc, lam = self.module.accelerations(self.parameters, self.time, state)
        except np.linalg.LinAlgError:
            raise AnalysisError("the mass matrix (with the constraints' rows) is singular at this state",
                                self.named(state), "choose another point (--at), away from where coordinates "
                                "stop describing the motion (a pole of spherical angles, a straight linkage)") from None
        if not (np.all(np.isfinite(acc)) and np.all(np.isfinite(lam))):
            raise AnalysisError("the accelerations are not finite at this state", self.named(state),
                                "check the parameter values and the point")
        return acc, lam

    def residual_jacobian(self, state: np.ndarray, acc: np.ndarray, lam: np.ndarray):
        """Dq, Dv, Dz (each NK x NK) at `state` and (q'', λ)."""
        return self.module.residual_jacobian(self.parameters, self.time, state, acc, lam)

    def forcing(self, state: np.ndarray) -> np.ndarray:
        """f (with γ below it for the constraints): the right-hand side b of K x = b."""
        return self.module.assemble(self.parameters, self.time, state)[1]

    def constraint_rows(self, state: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """g (holonomic rows), c = A q' + b and A: empty without constraints."""
        if not self.kernel.constraints:
            return np.zeros(0), np.zeros(0), np.zeros((0, self.n))
        return self.module.constraint_rows(self.parameters, self.time, state)


def evaluator(model, scene: str | None, at: dict | None, set: dict | None) -> Evaluator:
    """The generated functions of `model` (an api.Model) with `set` applied, and `at` as the
    start state of the plan."""
    from ..codegen.numpy import render_numpy
    from ..codegen.kernel import lower_to_kernel
    from ..run.loading import load as load_program
    values = tuple((name, float(value)) for name, value in (set or {}).items())
    values += tuple(_state_values(model.ir, at or {}))
    plan = model.plan(scene, Overrides(values, integrator=JACOBIAN_INTEGRATOR))
    kernel = lower_to_kernel(model.equations, plan)
    module = load_program(render_numpy(kernel, model.source.name))
    parameters = module.derive_parameters(np.array(plan.parameters, dtype=float),
                                          tuple(i for i, p in enumerate(model.ir.parameters)
                                                if p.name in plan.fixed_parameters))
    return Evaluator(module, kernel, plan, parameters, float(plan.time.start),
                     np.array(plan.initial_state, dtype=float))


def _state_values(model, at: dict) -> list[tuple[str, float]]:
    """`at` as the overrides of `lagc run --set`: "q" is "q.start", "q.velocity" stays."""
    names = [c.name for c in model.coordinates]
    values = []
    for key, value in at.items():
        name, velocity = (key[:-len(VELOCITY_SUFFIX)], True) if key.endswith(VELOCITY_SUFFIX) else (key, False)
        if name not in names:
            raise LagError(f"'{key}' names no coordinate of model {model.name}{suggest(name, names)} "
                           f"(give a coordinate as q=VALUE, its velocity as q.velocity=VALUE)", Setting("--at"))
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise LagError(f"'{key}' takes a number, got {value!r}", Setting("--at")) from None
        values.append((name + (VELOCITY_SUFFIX if velocity else ".start"), number))
    return values


def check_inputs(model, names) -> tuple[int, ...]:
    """The parameter indices of the inputs; a name that is not a parameter, or a structural one
    (a count), is refused."""
    parameters = [p.name for p in model.parameters]
    indices = []
    for name in names:
        if name not in parameters:
            raise LagError(f"input '{name}' is not a parameter of model {model.name}{suggest(name, parameters)}; "
                           "an input is a parameter, typically one that appears in a `force`", Setting("--input"))
        index = parameters.index(name)
        if model.parameters[index].structural:
            raise LagError(f"input '{name}' is a count (it sizes an indexed family), not a value that can vary",
                           Setting("--input"))
        indices.append(index)
    return tuple(indices)
