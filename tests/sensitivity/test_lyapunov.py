"""Lyapunov exponents (sensitivity/lyapunov.py): closed forms, integrable and chaotic library
models, the Hamiltonian pairing, and `lagc lyapunov`'s output and bad input."""
from __future__ import annotations

import numpy as np
import pytest

import lagdsl
from lagdsl.errors import LagError
from tests.conftest import MODELS, lagc_in_process, library_model, model_file

CARTESIAN_DOUBLE_PENDULUM = """model CartesianDouble
  parameter m1 = 1.0 [kg];
  parameter m2 = 1.0 [kg];
  parameter l1 = 1.0 [m];
  parameter l2 = 1.0 [m];
  parameter g = 9.81 [m/s^2];
  coordinate x1(start = l1*sin(1.0)) [m];
  coordinate y1(start = l1*cos(1.0)) [m]   "down";
  coordinate x2(start = l1*sin(1.0) + l2*sin(2.0)) [m];
  coordinate y2(start = l1*cos(1.0) + l2*cos(2.0)) [m];
  T = m1/2*(der(x1)^2 + der(y1)^2) + m2/2*(der(x2)^2 + der(y2)^2);
  U = -m1*g*y1 - m2*g*y2;
  constraint rod1: x1^2 + y1^2 = l1^2;
  constraint rod2: (x2 - x1)^2 + (y2 - y1)^2 = l2^2;
  scene chaos
    time(stop = 20, interval = 0.01);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
  end chaos;
end CartesianDouble;
"""

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
def springs():
    """(oscillator, inverted oscillator) with k/m = 4: exponents 0 and ±2 1/s."""
    return tuple(model_file(SPRING.format(name=name, sign=sign), name.lower())
                 for name, sign in (("Oscillator", ""), ("Inverted", "-")))


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


INVERTED_ON_A_LINE = """model OnALine
  parameter m = 1.0 [kg];
  parameter k = 4.0 [N/m];
  coordinate x(start = 0.3) [m];
  coordinate y(start = 0.3) [m];
  T = m/2*(der(x)^2 + der(y)^2);
  U = -k/2*(x^2 + y^2);
  constraint line: y = x;
  scene run
    time(stop = 10, interval = 0.1);
    integrator dop853(rtol = 1e-10, atol = 1e-12);
  end run;
end OnALine;
"""


@pytest.fixture(scope="module")
def on_a_line():
    """The inverted oscillator in Cartesian coordinates, held to the line y = x by a constraint:
    along it s'' = (k/m) s, so the exponents are ±sqrt(k/m) = ±2 1/s, two of them (2n - h - m = 2)."""
    return lagdsl.load(model_file(INVERTED_ON_A_LINE, "on_a_line"))


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_a_constrained_model_has_the_exponents_of_its_motion_on_the_constraint(on_a_line, backend):
    spectrum = on_a_line.lyapunov(all=True, backend=backend)
    assert len(spectrum.exponents) == 2
    assert spectrum.exponents[0] == pytest.approx(2.0, abs=0.03)
    assert spectrum.exponents[1] == pytest.approx(-2.0, abs=0.03)
    assert spectrum.growth[0].kind == "exponential"
    assert spectrum.hamiltonian is None         # measured in (q, q'): the pairs hold in the limit only


def test_the_c_backend_carries_the_same_tangent_vectors(on_a_line):
    numpy, c = (library_model("double_pendulum").lyapunov(stop=5, all=True, backend=b) for b in ("numpy", "c"))
    np.testing.assert_allclose(c.running, numpy.running, atol=1e-8)
    assert c.solver.startswith("dop853 (C, rtol 1e-10")
    numpy, c = (on_a_line.lyapunov(stop=4, backend=b) for b in ("numpy", "c"))
    np.testing.assert_allclose(c.running, numpy.running, atol=1e-8)


def test_the_c_backend_stands_dop853_in_for_gauss():
    spectrum = library_model("kepler").lyapunov("symplectic", stop=3, backend="c")
    assert "dop853 (C" in spectrum.solver and "in place of the scene's gauss, which has no error control" \
        in spectrum.solver


@pytest.mark.slow
def test_the_double_pendulum_in_cartesian_coordinates_has_the_angles_exponents():
    """The same motion written in (x1, y1, x2, y2) with two rod constraints: the spectrum has
    2n - h - m = 4 exponents, as in angles; the finite-time estimates differ by the change of
    metric and of starting vectors, O(1)/T: 0.008 1/s for the largest after 20 s."""
    cartesian = lagdsl.load(model_file(CARTESIAN_DOUBLE_PENDULUM, "cartesian_double")).lyapunov(stop=20, all=True, backend="c")
    angles = library_model("double_pendulum").lyapunov(stop=20, all=True)
    assert len(cartesian.exponents) == 4
    assert cartesian.largest == pytest.approx(angles.largest, abs=0.03)
    assert abs(sum(cartesian.exponents)) < 0.1           # volume kept on the manifold, up to O(1)/T


def test_a_nonholonomic_model_has_2n_minus_m_exponents_and_no_exponential_growth():
    # the rolling penny (n = 4, two rolling constraints) is integrable: six exponents, none growing exponentially
    spectrum = library_model("rolling_penny").lyapunov(stop=50, all=True)
    assert len(spectrum.exponents) == 6
    assert all(fit.kind != "exponential" for fit in spectrum.growth), spectrum.growth


def test_lagc_lyapunov_runs_a_constrained_model_on_c():
    done = lagc_in_process("lyapunov", MODELS / "atwood.lag", "--all", "--stop", "0.6", "--renormalise", "0.1",
                           "--backend", "c")
    assert done.returncode == 0, done.stderr
    assert "lambda_2 =" in done.stdout and "lambda_3" not in done.stdout       # 2n - h - m = 2
    assert "dop853 (C, rtol 1e-10" in done.stdout


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
    from lagdsl.sensitivity.tangent import lagrangian_frame
    J = np.block([[np.zeros((n, n)), np.eye(n)], [-np.eye(n), np.zeros((n, n))]])
    H = np.random.default_rng(n).standard_normal((2 * n, 2 * n))
    S = scipy.linalg.expm(J @ (H + H.T))
    logs = np.log(np.abs(np.diag(np.linalg.qr(S @ lagrangian_frame(n), mode="r"))))
    np.testing.assert_allclose(logs + logs[::-1], 0.0, atol=1e-10)
