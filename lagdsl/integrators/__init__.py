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


# The work counters each integrator keeps: the fields of the lag_stats its C file defines, in
# the order the run summary reports them. A fixed step is never rejected; only radau5 forms
# Jacobians and LU factors; gauss counts fixed-point sweeps and radau5 Newton iterations.
COUNTERS = {
    "rk4": ("accepted", "rhs_evals"),
    "gauss": ("accepted", "rhs_evals", "newton_iters"),
    "dopri5": ("accepted", "rejected", "rhs_evals"),
    "dop853": ("accepted", "rejected", "rhs_evals"),
    "radau5": ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"),
}
COUNTER_LABELS = {"accepted": "steps accepted", "rejected": "rejected", "rhs_evals": "right-hand sides",
                  "jac_evals": "Jacobians", "lu_decomps": "LU", "newton_iters": "iterations"}
