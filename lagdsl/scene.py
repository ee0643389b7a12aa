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
from dataclasses import dataclass

import sympy

from . import ir
from .computed_values import computed_values
from .frontend import draws as drawing, units
from .errors import LagError, suggest
from .integrators import registry
from .mechanics import Equations
# Re-exported: the run settings were defined here before they moved to settings.py.
from .settings import (DEFAULT_INTEGRATOR, DEFAULT_MAX_STEPS, DEFAULT_TIME, GRID_SLACK, MAX_ROWS,  # noqa: F401
                       RTOL_FLOOR, RUN_OPTIONS, InputUnit, IntegratorTraits, Overrides, RunPlan, SceneSettings,
                       check_step_count, given_options, grid_rows, step_limit, with_initial)


@dataclass(frozen=True)
class ScenePlan(IntegratorTraits):
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
    draws: tuple[ir.Draw, ...] = ()                 # computed as the last columns (see drawn_outputs)

    @property
    def columns(self) -> tuple[str, ...]:
        return tuple(o.column for o in self.outputs)

    @property
    def shown_columns(self) -> int:
        """How many of the columns are the scene's outputs; the draw statements' channels follow."""
        return len(self.outputs) - sum(len(drawing.channels(d)) for d in self.draws)

    @property
    def coordinates(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.model.coordinates)

    def run_plan(self) -> RunPlan:
        """What the runner needs of this plan (no expressions)."""
        return RunPlan(self.scene_name, self.time, self.integrator, self.parameters, self.initial_state,
                       self.coordinates, self.columns, self.invariants, self.constraints,
                       self.stop.text if self.stop else None)


def plan_scene(model: ir.Model, equations: Equations, scene_name: str | None = None,
               overrides: Overrides = Overrides(), draw: bool = False) -> ScenePlan:
    """The plan of a scene with the overrides applied; with `draw`, the channels of its draw
    statements (the model's, then the scene's) follow its outputs as further columns, computed by
    the same generated code (for the animation)."""
    scene = _find_scene(model, scene_name)
    settings = _settings(model, equations, scene)
    time, integrator, set_values, initial = settings.resolve(overrides)
    parameters = _parameter_values(model, set_values)
    outputs = scene.outputs if scene and scene.outputs else tuple(
        ir.OutputRequest(c.name, "expression", c.symbol, None, None) for c in model.coordinates)
    draws = scene_draws(model, scene, settings.scene_name) if draw else ()
    outputs += drawn_outputs(draws)
    _check_multipliers(outputs, scene.stop if scene else None, equations)
    settings.check_integrator(integrator)
    if registry.get(integrator.name).second_order:
        _check_velocity_free(equations, integrator)
    return ScenePlan(model, settings.scene_name, scene.description if scene else None,
                     time, integrator, parameters, frozenset(set_values),
                     tuple((name, start, velocity) for name, (start, velocity) in initial.items()),
                     outputs, tuple(q.name for q in equations.conserved), settings.constraints,
                     _initial_state(model, parameters, initial), scene.stop if scene else None, draws)


def scene_draws(model: ir.Model, scene: ir.Scene | None, scene_name: str) -> tuple[ir.Draw, ...]:
    """What a scene draws: the model's draw statements, then the scene's own; at least one."""
    draws = model.draws + (scene.draws if scene else ())
    if not draws:
        raise LagError(f"model {model.name} draws nothing in the scene {scene_name}: an animation needs draw "
                       "statements, such as `draw line({0, 0}, {x, y});` (docs/language.md, 'Drawing')", model.span)
    return draws


def drawn_outputs(draws: tuple[ir.Draw, ...]) -> tuple[ir.OutputRequest, ...]:
    """One output column per channel of each draw statement (draws.channels), in order."""
    return tuple(ir.OutputRequest(drawing.column_name(number, label), "expression", expression, None, draw.span)
                 for number, draw in enumerate(draws, 1) for label, expression in drawing.channels(draw))


def _check_velocity_free(equations: Equations, integrator: ir.IntegratorChoice) -> None:
    """A Nystrom method integrates q'' = a(t, q): refuse a model whose M or f reads a velocity."""
    velocity = equations.velocity_in_accelerations
    if velocity:
        raise LagError(f"{registry.get(integrator.name).title} needs accelerations that do not depend on the velocities, "
                       f"and {velocity} appears in this model's equations of motion (through a mass matrix "
                       "that changes with the coordinates, dissipation, or a velocity-dependent force); "
                       "use dop853", integrator.span)


def scene_defaults(model: ir.Model, equations: Equations,
                   scene_name: str | None = None) -> tuple[SceneSettings, tuple[float, ...], tuple[float, ...]]:
    """A scene's settings before any override, and the parameter values and initial state they
    give (what a warm `lagc run` resolves overrides against, run/plans.py)."""
    settings = _settings(model, equations, _find_scene(model, scene_name))
    parameters = _parameter_values(model, dict(settings.set_values))
    initial = {name: (start, velocity) for name, start, velocity in settings.initial}
    return settings, parameters, _initial_state(model, parameters, initial)


def _settings(model: ir.Model, equations: Equations, scene: ir.Scene | None) -> SceneSettings:
    return SceneSettings(
        scene.name if scene else "default", scene.time if scene else DEFAULT_TIME,
        scene.integrator if scene else DEFAULT_INTEGRATOR, tuple(p.name for p in model.parameters),
        frozenset(p.name for p in model.parameters if p.structural), tuple(c.name for c in model.coordinates),
        tuple((o.name, o.value) for o in (scene.parameter_overrides if scene else ())),
        tuple((o.coordinate, o.start, o.velocity) for o in (scene.initial_overrides if scene else ())),
        tuple(c.name for c in equations.active_constraints), input_units(model))


def parameters_in_expressions(model: ir.Model) -> frozenset[str]:
    """The parameters that other parameters or the start values are computed from: setting one of
    them changes values beyond its own."""
    used = set()
    for expression in [p.expression for p in model.parameters] + [
            e for c in model.coordinates for e in (c.start, c.velocity)]:
        used |= expression.free_symbols
    return frozenset(p.name for p in model.parameters if p.symbol in used)


def declared_inputs(model: ir.Model) -> tuple[tuple[str, ir.Unit | None], ...]:
    """Each value that can be set from outside the model file with its declared unit (None if
    it has none): the parameters, then each coordinate's start, then each one's velocity (in the
    coordinate's unit per second): the order of the generated program's table of them."""
    declared = [(p.name, p.unit) for p in model.parameters]
    declared += [(f"{q.name}.start", q.unit) for q in model.coordinates]
    return tuple(declared + [(f"{q.name}.velocity", units.per_second(q.unit)) for q in model.coordinates])


def input_units(model: ir.Model) -> tuple[tuple[str, InputUnit], ...]:
    """What given_values.input_in_si needs of each declared unit of declared_inputs."""
    return tuple((name, units.input_unit(unit)) for name, unit in declared_inputs(model) if unit is not None)


def _find_scene(model: ir.Model, name: str | None) -> ir.Scene | None:
    if name is None:
        return model.scenes[0] if model.scenes else None
    for scene in model.scenes:
        if scene.name == name:
            return scene
    names = [s.name for s in model.scenes]
    available = f" (scenes: {', '.join(names)})" if names else " (the model has no scenes)"
    raise LagError(f"no scene '{name}' in model {model.name}{suggest(name, names)}{available}", model.span)


def input_values(model: ir.Model, set_values: dict[str, float], initial: dict) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The parameters and the initial state of the values set (as SceneSettings.resolve gives
    them), the others computed as the model defines them: what a repeated run (model_runs.QuickRuns)
    computes again when it sets a parameter that other values are computed from."""
    parameters = _parameter_values(model, set_values)
    return parameters, _initial_state(model, parameters, initial)


def _parameter_values(model: ir.Model, set_values: dict[str, float]) -> tuple[float, ...]:
    """Parameters in declaration order; a parameter not set is recomputed from the ones before
    (computed_values.py: in double precision, its function compiled once per model)."""
    names = [p.name for p in model.parameters]
    values = computed_values(model).parameters(names, set_values)
    for parameter, value in zip(model.parameters, values):
        if not math.isfinite(value) and parameter.name not in set_values:
            _require_finite(value, f"the parameter {parameter.name}, computed from the others,")
    return tuple(values)


def _initial_state(model: ir.Model, parameters, initial: dict) -> tuple[float, ...]:
    """y0 = (q(0), q'(0)): the values set in `initial`, the model's (computed_values.py) elsewhere."""
    n = len(model.coordinates)
    state = with_initial(computed_values(model).initial(parameters), [c.name for c in model.coordinates], initial)
    # checked after the loop, and the message written only for a value that fails: a chain of
    # thousands of masses is planned at every simulate()
    for k, value in enumerate(state):
        if not math.isfinite(value):
            _require_finite(value, f"the {'start value' if k < n else 'start velocity'} of {model.coordinates[k % n].name}")
    return state


def _require_finite(value: float, what: str) -> None:
    """float() of an expression in overridden parameters may overflow or be NaN (m/0 with m = 0)."""
    if not math.isfinite(value):
        raise LagError(f"{what} is {value}, not a finite number (check the values set)")


def _check_multipliers(outputs, stop: ir.StopCondition | None, equations: Equations) -> None:
    """multiplier(c), alone or in an expression (an output, the stop condition), needs c to be
    active (it has a multiplier)."""
    dropped = {ir.multiplier_symbol(c.name): c.name for c in equations.constraints if c.dropped}

    def reads(expression: sympy.Expr) -> set[str]:
        return {dropped[s] for s in expression.free_symbols & dropped.keys()}
    uses = [({request.target} if request.kind == "multiplier" else
             reads(request.expression) if request.kind == "expression" else set(), request.span)
            for request in outputs]
    uses += [(reads(stop.function), stop.span)] if stop is not None else []
    for used, span in uses:
        for name in sorted(used & set(dropped.values())):
            raise LagError(f"constraint '{name}' is identically satisfied by the coordinates "
                           "and was dropped, so it has no multiplier", span)
