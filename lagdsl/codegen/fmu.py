"""ScenePlan + Kernel -> the variables of an FMU and its C source (FMI 2.0 or 3.0).

An FMU exports a scene: its parameters as tunable parameters, the state y = (q, q') as
continuous states (their derivatives q' and q'' for model exchange), its output columns together
with the energy, every momentum and every active constraint's multiplier as outputs, and, for
co-simulation, the integrator's options as fixed parameters. Each variable has a value reference
derived from its name alone (`value_references`), so that it keeps it across exports of the model:
another scene, another kind or another version of FMI.

The C source is the scene's generated C file (codegen/c.py) with the FMU's part in place of the
shared library's entry points and the standalone program: the variable table, the log
categories and the option checks generated here, then integrators/c/fmu.c, fmu_values.c,
fmu_run.c and the FMI version's entry points (FMI_FILES).
"""
from __future__ import annotations

import hashlib
import re
import warnings
from dataclasses import dataclass, replace

from .. import ir
from ..errors import LagError, LagWarning
from ..escape import c_comment, c_string
from ..integrators import c_file, registry
from ..integrators.registry import OPTION_ORDER, OPTIONS
from ..scene import ScenePlan
from ..tolerances import atol_vector
from .c import _literal, _options_initializer
from .c_abi import status_formatter
from .fmu_units import VariableUnits

KINDS = ("me", "cs")                  # model exchange, co-simulation
# The log categories (FMI's recommended names), in the order of enum lag_fmu_category.
LOG_CATEGORIES = (("logEvents", "the stop condition, and the integrator beginning again"),
                  ("logStatusWarning", "warnings: a tolerance raised to what can be met"),
                  ("logStatusDiscard", "model exchange: the model cannot be evaluated at a state"),
                  ("logStatusError", "errors: bad calls, bad values, failed steps (always logged)"))
# Integrator options whose value 0 means "not given" (lag_options in runtime.h).
UNSET_OPTIONS = {"max_step": "no limit", "max_steps": "the default limit, as lagc run's"}
# The entry points of each FMI version (integrators/c), pasted after the instance's files.
FMI_FILES = {2: ("fmi2.c",), 3: ("fmi3.c", "fmi3_run.c")}
INT32_MAX = 2**31 - 1                 # FMI 2's Integer, FMI 3's Int32


@dataclass(frozen=True)
class FmuVariable:
    """One variable: its name (FMI's structured naming convention), what it is in the generated C
    (`kind` and `index`, a row of lag_fmu_variables), its FMI attributes, its unit ("?" unknown)
    and its description; `derivative_of` names the state it is the derivative of."""

    name: str
    kind: str               # time, parameter, option, state, acceleration, output, indicator
    index: str              # C: its position in par, y, dydt or out, or its LAG_SET_ position
    causality: str
    variability: str
    initial: str | None
    start: float | None = None
    unit: str = "?"
    description: str | None = None
    derivative_of: str | None = None
    integer: bool = False
    reference: int = 0


def exported_kinds(plan: ScenePlan, kinds: tuple[str, ...] | None) -> tuple[str, ...]:
    """The kinds asked for, or by default both; a scene integrated in Hamilton's form has no q''
    for model exchange, so by default it is exported for co-simulation only (with a warning)."""
    if kinds is not None:
        return kinds
    if plan.canonical:
        warnings.warn(f"{registry.get(plan.integrator.name).title} integrates Hamilton's equations: the FMU of scene "
                      f"{plan.scene_name} is for co-simulation only (model exchange needs q'' from the mass matrix "
                      "solve)", LagWarning, stacklevel=2)
        return ("cs",)
    return KINDS


def fmu_plan(plan: ScenePlan, kinds: tuple[str, ...]) -> ScenePlan:
    """The scene's plan with the outputs an FMU adds to its columns: the energy, the momentum of
    every coordinate and the multiplier of every active constraint (those the scene lacks)."""
    if "me" in kinds and plan.canonical:
        raise LagError(f"{registry.get(plan.integrator.name).title} integrates Hamilton's equations, and model "
                       "exchange needs q'' from the mass matrix solve; export this scene with --kind cs, or a "
                       "scene with another integrator", plan.integrator.span)
    have = {(request.kind, request.target) for request in plan.outputs}
    extra = [ir.OutputRequest("energy", "energy", None, None, None),
             *(ir.OutputRequest(f"momentum({q})", "momentum", None, q, None) for q in plan.coordinates),
             *(ir.OutputRequest(f"multiplier({c})", "multiplier", None, c, None) for c in plan.constraints)]
    return replace(plan, outputs=plan.outputs + tuple(o for o in extra if (o.kind, o.target) not in have))


def value_references(names: list[str]) -> dict[str, int]:
    """A value reference for each name, from the name alone: 31 bits of its SHA-256 (a collision,
    unlikely among a model's names, moves the later name in sorted order to the next free one)."""
    taken: dict[int, str] = {}
    for name in sorted(names):
        reference = int.from_bytes(hashlib.sha256(name.encode()).digest()[:4], "big") & 0x7FFFFFFF
        while reference in taken:
            reference = (reference + 1) & 0x7FFFFFFF
        taken[reference] = name
    return {name: reference for reference, name in taken.items()}


def output_name(request: ir.OutputRequest) -> str:
    """The FMI name of an output column: energy, momentum.q, multiplier.c, residual.c, a named
    output as it is, any other expression quoted ('x1 + x2')."""
    if request.kind == "energy":
        return "energy"
    if request.kind != "expression":
        return f"{request.kind}.{request.target}"
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*(\[[0-9]+(,[0-9]+)*\])?", request.column):
        return request.column
    return "'" + request.column.replace("\\", "\\\\").replace("'", "\\'") + "'"


def fmu_variables(plan: ScenePlan, kinds: tuple[str, ...], version: int) -> tuple[FmuVariable, ...]:
    """The variables of an FMU of `plan` (as fmu_plan extends it), in the order of
    modelDescription.xml, each with its value reference."""
    model, units = plan.model, VariableUnits(plan.model, plan.scene_name)
    n, states_out = len(model.coordinates), _state_columns(plan)
    variables = [FmuVariable("time", "time", "0", "independent", "continuous", None, unit=units.time)] \
        if version == 3 else []
    variables += [FmuVariable(p.name, "parameter", str(i), "parameter", "tunable", "exact", value, units.of(p.name),
                              p.description) for i, (p, value) in enumerate(zip(model.parameters, plan.parameters))]
    if "cs" in kinds:
        variables += _option_variables(plan, units)
    for k, c in enumerate(model.coordinates):
        causality = "output" if k in states_out.values() else "local"
        variables.append(FmuVariable(c.name, "state", str(k), causality, "continuous", "exact", plan.initial_state[k],
                                     units.of(c.name), c.description))
    for k, c in enumerate(model.coordinates):
        causality = "output" if n + k in states_out.values() else "local"
        variables.append(FmuVariable(f"der({c.name})", "state", str(n + k), causality, "continuous", "exact",
                                     plan.initial_state[n + k], units.rate(c.name, 1), f"the velocity {c.name}'",
                                     c.name if "me" in kinds else None))
    if "me" in kinds:
        variables += [FmuVariable(f"der({c.name},2)", "acceleration", str(n + k), "local", "continuous", "calculated",
                                  None, units.rate(c.name, 2), f"the acceleration {c.name}''", f"der({c.name})")
                      for k, c in enumerate(model.coordinates)]
    variables += _output_variables(plan, units, {variable.name for variable in variables}, states_out)
    if version == 3 and "me" in kinds and plan.stop is not None:
        variables.append(FmuVariable("stop.indicator", "indicator", "0", "local", "continuous", "calculated",
                                     description=f"negative where the stop condition {plan.stop.text} holds"))
    references = value_references([variable.name for variable in variables])
    return tuple(replace(variable, reference=references[variable.name]) for variable in variables)


def _state_columns(plan: ScenePlan) -> dict[int, int]:
    """The output columns that are a coordinate or its velocity: column -> entry of y."""
    n = len(plan.model.coordinates)
    entries = {**{c.symbol: k for k, c in enumerate(plan.model.coordinates)},
               **{c.velocity_symbol: n + k for k, c in enumerate(plan.model.coordinates)}}
    return {j: entries[request.expression] for j, request in enumerate(plan.outputs)
            if request.kind == "expression" and request.expression in entries}


def _option_variables(plan: ScenePlan, units: VariableUnits) -> list[FmuVariable]:
    """The integrator's options, fixed parameters of co-simulation (start: the scene's)."""
    record, given = registry.get(plan.integrator.name), option_values(plan)
    variables = []
    for key in (key for key in OPTION_ORDER if key in record.options):
        option = OPTIONS[key]
        unset = f"; 0: {UNSET_OPTIONS[key]}" if key in UNSET_OPTIONS else \
            f"; {option.number_requirement}" if option.choices else ""
        variables.append(FmuVariable(
            f"integrator.{key}", "option", f"LAG_SET_{key.upper()}", "parameter", "fixed", "exact", given[key],
            units.time if key in ("step", "max_step") else "?",
            f"co-simulation with {record.name}: {option.meaning}{unset}", integer=bool(option.c_cast)))
    return variables + (_tolerance_variables(plan, units) if "atol" in record.options else [])


def _tolerance_variables(plan: ScenePlan, units: VariableUnits) -> list[FmuVariable]:
    """The atol of each component of y (tolerances.py), fixed parameters of co-simulation named
    integrator.atol.x and integrator.atol.'der(x)', in the unit of the state variable (as every
    value of the FMU: SI); start: the scene's (its atol(x), atol(der(x)), and atol(x) / (stop -
    start) for the velocity of a coordinate it names alone), 0 where the scene names none: 0
    means integrator.atol."""
    coordinates = plan.coordinates
    given = atol_vector(0.0, plan.integrator.atol_each, coordinates, plan.time.stop - plan.time.start) \
        or (0.0,) * (2 * len(coordinates))
    names = [*coordinates, *(f"'der({q})'" for q in coordinates)]
    return [FmuVariable(f"integrator.atol.{name}", "tolerance", str(k), "parameter", "fixed", "exact", given[k],
                        units.of(coordinates[k % len(coordinates)]) if k < len(coordinates)
                        else units.rate(coordinates[k % len(coordinates)], 1),
                        f"co-simulation: the absolute tolerance of {name.strip(chr(39))}; 0: integrator.atol")
            for k, name in enumerate(names)]


def option_values(plan: ScenePlan) -> dict[str, float]:
    """The integrator's options as the scene gives them, 0 for those it does not (UNSET_OPTIONS),
    the step limit within an FMI Integer."""
    values = {key: 0.0 for key in OPTION_ORDER} | dict(plan.integrator.options)
    values["max_steps"] = min(values["max_steps"], INT32_MAX)
    return values


def _output_variables(plan: ScenePlan, units: VariableUnits, taken: set[str],
                      states_out: dict[int, int]) -> list[FmuVariable]:
    """The output columns that are not states (a name given twice is one variable)."""
    described = {output.name: output.description for output in plan.model.outputs}
    variables = []
    for j, request in enumerate(plan.outputs):
        name = output_name(request)
        if j in states_out or name in taken:
            continue
        taken.add(name)
        variables.append(FmuVariable(name, "output", str(j), "output", "continuous", "calculated", None,
                                     units.column(request), described.get(request.column) or
                                     OUTPUT_DESCRIPTIONS.get(request.kind, "{column}").format(column=request.column,
                                                                                              target=request.target)))
    return variables


OUTPUT_DESCRIPTIONS = {"energy": "the energy h = sum of q' dL/dq' - L",
                       "momentum": "the momentum dL/d{target}' of {target}",
                       "multiplier": "the Lagrange multiplier of the constraint {target}",
                       "residual": "the residual of the constraint {target}"}


def fmu_c_part(kernel, plan: ScenePlan, variables: tuple[FmuVariable, ...], kinds: tuple[str, ...], version: int,
               token: str) -> str:
    """What the FMU's C file holds in place of the library and the program (codegen/c.py's `fmu`):
    the export's constants and tables, then the static files of integrators/c."""
    rows = [f"    {{ {v.reference}ul, LAG_FMU_{v.kind.upper()}, LAG_FMU_{'INTEGER' if v.integer else 'REAL'}, "
            f"{v.index} }},    /* {c_comment(v.name)} */ \\" for v in sorted(variables, key=lambda v: v.reference)]
    categories = ", ".join(f"LAG_FMU_LOG_{_category_constant(name)}" for name, _ in LOG_CATEGORIES)
    return "\n".join([
        f"#define LAG_FMU_TOKEN {c_string(token)}",
        f"#define LAG_FMU_MODEL_EXCHANGE {int('me' in kinds)}",
        f"#define LAG_FMU_CO_SIMULATION {int('cs' in kinds)}",
        f"#define LAG_FMU_T_START {_literal(kernel.time.start)}",
        f"#define LAG_FMU_T_STOP {_literal(kernel.time.stop)}",
        f"#define LAG_FMU_T_INTERVAL {_literal(kernel.time.interval)}",
        f"#define LAG_FMU_OPTIONS {{ {_options_initializer(option_values(plan))} }}",
        "/* integrator.atol.<component>: the atol of each component of y, 0 for integrator.atol's. */",
        f"#define LAG_FMU_ATOL_EACH {{ {_atol_starts(variables)} }}",
        f"#define LAG_FMU_STOP_TEXT {c_string(kernel.stop_text)}",
        "/* The variables (lagdsl/codegen/fmu.py), by value reference: reference, kind, type, index. */",
        f"#define LAG_FMU_NVARIABLES {len(variables)}",
        "#define LAG_FMU_VARIABLES { \\", *rows, "}",
        f"enum lag_fmu_category {{ {categories}, LAG_FMU_NCATEGORIES }};",
        "#define LAG_FMU_CATEGORIES { " + ", ".join(c_string(name) for name, _ in LOG_CATEGORIES) + " }",
        "", _option_refusal(plan), status_formatter(plan.integrator.name),
        *(c_file(name) for name in ("fmu.c", "fmu_values.c", "fmu_run.c", *FMI_FILES[version]))])


def _atol_starts(variables: tuple[FmuVariable, ...]) -> str:
    """The start values of integrator.atol.<component> in the order of y ("0": none exported)."""
    tolerances = sorted((v for v in variables if v.kind == "tolerance"), key=lambda v: int(v.index))
    return ", ".join(repr(float(v.start)) for v in tolerances) or "0"


def _category_constant(name: str) -> str:
    """logStatusError -> ERROR, logEvents -> EVENTS."""
    return re.sub(r"^log(Status)?", "", name).upper()


def _option_refusal(plan: ScenePlan) -> str:
    """lag_fmu_option_refusal: the checks of lagc run on each option of the scene's integrator
    (settings.validate_integrator), with 0 allowed for those it means "not given" for."""
    record = registry.get(plan.integrator.name)
    cases = []
    for key in (key for key in OPTION_ORDER if key in record.options):
        check, requirement = OPTIONS[key].c_accepts, OPTIONS[key].number_requirement
        if key in UNSET_OPTIONS:
            check, requirement = f"value == 0 || ({check})", f"0 ({UNSET_OPTIONS[key]}) or {requirement}"
        if key == "atol" and record.implicit:
            check, requirement = f"{check} && value > 0", "a finite number > 0 for an implicit method"
        cases += [f"    case LAG_SET_{key.upper()}:", f"        return {check} ? NULL : {c_string(requirement)};"]
    return "\n".join([
        f"/* Why `value` cannot be the option at LAG_SET_ position `index` of {c_comment(record.name)}, or NULL. */",
        "static const char *lag_fmu_option_refusal(int index, real value)",
        "{",
        "    switch (index) {", *cases,
        "    default:",
        "        return \"an option of another integrator\";",
        "    }",
        "}", ""])
