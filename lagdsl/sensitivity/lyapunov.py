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
largest exponent (QR is then a renormalisation to length 1), k = 2n the whole spectrum.
The exponents are in 1/s: time is in seconds everywhere in lagdsl. Each exponent's record
Σ_j log|R_ii^(j)| against t_j is also fitted as a + b log t + λ t (growth.py), which tells
exponential from algebraic growth where the finite-time value decays only as log(T)/T.

The growth is measured in canonical coordinates (q, p), p = ∂L/∂q' (`Legendre`,
`_canonical_estimates`), from the frame (e_q1 .. e_qn, e_pn .. e_p1), vector 2n+1-i being J times
vector i. A Hamiltonian flow (energy conserved: conservative, unforced, time-independent; no
active constraint) is symplectic in (q, p), and the QR factors of a symplectic map Φ from such a
frame pair exactly at every T: the unit normal to the span of Φ v_1 .. Φ v_2n-1 is
J Φ v_1/|Φ v_1| (as Φᵀ J Φ = J), so R_2n,2n = |v_1ᵀ J v_2n|/R_11 = 1/R_11, and so on inwards.
So λ_i + λ_{2n+1-i} = 0 to the integration's error, and on a bounded motion the flow's own
direction and the energy's gradient make the middle pair vanish in the limit (as 1/T): the report
prints both.

Constrained models are refused: their tangent vectors would have to stay on the constraint
manifold's tangent space, and the spectrum would have 2(n - m) exponents; that is not built.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.integrate
import sympy

from .. import ir
from ..errors import LagError, Setting, SimulationError
from ..integrators import registry
from ..mechanics.families import expanded
from ..mechanics.probe import evaluate_at, to_float
from .growth import MIN_POINTS, Growth, growth_fits
from .variational import VariationalSystem

DEFAULT_RENORMALISATION = 1.0           # s: the interval τ between two re-orthonormalisations
FALLBACK_INTEGRATOR = "dop853"          # for a scene whose integrator has no error control (gauss, rk4)
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
             progress=None) -> Spectrum:
    """The largest exponent, or with `all` the whole spectrum, of `plan` (a scene.ScenePlan of
    `model`, an api.Model) over the scene's time span, with the generated functions of `program`
    (sensitivity.run.build); `progress(t reached, start, stop)` is called at every t_j."""
    _check_model(model, plan)
    start, stop = float(plan.time.start), float(plan.time.stop)     # the plan has checked start < stop
    interval = _interval(renormalise, stop - start)
    n = len(plan.coordinates)
    par = np.array(plan.parameters, dtype=float)
    count = 2 * n if all else 1
    system = VariationalSystem(program.module, par, np.zeros((len(par), count)), n)
    solver = _Solver.of(plan, system)
    legendre = Legendre(model, plan)
    y0 = np.array(plan.initial_state, dtype=float)
    canonical_frame = _lagrangian_frame(n) if all else np.full((2 * n, 1), 1 / np.sqrt(2 * n))
    frame = np.linalg.solve(legendre.at(y0[None], np.array([start]))[0], canonical_frame)
    times, sums, states, frames = _benettin(system, solver, y0, frame, (start, stop, interval), progress)
    running = _canonical_estimates(legendre, times, sums, states, frames, start)
    exponents = tuple(float(value) for value in running[-1])
    hamiltonian = _hamiltonian_check(exponents) if all and _is_hamiltonian(model) else None
    return Spectrum(f"{model.name}, scene {plan.scene_name}", start, exponents, times, running, interval,
                    solver.describe(), growth_fits(times - start, running), hamiltonian)


class Legendre:
    """L(y, t) = ∂(q, p)/∂(q, q') = [[I, 0], [∂p/∂q, ∂p/∂q']], p = ∂L/∂q' (the momenta of the
    derived equations), evaluated from the symbolic equations at the plan's parameters."""

    def __init__(self, model, plan):
        equations = expanded(model.equations)
        self.calculus = equations.calculus()
        state = (*equations.coordinates, *equations.velocities)
        self.n = equations.size
        self.entries = [self.calculus.partial(p, x) if x in self.calculus.dependencies(p) else sympy.S.Zero
                        for p in equations.momenta for x in state]
        self.symbols = (*state, ir.TIME, *(p.symbol for p in model.ir.parameters))
        self.parameters = tuple(plan.parameters)

    def at(self, states: np.ndarray, times: np.ndarray) -> np.ndarray:
        """L at each (state, time): shape (points, 2n, 2n). Entries that are structurally zero are
        not evaluated, those that depend on neither state nor time once (a chain's ∂p/∂q' = M is
        constant, its ∂p/∂q zero: evaluating them at every point took a minute for 200 masses)."""
        n = self.n
        points = [(*y, t, *self.parameters) for y, t in zip(states, times)]
        lower = np.zeros((len(points), n * 2 * n))
        moving = set(self.symbols[:2 * n + 1])
        varying = [i for i, e in enumerate(self.entries) if e != 0 and self.calculus.dependencies(e) & moving]
        fixed = [i for i, e in enumerate(self.entries) if e != 0 and i not in varying]
        for indices, where in ((varying, points), (fixed, points[:1])):
            values = evaluate_at(self.calculus, [self.entries[i] for i in indices], self.symbols, where)
            lower[:, indices] = [[to_float(x) for x in row] for row in values]
        maps = np.zeros((len(points), 2 * n, 2 * n))
        maps[:, :n, :n] = np.eye(n)
        maps[:, n:, :] = lower.reshape(len(points), n, 2 * n)
        return maps


def _lagrangian_frame(n: int) -> np.ndarray:
    """The canonical frame (e_q1 .. e_qn, e_pn .. e_p1): vector 2n+1-i is J e_i up to sign, the
    ordering under which the QR factors of a symplectic map pair exactly (module docstring)."""
    return np.eye(2 * n)[:, [*range(n), *range(2 * n - 1, n - 1, -1)]]


def _canonical_estimates(legendre: Legendre, times, sums, states, frames, start: float) -> np.ndarray:
    """The running estimates measured in (q, p): the QR chain in (q, q') ends at V = Q_j R, and
    L(y_j) Q_j = Q' R' completes it to the QR factors of the tangent map in (q, p), whose diagonal
    is the product of the two."""
    maps = legendre.at(states, times)
    closing = np.array([np.abs(np.diag(np.linalg.qr(L @ Q, mode="r"))) for L, Q in zip(maps, frames)])
    return (sums + np.log(closing)) / (times - start)[:, None]


def _check_model(model, plan) -> None:
    """Refuse what the method does not cover: constraints, a stop condition (a model without
    coordinates is refused when its equations are derived)."""
    active = model.equations.active_constraints
    if active:
        span = next((c.span for c in model.ir.constraints if c.name == active[0].name), None)
        raise LagError(f"lyapunov: constraint '{active[0].name}' is active; Lyapunov exponents are computed "
                       "for unconstrained models only (write the model in independent coordinates)", span)
    if plan.stop is not None:
        raise LagError("lyapunov: the scene ends on a condition (`stop when`); the exponents need a fixed "
                       "stop time (give --stop, or choose a scene without a stop condition)", Setting("--scene"))


def _interval(renormalise: float | None, span: float) -> float:
    interval = DEFAULT_RENORMALISATION if renormalise is None else float(renormalise)
    if not (np.isfinite(interval) and interval > 0):
        raise LagError(f"lyapunov: the re-orthonormalisation interval must be a positive number of seconds, "
                       f"got {interval:g}", Setting("--renormalise"))
    return min(interval, span)


def _benettin(system: VariationalSystem, solver: "_Solver", y0: np.ndarray, frame: np.ndarray,
              grid: tuple[float, float, float], progress) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The module docstring's method in the coordinates (q, q') the equations are integrated in,
    from the frame V(t_0) = `frame`: the times t_j, the sums Σ log|R_ii| up to each, and the
    state y(t_j) and orthonormal frame Q_j there (for the change to (q, p), `_canonical_estimates`);
    `grid` is (start, stop, τ)."""
    start, stop, interval = grid
    steps = int(np.ceil((stop - start) / interval * (1 - 1e-12)))
    times = np.minimum(start + interval * np.arange(1, steps + 1), stop)
    sums = np.zeros((steps, frame.shape[1]))
    states, frames = np.empty((steps, y0.size)), np.empty((steps, *frame.shape))
    Y, t, total = np.concatenate([y0, frame.ravel()]), start, np.zeros(frame.shape[1])
    for j, t_next in enumerate(times):
        Y = solver.advance(t, t_next, Y)
        y, V = system.split(Y)
        Q, R = np.linalg.qr(V)
        growth = np.abs(np.diag(R))
        if not np.all(np.isfinite(growth) & (growth > 0)):
            raise SimulationError("the tangent vectors became degenerate (a growth factor is zero or not "
                                  "finite)", float(t_next), _named(system, y),
                                  "shorten the re-orthonormalisation interval (--renormalise)")
        total += np.log(growth)
        sums[j], states[j], frames[j] = total, y, Q
        Y, t = np.concatenate([y, Q.ravel()]), t_next
        if progress is not None:
            progress(t, start, stop)
    return times, sums, states, frames


class _Solver:
    """scipy's solver standing for the scene's integrator (dop853 if it has no error control),
    restarted at each re-orthonormalisation with the step size it had reached."""

    def __init__(self, system: VariationalSystem, name: str, method: str, options: dict, implicit: bool,
                 instead_of: str | None = None):
        self.system, self.name, self.method = system, name, getattr(scipy.integrate, method)
        self.instead_of = instead_of        # the scene's integrator, when it has no error control
        self.rtol, self.atol = float(options["rtol"]), float(options["atol"])
        self.max_step = float(options.get("max_step", np.inf))
        self.extra = {"jac": system.newton_matrix} if implicit else {}
        self.step: float | None = None

    @classmethod
    def of(cls, plan, system: VariationalSystem) -> "_Solver":
        record = registry.get(plan.integrator.name)
        options, instead_of = dict(plan.integrator.options), None
        if record.scipy is None or record.fixed_step:
            record, instead_of = registry.get(FALLBACK_INTEGRATOR), record.name
            options = {k: v for k, v in options.items() if k in record.options}
        return cls(system, record.name, record.scipy, {**dict(record.defaults), **options}, record.implicit,
                   instead_of)

    def describe(self) -> str:
        replaced = f", in place of the scene's {self.instead_of}, which has no error control" if self.instead_of else ""
        return f"{self.name} (scipy {self.method.__name__}, rtol {self.rtol:g}, atol {self.atol:g}{replaced})"

    def advance(self, t: float, t_next: float, Y: np.ndarray) -> np.ndarray:
        """Y at t_next from Y at t; SimulationError naming where the integration failed."""
        first = self.step if self.step is not None and self.step < t_next - t else None
        solver = self.method(self.system.rhs, t, Y, t_next, rtol=self.rtol, atol=self.atol,
                             max_step=self.max_step, first_step=first, **self.extra)
        while solver.status == "running":
            try:
                message = solver.step()
            except np.linalg.LinAlgError:
                message = "the mass matrix is singular"
            if solver.status == "failed" or message is not None:
                y, _ = self.system.split(solver.y)
                raise SimulationError(f"the variational equations' integration failed ({message})",
                                      float(solver.t), _named(self.system, y),
                                      "lower rtol, or choose radau5 for a stiff model")
            if solver.t < t_next:       # the last step is cut short to land on t_next: not kept
                self.step = solver.step_size
        return solver.y


def _named(system: VariationalSystem, y: np.ndarray) -> dict[str, float]:
    names = system.module.COORDINATES
    n = len(names)
    return {**{q: float(y[k]) for k, q in enumerate(names)},
            **{q + ".velocity": float(y[n + k]) for k, q in enumerate(names)}}


def _is_hamiltonian(model) -> bool:
    """Energy conserved (∂L/∂t = 0, no forces, no dissipation) and no active constraint."""
    return not model.equations.active_constraints and any(c.name == "energy" for c in model.equations.conserved)


def _hamiltonian_check(exponents: tuple[float, ...]) -> HamiltonianCheck:
    ordered = sorted(exponents, reverse=True)
    k = len(ordered)
    pairs = tuple(ordered[i] + ordered[k - 1 - i] for i in range(k // 2))
    middle = k // 2
    return HamiltonianCheck(pairs, (ordered[middle - 1], ordered[middle]))
