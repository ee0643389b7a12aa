"""dopri5 and dop853 form their continuous extension only on the steps that contain an output time.

The output grid does not change the steps (the driver steps until it passes an output time), so
a fine grid, which asks the dense output about every step, and a coarse one, which asks about a
few, take the same steps; where both ask, the rows must agree bit for bit, whatever the order in
which the driver projects, restarts and evaluates. dop853's three extra stages are spent only
on the steps asked about, which the right-hand-side count shows.
"""
from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import library_model

CASES = [("double_pendulum.lag", "chaos", 5.0), ("cartesian_pendulum.lag", "swing", 2.0)]   # the second projects


def run(path, scene, stop, integrator, interval):
    return library_model(path.removesuffix(".lag")).simulate(scene, integrator=integrator, stop=stop,
                                                             interval=interval, rtol=1e-9, atol=1e-11)


def common_rows(fine, coarse):
    """Indices of the coarse grid's times in the fine grid (both multiples of the fine interval)."""
    index = {t: i for i, t in enumerate(fine.t)}
    return [index[t] for t in coarse.t]


@pytest.mark.parametrize("path, scene, stop", CASES)
@pytest.mark.parametrize("integrator", ["dopri5", "dop853"])
def test_dense_rows_do_not_depend_on_which_steps_are_asked(path, scene, stop, integrator):
    fine = run(path, scene, stop, integrator, 0.01)
    coarse = run(path, scene, stop, integrator, 0.25)
    for counter in ("accepted", "rejected"):
        assert fine.summary.count(counter) == coarse.summary.count(counter)
    rows = common_rows(fine, coarse)
    assert len(rows) == len(coarse.t) > 2
    for column in coarse.columns:
        assert np.array_equal(fine[column][rows], coarse[column], equal_nan=True), column
    extra = fine.summary.count("rhs_evals") - coarse.summary.count("rhs_evals")
    if integrator == "dopri5":
        assert extra == 0                        # its extension needs no further stage
    else:
        # 3 stages per step asked about: nearly every step of the fine grid, few of the coarse
        assert extra % 3 == 0 and extra >= 3 * (fine.summary.count("accepted") // 2)
