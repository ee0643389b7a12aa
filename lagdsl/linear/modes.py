"""Modes of a linear model: eigenvalues s, frequencies, damping ratios, shapes and verdicts.

A mode δq = Re(φ e^{st}) has the natural frequency ω = |s| (rad/s; ω/2π in Hz), the damping
ratio ζ = -Re(s)/|s| and the growth rate Re(s). Which eigenproblem:

- no damping, no gyroscopic and no circulatory term (D = G = N = 0): the symmetric definite
  (K - ω² M) φ = 0, by scipy.linalg.eigh; s = ±iω for ω² > 0, ±√(-ω²) for ω² < 0. With a
  diagonal M and a banded K (the structure codegen/structure.py found for the generated code)
  it is the banded symmetric M^-1/2 K M^-1/2, by scipy.linalg.eig_banded, O(n b) storage.
- otherwise the first-order pencil [[0, I], [-(K + N), -(D + G)]] - s [[I, 0], [0, M]], by
  scipy.linalg.eig; one mode per complex-conjugate pair (the one with Im s > 0), one per real s.
- a model given in first-order form only (nonholonomic constraints, a constrained model moving):
  the eigenvalues of A, by scipy.linalg.eig, likewise.

The verdict of a mode, with ρ the largest |s| of the model and τ the tolerance:
unstable if Re s > τ max(ρ, 1/s), stable (asymptotically) if Re s < -τ max(ρ, 1/s), marginally
stable otherwise: purely imaginary to the tolerance, as undamped and gyroscopically stabilised
oscillations are, or zero, as a free (cyclic) coordinate is. The model's verdict is its worst
mode's. Shapes are in every coordinate of the model (δq_all = P φ), scaled so that the entry of
largest modulus is 1 (in that coordinate's unit).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

DEFAULT_TOLERANCE = 1e-9
VERDICTS = ("stable", "marginally stable", "unstable")
SYMMETRIC_TOLERANCE = 1e-14     # D, G, N count as zero below this times the largest entry of K and M


@dataclass(frozen=True)
class Mode:
    s: complex
    shape: np.ndarray               # complex, one entry per coordinate of the model
    verdict: str

    @property
    def omega(self) -> float:
        return abs(self.s)

    @property
    def frequency_hz(self) -> float:
        return abs(self.s) / (2 * np.pi)

    @property
    def damping_ratio(self) -> float:
        return -self.s.real / abs(self.s) if self.s != 0 else 0.0


@dataclass(frozen=True)
class Modes:
    modes: tuple[Mode, ...]
    coordinates: tuple[str, ...]    # every coordinate of the model (the shapes' entries)
    verdict: str
    tolerance: float                # τ: relative, in units of max(ρ, 1/s)
    method: str                     # which eigensolver


def analyse(linear, tolerance: float = DEFAULT_TOLERANCE) -> Modes:
    """The modes of `linear` (a LinearModel), ordered by frequency."""
    if linear.M is None:
        s, vectors = scipy.linalg.eig(linear.A)
        keep = s.imag >= 0
        s, vectors, method = s[keep], vectors[:, keep], "eig (the first-order A on the constraints' tangent space)"
    elif _is_symmetric(linear):
        values, vectors, method = _symmetric(linear)
        s = np.where(values >= 0, 1j * np.sqrt(np.abs(values)), np.sqrt(np.abs(values)) + 0j)
    else:
        s, vectors, method = _general(linear)
    shapes = _coordinate_shapes(linear, vectors)
    scale = tolerance * max(np.max(np.abs(s), initial=0.0), 1.0)
    modes = [Mode(complex(value), _normalised(shape), _verdict(value.real, scale))
             for value, shape in zip(s, shapes.T)]
    modes.sort(key=lambda m: (m.omega, -m.s.real))
    worst = max((VERDICTS.index(m.verdict) for m in modes), default=0)
    return Modes(tuple(modes), linear.all_coordinates, VERDICTS[worst], tolerance, method)


def _coordinate_shapes(linear, vectors: np.ndarray) -> np.ndarray:
    """Eigenvectors (columns: the independent coordinates, or the linear state) as displacements
    of every coordinate of the model (the state basis, then its coordinate rows)."""
    n = len(linear.all_coordinates)
    if linear.basis is None:
        return vectors[:n]
    if len(vectors) < linear.basis.shape[1]:        # coordinates only: the symmetric problem
        vectors = np.vstack([vectors, np.zeros_like(vectors)])
    return (linear.basis @ vectors)[:n]


def _verdict(real: float, scale: float) -> str:
    return "unstable" if real > scale else "stable" if real < -scale else "marginally stable"


def _is_symmetric(linear) -> bool:
    size = max(np.max(np.abs(linear.K), initial=0.0), np.max(np.abs(linear.M), initial=0.0))
    return all(np.max(np.abs(X), initial=0.0) <= SYMMETRIC_TOLERANCE * size for X in (linear.D, linear.G, linear.N))


def _symmetric(linear) -> tuple[np.ndarray, np.ndarray, str]:
    """ω² and the M-orthonormal shapes of (K - ω² M) φ = 0."""
    band = linear.structure.bandwidth
    n = len(linear.M)
    if linear.structure.diagonal_mass and band is not None and band < n - 1:
        root = 1 / np.sqrt(np.diag(linear.M))
        scaled = linear.K * root[:, None] * root[None, :]
        lower = np.array([np.concatenate([np.diag(scaled, -d), np.zeros(d)]) for d in range(band + 1)])
        values, vectors = scipy.linalg.eig_banded(lower, lower=True)
        return values, vectors * root[:, None], f"eig_banded (M diagonal, K banded, half-bandwidth {band})"
    values, vectors = scipy.linalg.eigh(linear.K, linear.M)
    return values, vectors, "eigh (symmetric definite: no damping, gyroscopic or circulatory term)"


def _general(linear) -> tuple[np.ndarray, np.ndarray, str]:
    """Eigenvalues of the first-order pencil, one per mode (see the module docstring)."""
    n = len(linear.M)
    identity = np.eye(n)
    left = np.block([[np.zeros((n, n)), identity], [-(linear.K + linear.N), -(linear.D + linear.G)]])
    right = np.block([[identity, np.zeros((n, n))], [np.zeros((n, n)), linear.M]])
    values, vectors = scipy.linalg.eig(left, right)
    keep = values.imag >= 0
    return values[keep], vectors[:, keep], "eig (first-order pencil: damping, gyroscopic or circulatory terms)"


TIED = 1e-9      # entries within this relative distance of the largest modulus count as equal


def _normalised(shape: np.ndarray) -> np.ndarray:
    """The shape divided by its entry of largest modulus (which becomes 1); among entries as
    large to TIED, the first: a symmetric shape (sin(3 pi i / (N + 1)) peaks at +1 and -1 alike)
    then gets the same sign whatever the eigensolver's rounding."""
    shape = np.asarray(shape, dtype=complex)
    magnitude = np.abs(shape)
    if not len(shape) or magnitude.max() == 0:
        return shape
    return shape / shape[np.flatnonzero(magnitude >= magnitude.max() * (1 - TIED))[0]]


def rows(modes: Modes) -> tuple[list[str], list[list]]:
    """The header and columns of the modes table (`lagc modes -o`): mode, real, imag, omega,
    frequency_hz, damping_ratio, verdict, then each coordinate's amplitude (signed: the real part
    of the normalised shape) and, when a shape is complex, each coordinate's phase in degrees."""
    shapes = np.array([m.shape for m in modes.modes]).reshape(len(modes.modes), len(modes.coordinates))
    header = ["mode", "real", "imag", "omega", "frequency_hz", "damping_ratio", "verdict", *modes.coordinates]
    columns = [list(range(1, len(modes.modes) + 1)), [m.s.real for m in modes.modes],
               [m.s.imag for m in modes.modes], [m.omega for m in modes.modes],
               [m.frequency_hz for m in modes.modes], [m.damping_ratio for m in modes.modes],
               [m.verdict for m in modes.modes], *(np.abs(shapes) * np.sign(shapes.real + (shapes.real == 0))).T]
    if np.any(np.abs(shapes.imag) > 1e-12):
        header += [f"{q}.phase_deg" for q in modes.coordinates]
        columns += list(np.degrees(np.angle(shapes)).T)
    return header, [list(column) for column in columns]


def table(modes: Modes):
    """The rows of `rows` as a pandas DataFrame, or a list of dicts without pandas."""
    header, columns = rows(modes)
    records = [dict(zip(header, values)) for values in zip(*columns)]
    try:
        import pandas
    except ImportError:
        return records
    return pandas.DataFrame(records, columns=header)
