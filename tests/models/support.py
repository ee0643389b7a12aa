"""Helpers of the model tests: one loaded model per library file (so each scene compiles once
for the whole session), the time of a periodic signal, and the check of a normal mode."""
from __future__ import annotations

import numpy as np
import sympy

from lagdsl.run.output import Result
from tests.conftest import library_model


model = library_model


def run(name: str, scene: str | None = None, **options) -> Result:
    """A scene of a library model; `options` are simulate()'s (parameters, "q.start", grid)."""
    values = {key: value for key, value in options.items() if "." in key}
    rest = {key: value for key, value in options.items() if "." not in key}
    return model(name).simulate(scene, set=values, **rest)


def invariant(result: Result, name: str) -> tuple[float, float]:
    """I(0) and max |I(t) - I(0)| of a conserved quantity that lagc found."""
    return {found: (start, worst) for found, start, worst in result.summary.invariants}[name]


def drift(result: Result, name: str) -> float:
    """max |I(t) - I(0)| of a conserved quantity found by lagc, relative to max(1, |I(0)|)."""
    start, worst = invariant(result, name)
    return worst / max(1.0, abs(start))


def crossings(t: np.ndarray, signal: np.ndarray) -> np.ndarray:
    """The times where `signal` changes sign, by linear interpolation between rows."""
    i = np.nonzero(np.sign(signal[:-1]) * np.sign(signal[1:]) < 0)[0]
    return t[i] - signal[i] * (t[i + 1] - t[i]) / (signal[i + 1] - signal[i])


def period(t: np.ndarray, signal: np.ndarray) -> float:
    """The mean period of an oscillation, from its crossings of the middle of its range in one
    direction (an oscillation that is not symmetric about that level, as in an anharmonic
    potential, crosses it at unequal half-periods)."""
    upward = crossings(t, signal - (signal.max() + signal.min()) / 2)[::2]
    return (upward[-1] - upward[0]) / (len(upward) - 1)


def mode_error(result: Result, names: list[str], shape: np.ndarray, omega: float) -> float:
    """How far q(t) is from shape cos(omega t), relative to the amplitude."""
    expected = np.outer(np.cos(omega * result.t), shape)
    actual = np.column_stack([result[name] for name in names])
    return float(np.max(np.abs(actual - expected)) / np.max(np.abs(shape)))


def chain_modes(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Small oscillations of n equal point masses on equal links, absolute angles: mass
    matrix m l^2 (n + 1 - max(i, j)), stiffness m g l diag(n + 1 - i). Returns omega^2 in units
    of g/l, ascending, and the mode shapes as columns (first entry 1)."""
    index = np.arange(1, n + 1)
    mass = (n + 1 - np.maximum.outer(index, index)).astype(float)
    stiffness = np.diag((n + 1 - index).astype(float))
    squares, shapes = np.linalg.eig(np.linalg.solve(mass, stiffness))
    order = np.argsort(squares.real)
    shapes = shapes.real[:, order]
    return squares.real[order], shapes / shapes[0]


def gimbal_rows(s: dict) -> list:
    """The closed-form rows M q'' - f of models/gimbal_gyroscope.lag (its header), in the symbols
    `s` of tests.mechanics.eom.symbols_of."""
    Jo, Ai, Bi, Ci, A, C, m, l, g = (s[n] for n in ("Jo", "Ai", "Bi", "Ci", "A", "C", "m", "l", "g"))
    sin, cos = sympy.sin(s["theta"]), sympy.cos(s["theta"])
    wphi, wtheta, wpsi = s["phi'"], s["theta'"], s["psi'"]
    aphi, atheta, apsi = s["phi''"], s["theta''"], s["psi''"]
    unbalance = A + Bi - C - Ci
    return [(Jo + (A + Bi) * sin**2 + (C + Ci) * cos**2) * aphi + C * cos * apsi
            - wtheta * sin * (C * wpsi - 2 * unbalance * wphi * cos),
            (A + Ai) * atheta - wphi * sin * (unbalance * wphi * cos - C * wpsi) - m * g * l * sin,
            C * cos * aphi + C * apsi - C * wphi * wtheta * sin]
