"""The explicit C integrators rk4, dopri5 and dop853 on problems with a known solution.

Each model is a small C fragment (LAG_NY, struct lag_system, lag_rhs and `exact`, the solution in
closed form evaluated in the working precision): the harmonic oscillator, the Kepler orbit of
eccentricity 0.5 (through Kepler's equation) and q = t^3.  One `main` performs any number of
runs, each given by nine command-line numbers

    rtol atol step max_step t_end max_steps fault samples project

and prints one line of `key=value` pairs per run: the init and final status, the final time,
whether a step went past t_end or left a gap (t_old differing from the previous t), the error at
the end (`err`) and the largest at the steps (`grid_err`), the largest error of the dense output
at `samples` interior points of every step (`dense_err`) and its mismatch at the ends of the step
(`ends`), the statistics, and the number of calls in the faulty region of the model (`bad`).
`project` makes main act like the driver of a constrained scene: restart after every step (1),
or after moving y onto the oscillator's invariant circle (2).  The runs of one program share one
compilation.
"""
from __future__ import annotations

import math
from dataclasses import astuple, dataclass, replace

import numpy as np
import pytest

from tests.run.c_harness import build_and_run

OSCILLATOR = r"""
#define LAG_NQ 1
#define LAG_NY 2
typedef struct lag_system lag_system;
struct lag_system { real omega; int fault; };

/* The faults: derivatives the model cannot deliver, counted in lag_test_bad_calls. */
enum { FAULT_NONE, FAULT_SINGULAR_AT_START, FAULT_NAN_BEYOND, FAULT_NONFINITE_BEYOND, FAULT_SINGULAR_AFTER };
static const real fault_radius = LAG_LIT(1.05);  /* the domain |q| <= 1.05 holds the solution */
static const real fault_time = 1;                /* the domain t <= 1 ends inside the interval */
static long lag_test_bad_calls;

/* q'' = -omega^2 q */
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    int outside = r_fabs(y[0]) > fault_radius;
    if ((sys->fault == FAULT_SINGULAR_AT_START && t == 0)
        || (sys->fault == FAULT_SINGULAR_AFTER && t > fault_time)) {
        ++lag_test_bad_calls;
        return LAG_ERR_SINGULAR;
    }
    if (sys->fault == FAULT_NONFINITE_BEYOND && outside) {
        ++lag_test_bad_calls;
        return LAG_ERR_NONFINITE;
    }
    dydt[0] = y[1];
    dydt[1] = -sys->omega * sys->omega * y[0];
    if (sys->fault == FAULT_NAN_BEYOND && outside) {
        ++lag_test_bad_calls;
        dydt[0] = dydt[1] = NAN;
    }
    return LAG_OK;
}

static void exact(const lag_system *sys, real t, real *y)
{
    y[0] = r_cos(sys->omega * t);
    y[1] = -sys->omega * r_sin(sys->omega * t);
}

static const lag_system test_system = {1, 0};
"""

KEPLER = r"""
#define LAG_NQ 2
#define LAG_NY 4
typedef struct lag_system lag_system;
struct lag_system { real e; int fault; };
static long lag_test_bad_calls;

/* the two-body problem, q'' = -q/|q|^3, mean motion 1 */
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    real r2 = y[0] * y[0] + y[1] * y[1], r3 = r2 * r_sqrt(r2);
    (void)sys;
    (void)t;
    dydt[0] = y[2];
    dydt[1] = y[3];
    dydt[2] = -y[0] / r3;
    dydt[3] = -y[1] / r3;
    return LAG_OK;
}

/* Kepler's equation E - e sin E = t by Newton's method, from the pericentre at t = 0. */
static void exact(const lag_system *sys, real t, real *y)
{
    real e = sys->e, E = t, dE, b = r_sqrt(1 - e * e), w;
    int k;
    for (k = 0; k < 50; ++k) {
        dE = (E - e * r_sin(E) - t) / (1 - e * r_cos(E));
        E -= dE;
        if (r_fabs(dE) <= 4 * REAL_EPSILON * (1 + r_fabs(E)))
            break;
    }
    w = 1 - e * r_cos(E);
    y[0] = r_cos(E) - e;
    y[1] = b * r_sin(E);
    y[2] = -r_sin(E) / w;
    y[3] = b * r_cos(E) / w;
}

static const lag_system test_system = {LAG_LIT(0.5), 0};
"""

MAIN = r"""
static void put(const char *key, real value)
{
    printf(" %s=", key);
    lag_print_real(stdout, value);
}

static real max_difference(const real *a, const real *b)
{
    real d = 0;
    int i;
    for (i = 0; i < LAG_NY; ++i)
        d = r_fmax(d, r_fabs(a[i] - b[i]));
    return d;
}

/* What the driver does after each step when project is set: restart (1), or first move y onto the
 * oscillator's invariant circle q^2 + q'^2 = 1 (2), as a projection onto a constraint would. */
static int project_and_restart(lag_stepper *s, int project)
{
    real norm = 0;
    int i;
    if (project == 2) {
        for (i = 0; i < LAG_NY; ++i)
            norm += s->y[i] * s->y[i];
        for (i = 0; i < LAG_NY; ++i)
            s->y[i] /= r_sqrt(norm);
    }
    return lag_stepper_restart(s);
}

static void run(char **arg)
{
    static lag_stepper s;
    lag_system sys = test_system;
    lag_options opt;
    real y_exact[LAG_NY], y_dense[LAG_NY], y_prev[LAG_NY], t_end, t_prev = 0;
    real grid_err = 0, dense_err = 0, ends = 0;
    int init, status, samples, project, k, overshoot = 0, gap = 0;
    long steps = 0;
    memset(&opt, 0, sizeof opt);
    opt.rtol = r_strtod(arg[0], NULL);
    opt.atol = r_strtod(arg[1], NULL);
    opt.step = r_strtod(arg[2], NULL);
    opt.max_step = r_strtod(arg[3], NULL);
    t_end = r_strtod(arg[4], NULL);
    opt.max_steps = atol(arg[5]);
    sys.fault = atoi(arg[6]);
    samples = atoi(arg[7]);
    project = atoi(arg[8]);
    lag_test_bad_calls = 0;
    exact(&sys, 0, y_prev);
    status = init = lag_stepper_init(&s, &sys, 0, y_prev, t_end, &opt);
    while (status == LAG_OK && s.t < t_end) {
        status = lag_stepper_step(&s);
        if (status == LAG_OK && project)
            status = project_and_restart(&s, project);
        if (status != LAG_OK)
            break;
        ++steps;
        overshoot |= s.t > t_end;
        gap |= s.t_old != t_prev || !(s.t > s.t_old);
        exact(&sys, s.t, y_exact);
        grid_err = r_fmax(grid_err, max_difference(s.y, y_exact));
        for (k = 1; k <= samples; ++k) {
            real t = s.t_old + (s.t - s.t_old) * k / (samples + 1);
            lag_stepper_dense(&s, t, y_dense);
            exact(&sys, t, y_exact);
            dense_err = r_fmax(dense_err, max_difference(y_dense, y_exact));
        }
        if (samples > 0) {
            lag_stepper_dense(&s, s.t_old, y_dense);
            ends = r_fmax(ends, max_difference(y_dense, y_prev));
            lag_stepper_dense(&s, s.t, y_dense);
            ends = r_fmax(ends, max_difference(y_dense, s.y));
        }
        t_prev = s.t;
        memcpy(y_prev, s.y, sizeof y_prev);
    }
    exact(&sys, s.t, y_exact);
    printf("init=%d status=%d at_end=%d overshoot=%d gap=%d steps=%ld", init, status, s.t == t_end,
           overshoot, gap, steps);
    put("t", s.t);
    put("err", max_difference(s.y, y_exact));
    put("grid_err", grid_err);
    put("dense_err", dense_err);
    put("ends", ends);
    put("h", s.h);
    printf(" accepted=%ld rejected=%ld rhs=%ld bad=%ld\n", s.stats.accepted, REJECTED(s),
           s.stats.rhs_evals, lag_test_bad_calls);
}

int main(int argc, char **argv)
{
    int i;
    (void)lag_cholesky_factor;
    (void)lag_cholesky_solve;
    (void)lag_cholesky_rcond;
    (void)lag_lu_factor;
    (void)lag_lu_solve;
    (void)r_isfinite;
    for (i = 1; i + 9 <= argc; i += 9)
        run(argv + i);
    return 0;
}
"""

CUBIC = r"""
#define LAG_NQ 1
#define LAG_NY 2
typedef struct lag_system lag_system;
struct lag_system { int fault; };
static long lag_test_bad_calls;

/* q'' = 6 t: q = t^3 is within reach of both RK4 and its cubic Hermite dense output */
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)sys;
    dydt[0] = y[1];
    dydt[1] = 6 * t;
    return LAG_OK;
}

static void exact(const lag_system *sys, real t, real *y)
{
    (void)sys;
    y[0] = t * t * t;
    y[1] = 3 * t * t;
}

static const lag_system test_system = {0};
"""

MODELS = {"oscillator": OSCILLATOR, "kepler": KEPLER, "cubic": CUBIC}
ADAPTIVE = ("dopri5", "dop853")
METHODS = ("rk4",) + ADAPTIVE
ORDER = {"rk4": 4, "dopri5": 5, "dop853": 8}
DENSE_ORDER = {"rk4": 3, "dopri5": 4, "dop853": 7}
FAULT_SINGULAR_AT_START, FAULT_NAN_BEYOND, FAULT_NONFINITE_BEYOND, FAULT_SINGULAR_AFTER = 1, 2, 3, 4
LAG_ERR_SINGULAR, LAG_ERR_STEP_TOO_SMALL, LAG_ERR_MAX_STEPS = 1, 3, 4
T_END = {"oscillator": 10.0, "kepler": 2 * math.pi}   # the Kepler orbit: one period
INTEGER_FIELDS = {"init", "status", "at_end", "overshoot", "gap", "steps",
                  "accepted", "rejected", "rhs", "bad"}


@dataclass
class Run:
    rtol: float = 0.0
    atol: float = 0.0
    step: float = 0.0
    max_step: float = 0.0
    t_end: float = 10.0
    max_steps: int = 0
    fault: int = 0
    samples: int = 0
    project: int = 0


def simulate(tmp_path, method: str, model: str, runs: list[Run], long_double: bool = False) -> list[dict]:
    args = [repr(float(value)) if isinstance(value, float) else str(int(value))
            for run in runs for value in astuple(run)]
    if long_double:
        tmp_path = tmp_path / "long_double"
        tmp_path.mkdir()
    # rk4 keeps no count of rejected steps: a fixed step is never rejected.
    rejected = "#define REJECTED(s) 0L\n" if method == "rk4" else "#define REJECTED(s) (s).stats.rejected\n"
    out = build_and_run(tmp_path, MODELS[model], method, rejected + MAIN, args,
                        extra_flags=["-DLAG_LONG_DOUBLE"] if long_double else [])
    results = []
    for line in out.splitlines():
        fields = dict(item.split("=") for item in line.split())
        results.append({k: int(v) if k in INTEGER_FIELDS else float(v) for k, v in fields.items()})
    assert len(results) == len(runs)
    return results


def fixed(method: str, step: float, t_end: float, samples: int = 0) -> Run:
    """Constant steps: rk4's own, or an adaptive method held at its maximum step by a tolerance so
    loose that every step is accepted."""
    if method == "rk4":
        return Run(step=step, t_end=t_end, samples=samples)
    return Run(rtol=1e6, atol=1e6, step=step, max_step=step, t_end=t_end, samples=samples)


def slopes(x, y) -> np.ndarray:
    """Successive log-log slopes d log y / d log x."""
    return np.diff(np.log(y)) / np.diff(np.log(x))


# (1) convergence

# Steps per unit time: in the asymptotic range and above round-off.  DOP853 on the Kepler orbit
# reaches its asymptotic range only where double round-off already shows, hence long double.
ORDER_CASES = [
    ("rk4", "oscillator", (4, 8, 16, 32), False),
    ("rk4", "kepler", (32, 64, 128, 256), False),
    ("dopri5", "oscillator", (1, 2, 4, 8), False),
    ("dopri5", "kepler", (16, 32, 64, 128), False),
    ("dop853", "oscillator", (1, 2, 3, 4), False),
    ("dop853", "kepler", (32, 48, 64), True),
]


@pytest.mark.parametrize("method, model, per_unit, long_double", ORDER_CASES)
def test_order_with_constant_steps(tmp_path, method, model, per_unit, long_double):
    runs = [fixed(method, 1 / n, T_END[model], samples=3) for n in per_unit]
    results = simulate(tmp_path, method, model, runs, long_double)
    for r in results:
        assert r["status"] == 0 and r["rejected"] == 0
    order = -slopes(per_unit, [r["err"] for r in results])
    dense_order = -slopes(per_unit, [r["dense_err"] for r in results])
    assert np.all(np.abs(order - ORDER[method]) < 0.35), order
    # the dense output's local error O(h^(p*+1)) adds to the global error O(h^p)
    assert np.all(dense_order > min(ORDER[method], DENSE_ORDER[method] + 1) - 0.35), dense_order


# The slope of log(error) against log(tolerance).  On the Kepler orbit the error of DOP853 grows
# from about 2 to about 50 tolerances over these tolerances (scipy's DOP853, with the same error
# estimate, takes the same steps), so its slope is below 1 there.  Over one orbit, at rtol = 1e-10,
# DOPRI5 is 1.5e-8 off (scipy's RK45 alike).
PROPORTIONALITY = {"oscillator": (0.9, 1.1), "kepler": (0.7, 1.15)}


@pytest.mark.parametrize("model", ("oscillator", "kepler"))
@pytest.mark.parametrize("method", ADAPTIVE)
def test_tolerance_proportionality(tmp_path, method, model):
    rtol = [10.0 ** -k for k in range(4, 12)]
    runs = [Run(rtol=tol, atol=tol, t_end=T_END[model]) for tol in rtol]
    results = simulate(tmp_path, method, model, runs)
    for r in results:
        assert r["status"] == 0 and r["at_end"] == 1
    err = np.array([r["grid_err"] for r in results])
    low, high = PROPORTIONALITY[model]
    slope = np.polyfit(np.log(rtol), np.log(err), 1)[0]
    assert low < slope < high, (slope, err)
    assert np.all(np.diff([r["accepted"] for r in results]) > 0)
    assert err[rtol.index(1e-10)] < (1e-8 if model == "oscillator" else 3e-8)


# (2) dense output

@pytest.mark.parametrize("model", ("oscillator", "kepler"))
@pytest.mark.parametrize("method", ADAPTIVE)
def test_dense_output_inside_adaptive_steps(tmp_path, method, model):
    """Between the steps the continuous extension is as accurate as the steps themselves."""
    tolerances = (1e-6, 1e-8, 1e-10)
    runs = [Run(rtol=tol, atol=tol, t_end=T_END[model], samples=7) for tol in tolerances]
    for r, tol in zip(simulate(tmp_path, method, model, runs), tolerances):
        assert r["status"] == 0
        assert r["dense_err"] < 3 * r["grid_err"] + 10 * tol
        assert r["ends"] < 1e-14


def test_rk4_dense_output_is_cubic_hermite(tmp_path):
    """On q = t^3 both the RK4 step and its cubic Hermite interpolant are exact."""
    [r] = simulate(tmp_path, "rk4", "cubic", [Run(step=0.3, t_end=2.0, samples=5)])
    assert r["err"] < 1e-14 and r["dense_err"] < 1e-14 and r["ends"] < 1e-14


# (3) the end of the interval

@pytest.mark.parametrize("method", METHODS)
def test_steps_end_exactly_at_t_end(tmp_path, method):
    t_ends = (10.0, 7.3, 1e-3, 123.456)
    if method == "rk4":
        runs = [Run(step=0.01, t_end=t) for t in t_ends]
    else:
        runs = [Run(rtol=1e-7, atol=1e-9, max_step=max_step, t_end=t)
                for max_step in (0.0, 0.3) for t in t_ends]
    for r in simulate(tmp_path, method, "oscillator", runs):
        assert r["status"] == 0 and r["at_end"] == 1
        assert r["overshoot"] == 0 and r["gap"] == 0
        assert r["steps"] == r["accepted"]


def test_rk4_step_count(tmp_path):
    """10 / 0.01 is 1000 steps, not 1001 with a sliver at the end; a true remainder is a step."""
    cases = [(0.01, 10.0, 1000), (0.1, 1.0, 10), (0.3, 1.0, 4), (0.01, 10.005, 1001), (0.1, 0.3, 3),
             (0.7, 0.5, 1), (1e-3, 123.456, 123456)]
    results = simulate(tmp_path, "rk4", "oscillator", [Run(step=h, t_end=t) for h, t, _ in cases])
    for (h, t, n), r in zip(cases, results):
        assert (r["accepted"], r["at_end"], r["gap"]) == (n, 1, 0), (h, t)


# (4) statistics

@pytest.mark.parametrize("method, first_step, samples", [("rk4", 0.01, 0), ("dopri5", 0.0, 0), ("dopri5", 0.01, 1),
                                                         ("dop853", 0.0, 0), ("dop853", 0.01, 0),
                                                         ("dop853", 0.0, 2)])
def test_statistics(tmp_path, method, first_step, samples):
    run = Run(rtol=1e-8, atol=1e-8, step=first_step, t_end=3 * T_END["kepler"], samples=samples)
    [r] = simulate(tmp_path, method, "kepler", [run])
    accepted, rejected, rhs = r["accepted"], r["rejected"], r["rhs"]
    assert r["status"] == 0 and accepted == r["steps"] > 0
    start = 1 if first_step else 2                       # f(t0, y0), and the probe of the starting step
    if method == "rk4":
        assert rejected == 0 and rhs == 1 + 4 * accepted  # f at the end of a step starts the next
    elif method == "dopri5":
        assert rhs == start + 6 * (accepted + rejected)   # 7 stages, the last is the next first
    else:
        # 11 new stages per trial and f at the new point per accepted step; the 3 dense-output
        # stages only on the steps the dense output is asked about (here every step, or none)
        dense_steps = accepted if samples else 0
        assert rhs == start + 11 * (accepted + rejected) + accepted + 3 * dense_steps
    assert rejected < accepted / 2


# (5) failures of the right-hand side

@pytest.mark.parametrize("method", METHODS)
def test_singular_at_start_is_returned(tmp_path, method):
    [r] = simulate(tmp_path, method, "oscillator", [Run(rtol=1e-6, atol=1e-6, step=0.1,
                                                         fault=FAULT_SINGULAR_AT_START)])
    assert r["init"] == LAG_ERR_SINGULAR and r["t"] == 0 and r["accepted"] == 0


@pytest.mark.parametrize("method", ADAPTIVE)
def test_trials_outside_the_domain_are_rejected(tmp_path, method):
    """A first step of 5 (most of a period) sends stages far outside |q| <= 1.05, where the model
    yields NaN or reports LAG_ERR_NONFINITE: the trial must be retried, never accepted."""
    runs = [Run(rtol=1e-8, atol=1e-8, step=5.0, fault=f) for f in (FAULT_NAN_BEYOND, FAULT_NONFINITE_BEYOND)]
    for r in simulate(tmp_path, method, "oscillator", runs):
        assert r["status"] == 0 and r["at_end"] == 1
        assert r["bad"] > 0 and r["rejected"] >= 1
        assert r["grid_err"] < 1e-6


@pytest.mark.parametrize("method", METHODS)
def test_end_of_the_domain(tmp_path, method):
    """The model is singular for t > 1: rk4 returns that status; the adaptive methods creep up to
    t = 1 until the step is below the resolution of t.  Either way y is the last good state."""
    [r] = simulate(tmp_path, method, "oscillator", [Run(rtol=1e-8, atol=1e-8, step=0.3,
                                                         fault=FAULT_SINGULAR_AFTER)])
    assert r["t"] <= 1.0
    if method == "rk4":
        assert r["status"] == LAG_ERR_SINGULAR and r["t"] == pytest.approx(0.9) and r["err"] < 1e-3
    else:
        assert r["status"] == LAG_ERR_STEP_TOO_SMALL and r["t"] > 1 - 1e-12 and r["err"] < 1e-6


@pytest.mark.parametrize("method", METHODS)
def test_max_steps(tmp_path, method):
    [r] = simulate(tmp_path, method, "oscillator", [Run(rtol=1e-8, atol=1e-8, step=0.01, max_steps=7)])
    assert r["status"] == LAG_ERR_MAX_STEPS
    # rk4 knows its number of steps in advance and refuses the run before the first step
    assert r["accepted"] + r["rejected"] == (0 if method == "rk4" else 7)


# the driver's restart

@pytest.mark.parametrize("method", METHODS)
def test_restart(tmp_path, method):
    """A restart without moving y changes nothing but costs one evaluation per step; after moving
    y onto the invariant circle the dense output runs through the moved states."""
    base = Run(rtol=1e-8, atol=1e-8, step=0.05 if method == "rk4" else 0.0, samples=3)
    plain, restarted, projected = simulate(tmp_path, method, "oscillator",
                                           [base, replace(base, project=1), replace(base, project=2)])
    for key in ("t", "err", "grid_err", "dense_err", "accepted", "rejected"):
        assert restarted[key] == plain[key], key
    assert restarted["rhs"] == plain["rhs"] + plain["accepted"]
    assert projected["status"] == 0 and projected["at_end"] == 1
    assert projected["ends"] < 1e-15 and projected["dense_err"] < 2 * plain["dense_err"]


# (6) long double

LONG_DOUBLE_RUN = {"rk4": Run(step=1e-4), "dopri5": Run(rtol=1e-18, atol=1e-18),
                   "dop853": Run(rtol=1e-18, atol=1e-18)}


@pytest.mark.parametrize("method", METHODS)
def test_long_double_reaches_tighter_accuracy(tmp_path, method):
    run = LONG_DOUBLE_RUN[method]
    [extended] = simulate(tmp_path, method, "oscillator", [run], long_double=True)
    [double] = simulate(tmp_path, method, "oscillator", [run])
    assert extended["status"] == 0 and extended["at_end"] == 1
    assert extended["grid_err"] < 1e-15
    assert extended["grid_err"] < double["grid_err"] / 10
