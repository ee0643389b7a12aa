"""(d) The stiff Fermi-Pasta-Ulam chain keeps its total oscillatory energy to O(1/omega).

    python benchmarks/stability/fpu_adiabatic.py [--stop 1000]

models/fermi_pasta_ulam.lag (Hairer, Lubich, Wanner, GNI I.5: three stiff springs of frequency
omega, start I = 1 in the first). For omega = 25 .. 200 with dop853 at rtol 1e-10, atol 1e-12
(accurate: it follows the exact solution), the largest deviation max |I(t) - 1| over the run,
times omega, which stays about constant if the deviation is O(1/omega); and at omega = 50 the
same run with other integrators: gauss (symplectic) with h omega = 0.5 and 1.5, and radau5 at
rtol 1e-6 (at this tolerance it has to resolve the stiff oscillation, so its L-stable damping,
which would remove oscillatory energy, does not come into play).
"""
from __future__ import annotations

import stabilitytools  # noqa: F401  (first: one BLAS thread)

import sys

import numpy as np

import lagdsl
from stabilitytools import command_line, MODELS, lagdsl_seconds, markdown_table, pyplot, save

OMEGAS = (25.0, 50.0, 100.0, 200.0)
AT_50 = [  # label, options
    ("dop853, rtol 1e-10", dict(rtol=1e-10, atol=1e-12)),
    ("gauss, 2 stages, h = 0.01 (h omega = 0.5)", dict(integrator="gauss", step=0.01, stages=2)),
    ("gauss, 2 stages, h = 0.03 (h omega = 1.5)", dict(integrator="gauss", step=0.03, stages=2)),
    ("radau5, rtol 1e-6", dict(integrator="radau5", rtol=1e-6, atol=1e-8)),
]


def run(omega, stop, **options):
    return lagdsl.load(MODELS / "fermi_pasta_ulam.lag").simulate("exchange", omega=omega, stop=stop,
                                                                 interval=0.1, **options)


def energy_drift(result) -> float:
    (_, start, drift), = result.summary.invariants
    return drift / abs(start)


def section(stop=1000.0) -> str:
    plt = pyplot()
    rows = []
    for omega in OMEGAS:
        print(f"fpu: omega {omega:g}, {stop:g} s", file=sys.stderr)
        result = run(omega, stop, rtol=1e-10, atol=1e-12)
        deviation = np.max(np.abs(result["I"] - 1))
        rows.append([f"{omega:g}", str(result.summary.count("accepted")), f"{lagdsl_seconds(result):.3g} s",
                     f"{deviation:.3g}", f"{deviation * omega:.2f}", f"{energy_drift(result):.2g}"])
    scan = markdown_table(["omega", "steps", "time", "max abs(I - 1)", "omega max abs(I - 1)",
                           "relative energy drift"], rows)

    figure, (exchange, totals) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    rows = []
    for label, options in AT_50:
        print(f"fpu: omega 50, {label}", file=sys.stderr)
        result = run(50.0, stop, **options)
        if label.startswith("dop853"):
            for name in ("I1", "I2", "I3"):
                exchange.plot(result.t, result[name], label=name, linewidth=0.7)
        totals.plot(result.t, result["I"], label=label, linewidth=0.7)
        rows.append([label, str(result.summary.count("accepted")), f"{lagdsl_seconds(result):.3g} s",
                     f"{np.max(np.abs(result['I'] - 1)):.3g}", f"{result['I'][-1]:.3g}",
                     f"{energy_drift(result):.2g}"])
    exchange.set_title("omega = 50, dop853: the oscillatory energies of the three stiff springs")
    exchange.legend()
    totals.set_title("their sum I, an adiabatic invariant, by integrator")
    totals.set_xlabel("t")
    totals.legend(fontsize="small")
    image = save(figure, "fpu_oscillatory_energy")
    methods = markdown_table(["integrator", "steps", "time", "max abs(I - 1)", "I at the end",
                              "relative energy drift"], rows)
    return "\n".join([f"### (d) Stiff FPU chain, t = 0 .. {stop:g}", "",
                      "dop853 (rtol 1e-10) at growing omega:", "", scan, "",
                      "omega = 50, by integrator:", "", methods, "", image])


if __name__ == "__main__":
    sys.exit(command_line(section, __doc__, stop=1000.0))
