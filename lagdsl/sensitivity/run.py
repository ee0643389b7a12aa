"""Forward sensitivities: the state and its derivatives S = ∂y/∂θ integrated as one system.

A direction θ is a parameter p, or a start value ("q.start", "q.velocity"). With y = (q, q')
and S = (Sq, Sv) one 2n-column per direction, the augmented system is

    q' = v,  K q'' = b;        Sq' = Sv,  K Sq'' = Dq Sq + Dv Sv + Dp J_θ

(sensitivity/lowering.py), K and b the generated `assemble`, the solve the generated
`solve_columns` with K's own factorization: M is never inverted, symbolically or numerically.
J_θ = ∂par/∂θ carries a direction into the parameter vector: 1 at the parameter itself, and
∂e_d/∂θ along the chain for a parameter d defined by an expression e_d of earlier ones (unless
set explicitly). Start values: S(0) = ∂y0/∂par J_θ for a parameter (the start written in terms
of it), the unit vector for "q.start" and "q.velocity", zero rows for starts set explicitly.

An output column h(t, y, par) has ∂h/∂θ = Cy S + Cp J_θ on the output grid.

The system is integrated as the NumPy backend integrates the scene (run/scipy_steps.py): by the
scipy solver that stands for its integrator, or for auto by the same switching between scipy's
DOP853 and Radau (integrators/python/auto.py). With `error_control` (the default, CVODES's "full
error control") S enters the step-size control with the state's tolerances; without it S
gets an infinite atol, so steps are chosen for the state alone.
"""
from __future__ import annotations

import time as clock
from dataclasses import dataclass, field

import numpy as np
import sympy

from ..errors import LagError, Setting, suggest
from ..integrators import registry
from ..run.output import Result, RunSummary, output_times
from ..run.scipy_steps import ScipyProblem, integrate_scipy
from ..run.status import simulation_error
from .variational import VariationalSystem, onto_constraints

START, VELOCITY = ".start", ".velocity"


@dataclass(frozen=True)
class SensitivityResult(Result):
    """A Result with `derivatives` (rows, columns, directions): ∂column/∂direction on the grid."""

    directions: tuple[str, ...] = ()
    derivatives: np.ndarray | None = None

    def sensitivity(self, column: str, direction: str) -> np.ndarray:
        """∂column(t)/∂direction on the output grid (a column of the scene, a parameter or "q.start")."""
        if column not in self.columns:
            raise KeyError(f"no column '{column}' (columns: {', '.join(self.columns)})")
        if direction not in self.directions:
            raise KeyError(f"no sensitivity by '{direction}' (computed: {', '.join(self.directions)})")
        return self.derivatives[:, self.columns.index(column), self.directions.index(direction)]


@dataclass(frozen=True)
class Directions:
    """The directions of a run: each a parameter index, or a state index (start values)."""

    names: tuple[str, ...]
    parameters: tuple[int | None, ...]      # parameter index, or None for a start value
    states: tuple[int | None, ...]          # index into y for a start value, or None


def directions(model, names, option: str = "--sensitivity") -> Directions:
    """Resolve names (parameters, "q.start", "q.velocity") against `model` (an ir.Model);
    `option` is where the names came from, for the messages."""
    parameters = [p.name for p in model.parameters]
    coordinates = [c.name for c in model.coordinates]
    n = len(coordinates)
    by_parameter, by_state = [], []
    if not names:
        raise LagError("name at least one parameter or start value", Setting(option))
    for name in names:
        stem, suffix = name.rsplit(".", 1) if "." in name else (name, "")
        if name in parameters:
            if model.parameters[parameters.index(name)].structural:
                raise LagError(f"'{name}' is a count (it sizes an indexed family), not a value "
                               "that can vary", Setting(option))
            by_parameter.append(parameters.index(name))
            by_state.append(None)
        elif stem in coordinates and "." + suffix in (START, VELOCITY):
            by_parameter.append(None)
            by_state.append(coordinates.index(stem) + (n if "." + suffix == VELOCITY else 0))
        else:
            known = [*parameters, *(c + START for c in coordinates), *(c + VELOCITY for c in coordinates)]
            raise LagError(f"'{name}' is neither a parameter nor a start value of model "
                           f"{model.name}{suggest(name, known)} (a parameter, q.start or q.velocity)",
                           Setting(option))
    if len(set(names)) < len(names):
        raise LagError("a parameter or start value is named twice", Setting(option))
    return Directions(tuple(names), tuple(by_parameter), tuple(by_state))


def parameter_directions(model, plan, chosen: Directions, values: np.ndarray) -> np.ndarray:
    """J_θ = ∂par/∂θ (parameters x directions) at the derived parameter values (module docstring)."""
    symbols = [p.symbol for p in model.parameters]
    at = {s: sympy.Float(float(v)) for s, v in zip(symbols, values)}
    J = np.zeros((len(symbols), len(chosen.names)))
    for j, index in enumerate(chosen.parameters):
        if index is not None:
            J[index, j] = 1.0
    for d, p in enumerate(model.parameters):
        if not p.expression.free_symbols or p.name in plan.fixed_parameters or d in chosen.parameters:
            continue
        for k, s in enumerate(symbols):
            if s in p.expression.free_symbols:
                J[d] += float(sympy.diff(p.expression, s).xreplace(at)) * J[k]
    return J


def initial_directions(module, plan, chosen: Directions, par: np.ndarray, J: np.ndarray) -> np.ndarray:
    """S(0), shape (2n, directions) (module docstring)."""
    n = len(plan.coordinates)
    S0 = module.initial_sensitivity(par) @ J
    for name, start, velocity in plan.initial:
        k = plan.coordinates.index(name)
        if start is not None:
            S0[k] = 0.0
        if velocity is not None:
            S0[n + k] = 0.0
    for j, index in enumerate(chosen.states):
        if index is not None:
            S0[index, j] = 1.0
    return S0


@dataclass(frozen=True)
class Program:
    """The generated NumPy functions of a scene with the sensitivity blocks (lowering.py)."""

    kernel: object
    module: object
    model: object                       # the api.Model: the constraints' derivatives at the start
    libraries: dict = field(default_factory=dict, compare=False)     # the C programs (c_run.py)


def build(model, scene: str | None) -> Program:
    """Generate and load the functions of `scene` of `model` (an api.Model)."""
    from ..codegen.numpy import render_numpy
    from ..run.loading import load as load_program
    from ..settings import Overrides
    from .lowering import lower_for_sensitivities
    code_plan = model.plan(scene, Overrides(integrator=JACOBIAN_INTEGRATOR))
    kernel = lower_for_sensitivities(model.equations, code_plan)
    return Program(kernel, load_program(render_numpy(kernel, model.source.name)), model)


# The integrator whose kernel carries Dq, Dv, Dz (linear/point.py builds its evaluator the same way).
JACOBIAN_INTEGRATOR = "radau5"


def options_of(plan) -> dict[str, float]:
    """The options of the plan's integrator (rtol, atol, ...), which scipy's solvers step with
    error control."""
    record = registry.get(plan.integrator.name)
    if not record.scipy_solvers or record.fixed_step:
        raise LagError(f"sensitivities need an adaptive integrator with error control on the NumPy backend "
                       f"(dopri5, dop853, radau5 or auto), not {plan.integrator.name}",
                       plan.integrator.span or Setting("--integrator"))
    return {**dict(record.defaults), **dict(plan.integrator.options)}


def integrate(program: Program, plan, chosen: Directions, times: np.ndarray | None = None,
              error_control: bool = True) -> SensitivityResult:
    """Run `plan` (a scene.ScenePlan) with the sensitivities by `chosen` on `times` (default: the
    scene's output grid, which starts at the scene's start time)."""
    start = prepare(program, plan, chosen, times)
    options = options_of(plan)
    n = len(plan.coordinates)
    tolerance = np.full(start.y0.size, float(options["atol"]))
    atol_each = plan.atol_vector(plan.coordinates)      # the state's own per component; the sensitivities keep atol
    if atol_each is not None:
        tolerance[:2 * n] = atol_each
    if not error_control:
        tolerance[2 * n:] = np.inf
    system = start.system
    started = clock.perf_counter()
    jacobian = system.newton_matrix if registry.get(plan.integrator.name).implicit else None
    problem = ScipyProblem.of(plan.integrator.name, system.rhs, jacobian, float(options["rtol"]), tolerance,
                              options.get("max_step"), plan.run_plan().max_steps, watch=False)
    Y, rhs_evals = _solve(problem, plan, start.times, start.y0)
    return result(program, plan, chosen, system, (start.times, Y), "numpy", (("rhs_evals", rhs_evals),),
                  clock.perf_counter() - started, options)


@dataclass(frozen=True)
class Start:
    """What a run with sensitivities starts from: the output times, y0 = (y(0), S(0) by rows)
    and the augmented system at the plan's parameters (its J = ∂par/∂θ)."""

    times: np.ndarray
    y0: np.ndarray
    system: VariationalSystem


def prepare(program: Program, plan, chosen: Directions, times: np.ndarray | None = None) -> Start:
    """The times, the start (S(0) projected onto the constraints' linearization) and the system."""
    if plan.stop is not None:
        raise LagError("sensitivities: the scene ends on a condition (`stop when`), whose time would move with "
                       "the parameters; run a scene with a fixed stop time", Setting("--scene"))
    module, n = program.module, len(plan.coordinates)
    par = np.array(plan.parameters, dtype=float)        # the plan computed the derived ones
    J = parameter_directions(plan.model, plan, chosen, par)
    times = output_times(plan.run_plan()) if times is None else np.asarray(times, dtype=float)
    state = np.array(plan.initial_state, dtype=float)
    S0 = initial_directions(module, plan, chosen, par, J)
    if program.kernel.constraints:
        S0 = onto_constraints(program.model, plan, module, par, state, S0, J)
    return Start(times, np.concatenate([state, S0.ravel()]), VariationalSystem(module, par, J, n))


def _solve(problem: ScipyProblem, plan, times: np.ndarray, y0: np.ndarray) -> tuple[np.ndarray, int]:
    """(Y at `times`, a column per time; the right-hand sides evaluated), integrated from the
    scene's start; SimulationError naming the time and state where it failed."""
    start = float(plan.time.start)
    grid = np.asarray(times, dtype=float) if times[0] == start else np.concatenate([[start], times])
    states, counts, failure = integrate_scipy(problem, grid, y0)
    if failure is not None:
        status, reached, Y = failure[:3]
        raise simulation_error(plan.run_plan(), status, reached, Y[:2 * len(plan.coordinates)], None, None,
                               *failure[3:])
    return np.array(states[len(grid) - len(times):]).T, int(counts["rhs_evals"])


def result(program, plan, chosen, system, solution: tuple[np.ndarray, np.ndarray], backend: str, counters,
           seconds: float, options: dict) -> SensitivityResult:
    """The output columns and their derivatives on the grid, with the run summary; `solution` is
    (t, Y) with Y = (y, S by rows) a column per time."""
    module, n = program.module, len(plan.coordinates)
    t_grid, Y = solution
    out, inv = module.observables(t_grid, Y[:2 * n], system.par)
    constrained = bool(program.kernel.constraints)
    derivatives = np.array([system.output_derivatives(t, Y[:, row], constrained) for row, t in enumerate(t_grid)])
    drifts = tuple((name, float(inv[i, 0]), float(np.max(np.abs(inv[i] - inv[i, 0]))))
                   for i, name in enumerate(plan.invariants))
    residual = None
    if constrained:         # not projected: the index-1 equations keep to the constraints up to their error
        g, c, _ = module.constraint_rows(system.par, t_grid, Y[:2 * n])
        residual = float(max(np.max(np.abs(g), initial=0.0), np.max(np.abs(c), initial=0.0)))
    summary = RunSummary(backend, plan.integrator.name, tuple(counters), seconds, drifts,
                         program.kernel.constraints, residual, None,
                         tuple((name, float(value)) for name, value in options.items()))
    return SensitivityResult(t_grid, plan.columns, np.asarray(out, dtype=float).T, summary,
                             directions=chosen.names, derivatives=derivatives)
