"""Tables on disk: the one CSV format of lagdsl, and tidy tables streamed block by block.

Every CSV lagdsl writes (a run's rows, a sweep's tidy table, the bench's table) goes through
csv_text: one number format, one quoting rule. A sweep too large to hold in memory is written
block by block by TableFile, as CSV or Parquet, into a file that appears complete or not at all.
"""
from __future__ import annotations

import io
import os
import warnings

import numpy as np

from ..errors import LagWarning
from ..escape import csv_field
from .files import OutputFile


def csv_text(header, columns) -> str:
    """The one CSV format of lagdsl's tables: a header of RFC 4180 fields, then one line per row
    of `columns` (equal-length sequences). Numbers are written as C's printf("%.17g") writes a
    double, so that `lagc run`, the Python API and the standalone C program write the same bytes:
    17 significant digits (they read back to the same double), no trailing zeros, `-0`, `inf`,
    `-inf`, `nan`; integers as integers, text quoted where it must be, None as an empty field."""
    cells = [_csv_cells(column) for column in columns]
    lines = [",".join(csv_field(str(name)) for name in header), *map(",".join, zip(*cells))]
    return "\n".join(lines) + "\n"


def _csv_cells(column) -> list[str]:
    array = np.asarray(column)
    if array.dtype.kind == "f":
        return _float_cells(array.astype(np.float64, copy=False).ravel())
    if array.dtype.kind in "iub":
        return list(array.astype(np.int64).astype(str))
    texts: dict = {}        # a sweep's status column repeats a few texts
    return [texts[x] if x in texts else texts.setdefault(x, _cell(x)) for x in column]


def _float_cells(array: np.ndarray) -> list[str]:
    """Each double as %.17g; a column that repeats its values (a sweep's times and inputs, one per
    member row) formats each distinct value once. Distinct means distinct bits, so 0 and -0 stay
    apart."""
    bits, index = np.unique(array.view(np.uint64), return_inverse=True)
    if 2 * len(bits) > len(array):
        return list(map("%.17g".__mod__, array.tolist()))
    texts = list(map("%.17g".__mod__, bits.view(np.float64).tolist()))
    return list(map(texts.__getitem__, index.ravel().tolist()))


def _cell(value) -> str:
    return "" if value is None else format(value, ".17g") if isinstance(value, float) else csv_field(str(value))


class TableFile:
    """A tidy table (a dict of equal-length columns) written to `path` one block at a time:
    Parquet when the name ends in .parquet and pyarrow is installed (a row group a block), else
    CSV. The file appears when the block ends (see files.OutputFile); `commit()` ends it early."""

    def __init__(self, path: str | os.PathLike):
        self.parquet = str(path).endswith(".parquet") and _has_pyarrow(path)
        self.output = OutputFile(path, binary=self.parquet)
        self.writer = None          # the ParquetWriter, or True once the CSV header is written

    def __enter__(self) -> TableFile:
        self.output.__enter__()
        return self

    def write(self, table: dict[str, np.ndarray]) -> None:
        if self.parquet:
            self._write_parquet(table)
            return
        text = csv_text(table, table.values())
        self.output.write(text if self.writer is None else text.split("\n", 1)[1])
        self.writer = True

    def _write_parquet(self, table: dict[str, np.ndarray]) -> None:
        import pyarrow.parquet
        arrow = _arrow(table)
        if self.writer is None:
            self.writer = pyarrow.parquet.ParquetWriter(self.output.stream, arrow.schema)
        self.writer.write_table(arrow)

    def commit(self) -> None:
        if self.parquet and self.writer is not None:
            self.writer.close()
        self.output.commit()

    def __exit__(self, kind, error, traceback) -> None:
        if kind is None:
            self.commit()
        else:
            self.output.__exit__(kind, error, traceback)


def parquet_bytes(table: dict[str, np.ndarray]) -> bytes:
    """A tidy table as the bytes of a Parquet file (needs pyarrow)."""
    import pyarrow.parquet
    buffer = io.BytesIO()
    pyarrow.parquet.write_table(_arrow(table), buffer)
    return buffer.getvalue()


def _arrow(table: dict[str, np.ndarray]):
    import pyarrow
    return pyarrow.table({name: column.astype(str) if column.dtype == object else column
                          for name, column in table.items()})


def _has_pyarrow(path) -> bool:
    try:
        import pyarrow.parquet  # noqa: F401
    except ImportError:
        warnings.warn(f"pyarrow is not installed; writing CSV to {path}", LagWarning, stacklevel=3)
        return False
    return True
