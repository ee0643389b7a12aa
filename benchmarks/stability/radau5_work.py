"""radau5's work as the elastic pendulum stiffens, k = 1e2 .. 1e12.

    python benchmarks/stability/radau5_work.py

models/elastic_pendulum.lag, scene `stiff` (10 s, rtol 1e-6, atol 1e-9) at each k: accepted and
rejected steps, right-hand sides, Jacobians and LU decompositions of lagdsl's radau5, and the
same counts of SciPy's Radau on the same equations (lagdsl's time: best of 3) (hand-written, analytic Jacobian, same
tolerances). Once the spring's vibration is too fast for the tolerance to follow (k >= 1e6),
the work no longer depends on k.
"""
from __future__ import annotations

import stabilitytools  # noqa: F401  (first: one BLAS thread)

import functools
import math
import sys

from scipy.integrate import solve_ivp

import lagdsl
from stabilitytools import command_line, MODELS, markdown_table
from stiff_speed import SPRING, spring_jacobian, spring_rhs


def section() -> str:
    model = lagdsl.load(MODELS / "elastic_pendulum.lag")
    rows = []
    for exponent in range(2, 13):
        k = 10.0 ** exponent
        print(f"radau5 work: k = {k:g}", file=sys.stderr)
        result = min((model.simulate("stiff", k=k) for _ in range(3)), key=lambda r: r.summary.wall_time)
        s = result.summary
        start = [SPRING["m"] * SPRING["g"] * math.cos(SPRING["phi0"]) / k, SPRING["phi0"], 0.0, 0.0]
        scipy = solve_ivp(functools.partial(spring_rhs, k=k), (0.0, 10.0), start, method="Radau",
                          jac=functools.partial(spring_jacobian, k=k), rtol=1e-6, atol=1e-9)
        counts = [str(s.count(name)) for name in ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps")]
        rows.append([f"1e{exponent}", *counts, f"{s.wall_time * 1e3:.3g} ms",
                     str(scipy.nfev), str(scipy.njev), str(scipy.nlu)])
    return markdown_table(["k [N/m]", "steps", "rejected", "f evals", "Jacobians", "LU", "time",
                           "SciPy Radau: f evals", "Jacobians", "LU"], rows)


if __name__ == "__main__":
    sys.exit(command_line(section, __doc__))
