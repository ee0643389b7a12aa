"""The Python API: `lagdsl.load("model.lag").simulate()`. The command line is a thin layer over it."""
from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .animation import DEFAULT_FPS, Animation, check_playback, drawing_of
from .errors import LagError, Setting, SimulationError
from .escape import visible
from .model_runs import (NOTHING_OVERRIDDEN, Program, QuickRuns, build_program, check_backend, description,
                         sweep_job)
from .sensitivity.methods import LyapunovMethod
from .settings import RUN_OPTIONS, Overrides, given_atol_each, given_options
from .source import SourceFile

if TYPE_CHECKING:       # what runs, lowers, sweeps or derives is imported when first used: a model
    from . import ir    # loaded from its stored plan (load) runs without sympy or lark
    from .codegen import GeneratedSource
    from .mechanics import Equations
    from .run import sweep as batch
    from .run.output import Result
    from .scene import ScenePlan



class Model(LyapunovMethod):
    """A parsed, checked model with its derived equations of motion.

    `derive=False` defers parsing and deriving to the first use that needs the model (`ir`,
    `equations`): load() passes it for a text whose stored plan the build cache holds, which
    proves that the text compiles, so that its repeated runs start without sympy or lark."""

    def __init__(self, source: SourceFile, derive: bool = True):
        self.source = source
        self._programs: dict[tuple[str, str, str, bool], Program] = {}   # scene, integrator, backend, drawn
        self._quick = QuickRuns()
        self._sensitivity_programs: dict[str, object] = {}             # sensitivity.run.Program by scene
        if derive:      # now: a model's errors are raised here
            self.ir  # noqa: B018

    @functools.cached_property
    def _compiled(self) -> tuple[ir.Model, Equations]:
        from .kept_models import compiled_model
        return compiled_model(self.source)

    @property
    def ir(self) -> ir.Model:
        return self._compiled[0]

    @property
    def equations(self) -> Equations:
        return self._compiled[1]

    @property
    def derived(self) -> bool:
        """Whether the model has been parsed and derived (see `derive`)."""
        return "_compiled" in self.__dict__

    @property
    def name(self) -> str:
        return self.ir.name

    @property
    def scenes(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.ir.scenes)

    def plan(self, scene: str | None = None, overrides: Overrides = Overrides(), draw: bool = False) -> ScenePlan:
        from .pipeline import plan
        return plan(self.ir, self.equations, scene, overrides, draw)

    def column_units(self, scene: str | None = None) -> tuple[str, ...]:
        """The unit of each column of a scene ("?" where the model does not say)."""
        columns = self.plan(scene).columns
        if self.ir.units is None:
            return ("?",) * len(columns)
        return self.ir.units.column_units(self.plan(scene).scene_name, columns)

    def emit(self, backend: str = "c", scene: str | None = None, overrides: Overrides = Overrides()) -> GeneratedSource:
        """The standalone generated source of a scene (C99 or a NumPy module)."""
        check_backend(backend)
        from .codegen.kept import kept_source, settles_code_only
        from .pipeline import generate

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
        check_backend(backend)
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
        check_backend(backend)
        scene_plan = self.plan(scene, overrides, draw)
        program = self._program(scene, scene_plan, backend, overrides)
        result = _execute(self.ir, program, scene_plan, progress)
        self._quick.keep_plan(self, scene, backend, overrides.integrator, scene_plan)
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
        job = sweep_job(self, scene, backend, set, client, overrides)
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
        return stream_to_file(sweep_job(self, scene, backend, set, client, overrides), path, workers, client, progress)

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
        """The generated, loaded code for a scene, integrator and backend: built on first use
        (model_runs.build_program), then kept. Parameters, initial values, the time grid,
        tolerances and step limits are run-time inputs of the generated code; only the scene and
        the integrator change it, so a repeated simulate() with other inputs only calls it."""
        key = (scene_plan.scene_name, scene_plan.integrator.name, backend, bool(scene_plan.draws))
        if key not in self._programs:
            self._programs[key] = build_program(self, scene, scene_plan, backend, overrides)
        return self._programs[key]


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
    from .pipeline import execute
    try:
        result = execute(program.source, scene_plan, progress, program.loaded)
    except SimulationError as error:
        if error.partial is not None:
            error.partial = split(error.partial)
        raise
    return _described(model, split(result), scene_plan.scene_name)


def load(path: str | Path) -> Model:
    """Read, check and derive a model file; raises LagError with located diagnostics. A text
    whose default scene's plan the build cache holds (run/plans.py: it compiled before, with this
    lagdsl) is parsed and derived when first needed instead (Model's `derive`)."""
    from .run import plans
    source = SourceFile.read(path)
    stored = plans.find(source, None, "c", None)
    model = Model(source, derive=stored is None)
    if stored is not None:
        model._quick.plans[(None, "c", None)] = stored        # the first simulate() reads it again else
    return model


def _described(model: ir.Model, result: Result, scene_name: str) -> Result:
    """`result` with its columns' units and what ran (the model and scene), for its plots."""
    return replace(result, **description(model, scene_name, result.columns))


def _times(start, stop, interval) -> tuple[float | None, ...]:
    """The time grid's overrides in seconds: numbers, or texts with a unit of time ("0.8 ns")."""
    if not any(isinstance(value, str) for value in (start, stop, interval)):
        return start, stop, interval        # in seconds already: no units module (it imports sympy)
    from .frontend import units
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
