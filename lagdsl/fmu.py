"""A scene as an FMU (Functional Mock-up Interface 2.0 or 3.0): one zip archive with
modelDescription.xml, the C sources and the binary for this platform.

    ScenePlan ──fmu_plan──▶ ScenePlan (+ energy, momenta, multipliers) ──lower──▶ Kernel
              ──fmu_variables──▶ variables ──model_description──▶ modelDescription.xml
    Kernel + variables ──render_context(fmu=fmu_c_part)──▶ sources/ID.c ──compile──▶ binaries/PLATFORM/ID.so

The lowered and printed scene serves both FMI versions (fmu_source), and the C file is kept in
the build cache as a run's is (codegen/kept.py): a second export of the scene lowers nothing.

The archive is the same bytes for the same export (its entries sorted, with a fixed date): the
binary is built with fixed flags and stripped, and cached by content hash as the libraries of
`lagc run` are (run/cache.py). The binary is for this machine's platform; the sources build it
for others (with the FMI headers they ship: the Modelica Association's, integrators/c/third_party/fmi/).
"""
from __future__ import annotations

import hashlib
import io
import platform
import uuid
import weakref
import zipfile
from importlib import resources

from . import __version__
from .codegen import GeneratedSource
from .codegen.c import c_context, render_context
from .codegen.fmu import KINDS, FmuVariable, exported_kinds, fmu_c_part, fmu_plan, fmu_variables
from .codegen.fmu_xml import build_description, model_description
from .codegen.kept import kept_source
from .codegen.kernel import lower_to_kernel
from .errors import LagError, Setting
from .run.cache import cached_entry
from .run.toolchain import compile_c, find_compiler
from .scene import ScenePlan
from .settings import Overrides

FMI_VERSIONS = (2, 3)
# Portable (no -march=native: the FMU travels), exported symbols the FMI functions only, no
# symbol table (it would name the temporary build directory: the bytes would differ per build).
FMU_FLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-s")
# The Modelica Association's headers, vendored unchanged (their licence beside them).
FMI_HEADERS = resources.files("lagdsl.integrators").joinpath("c", "third_party", "fmi")
HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
           3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}
# (system, machine) -> the binaries/ directory of FMI 2 and of FMI 3, and the library's suffix.
PLATFORMS = {("Linux", "x86_64"): ("linux64", "x86_64-linux", ".so"),
             ("Linux", "aarch64"): (None, "aarch64-linux", ".so"),
             ("Darwin", "x86_64"): ("darwin64", "x86_64-darwin", ".dylib"),
             ("Darwin", "arm64"): (None, "aarch64-darwin", ".dylib")}
# The archive's entries are dated the earliest a zip can say, whenever it is made.
ZIP_DATE = (1980, 1, 1, 0, 0, 0)
# A scene's FMU Kernel and C context by (scene, kinds), kept while its api.Model lives.
_LOWERED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def build_fmu(model, scene: str | None = None, version: int = 2, kinds: tuple[str, ...] | None = None) -> bytes:
    """The FMU of a scene of `model` (an api.Model) for model exchange and/or co-simulation
    (`kinds`: "me", "cs"; by default both, codegen.fmu.exported_kinds), as the bytes of its zip archive."""
    scene_plan = model.plan(scene)
    kinds = exported_kinds(scene_plan, kinds)
    check_export(version, kinds)
    plan = fmu_plan(scene_plan, kinds)
    variables = fmu_variables(plan, kinds, version)
    token = export_token(model.source.text, plan.scene_name, version, kinds)
    generated = kept_source(model.source, scene, Overrides(), False, f"fmi{version}-{'-'.join(kinds)}",
                            lambda: fmu_source(model, plan, variables, kinds, version, token))
    identifier, source = generated.suggested_name, generated.text
    folder, suffix = binary_platform(version)
    files = {"modelDescription.xml": model_description(plan, variables, kinds, version, identifier, token),
             f"sources/{identifier}.c": source.encode(),
             f"binaries/{folder}/{identifier}{suffix}": compile_binary(source, identifier, version),
             "documentation/licenses/fmi-headers.txt": _header_file("LICENSE.txt")}
    files.update({f"sources/{name}": _header_file(name) for name in HEADERS[version]})
    if version == 3:
        files["sources/buildDescription.xml"] = build_description(identifier)
    return archive(files)


def fmu_source(model, plan: ScenePlan, variables: tuple[FmuVariable, ...], kinds: tuple[str, ...], version: int,
               token: str) -> GeneratedSource:
    """The FMU's C file. The scene is lowered and printed once for its kinds, and kept while the
    model lives (_LOWERED): the FMI versions differ only in the FMU's part (codegen/fmu.py)."""
    lowered = _LOWERED.setdefault(model, {})
    key = (plan.scene_name, kinds)
    if key not in lowered:
        kernel = lower_to_kernel(model.equations, plan)                  # -> Kernel (+ the FMU's outputs)
        lowered[key] = kernel, c_context(kernel, model.source.name, elsewhere=True)
    kernel, context = lowered[key]
    return render_context(context, fmu=fmu_c_part(kernel, plan, variables, kinds, version, token))


def check_export(version: int, kinds: tuple[str, ...]) -> None:
    if version not in FMI_VERSIONS:
        raise LagError(f"FMI version {version}: lagc exports " + " and ".join(f"{v}.0" for v in FMI_VERSIONS)
                       + " (--fmi " + " or ".join(map(str, FMI_VERSIONS)) + ")", Setting("--fmi"))
    if not kinds or any(kind not in KINDS for kind in kinds):
        raise LagError(f"FMU kinds {', '.join(kinds) or 'none'}: choose from cs (co-simulation) and me "
                       "(model exchange)")


def export_token(model_text: str, scene: str, version: int, kinds: tuple[str, ...]) -> str:
    """The GUID (instantiation token) of an export: from what makes it, so the same every time."""
    made_from = "\0".join((__version__, model_text, scene, str(version), *sorted(kinds)))
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "lagdsl:" + hashlib.sha256(made_from.encode()).hexdigest())) + "}"


def binary_platform(version: int) -> tuple[str, str]:
    """The binaries/ directory of this machine in FMI `version`, and the shared library's suffix."""
    system, machine = platform.system(), platform.machine()
    folders = PLATFORMS.get((system, machine))
    folder = folders and folders[version - 2]
    if folder is None:
        raise LagError(f"FMI {version}.0 names no binaries/ directory for {system} on {machine} that lagc knows; "
                       "export FMI 3.0 (--fmi 3), or build the FMU's sources on a platform it names")
    return folder, folders[2]


def compile_binary(source: str, identifier: str, version: int) -> bytes:
    """The FMU's shared library, built with FMU_FLAGS and the FMI headers, cached by content hash."""
    compiler = find_compiler()
    key = hashlib.sha256("\0".join((source, compiler, *FMU_FLAGS, str(version))).encode()).hexdigest()
    with resources.as_file(FMI_HEADERS) as headers:
        flags = (*FMU_FLAGS, "-I", str(headers))
        entry = cached_entry(f"{identifier}-fmi{version}-{key[:20]}.so", key,
                             lambda path: compile_c(source, path, flags, compiler))
    return entry.read_bytes()


def archive(files: dict[str, bytes]) -> bytes:
    """A zip of `files` (name -> bytes), the same bytes for the same files: entries sorted, dated
    ZIP_DATE, Unix modes (the binaries executable)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zipped:
        for name in sorted(files):
            info = zipfile.ZipInfo(name, date_time=ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.create_system = 3
            info.external_attr = (0o755 if name.startswith("binaries/") else 0o644) << 16
            zipped.writestr(info, files[name], compresslevel=9)
    return buffer.getvalue()


def _header_file(name: str) -> bytes:
    return FMI_HEADERS.joinpath(name).read_bytes()
