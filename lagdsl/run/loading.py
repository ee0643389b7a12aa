"""What runs generated code: the shared library of C source, the module of NumPy source.

Both are kept in the build cache (run/cache.py) under the hash of the source, so a second run of
the same program neither compiles nor writes anything.
"""
from __future__ import annotations

import _ctypes
import ctypes
import hashlib
import importlib.abc
import importlib.util
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import InternalError, LagError
from .cache import cached_entry, discard
from .toolchain import shared_library

if TYPE_CHECKING:       # the code generators import sympy; running generated code does not need it
    from ..codegen import GeneratedSource


def load(source: GeneratedSource):
    """What runs `source`: its shared library (C, compiled on first use) or its module (NumPy).

    A caller that keeps it passes it back as `loaded` to run_c or run_numpy, which then go
    straight to the integration: no hashing of the source, no compiler, no dlopen or import.
    """
    if source.language == "c":
        path = shared_library(source.text, source.suggested_name)
        library = load_program_library(path)
        if library is None:             # not one of ours, manifest or not: build it again
            discard(path)
            library = load_program_library(shared_library(source.text, source.suggested_name))
        if library is None:
            raise InternalError(f"the library built from the generated C has no lag_run: {path}")
        return library
    return load_module(source)


def load_program_library(path: Path) -> ctypes.CDLL | None:
    """The library at `path` if it is a lagdsl program (it has lag_run), else None, closed again
    (dlopen would hand back a library still open under the same path, even after a rebuild)."""
    library = load_library(path)
    if hasattr(library, "lag_run"):
        return library
    _ctypes.dlclose(library._handle)
    return None


def load_library(path: Path) -> ctypes.CDLL:
    try:
        return ctypes.CDLL(str(path))
    except OSError as error:
        # The cache entry was verified, so this is the system refusing it (a cache directory on a
        # file system mounted noexec, say); ctypes gives dlopen's message without an errno.
        raise LagError(f"cannot load the compiled model '{path}': {error}") from None


def load_module(source: GeneratedSource):
    """Import generated NumPy code; it is kept in the build cache so that tracebacks point at a file.

    The module is executed from the generated text itself (the cache entry is verified to hold the
    same bytes), and no bytecode is written beside it: a damaged .pyc could not be told apart.
    """
    name, key = module_entry(source)
    path = cached_entry(name, key, lambda entry: _write_module(source.text, entry))
    return import_module(source.text, path, key)


def module_entry(source: GeneratedSource) -> tuple[str, str]:
    """The cache entry's name and key of a generated NumPy module."""
    key = hashlib.sha256(source.text.encode()).hexdigest()
    return f"{source.suggested_name}_{key[:20]}.py", key


def import_module(text: str, path: Path, key: str):
    """The module of generated `text`, held in the cache at `path` under `key`."""
    spec = importlib.util.spec_from_file_location(f"lagdsl_generated_{key[:20]}", path,
                                                  loader=_GeneratedLoader(text, path))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _write_module(text: str, entry: Path) -> None:
    try:
        compile(text, str(entry), "exec")     # never cache a module that cannot load
    except SyntaxError as error:
        raise InternalError(f"the generated Python does not parse: {error}") from None
    entry.write_text(text, encoding="utf-8")


class _GeneratedLoader(importlib.abc.InspectLoader):
    """Loads a module from text held in memory, compiled under the name of its file in the cache."""

    def __init__(self, text: str, path: Path):
        self.text, self.path = text, path

    def get_source(self, fullname: str) -> str:
        return self.text

    def get_code(self, fullname: str):
        return self.source_to_code(self.text, str(self.path))
