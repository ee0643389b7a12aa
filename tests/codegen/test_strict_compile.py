"""The generated C of every scene of every library model compiles warning-free, strictly,
in double and in long double precision, with and without OpenMP (the batch entry point)."""
from __future__ import annotations


import pytest

from lagdsl.run.toolchain import supports_openmp
from tests.conftest import compiled, library_model, library_scenes
from tests.run.c_harness import STRICT_FLAGS, find_cc

SCENES = library_scenes()

# The default run compiles the kinds of code that test_golden.py does not compile strictly: the
# dense Cholesky loops, the sparse saddle point of many constraints, a rheonomic constraint, the
# local form's loops with radau5's banded Jacobian. The other scenes are slow.
DEFAULT_SCENES = {("pendulum_chain", "swing"), ("cartesian_chain", "swing"), ("car_axis", "bumps"),
                  ("fpu_chain", "implicit")}


@pytest.mark.parametrize("model, scene", [
    pytest.param(model, scene, id=f"{model}.{scene}", marks=() if (model, scene) in DEFAULT_SCENES else pytest.mark.slow)
    for model, scene in SCENES])
def test_generated_c_compiles_under_strict_flags(tmp_path, model, scene):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source = tmp_path / f"{model}.c"
    source.write_text(library_model(model).emit("c", scene).text)
    openmp = ["-fopenmp"] if supports_openmp(cc) else []
    # Each flag once in the default run (double serial, long double with OpenMP); every pair in the slow one.
    builds = [[], ["-DLAG_LONG_DOUBLE", *openmp]]
    if (model, scene) not in DEFAULT_SCENES:
        builds += [["-DLAG_LONG_DOUBLE"], *([openmp] if openmp else [])]
    for flags in builds:
        done = compiled([cc, *STRICT_FLAGS, *flags, "-c", str(source), "-o", str(tmp_path / "m.o")])
        assert done.returncode == 0, done.stderr
