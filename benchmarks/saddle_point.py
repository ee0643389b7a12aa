"""The saddle-point system of a large constrained model: sparse LDLᵀ against the dense LU.

    python benchmarks/saddle_point.py [LINKS ...]        (default: 8 16 32)

A planar chain of LINKS bobs in Cartesian coordinates (models/cartesian_chain.lag for any
length): 2 LINKS coordinates and one holonomic constraint per link, so the system for
(q'', λ) has 3 LINKS unknowns. The same model is built twice, once with the sparse LDLᵀ that
lagdsl chooses from 16 unknowns on (docs/numerics.md, "The linear system in the generated code") and
once with that threshold raised so that the dense LU with partial pivoting is used. Each runs
the 10 s scene (dop853, rtol 1e-10, atol 1e-12) three times after a first, compiling run; the
best CPU time is printed with the ratio and the largest difference of the outputs (the chain is
chaotic: it grows with the length of the run, not with a fault of either solver).
"""
from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import lagdsl
from lagdsl.codegen import structure


def chain_model(links: int, directory: Path) -> Path:
    """The .lag text of a chain of `links` links in Cartesian coordinates."""
    lines = [f"model Chain{links}", f"  parameter n = {links};", "  parameter m = 1.0;", "  parameter l = 1.0;",
             "  parameter g = 9.81;", "  parameter theta0 = 0.5;",
             "  coordinate x[n](start = {i*l*sin(theta0), i in 1:n});",
             "  coordinate y[n](start = {-i*l*cos(theta0), i in 1:n});",
             "  T = sum(m/2*(der(x[i])^2 + der(y[i])^2), i in 1:n);", "  U = sum(m*g*y[i], i in 1:n);",
             "  constraint link1: x[1]^2 + y[1]^2 = l^2;"]
    lines += [f"  constraint link{i}: (x[{i}] - x[{i - 1}])^2 + (y[{i}] - y[{i - 1}])^2 = l^2;"
              for i in range(2, links + 1)]
    lines += ["  scene swing", "    time(stop = 10, interval = 0.01);",
              "    integrator dop853(rtol = 1e-10, atol = 1e-12);", "    output x[n], y[n], energy;",
              "  end swing;", f"end Chain{links};"]
    path = directory / f"chain{links}.lag"
    path.write_text("\n".join(lines) + "\n")
    return path


def best_run(path: Path, threshold: int):
    """(best CPU seconds of three runs, the last result) with SPARSE_KKT_ORDER = threshold."""
    structure.SPARSE_KKT_ORDER = threshold
    model = lagdsl.load(path)
    model.simulate()                                   # generation and compilation
    times, result = [], None
    for _ in range(3):
        started = time.process_time()
        result = model.simulate()
        times.append(time.process_time() - started)
    return min(times), result


def main(sizes: list[int]) -> None:
    default = structure.SPARSE_KKT_ORDER
    print("| links | unknowns | sparse LDLᵀ | dense LU | speed-up | max difference |")
    print("|------:|---------:|------------:|---------:|---------:|---------------:|")
    with tempfile.TemporaryDirectory() as directory:
        for links in sizes:
            path = chain_model(links, Path(directory))
            sparse, sparse_result = best_run(path, default)
            dense, dense_result = best_run(path, 10 ** 9)
            difference = np.max(np.abs(sparse_result.values - dense_result.values))
            print(f"| {links} | {3 * links} | {sparse * 1e3:.1f} ms | {dense * 1e3:.1f} ms | {dense / sparse:.1f}x "
                  f"| {difference:.1e} |", flush=True)
    structure.SPARSE_KKT_ORDER = default


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [8, 16, 32])
