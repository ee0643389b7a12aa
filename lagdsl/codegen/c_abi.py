"""The C side of lagdsl/abi.py and of the constants in settings.py, generated from them.

`runtime_header()` is runtime.h with its libm table (generated from lagdsl/frontend/functions.py);
`runtime_contract()` follows it in every C file (the integrators' tests paste it too): the
status codes, the shared constants and the indices of the settings vector. `status_printer()`,
`verdict_printer()` and `summary_packer(layout)` go between the driver and the programs that use them.
"""
from __future__ import annotations

from ..abi import (SETTINGS, STATUSES, UNKNOWN_STATUS, VERDICT_REMEDIES, VERDICTS, Status, SummaryLayout,
                   format_fields)
from ..escape import c_comment, c_string
from ..frontend.functions import LIBM_TABLE_MARKER, libm_table
from ..integrators import (AUTO_CALM, AUTO_GAIN, CALM_STEPS, COUNTER_LABELS, EXCITED_AMPLITUDE, FAST_ITERATIONS,
                           FAST_PROBE, STIFF_STEPS, SWITCH_TIMES, VERDICT_OSCILLATION, VERDICT_STIFF, c_file,
                           registry)
from ..integrators.registry import MAX_STEPS_CEILING
from ..settings import (DEFAULT_MAX_STEPS, FORECAST_JUDGED_AFTER, FORECAST_WINDOW, GRID_SLACK, MAX_ROWS,
                        MIN_STEP_EPS, RCOND_MIN_EPS, RTOL_FLOOR_EPS, START_STEP_FRACTION, START_STEP_MIN_STEPS,
                        STEPS_PER_ROW)


def _tolerance_constants(record: registry.Integrator) -> tuple[tuple[str, str, str], ...]:
    """The record's tolerance transform (rtol' = scale rtol^power), the power as a quotient so
    that it is exact in every precision."""
    power = record.tolerance_power
    return ((f"LAG_{record.name.upper()}_TOLERANCE_SCALE", f"LAG_LIT({record.tolerance_scale!r})",
             f"{record.name} works to rtol' = scale rtol^power ..."),
            (f"LAG_{record.name.upper()}_TOLERANCE_POWER",
             f"(LAG_LIT({power.numerator}.0) / LAG_LIT({power.denominator}.0))", "... and atol' = rtol' atol / rtol"))


VERDICT_NAMES = {VERDICT_STIFF: "LAG_VERDICT_STIFF", VERDICT_OSCILLATION: "LAG_VERDICT_OSCILLATION"}
# (name, value, what it is): settings.py's numbers as the C driver and integrators read them
# (those counted in eps: of the working precision).
SHARED_CONSTANTS = (
    ("LAG_MAX_ROWS", f"{MAX_ROWS}L", "the largest output grid, in rows"),
    ("LAG_DEFAULT_MAX_STEPS", f"{DEFAULT_MAX_STEPS}L", "an adaptive run's default step limit, or ..."),
    ("LAG_STEPS_PER_ROW", f"{STEPS_PER_ROW}L", "... this many steps per output row"),
    ("LAG_MAX_STEPS_CEILING", f"{MAX_STEPS_CEILING}L", "the largest step limit, given or implied by a fixed step"),
    ("LAG_FORECAST_JUDGED_AFTER", f"{FORECAST_JUDGED_AFTER}L", "the work forecast judges a run from this step on ..."),
    ("LAG_FORECAST_WINDOW", f"{FORECAST_WINDOW}L", "... once every this many steps"),
    ("LAG_GRID_SLACK", f"LAG_LIT({GRID_SLACK!r})", "a grid time within this many intervals of t1 is t1"),
    ("LAG_RTOL_FLOOR_EPS", f"{RTOL_FLOOR_EPS}", "the smallest rtol, in eps ..."),
    ("LAG_RTOL_FLOOR", "(LAG_RTOL_FLOOR_EPS * REAL_EPSILON)", "... and as a number"),
    ("LAG_MIN_STEP_EPS", f"{MIN_STEP_EPS}", "the smallest step, in eps of max(|t|, span)"),
    ("LAG_START_STEP_MIN_STEPS", f"{START_STEP_MIN_STEPS}", "the smallest first step, in smallest steps"),
    ("LAG_START_STEP_FRACTION", f"LAG_LIT({START_STEP_FRACTION!r})", "the starting step's probe, in spans"),
    ("LAG_RCOND_MIN", f"({RCOND_MIN_EPS} * REAL_EPSILON)", "below this reciprocal condition, K is singular"),
    ("LAG_AUTO_LOGGED", f"{SWITCH_TIMES}", "the switches of auto whose times the summary keeps"),
    ("LAG_STIFF_STEPS", f"{STIFF_STEPS}", "steps beyond the stability boundary that call for a verdict"),
    ("LAG_CALM_STEPS", f"{CALM_STEPS}", "steps within it, in a row, that clear the count"),
    ("LAG_FAST_ITERATIONS", f"{FAST_ITERATIONS}", "power iteration on J^2 for the spectral radius rho"),
    ("LAG_FAST_PROBE", f"LAG_LIT({FAST_PROBE!r})", "the probe of y'' spans this fraction of 1/rho"),
    ("LAG_EXCITED_AMPLITUDE", f"LAG_LIT({EXCITED_AMPLITUDE!r})", "a fast mode above this many tolerances is excited"),
    (VERDICT_NAMES[VERDICT_STIFF], f"{VERDICT_STIFF}", "the stiffness test's verdicts: stiff (damped or unexcited) ..."),
    (VERDICT_NAMES[VERDICT_OSCILLATION], f"{VERDICT_OSCILLATION}", "... or a fast oscillation to be resolved"),
    ("LAG_AUTO_CALM", f"LAG_LIT({AUTO_CALM!r})", "auto back to dop853 when radau5 keeps h rho below this ..."),
    ("LAG_AUTO_GAIN", f"LAG_LIT({AUTO_GAIN!r})", "... or its steps are not this many times dop853's"),
    *((f"LAG_{record.name.upper()}_STABILITY_BOUNDARY", f"LAG_LIT({record.stability_boundary!r})",
       f"h lambda beyond which {record.name}'s steps are held by stability")
      for record in map(registry.get, registry.names()) if record.stiffness_test),
    *(constant for record in map(registry.get, registry.names()) if record.transforms_tolerances
      for constant in _tolerance_constants(record)),
)
# The C argument of each value a status message may name, and its printf conversion where the
# message gives no format of its own ({rcond:.3g} is printed with %.3g).
MESSAGE_ARGUMENTS = {"max_steps": ("max_steps", "%ld"), "rcond": ("rcond", "%g"),
                     "rcond_min": ("(double)LAG_RCOND_MIN", "%g"), "forecast": ("forecast", "%g"),
                     "t_end": ("t_end", "%g")}
# The arguments of lag_print_status and lag_format_status after the status.
STATUS_PARAMETERS = "long max_steps, double rcond, double forecast, double t_end"


def runtime_header() -> str:
    """runtime.h with its libm table, generated from the built-in functions (functions.py)."""
    return c_file("runtime.h").replace(LIBM_TABLE_MARKER, libm_table())


def runtime_contract() -> str:
    """enum lag_status, the constants shared with Python, and the settings vector's indices."""
    width = max(len(status.c_name) for status in STATUSES.values()) + len(" = 0,")
    enumerators = [f"{status.c_name} = {code}{',' if code != max(STATUSES) else ''}".ljust(width)
                   + f" /* {c_comment(_with_field_names(status.message))} */"
                   for code, status in STATUSES.items()]
    constants = [f"#define {name} {value}".ljust(48) + f" /* {c_comment(what)} */"
                 for name, value, what in SHARED_CONSTANTS]
    settings = ", ".join(f"LAG_SET_{name.upper()}" for name in SETTINGS)
    return "\n".join([
        "/* ---- the contract with lagdsl's Python side: lagdsl/abi.py and lagdsl/settings.py ---- */",
        "/* How a run ends: the status codes of the model functions, the integrators and the driver. */",
        "enum lag_status {", *(f"    {line}" for line in enumerators), "};", "",
        *constants, "",
        "/* The positions in the settings vector of lag_run and lag_run_batch (lagdsl.abi.SETTINGS). */",
        f"enum lag_setting {{ {settings}, LAG_SETTINGS }};", ""])


def status_printer() -> str:
    """lag_print_status: a status's message as SimulationError words it, with its detail."""
    cases = []
    for status in [*STATUSES.values(), UNKNOWN_STATUS]:
        label = f"case {status.c_name}:" if status.c_name else "default:"
        cases += [f"    {label}", f"        {_printf(status)}", "        break;"]
    return "\n".join([
        "/* How a run with `status` failed, in the words of lagdsl.abi.STATUSES: the step limit was",
        " * max_steps, the reciprocal condition estimate at the failure rcond, the work forecast that",
        " * stopped it `forecast` steps to reach t_end. */",
        f"static void lag_print_status(FILE *file, int status, {STATUS_PARAMETERS})",
        "{",
        "    switch (status) {",
        *cases,
        "    }",
        "}", ""])


def status_formatter(integrator: str) -> str:
    """lag_format_status, lag_print_status into a buffer (an FMU's log, codegen/fmu.py), and
    lag_status_remedy, each status's remedy for a run of `integrator`."""
    cases, remedies = [], []
    for status in [*STATUSES.values(), UNKNOWN_STATUS]:
        label = f"case {status.c_name}:" if status.c_name else "default:"
        cases += [f"    {label}", f"        {_printf(status, 'snprintf(buffer, size')}", "        break;"]
        remedies += [f"    {label}", f"        return {c_string(status.remedy_for(integrator))};"]
    return "\n".join([
        "/* lag_print_status's words into `buffer` (of `size` bytes). */",
        f"static void lag_format_status(char *buffer, size_t size, int status, {STATUS_PARAMETERS})",
        "{",
        "    switch (status) {",
        *cases,
        "    }",
        "}",
        "",
        "/* What to try after a run failed with `status` (lagdsl.abi.STATUSES). */",
        "static const char *lag_status_remedy(int status)",
        "{",
        "    switch (status) {",
        *remedies,
        "    }",
        "}", ""])


def _with_field_names(text: str) -> str:
    """`text` with its format fields as their names: a message's words in a C comment."""
    return "".join(literal + (name or "") for literal, name, _ in format_fields(text))


def _printf(status: Status, call: str = "fprintf(file") -> str:
    """The printf (`call`, up to its format) of the status's message and detail."""
    return _printf_text(status.message + status.detail, MESSAGE_ARGUMENTS, call)


def _printf_text(message: str, arguments: dict[str, tuple[str, str]], call: str) -> str:
    """The printf (`call`, up to its format) of `message`: Python's format fields as printf's, each
    field's C argument and default conversion from `arguments`."""
    text, values = "", []
    for literal, name, spec in format_fields(message):
        text += literal.replace("%", "%%")
        if name is not None:
            argument, conversion = arguments[name]
            text += f"%{spec}" if spec else conversion
            values.append(argument)
    return f"{call}, {', '.join([c_string(text), *values])});"


def verdict_printer() -> str:
    """lag_print_verdict: the stiffness test's verdict of a run in the words of lagdsl.abi.VERDICTS,
    with the standalone program's remedy."""
    since = {name: (f"report->stats.{counter} - report->stats.stiff_{counter}", "%ld")
             for name, counter in (("accepted", "accepted"), ("rejected", "rejected"), ("rhs_evals", "rhs_evals"))}
    arguments = {"time": ("(double)report->stats.stiff_time", "%g"),
                 "scale": ("1 / (double)report->stats.stiff_rate", "%g"),
                 "period": ("6.283185307179586 / (double)report->stats.stiff_rate", "%g"),
                 "amplitude": ("(double)report->stats.stiff_amplitude", "%g"),
                 "rhs_total": ("report->stats.rhs_evals", "%ld"),
                 "remedy": (c_string(VERDICT_REMEDIES["program"]), "%s"), **since}
    cases = []
    for kind, message in VERDICTS.items():
        cases += [f"    case {VERDICT_NAMES[kind]}:", f"        {_printf_text(message, arguments, 'fprintf(file')}",
                  "        fputc('\\n', file);", "        break;"]
    return "\n".join([
        "/* The stiffness test's verdict in the words of lagdsl.abi.VERDICTS, if it gave one. */",
        "static void lag_print_verdict(FILE *file, const lag_report *report)",
        "{",
        "    switch (report->stats.stiff) {",
        *cases,
        "    }",
        "}", ""])


def summary_packer(layout: SummaryLayout) -> str:
    """lag_pack_summary: the lag_report of a run as the doubles of `layout`; the offsets and the
    counters' labels the standalone program reads back."""
    lines, offset = [], 0
    for field in layout.fields:
        if field.array:
            lines += [f"    for (i = 0; i < {field.size}; ++i)",
                      f"        summary[{offset} + i] = (double)report->{field.source}[i];"]
        else:
            lines.append(f"    summary[{offset}] = (double)report->{field.source};")
        offset += field.size
    offsets = [f"#define LAG_SUMMARY_{name.upper()} {layout.offset(name)}"
               for name in ("status", "rows", "t_fail", "rcond_fail", "forecast")]
    return "\n".join([
        "/* The run summary as lagdsl.abi.SummaryLayout lays it out for this scene: doubles, field by field. */",
        f"#define LAG_SUMMARY_SIZE {layout.size}",
        *offsets,
        f"#define LAG_SUMMARY_COUNTERS {layout.offset(layout.counters[0])}     /* the work counters, labelled: */",
        f"#define LAG_NCOUNTERS {len(layout.counters)}",
        "static const char *const lag_counter_labels[LAG_NCOUNTERS] = { "
        + ", ".join(c_string(COUNTER_LABELS[counter]) for counter in layout.counters) + " };",
        "",
        "static void lag_pack_summary(const lag_report *report, double *summary)",
        "{",
        "    int i;",
        *lines,
        "}", ""])
