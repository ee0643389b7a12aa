"""The fixed-step integrators of the NumPy backend: rk4 and gauss, on one state or a batch.

The state has shape (n,) or (n, B): B initial conditions integrated together with the same steps.
Both methods mirror their C counterparts (`lagdsl/integrators/c/rk4.c`, `gauss.c`) operation for
operation, so that the two backends agree to round-off:

- Steps end at t0 + k*step; the last one is shortened to end exactly at the final output time.
  An excess of (t_end - t0)/step over an integer below the rounding error of the times is not a
  step (10/0.01 is 1000 steps).
- rk4: the classical Runge-Kutta method of order 4, Hairer, Norsett, Wanner, Solving ODEs I,
  II.1, Table 1.2; dense output: the cubic Hermite interpolant of y and f at both ends of the
  step (HNW I, II.6), f at the new point being the first stage of the next step.
- gauss: s-stage Gauss-Legendre collocation (order 2s) on Hamilton's equations in canonical
  variables z = (q, p), symplectic and symmetric (Hairer, Lubich, Wanner, Geometric Numerical
  Integration, 2nd ed. (GNI), II.1.3 and VI.4).  The stage equations in the increments
  Z_i = sum_j mu_ij dz_j, dz_j = h b_j F(t0 + c_j h, z0 + Z_j), z1 = z0 + sum_j dz_j (mu_ij =
  a_ij / b_j, with mu_ij + mu_ji = 1 exactly: symplectic in floating point) are solved by
  fixed-point iteration from the extrapolated collocation polynomial of the last step
  (GNI VIII.6.1) until the increment is 0 or stops decreasing (GNI VIII.6); z is accumulated
  with compensated summation (GNI VIII.5).  Dense output: the collocation polynomial of the step,
  converted to (q, q').
  In a batch every column stops its iteration by its own criterion, so a batch gives the same
  result as its columns integrated one by one.

Output times between step ends are interpolated; a step ending exactly on one is delivered as is.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ...abi import INTERRUPTED, NO_CONVERGENCE, NONFINITE, PROJECTION_FAILED, SINGULAR, STEP_TOO_SMALL, status_of
from ...settings import MIN_STEP_EPS
from .gauss_coefficients import gauss_legendre_tableau, integrated_basis, symplectic_mu

if TYPE_CHECKING:
    from . import PythonRun

EPSILON = np.finfo(float).eps
MAX_ITERATIONS = 100
# A sweep that no longer decreases the increment, below this many ulp, has reached round-off
# (as in gauss.c); above it a stagnating iteration keeps iterating.
NOISE = 65536

# What a step of the Python integrators may raise that ends the run (_Output.failure_of).
STEP_ERRORS = (np.linalg.LinAlgError, ArithmeticError, KeyboardInterrupt)

STATS_KEYS = ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters")


class IntegrationFailure(RuntimeError):
    """The integration stopped: t and y are the last good time and state, Y the output rows
    delivered before (Y[:completed]), status the matching C status code, forecast the steps the
    work forecast said the run would take (HOPELESS; integrators/forecast.py)."""

    def __init__(self, message: str, t: float, y: np.ndarray, Y: np.ndarray,
                 completed: int | None = None, status: int = NONFINITE, forecast: float = math.nan):
        super().__init__(message)
        self.forecast = forecast
        self.t = t
        self.y = y
        self.Y = Y
        self.completed = len(Y) if completed is None else completed
        self.status = status


def _step_count(t0: float, t_end: float, step: float) -> int:
    """(t_end - t0)/step rounded up, not counting an excess below the rounding error of the times."""
    ratio = (t_end - t0) / step
    if not ratio > 0:
        return 0
    slack = 8 * EPSILON * (abs(t0) + abs(t_end)) / step
    whole = np.floor(ratio)
    return int(whole) + int(ratio - whole > slack)


class _Output:
    """Collects the rows of Y at the output times as the steps pass them.

    `stop`, if given, is a stop condition (lagdsl.run.stop.StopCondition): where it begins to
    hold in a step, the rows end with one at its time, and the integration stops.
    """

    def __init__(self, t_grid, y0, stop=None):
        self.t_grid = np.asarray(t_grid, dtype=float)
        self.Y = np.empty((len(self.t_grid),) + np.shape(y0))
        self.Y[0] = y0
        self.completed = 1
        self.stop, self.stopped, self.t_old = stop, False, self.t_grid[0]

    def deliver(self, t_new, y_new, dense):
        """Fill the rows up to t_new: y_new at t_new itself, dense(t) before it."""
        end = self.stop.crossed(self.t_old, t_new, y_new, dense) if self.stop is not None else None
        self.t_old = t_new
        while self.completed < len(self.t_grid) and self.t_grid[self.completed] <= t_new and (
                end is None or self.t_grid[self.completed] < end):
            t = self.t_grid[self.completed]
            self.Y[self.completed] = y_new if t == t_new else dense(t)
            self.completed += 1
        if end is not None:
            self.Y[self.completed] = y_new if end == t_new else dense(end)
            self.completed += 1
            self.stopped = True

    def failure(self, method: str, t, y, status: int = NONFINITE, detail: str = "", max_steps: int = 0,
                forecast: float = math.nan):
        """`method` failed with `status` in the step from (t, y): the status table's words, then `detail`."""
        words = status_of(status).describe(max_steps, forecast=forecast, t_end=float(self.t_grid[-1]))
        message = f"{method}: {words} (in the step from t = {t}){detail}"
        return IntegrationFailure(message, t, y, self.Y[:self.completed].copy(), self.completed, status, forecast)

    def failure_of(self, error: BaseException, method: str, t, y):
        """The failure of an exception raised in `method`'s step from t (one of STEP_ERRORS):
        a singular mass matrix, an overflow (numpy set to raise), or Ctrl-C."""
        if isinstance(error, np.linalg.LinAlgError):
            return self.failure(method, t, y, SINGULAR)
        if isinstance(error, KeyboardInterrupt):
            return self.failure(method, t, y, INTERRUPTED)
        return self.failure(method, t, y)


def _steps(output, step):
    """(last, t_new) of each step to the last output time, the times from t0 rather than by
    accumulation (no drift).  A step below the resolution of t (or not positive) is refused."""
    t0, t_end = output.t_grid[0], output.t_grid[-1]
    if not (step >= MIN_STEP_EPS * EPSILON * max(abs(t0), abs(t_end)) and step > 0):
        raise output.failure(f"a step of {step}", t0, output.Y[0], STEP_TOO_SMALL)
    steps = _step_count(t0, t_end, step)
    for n in range(1, steps + 1):
        if output.stopped:
            return
        yield n == steps, (t_end if n == steps else t0 + n * step)


def integrate_rk4(rhs, t_grid, y0, step, stop=None):
    """Classical RK4 with a fixed step; Y[k] at t_grid[k], shape (len(t_grid),) + y0.shape (with a
    stop condition `stop` that ends the run, fewer rows, the last at stop.time)."""
    t_grid = np.asarray(t_grid, dtype=float)
    y = np.array(y0, dtype=float)
    output = _Output(t_grid, y, stop)
    stats = dict.fromkeys(STATS_KEYS, 0)
    t = t_grid[0]
    f = rhs(t, y)
    stats["rhs_evals"] = 1
    try:
        for _, t_new in _steps(output, step):
            y_new, f_new = _rk4_step(rhs, t, y, f, t_new)
            stats["rhs_evals"] += 4
            if not (np.all(np.isfinite(y_new)) and np.all(np.isfinite(f_new))):
                raise output.failure("rk4", t, y)
            output.deliver(t_new, y_new, lambda s: _hermite(t, y, f, t_new, y_new, f_new, s))
            t, y, f = t_new, y_new, f_new
            stats["accepted"] += 1
    except STEP_ERRORS as error:
        raise output.failure_of(error, "rk4", t, y) from None
    return output.Y[:output.completed], stats


def _rk4_step(rhs, t, y, f, t_new):
    """The state at t_new and f there (the first stage of the next step)."""
    h = t_new - t
    t_mid = t + h / 2
    k2 = rhs(t_mid, y + (h / 2) * f)
    k3 = rhs(t_mid, y + (h / 2) * k2)
    k4 = rhs(t_new, y + h * k3)
    y_new = y + (h / 6) * (f + 2 * (k2 + k3) + k4)
    return y_new, rhs(t_new, y_new)


def _hermite(t_old, y_old, f_old, t, y, f, t_out):
    """The cubic Hermite interpolant of (y, f) at both ends, in the nested form of rk4.c."""
    h = t - t_old
    theta = (t_out - t_old) / h
    dy = y - y_old
    slope0 = h * f_old - dy
    return y_old + theta * (dy + (1 - theta) * (slope0 + theta * (dy - h * f - slope0)))


def integrate_gauss(hamilton_rhs, to_canonical, from_canonical, t_grid, y0, step, stages, stop=None):
    """s-stage Gauss-Legendre collocation with a fixed step on z = to_canonical(t, y).

    hamilton_rhs(t, z), to_canonical(t, y) and from_canonical(t, z) take and return arrays of
    shape (n,) or (n, B).  Returns (Y, stats) with Y[k] = y(t_grid[k]) in (q, q') form.
    stats["rhs_evals"] counts hamilton_rhs calls (one call evaluates the whole batch) and
    stats["newton_iters"] the fixed-point sweeps (those of the slowest column of a batch).
    A stop condition `stop` ends the run as in integrate_rk4.
    """
    t_grid = np.asarray(t_grid, dtype=float)
    y = np.array(y0, dtype=float)
    # The iteration works on (n, B) arrays; the model functions see the shape y0 has.
    if y.ndim == 1:
        hamilton_rhs = _on_column(hamilton_rhs)
        as_batch, as_given = (lambda x: np.asarray(x)[:, None]), (lambda x: x[:, 0])
    else:
        as_batch, as_given = np.asarray, np.asarray
    method = _Gauss(hamilton_rhs, *gauss_legendre_tableau(int(stages)))
    output = _Output(t_grid, y, stop)
    t = t_grid[0]
    z = as_batch(to_canonical(t, y))
    error = np.zeros_like(z)          # compensated summation: the part of z lost to rounding
    try:
        for last, t_new in _steps(output, step):
            z_new, error, y_new = _gauss_step(method, output, from_canonical, as_given, t, z, error, y, t_new,
                                              t_grid[-1] - t if last else step)
            t, z, y = t_new, z_new, y_new
    except STEP_ERRORS as error:
        raise output.failure_of(error, "gauss", t, y) from None
    return output.Y[:output.completed], method.stats


def _gauss_step(method, output, from_canonical, as_given, t, z, error, y, t_new, h):
    """One step of length h from (t, z): the rows it passes are delivered; returns z, its
    rounding error and y at t_new."""
    status = method.solve_stages(t, z, h)
    if status is not None:
        raise output.failure("gauss", t, y, NO_CONVERGENCE, f": {status}; reduce the step")
    z_new, error = method.update(z, error)
    if not np.all(np.isfinite(z_new)):
        raise output.failure("gauss", t, y)
    y_new = from_canonical(t_new, as_given(z_new))
    output.deliver(t_new, y_new, lambda s: from_canonical(s, as_given(method.dense(z, t, s))))
    return z_new, error, y_new


def _on_column(function):
    """function(t, x) for x of shape (n,), called on (n, 1) arrays."""
    return lambda t, x: np.asarray(function(t, x[:, 0]))[:, None]


class _Gauss:
    """The stage equations, update and collocation polynomial of one step (gauss.c's functions)."""

    def __init__(self, hamilton_rhs, c, b, A):
        self.hamilton_rhs = hamilton_rhs
        self.c, self.b, self.mu = c, b, symplectic_mu(b, A)
        self.stats = dict.fromkeys(STATS_KEYS, 0)
        self.dz = None            # h b_j F_j of the last step, shape (s, n, B): its polynomial
        self.dz_new = None        # h b_j F_j of the step being solved
        self.h = self.h_done = None   # length of the step being solved, of the last step
        self.predict_ratio = 1.0
        self.predict = self._predictor(1.0)

    def _predictor(self, ratio):
        """Z_i^0 = sum_j predict[i, j] dz_j: the last polynomial at theta = 1 + ratio c_i, minus theta = 1."""
        self.predict_ratio = ratio
        return integrated_basis(self.c, self.b, 1 + ratio * self.c).T / self.b - 1

    def _start(self, h, shape):
        if self.dz is None:
            return np.zeros((len(self.c),) + shape)
        if h != self.predict_ratio * self.h_done:
            self.predict = self._predictor(h / self.h_done)
        return self._combine(self.predict, self.dz)

    @staticmethod
    def _combine(weights, dz):
        """sum_j weights[i, j] dz_j, summed in order j = 0, 1, ... as in C (batch-independent)."""
        out = np.zeros((weights.shape[0],) + dz.shape[1:])
        for i in range(weights.shape[0]):
            for j in range(weights.shape[1]):
                out[i] += weights[i, j] * dz[j]
        return out

    def solve_stages(self, t, z, h):
        """Iterate the stage equations of a step of length h from (t, z); dz_new holds the result.
        Returns None, or why the iteration failed."""
        s = len(self.c)
        self.h = h
        stage = self._start(h, z.shape)
        self.dz_new = np.zeros_like(stage)
        active = np.arange(z.shape[1])
        delta_old = np.full(z.shape[1], np.inf)
        for _ in range(MAX_ITERATIONS):
            self.stats["newton_iters"] += 1
            for i in range(s):
                derivative = self.hamilton_rhs(t + self.c[i] * h, z[:, active] + stage[i][:, active])
                self.stats["rhs_evals"] += 1
                if not np.all(np.isfinite(derivative)):
                    return "the fixed-point iteration diverged"
                self.dz_new[i][:, active] = (h * self.b[i]) * derivative
            dz = self.dz_new[:, :, active]
            scale = np.max(np.maximum(np.abs(dz), np.abs(stage[:, :, active])), axis=0) + np.abs(z[:, active])
            following = self._combine(self.mu, dz)
            change = np.abs(following - stage[:, :, active])
            ratio = np.divide(change, scale, out=np.zeros_like(change), where=change > 0)
            delta = np.max(ratio, axis=(0, 1))
            stage[:, :, active] = following
            if not np.all(np.isfinite(delta)):
                return "the fixed-point iteration diverged"
            done = (delta == 0) | ((delta >= delta_old[active]) & (delta_old[active] <= NOISE * EPSILON))
            delta_old[active] = delta
            active = active[~done]
            if len(active) == 0:
                return None
        return f"the fixed-point iteration did not converge in {MAX_ITERATIONS} sweeps"

    def update(self, z, error):
        """z + sum_j dz_j by compensated summation (GNI VIII.5); accepts the step."""
        increment = error.copy()
        for j in range(len(self.b)):
            increment += self.dz_new[j]
        z_new = z + increment
        self.dz, self.h_done = self.dz_new, self.h
        self.stats["accepted"] += 1
        return z_new, (z - z_new) + increment

    def dense(self, z_old, t_old, t):
        """The collocation polynomial of the last step at t."""
        weights = integrated_basis(self.c, self.b, (t - t_old) / self.h_done) / self.b
        z = z_old.copy()
        for j in range(len(self.b)):
            z += weights[j] * self.dz[j]
        return z


def run_rk4(run: PythonRun):
    """The NumPy backend's rk4 (its record's stepper): (Y, stats), projected after every step
    where the scene has constraints."""
    if run.project is not None:
        return _rk4_projected(run)
    return integrate_rk4(run.rhs(), run.times, run.y0, run.options["step"], run.stop)


def run_gauss(run: PythonRun):
    """The NumPy backend's gauss (its record's stepper), on Hamilton's equations in (q, p)."""
    program, par = run.program, run.par
    return integrate_gauss(run.checked(lambda t, z: program.hamilton_rhs(t, z, par)),
                           lambda t, y: program.to_canonical(t, y, par),
                           lambda t, z: program.from_canonical(t, z, par),
                           run.times, run.y0, run.options["step"], int(run.options["stages"]), run.stop)


def _rk4_projected(run: PythonRun):
    """rk4 step by step, projecting onto the constraints after each step as the C driver does;
    output rows inside a step come from that step's dense output (and the stop condition's row)."""
    times, step, stop = run.times, run.options["step"], run.stop
    rows, stats, k, n, y = [run.y0], {"accepted": 0, "rejected": 0, "rhs_evals": 0}, 1, 0, run.y0
    try:
        while k < len(times):
            start, end = times[0] + n * step, min(times[0] + (n + 1) * step, times[-1])
            inside = [t for t in times[k:] if t <= end]
            grid = np.array([start, *inside] + ([] if inside and inside[-1] == end else [end]))
            try:
                Y, counts = integrate_rk4(run.rhs(), grid, y, end - start, stop)
                if stop is not None and stop.time is not None:     # the last row is at the stop time
                    inside = [*inside[:len(Y) - 2], stop.time]
                projected = [run.project(t, row) for t, row in zip(inside, Y[1:1 + len(inside)])]
                y_end = run.project(end, Y[-1])
            except IntegrationFailure as failure:       # with the rows of this run, not of the one step
                raise IntegrationFailure(str(failure), failure.t, failure.y, np.array(rows), len(rows),
                                         failure.status) from None
            except np.linalg.LinAlgError:
                raise IntegrationFailure("projection failed", start, y, np.array(rows), len(rows),
                                         PROJECTION_FAILED) from None
            rows.extend(projected)
            for key in stats:
                stats[key] += counts.get(key, 0)
            if stop is not None and stop.time is not None:
                break
            y = y_end
            k, n = k + len(inside), n + 1
    except KeyboardInterrupt:
        raise IntegrationFailure("rk4: interrupted", times[0] + n * step, y, np.array(rows),
                                 status=INTERRUPTED) from None
    return np.array(rows), stats
