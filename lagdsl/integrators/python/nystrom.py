"""The NumPy backend's Runge-Kutta-Nystrom pair rkn8: RKN8(6)9 of Dormand, El-Mikkawy and Prince.

The method (J. R. Dormand, M. E. A. El-Mikkawy, P. J. Prince, "High-order embedded Runge-Kutta-
Nystrom formulae", IMA J. Numer. Anal. 7 (1987) 423-430; Hairer, Norsett, Wanner, Solving ODEs I
(HNW I), Section II.14, (14.12)) integrates second-order systems whose accelerations do not depend
on the velocities,

    q'' = a(t, q),   y = (q, v), v = q'.

With g_1 = a(t, q) and, for i = 2..8,

    Q_i = q + h (c_i v + h sum_{j<i} abar_ij g_j),   g_i = a(t + c_i h, Q_i),

a step of size h is

    q_new = q + h (v + h sum_i bbar_i g_i),   v_new = v + h sum_i b_i g_i,

of order 8 (bbar_i = b_i (1 - c_i)), and g_9 = a(t + h, q_new) is the next step's g_1 (FSAL;
c_9 = 1, abar_9j = bbar_j).  The embedded solution of order 6 has the weights bbar_hat, b_hat
(b_hat uses g_9 too); the error estimate is their difference,

    err_q = h^2 sum_i e_i g_i,   err_v = h sum_i e'_i g_i,   e = bbar - bbar_hat, e' = b - b_hat,

measured in the norm of HNW I, II.4, (4.11) over the 2n components; it is O(h^7), hence the
exponent 1/7 of the step-size controller.

`integrate_rkn8` mirrors `lagdsl/integrators/c/rkn8.c` with `explicit_control.c` operation for
operation (the same formulas, sums in the same left-to-right order, the same constants, each
rounded once from its exact quotient), so that the NumPy and C backends agree to round-off:

- the first step: HNW I, II.4 ("Starting Step Size") on f = rhs(t, y) = (v, a), one extra
  evaluation (lag_control_first_step);
- the trials: at most max_step, stretched by up to 1% to land on t_end; a step below
  MIN_STEP_EPS eps max(|t|, t_end - t0) fails with STEP_TOO_SMALL, and accepted + rejected >= max_steps > 0
  with MAX_STEPS (lag_control_trial); after each accepted step the work forecast of the C driver
  (integrators/forecast.py) may end a run that cannot finish within max_steps, with HOPELESS;
- the step size: h err^(-1/7) with safety 0.9, the factor within [0.2, 10], no growth right
  after a rejection, h/10 after a trial whose accelerations failed (singular, non-finite) or
  whose error is not finite (lag_control_update);
- the dense output: the method has no continuous extension, so y at t_old < t < t_new is a step
  of the same method from the start of the last accepted step (7 evaluations); t = t_new gives
  y_new itself (lag_stepper_dense).

As in C, the accelerations of a stage are evaluated at (Q_i, 0): they read the positions only.
A failure raises IntegrationFailure (fixed_step.py) with the C status code, the last accepted
time and state, and the rows delivered before it.
"""
from __future__ import annotations

import math
from fractions import Fraction
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from ...abi import HOPELESS, MAX_STEPS, NONFINITE, OK, SINGULAR, STEP_TOO_SMALL
from ...settings import MIN_STEP_EPS
from ..forecast import WorkForecast
from .fixed_step import STATS_KEYS, STEP_ERRORS, IntegrationFailure, _Output

if TYPE_CHECKING:
    from . import PythonRun

__all__ = ["MAX_STEPS", "RKN8", "IntegrationFailure", "integrate_rkn8"]

EPSILON = np.finfo(float).eps
# explicit_control.c: safety factor, largest decrease and increase of h.
SAFETY, FACMIN, FACMAX = 0.9, 0.2, 10.0


def _tableau():
    """RKN8(6)9 in exact rationals, indices 0..8 for the stages 1..9 (the numbers of rkn8.c)."""
    F = Fraction
    c = (F(0), F(1, 20), F(1, 10), F(3, 10), F(1, 2), F(7, 10), F(9, 10), F(1), F(1))
    bbar = (F(223, 7938), F(0), F(1175, 8064), F(925, 6048), F(41, 448), F(925, 14112), F(1175, 72576),
            F(0), F(0))
    b = (F(223, 7938), F(0), F(5875, 36288), F(4625, 21168), F(41, 224), F(4625, 21168), F(5875, 36288),
         F(223, 7938), F(0))
    # The embedded order-6 weights, as published (rkn8.c writes e = bbar - bbar_hat, e' = b - b_hat).
    bbar_hat = (F(7987313, 109941300), F(0), F(1610737, 44674560), F(10023263, 33505920),
                F(-497221, 12409600), F(10023263, 78180480), F(1610737, 402071040), F(0), F(0))
    b_hat = (F(7987313, 109941300), F(0), F(1610737, 40207104), F(10023263, 23454144),
             F(-497221, 6204800), F(10023263, 23454144), F(1610737, 40207104), F(-4251941, 54970650),
             F(3, 20))
    rows = (
        (),
        (F(1, 800),),
        (F(1, 600), F(1, 300)),
        (F(9, 200), F(-9, 100), F(9, 100)),
        (F(-66701, 197352), F(28325, 32892), F(-2665, 5482), F(2170, 24669)),
        (F(227015747, 304251000), F(-54897451, 30425100), F(12942349, 10141700), F(-9499, 304251),
         F(539, 9250)),
        (F(-1131891597, 901789000), F(41964921, 12882700), F(-6663147, 3220675), F(270954, 644135),
         F(-108, 5875), F(114, 1645)),
        (F(13836959, 3667458), F(-17731450, 1833729), F(1063919505, 156478208), F(-33213845, 39119552),
         F(13335, 28544), F(-705, 14272), F(1645, 57088)),
        bbar[:8],
    )
    abar = tuple(tuple(row) + (F(0),) * (9 - len(row)) for row in rows)
    return SimpleNamespace(
        name="RKN8(6)9", order=8, embedded_order=6, stages=9,
        c=c, abar=abar, bbar=bbar, b=b, bbar_hat=bbar_hat, b_hat=b_hat,
        e=tuple(x - y for x, y in zip(bbar, bbar_hat)),
        ev=tuple(x - y for x, y in zip(b, b_hat)))


# The tableau as exact fractions: c, abar (9 x 9, lower triangular, row 9 = bbar), bbar, b, the
# embedded bbar_hat, b_hat and the error weights e = bbar - bbar_hat (positions), ev = b - b_hat
# (velocities, e' of the docstring).
RKN8 = _tableau()

# The working constants, as rkn8.c has them: each quotient rounded once, (real)p / q; each error
# weight the difference of the two rounded weights, (real)p1 / q1 - (real)p2 / q2.  A zero weight
# is a term rkn8.c leaves out of its sum (see _combination).
_C = tuple(float(x) for x in RKN8.c)
_ABAR = tuple(tuple(float(x) for x in row) for row in RKN8.abar)
_BBAR = tuple(float(x) for x in RKN8.bbar)
_B = tuple(float(x) for x in RKN8.b)
_E = tuple(float(x) - float(y) for x, y in zip(RKN8.bbar, RKN8.bbar_hat))
_EV = tuple(float(x) - float(y) for x, y in zip(RKN8.b, RKN8.b_hat))
_EXPONENT = 1.0 / 7      # 1/p, p = 7 the power of h in the error estimate


class _StageFailure(Exception):
    """An evaluation of the accelerations failed: the C status it corresponds to."""

    def __init__(self, status: int):
        super().__init__(status)
        self.status = status


def _fmin(a, b):
    """C's fmin: a NaN argument is ignored."""
    return b if a != a else a if b != b else (a if a < b else b)


def _fmax(a, b):
    """C's fmax: a NaN argument is ignored."""
    return b if a != a else a if b != b else (a if a > b else b)


def _pow(x, y):
    """C's pow for x >= 0 (Python's raises on 0 ** negative)."""
    if x == 0 and y < 0:
        return math.inf
    return x ** y


def _sequential_sum(x):
    """x_0 + x_1 + ... in this order, as a C loop adds (numpy.sum adds pairwise)."""
    return float(np.cumsum(x)[-1]) if len(x) else 0.0


def _sum_of_squares(x):
    """lag_sum_of_squares: sum x_i^2 in four interleaved partial sums, in C's order."""
    squares = x * x
    whole = len(squares) // 4 * 4
    partial = [0.0] * 4
    if whole:
        partial = [float(s) for s in np.cumsum(squares[:whole].reshape(-1, 4), axis=0)[-1]]
    for s in squares[whole:]:
        partial[0] = partial[0] + float(s)
    return (partial[0] + partial[1]) + (partial[2] + partial[3])


def _combination(weights, g):
    """sum_j weights[j] g_j over the nonzero weights, left to right: the sums of rkn8.c."""
    total = None
    for w, gj in zip(weights, g):
        if w != 0:
            total = w * gj if total is None else total + w * gj
    return total


class _Control:
    """lag_control of explicit_control.c: the trials' sizes and their verdicts."""

    def __init__(self, rtol, atol, t0, t_end, max_step, max_steps, stats):
        self.rtol, self.atol = float(rtol), float(atol)
        self.t_end = t_end
        self.span = t_end - t0
        self.hmax = float(max_step) if max_step > 0 else t_end - t0
        self.max_steps = int(max_steps)
        self.rejected = False
        self.stats = stats

    def scale(self, y0, y1):
        """atol + rtol max(|y0|, |y1|), |y0| when y1 is NaN (lag_control_scale)."""
        a0, a1 = np.abs(y0), np.abs(y1)
        return self.atol + self.rtol * np.where(a1 > a0, a1, a0)

    def first_step(self, t, y, f, rhs, n):
        """HNW I, II.4, steps (a)-(f) (lag_control_first_step); f = rhs(t, y)."""
        ny = len(y)
        w = self.scale(y, y)
        d0 = math.sqrt(_sequential_sum((y / w) * (y / w)) / ny)
        d1 = math.sqrt(_sequential_sum((f / w) * (f / w)) / ny)
        h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
        h0 = _fmin(h0, self.hmax)
        y1 = y + h0 * f
        self.stats["rhs_evals"] += 1
        try:
            f1 = np.asarray(rhs(t + h0, y1), dtype=float)
        except (np.linalg.LinAlgError, ArithmeticError):
            return h0       # a probe outside the model's domain only loses the refinement
        if not np.all(np.isfinite(f1[n:])):
            return h0
        if not h0 > 0:
            return h0       # C's d2 = x / 0 is not finite
        w = (f1 - f) / self.scale(y, y)
        d2 = math.sqrt(_sequential_sum(w * w) / ny) / h0
        if not math.isfinite(d2):
            return h0
        dmax = _fmax(d1, d2)
        h1 = _fmax(1e-6, h0 * 1e-3) if dmax <= 1e-15 else _pow(0.01 / dmax, _EXPONENT)
        return _fmin(_fmin(100 * h0, h1), self.hmax)

    def trial(self, t, h_proposed):
        """(status, h, t_new) of the next trial from t (lag_control_trial)."""
        hh = _fmin(h_proposed, self.hmax)
        if self.max_steps > 0 and self.stats["accepted"] + self.stats["rejected"] >= self.max_steps:
            return MAX_STEPS, None, None
        if not hh >= MIN_STEP_EPS * EPSILON * _fmax(abs(t), self.span):
            return STEP_TOO_SMALL, None, None
        if t + 1.01 * hh >= self.t_end:
            return OK, self.t_end - t, self.t_end
        return OK, hh, t + hh

    def update(self, status, h, err):
        """(accepted, next step size) after a trial of size h (lag_control_update)."""
        if status != OK or not math.isfinite(err):
            self.stats["rejected"] += 1
            self.rejected = True
            return False, h / 10
        fac = SAFETY * _pow(err, -_EXPONENT)
        if err > 1:
            self.stats["rejected"] += 1
            self.rejected = True
            return False, h * _fmax(FACMIN, fac)
        fac = _fmin(FACMAX, _fmax(FACMIN, fac))
        if self.rejected:
            fac = _fmin(fac, 1.0)
        self.rejected = False
        self.stats["accepted"] += 1
        return True, _fmin(h * fac, self.hmax)


class _Stepper:
    """lag_stepper of rkn8.c: the stages, the solution, the error and the dense output."""

    def __init__(self, accelerations, n, stats):
        self.accelerations = accelerations
        self.n = n
        self.velocities = np.zeros(n)     # the stage's velocities: a reads the positions only
        self.stats = stats
        self.g = [None] * 9

    def acceleration(self, t, q):
        """a(t, Q) (rkn8_acceleration); a failure raises _StageFailure with its C status."""
        self.stats["rhs_evals"] += 1
        try:
            g = np.array(self.accelerations(t, np.concatenate((q, self.velocities))), dtype=float)
        except np.linalg.LinAlgError:
            raise _StageFailure(SINGULAR) from None
        except ArithmeticError:
            raise _StageFailure(NONFINITE) from None
        if not np.all(np.isfinite(g)):
            raise _StageFailure(NONFINITE)
        return g

    def stages(self, t, q, v, h):
        """g_2 .. g_8 of a step of size h from (t, q, v), with g[0] = a(t, q) (rkn8_stages)."""
        g = self.g
        for i in range(1, 7):
            stage = q + h * (_C[i] * v + h * _combination(_ABAR[i][:i], g))
            g[i] = self.acceleration(t + _C[i] * h, stage)
        stage = q + h * (v + h * _combination(_ABAR[7][:7], g))
        g[7] = self.acceleration(t + h, stage)

    def solution(self, q, v, h):
        """(q_new, v_new) of the order-8 solution (rkn8_solution)."""
        q_new = q + h * (v + h * _combination(_BBAR, self.g))
        v_new = v + h * _combination(_B, self.g)
        return np.concatenate((q_new, v_new))

    def trial(self, control, t, y, h, t_new):
        """(y_new, the scaled error) of a trial of size h from (t, y) to t_new; g[8] = a(t_new, q_new)
        (rkn8_trial)."""
        n = self.n
        q, v = y[:n], y[n:]
        self.stages(t, q, v, h)
        y_new = self.solution(q, v, h)
        self.g[8] = self.acceleration(t_new, y_new[:n])
        error_q = h * h * _combination(_E, self.g)
        error_v = h * _combination(_EV, self.g)
        error = np.concatenate((error_q / control.scale(q, y_new[:n]), error_v / control.scale(v, y_new[n:])))
        return y_new, math.sqrt(_sum_of_squares(error) / len(y))

    def dense(self, t, t_old, y_old, g_old, t_now, y_now):
        """y at t_old <= t <= t_now: y_now at t_now, else a step of size t - t_old from (t_old, y_old)
        with g_1 = g_old (lag_stepper_dense; g[1..7] are overwritten, g[0] kept)."""
        if t == t_now or t_now == t_old:
            return (y_now if t == t_now else y_old).copy()
        n = self.n
        g1 = self.g[0]
        self.g[0] = g_old
        try:
            self.stages(t_old, y_old[:n], y_old[n:], t - t_old)
            return self.solution(y_old[:n], y_old[n:], t - t_old)
        finally:
            self.g[0] = g1


def integrate_rkn8(accelerations, rhs, t_grid, y0, rtol, atol, max_step=0, max_steps=0, stop=None):
    """RKN8(6)9 with adaptive steps on q'' = a(t, q), y = (q, v) of shape (2n,).

    accelerations(t, y) returns q'' (shape (n,)) and rhs(t, y) returns (v, q'') (used for the
    first step only, as in C).  Returns (Y, stats): Y[k] = y(t_grid[k]) (with a stop condition
    `stop` that ends the run, fewer rows, the last at stop.time) and the counters STATS_KEYS
    (accepted, rejected, rhs_evals: evaluations of the accelerations, dense outputs included).
    max_step > 0 bounds the step, max_steps > 0 the trials (accepted and rejected).
    """
    t_grid = np.asarray(t_grid, dtype=float)
    y = np.array(y0, dtype=float)
    if y.ndim != 1 or len(y) % 2:
        raise ValueError("rkn8 integrates one state y = (q, v) of shape (2n,)")
    n = len(y) // 2
    output = _Output(t_grid, y, stop)
    stats = dict.fromkeys(STATS_KEYS, 0)
    t0, t_end = float(t_grid[0]), float(t_grid[-1])
    t = t0
    control = _Control(rtol, atol, t0, t_end, max_step, max_steps, stats)
    stepper = _Stepper(accelerations, n, stats)
    forecast = WorkForecast(t0, t_end, max_steps) if max_steps > 0 else None
    try:
        f = _first_derivative(rhs, t, y, n, stats)
        stepper.g[0] = f[n:].copy()
        h = control.first_step(t, y, f, rhs, n)
        while t < t_end and not output.stopped:
            t_new, y_new, h = _accepted_step(control, stepper, output, t, y, h, max_steps)
            # rkn8_accept: the start of the step is kept for the dense output
            t_old, y_old, g_old = t, y, stepper.g[0]
            t, y, stepper.g[0] = t_new, y_new, stepper.g[8]
            if forecast is not None and forecast.hopeless(t - t_old, t):
                raise output.failure("rkn8", t, y, HOPELESS, max_steps=max_steps, forecast=forecast.steps)
            output.deliver(t, y, lambda s, t_old=t_old, y_old=y_old, g_old=g_old, t_now=t, y_now=y:
                           stepper.dense(s, t_old, y_old, g_old, t_now, y_now))
    except _StageFailure as failure:
        raise output.failure("rkn8", t, y, failure.status) from None
    except STEP_ERRORS as error:
        raise output.failure_of(error, "rkn8", t, y) from None
    return output.Y[:output.completed], stats


def _first_derivative(rhs, t, y, n, stats):
    """lag_stepper_init: f = (v, a) at the start, which gives g_1 and the first step."""
    stats["rhs_evals"] += 1
    try:
        f = np.array(rhs(t, y), dtype=float)
    except np.linalg.LinAlgError:
        raise _StageFailure(SINGULAR) from None
    except ArithmeticError:
        raise _StageFailure(NONFINITE) from None
    if not np.all(np.isfinite(f[n:])):
        raise _StageFailure(NONFINITE)
    return f


def _accepted_step(control, stepper, output, t, y, h, max_steps):
    """lag_stepper_step: trials from (t, y) until one is accepted; (t_new, y_new, the next step)."""
    while True:
        status, h_trial, t_new = control.trial(t, h)
        if status in (MAX_STEPS, STEP_TOO_SMALL):
            raise output.failure("rkn8", t, y, status, max_steps=max_steps)
        err, y_new = 0.0, None
        try:
            y_new, err = stepper.trial(control, t, y, h_trial, t_new)
            status = OK
        except _StageFailure as failure:
            status = failure.status
        except ArithmeticError:     # numpy set to raise: where C would get an inf or NaN
            status = NONFINITE
        accepted, h = control.update(status, h_trial, err)
        if accepted:
            return t_new, y_new, h


def run_rkn8(run: PythonRun):
    """The NumPy backend's rkn8 (its record's stepper): (Y, stats) of integrate_rkn8."""
    options = run.options
    accelerations = run.checked(lambda t, y: run.program.accelerations(run.par, t, y)[0])
    return integrate_rkn8(accelerations, run.rhs(), run.times, run.y0, options["rtol"], options["atol"],
                          options.get("max_step", 0.0), run.max_steps, run.stop)
