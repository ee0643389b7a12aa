"""The bundled integrators: C sources (package data, pasted into generated files) and the
NumPy backend's fixed-step methods."""

# Fragments an integrator file needs before it (after the model), in order.
SHARED_FRAGMENTS = {
    "rk4": ("fixed_step.c",),
    "gauss": ("fixed_step.c",),
    "dopri5": ("explicit_control.c",),
    "dop853": ("explicit_control.c",),
    "radau5": (),
}


def integrator_files(name: str) -> tuple[str, ...]:
    """The C files that make up integrator `name`, in the order they are pasted."""
    return (*SHARED_FRAGMENTS[name], f"{name}.c")
