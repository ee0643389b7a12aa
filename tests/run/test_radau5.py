"""The C integrator radau5 (Radau IIA, order 5) on stiff and non-stiff test problems.

Each model is a small C fragment (LAG_NQ, LAG_NY, the dense Jacobian layout, struct
lag_system, lag_rhs, lag_jacobian and `model_start`, the initial state); one `main` drives the
stepper for all of them. radau5 takes the Jacobian in the implicit form of radau5.c ("The
iteration matrices"): a first-order system y' = F(y) (LAG_NQ = 0) is R(y, z) = F(y) - z, so
Dv = dF/dy and Dz = -I; a second-order one q'' = F(q, q') has Dq = dF/dq, Dv = dF/dq', Dz = -1.

    prog rtol atol t_end max_step samples restart

and prints a line `step t_old t` per accepted step (when samples >= 0), the dense output at
`samples` interior points of every step as `dense t y...` (and at its end as `dense_end`),
calls lag_stepper_restart after every step when restart is 1, then prints `end t y...` and
`stats accepted rejected rhs_evals jac_evals lu_decomps newton_iters`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.run.c_harness import build_and_run

# The dense layout of Dq, Dv and Dz (lagdsl.codegen.structure.JacobianLayout), for every model.
DENSE_JACOBIAN = r"""
#define LAG_NK (LAG_NY - LAG_NQ)
#define LAG_JAC_AT(r, c) ((r) * LAG_NK + (c))
#define LAG_JAC_LOWER (LAG_NK - 1)
#define LAG_JAC_UPPER (LAG_NK - 1)
#define LAG_JAC_SIZE (LAG_NK * LAG_NK)
#define LAG_JAC_FIRST(r) 0
#define LAG_JAC_LAST(r) (LAG_NK - 1)
"""

VAN_DER_POL = r"""
#define LAG_NQ 1
#define LAG_NY 2
""" + DENSE_JACOBIAN + r"""typedef struct lag_system lag_system;
struct lag_system { real mu; };

/* y1' = y2, y2' = mu^2 ((1 - y1^2) y2 - y1): the stiff scaling of HW II, IV.1 (eps = 1/mu^2) */
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)t;
    dydt[0] = y[1];
    dydt[1] = sys->mu * sys->mu * ((1 - y[0] * y[0]) * y[1] - y[0]);
    return LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    real m2 = sys->mu * sys->mu;
    (void)t;
    jac[0] = m2 * (-2 * y[0] * y[1] - 1);     /* Dq */
    jac[1] = m2 * (1 - y[0] * y[0]);          /* Dv */
    jac[2] = -1;                               /* Dz */
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    sys->mu = 1000;
    y[0] = 2;
    y[1] = LAG_LIT(-0.66);
}
"""

ROBERTSON = r"""
#define LAG_NQ 0
#define LAG_NY 3
""" + DENSE_JACOBIAN + r"""typedef struct lag_system lag_system;
struct lag_system { real mu; };

/* Robertson's chemical kinetics, HW II, IV.1 (1.4) */
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)sys;
    (void)t;
    dydt[0] = LAG_LIT(-0.04) * y[0] + LAG_LIT(1e4) * y[1] * y[2];
    dydt[2] = LAG_LIT(3e7) * y[1] * y[1];
    dydt[1] = -dydt[0] - dydt[2];
    return LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    (void)sys;
    (void)t;
    real *dv = jac + LAG_JAC_SIZE, *dz = jac + 2 * LAG_JAC_SIZE;   /* no q: Dq is empty */
    int i;
    dv[0] = LAG_LIT(-0.04);
    dv[1] = LAG_LIT(1e4) * y[2];
    dv[2] = LAG_LIT(1e4) * y[1];
    dv[6] = 0;
    dv[7] = LAG_LIT(6e7) * y[1];
    dv[8] = 0;
    dv[3] = -dv[0] - dv[6];
    dv[4] = -dv[1] - dv[7];
    dv[5] = -dv[2] - dv[8];
    for (i = 0; i < LAG_JAC_SIZE; ++i)
        dz[i] = i % (LAG_NK + 1) == 0 ? -1 : 0;
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    sys->mu = 0;
    y[0] = 1;
    y[1] = 0;
    y[2] = 0;
}
"""

# y' = -mu (y - cos t) - sin t, y(0) = 1: the solution is cos t, the transients decay like exp(-mu t)
LINEAR_STIFF = r"""
#define LAG_NQ 0
#define LAG_NY 1
""" + DENSE_JACOBIAN + r"""typedef struct lag_system lag_system;
struct lag_system { real mu; };

static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    dydt[0] = -sys->mu * (y[0] - r_cos(t)) - r_sin(t);
    return LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    (void)t;
    (void)y;
    jac[1] = -sys->mu;     /* Dv */
    jac[2] = -1;           /* Dz */
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    sys->mu = LAG_LIT(1e6);
    y[0] = 1;
}
"""

# q'' = -q, q(0) = 1, q'(0) = 0: q = cos t
OSCILLATOR = r"""
#define LAG_NQ 1
#define LAG_NY 2
""" + DENSE_JACOBIAN + r"""typedef struct lag_system lag_system;
struct lag_system { real mu; };

static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)t;
    dydt[0] = y[1];
    dydt[1] = -sys->mu * y[0];
    return LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    (void)t;
    (void)y;
    jac[0] = -sys->mu;     /* Dq */
    jac[1] = 0;            /* Dv */
    jac[2] = -1;           /* Dz */
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    sys->mu = 1;
    y[0] = 1;
    y[1] = 0;
}
"""

MAIN = r"""
static lag_stepper stepper;

static void print_state(const char *tag, real t, const real *y)
{
    int i;
    printf("%s ", tag);
    lag_print_real(stdout, t);
    for (i = 0; i < LAG_NY; ++i) {
        printf(" ");
        lag_print_real(stdout, y[i]);
    }
    printf("\n");
}

int main(int argc, char **argv)
{
    lag_system sys;
    lag_options opt;
    real y0[LAG_NY], y[LAG_NY], t_end;
    int samples, restart, k, status = LAG_OK;
    (void)lag_cholesky_factor;
    (void)lag_cholesky_solve;
    (void)lag_cholesky_rcond;
    if (argc != 7)
        return 2;
    memset(&opt, 0, sizeof opt);
    opt.rtol = r_strtod(argv[1], NULL);
    opt.atol = r_strtod(argv[2], NULL);
    t_end = r_strtod(argv[3], NULL);
    opt.max_step = r_strtod(argv[4], NULL);
    samples = atoi(argv[5]);
    restart = atoi(argv[6]);
    model_start(&sys, y0);
    status = lag_stepper_init(&stepper, &sys, 0, y0, t_end, &opt);
    while (status == LAG_OK && stepper.t < t_end) {
        status = lag_stepper_step(&stepper);
        if (status == LAG_OK && restart)
            status = lag_stepper_restart(&stepper);
        if (status != LAG_OK)
            break;
        if (samples >= 0) {
            printf("step ");
            lag_print_real(stdout, stepper.t_old);
            printf(" ");
            lag_print_real(stdout, stepper.t);
            printf("\n");
        }
        for (k = 1; k <= samples; ++k) {
            real t = stepper.t_old + (stepper.t - stepper.t_old) * k / (samples + 1);
            lag_stepper_dense(&stepper, t, y);
            print_state("dense", t, y);
        }
        if (samples > 0) {
            lag_stepper_dense(&stepper, stepper.t, y);
            print_state("dense_end", stepper.t, y);
        }
    }
    print_state("end", stepper.t, stepper.y);
    printf("stats %ld %ld %ld %ld %ld %ld %d\n", stepper.stats.accepted, stepper.stats.rejected,
           stepper.stats.rhs_evals, stepper.stats.jac_evals, stepper.stats.lu_decomps,
           stepper.stats.newton_iters, status);
    return 0;
}
"""

STATS = ("accepted", "rejected", "rhs_evals", "jac_evals", "lu_decomps", "newton_iters", "status")


class Run:
    def __init__(self, text: str):
        self.steps, self.dense, self.dense_end = [], [], []
        for line in text.splitlines():
            tag, *values = line.split()
            if tag == "step":
                self.steps.append(tuple(float(v) for v in values))
            elif tag == "dense":
                self.dense.append([float(v) for v in values])
            elif tag == "dense_end":
                self.dense_end.append([float(v) for v in values])
            elif tag == "end":
                self.t, *self.y = (float(v) for v in values)
                self.y = np.array(self.y)
            elif tag == "stats":
                self.stats = dict(zip(STATS, (int(v) for v in values)))


def run(tmp_path, model: str, rtol: float, atol: float, t_end: float, max_step: float = 0.0,
        samples: int = -1, restart: bool = False, flags=()) -> Run:
    args = [repr(rtol), repr(atol), repr(t_end), repr(max_step), str(samples), str(int(restart))]
    result = Run(build_and_run(tmp_path, model, "radau5", MAIN, args, list(flags)))
    assert result.stats["status"] == 0, result.stats
    return result


@pytest.mark.slow
def test_van_der_pol_stiff(tmp_path):
    mu = 1e3

    def f(t, y):
        return [y[1], mu * mu * ((1 - y[0] ** 2) * y[1] - y[0])]

    def jac(t, y):
        return [[0, 1], [mu * mu * (-2 * y[0] * y[1] - 1), mu * mu * (1 - y[0] ** 2)]]

    # LSODA's BDF (another method than ours) agrees with scipy's Radau at 1e-12 to 1e-10, in 1/60 of its time
    ref = solve_ivp(f, (0, 2), [2, -0.66], method="LSODA", jac=jac, rtol=1e-12, atol=1e-12).y[:, -1]
    result = run(tmp_path, VAN_DER_POL, 1e-6, 1e-6, 2.0)
    assert result.t == 2.0
    assert np.all(np.abs(result.y - ref) <= 1e-4 * np.abs(ref)), (result.y, ref)
    # the step size follows the solution, not the stiff eigenvalue |lambda| ~ 3 mu^2 = 3e6 that
    # would hold an explicit method to ~1e6 steps (measured: 466 accepted, 9 rejected)
    assert result.stats["accepted"] < 1000
    assert result.stats["jac_evals"] < result.stats["accepted"]
    assert result.stats["lu_decomps"] <= result.stats["accepted"] + result.stats["rejected"]


def test_robertson_conserves_mass(tmp_path):
    def f(t, y):
        a, b = -0.04 * y[0] + 1e4 * y[1] * y[2], 3e7 * y[1] ** 2
        return [a, -a - b, b]

    ref = solve_ivp(f, (0, 1e5), [1, 0, 0], method="LSODA", rtol=1e-10, atol=1e-14).y[:, -1]
    result = run(tmp_path, ROBERTSON, 1e-6, 1e-10, 1e5, samples=0)
    assert result.t == 1e5
    assert abs(result.y.sum() - 1) < 1e-8
    assert np.all(np.abs(result.y - ref) <= 1e-4 * np.abs(ref) + 1e-9), (result.y, ref)
    assert len(result.steps) == result.stats["accepted"] < 300
    assert all(t1 > t0 for t0, t1 in result.steps)


def test_linear_stiff_follows_the_smooth_solution(tmp_path):
    rtol = 1e-8
    result = run(tmp_path, LINEAR_STIFF, rtol, rtol, 10.0)
    # the global error of a stiff problem is the last local error, bounded by the transformed
    # tolerance rtol' = 0.1 rtol^(2/3) = 4.6e-7 (measured: 2.1e-7 in 10 steps)
    assert abs(result.y[0] - math.cos(10.0)) < 0.1 * rtol ** (2 / 3)
    # stiffness does not limit the step: mu h ~ 1e6 >> 1
    assert result.stats["accepted"] < 100


def oscillator_error(tmp_path, rtol, flags=()):
    result = run(tmp_path, OSCILLATOR, rtol, rtol, 10.0, flags=flags)
    return max(abs(result.y[0] - math.cos(10.0)), abs(result.y[1] + math.sin(10.0))), result


def test_convergence_on_the_oscillator(tmp_path):
    errors = [oscillator_error(tmp_path, rtol)[0] for rtol in (1e-4, 1e-6, 1e-8, 1e-10)]
    assert errors[-1] < 1e-7
    assert all(e2 < e1 for e1, e2 in zip(errors, errors[1:])), errors
    # tolerance proportionality from the transformed tolerances: ~1 decade per decade of rtol
    assert errors[0] / errors[-1] > 1e3, errors


def test_dense_output_inside_steps(tmp_path):
    result = run(tmp_path, OSCILLATOR, 1e-8, 1e-8, 10.0, samples=5)
    dense = np.array(result.dense)
    assert len(dense) == 5 * result.stats["accepted"]
    t = dense[:, 0]
    exact = np.column_stack([np.cos(t), -np.sin(t)])
    # the collocation polynomial has order 3 inside the step, below the tolerance at this rtol
    assert np.max(np.abs(dense[:, 1:] - exact)) < 1e-6
    # it reproduces the step's end point
    end = result.dense_end[-1]
    assert end[0] == result.t and np.array_equal(end[1:], result.y)
    steps = np.array(result.steps)
    assert np.all(steps[1:, 0] == steps[:-1, 1])


@pytest.mark.slow
def test_dense_output_between_stiff_steps(tmp_path):
    """On the stiff Van der Pol run, through the fast jump too, the dense output stays within the
    (transformed) tolerance of the exact solution through the step's starting point."""
    mu, rtol = 1e3, 1e-6

    def f(t, y):
        return [y[1], mu * mu * ((1 - y[0] ** 2) * y[1] - y[0])]

    def jac(t, y):
        return [[0, 1], [mu * mu * (-2 * y[0] * y[1] - 1), mu * mu * (1 - y[0] ** 2)]]

    result = run(tmp_path, VAN_DER_POL, rtol, rtol, 2.0, samples=3)
    dense = np.array(result.dense).reshape(-1, 3, 3)
    ends = np.array(result.dense_end)
    tol = 0.1 * rtol ** (2 / 3)
    worst = 0.0
    for k in range(1, len(ends), 3):
        start = ends[k - 1]
        local = solve_ivp(f, (start[0], ends[k][0]), start[1:], method="LSODA", jac=jac,
                          rtol=1e-12, atol=1e-12, t_eval=dense[k][:, 0]).y.T
        worst = max(worst, np.max(np.abs(dense[k][:, 1:] - local) / (tol + tol * np.abs(local))))
    assert worst < 2, worst   # measured: 0.9


def test_last_step_ends_exactly_at_t_end(tmp_path):
    t_end = 2.7182818284590451
    result = run(tmp_path, OSCILLATOR, 1e-7, 1e-7, t_end, max_step=0.3, samples=0)
    assert result.t == t_end
    assert result.steps[-1][1] == t_end
    assert all(t1 <= t_end and t1 - t0 <= 0.3 * (1 + 1e-12) for t0, t1 in result.steps)


def test_restart_without_projection_changes_nothing(tmp_path):
    plain = run(tmp_path, ROBERTSON, 1e-6, 1e-10, 1e5)
    restarted = run(tmp_path, ROBERTSON, 1e-6, 1e-10, 1e5, restart=True)
    assert np.array_equal(plain.y, restarted.y) and plain.stats == restarted.stats


# y' = -1 from y = 1: the model (like a singular mass matrix) fails for y < 0, reached at t = 1
LEAVES_DOMAIN = r"""
#define LAG_NQ 0
#define LAG_NY 1
""" + DENSE_JACOBIAN + r"""typedef struct lag_system lag_system;
struct lag_system { real mu; };

static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)t;
    dydt[0] = -sys->mu;
    return y[0] < 0 ? LAG_ERR_SINGULAR : LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    (void)sys;
    (void)t;
    (void)y;
    jac[1] = 0;            /* Dv */
    jac[2] = -1;           /* Dz */
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    sys->mu = 1;
    y[0] = 1;
}
"""


def test_failing_right_hand_side_stops_at_the_domain_boundary(tmp_path):
    text = build_and_run(tmp_path, LEAVES_DOMAIN, "radau5", MAIN, ["1e-6", "1e-6", "2", "0", "-1", "0"])
    result = Run(text)
    # trials beyond the boundary are rejected with h/10 until h reaches the resolution of t;
    # then the model's status is returned, with the last good state
    assert result.stats["status"] == 1
    assert 1 - 1e-12 < result.t < 1 and result.y[0] >= 0


def test_long_double(tmp_path):
    error, result = oscillator_error(tmp_path, 1e-16, flags=["-DLAG_LONG_DOUBLE"])
    assert result.t == 10.0
    # beyond double precision (where rtol is floored at 10 eps and the error is ~1e-13): the
    # method constants are computed in the working precision (measured: 3e-15 in 2043 steps)
    assert error < 1e-14, error


# y' = A y, A = N^2 (tridiagonal Laplacian) + c (y[i+1] - y[i-1]) / 2: diffusion and advection
# on N = 16 points between walls, c = 4000, so that |c/2 - N^2| can exceed |g + 2 N^2| and the
# band LU pivots (3 times in this run). LAYOUT is the band of half-widths 1 or the dense layout:
# the same steps, the same numbers.
ADVECTION_DIFFUSION = r"""
#define LAG_NQ 0
#define LAG_NY 16
LAYOUT
typedef struct lag_system lag_system;
struct lag_system { real c; };

static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    int i;
    (void)t;
    for (i = 0; i < LAG_NY; ++i) {
        real left = i > 0 ? y[i - 1] : 0, right = i + 1 < LAG_NY ? y[i + 1] : 0;
        dydt[i] = 256 * (left - 2 * y[i] + right) + sys->c * (right - left) / 2;
    }
    return LAG_OK;
}

static int lag_jacobian(const lag_system *sys, real t, const real *y, real *jac)
{
    real *dv = jac + LAG_JAC_SIZE, *dz = jac + 2 * LAG_JAC_SIZE;
    int i;
    (void)t;
    (void)y;
    memset(jac, 0, sizeof(real) * 3 * LAG_JAC_SIZE);
    for (i = 0; i < LAG_NY; ++i) {
        dv[LAG_JAC_AT(i, i)] = -512;
        if (i > 0)
            dv[LAG_JAC_AT(i, i - 1)] = 256 - sys->c / 2;
        if (i + 1 < LAG_NY)
            dv[LAG_JAC_AT(i, i + 1)] = 256 + sys->c / 2;
        dz[LAG_JAC_AT(i, i)] = -1;
    }
    return LAG_OK;
}

static void model_start(lag_system *sys, real *y)
{
    int i;
    sys->c = 4000;
    for (i = 0; i < LAG_NY; ++i)
        y[i] = r_sin(LAG_LIT(3.14159265358979) * (i + 1) / (LAG_NY + 1));
}
"""
BANDED_JACOBIAN = r"""
#define LAG_NK LAG_NY
#define LAG_JAC_AT(r, c) ((r) * 3 + (c) - (r) + 1)
#define LAG_JAC_LOWER 1
#define LAG_JAC_UPPER 1
#define LAG_JAC_SIZE (LAG_NK * 3)
#define LAG_JAC_FIRST(r) ((r) > LAG_JAC_LOWER ? (r) - LAG_JAC_LOWER : 0)
#define LAG_JAC_LAST(r) ((r) + LAG_JAC_UPPER < LAG_NK ? (r) + LAG_JAC_UPPER : LAG_NK - 1)
"""


def test_band_factorisation_pivots_and_agrees_with_the_dense_one(tmp_path):
    from scipy.linalg import expm
    n, c = 16, 4000.0
    a = np.diag(np.full(n, -512.0)) + np.diag(np.full(n - 1, 256 - c / 2), -1) + np.diag(np.full(n - 1, 256 + c / 2), 1)
    y0 = np.sin(np.pi * np.arange(1, n + 1) / (n + 1))
    exact = expm(a * 0.05) @ y0
    (tmp_path / "band").mkdir()
    (tmp_path / "dense").mkdir()
    banded = run(tmp_path / "band", ADVECTION_DIFFUSION.replace("LAYOUT", BANDED_JACOBIAN), 1e-8, 1e-10, 0.05)
    dense = run(tmp_path / "dense", ADVECTION_DIFFUSION.replace("LAYOUT", DENSE_JACOBIAN), 1e-8, 1e-10, 0.05)
    assert np.max(np.abs(np.array(banded.y) - exact)) < 1e-7 * np.max(np.abs(y0))
    assert banded.stats == dense.stats
    assert np.max(np.abs(np.array(banded.y) - np.array(dense.y))) < 1e-12
