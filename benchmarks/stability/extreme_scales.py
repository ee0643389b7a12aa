"""(c) Extreme mass ratios and length scales stay finite and accurate.

    python benchmarks/stability/extreme_scales.py

- The block on a moving wedge (models/wedge.lag) at M/m = 1e-8 .. 1e8: from rest both move
  with constant accelerations known in closed form; the error is the largest relative error of
  x(t) and s(t) over the scene (0.5 s, rk4 with h = 1e-3, which is exact for t^2).
- The pendulum in Cartesian coordinates with its rod as a constraint
  (models/cartesian_pendulum.lag) at rod lengths 1e-6 .. 1e6 m and masses 1e-8 .. 1e8 kg,
  released at 0.5 rad, over one period T = 4 sqrt(l/g) K(sin^2(0.25)) with dop853 and radau5
  (rtol 1e-10, atol 1e-12 l: the absolute tolerance is a length and scales with the problem):
  the error is the distance from the starting point after one period, relative to l, and the
  rod's relative length error max |x^2 + y^2 - l^2| / l^2 (the residual is projected away
  after every step, whatever the scale).
- The double pendulum (models/double_pendulum.lag) at m2/m1 = 1e-8 and 1e8, 5 s of its chaotic
  scene: finite, and the relative energy drift.
"""
from __future__ import annotations

import stabilitytools  # noqa: F401  (first: one BLAS thread)

import math
import sys

import numpy as np
from scipy.special import ellipk

import lagdsl
from stabilitytools import command_line, MODELS, markdown_table

G = 9.81


def wedge_rows():
    model = lagdsl.load(MODELS / "wedge.lag")
    rows = []
    for exponent in (-8, -4, 0, 4, 8):
        M, m, a = 10.0 ** exponent, 1.0, 0.5
        result = model.simulate("slide", M=M, m=m)
        denominator = M + m * math.sin(a) ** 2
        errors = []
        for name, acceleration in (("x", -m * G * math.sin(a) * math.cos(a) / denominator),
                                   ("s", (M + m) * G * math.sin(a) / denominator)):
            exact = acceleration / 2 * result.t ** 2
            errors.append(np.max(np.abs(result[name] - exact)) / np.max(np.abs(exact)))
        rows.append([f"1e{exponent}", f"{max(errors):.2g}"])
    return markdown_table(["M/m", "max relative error of x, s"], rows)


def pendulum_rows():
    model = lagdsl.load(MODELS / "cartesian_pendulum.lag")
    rows = []
    for integrator in ("dop853", "radau5"):
        for length in (1e-6, 1e-3, 1.0, 1e3, 1e6):
            for mass in (1e-8, 1.0, 1e8):
                period = 4 * math.sqrt(length / G) * ellipk(math.sin(0.25) ** 2)
                result = model.simulate("swing", l=length, m=mass, stop=period, interval=period / 100,
                                        integrator=integrator, rtol=1e-10, atol=1e-12 * length)
                x, y = result["x"], result["y"]
                back = math.hypot(x[-1] - x[0], y[-1] - y[0]) / length
                rod = np.max(np.abs(x ** 2 + y ** 2 - length ** 2)) / length ** 2
                rows.append([integrator, f"{length:g}", f"{mass:g}", str(result.summary.count("accepted")),
                             f"{back:.2g}", f"{rod:.2g}", str(bool(np.all(np.isfinite(result.values))))])
    return markdown_table(["integrator", "l [m]", "m [kg]", "steps", "distance from the start after T, / l",
                           "largest rod error (x²+y²-l²) / l²", "finite"], rows)


def double_pendulum_rows():
    model = lagdsl.load(MODELS / "double_pendulum.lag")
    rows = []
    for m1, m2 in ((1.0, 1e-8), (1e-8, 1.0)):
        result = model.simulate("chaos", m1=m1, m2=m2, stop=5.0)
        (_, start, drift), = result.summary.invariants
        rows.append([f"{m2 / m1:g}", str(result.summary.count("accepted")),
                     str(bool(np.all(np.isfinite(result.values)))), f"{drift / abs(start):.2g}"])
    return markdown_table(["m2/m1", "steps", "finite", "relative energy drift"], rows)


def section() -> str:
    print("extreme scales: wedge, pendulum, double pendulum", file=sys.stderr)
    return "\n".join(["### (c) Mass ratios and length scales", "",
                      "Block on a wedge, closed-form constant accelerations (rk4, h = 1e-3, 0.5 s):", "",
                      wedge_rows(), "",
                      "Cartesian pendulum over one period (rtol 1e-10, atol 1e-12 l):", "",
                      pendulum_rows(), "",
                      "Double pendulum, 5 s of the chaotic scene (dop853, rtol 1e-10):", "",
                      double_pendulum_rows()])


if __name__ == "__main__":
    sys.exit(command_line(section, __doc__))
