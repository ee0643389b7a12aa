"""The driver's static C (integrators/c/driver.c, library.c, standalone*.c) compiled on its own.

A small stub model (two uncoupled oscillators q'' = -q, held together by q1 = q2 or q1' = q2') and a
stub stepper (explicit Euler, with every counter and auto's switch log) stand for what the code
generator writes; the C the generator derives from lagdsl/abi.py (the status codes, the shared
constants, lag_pack_summary, lag_print_status) is generated as for a scene. Each combination of
the LAG_HAS_* guards that a scene can have compiles under the strict flags, and the program with
all of them runs: CSV, summary, batch mode and a failure worded as SimulationError words it.
"""
from __future__ import annotations

import subprocess

import pytest

from lagdsl.abi import MAX_STEPS, STATUSES, summary_layout
from lagdsl.codegen.c_abi import runtime_contract, runtime_header, status_printer, summary_packer, verdict_printer
from lagdsl.integrators import c_file, standalone_source
from tests.run.c_harness import STRICT_FLAGS, find_cc
from tests.conftest import compiled

HEADERS = """#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <math.h>
#include <float.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
"""
MODEL = """
#define LAG_NQ 2
#define LAG_NY 4
#define LAG_NP 1
#define LAG_NOUT 1
typedef struct lag_system { real par[1]; } lag_system;
static const char *const lag_parameter_names[] = { "k" };
static const char *const lag_coordinate_names[] = { "q1", "q2" };
#define LAG_MODEL_NAME "Stub"
#define LAG_SCENE_NAME "stub"
#define LAG_NOPTIONS 1
static const char *const lag_option_names[] = { "max-steps" };
static const char *const lag_column_names[] = { "q1" };
static const lag_input_unit lag_input_units[] = { { "", "", "", 1.0, 0.0 }, { "m", "m", "length", 1.0, 0.0 },
    { "m", "m", "length", 1.0, 0.0 }, { "m/s", "m/s", "length/time", 1.0, 0.0 },
    { "cm/s", "m/s", "length/time", 0.01, -2.0816681711721684e-19 } };
#if LAG_HAS_TOLERANCES
#define LAG_NATOL 4
#define LAG_NATOL_PLAIN 2
#define LAG_ATOL_POSITIVE 0
static const char *const lag_atol_names[] = { "q1", "q2", "der(q1)", "der(q2)" };
static const int lag_atol_inputs[] = { 1, 2, 3, 4 };
static const int lag_atol_family[] = { -1, -1 };
static const double lag_scene_atol_given[] = { -1.0, -1.0, -1.0, -1.0 };
#endif
static void lag_system_prepare(lag_system *sys) { (void)sys; }
static void lag_default_parameters(real *par) { par[0] = 1; }
static void lag_derive_parameters(real *par, const int *fixed) { (void)par; (void)fixed; }
static void lag_initial_state(const real *par, real *y0)
{
    (void)par;
    y0[0] = y0[1] = 1;
    y0[2] = y0[3] = 0;
}
static int lag_rhs(const lag_system *sys, real t, const real *y, real *dydt)
{
    (void)t;
    dydt[0] = y[2];
    dydt[1] = y[3];
    dydt[2] = -sys->par[0] * y[0];
    dydt[3] = -sys->par[0] * y[1];
    return LAG_OK;
}
static real lag_condition(const lag_system *sys, real t, const real *y) { (void)sys; (void)t; (void)y; return 1; }
#if LAG_HAS_INVARIANTS
#define LAG_NINV 1
static const char *const lag_invariant_names[] = { "energy" };
static int lag_outputs(const lag_system *sys, real t, const real *y, real *out, real *inv)
{
    (void)t;
    out[0] = y[0];
    inv[0] = (y[2] * y[2] + y[3] * y[3] + sys->par[0] * (y[0] * y[0] + y[1] * y[1])) / 2;
    return LAG_OK;
}
#else
static int lag_outputs(const lag_system *sys, real t, const real *y, real *out)
{
    (void)sys;
    (void)t;
    out[0] = y[0];
    return LAG_OK;
}
#endif
#if LAG_HAS_CONSTRAINTS
#define LAG_NC 1
%(holonomic)s
static const char *const lag_constraint_names[] = { "together" };
/* g = q1 - q2 (holonomic) or only c = q1' - q2' (a velocity constraint); A = [1, -1]. */
static void lag_constraint_rows(const real *par, real t, const real *y, real *g, real *c, real *A)
{
    (void)par;
    (void)t;
#ifdef LAG_NH
    g[0] = y[0] - y[1];
#else
    (void)g;
#endif
    c[0] = y[2] - y[3];
    A[0] = 1;
    A[1] = -1;
}
static void lag_gram(int rows, const real *A, const real *r, real *G, real *x)
{
    int i, j, k;
    for (i = 0; i < rows; ++i) {
        for (j = 0; j < rows; ++j)
            for (G[i * rows + j] = 0, k = 0; k < LAG_NQ; ++k)
                G[i * rows + j] += A[i * LAG_NQ + k] * A[j * LAG_NQ + k];
        x[i] = r[i];
    }
}
#endif
#if LAG_HAS_STOP
static real lag_stop_function(const real *par, real t, const real *y) { (void)par; (void)t; return y[0]; }
#endif
"""
# Explicit Euler with a linear dense output, and every counter any integrator keeps.
STEPPER = """
#define LAG_INTEGRATOR_NAME "stub"
#define LAG_AUTO_LOGGED 8
enum lag_auto_method { LAG_AUTO_EXPLICIT, LAG_AUTO_IMPLICIT };
typedef struct lag_stats {
    long accepted, rejected, rhs_evals, jac_evals, lu_decomps, newton_iters;
    int stiff;
    real stiff_time, stiff_rate, stiff_amplitude, stiff_step;
    long stiff_accepted, stiff_rejected, stiff_rhs_evals;
} lag_stats;
typedef struct lag_switches { long count; real at[LAG_AUTO_LOGGED]; real span[2]; } lag_switches;
typedef struct lag_stepper {
    real t, t_old, y[LAG_NY], y_old[LAG_NY], h, t_end;
    long max_steps;
    lag_stats stats;
    lag_switches switches;
    const lag_system *sys;
} lag_stepper;
static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0, real t_end,
                            const lag_options *opt)
{
    s->sys = sys;
    s->t = s->t_old = t0;
    s->t_end = t_end;
    s->h = opt->step > 0 ? opt->step : LAG_LIT(0.001);
    s->max_steps = opt->max_steps;
    memcpy(s->y, y0, sizeof s->y);
    return LAG_OK;
}
static int lag_stepper_step(lag_stepper *s)
{
    real f[LAG_NY], h = r_fmin(s->h, s->t_end - s->t);
    int i, status;
    if (s->stats.accepted >= s->max_steps)
        return LAG_ERR_MAX_STEPS;
    if ((status = lag_rhs(s->sys, s->t, s->y, f)) != LAG_OK)
        return status;
    s->stats.rhs_evals += 1;
    memcpy(s->y_old, s->y, sizeof s->y);
    for (i = 0; i < LAG_NY; ++i)
        s->y[i] += h * f[i];
    s->t_old = s->t;
    s->t += h;
    s->stats.accepted += 1;
    return LAG_OK;
}
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real theta = (t - s->t_old) / (s->t - s->t_old);
    int i;
    for (i = 0; i < LAG_NY; ++i)
        yout[i] = s->y_old[i] + theta * (s->y[i] - s->y_old[i]);
    return LAG_OK;
}
static int lag_stepper_restart(lag_stepper *s) { (void)s; return LAG_OK; }
"""
# What the code generator writes for the scene's command line (model.c.j2).
SCENE = """
#define LAG_SCENE_T_START LAG_LIT(0.0)
#define LAG_SCENE_T_STOP LAG_LIT(2.0)
#define LAG_SCENE_T_INTERVAL LAG_LIT(0.5)
#define LAG_SCENE_OPTIONS { LAG_LIT(1e-08), LAG_LIT(1e-10), LAG_LIT(0.001), 0, 0, 0, 0L, NULL }
#if LAG_HAS_STOP
static const char lag_stop_text[] = "q1 < 0";
#endif
static int lag_option_setting(const char *program, const char *text, const char *equals, real value,
                              lag_options *options)
{
    (void)program;
    (void)equals;
    if (strncmp(text, "max-steps=", 10) == 0) {
        options->max_steps = (long)value;
        return 1;
    }
    return 0;
}
static void lag_print_options(FILE *file, const lag_options *options)
{
    fprintf(file, "step = %g", (double)options->step);
}
"""
# (constraints, holonomic, invariants, stop, integrator whose summary the stub reports, tolerances)
COMBINATIONS = {
    "nothing": (False, False, False, False, "rk4", False),
    "constraints": (True, False, False, False, "rk4", False),
    "holonomic": (True, True, False, False, "rk4", False),
    "invariants": (False, False, True, False, "rk4", False),
    "stop": (False, False, False, True, "rk4", False),
    "stiffness test": (False, False, False, False, "dop853", True),
    "switches": (False, False, False, False, "auto", True),
    "everything": (True, True, True, True, "dop853", True),
    "everything with switches": (True, False, True, True, "auto", True),
}


def program(constraints, holonomic, invariants, stop, integrator, tolerances) -> str:
    flags = {"LAG_HAS_CONSTRAINTS": constraints, "LAG_HAS_INVARIANTS": invariants, "LAG_HAS_STOP": stop,
             "LAG_HAS_STIFFNESS_TEST": integrator == "dop853", "LAG_HAS_SWITCHES": integrator == "auto",
             "LAG_HAS_TOLERANCES": tolerances}
    defines = "".join(f"#define {name} {int(value)}\n" for name, value in flags.items())
    layout = summary_layout(integrator, int(invariants), 4, constraints, stop)
    linear_algebra = c_file("lu.c") if constraints else ""      # the projection's; unused, it is a warning
    return "\n".join([HEADERS, runtime_header(), runtime_contract(), linear_algebra, defines,
                      MODEL % {"holonomic": "#define LAG_NH 1" if holonomic else ""}, STEPPER,
                      c_file("forecast.c"), c_file("driver.c"), summary_packer(layout), c_file("library.c"), SCENE,
                      status_printer(), verdict_printer() if integrator == "dop853" else "", standalone_source()])


def build(tmp_path, name: str, combination: tuple) -> str:
    cc = find_cc()
    if cc is None:
        pytest.skip("no C compiler")
    source, executable = tmp_path / f"{name}.c", tmp_path / name
    source.write_text(program(*combination))
    done = compiled([cc, *STRICT_FLAGS, str(source), "-o", str(executable), "-lm"])
    assert done.returncode == 0, done.stderr
    return str(executable)


# The default run compiles the driver with no guard and with every guard (either way of
# switching integrators); each guard alone is slow.
DEFAULT_COMBINATIONS = {"nothing", "everything", "everything with switches"}


@pytest.mark.parametrize("combination", [
    pytest.param(value, id=name, marks=() if name in DEFAULT_COMBINATIONS else pytest.mark.slow)
    for name, value in COMBINATIONS.items()])
def test_the_driver_compiles_alone_with_each_guard_a_scene_can_set(tmp_path, combination):
    build(tmp_path, "driver", combination)


def test_the_stub_program_runs_and_reports_as_the_python_side_words_it(tmp_path):
    executable = build(tmp_path, "everything", COMBINATIONS["everything"])
    done = subprocess.run([executable], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = done.stdout.splitlines()
    # q1 = cos t (to Euler's accuracy) turns negative near pi/2: the last row
    assert rows[0] == "t,q1" and [row.split(",")[0] for row in rows[1:5]] == ["0", "0.5", "1", "1.5"]
    assert len(rows) == 6 and rows[5].startswith("1.57") and "stopped at t = 1.57" in done.stderr
    assert done.stderr.startswith("integrator stub(step = 0.001): ")
    assert "drift of energy" in done.stderr and "largest constraint residual (together)" in done.stderr
    batch = subprocess.run([executable, "--batch"], input="q1.start=1 q2.start=1\n# none\n\nk=4\n",
                           capture_output=True, text=True)
    assert batch.returncode == 0, batch.stderr
    assert batch.stdout.splitlines()[0] == "member,t,q1" and batch.stdout.splitlines()[1].startswith("0,0,1")
    assert "2 members, 0 failed; integrator stub" in batch.stderr


def test_a_failure_is_worded_as_the_status_table_says(tmp_path):
    executable = build(tmp_path, "limited", COMBINATIONS["nothing"])
    done = subprocess.run([executable, "--max-steps=5"], capture_output=True, text=True)
    assert done.returncode == 1
    expected = STATUSES[MAX_STEPS].describe(max_steps=5)
    assert f"simulation failed at t = 0.0050000000000000001: {expected}\n" in done.stderr
    batch = subprocess.run([executable, "--batch", "--max-steps=5"], input="k=1\n", capture_output=True, text=True)
    assert f"member 0: simulation failed at t = 0.0050000000000000001 after 1 rows: {expected}\n" in batch.stderr
