"""The contract between the generated C and its Python callers, written once.

- `STATUSES`: every status code a run can end with, its C enumerator, its message and its
  remedy. The C `enum lag_status` and `lag_print_status` are generated from it
  (`codegen/c_abi.py`), and `SimulationError.status` holds the code.
- `SETTINGS`: the vector of doubles `lag_run` and `lag_run_batch` take (the output grid, the
  integrator's options, the step limit), in this order.
- `SummaryLayout`: the doubles a run reports (status, rows, failure, work counters, the
  stiffness test's verdict, `auto`'s switches, the invariants, the state at failure, the stop
  time), with their offsets. The C packing `lag_pack_summary` is generated from it, and Python
  reads a summary as a NumPy record of the layout's `dtype`, field by field.

- `NUMBER`: the values a setting takes on either command line (`lagc run --set`, the standalone
  program's NAME=VALUE): a decimal number with an optional sign, fraction and exponent, or inf,
  infinity, nan in any case. C's `lag_number_length` reads the same grammar.

The constants C shares with Python (the row limit, the step limit, the rtol floor ...) are
those of `settings.py`, emitted into C by `codegen/c_abi.py`.
"""
from __future__ import annotations

import math
import re
import string
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from .integrators import SWITCH_TIMES, VERDICT_OSCILLATION, VERDICT_STIFF, registry
from .integrators.registry import OPTION_ORDER
from .settings import RCOND_MIN, RunPlan


NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf|infinity|nan)", re.IGNORECASE)


def parse_number(text: str) -> float | None:
    """`text` as a number of the `NUMBER` grammar, or None (no hexadecimal, underscores or spaces,
    which Python's float() would take and C's strtod partly)."""
    return float(text) if NUMBER.fullmatch(text) else None


# What to try when a run's steps fail or grow too many, by the kind of integrator (Status.remedy's
# {advice}): a stiff problem wants an implicit method, but radau5 and auto are implicit already, and
# a fast mode excited above the tolerance must be resolved by any method; a fixed step is the user's.
ADVICE = {
    "explicit": "if the problem is stiff (a fast mode that is damped or not excited), try --integrator radau5 "
                "(or auto); a fast mode excited above the tolerance must be resolved by any method: loosen --rtol",
    "implicit": "a fast mode excited above the tolerance must be resolved by any method, implicit ones too: "
                "loosen --rtol and --atol",
    "fixed": "the step decides it (step = ...): a smaller one where the solution blew up, a larger one where it "
             "is below the resolution of t or takes too many steps",
}


def advice_for(integrator: str) -> str:
    """ADVICE for the integrator named `integrator`."""
    record = registry.get(integrator)
    return ADVICE["fixed" if record.fixed_step else "implicit" if record.implicit else "explicit"]


@dataclass(frozen=True)
class Status:
    """How a run ended. `message` may name the run's step limit ({max_steps}) and the work
    forecast that stopped it ({forecast} steps to reach {t_end}: integrators/forecast.py);
    `detail`, added where the reciprocal condition estimate at the failure is known, may name it
    ({rcond}) and the threshold ({rcond_min}). `remedy` may end in the integrator's ADVICE
    ({advice})."""

    code: int
    c_name: str         # the lag_status enumerator in C
    message: str        # what happened
    remedy: str         # what to try
    detail: str = ""

    def describe(self, max_steps: int, rcond: float | None = None, forecast: float = math.nan,
                 t_end: float = math.nan) -> str:
        text = self.message + (self.detail if rcond is not None else "")
        return text.format(max_steps=max_steps, rcond=rcond, rcond_min=RCOND_MIN, forecast=forecast, t_end=t_end)

    def remedy_for(self, integrator: str) -> str:
        """The remedy for a run of the integrator named `integrator`."""
        return self.remedy.format(advice=advice_for(integrator))


OK, SINGULAR, NONFINITE, STEP_TOO_SMALL, MAX_STEPS, NO_CONVERGENCE, PROJECTION_FAILED, INTERRUPTED, HOPELESS = range(9)
STATUSES = {status.code: status for status in (
    Status(OK, "LAG_OK", "no error", ""),
    Status(SINGULAR, "LAG_ERR_SINGULAR", "the mass matrix is singular at this state",
           "the coordinates are singular here (e.g. Euler angles at theta = 0, spherical coordinates at a "
           "pole, a link of zero length) or the constraints are dependent; use coordinates that do not pass "
           "through this configuration, or start away from it. A mass, inertia or length set to zero or a "
           "negative value does the same (the kinetic energy must be positive for every motion)",
           " (reciprocal condition estimate {rcond:.3g}, below {rcond_min:.3g})"),
    Status(NONFINITE, "LAG_ERR_NONFINITE", "the state or its derivative became infinite or NaN",
           "check the parameters and initial values; {advice}"),
    Status(STEP_TOO_SMALL, "LAG_ERR_STEP_TOO_SMALL", "the step size collapsed below the resolution of t",
           "the solution may be singular near this time (a collision, a coordinate singularity); "
           "or {advice}"),
    Status(MAX_STEPS, "LAG_ERR_MAX_STEPS", "the step limit of {max_steps} steps was reached",
           "raise --max-steps; or {advice}"),
    Status(NO_CONVERGENCE, "LAG_ERR_NO_CONVERGENCE", "the implicit iteration did not converge",
           "reduce the step (gauss: step = ...), or loosen the tolerances"),
    Status(PROJECTION_FAILED, "LAG_ERR_PROJECTION", "projection onto the constraints did not converge",
           "the constraints may be singular at this state; check the initial values"),
    Status(INTERRUPTED, "LAG_ERR_INTERRUPTED", "interrupted", ""),
    # Either backend's work forecast (integrators/forecast.py): the run stops long before its limit.
    Status(HOPELESS, "LAG_ERR_HOPELESS",
           "at this pace reaching t = {t_end:g} would take {forecast:.3g} steps, more than the step limit of "
           "{max_steps}",
           "the solution may be singular near this time, or the tolerance too tight for the run; to let it "
           "run, raise --max-steps above the forecast; or {advice}"),
)}
UNKNOWN_STATUS = Status(-1, "", "unknown failure", "please report this")

# The stiffness test's verdicts (c/stiffness_test.c) as every run summary words them, lagc's and
# the standalone program's (codegen/c_abi.verdict_printer): the time of the verdict, the fast
# mode's period 2 pi / rho (or time scale 1 / rho) and amplitude in tolerances, the work since,
# and a remedy from VERDICT_REMEDIES.
_WORK_SINCE = "since then {accepted} steps ({rejected} rejected) and {rhs_evals} of the {rhs_total} right-hand sides"
VERDICTS = {
    VERDICT_STIFF: "stiffness detected at t = {time:.6g}: a fast mode (time scale {scale:.3g} s), damped or not "
                   "excited, holds the steps at the stability boundary; " + _WORK_SINCE
                   + "; an implicit method needs far fewer steps: {remedy}",
    VERDICT_OSCILLATION: "a fast oscillation (period {period:.3g} s) is excited above the tolerance ({amplitude:.3g} "
                         "times it at t = {time:.6g}) and must be resolved; an implicit method will not take larger "
                         "steps (" + _WORK_SINCE + ")",
}
VERDICT_REMEDIES = {"lagc": "use --integrator radau5 (or auto)",
                    "program": "generate this program with integrator radau5 (or auto) in the scene"}


def status_of(code: int) -> Status:
    return STATUSES.get(code, UNKNOWN_STATUS)


def format_fields(text: str) -> list[tuple[str, str | None, str]]:
    """`text` as (literal, field name or None, format spec) pieces: what C's printf needs."""
    return [(literal, name, spec) for literal, name, spec, _ in string.Formatter().parse(text)]


# The settings vector of lag_run and lag_run_batch: the output grid, then the options in the order
# of lag_options (0 where the integrator has none), the step limit last; after these LAG_SETTINGS
# entries, the LAG_NY absolute tolerances of the components of y (settings_vector).
SETTINGS = ("t_start", "t_stop", "t_interval", *OPTION_ORDER)


def settings_vector(plan: RunPlan) -> np.ndarray:
    """SETTINGS, then the absolute tolerance of each component of y (lag_options.atol_each)."""
    values = {"t_start": plan.time.start, "t_stop": plan.time.stop, "t_interval": plan.time.interval,
              **dict(plan.integrator.options), "max_steps": plan.max_steps}
    atol_each = plan.atol_vector(plan.coordinates) or [values.get("atol", 0.0)] * (2 * len(plan.coordinates))
    return np.array([float(values.get(name, 0.0)) for name in SETTINGS] + [float(v) for v in atol_each])


@dataclass(frozen=True)
class SummaryField:
    """`size` doubles of the run summary, packed from `source`, a member of the C driver's
    lag_report: a number, or an array of `size` (read in Python as an array, whatever its size)."""

    name: str
    size: int
    source: str
    array: bool = False


@dataclass(frozen=True)
class SummaryLayout:
    """The run summary of a scene: its fields, one after the other, each `size` doubles.

    Every run has status, rows, t_fail and rcond_fail (the failure's time and the reciprocal
    condition estimate there), the work forecast's last verdict (integrators/forecast.py), its
    integrator's work counters (`counters`, contiguous) and the state at failure; the others
    follow from the scene: the constraints' residual and the initial projection, the stiffness
    test of dopri5 and dop853 (the kind of verdict, its time, the fast mode's spectral radius and
    amplitude, and the counters then), `auto`'s switches, the invariants' start values and
    drifts, and whether `stop when` ended the run and when.
    """

    fields: tuple[SummaryField, ...]
    counters: tuple[str, ...]

    @cached_property
    def size(self) -> int:
        return sum(field.size for field in self.fields)

    def offset(self, name: str) -> int:
        return self.offsets[name]

    @cached_property
    def offsets(self) -> dict[str, int]:
        """Where each field begins, in doubles from the start of the summary."""
        starts = np.cumsum([0, *(field.size for field in self.fields)])
        return {field.name: int(start) for field, start in zip(self.fields, starts)}

    @cached_property
    def dtype(self) -> np.dtype:
        """A record of doubles, one field a SummaryField."""
        return np.dtype([(field.name, np.float64, (field.size,)) if field.array else (field.name, np.float64)
                         for field in self.fields])

    def empty(self, count: int) -> np.ndarray:
        """Summaries of `count` runs, zero: one record each, contiguous doubles as C writes them."""
        return np.zeros(count, dtype=self.dtype)


@lru_cache(maxsize=256)
def summary_layout(integrator: str, invariants: int, state: int, constraints: bool, stop: bool) -> SummaryLayout:
    """The summary of a run with `integrator`, `invariants` conserved quantities watched, a state
    of `state` entries, with or without constraints and a stop condition."""
    record = registry.get(integrator)
    counters = record.counters
    fields = [SummaryField("status", 1, "status"), SummaryField("rows", 1, "rows"),
              SummaryField("t_fail", 1, "t_fail"), SummaryField("rcond_fail", 1, "rcond_fail"),
              SummaryField("forecast", 1, "forecast.steps"),
              *(SummaryField(counter, 1, f"stats.{counter}") for counter in counters)]
    if constraints:
        fields += [SummaryField("residual", 1, "residual_max"), SummaryField("projection", 1, "projection_start")]
    if record.stiffness_test:
        fields += [SummaryField(name, 1, f"stats.{name}")
                   for name in ("stiff", "stiff_time", "stiff_rate", "stiff_amplitude", "stiff_accepted",
                                "stiff_rejected", "stiff_rhs_evals")]
    if record.parts:
        fields += [SummaryField("switches", 1, "switches.count"),
                   SummaryField("explicit_span", 1, "switches.span[LAG_AUTO_EXPLICIT]"),
                   SummaryField("implicit_span", 1, "switches.span[LAG_AUTO_IMPLICIT]"),
                   SummaryField("switch_times", SWITCH_TIMES, "switches.at", array=True)]
    if invariants:
        fields += [SummaryField("invariant_start", invariants, "invariant_start", array=True),
                   SummaryField("invariant_drift", invariants, "invariant_drift", array=True)]
    fields.append(SummaryField("y_fail", state, "y_fail", array=True))
    if stop:
        fields += [SummaryField("stopped", 1, "stopped"), SummaryField("t_stop", 1, "t_stop")]
    return SummaryLayout(tuple(fields), counters)


def member_summary(counters: tuple[str, ...]) -> SummaryLayout:
    """What a sweep reads of each member (status, rows, t_fail, the work forecast that stopped it
    and the `counters`): the summaries
    the NumPy backend's batch path fills."""
    fields = ("status", "rows", "t_fail", "forecast", *counters)
    return SummaryLayout(tuple(SummaryField(name, 1, name) for name in fields), counters)


def plan_summary(plan: RunPlan) -> SummaryLayout:
    """The summary layout of the generated code of `plan` (as codegen lays it out for its kernel)."""
    return summary_layout(plan.integrator.name, len(plan.invariants), len(plan.initial_state),
                          bool(plan.constraints), plan.stop is not None)
