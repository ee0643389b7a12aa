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

import re
import string
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from .integrators import SWITCH_TIMES, registry
from .integrators.registry import OPTION_ORDER
from .settings import RCOND_MIN, RunPlan


NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|inf|infinity|nan)", re.IGNORECASE)


def parse_number(text: str) -> float | None:
    """`text` as a number of the `NUMBER` grammar, or None (no hexadecimal, underscores or spaces,
    which Python's float() would take and C's strtod partly)."""
    return float(text) if NUMBER.fullmatch(text) else None


@dataclass(frozen=True)
class Status:
    """How a run ended. `message` may name the run's step limit ({max_steps}); `detail`, added
    where the reciprocal condition estimate at the failure is known, may name it ({rcond}) and
    the threshold ({rcond_min})."""

    code: int
    c_name: str         # the lag_status enumerator in C
    message: str        # what happened
    remedy: str         # what to try
    detail: str = ""

    def describe(self, max_steps: int, rcond: float | None = None) -> str:
        text = self.message + (self.detail if rcond is not None else "")
        return text.format(max_steps=max_steps, rcond=rcond, rcond_min=RCOND_MIN)


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
           "check the parameters and initial values; a stiff model may need --integrator radau5"),
    Status(STEP_TOO_SMALL, "LAG_ERR_STEP_TOO_SMALL", "the step size collapsed below the resolution of t",
           "the solution may be singular near this time (a collision, a coordinate singularity), "
           "or the problem is stiff: try --integrator radau5 or a looser --rtol"),
    Status(MAX_STEPS, "LAG_ERR_MAX_STEPS", "the step limit of {max_steps} steps was reached",
           "raise --max-steps, or the problem is stiff: try --integrator radau5 (or loosen --rtol)"),
    Status(NO_CONVERGENCE, "LAG_ERR_NO_CONVERGENCE", "the implicit iteration did not converge",
           "reduce the step (gauss: step = ...), or loosen the tolerances"),
    Status(PROJECTION_FAILED, "LAG_ERR_PROJECTION", "projection onto the constraints did not converge",
           "the constraints may be singular at this state; check the initial values"),
    Status(INTERRUPTED, "LAG_ERR_INTERRUPTED", "interrupted", ""),
    # The NumPy backend's forecast (scipy_steps.WorkForecast); a C run meets the step limit itself.
    Status(HOPELESS, "LAG_ERR_HOPELESS",
           "at its pace so far, the run would need more steps than the step limit of {max_steps} allows",
           "the solution may be singular near this time, or the problem is stiff: try --integrator "
           "radau5, or raise --max-steps"),
)}
UNKNOWN_STATUS = Status(-1, "", "unknown failure", "please report this")


def status_of(code: int) -> Status:
    return STATUSES.get(code, UNKNOWN_STATUS)


def format_fields(text: str) -> list[tuple[str, str | None, str]]:
    """`text` as (literal, field name or None, format spec) pieces: what C's printf needs."""
    return [(literal, name, spec) for literal, name, spec, _ in string.Formatter().parse(text)]


# The settings vector of lag_run and lag_run_batch: the output grid, then the options in the order
# of lag_options (0 where the integrator has none), the step limit last.
SETTINGS = ("t_start", "t_stop", "t_interval", *OPTION_ORDER)


def settings_vector(plan: RunPlan) -> np.ndarray:
    values = {"t_start": plan.time.start, "t_stop": plan.time.stop, "t_interval": plan.time.interval,
              **dict(plan.integrator.options), "max_steps": plan.max_steps}
    return np.array([float(values.get(name, 0.0)) for name in SETTINGS])


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
    condition estimate there), its integrator's work counters (`counters`, contiguous) and the
    state at failure; the others follow from the scene: the constraints' residual and the initial
    projection, the stiffness test of dopri5 and dop853 (stiff, its time, and the counters then),
    `auto`'s switches, the invariants' start values and drifts, and whether `stop when` ended the
    run and when.
    """

    fields: tuple[SummaryField, ...]
    counters: tuple[str, ...]

    @property
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
              *(SummaryField(counter, 1, f"stats.{counter}") for counter in counters)]
    if constraints:
        fields += [SummaryField("residual", 1, "residual_max"), SummaryField("projection", 1, "projection_start")]
    if record.stiffness_test:
        fields += [SummaryField(name, 1, f"stats.{name}")
                   for name in ("stiff", "stiff_time", "stiff_accepted", "stiff_rejected", "stiff_rhs_evals")]
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
    """What a sweep reads of each member (status, rows, t_fail and the `counters`): the summaries
    the NumPy backend's batch path fills."""
    fields = ("status", "rows", "t_fail", *counters)
    return SummaryLayout(tuple(SummaryField(name, 1, name) for name in fields), counters)


def plan_summary(plan: RunPlan) -> SummaryLayout:
    """The summary layout of the generated code of `plan` (as codegen lays it out for its kernel)."""
    return summary_layout(plan.integrator.name, len(plan.invariants), len(plan.initial_state),
                          bool(plan.constraints), plan.stop is not None)
