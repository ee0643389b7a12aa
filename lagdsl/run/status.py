"""How a run ends: the status codes of both backends, their messages and remedies, and the
SimulationError a failure raises.

The codes are the C driver's lag_status (runtime.h); the NumPy backend and the Python steppers
use the same numbers, so a sweep reads one code per member whatever ran it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SimulationError, SimulationInterrupted
from ..settings import RunPlan
from .output import Result

# K (M, or the saddle-point matrix of a constrained system) counts as singular below this
# reciprocal condition estimate: q'' would keep fewer than about 3 correct digits. The generated
# code of both backends uses the same threshold (LAG_RCOND_MIN, RCOND_MIN).
RCOND_MIN = 1000 * float(np.finfo(float).eps)


@dataclass(frozen=True)
class Status:
    code: int
    c_name: str             # the lag_status enumerator in C
    message: str            # what happened ({max_steps}: the run's step limit)
    remedy: str             # what to try


OK, SINGULAR, NONFINITE, STEP_TOO_SMALL, MAX_STEPS, NO_CONVERGENCE, PROJECTION_FAILED, INTERRUPTED, HOPELESS = range(9)
STATUSES = {status.code: status for status in (
    Status(OK, "LAG_OK", "no error", ""),
    Status(SINGULAR, "LAG_ERR_SINGULAR", "the mass matrix is singular at this state",
           "the coordinates are singular here (e.g. Euler angles at theta = 0, spherical coordinates at a "
           "pole, a link of zero length) or the constraints are dependent; use coordinates that do not pass "
           "through this configuration, or start away from it"),
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
    Status(HOPELESS, "LAG_ERR_HOPELESS",
           "at its pace so far, the run would need more steps than the step limit of {max_steps} allows",
           "the solution may be singular near this time, or the problem is stiff: try --integrator "
           "radau5, or raise --max-steps"),
)}


def status_message(code: int, max_steps: int) -> str:
    status = STATUSES.get(code)
    return "unknown failure" if status is None else status.message.format(max_steps=max_steps)


def state_names(plan: RunPlan) -> list[str]:
    names = list(plan.coordinates)
    return names + [f"{n}'" for n in names]


def simulation_error(plan: RunPlan, code: int, t_fail: float, y_fail, partial: Result, rcond: float) -> SimulationError:
    """The error for a failed run; `rcond` is the reciprocal condition estimate of K at y_fail."""
    status = STATUSES.get(code, Status(code, "", "unknown failure", "please report this"))
    message = status.message.format(max_steps=plan.max_steps)
    if code == SINGULAR:
        message += f" (reciprocal condition estimate {rcond:.3g}, below {RCOND_MIN:.3g})"
    kind = SimulationInterrupted if code == INTERRUPTED else SimulationError
    state = dict(zip(state_names(plan), map(float, y_fail)))
    return kind(message, t_fail, state, status.remedy, partial, code)
