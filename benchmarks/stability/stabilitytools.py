"""Shared by the stability benchmarks: the path to benchmarks/benchtools.py (one core, CPU time,
Markdown tables), where the plots go, and matplotlib, which lagdsl does not depend on.

Import this module first (before NumPy): benchtools fixes the BLAS thread count to one.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import benchtools  # noqa: E402,F401  (one BLAS thread before NumPy is imported)
from benchtools import MODELS, cpu_seconds, markdown_table, pin_to_one_core  # noqa: E402,F401


def pyplot():
    """matplotlib.pyplot with a non-interactive backend. matplotlib is not a dependency of
    lagdsl: `pip install matplotlib` to draw the figures."""
    try:
        import matplotlib
    except ImportError:
        raise SystemExit("these benchmarks draw figures with matplotlib: pip install matplotlib") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def save(figure, name: str) -> str:
    """Write the figure to benchmarks/stability/NAME.png and return the Markdown image link."""
    figure.tight_layout()
    figure.savefig(HERE / f"{name}.png", dpi=110)
    return f"![{name}]({name}.png)"


def lagdsl_seconds(result) -> float:
    """lagdsl's own measurement of a run: the integration and the output rows (wall clock
    around the call into the compiled library; compiling is cached and not counted)."""
    return result.summary.wall_time


def command_line(section, doc: str, argv=None, **options) -> int:
    """The `main` of a benchmark script: parse --OPTION VALUE for each keyword (its default also
    gives its type), pin to one core, print the Markdown section that `section(**values)` returns."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    for name, default in options.items():
        parser.add_argument("--" + name.replace("_", "-"), type=type(default), default=default)
    values = vars(parser.parse_args(argv))
    pin_to_one_core()
    print(section(**values))
    return 0
