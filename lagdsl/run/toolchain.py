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
from functools import lru_cache
from pathlib import Path

from ..errors import InternalError, LagError
from .cache import cached_entry

STRICT_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic")
LIBRARY_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared")
# The working precision of a build: the macro runtime.h reads, and the library it needs beyond libm.
PRECISIONS = {"double": ((), ()), "long double": (("-DLAG_LONG_DOUBLE",), ()),
              "float128": (("-DLAG_FLOAT128",), ("-lquadmath",))}


def find_compiler() -> str:
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate):
            return candidate
    raise LagError("no C compiler found (looked for $CC, cc, gcc, clang); install one, "
                   "or run with --backend numpy")


def compile_c(source: str, output: Path, flags=STRICT_FLAGS, compiler: str | None = None,
              libraries: tuple[str, ...] = ()) -> None:
    """Compile one C file; a compiler error in generated code is our bug, reported in full."""
    compiler = compiler or find_compiler()
    with tempfile.TemporaryDirectory() as work:
        source_path = Path(work) / f"{output.stem}.c"
        source_path.write_text(source, encoding="utf-8")
        result = subprocess.run([compiler, *flags, str(source_path), "-o", str(output), *libraries, "-lm"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            raise InternalError(f"the generated C did not compile\n{result.stderr}")


def shared_library(source: str, stem: str, precision: str = "double") -> Path:
    """The compiled shared library for `source`, built on first use and cached.

    `precision` (a key of PRECISIONS) is the type of `real` inside; the entry points take and
    return doubles whatever it is. The double build's key is unchanged by the option.
    """
    compiler = find_compiler()
    name, key = library_entry(source, stem, compiler, precision)
    defines, libraries = PRECISIONS[precision]
    return cached_entry(name, key,
                        lambda path: compile_c(source, path, (*LIBRARY_FLAGS, *defines), compiler, libraries))


def library_entry(source: str, stem: str, compiler: str, precision: str = "double") -> tuple[str, str]:
    """The cache entry's name and key of the library that `compiler` builds from `source`."""
    defines, libraries = PRECISIONS[precision]
    key = hashlib.sha256("\0".join((source, compiler, *LIBRARY_FLAGS, *defines, *libraries)).encode()).hexdigest()
    suffix = "" if precision == "double" else "-" + precision.replace(" ", "_")
    return f"{stem}{suffix}-{key[:20]}.so", key


@lru_cache(maxsize=None)
def extended_precision(compiler: str) -> str:
    """The most precise `real` that `compiler` can build: "float128" when it has __float128 and
    libquadmath (gcc on x86 and others), else "long double" (clang, most non-x86 systems)."""
    probe = ("#include <quadmath.h>\nint main(void) { __float128 x = 2; "
             "return sqrtq(x) > 1 ? 0 : 1; }\n")
    with tempfile.TemporaryDirectory() as work:
        program = Path(work) / "probe.c"
        program.write_text(probe, encoding="utf-8")
        built = subprocess.run([compiler, str(program), "-o", str(Path(work) / "probe"), "-lquadmath"],
                               capture_output=True, text=True)
    return "float128" if built.returncode == 0 else "long double"
