"""Measured data for a fit: a `t` column and columns named as the scene's outputs.

Read from a CSV file (a header `t,x,...`, optionally with units `t [s]`, as `lagc run` writes
them) or from a table in memory (a pandas DataFrame or a mapping of names to 1-D arrays). Rows
need not be on the scene's grid, nor sorted. Every value must be a finite number: a bad cell of
a CSV file is reported at its line and column.
"""
from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import LagError, Setting, suggest
from ..source import SourceFile, Span

UNIT_SUFFIX = re.compile(r"\s*\[[^\]]*\]\s*$")      # "x [m]" is the column x


@dataclass(frozen=True)
class Data:
    """Measured values (rows x columns) at times t (sorted)."""

    t: np.ndarray
    columns: tuple[str, ...]
    values: np.ndarray


def read_data(data, outputs: tuple[str, ...], model_name: str) -> Data:
    """`data` (a CSV path, a DataFrame or a mapping) checked against the scene's `outputs`."""
    if isinstance(data, (str, Path)):
        return _sorted(*_read_csv(SourceFile.read(data), outputs, model_name))
    columns = [str(name) for name in getattr(data, "columns", data)]
    where = Setting("data")
    _check_names(columns, outputs, model_name, [where] * len(columns))
    table = {}
    for name in columns:
        values = np.asarray(data[name], dtype=float).ravel()
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise LagError(f"data column '{name}' has a value that is not a finite number (row {bad[0]})", where)
        table[name] = values
    if len({len(v) for v in table.values()}) > 1:
        raise LagError("the data columns differ in length", where)
    names = tuple(c for c in columns if c != "t")
    return _sorted(table["t"], names, np.column_stack([table[c] for c in names]))


def _read_csv(source: SourceFile, outputs, model_name) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    lines = source.text.split("\n")
    rows = [(number, line) for number, line in enumerate(lines, 1) if line.strip()]
    if not rows:
        raise LagError("the data file is empty (it needs a header t,<outputs> and rows)", _span(source, 1, 1, 0))
    header_line, header = rows[0]
    names, spans = [], []
    for field, column in _fields(header):
        names.append(UNIT_SUFFIX.sub("", field).strip())
        spans.append(_span(source, header_line, column, len(field)))
    _check_names(names, outputs, model_name, spans)
    if len(rows) < 2:
        raise LagError("the data file has a header but no rows", spans[0])
    values = np.empty((len(rows) - 1, len(names)))
    for r, (number, line) in enumerate(rows[1:]):
        fields = _fields(line)
        if len(fields) != len(names):
            raise LagError(f"this row has {len(fields)} values, the header names {len(names)} columns",
                           _span(source, number, 1, len(line)))
        for c, (field, column) in enumerate(fields):
            values[r, c] = _number(field, names[c], _span(source, number, column, len(field)))
    t = values[:, names.index("t")]
    kept = [c for c, name in enumerate(names) if name != "t"]
    return t, tuple(names[c] for c in kept), values[:, kept]


def _fields(line: str) -> list[tuple[str, int]]:
    """The comma-separated fields of a line (RFC 4180 quotes allowed), each with its 1-based column."""
    fields = next(csv.reader([line]))
    located, column = [], 1
    for field in fields:
        at = line.find(field, column - 1) if field else column - 1
        located.append((field, at + 1))
        column = at + len(field) + 2
    return located


def _number(field: str, column: str, span: Span) -> float:
    try:
        value = float(field)
    except ValueError:
        raise LagError(f"'{field.strip()}' in column '{column}' is not a number", span) from None
    if not math.isfinite(value):
        raise LagError(f"column '{column}' has a value that is not a finite number ({field.strip()})", span)
    return value


def _check_names(names, outputs, model_name: str, where) -> None:
    if "t" not in names:
        raise LagError("the data has no column 't' (the times of the measurements)", where[0] if where else None)
    if len(set(names)) < len(names):
        duplicate = next(n for n in names if names.count(n) > 1)
        raise LagError(f"the data names column '{duplicate}' twice", where[names.index(duplicate)])
    for name, place in zip(names, where):
        if name != "t" and name not in outputs:
            raise LagError(f"data column '{name}' is not an output of the scene of model {model_name}"
                           f"{suggest(name, list(outputs))} (outputs: {', '.join(outputs)})", place)
    if len(names) < 2:
        raise LagError("the data has only the column 't': name at least one output column", where[0])


def _span(source: SourceFile, line: int, column: int, width: int) -> Span:
    offset = sum(len(text) + 1 for text in source.text.split("\n")[:line - 1]) + column - 1
    return Span(source, line, column, offset, offset + max(1, width))


def _sorted(t: np.ndarray, columns: tuple[str, ...], values: np.ndarray) -> Data:
    order = np.argsort(t, kind="stable")
    return Data(np.asarray(t, dtype=float)[order], columns, np.asarray(values, dtype=float)[order])
