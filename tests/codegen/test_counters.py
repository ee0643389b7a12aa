"""A scene's generated file names only the work counters its integrator keeps.

rk4 never rejects a step and forms no Jacobian, so its C file says nothing of rejected steps,
Jacobians, LU factorisations or iterations, in the stepper, the summary array or the text the
program prints; the run summary of both backends says the same.
"""
from __future__ import annotations

import re

import pytest

from lagdsl import ir
from lagdsl.integrators import COUNTERS
from lagdsl.scene import Overrides
from tests.conftest import library_model

ALL_COUNTERS = {"accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters"}
OPTIONS = {"rk4": (("step", 0.01),), "gauss": (("step", 0.01),)}


@pytest.mark.parametrize("integrator", ir.INTEGRATORS)
def test_the_c_file_names_exactly_the_counters_of_its_integrator(integrator):
    # Kepler in polar coordinates; the Nystrom pair needs accelerations free of the velocities
    model = library_model("pleiades" if integrator == "rkn8" else "kepler")
    text = model.emit("c", None, Overrides(integrator=integrator, options=OPTIONS.get(integrator, ()))).text
    named = {counter for counter in ALL_COUNTERS if re.search(rf"\b{counter}\b", text)}
    assert named == set(COUNTERS[integrator])
    assert ("Jacobians" in text) == ("jac_evals" in COUNTERS[integrator])
    assert ("rejected" in text) == ("rejected" in COUNTERS[integrator])


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_an_rk4_summary_reports_steps_and_right_hand_sides_only(backend):
    wedge = library_model("wedge")
    summary = wedge.simulate(backend=backend, integrator="rk4", step=0.01, stop=0.1).summary
    assert [name for name, _ in summary.counters] == ["accepted", "rhs_evals"]
    assert summary.count("accepted") == 10 and summary.count("jac_evals") is None
    assert "Jacobians" not in summary.render() and "rejected" not in summary.render()
