"""Work against precision for the user's own model and scene (`lagc bench`, `Model.bench`).

Each integrator the scene admits runs a ladder of settings: rtol = 1e-3 .. 1e-13 (atol scaled
with it by the scene's atol/rtol) for the adaptive methods, steps of 4 down to 1/64 output
intervals for the fixed-step rk4 and gauss. Each setting records its integration time (best of
`repeat` runs), its work counters, and its global error: the largest absolute difference, over
the output rows and the scene's output columns, from the extended-precision reference
(`reference.py`). An error below the reference's own accuracy is not measured; it is reported
as that accuracy and marked, never as exact. `peers` adds the same ladder for scipy's solve_ivp
and CyRK (when installed) on the NumPy backend's right-hand side.
"""
from __future__ import annotations

import time as clock
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from decimal import Decimal

import numpy as np

from . import ir
from .errors import LagError, SimulationError
from .integrators import registry
from . import progress as progress_module
from .pipeline import execute, generate
from .reference import Reference, atol_ratio, reference_solution
from .run.loading import load as load_program
from .run.output import output_times
from .run.tables import csv_text
from .scene import ScenePlan
from .settings import Overrides, check_integrator_name

# The ladders' values are exact decimals (1e-06, not 1e-4 * 0.01 = 1.0000000000000002e-06): built
# as decimal products, then rounded once to double.
ADAPTIVE_RTOLS = tuple(Decimal(f"1e-{k}") for k in range(3, 14))
STEP_FACTORS = tuple(Decimal(2) ** j for j in range(2, -7, -1))     # steps of 4 .. 1/64 output intervals
MIN_TIMED = 0.05            # seconds: runs shorter than this are repeated (up to MAX_RUNS) for a stable best time
MAX_RUNS = 50
LADDER_TIME_LIMIT = 20.0     # seconds: a setting slower than this ends its ladder (tighter ones are slower still)
CSV_HEADER = ("integrator", "backend", "rtol", "atol", "step", "seconds", "rhs_evals", "steps", "rejected", "error",
              "reference_error")
SETTING_COLUMNS = ("rtol", "atol", "step")
SCIPY_PEERS = ("RK45", "DOP853", "Radau", "LSODA")
CYRK_PEERS = ("RK45", "DOP853")
BACKEND_CHOICES = {"c": ("c",), "numpy": ("numpy",), "both": ("c", "numpy")}


@dataclass(frozen=True)
class Setting:
    """One rung of a ladder: a method on a backend with its tolerances or its step."""

    integrator: str          # a lagdsl integrator, or a peer: "scipy-RK45", "cyrk-DOP853"
    backend: str             # "c" or "numpy" (peers run on the NumPy backend's right-hand side)
    rtol: float | None = None
    atol: float | None = None
    step: float | None = None

    @property
    def method(self) -> str:
        return f"{self.integrator} ({self.backend})"

    @property
    def coarseness(self) -> float:
        """The rung's place on its ladder: rtol, or the step of a fixed-step method."""
        return self.rtol if self.rtol is not None else self.step

    def describe(self) -> str:
        values = (("rtol", self.rtol), ("atol", self.atol), ("step", self.step))
        return f"{self.integrator} {self.backend} " + " ".join(f"{k}={v:g}" for k, v in values if v is not None)


@dataclass(frozen=True)
class BenchRow:
    setting: Setting
    seconds: float | None = None
    rhs_evals: int | None = None
    steps: int | None = None
    rejected: int | None = None
    measured: float | None = None        # max |run - reference|, None when the run failed
    reference_error: float = 0.0
    failure: str | None = None

    @property
    def below_reference(self) -> bool:
        """The difference from the reference is within the reference's own accuracy: not measured."""
        return self.measured is not None and self.measured <= self.reference_error

    @property
    def error(self) -> float | None:
        """The reported error: the measured one, or the reference's accuracy when it is below it."""
        if self.measured is None:
            return None
        return max(self.measured, self.reference_error)

    def record(self) -> dict:
        s = self.setting
        return {"integrator": s.integrator, "backend": s.backend, "rtol": s.rtol, "atol": s.atol, "step": s.step,
                "seconds": self.seconds, "rhs_evals": self.rhs_evals, "steps": self.steps,
                "rejected": self.rejected, "error": self.error, "reference_error": self.reference_error}


@dataclass(frozen=True)
class Drift:
    """I(t) - I(t0) of each conserved quantity, for one method's tightest setting."""

    setting: Setting
    t: np.ndarray
    drifts: tuple[tuple[str, np.ndarray], ...]


@dataclass(frozen=True)
class BenchReport:
    model: str
    scene: str
    reference: Reference
    rows: tuple[BenchRow, ...]
    notes: tuple[str, ...] = ()              # integrators not admitted, ladders cut short
    drifts: tuple[Drift, ...] = field(default=())
    invariant_units: tuple[tuple[str, str], ...] = ()     # (conserved quantity, its unit) for the drifts

    def sorted_rows(self) -> list[BenchRow]:
        """By method (lagdsl's integrators first, then the peers), then along its ladder, loosest
        first (by time, noise would scramble the tolerances)."""
        return sorted(self.rows, key=lambda r: (not registry.known(r.setting.integrator), r.setting.integrator,
                                                r.setting.backend, -r.setting.coarseness))

    def records(self) -> list[dict]:
        """The successful settings, one dict per row with the CSV's columns."""
        return [row.record() for row in self.sorted_rows() if row.failure is None]

    def csv(self) -> str:
        """The records as CSV; a setting as its shortest decimal (1e-06, which %.17g writes as
        9.9999999999999995e-07), the measurements as every table of lagdsl writes numbers."""
        records = self.records()
        return csv_text(CSV_HEADER, [[repr(record[name]) if name in SETTING_COLUMNS and record[name] is not None
                                      else record[name] for record in records] for name in CSV_HEADER])

    def render(self) -> str:
        """The table for the terminal: the reference, then one line per setting."""
        head = f"{'integrator':<14}{'backend':<8}{'rtol':>8}{'atol':>8}{'step':>9}{'seconds':>10}" \
               f"{'rhs_evals':>11}{'steps':>9}{'rejected':>9}  error"
        lines = [f"{self.model}, scene {self.scene}", self.reference.describe(), "", head]
        for row in self.sorted_rows():
            s = row.setting
            numbers = "".join(f"{_short(v):>{w}}" for v, w in ((s.rtol, 8), (s.atol, 8), (s.step, 9)))
            if row.failure is not None:
                lines.append(f"{s.integrator:<14}{s.backend:<8}{numbers}  failed: {row.failure}")
                continue
            error = f"<= {row.error:.2g} (reference accuracy)" if row.below_reference else f"{row.error:.2g}"
            counts = "".join(f"{'' if v is None else v:>{w}}" for v, w in
                             ((row.rhs_evals, 11), (row.steps, 9), (row.rejected, 9)))
            lines.append(f"{s.integrator:<14}{s.backend:<8}{numbers}{row.seconds:>10.3g}{counts}  {error}")
        lines += [f"note: {note}" for note in self.notes]
        return "\n".join(lines)


def _short(value: float | None) -> str:
    return "" if value is None else f"{value:.3g}"


# ---- ladders ---------------------------------------------------------------------------------
def adaptive_ladder(integrator: str, backend: str, ratio: float) -> list[Setting]:
    """rtol = 1e-3 .. 1e-13, atol = ratio * rtol."""
    return [Setting(integrator, backend, rtol=float(rtol), atol=float(rtol * _decimal(ratio)))
            for rtol in ADAPTIVE_RTOLS]


def step_ladder(integrator: str, backend: str, plan: ScenePlan) -> list[Setting]:
    """Steps of 4 down to 1/64 output intervals (the interval resolves the motion the user wants
    to see), none longer than the run, none needing more steps than the plan's step limit."""
    span = plan.time.stop - plan.time.start
    steps = [float(_decimal(plan.time.interval) * factor) for factor in STEP_FACTORS]
    return [Setting(integrator, backend, step=h) for h in steps if h <= span and span / h <= plan.max_steps]


def _decimal(value: float) -> Decimal:
    """The shortest decimal that reads back as `value` (0.01, not 0.01000000000000000020816...)."""
    return Decimal(repr(value))


def ladder(integrator: str, backend: str, plan: ScenePlan) -> list[Setting]:
    if registry.get(integrator).fixed_step:
        return step_ladder(integrator, backend, plan)
    return adaptive_ladder(integrator, backend, atol_ratio(plan))


def backends(choice: str) -> tuple[str, ...]:
    """"c", "numpy" or "both" -> the backends to run."""
    if choice not in BACKEND_CHOICES:
        raise LagError(f"unknown backend '{choice}' (available: {', '.join(BACKEND_CHOICES)})")
    return BACKEND_CHOICES[choice]


def progress_bar():
    """A progress bar that follows the settings (its total is set by run_bench)."""
    return progress_module.bar(0, "setting")


# ---- the bench -------------------------------------------------------------------------------
def run_bench(model, scene: str | None = None, overrides: Overrides = Overrides(),
              integrators: tuple[str, ...] | None = None, backends: tuple[str, ...] = ("c",),
              peers: bool = False, repeat: int = 3, drift: bool = False, progress=None,
              time_limit: float = LADDER_TIME_LIMIT) -> BenchReport:
    """Every admitted integrator's ladder on each backend (and the peers'), against the reference.

    `model` is an api.Model; `overrides` carries parameters, initial values and the time grid
    (integrator settings in it are ignored: the ladders set them). `progress`, if given, is a
    tqdm-like object (update(n), set_description(text), total) that follows the settings. A ladder
    stops after a setting slower than `time_limit` seconds.
    """
    if repeat < 1:
        raise LagError(f"repeat must be at least 1, got {repeat}")
    for backend in backends:
        if backend not in ("c", "numpy"):
            raise LagError(f"unknown backend '{backend}' (available: c, numpy)")
    base = replace(overrides, integrator=None, options=())
    plan = model.plan(scene, base)
    chosen, notes = _admitted(model, scene, base, plan.time.interval, integrators, backends)
    ladders = [ladder(name, backend, plan) for name, backend in chosen]
    peer_ladders = _peer_ladders(plan) if peers else []
    notes += [] if not peers or _cyrk() is not None else ["CyRK is not installed (pip install cyrk): no CyRK rows"]
    if progress is not None:
        progress.total = sum(len(steps) for steps in ladders + peer_ladders) + 1
        progress.set_description("reference")
    reference = reference_solution(model.equations, plan, model.source.name)
    _advance(progress)
    rows: list[BenchRow] = []
    drifts: list[Drift] = []
    for settings in ladders:
        done = _run_ladder(settings, lambda s: _run_lagdsl(model, scene, base, s, repeat, reference), progress, notes,
                           time_limit)
        rows += done
        if drift:
            drifts += _lagdsl_drift(model, scene, base, done, plan)
    if peer_ladders:
        module = load_program(generate(model.equations, plan, "numpy", model.source.name)[1])
        for settings in peer_ladders:
            watched: dict[Setting, np.ndarray] = {}
            done = _run_ladder(settings, lambda s: _run_peer(module, plan, s, repeat, reference, watched), progress,
                               notes, time_limit)
            rows += done
            if drift:
                drifts += _peer_drift(plan, done, watched)
    from .present import invariant_unit
    units = tuple((name, invariant_unit(model.ir, name)) for name in plan.invariants)
    return BenchReport(model.name, plan.scene_name, reference, tuple(rows), tuple(notes), tuple(drifts), units)


def _admitted(model, scene, base: Overrides, interval: float, integrators, backends) -> tuple[list[tuple[str, str]], list[str]]:
    """The (integrator, backend) pairs asked for (default: every integrator) that the scene admits,
    and a note for each it does not (gauss with constraints, auto on NumPy with constraints)."""
    names = integrators or registry.names()
    for name in names:
        check_integrator_name(name, None)
    chosen, notes = [], []
    for backend in backends:
        for name in names:
            step = (("step", interval),) if registry.get(name).fixed_step else ()
            reason = _refusal(model, scene, replace(base, integrator=name, options=step), backend)
            if reason is None:
                chosen.append((name, backend))
            else:
                notes.append(f"{name} ({backend}) is left out: {reason}")
    if not chosen:
        raise LagError("the scene admits none of the integrators asked for: " + "; ".join(notes))
    return chosen, notes


def _refusal(model, scene, overrides: Overrides, backend: str) -> str | None:
    """Why the scene cannot run `overrides.integrator` on `backend`, or None."""
    try:
        plan = model.plan(scene, overrides)
    except LagError as error:
        return error.diagnostics[0].message
    return registry.get(plan.integrator.name).refusal(backend, bool(plan.constraints))


def _advance(progress) -> None:
    if progress is not None:
        progress.update(1)


def _run_ladder(settings: list[Setting], run: Callable[[Setting], BenchRow], progress, notes: list[str],
                time_limit: float) -> list[BenchRow]:
    """Run the settings from the loosest on; stop after one slower than `time_limit` seconds."""
    rows = []
    for index, setting in enumerate(settings):
        if progress is not None:
            progress.set_description(setting.describe())
        row = run(setting)
        rows.append(row)
        _advance(progress)
        if row.seconds is not None and row.seconds > time_limit and index + 1 < len(settings):
            notes.append(f"{setting.method}: stopped after {setting.describe()} took {row.seconds:.3g} s "
                         f"(limit {time_limit:g} s); {len(settings) - index - 1} tighter settings not run")
            if progress is not None:
                progress.update(len(settings) - index - 1)
            break
    return rows


def _setting_overrides(base: Overrides, setting: Setting) -> Overrides:
    values = (("rtol", setting.rtol), ("atol", setting.atol), ("step", setting.step))
    return replace(base, integrator=setting.integrator,
                   options=tuple((k, float(v)) for k, v in values if v is not None))


def _run_lagdsl(model, scene, base: Overrides, setting: Setting, repeat: int, reference: Reference) -> BenchRow:
    overrides = _setting_overrides(base, setting)
    try:
        results = _repeated(lambda: model.simulate_plan(scene, setting.backend, overrides),
                            lambda result: result.summary.wall_time, repeat)
    except SimulationError as error:
        return BenchRow(setting, reference_error=reference.accuracy, failure=_failure_text(error))
    summary = results[0].summary
    return BenchRow(setting, min(r.summary.wall_time for r in results), summary.count("rhs_evals"),
                    summary.count("accepted"), summary.count("rejected"), reference.error_of(results[0].values),
                    reference.accuracy)


def _repeated(run: Callable, seconds: Callable, repeat: int) -> list:
    """`repeat` runs, and more while they add up to less than MIN_TIMED seconds (at most MAX_RUNS):
    the best of a few runs of 50 microseconds is still noise."""
    runs = [run()]
    while len(runs) < repeat or (sum(map(seconds, runs)) < MIN_TIMED and len(runs) < MAX_RUNS):
        runs.append(run())
    return runs


def _failure_text(error: SimulationError) -> str:
    return f"at t = {error.time:.6g}: {error.message}"


def invariant_plan(plan: ScenePlan, equations) -> ScenePlan:
    """The plan with the conserved quantities as its output columns (for their drift)."""
    outputs = tuple(ir.OutputRequest(q.name, "energy", None, None, None) if q.name == "energy" else
                    ir.OutputRequest(q.name, "momentum", None, q.name[len("momentum("):-1], None)
                    for q in equations.conserved)
    return replace(plan, outputs=outputs)


def _tightest(rows: list[BenchRow]) -> BenchRow | None:
    finished = [row for row in rows if row.failure is None]
    return finished[-1] if finished else None


def _lagdsl_drift(model, scene, base: Overrides, rows: list[BenchRow], plan: ScenePlan) -> list[Drift]:
    row = _tightest(rows)
    if row is None or not plan.invariants:
        return []
    tight = invariant_plan(model.plan(scene, _setting_overrides(base, row.setting)), model.equations)
    _, source = generate(model.equations, tight, row.setting.backend, model.source.name)
    result = execute(source, tight)
    return [Drift(row.setting, result.t, tuple((name, result[name] - result[name][0]) for name in result.columns))]


# ---- peers -----------------------------------------------------------------------------------
def _cyrk():
    try:
        import CyRK
    except ImportError:
        return None
    return CyRK


def _peer_ladders(plan: ScenePlan) -> list[list[Setting]]:
    ratio = atol_ratio(plan)
    names = [f"scipy-{m}" for m in SCIPY_PEERS] + ([f"cyrk-{m}" for m in CYRK_PEERS] if _cyrk() else [])
    return [adaptive_ladder(name, "numpy", ratio) for name in names]


def _peer_states(module, plan: ScenePlan, setting: Setting) -> tuple[np.ndarray, float, int, int | None]:
    """(states at the output times as columns, seconds, rhs evaluations, steps) of one peer run.
    Raises SimulationError when the solver gives up."""
    library, method = setting.integrator.split("-", 1)
    times = output_times(plan)
    par = np.array(plan.parameters, dtype=float)
    y0 = np.array(plan.initial_state, dtype=float)
    span = (float(times[0]), float(times[-1]))
    with np.errstate(all="ignore"):
        if library == "scipy":
            from scipy.integrate import solve_ivp
            started = clock.perf_counter()
            solution = solve_ivp(lambda t, y: module.rhs(t, y, par), span, y0, method=method, t_eval=times,
                                 rtol=setting.rtol, atol=setting.atol)
            seconds = clock.perf_counter() - started
            ok, message, states, evals, steps = solution.success, solution.message, solution.y, solution.nfev, None
        else:
            calls = [0]

            def rhs(dy, t, y):
                calls[0] += 1
                dy[:] = module.rhs(t, y, par)

            started = clock.perf_counter()
            solution = _cyrk().pysolve_ivp(rhs, span, y0, method=method, t_eval=times, rtol=setting.rtol,
                                           atol=setting.atol, pass_dy_as_arg=True)
            seconds = clock.perf_counter() - started
            ok, message, states, evals = solution.success, solution.message, solution.y, calls[0]
            steps = int(solution.steps_taken)
    if not ok or states.shape[1] != len(times):
        reached = float(times[states.shape[1] - 1]) if states.shape[1] else span[0]
        raise SimulationError(str(message), reached, {}, "")
    return states, seconds, int(evals), steps


def _run_peer(module, plan: ScenePlan, setting: Setting, repeat: int, reference: Reference,
              watched: dict) -> BenchRow:
    """One peer setting; the conserved quantities along its run go into `watched[setting]`."""
    try:
        runs = _repeated(lambda: _peer_states(module, plan, setting), lambda run: run[1], repeat)
    except SimulationError as error:
        return BenchRow(setting, reference_error=reference.accuracy, failure=_failure_text(error))
    states, _, evals, steps = runs[0]
    par = np.array(plan.parameters, dtype=float)
    with np.errstate(all="ignore"):
        values, watched[setting] = module.observables(output_times(plan), states, par)
    return BenchRow(setting, min(run[1] for run in runs), evals, steps, None, reference.error_of(values.T),
                    reference.accuracy)


def _peer_drift(plan: ScenePlan, rows: list[BenchRow], watched: dict) -> list[Drift]:
    row = _tightest(rows)
    if row is None or not plan.invariants:
        return []
    values = watched[row.setting]
    return [Drift(row.setting, output_times(plan),
                  tuple((name, values[i] - values[i][0]) for i, name in enumerate(plan.invariants)))]


def table(report: BenchReport):
    """The report's rows as a pandas DataFrame when pandas is installed, else a list of dicts."""
    records = report.records()
    try:
        import pandas
    except ImportError:
        return records
    return pandas.DataFrame(records, columns=list(CSV_HEADER))
