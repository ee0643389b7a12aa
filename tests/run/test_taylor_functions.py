"""taylor's own sin, cos and step root (integrators/c/taylor_functions.c) against libm, and the
sweep's lanes where they hand a lane back to the scalar statements.

- lag_sin and lag_cos within 1 ulp of libm's sin and cos on 10^6 arguments in [-100, 100] (most
  of them equal), within 2 ulp up to 2^20; libm's own beyond 2^20.
- taylor_root(x, n) = x^(1/n) to 1e-10 relative over the normal doubles, n = 1 .. 30.
- A sweep whose members leave the functions' ranges in some lanes (angles beyond 2^20 rad: the lane
  takes the scalar order 0; order 2 at a loose tolerance: the scalar radius) equals each member's
  simulate() bit for bit.
"""
from __future__ import annotations

import subprocess

import numpy as np
import pytest

from lagdsl.integrators import c_file
from lagdsl.codegen.c_abi import runtime_header
from tests.conftest import compiled, library_model
from tests.run.c_harness import STRICT_FLAGS, SYSTEM_HEADERS, find_cc

MAIN = r"""
static unsigned long long lag_test_state = 88172645463325252ULL;

/* A uniform double in [-1, 1) (xorshift64). */
static double lag_test_uniform(void)
{
    lag_test_state ^= lag_test_state << 13;
    lag_test_state ^= lag_test_state >> 7;
    lag_test_state ^= lag_test_state << 17;
    return (double)(lag_test_state >> 11) / 4503599627370496.0 - 1;
}

/* |a - b| in units in the last place of b. */
static double lag_test_ulps(double a, double b)
{
    return fabs(a - b) / (nextafter(fabs(b), INFINITY) - fabs(b));
}

int main(int argc, char **argv)
{
    const double span = atof(argv[1]);
    double worst = 0, root = 0;
    long i, equal = 0, count = 1000000;
    (void)argc;
    for (i = 0; i < count; ++i) {
        const double x = span * lag_test_uniform(), s = lag_test_ulps(lag_sin(x), sin(x)), c = lag_test_ulps(lag_cos(x), cos(x));
        const double y = exp(708 * lag_test_uniform());
        const int n = 1 + (int)(i % 30);
        equal += (s == 0) + (c == 0);
        worst = s > worst ? s : worst;
        worst = c > worst ? c : worst;
        root = fmax(root, fabs(taylor_root(y, n) - pow(y, 1.0 / n)) / pow(y, 1.0 / n));
    }
    printf("%.17g %.17g %.17g\n", worst, (double)equal / (2 * count), root);
    return 0;
}
"""


@pytest.fixture(scope="module")
def measure(tmp_path_factory):
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    directory = tmp_path_factory.mktemp("taylor_functions")
    source = directory / "functions.c"
    source.write_text("\n".join([SYSTEM_HEADERS, runtime_header(), c_file("taylor_functions.c"), MAIN]))
    program = directory / "functions"
    # the runtime's helpers that this program does not call are no error here
    compiled([cc, *STRICT_FLAGS, "-Wno-unused-function", str(source), "-o", str(program), "-lm"], check=True)

    def run(span: float) -> tuple[float, float, float]:
        out = subprocess.run([str(program), repr(span)], capture_output=True, text=True, check=True).stdout
        return tuple(float(word) for word in out.split())
    return run


def test_sin_and_cos_are_within_one_ulp_of_libm_on_the_angles_of_mechanics(measure):
    worst, equal, _ = measure(100.0)
    assert worst <= 1
    assert equal > 0.8


@pytest.mark.parametrize("span,bound", [(2.0 ** 20, 2), (1e12, 0)])
def test_far_from_zero_sin_and_cos_stay_close_and_beyond_their_range_are_libms(measure, span, bound):
    worst, _, _ = measure(span)
    assert worst <= bound


def test_the_step_root_is_the_power_to_ten_digits(measure):
    assert measure(1.0)[2] < 1e-10


@pytest.mark.parametrize("starts,tol", [((2.0 ** 21, 1.0), 1e-11), ((0.5, 1.0), 1e-2)])
def test_lanes_that_leave_the_functions_ranges_still_equal_their_simulate(starts, tol):
    """Beyond 2^20 rad (half of the members) a lane's order 0 is the scalar one; at rtol 1e-2 the
    order is 2, whose root taylor_root takes by itself: both still equal simulate()."""
    model = library_model("double_pendulum")
    count = 12
    theta1 = np.where(np.arange(count) % 2 == 0, starts[0], starts[1]) + 0.01 * np.arange(count)
    varied = {"theta1.start": theta1}
    sweep = model.sweep("chaos", set=varied, stop=1.0, integrator="taylor", rtol=tol, atol=tol)
    for b in range(count):
        result = model.simulate("chaos", set={"theta1.start": theta1[b]}, stop=1.0, integrator="taylor", rtol=tol,
                                atol=tol)
        assert np.array_equal(sweep.values[b, :len(result.t)], result.values), b
