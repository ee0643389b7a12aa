"""The bundled integrators: C sources (package data, pasted into generated files) and the
NumPy backend's fixed-step methods."""
from __future__ import annotations

import re
from importlib import resources

# Fragments an integrator file needs before it (after the model), in order.
SHARED_FRAGMENTS = {
    "rk4": ("fixed_step.c",),
    "gauss": ("fixed_step.c",),
    "dopri5": ("explicit_control.c",),
    "dop853": ("explicit_control.c",),
    "radau5": (),
    "auto": (),
}
# Integrators built from others: each part is pasted with its interface renamed (lag_stepper ->
# dop853_stepper, lag_stepper_init -> dop853_stepper_init, ...), then the composite's own file
# defines lag_stepper over them.
COMPOSITES = {"auto": ("dop853", "radau5")}
# The explicit pairs, whose stiffness test (explicit_control.c) the run summary reports.
STIFFNESS_TESTED = ("dopri5", "dop853")


def integrator_files(name: str) -> tuple[str, ...]:
    """The C files that make up integrator `name`, in the order they are pasted."""
    parts = [file for part in COMPOSITES.get(name, ()) for file in integrator_files(part)]
    return tuple(dict.fromkeys([*parts, *SHARED_FRAGMENTS[name], f"{name}.c"]))


def integrator_source(name: str) -> str:
    """The C text of integrator `name`: its files in order, the parts of a composite renamed."""
    renamed = {f"{part}.c": part for part in COMPOSITES.get(name, ())}
    texts = []
    for file in integrator_files(name):
        text = c_file(file)
        if file in renamed:
            text = _rename_interface(text, renamed[file])
        texts.append(text)
    return "\n".join(texts)


def c_file(name: str) -> str:
    """A bundled C fragment (runtime.h, lu.c, an integrator file)."""
    return resources.files(__name__).joinpath("c").joinpath(name).read_text(encoding="utf-8")


def _rename_interface(text: str, prefix: str) -> str:
    """lag_stepper* -> PREFIX_stepper*, LAG_INTEGRATOR_NAME -> LAG_PREFIX_NAME."""
    text = re.sub(r"\blag_stepper", f"{prefix}_stepper", text)
    return re.sub(r"\bLAG_INTEGRATOR_NAME\b", f"LAG_{prefix.upper()}_NAME", text)
