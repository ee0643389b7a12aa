"""What a Model keeps to run its scenes: the programs built for them (`Program`, `build_program`),
the plans it stores for runs in other processes (run/plans.py), and its repeated runs prepared
once (`QuickRuns`), so that a repeated simulate() pays only the call and its result."""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import LagError
from .settings import RUN_OPTIONS, Overrides, given_atol_each, given_options

if TYPE_CHECKING:
    from . import ir
    from .api import Model
    from .codegen import GeneratedSource
    from .codegen.kernel import Kernel
    from .run import plans
    from .run.sweep_job import SweepJob
    from .scene import ScenePlan

BACKENDS = ("c", "numpy")
GRID_OVERRIDES = ("start", "stop", "interval", "integrator")
NOTHING_OVERRIDDEN = Overrides()    # simulate() with no arguments: one instance, found by identity in QuickRuns
SETTINGS_FIELDS = tuple(f.name for f in fields(Overrides) if f.name != "values")    # the runs alike but for their inputs
QUICK_RUNS = 16         # prepared repeated runs a Model keeps (a fit varies its inputs: the last ones)


class QuickRuns:
    """A model's repeated runs, planned without sympy from the scene's settings and values (as a
    warm `lagc run` plans, run/plans.py) and prepared once for their overrides (the last
    QUICK_RUNS kept). A C run with new values only (a fit's next call) is the last one prepared
    with the same grid and integrator given new inputs (c_backend.CRun.with_inputs). The plans
    are those of the scenes this Model ran, whose programs it keeps, and, for a Model whose
    equations are not derived yet (load), those the build cache holds with their programs."""

    def __init__(self):
        self.plans: dict[tuple, plans.StoredPlan | None] = {}   # by the scene, backend and integrator asked for
        self.runs: dict[tuple, Callable] = {}                   # by scene, backend and overrides
        self.alike: dict[tuple, Callable] = {}                  # C runs by scene, backend and overrides but values
        self.loaded: dict[tuple, object] = {}                   # the cache's plans' programs, as self.plans

    def get(self, model: Model, scene: str | None, backend: str, overrides: Overrides):
        """A function of `progress` that runs and describes the result; None where that cannot
        serve: the first run of a scene, code not yet generated."""
        key = (scene, backend, None if overrides is NOTHING_OVERRIDDEN else overrides)   # no Overrides.__hash__
        quick = self.runs.get(key)
        if quick is not None:       # kept only for a backend checked
            return quick
        check_backend(backend)
        asked = (scene, backend, overrides.integrator)
        stored = self._plan(model, asked)
        if stored is None:
            return None
        settings_key = (scene, backend, *map(overrides.__getattribute__, SETTINGS_FIELDS))    # faster than replace()
        alike = self.alike.get(settings_key)
        if alike is not None:
            quick = alike.with_inputs(*stored.values(overrides, functools.partial(_input_values, model)))
        else:
            run_plan = stored.resolve(overrides, functools.partial(_input_values, model))
            loaded = self._loaded(model, asked, stored, run_plan)
            if loaded is None:
                return None
            from .run import runner
            quick = runner.prepared(run_plan, backend, loaded, units=stored.units, origin=stored.origin)
            if backend == "c":
                _keep(self.alike, settings_key, quick)
        _keep(self.runs, key, quick)
        return quick

    def _plan(self, model: Model, asked: tuple) -> plans.StoredPlan | None:
        """The plan kept for the scene, backend and integrator `asked` for; for a Model not yet
        derived, the build cache's (looked up once)."""
        if asked not in self.plans and not model.derived:
            from .run import plans
            self.plans[asked] = plans.find(model.source, *asked)
        return self.plans.get(asked)

    def _loaded(self, model: Model, asked: tuple, stored: plans.StoredPlan, run_plan):
        """The loaded program that runs `run_plan`: the one the Model keeps, or else that of the
        build cache's plan (loaded once); None where neither is at hand."""
        program = model.built_program(run_plan.scene_name, run_plan.integrator.name, asked[1])
        if program is not None:
            return program.loaded
        if asked not in self.loaded:
            self.loaded[asked] = stored.program and stored.program.load()
        return self.loaded[asked]

    def keep_plan(self, model: Model, scene: str | None, backend: str, integrator: str | None,
                  scene_plan: ScenePlan) -> None:
        key = (scene, backend, integrator)
        stored = self.plans.get(key) or _stored_plan(model, scene, scene_plan, None)
        if stored is not None:
            self.plans[key] = stored


def _input_values(model: Model, set_values: dict[str, float], initial: dict) -> tuple[tuple[float, ...], ...]:
    """scene.input_values of `model` (plans.Computed): the model is derived if it was not."""
    from .scene import input_values
    return input_values(model.ir, set_values, initial)


@dataclass(frozen=True)
class Program:
    """What a Model keeps per scene, integrator and backend: its source, the loaded shared library
    (C) or imported module (NumPy) that runs it, and how to lower its kernel: a source kept from
    another process (codegen/kept.py) is run without one, and only a NumPy sweep needs it."""
    lower: Callable[[], Kernel]
    source: GeneratedSource
    loaded: object

    @functools.cached_property
    def kernel(self) -> Kernel:
        return self.lower()

    def library_bytes(self) -> bytes:
        """The compiled shared library (C), to ship to other processes: a ctypes handle cannot be."""
        return Path(self.loaded._name).read_bytes()


def build_program(model: Model, scene: str | None, scene_plan: ScenePlan, backend: str, overrides: Overrides) -> Program:
    """The generated, loaded code for a scene, integrator and backend (Model._program keeps it),
    its plan stored for other processes. The generated source is the one kept in the build
    cache if there is one (codegen/kept.py); else it is lowered and printed, and kept."""
    drawn = bool(scene_plan.draws)
    code_overrides = Overrides(integrator=scene_plan.integrator.name, options=overrides.options)
    code_plan = model.plan(scene, code_overrides, drawn)
    from .codegen.kept import kept_source
    from .pipeline import generate
    from .run.loading import load as load_program
    lowered = functools.cache(lambda: generate(model.equations, code_plan, backend, model.source.name))
    source = kept_source(model.source, scene, code_overrides, drawn, backend, lambda: lowered()[1])
    program = Program(lambda: lowered()[0], source, load_program(source))
    _store_plan(model, scene, backend, overrides.integrator, code_plan, source)
    return program


def _store_plan(model: Model, scene: str | None, backend: str, integrator: str | None, code_plan: ScenePlan,
                source: GeneratedSource) -> None:
    """Keep the scene's plan in the build cache for a warm `lagc run` in another process
    (run/plans.py), under the scene and integrator as asked for."""
    from .run import plans
    stored = _stored_plan(model, scene, code_plan, plans.program_entry(source))
    if stored is not None:
        plans.store(model.source, scene, backend, integrator, stored)


def _stored_plan(model: Model, scene: str | None, scene_plan: ScenePlan, entry) -> plans.StoredPlan | None:
    """What a repeated run of the scene plans from without sympy (run/plans.py), its program at
    `entry` (None: kept in the Model); None where the scene's values cannot be fixed beforehand,
    or the plan draws (a repeated run computes the scene's columns alone)."""
    from .run import plans
    from .scene import parameters_in_expressions, scene_defaults
    if scene_plan.draws:
        return None
    try:
        settings, parameters, initial_state = scene_defaults(model.ir, model.equations, scene)
    except LagError:        # a value computed from the others is not finite unless overridden
        return None
    return plans.StoredPlan(settings, parameters, initial_state, parameters_in_expressions(model.ir),
                            scene_plan.columns, scene_plan.invariants,
                            scene_plan.stop.text if scene_plan.stop else None, entry,
                            **description(model.ir, scene_plan.scene_name, scene_plan.columns))


def _keep(runs: dict, key: tuple, run: Callable) -> None:
    """Keep `run` under `key` among the last QUICK_RUNS."""
    if len(runs) >= QUICK_RUNS:
        del runs[next(iter(runs))]
    runs[key] = run


def description(model: ir.Model, scene_name: str, columns: tuple[str, ...]) -> dict:
    units = None if model.units is None else model.units.column_units(scene_name, columns)
    return dict(units=units, origin=f"{model.name}, scene {scene_name}")


def check_backend(backend: str) -> None:
    if backend not in BACKENDS:
        raise LagError(f"unknown backend '{backend}' (available: {', '.join(BACKENDS)})")


def sweep_job(model: Model, scene: str | None, backend: str, varied: dict, client, overrides: dict) -> SweepJob:
    """The job of Model.sweep and sweep_to_file: `varied` by member, `overrides` (simulate()'s
    keywords) for all; the members run the Model's program of the scene."""
    check_backend(backend)
    if client is not None and backend != "c":
        raise LagError("sweep: a Dask client runs the C backend only; use backend='c'")
    grid = {k: overrides.pop(k) for k in GRID_OVERRIDES if k in overrides}
    options = {k: overrides.pop(k) for k in RUN_OPTIONS if k in overrides}
    from .run.sweep_job import SweepJob
    base = Overrides((), grid.get("start"), grid.get("stop"), grid.get("interval"), grid.get("integrator"),
                     given_options(options), given_atol_each(options))
    return SweepJob(lambda o: model.plan(scene, o), lambda p: model._program(scene, p, backend, base), base,
                    {**overrides, **dict(varied)}, backend)
