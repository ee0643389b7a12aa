"""Library models loaded once per test session, and FMUs of them written to files, for the FMU tests."""
from __future__ import annotations

from pathlib import Path

from lagdsl.fmu import build_fmu
from tests.conftest import library_model as load     # loaded once per session


def fmu_file(folder: Path, name: str, scene: str | None = None, kinds: tuple[str, ...] | None = None,
             version: int = 2) -> Path:
    """The FMU of a library model's scene, written to `folder`."""
    path = folder / f"{name}.{scene or 'first'}.{'-'.join(kinds or ('default',))}.fmi{version}.fmu"
    path.write_bytes(build_fmu(load(name), scene, version, kinds))
    return path
