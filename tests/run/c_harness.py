"""Compile and run a small C program made of the bundled runtime, one integrator and a test model.

The integrator tests write a test model (LAG_NQ, LAG_NY, struct lag_system, lag_rhs, ...) and a
`main` that drives the stepper, in C, and use this helper to assemble the single translation unit
as the code generator does: runtime.h and the contract with Python that follows it (the status
codes and shared constants), the linear algebra used (cholesky.c, lu.c), model, integrator, main.
"""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

from lagdsl.codegen.c_abi import runtime_contract, runtime_header
from lagdsl.integrators import integrator_source
from tests.conftest import compiled

C_SOURCES = Path(__file__).resolve().parents[2] / "lagdsl" / "integrators" / "c"
STRICT_FLAGS = ["-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic"]
SYSTEM_HEADERS = "#include <math.h>\n#include <float.h>\n#include <stdio.h>\n#include <stdlib.h>\n#include <string.h>\n"


def find_cc() -> str | None:
    for name in ("cc", "gcc", "clang"):
        if shutil.which(name):
            return name
    return None


def build_scene_programs(model: Path, scenes: tuple[str, ...], directory: Path) -> dict[str, Path]:
    """The generated standalone program of each scene of `model`, compiled under the strict flags
    into `directory` (a test skips where no compiler is found)."""
    import pytest

    from tests.conftest import lagc_in_process
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    built = {}
    for scene in scenes:
        source = directory / f"{scene}.c"
        emitted = lagc_in_process("emit", str(model), "--emit", "c", "--scene", scene, "-o", str(source))
        assert emitted.returncode == 0, emitted.stderr
        built[scene] = directory / scene
        compiled([cc, *STRICT_FLAGS, str(source), "-o", str(built[scene]), "-lm"], check=True)
    return built


def assemble(model_c: str, integrator: str, main_c: str) -> str:
    """The integrator's files (with the fragments it shares; a composite's parts renamed) between
    the model and main."""
    integrator_c = integrator_source(integrator)
    users = model_c + integrator_c + main_c
    # only the linear algebra someone calls, as the generator does: unused static functions are warnings
    shared = [(C_SOURCES / name).read_text() for name, prefix in (("cholesky.c", "lag_cholesky"), ("lu.c", "lag_lu_"))
              if prefix in users]
    return "\n".join([SYSTEM_HEADERS, runtime_header(), runtime_contract(), *shared, model_c, integrator_c, main_c])


def build_and_run(tmp_path: Path, model_c: str, integrator: str, main_c: str,
                  args: list[str] = (), extra_flags: list[str] = ()) -> str:
    """Compile with the strict flags (warnings are errors) and return the program's stdout."""
    cc = find_cc()
    if cc is None:
        import pytest
        pytest.skip("no C compiler")
    src = tmp_path / f"{integrator}_test.c"
    exe = tmp_path / f"{integrator}_test"
    src.write_text(assemble(model_c, integrator, main_c))
    compiled([cc, *STRICT_FLAGS, *extra_flags, str(src), "-o", str(exe), "-lm"], check=True)
    return subprocess.run([str(exe), *args], check=True, capture_output=True, text=True).stdout
