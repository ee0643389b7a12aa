"""The work forecast: an adaptive run stops as soon as its pace says it cannot reach its stop
time within its step limit, rather than when it has used the limit up.

One rule for both backends: `WorkForecast` here (the NumPy backend's scipy loop and its rkn8),
and `lag_forecast_step` in the C driver (integrators/c/driver.c), with the same constants
(settings.FORECAST_JUDGED_AFTER and FORECAST_WINDOW, emitted to C as LAG_FORECAST_*). So a scene
finishes on both backends or stops on both, whatever a step costs on each.

After n accepted steps from `start` to t, with `left` = |stop - t| still to go, the forecast of
the steps the whole run takes is

    n + min(left n / |t - start|,  left / h_recent)

where h_recent is the largest step of the last one or two windows of FORECAST_WINDOW steps. The
first term is the average pace since the start, which a passing burst of small steps (a close
approach) barely moves; the second the recent step size, which forgives a fast transient at the
start. It is judged once every FORECAST_WINDOW steps from FORECAST_JUDGED_AFTER steps on; the run
is hopeless when the forecast exceeds the step limit. A runaway (a collapsing step, an absurd
tolerance, g = 1e300) forecasts far more steps than any limit and stops after about
FORECAST_JUDGED_AFTER steps, in milliseconds; a long legitimate run forecasts its own length and
goes on.
"""
from __future__ import annotations

import math

from ..settings import FORECAST_JUDGED_AFTER, FORECAST_WINDOW


class WorkForecast:
    """The forecast of a run from `start` to `stop` with a limit of `max_steps` steps; `steps`
    is the forecast when it last judged the run (NaN before), the number a failure reports."""

    def __init__(self, start: float, stop: float, max_steps: int):
        self.start, self.stop, self.max_steps = start, stop, max_steps
        self.taken = 0
        self.window_largest = self.previous_largest = 0.0
        self.steps = math.nan

    def hopeless(self, step: float, t: float) -> bool:
        """After an accepted step of size `step` that reached t: can the run no longer finish?"""
        self.taken += 1
        self.window_largest = max(self.window_largest, abs(step))
        if self.taken % FORECAST_WINDOW:
            return False
        recent = max(self.window_largest, self.previous_largest)
        self.previous_largest, self.window_largest = self.window_largest, 0.0
        if self.taken < FORECAST_JUDGED_AFTER:
            return False
        left, covered = abs(self.stop - t), abs(t - self.start)
        by_average = left * self.taken / covered if covered > 0 else math.inf
        by_recent = left / recent if recent > 0 else math.inf
        self.steps = self.taken + min(by_average, by_recent)
        return self.steps > self.max_steps
