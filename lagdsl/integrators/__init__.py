"""The bundled integrators: their records (registry.py), their C sources (package data, pasted
into generated files) and the NumPy backend's own methods (python/)."""
from __future__ import annotations

import re
from importlib import resources

from . import registry

COUNTER_LABELS = {"accepted": "steps accepted", "rejected": "rejected", "rhs_evals": "right-hand sides",
                  "jac_evals": "Jacobians", "lu_decomps": "LU", "newton_iters": "iterations",
                  "orders": "Taylor orders"}
# The times of a composite's first switches that its run summary reports (abi.summary_layout).
SWITCH_TIMES = 8                  # auto's switch times in a summary (LAG_AUTO_LOGGED in C)

# The stiffness test of the explicit pairs and auto's switches, the same rule on both backends
# (c/stiffness_test.c, c/auto.c and python/stiffness.py; emitted into C by codegen/c_abi.py; the
# pairs' stability boundaries are in their records). docs/numerics.md explains the rule.
STIFF_STEPS = 15                  # accepted steps beyond the stability boundary that call for a verdict
CALM_STEPS = 6                    # accepted steps within it, in a row, that clear the count
FAST_ITERATIONS = 8               # steps of power iteration on J^2 for the spectral radius rho
FAST_PROBE = 1e-3                 # the probe of y'' along the solution spans this fraction of 1/rho
EXCITED_AMPLITUDE = 100.0         # a fast mode above this many tolerances must be resolved
VERDICT_STIFF, VERDICT_OSCILLATION = 1, 2   # the kinds of verdict (0: none)
AUTO_CALM = 3.0                   # auto returns to dop853 when radau5's steps keep h rho below this ...
AUTO_GAIN = 2.0                   # ... or when they are not this many times dop853's steps


def integrator_files(name: str) -> tuple[str, ...]:
    """The C files that make up integrator `name`, in the order they are pasted."""
    record = registry.get(name)
    parts = [file for part in record.parts for file in integrator_files(part)]
    return tuple(dict.fromkeys([*parts, *record.c_fragments, record.c_file, *record.c_protocol]))


def integrator_source(name: str) -> str:
    """The C text of integrator `name`: its files in order, each part of a composite (with its
    fragments) renamed."""
    owner = {file: part for part in registry.get(name).parts for file in integrator_files(part)}
    texts = []
    for file in integrator_files(name):
        text = c_file(file)
        if file in owner:
            text = _rename_interface(text, owner[file])
        texts.append(text)
    return "\n".join(texts)


# The standalone program's C files, in the order they are pasted (c/standalone_input.c says what each holds).
STANDALONE_FILES = ("standalone_input.c", "standalone_output.c", "standalone_batch.c", "standalone.c")


def standalone_source() -> str:
    """The C text of the standalone program: its files in order."""
    return "\n".join(c_file(file) for file in STANDALONE_FILES)


def c_file(name: str) -> str:
    """A bundled C fragment (runtime.h, lu.c, an integrator file)."""
    return resources.files(__name__).joinpath("c").joinpath(name).read_text(encoding="utf-8")


def _rename_interface(text: str, prefix: str) -> str:
    """lag_stepper* -> PREFIX_stepper*, lag_stats -> PREFIX_stats, LAG_INTEGRATOR_NAME -> LAG_PREFIX_NAME."""
    text = re.sub(r"\blag_stepper", f"{prefix}_stepper", text)
    text = re.sub(r"\blag_stats\b", f"{prefix}_stats", text)
    return re.sub(r"\bLAG_INTEGRATOR_NAME\b", f"LAG_{prefix.upper()}_NAME", text)
