"""Parameters fitted to measured data by nonlinear least squares, the sensitivities as Jacobian.

With data d_i (a column c_i at a time t_i) and σ_i their standard deviations, the fit minimizes

    cost = ½ Σ r_i²,   r_i = (h_{c_i}(t_i; θ) - d_i) / σ_i,

by scipy.optimize.least_squares (trust region reflective, bounds allowed), whose Jacobian
J_ij = ∂h_{c_i}(t_i)/∂θ_j / σ_i is the forward sensitivities of one run (sensitivity/run.py):
one model run gives the residuals and J together, no finite differences.

At the minimum the covariance of θ is estimated as cov = s² (JᵀJ)⁻¹ with the residual variance
s² = 2 cost / (N - P) (N residuals, P parameters), so that a σ known only up to a factor still
gives sound standard errors: stderr_j = √cov_jj, correlation_jk = cov_jk / (stderr_j stderr_k).
(JᵀJ)⁻¹ comes from the singular values of J; a direction J does not see has an infinite error.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np
import scipy.optimize

from ..errors import LagError, Setting, SimulationError
from ..scene import input_units
from ..given_values import InSI, input_in_si
from ..settings import Overrides, given_atol_each, given_options
from .data import read_data
from .run import directions


@dataclass(frozen=True)
class Fit:
    """The fitted values and their standard errors (by name), the correlation matrix (in the
    order of `names`), the residuals (a table: t, then model - data per column), the fitted
    model on the same rows (`fitted`), the final cost ½ Σ r², and `nfev`, the number of model runs."""

    names: tuple[str, ...]
    values: dict[str, float]
    stderr: dict[str, float]
    correlation: np.ndarray
    residuals: dict[str, np.ndarray]
    fitted: dict[str, np.ndarray]
    cost: float
    nfev: int
    success: bool
    message: str

    def to_json(self) -> str:
        return json.dumps({"values": self.values, "stderr": self.stderr, "names": list(self.names),
                           "correlation": self.correlation.tolist(), "cost": self.cost, "nfev": self.nfev,
                           "success": self.success, "message": self.message}, indent=2, allow_nan=True) + "\n"

    def render(self) -> str:
        """The values ± their standard errors, the correlations (with two or more), the cost."""
        lines = [f"{name} = {self.values[name]:.10g} ± {self.stderr[name]:.3g}" for name in self.names]
        if len(self.names) > 1:
            width = max(len(name) for name in self.names)
            lines.append("correlation:")
            lines += [f"  {name:>{width}} " + " ".join(f"{value:7.3f}" for value in row)
                      for name, row in zip(self.names, self.correlation)]
        lines.append(f"cost {self.cost:.6g} after {self.nfev} model runs: {self.message}")
        return "\n".join(lines)


def fit(model, data, params: dict, outputs=None, sigma=None, scene: str | None = None,
        bounds: dict | None = None, set: dict | None = None, integrator: str | None = None,
        options: dict | None = None, backend: str = "numpy") -> Fit:
    """Fit `params` ({name: start value}: parameters or "q.start", "q.velocity") of `model` (an
    api.Model) so that its `outputs` (default: the data's columns) match `data` (see data.py);
    `set` holds other parameters fixed (numbers, or texts with a unit that scene.plan_scene
    converts: "30 deg"), `bounds` maps a name to (low, high), `sigma` is one number or
    {column: number} (default 1); `integrator` and `options` (rtol, atol, ...) override the
    scene's; `backend` ("numpy" or "c") runs the model."""
    names = directions(model.ir, tuple(params), "--fit").names
    base = Overrides(tuple((set or {}).items()), integrator=integrator, options=given_options(options or {}),
                     atol_each=given_atol_each(options or {}))
    plan = model.plan(scene, base)
    measured = read_data(data, plan.columns, model.name)
    columns = _chosen_columns(measured.columns, outputs)
    times, rows = np.unique(measured.t, return_inverse=True)
    if times[0] < plan.time.start:
        raise LagError(f"the data start at t = {times[0]:g}, before the scene's start {plan.time.start:g}",
                       Setting("data"))
    picked = [measured.columns.index(c) for c in columns]
    scale = _sigma(sigma, columns)
    target = measured.values[:, picked]
    runs = _Runs(model, (scene, backend), names, base, times, rows, [plan.columns.index(c) for c in columns])

    def residuals(x):
        values, _ = runs.at(x)
        return ((values - target) / scale).ravel()

    def jacobian(x):
        _, derivatives = runs.at(x)
        return (derivatives / scale[None, :, None]).reshape(-1, len(names))

    declared = dict(input_units(model.ir))
    low, high = _bounds(names, bounds or {}, declared)
    start = np.array([input_in_si(name, params[name], declared.get(name)) for name in names])
    solution = scipy.optimize.least_squares(residuals, np.clip(start, low, high), jac=jacobian, bounds=(low, high),
                                            x_scale="jac")
    return _result(names, solution, runs, target, measured.t, columns)


class _Runs:
    """One model run per parameter vector, kept for the residuals and the Jacobian at it."""

    def __init__(self, model, where: tuple[str | None, str], names, base: Overrides, times, rows, columns):
        self.model, self.names, self.base = model, names, base
        self.scene, self.backend = where
        self.times, self.rows, self.columns = times, rows, columns
        self.count, self.last = 0, None

    def at(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.last is None or not np.array_equal(self.last[0], x):
            values = {**dict(self.base.values), **{name: InSI(value) for name, value in zip(self.names, x)}}
            overrides = replace(self.base, values=tuple(values.items()),
                                stop=float(self.times[-1]))
            try:
                result = self.model.sensitivities(self.scene, self.backend, overrides, self.names, self.times)
            except SimulationError as error:
                trial = ", ".join(f"{name} = {value:.10g}" for name, value in zip(self.names, x))
                raise SimulationError(f"{error.message}, in the fit's run at {trial}", error.time, error.state,
                                      f"{error.remedy}; or keep the values in range (bounds, --bound)") from None
            self.count += 1
            self.last = (np.array(x), result.values[self.rows][:, self.columns],
                         result.derivatives[self.rows][:, self.columns])
        return self.last[1], self.last[2]


def _chosen_columns(measured: tuple[str, ...], outputs) -> tuple[str, ...]:
    if outputs is None:
        return measured
    missing = [c for c in outputs if c not in measured]
    if missing:
        raise LagError(f"output '{missing[0]}' has no column in the data (columns: {', '.join(measured)})",
                       Setting("--output"))
    return tuple(outputs)


def _sigma(sigma, columns) -> np.ndarray:
    """One standard deviation per fitted column: `sigma` a number, {column: number} or None (1)."""
    if isinstance(sigma, dict):
        unknown = [c for c in sigma if c not in columns]
        if unknown:
            raise LagError(f"sigma given for '{unknown[0]}', which is not fitted (fitted: {', '.join(columns)})",
                           Setting("--sigma"))
        values = [sigma.get(c, 1.0) for c in columns]
    else:
        values = [1.0 if sigma is None else sigma] * len(columns)
    scale = np.array(values, dtype=float)
    if not np.all(np.isfinite(scale) & (scale > 0)):
        raise LagError("sigma must be positive and finite", Setting("--sigma"))
    return scale


def _bounds(names, bounds: dict, declared: dict) -> tuple[np.ndarray, np.ndarray]:
    """The bounds of each fitted value in SI (given in its declared unit, as its start value)."""
    unknown = [name for name in bounds if name not in names]
    if unknown:
        raise LagError(f"bounds given for '{unknown[0]}', which is not fitted (fitted: {', '.join(names)})",
                       Setting("--bounds"))
    low, high = (np.array([input_in_si(n, bounds.get(n, (-np.inf, np.inf))[end], declared.get(n)) for n in names])
                 for end in (0, 1))
    if np.any(low >= high):
        raise LagError("each bound needs low < high", Setting("--bounds"))
    return low, high


def _result(names, solution, runs: _Runs, target, times, columns) -> Fit:
    J = solution.jac
    dof = J.shape[0] - J.shape[1]
    variance = 2 * solution.cost / dof if dof > 0 else np.nan
    _, singular, Vt = np.linalg.svd(J, full_matrices=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        covariance = (Vt.T / singular**2) @ Vt * variance
        stderr = np.sqrt(np.diag(covariance))
        correlation = covariance / np.outer(stderr, stderr)
    values, _ = runs.at(solution.x)
    table = {"t": times, **{c: values[:, k] - target[:, k] for k, c in enumerate(columns)}}
    fitted = {"t": times, **{c: values[:, k] for k, c in enumerate(columns)}}
    return Fit(names, {n: float(v) for n, v in zip(names, solution.x)},
               {n: float(s) for n, s in zip(names, stderr)}, correlation, table, fitted, float(solution.cost),
               runs.count, bool(solution.success), str(solution.message))
