"""The SimulationError a failed run raises, from its status (lagdsl/abi.py: the codes of both
backends, their messages and remedies; the NumPy backend and the Python steppers use the C
driver's numbers, so a sweep reads one code per member whatever ran it).
"""
from __future__ import annotations

import math

from ..abi import INTERRUPTED, status_of
from ..errors import SimulationError, SimulationInterrupted
from ..settings import RunPlan
from .output import Result


def state_names(plan: RunPlan) -> list[str]:
    names = list(plan.coordinates)
    return names + [f"{n}'" for n in names]


def simulation_error(plan: RunPlan, code: int, t_fail: float, y_fail, partial: Result, rcond: float,
                     forecast: float = math.nan) -> SimulationError:
    """The error for a failed run; `rcond` is the reciprocal condition estimate of K at y_fail,
    `forecast` the steps the work forecast said the run would take (integrators/forecast.py)."""
    status = status_of(code)
    kind = SimulationInterrupted if code == INTERRUPTED else SimulationError
    state = dict(zip(state_names(plan), map(float, y_fail)))
    message = status.describe(plan.max_steps, rcond, forecast, plan.time.stop)
    return kind(message, t_fail, state, status.remedy_for(plan.integrator.name), partial, code, forecast)
