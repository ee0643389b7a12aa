"""The C program of a run with forward sensitivities: the scene's program, then the augmented
system (templates/c/sensitivity.c.j2), a copy of the scene's integrator for it and its entry
point lag_sensitivity_run (integrators/c/sensitivity.c).

The copy is the integrator's own text with every name it defines, and the names of the model
interface it calls (README.md in integrators/c), prefixed: lag_X -> lag_aug_X, LAG_X -> LAG_AUG_X,
other -> aug_other. So the copy integrates the augmented system (lag_aug_rhs, LAG_AUG_NY, ...)
beside the scene's own integrator, unchanged, in one translation unit: the program without
sensitivities stays the same text.

Without error control of the sensitivities, the copy's error norms (the weighted root mean
square of the interface, HNW I, II.4, (4.11)) run over the state's 2n components only: the
sums of squares of dopri5, dop853 and rkn8 (lag_sum_of_squares) and radau5's norm read a
weight that is 0 on S, and divide by 2n.
"""
from __future__ import annotations

import re
from dataclasses import replace

from ..errors import InternalError, LagError, Setting
from ..integrators import c_file, integrator_source, registry
from ..integrators.registry import OPTION_ORDER, OPTIONS
from .c import render_c
from .kernel import Kernel

# The doubles of lag_sensitivity_run's summary, in order; the augmented state follows the last.
SUMMARY_FIELDS = ("status", "rows", "t_reached", "accepted", "rejected", "rhs_evals", "y_reached")
# What the integrators call of the model, besides the names they define themselves.
MODEL_INTERFACE = ("LAG_NQ", "LAG_NY", "LAG_NK", "LAG_JAC_AT", "LAG_JAC_LOWER", "LAG_JAC_UPPER", "LAG_JAC_SIZE",
                   "LAG_JAC_FIRST", "LAG_JAC_LAST", "LAG_STEPPER_PUBLIC", "lag_system", "lag_rhs",
                   "lag_accelerations", "lag_jacobian")
DEFINED = (re.compile(r"^#define\s+(\w+)", re.M),
           re.compile(r"^static\s[^;=(]*?\b(\w+)\s*\(", re.M),            # functions
           re.compile(r"\btypedef\s+struct\s+(\w+)"), re.compile(r"^}\s*(\w+);", re.M))
STATIC_CONSTANTS = re.compile(r"^static\s+const\s[^;]*;", re.M | re.S)
DECLARATOR = re.compile(r"\b(\w+)\s*(?:\[[^\]]*\])*\s*=(?!=)")
ENUM = re.compile(r"\benum\s+(\w+)\s*\{([^}]*)\}")


def sensitivity_source(kernel: Kernel, integrator, directions: int, source_name: str, error_control: bool):
    """The GeneratedSource of the scene's program with lag_sensitivity_run for `directions`
    directions; `kernel` is the sensitivity lowering's (with Dq, Dv, Dz and Dp), `integrator`
    the scene's choice (ir.IntegratorChoice), which the program is built for."""
    record = registry.get(integrator.name)
    refuse_integrator(record, integrator)
    program = replace(kernel, integrator=integrator, output_jacobian=None, initial_sensitivity=None)
    context = {"directions": directions, "summary": SUMMARY_FIELDS,
               "nystrom": record.second_order, "implicit": record.implicit, "error_control": error_control,
               "integrator": augmented_integrator(record.name, error_control), "driver": c_file("sensitivity.c"),
               "options": [(key, OPTIONS[key].c_cast) for key in OPTION_ORDER]}
    return render_c(program, source_name, sensitivity=context)


def refuse_integrator(record: registry.Integrator, integrator) -> None:
    """Sensitivities need an adaptive method that steps the right-hand side it is given."""
    if record.fixed_step or record.series:
        why = ("its Taylor series are generated for the equations of motion, not for the variational equations"
               if record.series else "it has no error control")
        able = [name for name in registry.names() if registry.get(name).adaptive and not registry.get(name).series]
        raise LagError(f"sensitivities on the C backend need an adaptive integrator ({', '.join(able)}), "
                       f"not {record.name}: {why}", integrator.span or Setting("--integrator"))


def augmented_integrator(name: str, error_control: bool) -> str:
    """The C text of integrator `name` with its names and the model's prefixed (module docstring)."""
    text = integrator_source(name)
    names = set(MODEL_INTERFACE)
    for pattern in DEFINED:
        names.update(pattern.findall(text))
    for statement in STATIC_CONSTANTS.findall(text):
        names.update(DECLARATOR.findall(statement))
    for tag, enumerators in ENUM.findall(text):
        names.update([tag, *(item.split("=")[0].strip() for item in enumerators.split(",") if item.strip())])
    text = re.sub(r"\b(" + "|".join(sorted(names, key=len, reverse=True)) + r")\b",
                  lambda match: _prefixed(match.group(1)), text)
    return text if error_control else _state_error_norms(text, name)


def _prefixed(name: str) -> str:
    for stem in ("lag_", "LAG_"):
        if name.startswith(stem):
            return f"{stem}aug_{name[len(stem):]}" if stem == "lag_" else f"LAG_AUG_{name[len(stem):]}"
    return f"aug_{name}"


def _state_error_norms(text: str, name: str) -> str:
    """The error norms over the state alone: lag_aug_sum_of_squares weighs each component by
    LAG_AUG_IN_ERROR(i) (defined with the augmented system) and the norms divide by LAG_AUG_NERR."""
    for sum_of_squares, weighted in STATE_NORMS:
        text = text.replace(sum_of_squares, weighted)
    if "LAG_AUG_IN_ERROR" not in text or "LAG_AUG_NERR" not in text:
        raise InternalError(f"the error norm of {name} is not one STATE_NORMS knows (codegen/c_sensitivity.py)")
    return text


# The sums of squares of the error norms (explicit_control.c's lag_sum_of_squares, radau5's
# radau_norm) weighted by LAG_AUG_IN_ERROR, and their divisions by the augmented length by 2n.
STATE_NORMS = (
    ("partial[j] += x[i + j] * x[i + j];", "partial[j] += LAG_AUG_IN_ERROR(i + j) * x[i + j] * x[i + j];"),
    ("partial[0] += x[i] * x[i];", "partial[0] += LAG_AUG_IN_ERROR(i) * x[i] * x[i];"),
    ("sum += (e[i] / sk) * (e[i] / sk);", "sum += LAG_AUG_IN_ERROR(i) * (e[i] / sk) * (e[i] / sk);"),
    ("s->error) / LAG_AUG_NY", "s->error) / LAG_AUG_NERR"),
    ("r_sqrt(LAG_AUG_NY * denominator)", "r_sqrt(LAG_AUG_NERR * denominator)"),
    ("r_sqrt(sum / LAG_AUG_NY)", "r_sqrt(sum / LAG_AUG_NERR)"))
