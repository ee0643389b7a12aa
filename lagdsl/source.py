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
        data = Path(path).read_bytes()
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as error:
            from .errors import LagError
            source = cls(str(path), data.decode("utf-8", errors="replace"))
            offset = len(data[:error.start].decode("utf-8", errors="replace"))
            line = source.text.count("\n", 0, offset) + 1
            column = offset - (source.text.rfind("\n", 0, offset) + 1) + 1
            raise LagError(f"the file is not UTF-8 text (byte 0x{data[error.start]:02x})",
                           Span(source, line, column, offset, offset + 1)) from None
        text = text.removeprefix("\ufeff")      # a byte order mark, as some Windows editors write
        return cls(str(path), text.replace("\r\n", "\n").replace("\r", "\n"))   # as read_text does

    def line(self, number: int) -> str:
        """The text of 1-based line `number`, without its newline.

        Lines end at '\\n' only, as the parser counts them (str.splitlines also breaks at form
        feeds and other separators, which would show the wrong line under a diagnostic).
        """
        lines = self.text.split("\n")
        return lines[number - 1].rstrip("\r") if 0 < number <= len(lines) else ""


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
