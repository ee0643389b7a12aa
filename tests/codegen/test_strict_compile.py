"""The generated C of every scene of every library model compiles warning-free, strictly,
in double and in long double precision, with and without OpenMP (the batch entry point)."""
from __future__ import annotations

import subprocess

import pytest

import lagdsl
from lagdsl.run.toolchain import supports_openmp
from tests.conftest import MODELS
from tests.run.c_harness import STRICT_FLAGS, find_cc

SCENES = [(path.stem, scene) for path in sorted(MODELS.glob("*.lag"))
          for scene in (lagdsl.load(path).scenes or (None,))]


@pytest.mark.parametrize("model, scene", SCENES, ids=[f"{m}.{s}" for m, s in SCENES])
def test_generated_c_compiles_under_strict_flags(tmp_path, model, scene):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source = tmp_path / f"{model}.c"
    source.write_text(lagdsl.load(MODELS / f"{model}.lag").emit("c", scene).text)
    threading = ([], ["-fopenmp"]) if supports_openmp(cc) else ([],)
    for precision in ([], ["-DLAG_LONG_DOUBLE"]):
        for openmp in threading:
            done = subprocess.run([cc, *STRICT_FLAGS, *precision, *openmp, "-c", str(source), "-o",
                                   str(tmp_path / "m.o")], capture_output=True, text=True)
            assert done.returncode == 0, done.stderr
