/* lagdsl C runtime: precision, libm function table, run options.
 *
 * This fragment is pasted at the top of every generated C file (after the system #includes
 * <math.h>, <float.h>, <stdio.h>, <stdlib.h>, <string.h>), so it has no #include of its own
 * except the optional <quadmath.h>.  Every floating-point type and libm call in generated code
 * and in the bundled integrators goes through the names below, so that one macro switches the
 * whole program between double (default), long double (-DLAG_LONG_DOUBLE) and __float128
 * (-DLAG_FLOAT128, links -lquadmath): the extended-precision reference runs of `lagc bench`.
 */
#if defined(LAG_FLOAT128)
#include <quadmath.h>
typedef __float128 real;
#define LAG_FN(name) name##q
#define LAG_LIT(x) x##Q
#define REAL_EPSILON FLT128_EPSILON
#define REAL_MAX FLT128_MAX
#define REAL_MIN FLT128_MIN
#define REAL_DIG 34
#elif defined(LAG_LONG_DOUBLE)
typedef long double real;
#define LAG_FN(name) name##l
#define LAG_LIT(x) x##L
#define REAL_EPSILON LDBL_EPSILON
#define REAL_MAX LDBL_MAX
#define REAL_MIN LDBL_MIN
#define REAL_DIG 21
#else
typedef double real;
#define LAG_FN(name) name
#define LAG_LIT(x) x
#define REAL_EPSILON DBL_EPSILON
#define REAL_MAX DBL_MAX
#define REAL_MIN DBL_MIN
#define REAL_DIG 17
#endif

/* The libm function table: r_sqrt is sqrt, sqrtl or sqrtq. */
/* LIBM_TABLE: generated from lagdsl/frontend/functions.py, pasted here by codegen/c.py */

static int r_isfinite(real x) { return x - x == x - x; } /* false for inf and nan in every precision */

/* The status codes (enum lag_status), the constants shared with the Python side and the smallest
 * step's factor LAG_MIN_STEP_EPS follow this fragment, generated from lagdsl/abi.py and
 * lagdsl/settings.py (lagdsl/codegen/c_abi.py). */

/* The smallest step an adaptive method may take from t on a run of length `span`:
 * LAG_MIN_STEP_EPS eps max(|t|, span) (why: settings.MIN_STEP_EPS). */
#define LAG_MIN_STEP(t, span) (LAG_MIN_STEP_EPS * REAL_EPSILON * r_fmax(r_fabs(t), (span)))
/* The smallest first step (why: settings.START_STEP_MIN_STEPS). */
#define LAG_START_STEP_FLOOR(t, span) (LAG_START_STEP_MIN_STEPS * LAG_MIN_STEP(t, span))

/* What the driver asks of an integrator; unused fields are ignored by each method. */
typedef struct lag_options {
    real rtol, atol;   /* adaptive methods: error tolerance per component, |e_i| <= atol + rtol*|y_i| */
    real step;         /* fixed-step methods (rk4, gauss): the step; adaptive: initial step, 0 = automatic */
    real max_step;     /* adaptive: largest step, 0 = no limit */
    int stages;        /* gauss: number of stages s (order 2s) */
    int norm;          /* taylor: the error norm, 0 component, 1 state (integrators/registry.py: norm) */
    long max_steps;    /* give up after this many attempted steps (every try counts), 0 = no limit;
                        * the driver always sets a limit */
    const double *atol_each;   /* adaptive methods: the atol of each of the LAG_NY components of y,
                                * or NULL: atol for every one (lagdsl/tolerances.py) */
} lag_options;

/* The absolute tolerance of component i of y. */
#define LAG_ATOL(opt, i) ((opt)->atol_each != NULL ? (real)(opt)->atol_each[i] : (opt)->atol)

/* The members every integrator's lag_stepper begins with, which the driver reads (README.md): the
 * time reached by the last accepted step, the start of that step (the dense output is valid on
 * [t_old, t]), the state at t in (q, q') form, the step size proposed for the next step, and the
 * integrator's work counters (its own `stats_type`, lag_stats). */
#define LAG_STEPPER_PUBLIC(stats_type) \
    real t;                 \
    real t_old;             \
    real y[LAG_NY];         \
    real h;                 \
    stats_type stats;

#ifndef LAG_FMU     /* an FMU reads and writes no text of numbers (codegen/fmu.py) */
/* The declared unit of an input of the standalone program, in which NAME=VALUE reads a plain
 * number (as lagc run --set does): as written, in SI, its dimension in words, and its factor to
 * SI as scale + scale_low (the generated table lag_input_units, one a parameter, start, velocity). */
typedef struct lag_input_unit {
    const char *unit, *si, *dimension;
    double scale, scale_low;
} lag_input_unit;

/* Reading and writing numbers in the working precision (the CSV and the command line). */
#if defined(LAG_FLOAT128)
#define r_strtod(text, end) strtoflt128((text), (end))
static void lag_print_number(FILE *file, real x)
{
    char buffer[64];
    quadmath_snprintf(buffer, sizeof buffer, "%.36Qg", x);
    fputs(buffer, file);
}
#elif defined(LAG_LONG_DOUBLE)
#define r_strtod(text, end) strtold((text), (end))
static void lag_print_number(FILE *file, real x) { fprintf(file, "%.21Lg", x); }
#else
#define r_strtod(text, end) strtod((text), (end))
static void lag_print_number(FILE *file, real x) { fprintf(file, "%.17g", x); }
#endif

/* A NaN is written "nan" whatever its sign bit (printf may write "-nan"), as lagc run writes it. */
static void lag_print_real(FILE *file, real x)
{
    if (x != x)
        fputs("nan", file);
    else
        lag_print_number(file, x);
}
#endif
