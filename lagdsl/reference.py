"""The reference solution of a scene: the same scene computed far more accurately than any
setting it judges, to measure the global error of a run (`lagc bench`, `lagc run --error`).

The generated C is built in extended precision (`real` = __float128 with libquadmath when the
compiler has it, long double otherwise) and run with taylor (radau5 for scenes that chose an
implicit method: they are stiff) at a tolerance many orders below the tightest setting of a
bench ladder (rtol 1e-13). Its own accuracy is estimated, not assumed: a second reference at a
100x looser tolerance is computed, and the largest difference between the two (over the output
rows and columns) bounds the error of the tighter one, whose error is smaller by about the ratio
of the tolerances. The output grid adds one more term: a double-precision run writes its rows at
the times t0 + k dt rounded to double, the extended-precision run at the exact ones; the
solution moves by up to |y'| ulp(t) in between.

Both runs use the parameters and initial state of the plan as doubles, exactly what every
double-precision run of the scene starts from, and deliver their rows as doubles. The result is
cached by content hash (the generated source, the compiler, the precision, every input of the
run), like the compiled libraries (`run/cache.py`): a second bench of the same scene does not
recompute it.
"""
from __future__ import annotations

import ctypes
import hashlib
import json
import time as clock
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from . import ir
from .errors import LagError, SimulationError
from .integrators import registry
from .mechanics import Equations
from .pipeline import generate
from .run.cache import cached_entry, find_entry
from .run.c_backend import run_c
from .run.scipy_steps import Progress
from .run.toolchain import extended_precision, find_compiler, shared_library
from .run.output import ErrorEstimate, Result
from .scene import ScenePlan
from .settings import RTOL_FLOOR

# rtol of the reference and of its check run, per precision and method. taylor's error follows
# its tolerance down to the rounding of the output; radau5 (order 5) needs a tighter one.
REFERENCE_TOLERANCES = {
    "float128": {"taylor": (1e-20, 1e-18), "radau5": (1e-22, 1e-20)},
    "long double": {"taylor": (1e-17, 1e-15), "radau5": (1e-17, 1e-15)},
}
REFERENCE_MAX_STEPS = 10**7
DEFAULT_ATOL_RATIO = 1e-2       # atol / rtol when the scene gives no tolerances (dop853's defaults)
PRECISION_NAMES = {"float128": "__float128", "long double": "long double"}


@dataclass(frozen=True)
class Reference:
    """The reference rows (`t`, `values` in the scene's `columns`) and how far they can be trusted."""

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray
    accuracy: float           # estimated largest absolute error of `values`
    integrator: str
    precision: str            # "float128" or "long double"
    rtol: float
    atol: float
    seconds: float            # the time both runs took when the reference was computed
    cached: bool              # read from the cache this time

    def describe(self) -> str:
        where = "from the cache" if self.cached else "computed"
        return (f"reference: {self.integrator}(rtol = {self.rtol:g}, atol = {self.atol:g}) in "
                f"{PRECISION_NAMES[self.precision]}, accuracy {self.accuracy:.2g} (max abs over rows and "
                f"columns; from a second reference at 100x the tolerance), {self.seconds:.3g} s, {where}")

    def error_of(self, values: np.ndarray) -> float:
        """The largest absolute difference of `values` (rows of the same grid and columns) from the
        reference, over the rows both have (a stop condition may end a run a row sooner or later)."""
        return float(np.max(self.column_errors(values), initial=0.0))

    def column_errors(self, values: np.ndarray) -> np.ndarray:
        """The largest absolute difference from the reference in each column, over the rows both have."""
        rows = min(len(values), len(self.values))
        return _column_differences(values[:rows], self.values[:rows])


def reference_method(plan: ScenePlan) -> str:
    """radau5 for a scene that chose an implicit method (it is stiff), taylor otherwise: in
    __float128 it reaches dop853's accuracy in a quarter of its time (the double pendulum over
    20 s at rtol 1e-20: 0.29 s against 1.26 s of CPU; benchmarks/README.md)."""
    return "radau5" if registry.get(plan.integrator.name).implicit else "taylor"


def atol_ratio(plan: ScenePlan) -> float:
    """atol / rtol of the scene's tolerances, by which every ladder and reference scales atol."""
    options = dict(plan.integrator.options)
    if options.get("rtol") and "atol" in options:
        return options["atol"] / options["rtol"]
    return DEFAULT_ATOL_RATIO


@dataclass(frozen=True)
class _Recipe:
    """What the reference of a plan is computed from, and the name and key of its cache entry."""

    plans: tuple[ScenePlan, ScenePlan]      # the reference and its check, 100x looser
    kernel: object
    source: object
    precision: str
    name: str
    key: str


def _recipe(equations: Equations, plan: ScenePlan, source_name: str) -> _Recipe:
    precision = extended_precision(find_compiler())
    method = reference_method(plan)
    ratio = atol_ratio(plan)
    plans = tuple(_with_tolerance(plan, method, rtol, ratio) for rtol in REFERENCE_TOLERANCES[precision][method])
    kernel, source = generate(equations, plans[0], "c", source_name)
    inputs = {"version": 1, "source": hashlib.sha256(source.text.encode()).hexdigest(), "compiler": find_compiler(),
              "precision": precision, "parameters": plan.parameters, "initial": plan.initial_state,
              "time": (plan.time.start, plan.time.stop, plan.time.interval),
              "options": [p.integrator.options for p in plans]}
    key = hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()
    return _Recipe(plans, kernel, source, precision, f"{source.suggested_name}-reference-{key[:20]}.npz", key)


def reference_is_cached(equations: Equations, plan: ScenePlan, source_name: str) -> bool:
    recipe = _recipe(equations, plan, source_name)
    return find_entry(recipe.name, recipe.key) is not None


def reference_solution(equations: Equations, plan: ScenePlan, source_name: str,
                       progress: Progress | None = None) -> Reference:
    """The reference for the scene as planned (its parameters, initial state, time grid); cached."""
    recipe = _recipe(equations, plan, source_name)
    computed = []

    def build(path) -> None:
        library = ctypes.CDLL(str(shared_library(recipe.source.text, recipe.source.suggested_name,
                                                    openmp=False, precision=recipe.precision)))
        started = clock.perf_counter()
        rows = [_run(recipe.kernel, recipe.source, p, library, progress) for p in recipe.plans]
        seconds = clock.perf_counter() - started
        accuracy = max(float(np.max(np.abs(rows[0].values - rows[1].values), initial=0.0)),
                       _grid_rounding(rows[0].t, rows[0].values))
        with open(path, "wb") as stream:
            np.savez(stream, t=rows[0].t, values=rows[0].values, accuracy=accuracy, seconds=seconds)
        computed.append(True)

    entry = cached_entry(recipe.name, recipe.key, build)
    options = dict(recipe.plans[0].integrator.options)
    with np.load(entry) as data:
        return Reference(data["t"], plan.columns, data["values"], float(data["accuracy"]),
                         recipe.plans[0].integrator.name, recipe.precision, options["rtol"], options["atol"],
                         float(data["seconds"]), cached=not computed)


def estimate_error(result: Result, equations: Equations, plan: ScenePlan, source_name: str,
                   rerun: Callable[[tuple[tuple[str, float], ...]], Result]) -> ErrorEstimate:
    """The global error of `result` (a run of `plan`): its largest absolute difference from a rerun
    with 100x tighter settings (`rerun(options)`), or from the reference when that is cached or the
    tighter settings are beyond double precision (rtol / 100 below RTOL_FLOOR) or fail. A rerun costs
    a few times the run (dop853's work grows like tol^(-1/8)); a reference, dozens of times."""
    started = clock.perf_counter()
    tighter = tighter_options(plan)
    if tighter is not None and not reference_is_cached(equations, plan, source_name):
        try:
            other = rerun(tighter)
            if other.values.shape != result.values.shape:
                raise SimulationError("the rerun delivered other rows", 0.0, {}, "")
            settings = ", ".join(f"{key} = {value:g}" for key, value in tighter)
            return _estimate(result, _column_differences(result.values, other.values), f"a rerun at {settings}",
                             started)
        except (SimulationError, LagError):
            pass
    reference = reference_solution(equations, plan, source_name)
    return _estimate(result, reference.column_errors(result.values),
                     f"the {PRECISION_NAMES[reference.precision]} reference (its accuracy {reference.accuracy:.2g})",
                     started)


def _estimate(result: Result, errors: np.ndarray, against: str, started: float) -> ErrorEstimate:
    """The estimate from each column's largest error, with the columns' names and units."""
    return ErrorEstimate(float(np.max(errors, initial=0.0)), against, clock.perf_counter() - started,
                         tuple(zip(result.columns, map(float, errors))), result.units)


def tighter_options(plan: ScenePlan) -> tuple[tuple[str, float], ...] | None:
    """Settings whose error is about 100x smaller: tolerances / 100, or the step / 100^(1/order)
    (rk4: order 4, gauss: 2 per stage). None when rtol / 100 is below double precision's floor."""
    options = dict(plan.integrator.options)
    if "step" in options:
        order = registry.get(plan.integrator.name).order_with(options)
        kept = (("stages", options["stages"]),) if "stages" in options else ()
        return (("step", options["step"] / 100 ** (1 / order)), *kept)
    if options.get("rtol", 0) / 100 < RTOL_FLOOR:
        return None
    return (("rtol", options["rtol"] / 100), ("atol", options["atol"] / 100))


def _column_differences(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.max(np.abs(a - b), axis=0, initial=0.0)


def _with_tolerance(plan: ScenePlan, method: str, rtol: float, ratio: float) -> ScenePlan:
    """The plan run with `method` at rtol (atol = ratio rtol), below double precision's rtol floor
    on purpose, and a step limit for the many steps that takes."""
    options = (("atol", rtol * ratio), ("max_steps", float(REFERENCE_MAX_STEPS)), ("rtol", rtol))
    return replace(plan, integrator=ir.IntegratorChoice(method, options, None))


def _run(kernel, source, plan: ScenePlan, library, progress: Progress | None):
    try:
        return run_c(kernel, source, plan.run_plan(), progress, library)
    except SimulationError as error:
        options = dict(plan.integrator.options)
        error.message = (f"the reference solution ({plan.integrator.name} at rtol = {options['rtol']:g} in "
                         f"extended precision) failed: {error.message}")
        raise


def _grid_rounding(t: np.ndarray, values: np.ndarray) -> float:
    """How far the solution moves between an output time and its value rounded to double:
    the largest |change per unit time| between neighbouring rows times ulp(t)."""
    if len(t) < 2:
        return 0.0
    slopes = np.max(np.abs(np.diff(values, axis=0)), axis=1, initial=0.0) / np.diff(t)
    return float(np.max(slopes * np.spacing(np.abs(t[1:]))))
