"""Model source text and positions in it."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class SourceFile:
    """A model file read once as UTF-8; `name` is how diagnostics refer to it."""

    name: str
    text: str

    @classmethod
    def read(cls, path: str | Path) -> "SourceFile":
        return cls(str(path), Path(path).read_text(encoding="utf-8"))

    def line(self, number: int) -> str:
        """The text of 1-based line `number`, without its newline."""
        lines = self.text.splitlines()
        return lines[number - 1] if 0 < number <= len(lines) else ""


@dataclass(frozen=True)
class Span:
    """A region of a source file: 1-based line and column of its start, 0-based offsets."""

    source: SourceFile
    line: int
    column: int
    start: int
    end: int

    @property
    def text(self) -> str:
        return self.source.text[self.start:self.end]

    def __repr__(self) -> str:  # keeps IR reprs short
        return f"Span({self.source.name}:{self.line}:{self.column})"
