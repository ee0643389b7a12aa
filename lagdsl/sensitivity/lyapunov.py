"""Lyapunov exponents from the generated variational equations (Benettin's method).

A tangent vector v carried by the motion y(t) obeys the variational equations

    v' = ∂f/∂y (y(t), t) v,        y = (q, q'),  f = (q', q''(q, q', t)),

which are the forward sensitivities' equations (variational.py) without the parameters' forcing:
K (Sq'', Sλ) = Dq Sq + Dv Sv with the generated Jacobian blocks, never finite differences. The
exponents are the growth rates of k tangent vectors V = (v_1 ... v_k):

    λ_i = lim_{T→∞} (1/T) Σ_j log |R_ii^(j)|,   V(t_j) = Q_j R_j (QR),  V ← Q_j,

re-orthonormalised at a fixed interval τ (t_j = t_0 + j τ) before the vectors grow too long or
collapse onto the most unstable direction (G. Benettin, L. Galgani, A. Giorgilli, J.-M.
Strelcyn, Meccanica 15, 9-30, 1980; the method of docs/numerics.md). One vector (k = 1) gives the
largest exponent (QR is then a renormalisation to length 1), k = 2n the whole spectrum
(fewer with constraints, below).
The exponents are in 1/s: time is in seconds everywhere in lagdsl. Each exponent's record
Σ_j log|R_ii^(j)| against t_j is also fitted as a + b log t + λ t (growth.py), which tells
exponential from algebraic growth where the finite-time value decays only as log(T)/T.

The growth is measured in canonical coordinates (q, p), p = ∂L/∂q' (tangent.py's `Canonical`),
from the frame (e_q1 .. e_qn, e_pn .. e_p1), vector 2n+1-i being J times vector i. A Hamiltonian
flow (energy conserved: conservative, unforced, time-independent; no active constraint) is
symplectic in (q, p), and the QR factors of a symplectic map Φ from such a frame pair exactly at
every T: the unit normal to the span of Φ v_1 .. Φ v_2n-1 is J Φ v_1/|Φ v_1| (as Φᵀ J Φ = J),
so R_2n,2n = |v_1ᵀ J v_2n|/R_11 = 1/R_11, and so on inwards. So λ_i + λ_{2n+1-i} = 0 to the
integration's error, and on a bounded motion the flow's own direction and the energy's gradient
make the middle pair vanish in the limit (as 1/T): the report prints both.

A constrained model's vectors live in the tangent space of its constraint manifold, which has
2n - h - m dimensions (h holonomic rows among m), and are measured in (q, q') (tangent.py's
`OnConstraints`); the state and the vectors are projected onto the manifold and its tangent space
at each t_j. On the C backend the scene's C integrator carries them (tangent_solvers.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import LagError, Setting, SimulationError
from .growth import MIN_POINTS, Growth, growth_fits
from .tangent import Canonical, OnConstraints
from .tangent_solvers import solver_for
from .variational import VariationalSystem, named_state

DEFAULT_RENORMALISATION = 1.0           # s: the interval τ between two re-orthonormalisations
UNIT = "1/s"


@dataclass(frozen=True)
class HamiltonianCheck:
    """The symplectic structure seen in a spectrum (sorted descending): λ_i + λ_{2n+1-i} for
    i = 1..n, and the two exponents nearest zero (λ_n, λ_{n+1})."""

    pair_sums: tuple[float, ...]
    vanishing: tuple[float, float]

    @property
    def deviation(self) -> float:
        """The largest of |pair sum| and |vanishing exponent|."""
        return float(max(np.max(np.abs(self.pair_sums)), np.max(np.abs(self.vanishing))))


@dataclass(frozen=True)
class Spectrum:
    """Lyapunov exponents (in the order of the QR factors: descending once converged, in 1/s), the
    running estimates `running[j]` at the re-orthonormalisation times `times[j]`, the fit of each
    exponent's growth that separates exponential from algebraic growth (growth.py; None for a
    record too short), and the Hamiltonian check (None when the model is not Hamiltonian or only
    the largest was computed)."""

    title: str
    start: float
    exponents: tuple[float, ...]
    times: np.ndarray
    running: np.ndarray
    interval: float
    solver: str
    growth: tuple[Growth, ...] | None
    hamiltonian: HamiltonianCheck | None

    @property
    def largest(self) -> float:
        return max(self.exponents)

    def render(self) -> str:
        lines = [f"Lyapunov exponents of {self.title}: {self.times[-1] - self.start:g} s, re-orthonormalised "
                 f"every {self.interval:g} s, {self.solver}"]
        lines += [f"  lambda_{i} = {value: .6e} {UNIT}" for i, value in enumerate(self.exponents, 1)]
        lines += self._growth_lines()
        if self.hamiltonian is not None:
            check = self.hamiltonian
            k = len(self.exponents)
            lines.append("Hamiltonian (energy conserved): the pairs sum to zero, and on a bounded motion two "
                         "exponents vanish")
            lines += [f"  lambda_{i} + lambda_{k + 1 - i} = {value: .3e} {UNIT}"
                      for i, value in enumerate(check.pair_sums, 1)]
            lines.append(f"  the two nearest zero: {check.vanishing[0]: .3e}, {check.vanishing[1]: .3e} {UNIT}")
            lines.append(f"  largest deviation {check.deviation:.3e} {UNIT} (the pairs sum to zero to the "
                         "integration's error; the two nearest zero shrink as 1/T)")
        return "\n".join(lines) + "\n"

    def _growth_lines(self) -> list[str]:
        if self.growth is None:
            return [f"growth not fitted: fewer than {MIN_POINTS} re-orthonormalisations after the first tenth "
                    "of the run (shorten --renormalise)"]
        window = self.growth[0].window
        lines = [f"growth fitted as log|v| = a + b log t + lambda t over t = {window[0]:g} .. {window[1]:g} s "
                 f"from the start ({self.growth[0].points} points; the finite-time value tends to lambda only as "
                 "log(t)/t where |v| grows as a power of t):"]
        return lines + [f"  lambda_{i}: {fit.describe()}" for i, fit in enumerate(self.growth, 1)]

    def to_csv(self) -> str:
        """The convergence record: t, then each exponent's running estimate."""
        header = ",".join(["t [s]", *(f"lambda_{i} [{UNIT}]" for i in range(1, len(self.exponents) + 1))])
        rows = (",".join(f"{value:.17g}" for value in (t, *estimate)) for t, estimate in zip(self.times, self.running))
        return header + "\n" + "".join(row + "\n" for row in rows)


def lyapunov(model, program, plan, all: bool = False, renormalise: float | None = None,
             progress=None, backend: str = "numpy") -> Spectrum:
    """The largest exponent, or with `all` the whole spectrum, of `plan` (a scene.ScenePlan of
    `model`, an api.Model) over the scene's time span, with the generated functions of `program`
    (sensitivity.run.build), integrated on `backend` ("numpy" or "c", tangent_solvers.py);
    `progress(t reached, start, stop)` is called at every t_j."""
    if plan.stop is not None:
        raise LagError("lyapunov: the scene ends on a condition (`stop when`); the exponents need a fixed "
                       "stop time (give --stop, or choose a scene without a stop condition)", Setting("--scene"))
    start, stop = float(plan.time.start), float(plan.time.stop)     # the plan has checked start < stop
    interval = _interval(renormalise, stop - start)
    n = len(plan.coordinates)
    par = np.array(plan.parameters, dtype=float)
    constrained = bool(model.equations.active_constraints)
    measure = OnConstraints(model, plan, program.module, par) if constrained else Canonical(model, plan)
    y0, _ = measure.settle(start, np.array(plan.initial_state, dtype=float), np.zeros((2 * n, 0)))
    frame = measure.frame(y0, start, all)
    system = VariationalSystem(program.module, par, np.zeros((len(par), frame.shape[1])), n)
    solver = solver_for(backend, program, plan, system)
    times, sums, states, frames = _benettin(system, solver, measure, y0, frame, (start, stop, interval), progress)
    running = measure.estimates(times, sums, states, frames, start)
    exponents = tuple(float(value) for value in running[-1])
    hamiltonian = _hamiltonian_check(exponents) if all and _is_hamiltonian(model) else None
    return Spectrum(f"{model.name}, scene {plan.scene_name}", start, exponents, times, running, interval,
                    solver.describe(), growth_fits(times - start, running), hamiltonian)


def _interval(renormalise: float | None, span: float) -> float:
    interval = DEFAULT_RENORMALISATION if renormalise is None else float(renormalise)
    if not (np.isfinite(interval) and interval > 0):
        raise LagError(f"lyapunov: the re-orthonormalisation interval must be a positive number of seconds, "
                       f"got {interval:g}", Setting("--renormalise"))
    return min(interval, span)


def _benettin(system: VariationalSystem, solver, measure, y0: np.ndarray, frame: np.ndarray,
              grid: tuple[float, float, float], progress) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The module docstring's method in the coordinates (q, q') the equations are integrated in,
    from the frame V(t_0) = `frame`, advanced by `solver` (tangent_solvers.py) and settled by
    `measure` at each t_j (tangent.py: onto the constraints, if any): the times t_j, the sums
    Σ log|R_ii| up to each, and the state y(t_j) and orthonormal frame Q_j there (for the change
    to (q, p)); `grid` is (start, stop, τ)."""
    start, stop, interval = grid
    steps = int(np.ceil((stop - start) / interval * (1 - 1e-12)))
    times = np.minimum(start + interval * np.arange(1, steps + 1), stop)
    sums = np.zeros((steps, frame.shape[1]))
    states, frames = np.empty((steps, y0.size)), np.empty((steps, *frame.shape))
    Y, t, total = np.concatenate([y0, frame.ravel()]), start, np.zeros(frame.shape[1])
    for j, t_next in enumerate(times):
        Y = solver.advance(t, t_next, Y)
        y, V = measure.settle(t_next, *system.split(Y))
        Q, R = np.linalg.qr(V)
        growth = np.abs(np.diag(R))
        if not np.all(np.isfinite(growth) & (growth > 0)):
            raise SimulationError("the tangent vectors became degenerate (a growth factor is zero or not "
                                  "finite)", float(t_next), named_state(system.module, y),
                                  "shorten the re-orthonormalisation interval (--renormalise)")
        total += np.log(growth)
        sums[j], states[j], frames[j] = total, y, Q
        Y, t = np.concatenate([y, Q.ravel()]), t_next
        if progress is not None:
            progress(t, start, stop)
    return times, sums, states, frames


def _is_hamiltonian(model) -> bool:
    """Energy conserved (∂L/∂t = 0, no forces, no dissipation) and no active constraint."""
    return not model.equations.active_constraints and any(c.name == "energy" for c in model.equations.conserved)


def _hamiltonian_check(exponents: tuple[float, ...]) -> HamiltonianCheck:
    ordered = sorted(exponents, reverse=True)
    k = len(ordered)
    pairs = tuple(ordered[i] + ordered[k - 1 - i] for i in range(k // 2))
    middle = k // 2
    return HamiltonianCheck(pairs, (ordered[middle - 1], ordered[middle]))
