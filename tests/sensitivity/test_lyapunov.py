"""Lyapunov exponents (sensitivity/lyapunov.py): closed forms, integrable and chaotic library
models, the Hamiltonian pairing, and `lagc lyapunov`'s output and bad input."""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import LagError
from tests.conftest import MODELS, lagc_in_process, library_model

SPRING = """model {name}
  parameter m = 1.0 [kg];
  parameter k = 4.0 [N/m];
  coordinate x(start = 0.3) [m];
  T = m/2*der(x)^2;
  U = {sign}k/2*x^2;
  scene run
    time(stop = 10, interval = 0.1);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
  end run;
end {name};
"""


@pytest.fixture(scope="module")
def springs(tmp_path_factory):
    """(oscillator, inverted oscillator) with k/m = 4: exponents 0 and ±2 1/s."""
    folder = tmp_path_factory.mktemp("springs")
    paths = []
    for name, sign in (("Oscillator", ""), ("Inverted", "-")):
        path = folder / f"{name.lower()}.lag"
        path.write_text(SPRING.format(name=name, sign=sign))
        paths.append(path)
    return tuple(paths)


def test_the_inverted_oscillator_has_the_exponents_plus_and_minus_sqrt_k_over_m(springs):
    # x'' = (k/m) x: the tangent map is [[cosh, sinh/w], [w sinh, cosh]](w t), w = sqrt(k/m) = 2,
    # so the exponents are ±w, reached as log(cosh-like factor)/T: within 0.03 after 10 s.
    spectrum = lagdsl.load(springs[1]).lyapunov(all=True)
    assert spectrum.exponents[0] == pytest.approx(2.0, abs=0.03)
    assert spectrum.exponents[0] + spectrum.exponents[1] == pytest.approx(0.0, abs=1e-9)
    assert spectrum.hamiltonian.pair_sums[0] == pytest.approx(0.0, abs=1e-9)
    assert spectrum.running.shape == (10, 2)
    assert spectrum.growth[0].kind == "exponential" and spectrum.growth[0].rate == pytest.approx(2.0, abs=0.03)
    np.testing.assert_allclose(spectrum.times, np.arange(1.0, 11.0))


def test_the_harmonic_oscillator_exponents_stay_below_1e_3_over_1000_s(springs):
    # isochronous: tangent vectors stay bounded, so |λ| <= log(ratio of their lengths)/T = log(2)/1000;
    # k = 1/4 (a period of 4π s) and rtol 1e-8 keep the 1000 s run to a few seconds
    spectrum = lagdsl.load(springs[0]).lyapunov(stop=1000, all=True, set={"k": 0.25}, rtol=1e-8, atol=1e-10,
                                                renormalise=10)
    assert max(abs(value) for value in spectrum.exponents) < 1e-3
    assert spectrum.hamiltonian.deviation < 1e-3
    for growth in spectrum.growth:
        assert growth.kind == "bounded" and abs(growth.rate) < 1e-3, growth
    assert spectrum.growth[0].window == (100.0, 1000.0) and spectrum.growth[0].points == 91


@pytest.mark.slow
def test_kepler_grows_as_t_and_its_exponential_rate_is_below_1e_3():
    """e = 0.5 (periapsis r = 1, r theta' = sqrt(1 + e)) over 1000 s. The tangent vectors grow
    linearly (the period depends on the energy: a shear), so the plain finite-time estimate is
    log(c t)/t, 6.8e-3 1/s, not below 1e-3; the fit of log|v| = a + b log t + λ t tells the
    growth is algebraic with b = 1 within its error and puts every exponential rate below 1e-3.
    The pairs of the fitted rates sum to zero as the records do (the fit is linear)."""
    spectrum = library_model("kepler").lyapunov(stop=1000, all=True, set={"theta.velocity": 1.5 ** 0.5})
    largest = spectrum.growth[0]
    assert spectrum.largest > 1e-3
    assert largest.kind == "algebraic" and abs(largest.power - 1) < 3 * largest.power_error, largest
    assert all(abs(fit.rate) < 1e-3 and fit.rate_error < 1e-3 for fit in spectrum.growth), spectrum.growth
    assert [fit.kind for fit in spectrum.growth[1:3]] == ["bounded", "bounded"]
    assert abs(spectrum.growth[0].rate + spectrum.growth[3].rate) < 1e-9
    assert max(abs(value) for value in spectrum.hamiltonian.pair_sums) < 1e-9


@pytest.mark.slow
def test_henon_heiles_at_the_escape_energy_has_a_positive_largest_exponent():
    """E = 1/6 from the model's start (y0 = 0.1, vy0 = 0.1) lies in the chaotic sea: the largest
    exponent settles near 0.15 1/s and its growth is exponential; the regular orbit at E = 1/24
    grows as a power of t, its exponential rate not distinguishable from zero."""
    model = library_model("henon_heiles")
    chaotic = model.lyapunov(stop=500, set={"E": 1 / 6})
    regular = model.lyapunov("regular", stop=500)
    assert 0.03 < chaotic.largest < 0.3
    assert chaotic.growth[0].kind == "exponential" and chaotic.growth[0].rate > 0.03
    assert regular.largest < chaotic.largest / 5
    assert regular.growth[0].kind == "algebraic" and abs(regular.growth[0].rate) < 1e-3


@pytest.mark.slow
def test_the_double_pendulum_spectrum_pairs_to_zero():
    spectrum = library_model("double_pendulum").lyapunov(stop=20, all=True)
    assert spectrum.largest > 0.1
    assert max(abs(value) for value in spectrum.hamiltonian.pair_sums) < 1e-3
    assert abs(sum(spectrum.exponents)) < 1e-3         # the flow keeps volume in (q, p)
    rates = [fit.rate for fit in spectrum.growth]
    assert spectrum.growth[0].kind == "exponential" and rates[0] > 0.1
    assert max(abs(rates[i] + rates[3 - i]) for i in range(2)) < 1e-3


def test_a_record_too_short_is_not_fitted(springs):
    spectrum = lagdsl.load(springs[1]).lyapunov(stop=4)
    assert spectrum.growth is None
    assert "growth not fitted: fewer than 5 re-orthonormalisations" in spectrum.render()


def test_lagc_lyapunov_prints_the_exponents_and_writes_the_record(springs, tmp_path):
    record = tmp_path / "conv.csv"
    done = lagc_in_process("lyapunov", springs[1], "--all", "--stop", "4", "--renormalise", "0.5", "-o", record)
    assert done.returncode == 0, done.stderr
    assert "lambda_1 =  2.0" in done.stdout and "1/s" in done.stdout
    assert "lambda_1 + lambda_2 =" in done.stdout
    assert "growth fitted as log|v| = a + b log t + lambda t over t = 0.5 .. 4 s" in done.stdout
    assert "lambda_1: rate  1.9" in done.stdout and ": exponential" in done.stdout
    lines = record.read_text().splitlines()
    assert lines[0] == "t [s],lambda_1 [1/s],lambda_2 [1/s]"
    assert len(lines) == 1 + 8


def test_lagc_lyapunov_plots_the_convergence(springs, tmp_path):
    pytest.importorskip("matplotlib")
    picture = tmp_path / "conv.png"
    done = lagc_in_process("lyapunov", springs[1], "--stop", "2", "--plot", picture)
    assert done.returncode == 0, done.stderr
    assert picture.read_bytes().startswith(b"\x89PNG")


@pytest.mark.parametrize("arguments, message", [
    (("--scene", "nope"), "error: no scene 'nope' in model Inverted"),
    (("--stop", "0"), "error: the stop time 0 is not after the start time 0"),
    (("--renormalise", "-1"), "--renormalise: lyapunov: the re-orthonormalisation interval must be a positive number"),
    (("--set", "q=1"), "'q'"),
])
def test_bad_options_exit_2_without_a_traceback(springs, arguments, message):
    done = lagc_in_process("lyapunov", springs[1], *arguments)
    assert done.returncode == 2, done.stderr
    assert message in done.stderr
    assert "Traceback" not in done.stderr


def test_a_constrained_model_is_refused_at_its_constraint():
    done = lagc_in_process("lyapunov", MODELS / "atwood.lag", "--stop", "1")
    assert done.returncode == 2
    assert "atwood.lag:18:3: error: lyapunov: constraint 'string' is active" in done.stderr
    assert "Traceback" not in done.stderr


def test_a_model_with_nothing_to_integrate_is_refused(tmp_path):
    path = tmp_path / "empty.lag"
    path.write_text("model Empty\n  parameter k = 1.0;\n  T = 0;\n  U = k;\nend Empty;\n")
    done = lagc_in_process("lyapunov", path)
    assert done.returncode == 2
    assert "empty.lag:1:7: error: model Empty declares no coordinate: there is nothing to integrate" in done.stderr


def test_the_api_refuses_an_unknown_option(springs):
    with pytest.raises(LagError, match="unknown option 'tolerance'"):
        lagdsl.load(springs[1]).lyapunov(tolerance=1e-3)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_qr_factors_of_a_symplectic_map_pair_from_the_lagrangian_frame(n):
    # the property the Hamiltonian check rests on (module docstring): exact at any T, not in the limit
    import scipy.linalg
    from lagdsl.sensitivity.lyapunov import _lagrangian_frame
    J = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    H = np.random.default_rng(n).standard_normal((2 * n, 2 * n))
    S = scipy.linalg.expm(J @ (H + H.T))
    logs = np.log(np.abs(np.diag(np.linalg.qr(S @ _lagrangian_frame(n), mode="r"))))
    np.testing.assert_allclose(logs + logs[::-1], 0.0, atol=1e-10)
