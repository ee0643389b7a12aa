"""Results of a run: the table of outputs, the run summary, and writing them safely."""
from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..escape import csv_field
from ..integrators import COUNTER_LABELS


@dataclass(frozen=True)
class RunSummary:
    """What the run cost and how well it kept its invariants and constraints."""

    backend: str
    integrator: str
    counters: tuple[tuple[str, int], ...]               # the work the integrator counts (accepted, ...)
    wall_time: float                                    # seconds, the integration alone
    invariants: tuple[tuple[str, float, float], ...]    # name, initial value, max |drift|
    constraints: tuple[str, ...]
    residual_max: float | None
    projection_start: float | None                      # how far the initial state was projected

    def count(self, counter: str) -> int | None:
        """A work counter ("accepted", "rhs_evals", ...), None when the integrator does not keep it."""
        return dict(self.counters).get(counter)

    def render(self) -> str:
        counts = [f"{value} {COUNTER_LABELS[name]}" for name, value in self.counters]
        lines = [f"integrator {self.integrator} ({self.backend}): " + ", ".join(counts)
                 + f", {self.wall_time:.3g} s"]
        for name, start, drift in self.invariants:
            relative = f", relative {drift / abs(start):.3g}" if start != 0 else ""
            lines.append(f"drift of {name}: {drift:.3g} (from {start:.17g}{relative})")
        if self.constraints:
            lines.append(f"largest constraint residual ({', '.join(self.constraints)}): {self.residual_max:.3g}")
            if self.projection_start:
                lines.append(f"the initial state was moved by {self.projection_start:.3g} onto the constraints")
        return "\n".join(lines)


@dataclass(frozen=True)
class Result:
    """Output times `t`, the named columns, and the summary. `result["theta1"]` is a column."""

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray            # shape (len(t), len(columns))
    summary: RunSummary

    def __getitem__(self, column: str) -> np.ndarray:
        if column == "t":
            return self.t
        try:
            return self.values[:, self.columns.index(column)]
        except ValueError:
            raise KeyError(f"no column '{column}' (columns: {', '.join(self.columns)})") from None

    def csv(self) -> str:
        """The header `t,<columns>` (RFC 4180 fields) and one row per output time.

        Numbers are written as C's printf("%.17g") writes a double, so that `lagc run`,
        `to_csv` and the standalone C program write the same bytes: 17 significant digits
        (they read back to the same double), no trailing zeros, `-0`, `inf`, `-inf`, `nan`.
        """
        buffer = io.StringIO()
        buffer.write(",".join(csv_field(name) for name in ("t", *self.columns)) + "\n")
        for time, row in zip(self.t, self.values):
            buffer.write(",".join(format(float(x), ".17g") for x in (time, *row)) + "\n")
        return buffer.getvalue()

    def to_csv(self, path: str | os.PathLike) -> None:
        write_atomically(Path(path), self.csv())


def write_atomically(path: Path, text: str) -> None:
    """Write to a temporary file beside `path` and rename it: readers never see half a file."""
    partial = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        partial.write_text(text, encoding="utf-8")
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
