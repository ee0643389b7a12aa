"""The Python API: `lagdsl.load("model.lag").simulate()`. The command line is a thin layer over it."""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import ir
from .frontend import units
from .animation import DEFAULT_FPS, Animation, check_playback, drawing_of
from .errors import LagError, Setting, SimulationError
from .escape import visible
from .mechanics import Equations
from .pipeline import compile_model, execute, generate, plan
from .scene import (RUN_OPTIONS, Overrides, ScenePlan, given_options, input_values, parameters_in_expressions,
                    scene_defaults)
from .sensitivity.methods import LyapunovMethod
from .settings import given_atol_each
from .source import SourceFile

if TYPE_CHECKING:       # what runs, lowers or sweeps is imported when first used: loading a model needs none of it
    from .codegen import GeneratedSource
    from .codegen.kernel import Kernel
    from .run import plans
    from .run import sweep as batch
    from .run.output import Result
    from .run.sweep_job import SweepJob

BACKENDS = ("c", "numpy")
GRID_OVERRIDES = ("start", "stop", "interval", "integrator")
NOTHING_OVERRIDDEN = Overrides()    # simulate() with no arguments: one instance, found by identity in QuickRuns
SETTINGS_FIELDS = tuple(f.name for f in fields(Overrides) if f.name != "values")    # the runs alike but for their inputs
QUICK_RUNS = 16         # prepared repeated runs a Model keeps (a fit varies its inputs: the last ones)


class QuickRuns:
    """A model's repeated runs, planned without sympy from the scene's settings and values (as a
    warm `lagc run` plans, run/plans.py) and prepared once for their overrides (the last
    QUICK_RUNS kept). A C run with new values only (a fit's next call) is the last one prepared
    with the same grid and integrator given new inputs (c_backend.CRun.with_inputs)."""

    def __init__(self):
        self.plans: dict[str | None, plans.StoredPlan] = {}     # by the scene asked for
        self.runs: dict[tuple, Callable] = {}                   # by scene, backend and overrides
        self.alike: dict[tuple, Callable] = {}                  # C runs by scene, backend and overrides but values

    def get(self, model: "Model", scene: str | None, backend: str, overrides: Overrides):
        """A function of `progress` that runs and describes the result; None where that cannot
        serve: the first run of a scene, code not yet generated."""
        key = (scene, backend, None if overrides is NOTHING_OVERRIDDEN else overrides)   # no Overrides.__hash__
        quick = self.runs.get(key)
        if quick is not None:       # kept only for a backend checked
            return quick
        _check_backend(backend)
        stored = self.plans.get(scene)
        if stored is None:
            return None
        computed = functools.partial(input_values, model.ir)
        settings_key = (scene, backend, *map(overrides.__getattribute__, SETTINGS_FIELDS))    # faster than replace()
        alike = self.alike.get(settings_key)
        if alike is not None:
            quick = alike.with_inputs(*stored.values(overrides, computed))
        else:
            from .run import runner
            run_plan = stored.resolve(overrides, computed)
            program = model.built_program(run_plan.scene_name, run_plan.integrator.name, backend)
            if program is None:
                return None
            quick = runner.prepared(run_plan, backend, program.loaded,
                                    **_description(model.ir, run_plan.scene_name, run_plan.columns))
            if backend == "c":
                _keep(self.alike, settings_key, quick)
        _keep(self.runs, key, quick)
        return quick

    def keep_plan(self, model: "Model", scene: str | None, scene_plan: ScenePlan) -> None:
        stored = self.plans.get(scene) or _stored_plan(model, scene, scene_plan, None)
        if stored is not None:
            self.plans[scene] = stored


class Model(LyapunovMethod):
    """A parsed, checked model with its derived equations of motion."""

    def __init__(self, source: SourceFile):
        self.source = source
        self.ir: ir.Model
        self.equations: Equations
        self.ir, self.equations = compile_model(source)
        self._programs: dict[tuple[str, str, str, bool], Program] = {}   # scene, integrator, backend, drawn
        self._quick = QuickRuns()
        self._sensitivity_programs: dict[str, object] = {}             # sensitivity.run.Program by scene
        self.fmu_code: dict[tuple, tuple] = {}      # lagdsl.fmu: a scene's FMU Kernel and C context, by scene and kinds

    @property
    def name(self) -> str:
        return self.ir.name

    @property
    def scenes(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.ir.scenes)

    def plan(self, scene: str | None = None, overrides: Overrides = Overrides(), draw: bool = False) -> ScenePlan:
        return plan(self.ir, self.equations, scene, overrides, draw)

    def column_units(self, scene: str | None = None) -> tuple[str, ...]:
        """The unit of each column of a scene ("?" where the model does not say)."""
        columns = self.plan(scene).columns
        if self.ir.units is None:
            return ("?",) * len(columns)
        return self.ir.units.column_units(self.plan(scene).scene_name, columns)

    def emit(self, backend: str = "c", scene: str | None = None, overrides: Overrides = Overrides()) -> GeneratedSource:
        """The standalone generated source of a scene (C99 or a NumPy module)."""
        _check_backend(backend)
        from .codegen.kept import kept_source, settles_code_only

        def generated() -> GeneratedSource:
            return generate(self.equations, self.plan(scene, overrides), backend, self.source.name)[1]
        return kept_source(self.source, scene, overrides, False, backend, generated) if settles_code_only(overrides) \
            else generated()

    def simulate(self, scene: str | None = None, backend: str = "c", *, set: dict | None = None,
                 start: float | None = None, stop: float | None = None, interval: float | None = None,
                 integrator: str | None = None, rtol: float | None = None, atol: float | dict[str, float | str] | None = None,
                 step: float | None = None, stages: int | None = None, max_step: float | None = None,
                 max_steps: int | None = None, norm: str | None = None, estimate_error: bool = False,
                 draw: bool = False, sensitivities=None, sensitivity_error_control: bool = True, **parameters: float) -> Result:
        """Run a scene and return its outputs.

        `set` maps parameter names, "q.start" and "q.velocity" to values (numbers in the declared
        unit, or texts with a unit: "30 deg"); parameters may also be given as keyword arguments
        (`simulate(m2=3)`). The other arguments override the scene's time grid (seconds, or
        "0.8 ns") and integrator; `atol` is one number for every component of the state, or a
        dict of components ("x", "der(x)") to numbers in each one's declared unit or texts with a
        unit (tolerances.py); `max_steps` bounds the steps (default: settings.step_limit,
        DEFAULT_MAX_STEPS or STEPS_PER_ROW per output row); `norm` is taylor's error norm, "component"
        or "state" (integrators/registry.py). `estimate_error` fills
        `result.summary.error` (an ErrorEstimate: `.value`, the largest absolute error over rows
        and columns, in `.column`; `.columns`, each column's largest, in its unit; against a 100x
        tighter rerun or the extended-precision reference; `float(...)` gives the value). Raises
        SimulationError (with `.partial`, the rows computed so far) when the integration fails,
        SimulationInterrupted (a SimulationError) when Ctrl-C stops it.
        `draw` also computes what the draw statements show (`result.drawing`, `result.animate()`).

        `sensitivities` names parameters and start values ("q.start", "q.velocity"): the run then
        integrates the variational equations with the state (sensitivity/run.py, and
        sensitivity/c_run.py on the C backend; an adaptive integrator) and returns a SensitivityResult, whose
        `.sensitivity("x", "k")` is ∂x(t)/∂k on the grid; `sensitivity_error_control` says whether
        they enter the step-size control (default: they do).
        """
        values = {**set, **parameters} if set else parameters
        given = tuple((name, single_number(name, value)) for name, value in values.items()) if values else ()
        if (start is None and stop is None and interval is None and integrator is None and rtol is None
                and atol is None and step is None and stages is None and max_step is None and max_steps is None
                and norm is None):      # values only (a fit's call): nothing to parse (a chain: 0.2 us, all() 1 us)
            overrides = Overrides(given) if given else NOTHING_OVERRIDDEN
        else:
            options = dict(rtol=rtol, atol=atol, step=step, stages=stages, max_step=max_step, max_steps=max_steps,
                           norm=norm)
            overrides = Overrides(given, *_times(start, stop, interval), integrator, given_options(options),
                                  given_atol_each(options))
        if sensitivities is not None:
            if draw:
                raise LagError("a run with sensitivities is not drawn; run simulate(..., draw=True) without them")
            return self.sensitivities(scene, backend, overrides, sensitivities, error_control=sensitivity_error_control)
        quick = None if estimate_error or draw else self._quick.get(self, scene, backend, overrides)  # as simulate_plan
        return quick() if quick is not None else self.simulate_plan(scene, backend, overrides, None, estimate_error, draw)

    def sensitivities(self, scene: str | None, backend: str, overrides: Overrides, names, times=None,
                      error_control: bool = True):
        """A run with its sensitivities by `names` (see simulate), on `times` (default: the grid)."""
        from .sensitivity import c_run, run as sensitivity
        _check_backend(backend)
        scene_plan = self.plan(scene, overrides)
        chosen = sensitivity.directions(self.ir, list(names))
        if scene_plan.scene_name not in self._sensitivity_programs:
            self._sensitivity_programs[scene_plan.scene_name] = sensitivity.build(self, scene)
        integrate = c_run.integrate_c if backend == "c" else sensitivity.integrate
        result = integrate(self._sensitivity_programs[scene_plan.scene_name], scene_plan, chosen, times, error_control)
        return _described(self.ir, result, scene_plan.scene_name)

    def simulate_plan(self, scene: str | None, backend: str, overrides: Overrides,
                      progress: Callable[[float, float, float], None] | None = None,
                      estimate_error: bool = False, draw: bool = False) -> Result:
        """`simulate` with the overrides already gathered (what `lagc run` calls); `progress` is
        called as progress(t reached, start, stop) every so often."""
        quick = None if estimate_error or draw else self._quick.get(self, scene, backend, overrides)
        if quick is not None:
            return quick(progress)
        _check_backend(backend)
        scene_plan = self.plan(scene, overrides, draw)
        program = self._program(scene, scene_plan, backend, overrides)
        result = _execute(self.ir, program, scene_plan, progress)
        self._quick.keep_plan(self, scene, scene_plan)
        if not estimate_error:
            return result

        def rerun(options) -> Result:
            tighter = replace(overrides, integrator=scene_plan.integrator.name, options=options)
            return self.simulate_plan(scene, backend, tighter)

        from . import reference
        plain = self.plan(scene, overrides) if draw else scene_plan     # the reference computes the columns alone
        error = reference.estimate_error(result, self.equations, plain, self.source.name, rerun)
        return replace(result, summary=replace(result.summary, error=error))

    def animate(self, scene: str | None = None, backend: str = "c", *, fps: int = DEFAULT_FPS, speed: float = 1.0,
                **options) -> Animation:
        """Run a scene with its draw statements and return its animation (an animation.Animation:
        shown in Jupyter, `.save("run.html")`, ".gif" or ".mp4"). The output grid is one row per
        frame at `fps` frames per second of playback, `speed` model seconds per second, unless
        `interval` is given; `options` are simulate's."""
        check_playback(fps, speed)
        return self.simulate(scene, backend, draw=True, **{"interval": speed / fps, **options}).animate(speed)

    def fit(self, data, params: dict, *, outputs=None, sigma=None, scene: str | None = None,
            bounds: dict | None = None, set: dict | None = None, integrator: str | None = None,
            backend: str = "numpy", **options):
        """Fit `params` ({name: start value}) to `data` (a CSV path or a DataFrame with a `t` column
        and columns named as the scene's outputs) by least squares, the sensitivities as the
        Jacobian; returns a sensitivity.fit.Fit (.values, .stderr, .correlation, .residuals, .cost,
        .nfev). `integrator` and `options` (rtol, atol, max_step, ...) override the scene's;
        `backend` ("numpy" or "c") runs the model. See sensitivity/fit.py for the statistics."""
        from .sensitivity.fit import fit
        unknown = [name for name in options if name not in RUN_OPTIONS]
        if unknown:
            raise LagError(f"fit: unknown option '{unknown[0]}' (options: {', '.join(RUN_OPTIONS)})")
        held = {name: single_number(name, value) for name, value in (set or {}).items()}
        return fit(self, data, params, outputs, sigma, scene, bounds, held, integrator, options, backend)

    def bench(self, scene: str | None = None, *, integrators: tuple[str, ...] | None = None, backend: str = "c",
              peers: bool = False, repeat: int = 3, set: dict | None = None, start: float | None = None,
              stop: float | None = None, interval: float | None = None, progress: bool = False):
        """Work against precision: each integrator's ladder of settings, its time and its global error
        against the extended-precision reference (see lagdsl.bench).

        `backend` is "c", "numpy" or "both"; `peers` adds scipy's solve_ivp and CyRK (if installed).
        Returns a pandas DataFrame when pandas is installed, else a list of dicts, with the columns
        of `lagc bench -o`: integrator, backend, rtol, atol, step, seconds, rhs_evals, steps,
        rejected, error, reference_error.
        """
        from . import bench
        overrides = Overrides(tuple((k, single_number(k, v)) for k, v in (set or {}).items()),
                              *_times(start, stop, interval))
        report = bench.run_bench(self, scene, overrides, integrators, bench.backends(backend), peers, repeat,
                                 progress=bench.progress_bar() if progress else None)
        return bench.table(report)

    def sweep(self, scene: str | None = None, backend: str = "c", *, set: dict, workers: int | None = None,
              client=None, progress: bool = False, **overrides) -> batch.Sweep:
        """Run B members of a scene in one call and return a `Sweep` (values shaped (B, T, C)).

        `set` maps the names simulate(set=...) takes (parameters, "q.start", "q.velocity") to
        numbers or 1-D arrays of one common length B; `overrides` are simulate's (stop, interval,
        integrator, rtol, ..., and parameters as numbers). On the C backend the members run in
        parallel on `workers` threads (default: OMP_NUM_THREADS, else every CPU), or on the Dask
        cluster behind `client` (a dask.distributed.Client); member b equals
        simulate(set={k: v[b]}) bit for bit. A member that fails is marked in `.status` with its
        `.failure_time`; the others complete. `progress` shows a progress bar on stderr. A sweep
        whose values would not fit in memory is refused before it runs: see sweep_to_file.
        """
        from .run.sweep_job import progress_bar
        job = self._sweep_job(scene, backend, set, client, overrides)
        job.check_fits()
        with progress_bar(progress, job.count) as advance:
            return job.run(0, job.count, workers, client, advance)

    def sweep_to_file(self, path: str | Path, scene: str | None = None, backend: str = "c", *, set: dict,
                      workers: int | None = None, client=None, progress: bool = False,
                      **overrides) -> batch.SweepSummary:
        """`sweep`, its tidy table (Sweep.tidy) written to `path` block by block, in memory bounded
        by a block whatever the number of members: Parquet if the name ends in .parquet (and
        pyarrow is installed), else CSV. The file appears complete or not at all; after Ctrl-C it
        holds the members run so far and SimulationInterrupted carries their summary."""
        from .run.sweep_job import stream_to_file
        return stream_to_file(self._sweep_job(scene, backend, set, client, overrides), path, workers, client, progress)

    def _sweep_job(self, scene: str | None, backend: str, varied: dict, client, overrides: dict) -> SweepJob:
        _check_backend(backend)
        if client is not None and backend != "c":
            raise LagError("sweep: a Dask client runs the C backend only; use backend='c'")
        grid = {k: overrides.pop(k) for k in GRID_OVERRIDES if k in overrides}
        options = {k: overrides.pop(k) for k in RUN_OPTIONS if k in overrides}
        from .run.sweep_job import SweepJob
        base = Overrides((), grid.get("start"), grid.get("stop"), grid.get("interval"), grid.get("integrator"),
                         given_options(options), given_atol_each(options))
        return SweepJob(lambda o: self.plan(scene, o), lambda p: self._program(scene, p, backend, base), base,
                        {**overrides, **dict(varied)}, backend)

    def equilibrium(self, scene: str | None = None, *, guess: dict | None = None, set: dict | None = None):
        """An equilibrium near `guess` ({"q": value, "q.velocity": value}; what is not given is the
        scene's start) with `set` applied: Newton on the accelerations at the given velocities
        (zero, or the rates of cyclic coordinates), the constraints kept. Returns a
        linear.Equilibrium (`.at`, `.residual`); raises AnalysisError when Newton does not converge."""
        from .linear import evaluator, find_equilibrium
        return find_equilibrium(evaluator(self, scene, guess, set))

    def linearize(self, scene: str | None = None, *, at: dict | None = None, set: dict | None = None,
                  inputs=(), outputs=None, find: bool = False):
        """The linear model about `at` (or, with `find`, about the equilibrium near it): a
        linear.LinearModel with .M .D .G .K .N .A .B .C .Dm, .coordinates, .modes(), .to_control().
        `inputs` are parameter names (B), `outputs` names of scene columns, outputs, coordinates,
        `energy` or `momentum(q)` (C, Dm; default: the scene's columns). See docs/numerics.md."""
        from .linear import linearize_model
        return linearize_model(self, scene, at, set, tuple(inputs), outputs, find)[0]

    def built_program(self, scene: str, integrator: str, backend: str) -> Program | None:
        """The code generated and loaded for a scene (by name), integrator and backend (not drawn), if built."""
        return self._programs.get((scene, integrator, backend, False))

    def _program(self, scene: str | None, scene_plan: ScenePlan, backend: str, overrides: Overrides) -> Program:
        """The generated, loaded code for a scene, integrator and backend: built on first use, then kept.

        Parameters, initial values, the time grid, tolerances, steps and step limits are run-time
        inputs of the generated code; only the scene and the integrator change the code. So a
        repeated simulate() with other inputs only fills the input arrays and calls the code.
        """
        drawn = bool(scene_plan.draws)
        key = (scene_plan.scene_name, scene_plan.integrator.name, backend, drawn)
        if key not in self._programs:
            code_overrides = Overrides(integrator=scene_plan.integrator.name, options=overrides.options)
            code_plan = self.plan(scene, code_overrides, drawn)
            from .codegen.kept import kept_source
            from .run.loading import load as load_program
            lowered = functools.cache(lambda: generate(self.equations, code_plan, backend, self.source.name))
            source = kept_source(self.source, scene, code_overrides, drawn, backend, lambda: lowered()[1])
            self._programs[key] = Program(lambda: lowered()[0], source, load_program(source))
            _store_plan(self, scene, backend, overrides.integrator, code_plan, source)
        return self._programs[key]


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
    if scene_plan.draws:
        return None
    try:
        settings, parameters, initial_state = scene_defaults(model.ir, model.equations, scene)
    except LagError:        # a value computed from the others is not finite unless overridden
        return None
    return plans.StoredPlan(settings, parameters, initial_state, parameters_in_expressions(model.ir),
                            scene_plan.columns, scene_plan.invariants,
                            scene_plan.stop.text if scene_plan.stop else None, entry)


def _execute(model: ir.Model, program: Program, scene_plan: ScenePlan, progress) -> Result:
    """The run of `scene_plan`, described (_described), the draw statements' columns taken out of
    the result (and out of the rows a failed run kept) into its `drawing`."""
    def split(result: Result) -> Result:
        if not scene_plan.draws:
            return result
        shown = scene_plan.shown_columns
        return replace(result, columns=result.columns[:shown], values=result.values[:, :shown],
                       drawing=drawing_of(f"{model.name}, scene {scene_plan.scene_name}", scene_plan.draws,
                                          result.values[:, shown:]))
    try:
        result = execute(program.source, scene_plan, progress, program.loaded)
    except SimulationError as error:
        if error.partial is not None:
            error.partial = split(error.partial)
        raise
    return _described(model, split(result), scene_plan.scene_name)


def _keep(runs: dict, key: tuple, run: Callable) -> None:
    """Keep `run` under `key` among the last QUICK_RUNS."""
    if len(runs) >= QUICK_RUNS:
        del runs[next(iter(runs))]
    runs[key] = run


def load(path: str | Path) -> Model:
    """Read, check and derive a model file; raises LagError with located diagnostics."""
    return Model(SourceFile.read(path))


def _described(model: ir.Model, result: Result, scene_name: str) -> Result:
    """`result` with its columns' units and what ran (the model and scene), for its plots."""
    return replace(result, **_description(model, scene_name, result.columns))


def _description(model: ir.Model, scene_name: str, columns: tuple[str, ...]) -> dict:
    units = None if model.units is None else model.units.column_units(scene_name, columns)
    return dict(units=units, origin=f"{model.name}, scene {scene_name}")


def _times(start, stop, interval) -> tuple[float | None, ...]:
    """The time grid's overrides in seconds: numbers, or texts with a unit of time ("0.8 ns")."""
    return tuple(units.time_in_seconds(value, name) for name, value in
                 (("start", start), ("stop", stop), ("interval", interval)))


def single_number(name: str, value) -> float | str:
    """`value` as the one number simulate() and bench() take for input `name`; a list or an array
    (several values) is refused with a pointer to sweep(), which runs one member per value."""
    if type(value) is float or type(value) is int:     # the common case, without numpy's np.ndim (microseconds a call)
        return float(value)
    if np.ndim(value) > 0:
        raise LagError(f"a run takes one value of each input, got {np.size(value)} values; to run a member "
                       f"for each, use model.sweep(set={{'{name}': [...]}})", Setting(name))
    if isinstance(value, str):
        return value        # a number and its unit, "30 deg": scene.plan_scene converts it to SI
    try:
        return float(value)
    except (TypeError, ValueError):
        raise LagError(f"expected a number, got {visible(repr(value))}", Setting(name)) from None


def _check_backend(backend: str) -> None:
    if backend not in BACKENDS:
        raise LagError(f"unknown backend '{backend}' (available: {', '.join(BACKENDS)})")
