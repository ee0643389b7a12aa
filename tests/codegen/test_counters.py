"""A scene's generated file names only the work counters its integrator keeps.

rk4 never rejects a step and forms no Jacobian, so its C file says nothing of rejected steps,
Jacobians, LU factorisations or iterations, in the stepper, the summary array or the text the
program prints (in the code the preprocessor keeps: the driver's parts for other integrators
stand behind #if LAG_HAS_... = 0); the run summary of both backends says the same.
"""
from __future__ import annotations

import re
import subprocess

import pytest

from lagdsl.integrators import COUNTER_LABELS, registry
from lagdsl.scene import Overrides
from tests.conftest import library_model
from tests.run.c_harness import find_cc

ALL_COUNTERS = set(COUNTER_LABELS)
OPTIONS = {"rk4": (("step", 0.01),), "gauss": (("step", 0.01),)}


@pytest.mark.parametrize("integrator", registry.names())
def test_the_c_file_names_exactly_the_counters_of_its_integrator(integrator):
    # Kepler in polar coordinates; the Nystrom pair needs accelerations free of the velocities
    model = library_model("pleiades" if integrator == "rkn8" else "kepler")
    text = preprocessed(model.emit("c", None, Overrides(integrator=integrator,
                                                        options=OPTIONS.get(integrator, ()))).text)
    named = {counter for counter in ALL_COUNTERS if re.search(rf"\b{counter}\b", text)}
    counters = registry.get(integrator).counters
    assert named == set(counters)
    assert ("Jacobians" in text) == ("jac_evals" in counters)
    assert ("rejected" in text) == ("rejected" in counters)


def preprocessed(text: str) -> str:
    """The code of a generated C file that its #if guards keep, without comments (and without the
    system headers, which are not ours)."""
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    ours = "\n".join(line for line in text.splitlines() if not line.startswith("#include <"))
    return subprocess.run([cc, "-E", "-P", "-x", "c", "-"], input=ours, capture_output=True, text=True,
                          check=True).stdout


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_an_rk4_summary_reports_steps_and_right_hand_sides_only(backend):
    wedge = library_model("wedge")
    summary = wedge.simulate(backend=backend, integrator="rk4", step=0.01, stop=0.1).summary
    assert [name for name, _ in summary.counters] == ["accepted", "rhs_evals"]
    assert summary.count("accepted") == 10 and summary.count("jac_evals") is None
    assert "Jacobians" not in summary.render() and "rejected" not in summary.render()
