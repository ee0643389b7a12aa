"""Writing what lagdsl produces: output files (-o) replaced atomically, and standard output
checked to the last byte.

An output file is never left half written: a regular file is written beside itself and renamed
into place. Standard output is written with os.write and every byte accounted for, so that a full
disk or a file-size limit (`ulimit -f`) is an error, never a silently truncated table.
"""
from __future__ import annotations

import errno
import os
import secrets
import stat
import sys
from pathlib import Path

from ..escape import visible


class CannotWrite(OSError):
    """An output file that cannot be written; the message names the path as the user gave it."""

    def __init__(self, path: str | os.PathLike, reason: OSError):
        super().__init__(reason.errno, visible(f"cannot write '{os.fspath(path)}': {_describe(reason)}"))


def check_writable(path: str | os.PathLike, model: str | os.PathLike | None = None) -> None:
    """Raise CannotWrite now if `write_output(path, ...)` is bound to fail (before a long run, say):
    no file name, a directory, the model file itself (`model`), a read-only file, or a directory
    in which no file can be created (tried: a temporary file is made and removed)."""
    try:
        target, existing = _destination(path)
        if model is not None and existing is not None and os.path.samefile(target, model):
            raise PermissionError(errno.EPERM, "it is the model file itself")
        if existing is None or stat.S_ISREG(existing.st_mode):
            _probe(target)
    except OSError as error:
        raise CannotWrite(path, error) from None


def _probe(target: Path) -> None:
    """Create and remove a temporary file beside `target`, as write_output will."""
    partial = _temporary(target)
    os.close(os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
    partial.unlink()


def write_output(path: str | os.PathLike, text: str | bytes) -> None:
    """Write `text` (UTF-8, or bytes as they are: a Parquet file, a PNG) to `path` without
    damaging what is there (see OutputFile)."""
    with OutputFile(path, binary=isinstance(text, bytes)) as stream:
        stream.write(text)


class OutputFile:
    """`path` opened for writing piece by piece, committed when the block ends without an exception.

    A regular file (new, or existing and writable) is written to a temporary file beside it and
    renamed over it, so readers never see half a file; an existing file keeps its mode, a new one
    gets the default mode (umask). A symbolic link is followed: its target is written and the link
    stays. A device or FIFO (/dev/null, a pipe) is written in place, never replaced. A directory,
    a read-only file or a missing directory is refused with CannotWrite, and no temporary file is
    left behind; so is a write that fails, and after an exception the temporary file is removed.
    `commit()` ends the file early (what a table interrupted by Ctrl-C does with the rows it has).
    """

    def __init__(self, path: str | os.PathLike, binary: bool = False):
        self.path, self.binary = path, binary
        self.stream = self.partial = self.target = self.mode = None

    def __enter__(self):
        try:
            self.target, existing = _destination(self.path)
            in_place = existing is not None and not stat.S_ISREG(existing.st_mode)
            self.mode = stat.S_IMODE(existing.st_mode) if existing is not None and not in_place else None
            if in_place:
                self.stream = _open(self.target, self.binary)
            else:
                self.partial = _temporary(self.target)
                descriptor = os.open(self.partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # & ~umask
                self.stream = _open(self.partial, self.binary, descriptor)
        except OSError as error:
            raise CannotWrite(self.path, error) from None
        return self

    def write(self, data: str | bytes) -> None:
        try:
            self.stream.write(data)
        except OSError as error:
            raise CannotWrite(self.path, error) from None

    def commit(self) -> None:
        if self.stream is None:
            return
        try:
            if self.mode is not None:
                os.fchmod(self.stream.fileno(), self.mode)
            self.stream.close()
            self.stream = None
            if self.partial is not None:
                os.replace(self.partial, self.target)
                self.partial = None
        except OSError as error:
            self._discard()
            raise CannotWrite(self.path, error) from None

    def __exit__(self, kind, error, traceback) -> None:
        if kind is None:
            self.commit()
        else:
            self._discard()

    def _discard(self) -> None:
        if self.stream is not None:
            self.stream.close()
            self.stream = None
        if self.partial is not None:
            self.partial.unlink(missing_ok=True)
            self.partial = None


def _destination(path: str | os.PathLike) -> tuple[Path, os.stat_result | None]:
    """The file to write (symbolic links resolved) and its status, None if it does not exist yet."""
    given = os.fspath(path)
    if not given:
        raise FileNotFoundError(errno.ENOENT, "the file name is empty")
    if given.endswith(os.sep):
        raise IsADirectoryError(errno.EISDIR, "the name ends in '/', a directory")
    target = Path(os.path.realpath(path))
    try:
        existing = target.stat()
    except FileNotFoundError:
        if not target.parent.is_dir():
            raise FileNotFoundError(errno.ENOENT, f"the directory '{target.parent}' does not exist") from None
        return target, None
    if stat.S_ISDIR(existing.st_mode):
        raise IsADirectoryError(errno.EISDIR, "it is a directory")
    # Root may write anything, so os.access alone would let root replace a file marked read-only.
    if stat.S_ISREG(existing.st_mode) and (not existing.st_mode & 0o222 or not os.access(target, os.W_OK)):
        raise PermissionError(errno.EACCES, "the file is read-only")
    return target, existing


def _open(target, binary: bool, descriptor: int | None = None):
    opener = open if descriptor is None else os.fdopen
    where = target if descriptor is None else descriptor
    return opener(where, "wb") if binary else opener(where, "w", encoding="utf-8")


def _describe(error: OSError) -> str:
    reason = error.strerror or str(error)
    return reason[:1].lower() + reason[1:]


def _temporary(target: Path) -> Path:
    """A name beside `target`, unique per process and thread."""
    return target.with_name(f".{target.name}.{secrets.token_hex(8)}.tmp")


class CannotWriteStdout(OSError):
    def __init__(self, reason: OSError):
        super().__init__(reason.errno, f"cannot write standard output: {_describe(reason)}")


def write_stdout(text: str) -> None:
    """Write `text` to standard output, every byte of it, or raise CannotWriteStdout (a full disk,
    a file-size limit). A reader that went away raises BrokenPipeError, which `lagc` ends quietly
    on. Where standard output is not a file descriptor (a test's capture), it is written as it is."""
    stream = sys.stdout
    try:
        descriptor = stream.fileno()
    except (AttributeError, OSError, ValueError):       # io.UnsupportedOperation is an OSError
        stream.write(text)
        return
    data = memoryview(text.encode(stream.encoding or "utf-8", stream.errors or "strict"))
    try:
        stream.flush()
        while data:
            written = os.write(descriptor, data)
            if written <= 0:
                raise OSError(errno.EIO, "nothing was written")
            data = data[written:]
    except BrokenPipeError:
        raise
    except OSError as error:
        raise CannotWriteStdout(error) from None
