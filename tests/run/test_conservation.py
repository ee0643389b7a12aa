"""Conserved quantities and constraint residuals over whole library scenes (C backend)."""
from __future__ import annotations

import numpy as np

from tests.conftest import library_model


def drifts(result) -> dict[str, float]:
    """Relative drift max |I - I0| / max(|I0|, 1e-300) of each watched invariant."""
    return {name: drift / max(abs(start), 1e-300) for name, start, drift in result.summary.invariants}


def test_heavy_top_keeps_both_momenta_and_energy():
    result = library_model("heavy_top").simulate("nutation")
    assert set(drifts(result)) == {"momentum(phi)", "momentum(psi)", "energy"}
    assert max(drifts(result).values()) < 1e-9


def test_kepler_ten_orbits_adaptive_and_symplectic():
    model = library_model("kepler")
    adaptive = drifts(model.simulate("ellipse"))
    assert adaptive["momentum(theta)"] < 1e-10 and adaptive["energy"] < 1e-9
    symplectic = model.simulate("symplectic", stop=600.0)       # about 100 orbits
    assert drifts(symplectic)["energy"] < 1e-11
    assert drifts(symplectic)["momentum(theta)"] < 1e-12


def test_rolling_penny_stays_on_its_constraints_and_conserves_energy():
    result = library_model("rolling_penny").simulate("roll")
    assert result.summary.residual_max < 1e-12
    assert np.max(np.abs(result["residual(roll_x)"])) < 1e-12
    # h starts near 0 (T and U nearly cancel), so compare the drift with the kinetic energy
    # scale m (a phi')^2 ~ 1e-4 J instead.
    energy_drift = dict((name, drift) for name, _, drift in result.summary.invariants)["energy"]
    assert energy_drift < 1e-11
    assert drifts(result)["momentum(theta)"] < 1e-12


def test_cartesian_pendulum_rod_length_is_kept():
    result = library_model("cartesian_pendulum").simulate("swing", stop=100.0)
    assert np.max(np.abs(result["x"]**2 + result["y"]**2 - 1.0)) < 1e-12
    assert drifts(result)["energy"] < 1e-8


def test_chain_energy():
    result = library_model("pendulum_chain").simulate("swing")
    assert drifts(result)["energy"] < 1e-6


def test_damped_pendulum_loses_energy_to_dissipation_when_undriven():
    result = library_model("damped_driven_pendulum").simulate("driven", A=0.0)
    energy = result["energy"]
    assert np.all(np.diff(energy) <= 1e-12)          # dh/dt = -b theta'^2 <= 0
    assert energy[-1] < energy[0]
