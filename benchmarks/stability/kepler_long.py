"""(b) Kepler, eccentricity 0.6, over 10^4 orbits: the symplectic gauss method keeps the energy
error bounded; explicit methods drift.

    python benchmarks/stability/kepler_long.py [--orbits 10000]

models/kepler.lag (G M = 1, m = 1) started at perihelion r = 1 with theta' = sqrt(1 + e): an
ellipse with a = 1/(1 - e) = 2.5 and period 2 pi a^(3/2) = 24.8. Each method runs the whole
span once, with an output row every tenth of a period; the relative energy error
|E(t) - E(0)| / |E(0)| is compared in the first and the last tenth of the run, and its growth is
fitted by a straight line (error per orbit) over the whole run.
"""
from __future__ import annotations

import stabilitytools  # noqa: F401  (first: one BLAS thread)

import math
import sys

import numpy as np

import lagdsl
from stabilitytools import command_line, MODELS, lagdsl_seconds, markdown_table, pyplot, save

ECCENTRICITY = 0.6
PERIOD = 2 * math.pi * (1 / (1 - ECCENTRICITY)) ** 1.5
RUNS = [  # label, scene, options
    ("gauss, 3 stages, h = 0.05", "symplectic", dict(step=0.05)),
    ("dop853, rtol 1e-8", "ellipse", dict(rtol=1e-8, atol=1e-10)),
    ("dop853, rtol 1e-10", "ellipse", dict(rtol=1e-10, atol=1e-12)),
    ("dopri5, rtol 1e-8", "ellipse", dict(integrator="dopri5", rtol=1e-8, atol=1e-10)),
]


def run(scene, orbits, options):
    return lagdsl.load(MODELS / "kepler.lag").simulate(
        scene, set={"theta.velocity": math.sqrt(1 + ECCENTRICITY)}, stop=orbits * PERIOD,
        interval=PERIOD / 10, **options)


def section(orbits=10000) -> str:
    plt = pyplot()
    figure, axes = plt.subplots(figsize=(8, 4.5))
    rows = []
    for label, scene, options in RUNS:
        print(f"kepler: {label}, {orbits} orbits", file=sys.stderr)
        result = run(scene, orbits, options)
        energy = result["energy"]
        error = np.abs(energy - energy[0]) / abs(energy[0])
        tenth = len(error) // 10
        slope = np.polyfit(result.t / PERIOD, error, 1)[0]
        rows.append([label, str(result.summary.count("accepted")), f"{lagdsl_seconds(result):.3g} s",
                     f"{error[:tenth].max():.2g}", f"{error[-tenth:].max():.2g}", f"{slope:.2g}"])
        axes.loglog(result.t[1:] / PERIOD, np.maximum(error[1:], 1e-17), label=label, linewidth=0.7)
    axes.set_xlabel("orbits")
    axes.set_ylabel("|E - E(0)| / |E(0)|")
    axes.set_title(f"Kepler, e = {ECCENTRICITY}: relative energy error")
    axes.legend()
    image = save(figure, "kepler_energy")
    table = markdown_table(["method", "steps", "time", "max error, first tenth", "max error, last tenth",
                            "fitted growth per orbit"], rows)
    return "\n".join([f"### (b) Kepler, e = {ECCENTRICITY}, {orbits} orbits", "", table, "", image])


if __name__ == "__main__":
    sys.exit(command_line(section, __doc__, orbits=10000))
