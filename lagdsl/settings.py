"""What a run is set to, in plain numbers and names: the time grid, the integrator and its
options, the overrides given outside the model file, and the `RunPlan` the runner executes.

Nothing here needs sympy or the parser. `scene.py` resolves a scene of a parsed model through
these functions; a warm `lagc run` (`run/plans.py`) resolves the same overrides against a stored
copy of the scene's settings, with the same checks and the same messages.
"""
from __future__ import annotations

import functools
import math
import sys
import warnings
from dataclasses import dataclass, replace

from .errors import LagError, LagWarning, Setting, suggest
from .given_values import SECONDS, InputUnit, input_in_si
from .integrators import registry
from .integrators.registry import DEFAULT_MAX_STEPS, MAX_STEPS_CEILING, OPTION_ORDER, OPTIONS
from .source import Span
from .tolerances import atol_vector, check_atol_each, check_component_name, component_input, component_key

# Integrator settings that can be given outside the model file (`lagc run --rtol`, `simulate(rtol=)`).
RUN_OPTIONS = OPTION_ORDER

# Numbers the generated C shares (codegen/c_abi.py emits them as LAG_MAX_ROWS, ...). Those
# counted in units of the rounding unit eps are eps of the working precision in C.
MAX_ROWS = 10**7              # the largest output grid
# DEFAULT_MAX_STEPS (registry.py, where the help text names it): an adaptive run's step limit
# unless the grid asks for more (step_limit) ...
STEPS_PER_ROW = 100           # ... at this many steps per output row
# The work forecast (integrators/forecast.py, the C driver's lag_forecast_step): judged from this
# many accepted steps on, once every FORECAST_WINDOW steps, with the largest step of the last window.
FORECAST_JUDGED_AFTER = 1000
FORECAST_WINDOW = 100
GRID_SLACK = 1e-9             # a grid time within this many intervals of stop is stop
RTOL_FLOOR_EPS = 10           # no error control is finer than the rounding of y: rtol >= this many eps
RTOL_FLOOR = RTOL_FLOOR_EPS * sys.float_info.epsilon
# The smallest step an adaptive method may take from t on a run of length `span` is
# MIN_STEP_EPS eps max(|t|, span): below a few eps |t|, t + h == t (HNW I, II.4), and the span makes
# the test fire near t = 0 too, where eps |t| is no bound at all (10^14 such steps would not
# cross the run).
MIN_STEP_EPS = 10
# An adaptive method's first step, when none is given, is at least START_STEP_MIN_STEPS smallest
# steps: the starting-step estimate of HNW I, II.4 (the step that changes y by 1% in the norm of the
# error test) can lie below the smallest step when a component at 0 is weighed by a tiny atol
# (an electron's x' = 0 at t = 0 under atol 1e-18), and such a start is no collapse: the error
# test rejects a too large first step, which leaves room for a few rejections before the floor.
START_STEP_MIN_STEPS = 100
# Where the starting-step estimate has nothing to measure (y or f(t0, y) near 0) its probe step is
# this fraction of the span (HNW I, II.4 and RADAU5 take 1e-6, which assumes t of order 1).
START_STEP_FRACTION = 1e-6


def min_step(t: float, span: float) -> float:
    """The smallest step an adaptive method may take from t on a run of length `span` (LAG_MIN_STEP)."""
    return MIN_STEP_EPS * sys.float_info.epsilon * max(abs(t), span)


def start_step_floor(t: float, span: float) -> float:
    """The smallest first step an adaptive method starts with at t (LAG_START_STEP_FLOOR)."""
    return START_STEP_MIN_STEPS * min_step(t, span)
# K (M, or the saddle-point matrix of a constrained system) counts as singular below this
# reciprocal condition estimate: q'' would keep fewer than about 3 correct digits (relative error
# ~ eps / rcond). It is taken after equilibration, so it measures how nearly dependent the
# coordinates (and constraints) are, not their units.
RCOND_MIN_EPS = 1000
RCOND_MIN = RCOND_MIN_EPS * sys.float_info.epsilon


@dataclass(frozen=True)
class TimeGrid:
    start: float
    stop: float
    interval: float
    span: Span | None


@dataclass(frozen=True)
class IntegratorChoice:
    name: str
    options: tuple[tuple[str, float], ...]
    span: Span | Setting | None        # Setting: chosen on the command line (--integrator)
    atol_each: tuple[tuple[str, float], ...] = ()   # atol(x), atol(der(x)): tolerances.py


DEFAULT_INTEGRATOR = IntegratorChoice("dop853", (("rtol", 1e-8), ("atol", 1e-10)), None)
DEFAULT_TIME = TimeGrid(0.0, 10.0, 0.01, None)


def given_options(values) -> tuple[tuple[str, float], ...]:
    """The run options among `values` (a mapping of name to value or None) that were given; of
    atol, the value for every component (given_atol_each has those per component); a time (step,
    max_step) may carry its unit ("1 ms"); an option of words (norm) is given its word ("state")."""
    values = {**values, "atol": split_atol(values.get("atol"))[0]}
    return tuple((name, _option_number(name, values[name])) for name in RUN_OPTIONS if values.get(name) is not None)


def _option_number(name: str, value) -> float:
    """The number an option holds for `value`: in SI for a time, the index of its word for an option of words."""
    option = OPTIONS[name]
    if option.time:
        return input_in_si(name, value, SECONDS)
    if not option.choices or not isinstance(value, str):
        return float(value)             # an index, as given_options gave it (validate_integrator checks it)
    if value not in option.choices:
        raise LagError(f"must be {option.requirement}, got {value!r}", Setting("--" + option.flag))
    return float(option.choices.index(value))


def given_atol_each(values) -> tuple[tuple[str, float], ...]:
    """atol per component among `values` (tolerances.py): from {"x": 1e-18} or ["x=1e-18", ...]."""
    return split_atol(values.get("atol"))[1]


def split_atol(atol) -> tuple[float | None, tuple[tuple[str, float], ...]]:
    """(the atol of every component or None, the pairs per component) of a number, a mapping of
    component names to numbers, or command-line items (a number, or NAME=VALUE; the last number wins)."""
    if atol is None or isinstance(atol, (int, float)):
        return atol, ()
    if isinstance(atol, dict):
        return None, tuple((component_key(str(k)), single_atol(k, v)) for k, v in atol.items())
    scalar, pairs = None, []
    for item in atol:
        if isinstance(item, tuple):
            pairs.append(item)
        else:
            scalar = item
    return scalar, tuple(pairs)


def single_atol(name, value) -> float | str:
    """A value of atol(name): a number (in the component's declared unit), or a text of a number
    and its unit."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise LagError(f"atol({name}) must be a number, or a text of a number and its unit, got {value!r}",
                       Setting("atol"))
    return value if isinstance(value, str) else float(value)


@dataclass(frozen=True)
class Overrides:
    """Settings given outside the model file (`lagc run` options, `simulate()` arguments).

    `values` maps a parameter name, "q.start" or "q.velocity" to a number in the declared unit of
    what it sets, or to a text of a number and its unit ("30 deg"); SceneSettings.resolve converts
    both to SI (input_in_si).
    """

    values: tuple[tuple[str, float | str], ...] = ()
    start: float | None = None
    stop: float | None = None
    interval: float | None = None
    integrator: str | None = None
    options: tuple[tuple[str, float], ...] = ()     # rtol, atol, step, stages, max_step, max_steps
    atol_each: tuple[tuple[str, float | str], ...] = ()   # per component, as values: ("x", 1e-18), ("der(x)", "1 um/s")


def grid_rows(start: float, stop: float, interval: float) -> int:
    """Rows of the output grid: start + k*interval while below stop, then stop itself (so a stop
    that is not on the grid still ends the table, and an interval longer than the run gives the
    two rows start and stop). The C driver's lag_last_row is the same rule."""
    ratio = (stop - start) / interval
    last = math.floor(ratio + GRID_SLACK)
    return last + 2 if ratio - last > GRID_SLACK or last == 0 else last + 1


def step_limit(integrator: IntegratorChoice, time: TimeGrid) -> int:
    """The most steps (accepted + rejected) a run may take (the C driver's lag_step_limit): the
    integrator's max_steps if given; for a fixed step h, the steps it implies, which are the
    user's own count: floor((stop - start) / h) + 1, and one more a row where a step is cut to land
    on it; else DEFAULT_MAX_STEPS or STEPS_PER_ROW per output row, whichever is larger. An
    adaptive run stops long before it reaches the limit when its pace forecasts more steps than
    the limit (integrators/forecast.py): the limit is a budget of work, not a count a legitimate
    run is expected to reach."""
    options = dict(integrator.options)
    rows = grid_rows(time.start, time.stop, time.interval)
    if options.get("max_steps"):
        return int(options["max_steps"])
    if options.get("step", 0) > 0:
        return min(math.floor((time.stop - time.start) / options["step"]) + 1 + rows, MAX_STEPS_CEILING)
    return max(DEFAULT_MAX_STEPS, STEPS_PER_ROW * rows)


class IntegratorTraits:
    """What follows from a plan's integrator and time grid (for ScenePlan and RunPlan alike)."""

    integrator: IntegratorChoice
    time: TimeGrid

    @property
    def max_steps(self) -> int:
        return step_limit(self.integrator, self.time)

    @property
    def implicit(self) -> bool:
        return registry.get(self.integrator.name).implicit

    @property
    def canonical(self) -> bool:
        return registry.get(self.integrator.name).canonical

    @property
    def series(self) -> bool:
        return registry.get(self.integrator.name).series

    def atol_vector(self, coordinates: tuple[str, ...]) -> tuple[float, ...] | None:
        """The absolute tolerance of each component of y = (q, q'), or None when atol is one
        number for all (tolerances.py)."""
        return atol_vector(dict(self.integrator.options).get("atol", 0.0), self.integrator.atol_each, coordinates,
                           self.time.stop - self.time.start)


@dataclass(frozen=True)
class RunPlan(IntegratorTraits):
    """What the runner needs to run generated code: names and numbers, no expressions."""

    scene_name: str
    time: TimeGrid
    integrator: IntegratorChoice
    parameters: tuple[float, ...]           # one value per model parameter, in order
    initial_state: tuple[float, ...]        # y0 = (q(0), q'(0))
    coordinates: tuple[str, ...]
    columns: tuple[str, ...]
    invariants: tuple[str, ...]             # names of conserved quantities to watch
    constraints: tuple[str, ...]            # active constraints (projected, monitored)
    stop: str | None = None                 # the text of the scene's `stop when` condition


@dataclass(frozen=True)
class SceneSettings:
    """A scene's settings before the overrides: its time grid and integrator, its `set`
    statements, and the names that overrides may refer to."""

    scene_name: str
    time: TimeGrid
    integrator: IntegratorChoice
    parameters: tuple[str, ...]                     # every parameter, in order
    structural: frozenset[str]                      # parameters that fix the size of the model
    coordinates: tuple[str, ...]
    set_values: tuple[tuple[str, float], ...]       # the scene's `set p = value`
    initial: tuple[tuple[str, float | None, float | None], ...]   # the scene's (coordinate, start, velocity)
    constraints: tuple[str, ...]                    # active constraints
    units: tuple[tuple[str, InputUnit], ...] = ()   # the declared unit of each input that has one

    def resolve(self, overrides: Overrides) -> tuple[TimeGrid, IntegratorChoice, dict, dict]:
        """The time grid, the integrator, the parameters set ({name: value}) and the initial values
        set ({coordinate: (start, velocity)}) with `overrides` applied on top of the scene's."""
        time = _time(self.time, overrides)
        integrator = _integrator(self.integrator, overrides, self.coordinates, dict(self.units))
        return (time, integrator, *self.resolve_values(overrides))

    def resolve_values(self, overrides: Overrides) -> tuple[dict, dict]:
        """The parameters set and the initial values set of `resolve`, alone (the time grid and
        the integrator left out: a repeated run with the same ones has checked them)."""
        units, set_values, initial = map(dict, self._as_dicts)     # copies, which the overrides change
        for name, value in overrides.values:
            self._check_name(name)
            self._apply_override(name, input_in_si(name, value, units.get(name)), set_values, initial)
        return set_values, initial

    @functools.cached_property
    def _as_dicts(self) -> tuple[dict, dict, dict]:
        """The units, the values set and the initial values by name, made once (a repeated run's)."""
        return dict(self.units), dict(self.set_values), {name: (start, velocity) for name, start, velocity in self.initial}

    def check_integrator(self, choice: IntegratorChoice) -> None:
        refusal = registry.get(choice.name).refusal("c", bool(self.constraints))
        if refusal is not None:
            raise LagError(refusal, choice.span)

    def _check_name(self, name: str) -> None:
        """`name` is a parameter that may be set, or COORDINATE.start or COORDINATE.velocity."""
        coordinate, _, part = name.rpartition(".")
        if part in ("start", "velocity") and coordinate:
            if coordinate not in self.coordinates:
                raise LagError(f"cannot set '{name}': '{coordinate}' is not a coordinate"
                               f"{suggest(coordinate, self.coordinates)}")
            return
        if name not in self.parameters:
            choices = list(self.parameters) + [f"{c}.start" for c in self.coordinates]
            raise LagError(f"cannot set '{name}': it is not a parameter, nor COORDINATE.start or "
                           f"COORDINATE.velocity{suggest(name, choices)}")
        if name in self.structural:
            raise LagError(f"'{name}' fixes the size of the model (it is used as an index range); "
                           "change it in the model file")

    @staticmethod
    def _apply_override(name: str, value: float, set_values: dict, initial: dict) -> None:
        """Set the checked `name` to `value` (in SI)."""
        if not math.isfinite(value):
            raise LagError(f"cannot set '{name}' to {value}: values must be finite numbers")
        coordinate, _, part = name.rpartition(".")
        if part in ("start", "velocity") and coordinate:
            start, velocity = initial.get(coordinate, (None, None))
            initial[coordinate] = (value, velocity) if part == "start" else (start, value)
        else:
            set_values[name] = value


def _time(time: TimeGrid, overrides: Overrides) -> TimeGrid:
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


def _integrator(choice: IntegratorChoice, overrides: Overrides, coordinates: tuple[str, ...],
                units: dict[str, InputUnit]) -> IntegratorChoice:
    """The scene's integrator with the overrides applied (an atol per component read in its
    declared unit, `units`, and kept in SI).

    Another method (`--integrator`) keeps the scene's settings that it has too: the tolerances
    of dop853 carry over to radau5, the step of gauss to rk4. Errors in a value given as an
    override point at its option, not at the scene.
    """
    name = overrides.integrator or choice.name
    chosen = Setting(f"--integrator {name}") if overrides.integrator else choice.span
    check_integrator_name(name, chosen)
    allowed = registry.get(name).options
    values = {k: v for k, v in choice.options if k in allowed}
    origins: dict[str, Setting] = {}
    for key, value in overrides.options:
        origins[key] = Setting("--" + OPTIONS[key].flag)
        if key not in allowed:
            raise LagError(f"{name} has no option '{key}' (options: {', '.join(allowed)})", origins[key])
        values[key] = value
    atol_each = dict(choice.atol_each) if "atol" in allowed else {}
    for key, value in overrides.atol_each:
        origins[key] = Setting(f"--atol {key}={value if isinstance(value, str) else format(value, 'g')}")
        if "atol" not in allowed:
            raise LagError(f"{name} has no option 'atol' (options: {', '.join(allowed)})", origins[key])
        check_component_name(key, coordinates, origins[key])
        atol_each[key] = input_in_si(f"atol({key})", value, units.get(component_input(key, coordinates)))
    check_atol_each(tuple(atol_each.items()), coordinates, registry.get(name).implicit, origins)
    validated = validate_integrator(name, values, chosen, origins)
    return _raise_rtol_to_floor(replace(validated, atol_each=tuple(sorted(atol_each.items()))))


def _raise_rtol_to_floor(choice: IntegratorChoice) -> IntegratorChoice:
    """rtol below RTOL_FLOOR asks for more than double precision can deliver: the step size would
    collapse or the run crawl. Raise it, as Hairer's codes do, and say so once."""
    options = dict(choice.options)
    if "rtol" not in options or options["rtol"] >= RTOL_FLOOR:
        return choice
    warnings.warn(f"rtol = {options['rtol']:g} is below {RTOL_FLOOR_EPS} eps; raised to {RTOL_FLOOR:.3g}", LagWarning,
                  stacklevel=2)
    options["rtol"] = RTOL_FLOOR
    return replace(choice, options=tuple(sorted(options.items())))


def check_integrator_name(name: str, span: Span | Setting | None) -> None:
    if not registry.known(name):
        names = registry.names()
        raise LagError(f"unknown integrator '{name}'{suggest(name, names)} (available: {', '.join(names)})", span)


def validate_integrator(name: str, values: dict[str, float], span: Span | Setting | None,
                        origins: dict[str, Span | Setting] | None = None) -> IntegratorChoice:
    """Check and complete an integrator's options: each value as its option's record requires,
    rtol and atol not both 0 (and atol positive for an implicit method), a step for a fixed-step
    one, the record's defaults for the rest. rtol below RTOL_FLOOR is raised by the scene plan, not
    here. `span` is where the integrator was chosen, `origins` where each option's value was
    given (in the scene, or a command-line option): errors point there."""
    origins = origins or {}
    record = registry.get(name)
    for key, value in values.items():
        if not OPTIONS[key].accepts(value):
            raise LagError(f"{name}({key} = ...) must be {OPTIONS[key].requirement}", origins.get(key, span))
    if values.get("rtol") == 0 and values.get("atol") == 0:
        raise LagError(f"{name}(rtol = ..., atol = ...) cannot both be 0", origins.get("rtol", span))
    if record.implicit and values.get("atol") == 0:
        # Hairer's RADAU5 refuses it too: the Newton iteration weighs each component by
        # atol + rtol |y|, which is 0 for a component at 0 (a body at rest).
        raise LagError(f"{name}(atol = ...) must be positive: the implicit method weighs each "
                       "component by atol + rtol |y|, which is 0 where a component is 0",
                       origins.get("atol", span))
    if record.fixed_step and "step" not in values:
        example = "--step 0.001" if isinstance(span, Setting) else f"{name}(step = 0.001)"
        raise LagError(f"{name} is a fixed-step method and needs a step: {example}", span)
    for key, default in record.defaults:
        values.setdefault(key, default)
    return IntegratorChoice(name, tuple(sorted(values.items())), span)


def check_step_count(plan: IntegratorTraits) -> None:
    """A fixed-step method knows its number of steps before it runs: refuse a run over the limit
    (the C integrators would stop at once with LAG_ERR_MAX_STEPS)."""
    choice, time = plan.integrator, plan.time
    step = dict(choice.options).get("step")
    if not registry.get(choice.name).fixed_step or step is None:
        return
    steps = (time.stop - time.start) / step
    if steps > plan.max_steps:
        raise LagError(f"{choice.name} with step {step:g} would take {steps:.3g} steps from {time.start:g} to "
                       f"{time.stop:g}, more than the step limit of {plan.max_steps}; take a larger step or "
                       "raise --max-steps", choice.span)


def with_initial(state, coordinates, initial: dict) -> tuple[float, ...]:
    """The initial state `state` (q(0), then q'(0), of `coordinates`) with the start values and
    velocities set in `initial` ({coordinate: (start or None, velocity or None)}) put in."""
    state, n = list(state), len(coordinates)
    for k, name in enumerate(coordinates):
        start, velocity = initial.get(name, (None, None))
        state[k] = start if start is not None else state[k]
        state[n + k] = velocity if velocity is not None else state[n + k]
    return tuple(state)
