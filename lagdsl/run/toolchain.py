"""Finding a C compiler and building generated sources, cached by content hash.

A shared library is built once per (source, compiler, flags) and reused: its file name
carries the SHA-256 of all three, so a second run of the same scene does not recompile and a
changed model never reuses a stale library. The cache itself (where it lives, how entries are
verified before use and built without collisions) is `cache.py`.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import InternalError, LagError
from .cache import cached_entry

STRICT_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic")
LIBRARY_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared")


def find_compiler() -> str:
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate):
            return candidate
    raise LagError("no C compiler found (looked for $CC, cc, gcc, clang); install one, "
                   "or run with --backend numpy")


def compile_c(source: str, output: Path, flags=STRICT_FLAGS, compiler: str | None = None) -> None:
    """Compile one C file; a compiler error in generated code is our bug, reported in full."""
    compiler = compiler or find_compiler()
    with tempfile.TemporaryDirectory() as work:
        source_path = Path(work) / f"{output.stem}.c"
        source_path.write_text(source, encoding="utf-8")
        result = subprocess.run([compiler, *flags, str(source_path), "-o", str(output), "-lm"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            raise InternalError(f"the generated C did not compile\n{result.stderr}")


def shared_library(source: str, stem: str) -> Path:
    """The compiled shared library for `source`, built on first use and cached."""
    compiler = find_compiler()
    name, key = library_entry(source, stem, compiler)
    return cached_entry(name, key, lambda path: compile_c(source, path, LIBRARY_FLAGS, compiler))


def library_entry(source: str, stem: str, compiler: str) -> tuple[str, str]:
    """The cache entry's name and key of the library that `compiler` builds from `source`."""
    key = hashlib.sha256("\0".join((source, compiler, *LIBRARY_FLAGS)).encode()).hexdigest()
    return f"{stem}-{key[:20]}.so", key
