"""Model + Equations + scene + overrides -> ScenePlan: what one simulation needs.

The plan resolves the scene (the model's first, or the default set-up: t = 0..10 every 0.01,
dop853 at rtol 1e-8, every coordinate as output), applies overrides from the command line or
the Python API on top of the scene's own `set` statements, and decides what the generated
code must contain: the outputs asked for, the invariants to watch, constraint projection only
for active constraints, a Jacobian only for an implicit integrator, the canonical form only
for the symplectic `gauss`.
"""
from __future__ import annotations

import math
import sys
import warnings
from dataclasses import dataclass, replace

import sympy

from . import ir
from .errors import LagError, LagWarning, Setting
from .expressions import suggest
from .mechanics import Equations
from .semantics import DEFAULT_INTEGRATOR, DEFAULT_TIME, INTEGRATOR_OPTIONS, validate_integrator


# Integrator settings that can be given outside the model file (`lagc run --rtol`, `simulate(rtol=)`).
RUN_OPTIONS = ("rtol", "atol", "step", "stages", "max_step", "max_steps")


def given_options(values) -> tuple[tuple[str, float], ...]:
    """The run options among `values` (a mapping of name to value or None) that were given."""
    return tuple((name, float(values[name])) for name in RUN_OPTIONS if values.get(name) is not None)


@dataclass(frozen=True)
class Overrides:
    """Settings given outside the model file (`lagc run` options, `simulate()` arguments).

    `values` maps a parameter name, "q.start" or "q.velocity" to a number.
    """

    values: tuple[tuple[str, float], ...] = ()
    start: float | None = None
    stop: float | None = None
    interval: float | None = None
    integrator: str | None = None
    options: tuple[tuple[str, float], ...] = ()     # rtol, atol, step, stages, max_step, max_steps


MAX_ROWS = 10**7              # the largest output grid
DEFAULT_MAX_STEPS = 100000    # the step limit unless the grid asks for more (ScenePlan.max_steps)
GRID_SLACK = 1e-9             # a grid time within this many intervals of stop is stop
RTOL_FLOOR = 10 * sys.float_info.epsilon   # no error control is finer than the rounding of y


def grid_rows(start: float, stop: float, interval: float) -> int:
    """Rows of the output grid: start + k*interval while below stop, then stop itself (so a stop
    that is not on the grid still ends the table, and an interval longer than the run gives the
    two rows start and stop). The C driver's lag_last_row is the same rule."""
    ratio = (stop - start) / interval
    last = math.floor(ratio + GRID_SLACK)
    return last + 2 if ratio - last > GRID_SLACK or last == 0 else last + 1


def step_limit(integrator: ir.IntegratorChoice, time: ir.TimeGrid) -> int:
    """The most steps (accepted + rejected) a run may take: the integrator's max_steps, or by
    default 100000 (as in Hairer's codes) or 100 per output row, whichever is larger."""
    given = dict(integrator.options).get("max_steps")
    return int(given) if given else max(DEFAULT_MAX_STEPS, 100 * grid_rows(time.start, time.stop, time.interval))


@dataclass(frozen=True)
class ScenePlan:
    model: ir.Model
    scene_name: str
    description: str | None
    time: ir.TimeGrid
    integrator: ir.IntegratorChoice
    parameters: tuple[float, ...]                   # one value per model parameter, in order
    fixed_parameters: frozenset[str]                # set explicitly: not recomputed from others
    initial: tuple[tuple[str, float | None, float | None], ...]  # (coordinate, start, velocity) overrides
    outputs: tuple[ir.OutputRequest, ...]
    invariants: tuple[str, ...]                     # names of conserved quantities to watch
    constraints: tuple[str, ...]                    # active constraints (projected, monitored)
    initial_state: tuple[float, ...]                # y0 = (q(0), q'(0)) with every override applied
    stop: ir.StopCondition | None = None            # the scene's `stop when ...`

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(o.column for o in self.outputs)

    @property
    def max_steps(self) -> int:
        return step_limit(self.integrator, self.time)

    @property
    def implicit(self) -> bool:
        return self.integrator.name in ir.IMPLICIT_INTEGRATORS

    @property
    def canonical(self) -> bool:
        return self.integrator.name == "gauss"


def plan_scene(model: ir.Model, equations: Equations, scene_name: str | None = None,
               overrides: Overrides = Overrides()) -> ScenePlan:
    scene = _find_scene(model, scene_name)
    time = _time(scene.time if scene else DEFAULT_TIME, overrides)
    integrator = _integrator(scene.integrator if scene else DEFAULT_INTEGRATOR, overrides)
    outputs = scene.outputs if scene and scene.outputs else tuple(
        ir.OutputRequest(c.name, "expression", c.symbol, None, None) for c in model.coordinates)
    set_values = dict((o.name, o.value) for o in (scene.parameter_overrides if scene else ()))
    initial = {o.coordinate: (o.start, o.velocity) for o in (scene.initial_overrides if scene else ())}
    for name, value in overrides.values:
        _apply_override(model, name, value, set_values, initial)
    parameters = _parameter_values(model, set_values)
    active = tuple(c.name for c in equations.active_constraints)
    _check_outputs(outputs, equations)
    if integrator.name == "gauss" and active:
        raise LagError("the symplectic gauss integrator does not handle constraints; use radau5 or dop853",
                       integrator.span)
    return ScenePlan(model, scene.name if scene else "default", scene.description if scene else None,
                     time, integrator, parameters, frozenset(set_values),
                     tuple((name, start, velocity) for name, (start, velocity) in initial.items()),
                     outputs, tuple(q.name for q in equations.conserved), active,
                     _initial_state(model, parameters, initial), scene.stop if scene else None)


def _find_scene(model: ir.Model, name: str | None) -> ir.Scene | None:
    if name is None:
        return model.scenes[0] if model.scenes else None
    for scene in model.scenes:
        if scene.name == name:
            return scene
    names = [s.name for s in model.scenes]
    available = f" (scenes: {', '.join(names)})" if names else " (the model has no scenes)"
    raise LagError(f"no scene '{name}' in model {model.name}{suggest(name, names)}{available}", model.span)


def _time(time: ir.TimeGrid, overrides: Overrides) -> ir.TimeGrid:
    start = overrides.start if overrides.start is not None else time.start
    stop = overrides.stop if overrides.stop is not None else time.stop
    interval = overrides.interval if overrides.interval is not None else time.interval
    for what, value in (("start time", start), ("stop time", stop), ("output interval", interval)):
        if not math.isfinite(value):
            raise LagError(f"the {what} must be a finite number, not {value}")
    if not stop > start:
        raise LagError(f"the stop time {stop:g} is not after the start time {start:g}")
    if not interval > 0:
        raise LagError("the output interval must be positive")
    if not (stop - start) / interval < MAX_ROWS or grid_rows(start, stop, interval) > MAX_ROWS:
        # The interval is what to change: point at the scene's time statement when it came from there.
        raise LagError(f"the output grid from {start:g} to {stop:g} every {interval:g} would have "
                       f"{(stop - start) / interval + 1:.3g} rows, more than the limit of {MAX_ROWS:.0e}; "
                       "choose a larger --interval", time.span if overrides.interval is None else None)
    return replace(time, start=start, stop=stop, interval=interval)


def _integrator(choice: ir.IntegratorChoice, overrides: Overrides) -> ir.IntegratorChoice:
    """The scene's integrator with the overrides applied.

    Another method (`--integrator`) keeps the scene's settings that it has too: the tolerances
    of dop853 carry over to radau5, the step of gauss to rk4. Errors in a value given as an
    override point at its option, not at the scene.
    """
    name = overrides.integrator or choice.name
    chosen = Setting(f"--integrator {name}") if overrides.integrator else choice.span
    if name not in ir.INTEGRATORS:
        raise LagError(f"unknown integrator '{name}'{suggest(name, ir.INTEGRATORS)} "
                       f"(available: {', '.join(ir.INTEGRATORS)})", chosen)
    allowed = INTEGRATOR_OPTIONS[name]
    values = {k: v for k, v in choice.options if k in allowed}
    origins: dict[str, Setting] = {}
    for key, value in overrides.options:
        origins[key] = Setting("--" + key.replace("_", "-"))
        if key not in allowed:
            raise LagError(f"{name} has no option '{key}' (options: {', '.join(allowed)})", origins[key])
        values[key] = value
    return _raise_rtol_to_floor(validate_integrator(name, values, chosen, origins))


def _raise_rtol_to_floor(choice: ir.IntegratorChoice) -> ir.IntegratorChoice:
    """rtol below 10 eps asks for more than double precision can deliver: the step size would
    collapse or the run crawl. Raise it, as Hairer's codes do, and say so once."""
    options = dict(choice.options)
    if "rtol" not in options or options["rtol"] >= RTOL_FLOOR:
        return choice
    warnings.warn(f"rtol = {options['rtol']:g} is below 10 eps; raised to {RTOL_FLOOR:.3g}", LagWarning,
                  stacklevel=2)
    options["rtol"] = RTOL_FLOOR
    return replace(choice, options=tuple(sorted(options.items())))


def check_step_count(plan: ScenePlan) -> None:
    """A fixed-step method knows its number of steps before it runs: refuse a run over the limit
    (the C integrators would stop at once with LAG_ERR_MAX_STEPS)."""
    integrator, time = plan.integrator, plan.time
    step = dict(integrator.options).get("step")
    if integrator.name not in ("rk4", "gauss") or step is None:
        return
    steps = (time.stop - time.start) / step
    if steps > plan.max_steps:
        raise LagError(f"{integrator.name} with step {step:g} would take {steps:.3g} steps from {time.start:g} to "
                       f"{time.stop:g}, more than the step limit of {plan.max_steps}; take a larger step or "
                       "raise --max-steps", integrator.span)


def _apply_override(model: ir.Model, name: str, value: float, set_values: dict, initial: dict) -> None:
    if not math.isfinite(value):
        raise LagError(f"cannot set '{name}' to {value}: values must be finite numbers")
    coordinate, _, part = name.rpartition(".")
    if part in ("start", "velocity") and coordinate:
        names = [c.name for c in model.coordinates]
        if coordinate not in names:
            raise LagError(f"cannot set '{name}': '{coordinate}' is not a coordinate{suggest(coordinate, names)}")
        start, velocity = initial.get(coordinate, (None, None))
        initial[coordinate] = (value, velocity) if part == "start" else (start, value)
        return
    parameters = {p.name: p for p in model.parameters}
    if name not in parameters:
        choices = list(parameters) + [f"{c.name}.start" for c in model.coordinates]
        raise LagError(f"cannot set '{name}': it is not a parameter, nor COORDINATE.start or "
                       f"COORDINATE.velocity{suggest(name, choices)}")
    if parameters[name].structural:
        raise LagError(f"'{name}' fixes the size of the model (it is used as an index range); "
                       "change it in the model file")
    set_values[name] = value


def _parameter_values(model: ir.Model, set_values: dict[str, float]) -> tuple[float, ...]:
    """Parameters in declaration order; a parameter not set is recomputed from the ones before."""
    values: dict = {}
    result = []
    for parameter in model.parameters:
        if parameter.name in set_values:
            value = float(set_values[parameter.name])
        else:
            value = float(parameter.expression.xreplace(values).evalf(30)) if parameter.expression.free_symbols \
                else parameter.value
            _require_finite(value, f"the parameter {parameter.name}, computed from the others,")
        values[parameter.symbol] = sympy.Float(value, 30)
        result.append(value)
    return tuple(result)


def _initial_state(model: ir.Model, parameters, initial: dict) -> tuple[float, ...]:
    values = {p.symbol: sympy.Float(v, 30) for p, v in zip(model.parameters, parameters)}
    starts, velocities = [], []
    for c in model.coordinates:
        start, velocity = initial.get(c.name, (None, None))
        starts.append(start if start is not None else float(c.start.xreplace(values).evalf(30)))
        velocities.append(velocity if velocity is not None else float(c.velocity.xreplace(values).evalf(30)))
        _require_finite(starts[-1], f"the start value of {c.name}")
        _require_finite(velocities[-1], f"the start velocity of {c.name}")
    return tuple(starts + velocities)


def _require_finite(value: float, what: str) -> None:
    """float() of an expression in overridden parameters may overflow or be NaN (m/0 with m = 0)."""
    if not math.isfinite(value):
        raise LagError(f"{what} is {value}, not a finite number (check the values set)")


def _check_outputs(outputs, equations: Equations) -> None:
    """multiplier(c), alone or in an expression, needs c to be active (it has a multiplier)."""
    dropped = {ir.multiplier_symbol(c.name): c.name for c in equations.constraints if c.dropped}
    for request in outputs:
        used = {request.target} if request.kind == "multiplier" else set()
        if request.kind == "expression":
            used |= {dropped[s] for s in request.expression.free_symbols & dropped.keys()}
        for name in sorted(used & set(dropped.values())):
            raise LagError(f"constraint '{name}' is identically satisfied by the coordinates "
                           "and was dropped, so it has no multiplier", request.span)
