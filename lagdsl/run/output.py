"""Results of a run: the output grid, the table of outputs (its CSV by run.tables) and the run summary."""
from __future__ import annotations

import math
import os
import functools
from dataclasses import MISSING, dataclass, field, fields

import numpy as np

from ..abi import VERDICT_REMEDIES, VERDICTS
from ..integrators import COUNTER_LABELS, VERDICT_STIFF
from ..integrators.registry import OPTION_ORDER, OPTIONS
from ..settings import RunPlan, grid_rows


def output_times(plan: RunPlan) -> np.ndarray:
    """start + k*interval while below stop, then stop (the rule of settings.grid_rows)."""
    start, stop, interval = plan.time.start, plan.time.stop, plan.time.interval
    times = start + interval * np.arange(grid_rows(start, stop, interval))
    times[-1] = stop
    return times


@dataclass(frozen=True)
class Stiffness:
    """The verdict of an explicit method's stiffness test (abi.VERDICTS: `kind` VERDICT_STIFF or
    VERDICT_OSCILLATION) at `time`: the fast mode's spectral radius `rate` (1/s) and amplitude in
    tolerances; the work done since."""

    kind: int
    time: float
    rate: float
    amplitude: float
    accepted: int           # steps accepted since
    rejected: int           # steps rejected since
    rhs_evals: int          # right-hand sides evaluated since
    rhs_total: int          # ... and in the whole run

    @property
    def stiff(self) -> bool:
        """An implicit method would help (the fast mode is damped or not excited)."""
        return self.kind == VERDICT_STIFF

    def render(self) -> str:
        return VERDICTS[self.kind].format(
            time=self.time, scale=1 / self.rate, period=2 * math.pi / self.rate, amplitude=self.amplitude,
            accepted=self.accepted, rejected=self.rejected, rhs_evals=self.rhs_evals, rhs_total=self.rhs_total,
            remedy=VERDICT_REMEDIES["lagc"])


@dataclass(frozen=True)
class Switches:
    """`auto`: the times of its switches (the first from methods[0] to methods[1], the next back,
    ...; `count` may exceed len(times)) and the span of t each method covered."""

    methods: tuple[str, str]
    count: int
    times: tuple[float, ...]
    spans: tuple[float, float]

    def render(self) -> str:
        moves = [f"to {self.methods[(i + 1) % 2]} at t = {t:.6g}" for i, t in enumerate(self.times)]
        if self.count > len(self.times):
            moves.append("...")
        listed = f" ({', '.join(moves)})" if moves else ""
        noun = "switch" if self.count == 1 else "switches"
        return (f"auto: {self.count} {noun}{listed}; {self.methods[0]} over {self.spans[0]:.6g} of t, "
                f"{self.methods[1]} over {self.spans[1]:.6g}")


@dataclass(frozen=True)
class ErrorEstimate:
    """The estimated global error of a run: the largest absolute difference, over the output rows
    and columns, from a more accurate solution (`against` says which), and the seconds it took.
    `columns` gives the largest over the rows of each column, in the column's unit (`units`): the
    columns of a run are in different units, so the one largest number says little without them."""

    value: float
    against: str
    seconds: float
    columns: tuple[tuple[str, float], ...] = ()      # (column, its largest error over the rows)
    units: tuple[str, ...] | None = None              # each column's unit, as Result.units

    def __float__(self) -> float:
        return self.value

    @property
    def column(self) -> str | None:
        """The column where the largest error is."""
        return max(self.columns, key=lambda entry: entry[1])[0] if self.columns else None

    def _unit(self, column: str) -> str:
        if self.units is None:
            return ""
        unit = self.units[[name for name, _ in self.columns].index(column)]
        return "" if unit == "?" else f" {unit}"

    def render(self) -> str:
        where = f"{self._unit(self.column)} in {self.column}" if self.column is not None else ""
        text = (f"estimated global error: {self.value:.2g}{where} (the largest over the rows and columns, "
                f"against {self.against}; {self.seconds:.3g} s)")
        if len(self.columns) > 1:
            text += "\n  per column: " + ", ".join(f"{name} {error:.2g}{self._unit(name)}"
                                                  for name, error in self.columns)
        return text


@dataclass(frozen=True)
class Stop:
    """The scene's stop condition ended the run at `time`, the time of the last row."""

    condition: str          # as written: "y < 0"
    time: float

    def render(self) -> str:
        return f"stopped at t = {self.time:.17g}, where {self.condition}"


@dataclass(frozen=True)
class RunSummary:
    """What the run cost and how well it kept its invariants and constraints."""

    backend: str
    integrator: str
    counters: tuple[tuple[str, int], ...]               # the work the integrator counts (accepted, ...)
    wall_time: float                                    # seconds, the integration alone
    invariants: tuple[tuple[str, float, float], ...]    # name, initial value, max |drift|
    constraints: tuple[str, ...]
    residual_max: float | None
    projection_start: float | None                      # how far the initial state was projected
    settings: tuple[tuple[str, float], ...] = ()        # the integrator's options as used
    stiffness: Stiffness | None = None                  # explicit methods: stiffness detected
    switches: Switches | None = None                    # auto: its changes of method
    stopped: Stop | None = None                         # the scene's stop condition ended the run
    error: ErrorEstimate | None = None                  # lagc run --error, simulate(estimate_error=True)
    uncounted: tuple[tuple[str, str], ...] = ()         # counters this run could not keep, and why
    atol_each: tuple[tuple[str, float], ...] = ()       # atol per component, as given (tolerances.py)

    def count(self, counter: str) -> int | None:
        """A work counter ("accepted", "rhs_evals", ...), None when the integrator does not keep it."""
        return dict(self.counters).get(counter)

    def render(self) -> str:
        entries = [(name, f"{value} {COUNTER_LABELS[name]}") for name, value in self.counters]
        entries += [(name, f"{COUNTER_LABELS[name]}: {why}") for name, why in self.uncounted]
        counts = [text for _, text in sorted(entries, key=lambda entry: list(COUNTER_LABELS).index(entry[0]))]
        lines = [f"integrator {self.integrator}({self.settings_text()}) ({self.backend}): "
                 + ", ".join([*counts, f"{self.wall_time:.3g} s"])]
        lines += [part.render() for part in (self.stiffness, self.switches, self.stopped, self.error)
                  if part is not None]
        for name, start, drift in self.invariants:
            relative = f", relative {drift / abs(start):.3g}" if start != 0 else ""
            lines.append(f"drift of {name}: {drift:.3g} (from {start:.17g}{relative})")
        if self.constraints and self.residual_max is not None:      # None: no row was computed
            lines.append(f"largest constraint residual ({', '.join(self.constraints)}): {self.residual_max:.3g}")
            if self.projection_start:
                lines.append(f"the initial state was moved by {self.projection_start:.3g} onto the constraints")
        return "\n".join(lines)

    def settings_text(self) -> str:
        """"rtol = 1e-10, atol = 1e-12, atol(x) = 1e-18" or "step = 0.01, stages = 2", as in a scene."""
        values = dict(self.settings)
        return ", ".join([f"{key} = {OPTIONS[key].word(values[key])}" for key in OPTION_ORDER
                          if key in values and key != "max_steps"]
                         + [f"atol({name}) = {value:g}" for name, value in self.atol_each])


class Deferred(functools.partial):
    """A field's value made when the field is first read (a repeated C run's summary, which a fit
    never reads): a function and its arguments, called then. A functools.partial, made without
    a Python-level __init__ or a closure: a repeated run makes one each call."""

    __slots__ = ()


class _DeferredField:
    """A dataclass field that may be given a Deferred: read, it is made once and kept."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, instance, owner=None):
        if instance is None:        # no default: dataclass takes the field as required
            raise AttributeError(self.name)
        value = instance.__dict__[self.name]
        if type(value) is Deferred:
            value = instance.__dict__[self.name] = value()
        return value

    def __set__(self, instance, value) -> None:
        instance.__dict__[self.name] = value


@dataclass(frozen=True)
class Result:
    """Output times `t`, the named columns, and the summary. `result["theta1"]` is a column.
    `drawing` (an animation.Drawing) holds what the draw statements show at the times `t`, in a
    run asked to draw (`simulate(..., draw=True)`)."""

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray            # shape (len(t), len(columns))
    summary: RunSummary = _DeferredField()     # a RunSummary (or a Deferred, made when read)
    units: tuple[str, ...] | None = None    # each column's unit ("?" unknown; None: a model without units)
    origin: str = ""                        # what ran, for titles: "Kepler, scene ellipse"
    drawing: object | None = field(default=None, kw_only=True)     # keyword-only: subclasses add fields

    @staticmethod
    def run_fields(columns: tuple[str, ...], units: tuple[str, ...] | None, origin: str) -> dict:
        """The fields a repeated C run's results share, all but t, values and summary: such a
        result is made by object.__new__, these put in its __dict__ with the other three
        (c_backend.CRun)."""
        return {**_field_defaults(Result), "columns": columns, "units": units, "origin": origin}

    def __getstate__(self) -> dict:
        """The fields to pickle (a Result goes back from a sweep's worker), the summary made."""
        return {**self.__dict__, "summary": self.summary}

    def animate(self, speed: float = 1.0):
        """The animation of the run (an animation.Animation: shown in Jupyter, `.save(path)`),
        played at `speed` model seconds per second."""
        from ..animation import Animation
        from ..errors import LagError
        if self.drawing is None:
            raise LagError("this result was run without its draw statements: run simulate(..., draw=True), "
                           "or call model.animate()")
        return Animation(self.drawing, self.t, speed)

    def __getitem__(self, column: str) -> np.ndarray:
        if column == "t":
            return self.t
        try:
            return self.values[:, self.columns.index(column)]
        except ValueError:
            raise KeyError(f"no column '{column}' (columns: {', '.join(self.columns)})") from None

    def csv(self, units: tuple[str, ...] | None = None) -> str:
        from .tables import csv_text
        """The header `t,<columns>` (RFC 4180 fields) and one row per output time.

        With `units` (one per column, "?" where unknown), the header names them: `t [s],x [m]`.

        Numbers as csv_text writes them (as the standalone C program does).
        """
        names = ("t", *self.columns)
        if units is not None:
            names = tuple(f"{name} [{unit}]" for name, unit in zip(names, ("s", *units)))
        return csv_text(names, (np.asarray(self.t, dtype=float), *np.asarray(self.values, dtype=float).T))

    def to_csv(self, path: str | os.PathLike) -> None:
        from .files import write_output
        write_output(path, self.csv())

    def plot(self, path: str | os.PathLike, xy: tuple[str, str] | None = None) -> None:
        """Write a PNG figure (atomically, as to_csv): the columns against t, or with `xy` =
        ("x", "y") the trajectory of column y against column x; titled with the model and scene,
        each axis with its unit (plots.py)."""
        from .. import plots
        from .files import write_output
        write_output(path, plots.outputs_png(self) if xy is None else plots.trajectory_png(self, *xy))


@functools.cache
def _field_defaults(cls: type) -> dict:
    """The fields of a dataclass that have a default, with it (Result.run_fields)."""
    return {f.name: f.default for f in fields(cls) if f.default is not MISSING}
