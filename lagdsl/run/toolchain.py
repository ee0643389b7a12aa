"""Finding a C compiler and building generated sources, cached by content hash.

A shared library is built once per (source, compiler, flags) and reused: its file name
carries the SHA-256 of all three, so a second run of the same scene does not recompile and a
changed model never reuses a stale library. The cache itself (where it lives, how entries are
verified before use and built without collisions) is `cache.py`.
"""
from __future__ import annotations

import functools
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
OPENMP_FLAG = "-fopenmp"
# A parallel loop that needs the OpenMP runtime: a compiler that accepts -fopenmp but cannot link
# libgomp (or libomp) must not count as supporting it.
OPENMP_PROBE = """#include <omp.h>
int main(void)
{
    int n = 0;
#pragma omp parallel reduction(+:n)
    n += omp_get_num_threads() > 0;
    return n > 0 ? 0 : 1;
}
"""


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


def shared_library(source: str, stem: str, openmp: bool | None = None) -> Path:
    """The compiled shared library for `source`, built on first use and cached: with OpenMP
    (the batch entry point runs its members in parallel) when the compiler supports it, unless
    `openmp` says otherwise. The generated code gives the same results bit for bit either way."""
    compiler = find_compiler()
    flags = library_flags(compiler, openmp)
    key = hashlib.sha256("\0".join((source, compiler, *flags)).encode()).hexdigest()
    return cached_entry(f"{stem}-{key[:20]}.so", key, lambda path: compile_c(source, path, flags, compiler))


def library_flags(compiler: str, openmp: bool | None = None) -> tuple[str, ...]:
    use_openmp = supports_openmp(compiler) if openmp is None else openmp
    return (*LIBRARY_FLAGS, OPENMP_FLAG) if use_openmp else LIBRARY_FLAGS


@functools.lru_cache(maxsize=None)
def supports_openmp(compiler: str) -> bool:
    """Whether `compiler` builds and links an OpenMP program (asked once per compiler and process)."""
    with tempfile.TemporaryDirectory() as work:
        probe = Path(work) / "probe.c"
        probe.write_text(OPENMP_PROBE, encoding="ascii")
        try:
            done = subprocess.run([compiler, OPENMP_FLAG, str(probe), "-o", str(Path(work) / "probe")],
                                  capture_output=True, text=True, timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            return False
        return done.returncode == 0
