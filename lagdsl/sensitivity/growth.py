"""How a tangent vector grows: exponentially, algebraically or not at all (sensitivity/lyapunov.py).

The finite-time exponent λ(T) = G(T)/T, G(t) = Σ_j log|R_ii^(j)| the logarithm of the growth up
to t, tends to λ only as log(T)/T when the tangent vectors grow as a power of t: on an
integrable motion whose frequencies depend on the actions (Kepler: the period depends on the
energy), a neighbouring motion drifts along the torus in proportion to t, so |v| ~ t and
λ(T) ~ log(T)/T, 6.6e-3 1/s after 1000 s for Kepler's ellipse. Growth of the form

    G(t) = a + b log t + λ t        (t from the start of the run)

covers the three cases a tangent vector of a smooth flow has: bounded (b = λ = 0: an isochronous
motion, the harmonic oscillator), algebraic (|v| ~ t^b, b = 1 for a shear) and exponential (λ ≠ 0,
chaos). Least squares on the record G(t_j), t_j >= T/10 (the first tenth is left to the
vectors' alignment with the most unstable direction, which takes a few 1/(λ_1 - λ_2)), gives b
and λ with their standard errors. The fit is linear in G, so the pairs of a Hamiltonian spectrum,
whose records sum to zero at every t_j, give fitted rates that sum to zero as well.

Standard errors. The residuals e_j of G about the fit are not independent: a quasi-periodic
motion makes them oscillate with its frequencies, a chaotic one correlates them over a few
Lyapunov times, so the ordinary least-squares errors would be too small (for Kepler's record, by
a factor 1.6). The covariance of the coefficients is Newey and West's (Econometrica 55, 703-708,
1987), which holds for residuals correlated over a finite range:

    cov = B⁻¹ S B⁻¹ n/(n - 3),   B = XᵀX,   S = Σ_{|l| <= L} (1 - |l|/(L + 1)) Σ_j x_j e_j e_{j-l} x_{j-l}ᵀ,

x_j = (1, log t_j, t_j) the rows of the design X, with the bandwidth L = ⌈n^(1/3)⌉ lags, the rate
at which the Bartlett weights make S consistent (D. W. K. Andrews, Econometrica 59, 817-858, 1991).

Growth type: exponential when |λ| exceeds SIGNIFICANCE standard errors and the exponential term
makes at least one e-fold over the window, |λ| (t_1 - t_0) > 1; else algebraic when |b| exceeds
SIGNIFICANCE standard errors; else bounded. The e-fold is the resolution of a finite run: a
smaller exponential term changes G by less than the power law's own corrections do (log t
changes by log 10 over the window), so the two forms are not told apart by the fit's statistics,
which assume the form is right. (Hénon-Heiles' regular orbit over 500 s fits λ = -2.5e-4 ± 6e-5
1/s beside b = 1.12: 4 standard errors, but 0.11 e-folds.)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FIT_FROM = 0.1          # the fit starts at this fraction of the run (the alignment transient before)
SIGNIFICANCE = 3.0      # standard errors a rate or a power must exceed to count
MIN_POINTS = 5          # three coefficients, and residuals enough for their covariance


@dataclass(frozen=True)
class Growth:
    """The fit G(t) = a + b log t + λ t of one exponent's record: λ (`rate`, 1/s) and b (`power`)
    with their standard errors, over `window` (s from the start) with `points` points."""

    rate: float
    rate_error: float
    power: float
    power_error: float
    window: tuple[float, float]
    points: int

    @property
    def kind(self) -> str:
        if abs(self.rate) > SIGNIFICANCE * self.rate_error and abs(self.rate) * (self.window[1] - self.window[0]) > 1:
            return "exponential"
        if abs(self.power) > SIGNIFICANCE * self.power_error:
            return "algebraic"
        return "bounded"

    def describe(self) -> str:
        text = f"rate {self.rate: .3e} +- {self.rate_error:.1e} 1/s, power of t {self.power: .3f} +- " \
               f"{self.power_error:.3f}: {self.kind}"
        return text + (f" (|v| ~ t^{self.power:.2f})" if self.kind == "algebraic" else "")


def growth_fits(elapsed: np.ndarray, running: np.ndarray) -> tuple[Growth, ...] | None:
    """The fit of each exponent's record (columns of `running`, the estimates G/t at the times
    `elapsed` since the start), or None when the window holds fewer than MIN_POINTS points."""
    keep = elapsed >= FIT_FROM * elapsed[-1]
    t = elapsed[keep]
    if len(t) < MIN_POINTS:
        return None
    design = np.column_stack([np.ones_like(t), np.log(t), t])
    fits = []
    for record in (running[keep] * t[:, None]).T:
        coefficients, *_ = np.linalg.lstsq(design, record, rcond=None)
        errors = np.sqrt(np.diag(_newey_west(design, record - design @ coefficients)))
        fits.append(Growth(float(coefficients[2]), float(errors[2]), float(coefficients[1]), float(errors[1]),
                           (float(t[0]), float(t[-1])), len(t)))
    return tuple(fits)


def _newey_west(design: np.ndarray, residuals: np.ndarray) -> np.ndarray:
    """The coefficients' covariance for correlated residuals (module docstring)."""
    n, k = design.shape
    scores = design * residuals[:, None]
    S = scores.T @ scores
    lags = int(np.ceil(n ** (1 / 3)))
    for lag in range(1, min(lags, n - 1) + 1):
        product = scores[lag:].T @ scores[:-lag]
        S += (1 - lag / (lags + 1)) * (product + product.T)
    bread = np.linalg.inv(design.T @ design)
    return bread @ S @ bread * n / (n - k)
