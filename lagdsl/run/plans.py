"""Run plans kept across processes: a warm `lagc run` parses, derives and lowers nothing.

Once the code of a scene has been built, a plan entry goes into the build cache (`cache.py`)
beside it: a JSON file holding the scene's settings before any override (time grid, integrator,
its `set` statements, the names overrides may refer to, `settings.SceneSettings`), the
parameter values and initial state they give, the columns and their units, the invariants, the
active constraints, and the name and key of the cache entry of the compiled library or NumPy
module. `lagdsl.load` of a text whose plan is stored defers parsing and deriving it to the first
use that needs the equations (api.Model), so that a new process's repeated simulate() runs from
the plan as a warm `lagc run` does.
Its key is the SHA-256 of the model's text, the scene and integrator asked for (None: the
model's own), the backend, the C compiler, the plan format and a digest of lagdsl itself (its
version, its files' sizes and times), so that an edited model, another compiler or another
lagdsl never finds it.

A later run with the same key resolves its overrides against the plan with the checks and
messages of the full pipeline (both go through `SceneSettings.resolve`), loads the verified
library or module and runs it, without importing sympy or lark. Positions in the model
(the spans errors point at) are stored as numbers and re-attached to the model's text, which
the key pins. Setting a parameter that other parameters or start values are computed from needs
the expressions: in a new process such a run, like one whose plan or program entry is missing
or fails verification, takes the full pipeline (`StoredPlan.resolve` returns None), which writes
the entry again; a process that has the model passes its compiled values (scene.input_values,
computed_values.py) instead.
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from fractions import Fraction
from typing import Callable

from ..errors import LagError
from ..given_values import InputUnit
from ..settings import IntegratorChoice, Overrides, RunPlan, SceneSettings, TimeGrid, with_initial
from ..source import SourceFile, Span
from . import loading, runner
from .cache import cached_entry, find_entry, package_digest
from .output import Result
from .toolchain import LIBRARY_FLAGS, find_compiler, library_entry, optimized

PLAN_FORMAT = 4
# the parameters and initial state of the values set and the initial values set (scene.input_values)
Computed = Callable[[dict, dict], tuple[tuple[float, ...], tuple[float, ...]]]


@dataclass(frozen=True)
class ProgramEntry:
    """The cache entry of a scene's program: a compiled library (language "c") or a NumPy module."""

    language: str
    name: str
    key: str

    def load(self):
        """The loaded library or imported module, or None when the entry is missing or damaged."""
        path = find_entry(self.name, self.key)
        if path is None:
            return None
        if self.language == "c":
            return loading.load_program_library(path)
        return loading.import_module(path.read_text(encoding="utf-8"), path, self.key)


def program_entry(source) -> ProgramEntry:
    """The cache entry that loading.load(source) uses for a GeneratedSource."""
    if source.language == "c":
        return ProgramEntry("c", *library_entry(source.text, source.suggested_name, find_compiler()))
    return ProgramEntry("numpy", *loading.module_entry(source))


@dataclass(frozen=True)
class StoredPlan:
    """A scene as a warm run needs it: its settings, the values they give, and its program."""

    settings: SceneSettings
    parameters: tuple[float, ...]           # with the scene's `set` statements
    initial_state: tuple[float, ...]        # with the scene's initial values
    computed_from: frozenset[str]           # parameters that other values are computed from
    columns: tuple[str, ...]
    invariants: tuple[str, ...]
    stop: str | None                        # the text of the scene's stop condition
    program: ProgramEntry | None            # None: the program a Model keeps (model_runs.QuickRuns)
    units: tuple[str, ...] | None           # the columns' units, as api.Model's results carry them
    origin: str                             # the model and scene, as its results carry them

    def resolve(self, overrides: Overrides, computed: Computed | None = None) -> RunPlan | None:
        """The run plan with `overrides` applied, as scene.plan_scene makes it (the same errors, in
        the same order); None when a value to set needs the model's expressions and `computed`
        is not given (see `values`)."""
        settings = self.settings
        if computed is None and self.recomputes(overrides):
            return None
        time, integrator, _, _ = settings.resolve(overrides)
        parameters, state = self.values(overrides, computed)
        settings.check_integrator(integrator)
        return RunPlan(settings.scene_name, time, integrator, parameters, state, settings.coordinates,
                       self.columns, self.invariants, settings.constraints, self.stop)

    def recomputes(self, overrides: Overrides) -> bool:
        """Whether `overrides` set a value that other values are computed from."""
        return any(name in self.computed_from for name, _ in overrides.values)

    def values(self, overrides: Overrides, computed: Computed | None) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """The parameters and the initial state with `overrides` set. A value set that others
        are computed from needs the model's expressions: `computed` (scene.input_values of the
        model, where the process has it) computes the others anew."""
        set_values, initial = self.settings.resolve_values(overrides)
        if self.recomputes(overrides):
            return computed(set_values, initial)
        parameters = tuple(float(set_values.get(name, value))
                           for name, value in zip(self.settings.parameters, self.parameters))
        return parameters, with_initial(self.initial_state, self.settings.coordinates, initial)

    def run(self, plan: RunPlan, progress=None) -> Result | None:
        """Run `plan` with the stored program; None if the program entry is no longer valid."""
        loaded = self.program.load()
        return None if loaded is None else runner.run(plan, self.program.language, loaded, progress)


def find(source: SourceFile, scene: str | None, backend: str, integrator: str | None) -> StoredPlan | None:
    """The stored plan of this model text, scene, backend and integrator, if the cache holds a valid one."""
    key = _plan_key(source, scene, backend, integrator)
    entry = key and find_entry(_plan_name(key), key)
    try:
        return _from_json(json.loads(entry.read_text(encoding="utf-8")), source) if entry else None
    except OSError:         # removed since it was verified (lagc cache clear): build as if it never was
        return None


def store(source: SourceFile, scene: str | None, backend: str, integrator: str | None, plan: StoredPlan) -> None:
    """Write the plan entry (once; a valid one is kept)."""
    key = _plan_key(source, scene, backend, integrator)
    if key:
        text = json.dumps(_to_json(plan), separators=(",", ":")) + "\n"
        cached_entry(_plan_name(key), key, lambda path: path.write_text(text, encoding="utf-8"))


def _plan_name(key: str) -> str:
    return f"plan-{key[:20]}.json"


def _plan_key(source: SourceFile, scene: str | None, backend: str, integrator: str | None) -> str | None:
    """The plan's key; None without a C compiler (the full pipeline then says so in its place)."""
    try:
        compiler = find_compiler() if backend == "c" else ""
    except LagError:
        return None
    flags = optimized(LIBRARY_FLAGS) if backend == "c" else ()     # a plan names the library these build
    fields = json.dumps([PLAN_FORMAT, package_digest(), scene, backend, integrator, compiler, flags])
    return hashlib.sha256(f"{fields}\0{source.text}".encode()).hexdigest()


# ---- JSON ----------------------------------------------------------------------------------
def _to_json(plan: StoredPlan) -> dict:
    s = plan.settings
    return {
        "scene": s.scene_name,
        "time": [s.time.start, s.time.stop, s.time.interval, _span_json(s.time.span)],
        "integrator": [s.integrator.name, [list(o) for o in s.integrator.options], _span_json(s.integrator.span),
                       [list(o) for o in s.integrator.atol_each]],
        "parameter_names": list(s.parameters), "structural": sorted(s.structural),
        "coordinates": list(s.coordinates), "set_values": [list(v) for v in s.set_values],
        "initial": [list(v) for v in s.initial], "constraints": list(s.constraints),
        "units": [[name, unit.text, str(unit.factor)] for name, unit in s.units],
        "parameters": list(plan.parameters), "initial_state": list(plan.initial_state),
        "computed_from": sorted(plan.computed_from), "columns": list(plan.columns),
        "invariants": list(plan.invariants), "stop": plan.stop,
        "program": [plan.program.language, plan.program.name, plan.program.key],
        "column_units": None if plan.units is None else list(plan.units), "origin": plan.origin,
    }


def _from_json(data: dict, source: SourceFile) -> StoredPlan:
    start, stop, interval, time_span = data["time"]
    name, options, integrator_span, atol_each = data["integrator"]
    settings = SceneSettings(
        data["scene"], TimeGrid(start, stop, interval, _span(time_span, source)),
        IntegratorChoice(name, tuple((k, v) for k, v in options), _span(integrator_span, source),
                         tuple((k, v) for k, v in atol_each)),
        tuple(data["parameter_names"]), frozenset(data["structural"]), tuple(data["coordinates"]),
        tuple((k, v) for k, v in data["set_values"]), tuple((c, s, v) for c, s, v in data["initial"]),
        tuple(data["constraints"]),
        tuple((name, InputUnit(text, Fraction(factor))) for name, text, factor in data["units"]))
    return StoredPlan(settings, tuple(data["parameters"]), tuple(data["initial_state"]),
                      frozenset(data["computed_from"]), tuple(data["columns"]), tuple(data["invariants"]),
                      data["stop"], ProgramEntry(*data["program"]),
                      None if data["column_units"] is None else tuple(data["column_units"]), data["origin"])


def _span_json(span: Span | None) -> list[int] | None:
    return None if span is None else [span.line, span.column, span.start, span.end]


def _span(fields: list[int] | None, source: SourceFile) -> Span | None:
    return None if fields is None else Span(source, *fields)
