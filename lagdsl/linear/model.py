"""LinearModel: the matrices of a linearization, their names, and what is done with them."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg


@dataclass(frozen=True)
class Structure:
    """What is known of M and K beyond their entries: M diagonal, K banded (half-bandwidth)."""

    diagonal_mass: bool = False
    bandwidth: int | None = None


@dataclass(frozen=True)
class LinearModel:
    """M δq'' + (D + G) δq' + (K + N) δq = Bq δu, and x' = A x + B u, y = C x + Dm u
    (linear/linearize.py has the formulas), in SI units.

    Without constraints, or with holonomic ones about an equilibrium at rest, x = (δq, δq') in the
    independent `coordinates`, and both forms are given. Otherwise (nonholonomic constraints, a
    constrained model moving) x holds the independent entries of the state, named in `states`
    (`q` or `q.velocity`), and only the first-order form is: M, D, G, K, N and Bq are None.
    `basis` maps x to the whole state (q, q') of the model (None without constraints: x is the
    state); `eliminated` are the coordinates the constraints expressed through the others.
    `point` is the state the model is about ({"q": value, "q.velocity": value}), `output_values`
    the outputs there.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    Dm: np.ndarray
    coordinates: tuple[str, ...]
    states: tuple[str, ...]
    eliminated: tuple[str, ...]
    basis: np.ndarray | None
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    output_values: np.ndarray
    point: dict[str, float]
    parameters: dict[str, float]
    time: float
    structure: Structure = field(default_factory=Structure)
    M: np.ndarray | None = None
    D: np.ndarray | None = None
    G: np.ndarray | None = None
    K: np.ndarray | None = None
    N: np.ndarray | None = None
    Bq: np.ndarray | None = None

    @classmethod
    def from_second_order(cls, mass, damping, stiffness, Bq, C, Dm, **names) -> "LinearModel":
        """Split the velocity and position coefficients into symmetric and skew parts and form
        the first-order A, B (M⁻¹ applied by a division where M is diagonal, else by a Cholesky
        solve, or LU where M is not definite)."""
        n = len(mass)
        solve = _mass_solver(mass)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -solve(stiffness) + 0.0        # + 0.0: no -0 in the files written
        A[n:, n:] = -solve(damping) + 0.0
        B = np.vstack([np.zeros_like(Bq), solve(Bq)])
        states = (*names["coordinates"], *(f"{q}.velocity" for q in names["coordinates"]))
        return cls(A, B, C, Dm, states=states, **names, M=(mass + mass.T) / 2, D=(damping + damping.T) / 2,
                   G=(damping - damping.T) / 2, K=(stiffness + stiffness.T) / 2, N=(stiffness - stiffness.T) / 2,
                   Bq=Bq)

    @property
    def all_coordinates(self) -> tuple[str, ...]:
        """Every coordinate of the model, in its order."""
        return tuple(self.point)[:len(self.point) // 2]

    def modes(self, tolerance: float | None = None):
        """The modes (linear/modes.py): a pandas DataFrame when pandas is installed, else a
        list of dicts, one row per mode, with the columns of `lagc modes -o`."""
        from .modes import DEFAULT_TOLERANCE, analyse, table
        return table(analyse(self, DEFAULT_TOLERANCE if tolerance is None else tolerance))

    def to_control(self):
        """The first-order model as a python-control StateSpace (needs the `control` package:
        pip install "lagdsl[control]"), with the state, input and output names."""
        try:
            import control
        except ImportError:
            raise ImportError("to_control() needs the python-control package: pip install control") from None
        B = self.B if self.inputs else np.zeros((len(self.A), 0))
        C = self.C if self.outputs else np.zeros((0, len(self.A)))
        return control.ss(self.A, B, C, self.Dm.reshape(len(C), B.shape[1]), states=list(self.states),
                          inputs=list(self.inputs), outputs=list(self.outputs))


def _mass_solver(mass: np.ndarray):
    """X -> M⁻¹ X: a division where M is diagonal (a chain of point masses), else by one
    factorisation of M (which, in LAPACK, also starts its threads: a quarter second)."""
    diagonal = np.diag(mass)
    if np.all(diagonal != 0) and np.count_nonzero(mass) == np.count_nonzero(diagonal):
        return lambda X: X / diagonal.reshape(-1, *(1,) * (np.ndim(X) - 1))
    try:
        factor = scipy.linalg.cho_factor(mass)
        return lambda X: scipy.linalg.cho_solve(factor, X)
    except np.linalg.LinAlgError:
        factor = scipy.linalg.lu_factor(mass)
        return lambda X: scipy.linalg.lu_solve(factor, X)
