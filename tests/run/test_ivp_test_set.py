"""Library models against published references: the Test Set for IVP Solvers (F. Mazzia,
C. Magherini, release 2.4) problems "andrews" and "caraxis", and the stiff elastic pendulum
against the rigid pendulum it tends to. Each with the explicit dop853 and the implicit radau5."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.conftest import library_model

pytestmark = pytest.mark.slow      # long reference runs; the default run has closed forms of each kind

# The test set's reference solutions (computed there with PSIDE / RADAU at tolerance 1e-14)
ANDREWS_AT_0_03 = {
    "beta": 15.81077119629904, "theta": -15.75637105984298, "gamma": 0.04082224013073101,
    "phi": -0.5347301163226948, "delta": 0.5244099658805304, "omega": 0.5347301163226948,
    "epsilon": 1.048080741042263,
}
CAR_AXIS_AT_3 = {
    "xl": 0.04934557842755629, "yl": 0.4969894602303324,
    "xr": 1.041742524885400, "yr": 0.3739110272652214,
    # the multipliers agree too: the test set writes m q'' = f + G^T lambda with the same rows
    "multiplier(guide)": -0.4736886750784630e-2, "multiplier(axle)": -0.1104680411345730e-2,
}

# model, scene, its reference, the reference time; the integrator with its tolerances; the
# accepted relative error (the measured worst in the comment)
REFERENCE_RUNS = [
    ("andrews", "squeeze", ANDREWS_AT_0_03, 0.03, "dop853", 1e-10, 1e-12, 1e-7),    # 3e-10
    ("andrews", "squeeze", ANDREWS_AT_0_03, 0.03, "radau5", 1e-10, 1e-12, 1e-7),    # 1.3e-9
    ("car_axis", "bumps", CAR_AXIS_AT_3, 3.0, "dop853", 1e-10, 1e-12, 1e-6),        # 2e-12
    ("car_axis", "bumps", CAR_AXIS_AT_3, 3.0, "radau5", 1e-8, 1e-10, 1e-6),         # 1.4e-8
]


@pytest.mark.parametrize("model, scene, reference, t_end, integrator, rtol, atol, accepted",
                         REFERENCE_RUNS, ids=[f"{r[0]}-{r[4]}" for r in REFERENCE_RUNS])
def test_reference_solution(model, scene, reference, t_end, integrator, rtol, atol, accepted):
    result = library_model(model).simulate(scene, integrator=integrator,
                                                           rtol=rtol, atol=atol)
    assert result.t[-1] == pytest.approx(t_end)
    worst = max(abs(result[name][-1] - value) / abs(value) for name, value in reference.items())
    assert worst < accepted
    assert result.summary.residual_max < 1e-12


def rigid_pendulum_angle(t: np.ndarray, phi0: float = 1.0, g_over_l: float = 9.81) -> np.ndarray:
    solution = solve_ivp(lambda _, y: [y[1], -g_over_l * np.sin(y[0])], (t[0], t[-1]), [phi0, 0.0],
                         method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t)
    return solution.y[0]


def elastic_pendulum(k: float, **options):
    return library_model("elastic_pendulum").simulate("stiff", k=k, **options)


def test_radau5_steps_stay_flat_as_the_spring_stiffens():
    """k from 1e2 (soft: the spring's motion is resolved) to 1e12 (a vibration at 1e6 rad/s
    that no step resolves): radau5 completes every run, and once stiff the step count no
    longer grows with k (measured at rtol 1e-6: 559, 2241, 256, 164, 164, 164 steps)."""
    accepted = {}
    for exponent in range(2, 13, 2):
        result = elastic_pendulum(10.0 ** exponent)
        assert result.t[-1] == pytest.approx(10.0)
        accepted[exponent] = result.summary.count("accepted")
    assert all(accepted[e] < 300 for e in (6, 8, 10, 12)), accepted
    stiff = [accepted[e] for e in (8, 10, 12)]
    assert max(stiff) <= 1.1 * min(stiff), accepted


@pytest.mark.parametrize("k, rtol, tolerance", [(1e8, 1e-10, 1e-5), (1e12, 1e-10, 1e-7),
                                                (1e12, 1e-6, 1e-5)])
def test_stiff_spring_swings_like_the_rigid_pendulum(k, rtol, tolerance):
    """The angle differs from the rigid pendulum's by the spring's O(mg/k) stretch (measured
    over 10 s: 2.8e-6 at k = 1e8) and by the integration error (3e-6 at rtol 1e-6)."""
    result = elastic_pendulum(k, rtol=rtol, atol=rtol * 1e-3)
    rigid = rigid_pendulum_angle(result.t)
    assert np.max(np.abs(result["phi"] - rigid)) < tolerance
    # the spring stays at its static extension, m (g cos(phi) + l phi'^2) / k at most 3 g / k
    assert np.max(np.abs(result["s"])) < 3 * 9.81 / k


def test_dop853_on_the_soft_spring_matches_radau5():
    model = library_model("elastic_pendulum")
    explicit = model.simulate("soft")
    implicit = model.simulate("soft", integrator="radau5", rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(explicit.values - implicit.values)) < 1e-6
    # nothing dissipates: the energy is conserved by both (the radau5 run to its tolerance)
    assert dict((n, d) for n, _, d in explicit.summary.invariants)["energy"] < 1e-8
