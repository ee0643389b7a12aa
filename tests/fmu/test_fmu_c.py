"""The FMU's C under the strict flags, and every FMI function called in and out of order with
good and bad arguments (fmi2_calls.c, fmi3_calls.c) under the address and undefined-behaviour
sanitizers."""
from __future__ import annotations

import gc
import io
import subprocess
import weakref
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest

import lagdsl
from lagdsl.codegen.kernel import lower_to_kernel
from lagdsl.fmu import build_fmu
from lagdsl.source import SourceFile
from tests.conftest import MODELS, compiled, slow_unless_kept
from tests.fmu.fmu_files import load
from tests.run.c_harness import STRICT_FLAGS, find_cc

SANITIZERS = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer", "-g"]
CALLS = {version: Path(__file__).with_name(f"fmi{version}_calls.c") for version in (2, 3)}
# FMI 2.0 and 3.0: the instantiation token's attribute, and the derivatives' elements.
TOKEN = {2: "guid", 3: "instantiationToken"}
DERIVATIVES = {2: "ModelStructure/Derivatives/Unknown", 3: "ModelStructure/ContinuousStateDerivative"}


def unpack(fmu: bytes, folder: Path) -> tuple[Path, ET.Element]:
    """The FMU's files in `folder`: its C source, and its parsed modelDescription.xml."""
    with zipfile.ZipFile(io.BytesIO(fmu)) as archive:
        archive.extractall(folder)
    description = ET.parse(folder / "modelDescription.xml").getroot()
    identifier = description.find("*[@modelIdentifier]").get("modelIdentifier")
    return folder / "sources" / f"{identifier}.c", description


def reference(description: ET.Element, **attributes: str) -> str:
    """The value reference of the first variable with these attributes."""
    for variable in description.find("ModelVariables"):
        if all(variable.get(name) == value for name, value in attributes.items()):
            return variable.get("valueReference")
    raise AssertionError(f"no variable with {attributes}")


@pytest.fixture
def cc():
    compiler = find_cc()
    if compiler is None:
        pytest.skip("no C compiler")
    return compiler


FMU_SOURCES = [("double_pendulum", None, ("me", "cs")), ("rolling_penny", None, ("cs",)), ("rolling_penny", None, ("me",)),
               ("coupled_oscillators", "pluck", ("cs",)), ("bead_on_hoop", None, ("me", "cs")),
               ("fpu_chain", "implicit", ("me", "cs"))]          # the last takes 34 s of CPU


# The default run compiles both kinds of FMI 2 (a dense model) and both of FMI 3 (a rheonomic one);
# every other pair is slow.
@pytest.mark.parametrize("model, scene, kind, version", slow_unless_kept(
    [(*case, version) for case in FMU_SOURCES for version in (2, 3)],
    {("double_pendulum", None, ("me", "cs"), 2), ("bead_on_hoop", None, ("me", "cs"), 3)}))
def test_fmu_source_compiles_under_strict_flags(tmp_path, cc, model, scene, kind, version):
    source, _ = unpack(build_fmu(load(model), scene, version, kind), tmp_path)
    done = compiled([cc, *STRICT_FLAGS, "-fPIC", "-I", str(source.parent), "-c", str(source), "-o",
                     str(tmp_path / "fmu.o")])
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("version", [pytest.param(2, marks=pytest.mark.slow), 3])     # FMI 2's calls: slow
@pytest.mark.parametrize("model", ["double_pendulum", pytest.param("rolling_penny", marks=pytest.mark.slow)])
def test_every_function_in_and_out_of_order_under_sanitizers(tmp_path, cc, model, version):
    source, description = unpack(build_fmu(load(model), version=version), tmp_path)
    program = tmp_path / "calls"
    built = compiled([cc, *STRICT_FLAGS, *SANITIZERS, "-I", str(source.parent), str(CALLS[version]), str(source),
                      "-o", str(program), "-lm"])
    if built.returncode != 0 and "sanitize" in built.stderr:
        pytest.skip(f"the compiler has no sanitizers here: {built.stderr[:200]}")
    assert built.returncode == 0, built.stderr
    states = len(description.findall(DERIVATIVES[version]))
    references = [reference(description, causality="parameter", variability="tunable"),
                  reference(description, variability="continuous", initial="exact"),
                  reference(description, causality="output", initial="calculated"),
                  reference(description, name="integrator.max_steps"), "4294967295"]
    ran = subprocess.run([str(program), description.get(TOKEN[version]), *references, str(states)], capture_output=True,
                         text=True, timeout=300)
    assert ran.returncode == 0 and ran.stdout.endswith("ok\n"), ran.stdout[-2000:] + ran.stderr[-3000:]
    assert "runtime error" not in ran.stderr and "Sanitizer" not in ran.stderr, ran.stderr
    assert "logStatusError" in ran.stdout        # the refusals went through the logger


def test_both_fmi_versions_print_a_scene_lowered_once_while_its_model_lives(monkeypatch):
    """The two FMI versions of a scene share its lowering and printing (fmu._LOWERED), which
    goes with the model."""
    from lagdsl import fmu
    from lagdsl.codegen.fmu import exported_kinds, fmu_plan, fmu_variables
    lowerings = []
    monkeypatch.setattr(fmu, "lower_to_kernel", lambda *arguments: lowerings.append(1) or lower_to_kernel(*arguments))
    model = lagdsl.Model(SourceFile.read(MODELS / "double_pendulum.lag"))
    scene = model.plan(None)
    kinds = exported_kinds(scene, None)
    plan = fmu_plan(scene, kinds)
    texts = [fmu.fmu_source(model, plan, fmu_variables(plan, kinds, version), kinds, version, "{token}").text
             for version in (2, 3)]
    assert len(lowerings) == 1 and "fmi2Instantiate" in texts[0] and "fmi3InstantiateModelExchange" in texts[1]
    released = weakref.ref(model)
    del model
    gc.collect()
    assert released() is None                  # _LOWERED does not keep it
