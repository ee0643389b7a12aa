"""The C integrator gauss (s-stage Gauss-Legendre collocation, order 2s) on a pendulum.

The model is the pendulum L = m l^2 q'^2 / 2 + m g l cos q in canonical form: p = m l^2 q',
H = p^2 / (2 m l^2) - m g l cos q.  One `main` serves every test:

    prog tableau s...                                  c, b and mu_ij = a_ij / b_j of each s
    prog run s step t_end dt stride restart [...]      one run per group of six arguments

A run prints `run`, then the grid k dt <= t_end as the driver delivers it (the state when a step
ends there, else the dense output) as `grid t q q'`, every stride-th step as `step t q q'`
(stride 0: none), and at the end `end t q q'` and
`stats status accepted rhs_evals newton_iters`.  With restart = 1 it calls
lag_stepper_restart after every step, as the driver does after a projection.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.run.c_harness import build_and_run

try:
    from lagdsl.integrators.python.gauss_coefficients import gauss_legendre_tableau, symplectic_mu
except ImportError:         # the package is not installed: use the repository
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from lagdsl.integrators.python.gauss_coefficients import gauss_legendre_tableau, symplectic_mu

M, L, G = 1.3, 0.7, 9.81
Q0 = 1.2          # a large swing: the pendulum is far from its linearization

PENDULUM_C = r"""
#define LAG_NQ 1
#define LAG_NY 2
typedef struct lag_system lag_system;
struct lag_system { real m, l, g; };

static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)t;
    dydt[0] = y[1];
    dydt[1] = -sys->g / sys->l * r_sin(y[0]);
    return LAG_OK;
}

/* q' = p / (m l^2), p' = dL/dq = -m g l sin q */
static int lag_hamilton_rhs(const lag_system *sys, real t, const real *z, real *dzdt)
{
    (void)t;
    dzdt[0] = z[1] / (sys->m * sys->l * sys->l);
    dzdt[1] = -sys->m * sys->g * sys->l * r_sin(z[0]);
    return LAG_OK;
}

static int lag_to_canonical(const lag_system *sys, real t, const real *y, real *z)
{
    (void)t;
    z[0] = y[0];
    z[1] = sys->m * sys->l * sys->l * y[1];
    return LAG_OK;
}

static int lag_from_canonical(const lag_system *sys, real t, const real *z, real *y)
{
    (void)t;
    y[0] = z[0];
    y[1] = z[1] / (sys->m * sys->l * sys->l);
    return LAG_OK;
}

static void model_parameters(lag_system *sys)
{
    sys->m = LAG_LIT(1.3);
    sys->l = LAG_LIT(0.7);
    sys->g = LAG_LIT(9.81);
}

static void model_start(real *y)
{
    y[0] = LAG_LIT(1.2);
    y[1] = 0;
}

/* pasted in for every integrator, but not all are used by each */
static void model_unused(void)
{
    (void)r_isfinite;
    (void)lag_cholesky_factor;
    (void)lag_cholesky_solve;
    (void)lag_cholesky_rcond;
    (void)lag_lu_factor;
    (void)lag_lu_solve;
    (void)lag_hamilton_rhs;
    (void)lag_to_canonical;
    (void)lag_from_canonical;
    (void)lag_rhs;
}
"""

RUN_C = r"""
#ifndef ITERATIONS                                  /* rk4, which shares this driver, has none */
#define ITERATIONS(s) (s)->stats.newton_iters
#endif

static void print_row(const char *tag, real t, const real *y)
{
    int i;
    printf("%s ", tag);
    lag_print_real(stdout, t);
    for (i = 0; i < LAG_NY; ++i) {
        putchar(' ');
        lag_print_real(stdout, y[i]);
    }
    putchar('\n');
}

/* From 0 to t_end, delivering the grid k dt like the driver. */
static void run(lag_stepper *s, const lag_system *sys, const lag_options *opt, real t_end, real dt,
                long stride, int restart)
{
    real y0[LAG_NY], y[LAG_NY];
    long k = 1, last = dt > 0 ? (long)r_floor(t_end / dt + LAG_LIT(1e-9)) : 0;
    int status;
    model_start(y0);
    status = lag_stepper_init(s, sys, 0, y0, t_end, opt);
    while (status == LAG_OK && s->t < t_end) {
        if ((status = lag_stepper_step(s)) != LAG_OK)
            break;
        for (; k <= last; ++k) {
            real tk = k == last && k * dt > t_end ? t_end : k * dt;
            if (tk > s->t)
                break;
            if (tk == s->t) {
                print_row("grid", tk, s->y);
            } else {
                lag_stepper_dense(s, tk, y);
                print_row("grid", tk, y);
            }
        }
        if (stride > 0 && s->stats.accepted % stride == 0)
            print_row("step", s->t, s->y);
        if (restart)
            status = lag_stepper_restart(s);
    }
    print_row("end", s->t, s->y);
    printf("stats %d %ld %ld %ld\n", status, s->stats.accepted,
           s->stats.rhs_evals, ITERATIONS(s));
}
"""

MAIN_C = RUN_C + r"""
static void print_tableau(const lag_stepper *s)
{
    int i, j;
    for (i = 0; i < s->stages; ++i) {
        printf("c %d %d ", s->stages, i);
        lag_print_real(stdout, s->c[i]);
        printf("\nb %d %d ", s->stages, i);
        lag_print_real(stdout, s->b[i]);
        for (j = 0; j < s->stages; ++j) {
            printf("\nmu %d %d %d ", s->stages, i, j);
            lag_print_real(stdout, s->mu[i][j]);
        }
        putchar('\n');
    }
}

int main(int argc, char **argv)
{
    static lag_stepper s;
    lag_system sys;
    lag_options opt;
    int i;
    model_unused();
    model_parameters(&sys);
    memset(&opt, 0, sizeof opt);
    if (argc > 1 && strcmp(argv[1], "tableau") == 0) {
        for (i = 2; i < argc; ++i) {
            real y0[LAG_NY];
            opt.stages = atoi(argv[i]);
            opt.step = 1;
            model_start(y0);
            lag_stepper_init(&s, &sys, 0, y0, 1, &opt);
            print_tableau(&s);
        }
        return 0;
    }
    for (i = 2; i + 5 < argc; i += 6) {
        printf("run\n");
        opt.stages = atoi(argv[i]);
        opt.step = r_strtod(argv[i + 1], NULL);
        run(&s, &sys, &opt, r_strtod(argv[i + 2], NULL), r_strtod(argv[i + 3], NULL), atol(argv[i + 4]),
            atoi(argv[i + 5]));
    }
    return 0;
}
"""


def parse_runs(text: str) -> list[dict]:
    """Each run as {"grid": rows (t, q, q'), "step": rows, "end": (t, q, q'), "stats": dict}."""
    runs = []
    for line in text.splitlines():
        tag, *fields = line.split()
        if tag == "run":
            runs.append({"grid": [], "step": []})
        elif tag in ("grid", "step"):
            runs[-1][tag].append([float(x) for x in fields])
        elif tag == "end":
            runs[-1]["end"] = np.array([float(x) for x in fields])
        elif tag == "stats":
            runs[-1]["stats"] = dict(zip(("status", "accepted", "rhs_evals", "newton_iters"),
                                         map(int, fields)))
    for r in runs:
        r["grid"], r["step"] = np.array(r["grid"]).reshape(-1, 3), np.array(r["step"]).reshape(-1, 3)
    return runs


def run_c(tmp_path, groups, extra_flags=()) -> list[dict]:
    """groups: (stages, step, t_end, dt, stride, restart) per run."""
    args = ["run"] + [str(x) for group in groups for x in group]
    return parse_runs(build_and_run(tmp_path, PENDULUM_C, "gauss", MAIN_C, args, list(extra_flags)))


def tableau_c(tmp_path, stages, extra_flags=()) -> dict:
    args = ["tableau", *map(str, stages)]
    text = build_and_run(tmp_path, PENDULUM_C, "gauss", MAIN_C, args, list(extra_flags))
    values = {}
    for line in text.splitlines():
        name, *index, value = line.split()
        values[(name, *map(int, index))] = value
    return values


def energy(q, v):
    return M * L * L * v * v / 2 - M * G * L * np.cos(q)


def pendulum(t, y):
    return np.array([y[1], -G / L * np.sin(y[0])])


def reference(t_end):
    return solve_ivp(pendulum, (0, t_end), [Q0, 0.0], method="DOP853", rtol=1e-13, atol=1e-13,
                     dense_output=True)


STEPS_FOR_ORDER = {1: (0.04, 0.02, 0.01), 2: (0.2, 0.1, 0.05), 3: (0.2, 0.1, 0.05)}


@pytest.mark.parametrize("stages", [1, 2, 3])
def test_order_2s(tmp_path, stages):
    t_end = 3.0
    runs = run_c(tmp_path, [(stages, h, t_end, 0, 0, 0) for h in STEPS_FOR_ORDER[stages]])
    exact = reference(t_end).y[:, -1]
    errors = np.array([np.max(np.abs(r["end"][1:] - exact)) for r in runs])
    orders = np.log2(errors[:-1] / errors[1:])
    assert abs(orders[-1] - 2 * stages) < 0.3, (errors, orders)
    for r in runs:
        assert r["stats"]["status"] == 0
        assert r["stats"]["rhs_evals"] == stages * r["stats"]["newton_iters"]


def relative_energy_error(rows):
    h0 = energy(Q0, 0.0)
    return np.abs(energy(rows[:, 1], rows[:, 2]) - h0) / abs(h0)


@pytest.mark.slow
def test_energy_bounded_without_drift(tmp_path):
    """10^5 steps of h = 0.1 (h omega = 0.37), s = 2: the O(h^4) energy error oscillates with the
    same amplitude at the end as at the start; s = 3 at h = 0.005: round-off level, 10^5 steps;
    s = 6 at h = 0.05: round-off level over 10^6 steps (rounded a_ij instead of mu_ij, or stopping
    the iteration at Delta <= eps, make it drift linearly to 1e-12 ... 7e-12 there)."""
    coarse, fine, longest = run_c(tmp_path, [(2, 0.1, 1e4, 0, 1, 0), (3, 0.005, 500, 0, 1, 0),
                                             (6, 0.05, 5e4, 0, 100, 0)])
    for run, steps in ((coarse, 10**5), (fine, 10**5), (longest, 10**6)):
        assert run["stats"]["status"] == 0 and run["stats"]["accepted"] == steps
    first, last = first_and_last_tenth(relative_energy_error(coarse["step"]))
    assert 1e-6 < first < 1e-4
    assert abs(last / first - 1) < 0.01, (first, last)
    assert max(first_and_last_tenth(relative_energy_error(fine["step"]))) < 1e-14
    first, last = first_and_last_tenth(relative_energy_error(longest["step"]))
    assert first < 5e-14 and last < 5e-14, (first, last)


def first_and_last_tenth(error):
    """The largest error over the first and over the last 10% of a run."""
    tenth = len(error) // 10
    return error[:tenth].max(), error[-tenth:].max()


def test_last_step_lands_on_t_end(tmp_path):
    runs = run_c(tmp_path, [(2, 0.01, 10, 0, 0, 0), (2, 0.3, 1, 0, 1, 0), (3, 0.1, 0.7, 0, 0, 0)])
    assert runs[0]["stats"]["accepted"] == 1000 and runs[0]["end"][0] == 10.0
    assert runs[1]["stats"]["accepted"] == 4 and runs[1]["end"][0] == 1.0
    assert list(runs[1]["step"][:, 0]) == [0.3, 0.6, 3 * 0.3, 1.0]    # t0 + k h, then t_end
    assert runs[2]["stats"]["accepted"] == 7 and runs[2]["end"][0] == 0.7


@pytest.mark.parametrize("stages", [2, 3])
def test_dense_output_order_s_plus_1(tmp_path, stages):
    """The collocation polynomial between the step ends is accurate to O(h^(s+1)); where a grid
    time is a step end the state itself is delivered."""
    t_end, dt = 3.0, 0.0137
    steps = (0.2, 0.1, 0.05)
    runs = run_c(tmp_path, [(stages, h, t_end, dt, 1, 0) for h in steps])
    sol = reference(t_end).sol
    errors = []
    for r in runs:
        grid = r["grid"]
        assert len(grid) == int(t_end / dt) and np.allclose(np.diff(grid[:, 0]), dt)
        errors.append(np.max(np.abs(grid[:, 1:] - sol(grid[:, 0]).T)))
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    assert abs(orders[-1] - (stages + 1)) < 0.4, (errors, orders)
    on_steps = run_c(tmp_path, [(stages, 0.1, 1, 0.1, 1, 0)])[0]
    assert np.array_equal(on_steps["grid"][:, 1:], on_steps["step"][:, 1:])


def test_restart_keeps_the_solution(tmp_path):
    """lag_stepper_restart re-reads y after every step: only the compensated-summation carry is
    lost, so the solution changes by round-off."""
    plain, restarted = run_c(tmp_path, [(3, 0.05, 10, 0, 0, 0), (3, 0.05, 10, 0, 0, 1)])
    assert np.max(np.abs(plain["end"] - restarted["end"])) < 1e-12


def test_failures_report_and_keep_the_last_good_state(tmp_path):
    """A step far too large for fixed-point iteration (h omega = 15) does not converge; a step
    that is not positive or below the resolution of t, or an invalid number of stages, is
    refused at init."""
    diverged, no_step, tiny_step, too_many = run_c(tmp_path, [(2, 4.0, 8, 0, 0, 0), (2, 0, 1, 0, 0, 0),
                                                              (2, 1e-16, 1, 0, 0, 0), (7, 0.1, 1, 0, 0, 0)])
    assert diverged["stats"]["status"] == 5 and diverged["stats"]["accepted"] == 0
    assert list(diverged["end"]) == [0.0, Q0, 0.0]
    assert no_step["stats"]["status"] == 3 and tiny_step["stats"]["status"] == 3
    assert too_many["stats"]["status"] == 5


def test_long_double(tmp_path):
    """-DLAG_LONG_DOUBLE: coefficients to long double precision, and the same solution."""
    mpmath = pytest.importorskip("mpmath")
    values = tableau_c(tmp_path, range(1, 7), ["-DLAG_LONG_DOUBLE"])
    with mpmath.workdps(40):
        for s in range(1, 7):
            c, b, a = exact_tableau(mpmath, s)
            for i in range(s):
                assert abs(mpmath.mpf(values["c", s, i]) - c[i]) < 1e-18
                assert abs(mpmath.mpf(values["b", s, i]) - b[i]) < 1e-18
                for j in range(s):
                    assert abs(mpmath.mpf(values["mu", s, i, j]) * b[j] - a[i][j]) < 1e-18
    long_double = run_c(tmp_path, [(3, 0.05, 3, 0, 0, 0)], ["-DLAG_LONG_DOUBLE"])[0]
    double = run_c(tmp_path, [(3, 0.05, 3, 0, 0, 0)])[0]
    assert long_double["stats"]["status"] == 0
    assert np.max(np.abs(long_double["end"] - double["end"])) < 1e-12


def exact_tableau(mpmath, s):
    """c, b, a_ij of the s-stage Gauss method in the current mpmath precision."""
    roots = mpmath.polyroots(mpmath.taylor(lambda x: mpmath.legendre(s, x), 0, s)[::-1],
                             maxsteps=200, extraprec=200)
    c = sorted((1 + x) / 2 for x in roots)

    def basis(j, x):
        return mpmath.fprod((x - c[m]) / (c[j] - c[m]) for m in range(s) if m != j)

    b = [mpmath.quad(lambda x: basis(j, x), [0, 1]) for j in range(s)]
    a = [[mpmath.quad(lambda x: basis(j, x), [0, c[i]]) for j in range(s)] for i in range(s)]
    return c, b, a


def test_coefficients_agree_with_python(tmp_path):
    values = tableau_c(tmp_path, range(1, 7))
    for s in range(1, 7):
        c, b, A = gauss_legendre_tableau(s)
        mu = symplectic_mu(b, A)
        c_c = np.array([float(values["c", s, i]) for i in range(s)])
        b_c = np.array([float(values["b", s, i]) for i in range(s)])
        mu_c = np.array([[float(values["mu", s, i, j]) for j in range(s)] for i in range(s)])
        assert np.max(np.abs(c_c - c)) <= 1e-15
        assert np.max(np.abs(b_c - b)) <= 1e-15
        assert np.max(np.abs(mu_c * b_c - A)) <= 1e-15
        assert np.max(np.abs(mu_c - mu)) <= 1e-15
        assert np.all(mu_c + mu_c.T == 1)        # symplectic to the last bit
