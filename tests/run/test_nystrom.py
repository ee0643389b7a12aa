"""The NumPy backend's Runge-Kutta-Nystrom pair rkn8 (RKN8(6)9, lagdsl/integrators/python/nystrom.py).

- The tableau in exact rationals: the simplifying conditions, and the orders 8 and 6 measured
  in 50-digit arithmetic with a single step of the method (so the tableau is tested apart from
  the rounding of the working constants).
- rkn8.c has the same numbers: its constants, parsed from the source, against the tableau.
- integrate_rkn8 on the harmonic oscillator: accuracy at step ends and between them (the dense
  output is a side step of the method), energy drift, a stop condition, and the failures.
"""
from __future__ import annotations

import math
import re
from fractions import Fraction
from pathlib import Path

import mpmath
import numpy as np
import pytest

from lagdsl.integrators.python import nystrom
from lagdsl.integrators.python.fixed_step import NONFINITE, STEP_TOO_SMALL
from lagdsl.integrators.python.nystrom import MAX_STEPS, RKN8, IntegrationFailure, integrate_rkn8
from lagdsl.run.stop import StopCondition

RKN8_C = Path(__file__).resolve().parents[2] / "lagdsl" / "integrators" / "c" / "rkn8.c"
STAGES = range(9)


# --- (a) the tableau in exact arithmetic ----------------------------------------------------------

def test_tableau_shape():
    assert len(RKN8.c) == len(RKN8.bbar) == len(RKN8.b) == len(RKN8.e) == len(RKN8.ev) == 9
    assert all(isinstance(x, Fraction) for row in (RKN8.c, RKN8.bbar, RKN8.b, RKN8.e, RKN8.ev, *RKN8.abar)
               for x in row)
    assert RKN8.c[0] == 0 and RKN8.c[7] == RKN8.c[8] == 1
    for i in STAGES:     # explicit: strictly lower triangular
        assert all(RKN8.abar[i][j] == 0 for j in range(i, 9))
    assert tuple(RKN8.abar[8]) == tuple(RKN8.bbar), "FSAL: the last row of abar is bbar"


def test_row_sums():
    """sum_j abar_ij = c_i^2 / 2: each stage integrates q'' = const exactly."""
    for i in STAGES:
        assert sum(RKN8.abar[i]) == RKN8.c[i] ** 2 / 2, f"row {i + 1}"


def test_weights():
    assert sum(RKN8.bbar) == Fraction(1, 2)
    assert sum(RKN8.b) == 1
    for i in STAGES:
        assert RKN8.bbar[i] == RKN8.b[i] * (1 - RKN8.c[i]), f"bbar_{i + 1} = b_{i + 1} (1 - c_{i + 1})"


def test_embedded_weights():
    bbar_hat = [x - e for x, e in zip(RKN8.bbar, RKN8.e)]
    b_hat = [x - e for x, e in zip(RKN8.b, RKN8.ev)]
    assert sum(bbar_hat) == Fraction(1, 2)
    assert sum(b_hat) == 1
    assert sum(RKN8.e) == 0 and sum(RKN8.ev) == 0
    for i in STAGES:
        assert bbar_hat[i] == b_hat[i] * (1 - RKN8.c[i]), f"embedded bbar_{i + 1} = b_{i + 1} (1 - c_{i + 1})"
    assert RKN8.e[7] == RKN8.e[8] == 0, "the position estimate needs no g_8, g_9"


def test_quadrature_orders():
    """sum b_i c_i^k = 1/(k+1) and sum bbar_i c_i^k = 1/((k+1)(k+2)) up to the order: k <= 7 and
    k <= 6 for the order-8 pair, k <= 5 and k <= 4 for the embedded order-6 pair, and no further."""
    c = RKN8.c
    bbar_hat = [x - e for x, e in zip(RKN8.bbar, RKN8.e)]
    b_hat = [x - e for x, e in zip(RKN8.b, RKN8.ev)]

    def defects(weights, exact):
        return [sum(w * ci ** k for w, ci in zip(weights, c)) - exact(k) for k in range(10)]

    velocity, position = (lambda k: Fraction(1, k + 1)), (lambda k: Fraction(1, (k + 1) * (k + 2)))
    for weights, exact, highest in ((RKN8.b, velocity, 7), (RKN8.bbar, position, 6),
                                    (b_hat, velocity, 5), (bbar_hat, position, 4)):
        found = defects(weights, exact)
        assert all(d == 0 for d in found[:highest + 1]) and found[highest + 1] != 0


# --- (b) the orders, measured in 50-digit arithmetic ----------------------------------------------

def _accelerations(t, q):
    """A nonlinear, non-autonomous q'' = a(t, q) in three dimensions."""
    q1, q2, q3 = q
    return [-q1 - q1 * q2 + mpmath.sin(t) / 10,
            -q2 - q1 * q1 / 2 + q2 * q2 / 4 + q3 / 3,
            -4 * q3 + mpmath.cos(3 * t) * q1]


def _mp(x: Fraction):
    return mpmath.mpf(x.numerator) / x.denominator


def _mp_step(t, q, v, h):
    """One step of the tableau in mpmath: (q_new, v_new, err_q, err_v)."""
    c = [_mp(x) for x in RKN8.c]
    abar = [[_mp(x) for x in row] for row in RKN8.abar]
    n = len(q)
    g = [_accelerations(t, q)]
    for i in range(1, 9):
        stage = [q[k] + h * (c[i] * v[k] + h * sum(abar[i][j] * g[j][k] for j in range(i))) for k in range(n)]
        g.append(_accelerations(t + c[i] * h, stage))
    combine = lambda weights, k: sum(_mp(w) * g[j][k] for j, w in enumerate(weights) if w)  # noqa: E731
    q_new = [q[k] + h * (v[k] + h * combine(RKN8.bbar, k)) for k in range(n)]
    v_new = [v[k] + h * combine(RKN8.b, k) for k in range(n)]
    err_q = [h * h * combine(RKN8.e, k) for k in range(n)]
    err_v = [h * combine(RKN8.ev, k) for k in range(n)]
    return q_new, v_new, err_q, err_v


def _slope(hs, errors):
    return np.polyfit(np.log2(hs), np.log2(errors), 1)[0]


def test_orders_in_high_precision():
    """Local errors of one step of size h = 0.2 / 2^k against 64 steps of h/64: O(h^9) for the
    order-8 solution, O(h^7) for the embedded one (q and v each)."""
    with mpmath.workdps(50):
        t0 = mpmath.mpf("0.3")
        q0 = [mpmath.mpf("0.7"), mpmath.mpf("-0.4"), mpmath.mpf("0.25")]
        v0 = [mpmath.mpf("0.2"), mpmath.mpf("0.5"), mpmath.mpf("-0.3")]
        hs, errors = [], {key: [] for key in ("q8", "v8", "q6", "v6")}
        for k in range(4):
            h = mpmath.mpf("0.2") / 2 ** k
            q, v, err_q, err_v = _mp_step(t0, q0, v0, h)
            q_ref, v_ref = q0, v0
            for m in range(64):
                q_ref, v_ref, _, _ = _mp_step(t0 + m * h / 64, q_ref, v_ref, h / 64)
            distance = lambda x, y: float(max(abs(a - b) for a, b in zip(x, y)))  # noqa: E731
            hs.append(float(h))
            errors["q8"].append(distance(q, q_ref))
            errors["v8"].append(distance(v, v_ref))
            errors["q6"].append(distance([a - e for a, e in zip(q, err_q)], q_ref))
            errors["v6"].append(distance([a - e for a, e in zip(v, err_v)], v_ref))
    slopes = {key: _slope(hs, value) for key, value in errors.items()}
    assert 8.5 <= slopes["q8"] <= 9.5, slopes
    assert 8.5 <= slopes["v8"] <= 9.5, slopes
    assert 6.5 <= slopes["q6"] <= 7.5, slopes
    assert 6.5 <= slopes["v6"] <= 7.5, slopes


# --- (c) rkn8.c has the same numbers ----------------------------------------------------------------

CONSTANT = re.compile(r"\brkn8_(\w+)\s*=\s*(-?)\(real\)(\d+)\s*/\s*(\d+)(?:\s*([+-])\s*\(real\)(\d+)\s*/\s*(\d+))?")


def _c_constants():
    """{name: (first quotient, second quotient or None)} of every rkn8_<name> = ... in rkn8.c."""
    found = {}
    for match in CONSTANT.finditer(RKN8_C.read_text()):
        name, sign, p, q, op, p2, q2 = match.groups()
        first = Fraction(int(p), int(q)) * (-1 if sign else 1)
        second = None if op is None else Fraction(int(p2), int(q2)) * (-1 if op == "-" else 1)
        assert name not in found, f"rkn8_{name} defined twice"
        found[name] = (first, second)
    return found


def _tableau_entry(name):
    """The tableau's value of the C constant rkn8_<name>."""
    if m := re.fullmatch(r"c(\d)", name):
        return RKN8.c[int(m[1]) - 1]
    if m := re.fullmatch(r"a(\d)_(\d)", name):
        return RKN8.abar[int(m[1]) - 1][int(m[2]) - 1]
    if m := re.fullmatch(r"(bbar|b|e|ev)(\d)", name):
        return getattr(RKN8, m[1])[int(m[2]) - 1]
    raise AssertionError(f"rkn8_{name}: not a tableau entry")


def test_c_constants_are_the_tableau():
    constants = _c_constants()
    assert len(constants) > 50
    for name, (first, second) in constants.items():
        exact = first + (second or 0)
        assert exact == _tableau_entry(name), name
        if second is not None:      # e = bbar - bbar_hat, e' = b - b_hat, as published
            weights = RKN8.bbar if name.startswith("e") and not name.startswith("ev") else RKN8.b
            assert first == weights[int(name[-1]) - 1], name
    # and nothing nonzero is missing from the C code (c_8 = c_9 = 1, abar_9 = bbar are implicit)
    names = [f"c{i + 1}" for i in range(1, 7)]
    names += [f"a{i + 1}_{j + 1}" for i in range(1, 8) for j in range(i)]
    names += [f"{key}{i + 1}" for key in ("bbar", "b", "e", "ev") for i in STAGES if getattr(RKN8, key)[i] != 0]
    assert sorted(names) == sorted(constants)


def test_working_constants_round_as_c():
    """The floats of nystrom.py are the C expressions: (real)p / q rounded once, the error weights
    the difference of two rounded quotients."""
    constants = _c_constants()
    as_c = {name: float(first) + (float(second) if second is not None else 0.0)
            for name, (first, second) in constants.items()}
    for i in STAGES:
        for key, values in (("e", nystrom._E), ("ev", nystrom._EV), ("bbar", nystrom._BBAR), ("b", nystrom._B)):
            assert values[i] == as_c.get(f"{key}{i + 1}", 0.0), f"{key}{i + 1}"
        for j in range(i):
            if i < 8:
                assert nystrom._ABAR[i][j] == as_c[f"a{i + 1}_{j + 1}"]
    # not the exact difference rounded once: the two differ (e_3, e_4, e_6, e'_8), and C has the former
    assert any(x != float(exact) for x, exact in zip(nystrom._E + nystrom._EV, RKN8.e + RKN8.ev))


# --- (d) integrate_rkn8 on the harmonic oscillator --------------------------------------------------

def oscillator(t, y):
    return -y[:1]


def oscillator_rhs(t, y):
    return np.array([y[1], -y[0]])


class StepEnds:
    """A stop condition that never holds: it records the end of every accepted step."""

    def __init__(self):
        self.ends = []
        self.time = None

    def crossed(self, t_old, t, y, dense):
        self.ends.append((t, np.array(y)))
        return None


def exact(t):
    return np.stack([np.cos(t), -np.sin(t)], axis=-1)


def run_oscillator(times, stop=None, **options):
    return integrate_rkn8(oscillator, oscillator_rhs, times, np.array([1.0, 0.0]),
                          options.pop("rtol", 1e-10), options.pop("atol", 1e-12), stop=stop, **options)


def grid(t_end, dt):
    times = np.arange(0.0, t_end, dt)
    return np.append(times, t_end)


def test_oscillator_accuracy_and_dense_output():
    times = grid(10.0, 0.37)
    ends = StepEnds()
    Y, stats = run_oscillator(times, ends)
    assert Y.shape == (len(times), 2)
    row_errors = np.max(np.abs(Y - exact(times)), axis=1)
    assert np.all(row_errors <= 1e-8), row_errors.max()
    energy = 0.5 * (Y[:, 0] ** 2 + Y[:, 1] ** 2)
    assert np.max(np.abs(energy - 0.5)) <= 1e-9
    # the rows between step ends are as accurate as the step ends around them
    t_end = np.array([t for t, _ in ends.ends])
    end_errors = np.array([np.max(np.abs(y - exact(t))) for t, y in ends.ends])
    assert t_end[-1] == 10.0 and np.all(np.diff(t_end) > 0)
    dense = 0
    for t, error in zip(times[1:], row_errors[1:]):
        k = np.searchsorted(t_end, t)
        if t_end[k] != t:
            dense += 1
            around = max(end_errors[k], end_errors[k - 1] if k > 0 else 0.0)
            assert error <= 2 * around + 1e-14, (t, error, around)
    assert dense >= len(times) - 3
    # work: 2 evaluations to start, 8 per trial, 7 per row between step ends
    assert stats["accepted"] == len(ends.ends) and stats["accepted"] >= 10
    assert stats["rhs_evals"] == 2 + 8 * (stats["accepted"] + stats["rejected"]) + 7 * dense
    # the steps do not depend on the output grid
    other = StepEnds()
    run_oscillator(grid(10.0, 0.05), other)
    assert [t for t, _ in other.ends] == list(t_end)
    assert all(np.array_equal(y, z) for (_, y), (_, z) in zip(ends.ends, other.ends))


def test_oscillator_max_step_and_tolerance():
    times = np.array([0.0, 10.0])
    ends = StepEnds()
    run_oscillator(times, ends, max_step=0.25)
    assert np.all(np.diff([0.0] + [t for t, _ in ends.ends]) <= 0.25)
    Y_loose, loose = run_oscillator(times, rtol=1e-5, atol=1e-7)
    Y_tight, tight = run_oscillator(times)
    assert loose["accepted"] < tight["accepted"]
    assert np.max(np.abs(Y_tight[-1] - exact(10.0))) < np.max(np.abs(Y_loose[-1] - exact(10.0))) < 1e-4


def test_stop_condition():
    """stop when q < 0: the last row is at pi/2, to the integrator's accuracy."""
    times = grid(10.0, 0.37)
    stop = StopCondition(lambda t, y: float(y[0]))
    assert not stop.holds_at_start(0.0, np.array([1.0, 0.0]))
    Y, _ = run_oscillator(times, stop)
    assert stop.time == pytest.approx(math.pi / 2, abs=1e-9)
    assert len(Y) == np.sum(times < stop.time) + 1
    assert abs(Y[-1, 0]) < 1e-9


# --- (e) failures --------------------------------------------------------------------------------------

def test_nonfinite_accelerations_fail_with_the_rows_before():
    def broken(t, y):
        return np.array([np.nan]) if t > 1 else -y[:1]

    def broken_rhs(t, y):
        return np.concatenate([y[1:], broken(t, y)])

    times = grid(3.0, 0.1)
    clean, _ = run_oscillator(times)
    with pytest.raises(IntegrationFailure) as info:
        integrate_rkn8(broken, broken_rhs, times, np.array([1.0, 0.0]), 1e-10, 1e-12)
    failure = info.value
    assert failure.status in (NONFINITE, STEP_TOO_SMALL)
    assert failure.t <= 1.0 and np.all(np.isfinite(failure.y))
    before = int(np.sum(times < 0.95))
    assert failure.completed == len(failure.Y) >= before
    assert np.array_equal(failure.Y[:before], clean[:before])
    assert np.all(times[:failure.completed] <= failure.t)


def test_max_steps():
    with pytest.raises(IntegrationFailure) as info:
        run_oscillator(grid(10.0, 0.37), max_steps=5)
    assert info.value.status == MAX_STEPS == 4
    assert info.value.t < 10.0
    assert info.value.completed == len(info.value.Y) >= 1


def test_singular_start():
    def singular(t, y):
        raise np.linalg.LinAlgError("singular")

    with pytest.raises(IntegrationFailure) as info:
        integrate_rkn8(singular, singular, [0.0, 1.0], np.array([1.0, 0.0]), 1e-8, 1e-10)
    assert info.value.status == 1 and info.value.t == 0.0 and len(info.value.Y) == 1
