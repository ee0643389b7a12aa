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
import signal
import subprocess
import tempfile
from pathlib import Path

from ..errors import InternalError, LagError
from ..progress import slow_stage
from .cache import cached_entry

STRICT_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic")
# The libraries of the local build cache run only on this machine, so they are tuned for it.
# Chosen by measurement (double pendulum, dop853, 50 s at rtol 1e-10: 1.62 ms at -O2, 1.37 ms
# with these): -march=native alone is slower than -O2 (2.3 ms), because GCC's SLP vectorizer
# stores a stage's argument as one wide vector that the right-hand side reads back as scalars,
# a store-forwarding stall on every call; -fno-tree-slp-vectorize removes it. -fno-math-errno
# lets sqrt be one instruction. None of them changes a result: ISO C mode (-std=c99) keeps
# a*b + c from being contracted into an fma, and nothing allows reassociation.
LIBRARY_FLAGS = ("-std=c99", "-O3", "-march=native", "-fno-tree-slp-vectorize", "-fno-math-errno",
                 "-fPIC", "-shared")
# For a compiler that refuses one of the above (-march=native is not universal).
PORTABLE_LIBRARY_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared")
# $LAGDSL_OPTIMIZE, where set, is the -O level of every library build instead of the above: a
# test run builds hundreds of model libraries once each and runs most for milliseconds, and at -O1
# gcc takes half its -O3 time. The level changes no result (see LIBRARY_FLAGS).
OPTIMIZE_VARIABLE = "LAGDSL_OPTIMIZE"
OPTIMIZATION_LEVELS = ("0", "1", "2", "3", "s", "g")
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
# What a compiler driver prints when the compiler proper died of a signal (the out-of-memory killer
# sends SIGKILL to cc1, not to the driver): gcc, then clang.
KILLED_DIAGNOSTICS = ("signal terminated program", "due to signal", "unable to execute command: Killed")
# The working precision of a build: the macro runtime.h reads, and the library it needs beyond libm.
PRECISIONS = {"double": ((), ()), "long double": (("-DLAG_LONG_DOUBLE",), ()),
              "float128": (("-DLAG_FLOAT128",), ("-lquadmath",))}


def find_compiler() -> str:
    for candidate in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if candidate and shutil.which(candidate):
            return candidate
    raise LagError("no C compiler found (looked for $CC, cc, gcc, clang); install one, "
                   "or run with --backend numpy")


class CompilerFailed(InternalError):
    """The C compiler refused the generated code or its flags; `diagnostics` is what it printed."""

    def __init__(self, diagnostics: str):
        super().__init__(f"the generated C did not compile\n{diagnostics}")
        self.diagnostics = diagnostics


def compile_c(source: str, output: Path, flags=STRICT_FLAGS, compiler: str | None = None,
              libraries: tuple[str, ...] = ()) -> None:
    """Compile one C file; a compiler error in generated code is our bug, reported in full. A
    compiler killed by a signal (the out-of-memory killer, a Ctrl-C, a time limit) is not: that
    is a LagError naming the signal and what to do."""
    compiler = compiler or find_compiler()
    with tempfile.TemporaryDirectory() as work:
        source_path = Path(work) / "model.c"        # the output's name may be long; this one never is
        source_path.write_text(source, encoding="utf-8")
        with slow_stage(f"compiling the generated C ({len(source) / 1e6:.1f} MB) with {compiler}"):
            result = subprocess.run([compiler, *flags, str(source_path), "-o", str(output), *libraries, "-lm"],
                                    capture_output=True, text=True)
        if result.returncode != 0:
            _raise_if_killed(result, compiler, len(source))
            raise CompilerFailed(result.stderr)


def _raise_if_killed(result: subprocess.CompletedProcess, compiler: str, size: int) -> None:
    """A LagError when the compiler, or the compiler proper under its driver, died of a signal:
    a negative return code (the process itself), 128 + the signal (a wrapper script's child), or
    the driver's own words for it."""
    code = result.returncode
    number = -code if code < 0 else code - 128 if 128 < code < 128 + signal.NSIG else None
    if number is None and not any(words in result.stderr for words in KILLED_DIAGNOSTICS):
        return
    what = f"signal {number} ({signal.Signals(number).name})" if number in signal.valid_signals() else "a signal"
    raise LagError(f"the C compiler {compiler} was killed by {what} while compiling {size / 1e6:.1f} MB of "
                   f"generated C (SIGKILL is most often the out-of-memory killer); free memory and run "
                   f"again, or run with --backend numpy\n{result.stderr.strip()}".rstrip())


def shared_library(source: str, stem: str, openmp: bool | None = None, precision: str = "double") -> Path:
    """The compiled shared library for `source`, built on first use and cached: with OpenMP
    (the batch entry point runs its members in parallel) when the compiler supports it, unless
    `openmp` says otherwise. The generated code gives the same results bit for bit either way.

    `precision` (a key of PRECISIONS) is the type of `real` inside; the entry points take and
    return doubles whatever it is. The double build's key is unchanged by the option.
    """
    compiler = find_compiler()
    name, key = library_entry(source, stem, compiler, openmp, precision)
    return cached_entry(name, key, lambda path: _compile_library(source, path, compiler, openmp, precision))


def library_entry(source: str, stem: str, compiler: str, openmp: bool | None = None,
                  precision: str = "double") -> tuple[str, str]:
    """The cache entry's name and key of the library that `compiler` builds from `source`."""
    libraries = PRECISIONS[precision][1]
    flags = library_flags(compiler, openmp, precision=precision)
    key = hashlib.sha256("\0".join((source, compiler, *flags, *libraries)).encode()).hexdigest()
    suffix = "" if precision == "double" else "-" + precision.replace(" ", "_")
    return f"{stem}{suffix}-{key[:20]}.so", key


def library_flags(compiler: str, openmp: bool | None = None, flags: tuple[str, ...] | None = None,
                  precision: str = "double") -> tuple[str, ...]:
    """`flags` (the tuned LIBRARY_FLAGS by default) with the precision's macro, and OpenMP where
    asked for or supported."""
    flags = (*optimized(LIBRARY_FLAGS if flags is None else flags), *PRECISIONS[precision][0])
    use_openmp = supports_openmp(compiler) if openmp is None else openmp
    return (*flags, OPENMP_FLAG) if use_openmp else flags


def optimized(flags: tuple[str, ...]) -> tuple[str, ...]:
    """`flags` with the optimisation level that $LAGDSL_OPTIMIZE names, if it names one."""
    level = os.environ.get(OPTIMIZE_VARIABLE, "")
    if not level:
        return flags
    if level not in OPTIMIZATION_LEVELS:
        raise LagError(f"{OPTIMIZE_VARIABLE}={level!r} is not an optimisation level: set it to one of "
                       f"{', '.join(OPTIMIZATION_LEVELS)} (gcc's -O0 ... -Og), or unset it for the tuned -O3")
    return tuple(f"-O{level}" if flag.startswith("-O") else flag for flag in flags)


def _compile_library(source: str, output: Path, compiler: str, openmp: bool | None, precision: str) -> None:
    """Build with the tuned flags, or with the portable ones where the compiler refuses those:
    where its diagnostics name one of the tuned flags the portable set leaves out. Any other
    failure is raised as it is (a killed compiler would be killed again, an error in the
    generated C would recur)."""
    libraries = PRECISIONS[precision][1]
    try:
        compile_c(source, output, library_flags(compiler, openmp, precision=precision), compiler, libraries)
    except CompilerFailed as failure:
        if not refuses_tuned_flags(failure.diagnostics):
            raise
        compile_c(source, output, library_flags(compiler, openmp, PORTABLE_LIBRARY_FLAGS, precision), compiler,
                  libraries)


def refuses_tuned_flags(diagnostics: str) -> bool:
    """Whether a compiler's diagnostics name a tuned flag that the portable set leaves out, by the
    option's name (gcc says "bad value 'native' for '-march=' switch", clang "unknown argument")."""
    options = {flag.split("=")[0] for flag in LIBRARY_FLAGS if flag not in PORTABLE_LIBRARY_FLAGS}
    return any(option in diagnostics for option in options)


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


@functools.lru_cache(maxsize=None)
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
