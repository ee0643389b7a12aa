"""The bundled integrators: C sources (package data, pasted into generated files) and the
NumPy backend's fixed-step methods."""
from __future__ import annotations

import re
from importlib import resources

# Fragments an integrator file needs before it (after the model), in order.
SHARED_FRAGMENTS = {
    "rk4": ("fixed_step.c",),
    "gauss": ("fixed_step.c",),
    "dopri5": ("explicit_control.c", "stiffness_test.c"),
    "dop853": ("explicit_control.c", "stiffness_test.c"),
    "rkn8": ("explicit_control.c",),
    "radau5": (),
    "auto": (),
}
# Integrators built from others: each part is pasted, after its fragments, with its interface
# renamed (lag_stepper -> dop853_stepper, lag_stepper_init -> dop853_stepper_init, lag_stats ->
# dop853_stats, ...), then the composite's own file defines lag_stepper over them.
COMPOSITES = {"auto": ("dop853", "radau5")}
# The explicit pairs, whose stiffness test (explicit_control.c) the run summary reports.
STIFFNESS_TESTED = ("dopri5", "dop853")

# The work counters each integrator keeps: the fields of the lag_stats its C file defines, in
# the order the run summary reports them. A fixed step is never rejected; only radau5 forms
# Jacobians and LU factors; gauss counts fixed-point sweeps and radau5 Newton iterations.
COUNTERS = {
    "rk4": ("accepted", "rhs_evals"),
    "gauss": ("accepted", "rhs_evals", "newton_iters"),
    "dopri5": ("accepted", "rejected", "rhs_evals"),
    "dop853": ("accepted", "rejected", "rhs_evals"),
    "rkn8": ("accepted", "rejected", "rhs_evals"),
    "radau5": ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"),
    "auto": ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"),
}
COUNTER_LABELS = {"accepted": "steps accepted", "rejected": "rejected", "rhs_evals": "right-hand sides",
                  "jac_evals": "Jacobians", "lu_decomps": "LU", "newton_iters": "iterations"}
# The run summary's entries after the counters: the stiffness test's verdict (stiff, its time,
# accepted, rejected, rhs_evals then) and a composite's switches (count, two spans, the times).
STIFFNESS_ENTRIES = 5
SWITCH_TIMES = 8                  # LAG_AUTO_LOGGED in auto.c
SWITCH_ENTRIES = 3 + SWITCH_TIMES


def summary_extras(name: str) -> int:
    """How many summary entries follow integrator `name`'s counters (before the invariants)."""
    return (STIFFNESS_ENTRIES if name in STIFFNESS_TESTED else 0) + (SWITCH_ENTRIES if name in COMPOSITES else 0)


def integrator_files(name: str) -> tuple[str, ...]:
    """The C files that make up integrator `name`, in the order they are pasted."""
    parts = [file for part in COMPOSITES.get(name, ()) for file in integrator_files(part)]
    return tuple(dict.fromkeys([*parts, *SHARED_FRAGMENTS[name], f"{name}.c"]))


def integrator_source(name: str) -> str:
    """The C text of integrator `name`: its files in order, each part of a composite (with its
    fragments) renamed."""
    owner = {file: part for part in COMPOSITES.get(name, ()) for file in integrator_files(part)}
    texts = []
    for file in integrator_files(name):
        text = c_file(file)
        if file in owner:
            text = _rename_interface(text, owner[file])
        texts.append(text)
    return "\n".join(texts)


def c_file(name: str) -> str:
    """A bundled C fragment (runtime.h, lu.c, an integrator file)."""
    return resources.files(__name__).joinpath("c").joinpath(name).read_text(encoding="utf-8")


def _rename_interface(text: str, prefix: str) -> str:
    """lag_stepper* -> PREFIX_stepper*, lag_stats -> PREFIX_stats, LAG_INTEGRATOR_NAME -> LAG_PREFIX_NAME."""
    text = re.sub(r"\blag_stepper", f"{prefix}_stepper", text)
    text = re.sub(r"\blag_stats\b", f"{prefix}_stats", text)
    return re.sub(r"\bLAG_INTEGRATOR_NAME\b", f"LAG_{prefix.upper()}_NAME", text)
