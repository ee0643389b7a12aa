"""The stop condition of a scene (`stop when h < 0;`) on the NumPy backend, as the C driver checks it.

The condition holds where e(t, y) < 0 (ir.StopCondition). It is checked at the start, then at
the end of every step; where it begins to hold inside a step, the stop time is the root of e
along the step's dense output, found to the resolution of t, so the event is located to the
integrator's own accuracy. The C driver's lag_stop_root is the same method.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

EPSILON = float(np.finfo(float).eps)


class StopCondition:
    """e(t, y) of one run, with its value at the end of the last step (e_old) and the stop time."""

    def __init__(self, function: Callable[[float, np.ndarray], float]):
        self.function = function
        self.e_old = 0.0
        self.time: float | None = None

    def holds_at_start(self, t: float, y: np.ndarray) -> bool:
        self.e_old = self.function(t, y)
        if self.e_old < 0:
            self.time = t
        return self.time is not None

    def crossed(self, t_old: float, t: float, y: np.ndarray, dense: Callable[[float], np.ndarray]) -> float | None:
        """After a step from t_old to t (state y, dense output `dense`): None while the
        condition does not hold at t, else the time in the step where it began to."""
        e = self.function(t, y)
        if not e < 0:
            self.e_old = e
            return None
        self.time = stop_root(lambda s: self.function(s, dense(s)), t_old, t, self.e_old, e)
        return self.time


def stop_root(e: Callable[[float], float], a: float, b: float, fa: float, fb: float) -> float:
    """The root of e in [a, b] where e(a) = fa >= 0 > fb = e(b), by regula falsi with the Illinois
    modification (Dahlquist and Bjorck, Numerical Methods, 6.2.3), to the resolution of t; the
    bracket's right end (where e < 0) is returned."""
    side = 0
    for _ in range(200):
        if not b - a > 4 * EPSILON * max(abs(a), abs(b)):
            break
        with np.errstate(all="ignore"):
            c = b - fb * (b - a) / (fb - fa)
        if not a < c < b:
            c = a + (b - a) / 2         # a secant step outside the bracket (or NaN): bisect
        fc = e(c)
        if fc < 0:
            b, fb = c, fc
            if side == -1:
                fa /= 2
            side = -1
        else:
            a, fa = c, fc
            if side == 1:
                fb /= 2
            side = 1
    return b
