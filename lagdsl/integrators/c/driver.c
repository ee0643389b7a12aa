/* The driver: integrate a scene on its output grid, projecting onto its constraints and watching
 * its invariants and its stop condition, and report how the run went (lag_integrate).
 *
 * Pasted into every generated C file after the model and the integrator (lagdsl/codegen/c.py);
 * library.c and the standalone program's files follow it. From the model it reads LAG_NQ, LAG_NY, LAG_NOUT,
 * lag_system, lag_system_prepare, lag_outputs and lag_condition, and what the scene has, as its
 * LAG_HAS_* flags say:
 *   LAG_HAS_CONSTRAINTS   LAG_NC (LAG_NH of them holonomic, first), lag_constraint_rows, lag_gram
 *   LAG_HAS_INVARIANTS    LAG_NINV, and lag_outputs(sys, t, y, out, inv)
 *   LAG_HAS_STOP          lag_stop_function
 *   LAG_HAS_SWITCHES      the integrator's lag_switches (auto)
 * and from the integrator its interface (README.md in this directory).
 */

/* The run report: how the integration went, what it cost, how well invariants held. */
typedef struct lag_report {
    int status;                    /* LAG_OK or the failure */
    real t_fail;                   /* on failure: the last time reached */
    real y_fail[LAG_NY];           /* on failure: the state there */
    real rcond_fail;               /* on failure: the reciprocal condition estimate of the system for q'' there */
    long rows;                     /* output rows delivered */
    lag_forecast forecast;         /* the work forecast, its last verdict in forecast.steps */
    lag_stats stats;
#if LAG_HAS_SWITCHES
    lag_switches switches;         /* auto: when it changed methods, and the span of t of each */
#endif
#if LAG_HAS_INVARIANTS
    real invariant_start[LAG_NINV];
    real invariant_drift[LAG_NINV];    /* max |I(t) - I(t0)| over the output rows */
#endif
#if LAG_HAS_CONSTRAINTS
    real residual_max;             /* max |constraint residual| over the output rows */
    real projection_start;         /* how far the initial state was moved onto the constraints */
#endif
#if LAG_HAS_STOP
    int stopped;                   /* the stop condition ended the run ... */
    real t_stop;                   /* ... at this time, the last row */
#endif
} lag_report;

/* Receives each output row (t and the LAG_NOUT columns); returns nonzero to stop. */
typedef int (*lag_sink)(void *context, real t, const real *out);
#if LAG_HAS_CONSTRAINTS

/* The least-norm correction of z (LAG_NQ entries) by the first `rows` rows of A (row-major, LAG_NQ
 * columns) and residuals r: z <- z - A^T (A A^T)^-1 r. *step is the largest |change|; fails
 * (LAG_ERR_PROJECTION) where A A^T is singular. */
static int lag_correct(int rows, const real *A, const real *r, real *z, real *step)
{
    real G[LAG_NC * LAG_NC], x[LAG_NC];
    int pivots[LAG_NC], i, k;
    lag_gram(rows, A, r, G, x);
    if (lag_lu_factor(rows, G, pivots) != 0)
        return LAG_ERR_PROJECTION;
    lag_lu_solve(rows, G, pivots, x);
    *step = 0;
    for (k = 0; k < LAG_NQ; ++k) {
        real change = 0;
        for (i = 0; i < rows; ++i)
            change += A[i * LAG_NQ + k] * x[i];
        z[k] -= change;
        *step = r_fmax(*step, r_fabs(change));
    }
    return LAG_OK;
}

/* Project y onto the constraint manifold: positions by Gauss-Newton on g(q, t) = 0
 * (q <- q - A_h^T (A_h A_h^T)^-1 g), then velocities onto A q' + b = 0
 * (q' <- q' - A^T (A A^T)^-1 c). Hairer, Lubich, Wanner, GNI, IV.4. Returns the size of the move.
 * The positions have converged when a correction is within rounding of q, or when corrections
 * below sqrt(eps) stop shrinking: Gauss-Newton converges quadratically down to the rounding of
 * g, which in a sum of n terms (a closed chain of 64 links) lies above a few eps of q. */
static int lag_project(const lag_system *sys, real t, real *y, real *moved)
{
    real c[LAG_NC], A[LAG_NC * LAG_NQ], step;
    int status;
#ifdef LAG_NH
    real g[LAG_NH], previous = REAL_MAX;
    int k, iteration;
#else
    real *g = NULL;
#endif
    *moved = 0;
#ifdef LAG_NH
    for (iteration = 0;; ++iteration) {
        real size = 0;
        lag_constraint_rows(sys->par, t, y, g, c, A);
        if ((status = lag_correct(LAG_NH, A, g, y, &step)) != LAG_OK)
            return status;
        for (k = 0; k < LAG_NQ; ++k)
            size = r_fmax(size, r_fabs(y[k]));
        *moved = r_fmax(*moved, step);
        if (step <= 4 * REAL_EPSILON * (1 + size)
            || (step > previous / 2 && step <= r_sqrt(REAL_EPSILON) * (1 + size)))
            break;
        if (iteration == 10)
            return LAG_ERR_PROJECTION;
        previous = step;
    }
#endif
    lag_constraint_rows(sys->par, t, y, g, c, A);
    if ((status = lag_correct(LAG_NC, A, c, y + LAG_NQ, &step)) != LAG_OK)
        return status;
    *moved = r_fmax(*moved, step);
    return LAG_OK;
}

static real lag_residual(const lag_system *sys, real t, const real *y)
{
    real c[LAG_NC], A[LAG_NC * LAG_NQ], largest = 0;
    int i;
#ifdef LAG_NH
    real g[LAG_NH];
    lag_constraint_rows(sys->par, t, y, g, c, A);
    for (i = 0; i < LAG_NH; ++i)
        largest = r_fmax(largest, r_fabs(g[i]));
#else
    lag_constraint_rows(sys->par, t, y, NULL, c, A);
#endif
    for (i = 0; i < LAG_NC; ++i)
        largest = r_fmax(largest, r_fabs(c[i]));
    return largest;
}
#endif

/* Deliver one output row and update the invariant and residual watch. */
static int lag_deliver(const lag_system *sys, real t, const real *y, lag_sink sink, void *context,
                       lag_report *report)
{
    real out[LAG_NOUT];
#if LAG_HAS_INVARIANTS
    real inv[LAG_NINV];
    int i, status = lag_outputs(sys, t, y, out, inv);
#else
    int status = lag_outputs(sys, t, y, out);
#endif
    if (status != LAG_OK)
        return status;
#if LAG_HAS_INVARIANTS
    for (i = 0; i < LAG_NINV; ++i) {
        if (report->rows == 0)
            report->invariant_start[i] = inv[i];
        report->invariant_drift[i] = r_fmax(report->invariant_drift[i], r_fabs(inv[i] - report->invariant_start[i]));
    }
#endif
#if LAG_HAS_CONSTRAINTS
    report->residual_max = r_fmax(report->residual_max, lag_residual(sys, t, y));
#endif
    report->rows += 1;
    return sink(context, t, out) ? LAG_ERR_MAX_STEPS : LAG_OK;
}
#if LAG_HAS_STOP

/* The time in the last step [t_old, t] where e = lag_stop_function turns negative: e(t_old) =
 * e_old >= 0 > e_new = e(t). The root of e along the step's dense output, by regula falsi with
 * the Illinois modification (Dahlquist and Bjorck, Numerical Methods, 6.2.3), to the resolution
 * of t; the bracket's right end, where the condition holds, goes to *root. Returns the status of
 * the dense output (which may evaluate the right-hand side on its first call in a step). */
static int lag_stop_root(const lag_system *sys, lag_stepper *stepper, real e_old, real e_new, real *root)
{
    real a = stepper->t_old, b = stepper->t, fa = e_old, fb = e_new, y[LAG_NY];
    int side = 0, iteration, status;
    for (iteration = 0; iteration < 200 && b - a > 4 * REAL_EPSILON * r_fmax(r_fabs(a), r_fabs(b)); ++iteration) {
        real c = b - fb * (b - a) / (fb - fa), fc;
        if (!(c > a && c < b))
            c = a + (b - a) / 2;    /* a secant step outside the bracket (or NaN): bisect */
        if ((status = lag_stepper_dense(stepper, c, y)) != LAG_OK)
            return status;
        fc = lag_stop_function(sys->par, c, y);
        if (fc < 0) {
            b = c;
            fb = fc;
            if (side == -1)
                fa /= 2;
            side = -1;
        } else {
            a = c;
            fa = fc;
            if (side == 1)
                fb /= 2;
            side = 1;
        }
    }
    *root = b;
    return LAG_OK;
}

/* After a step: does the stop condition hold at its end? Then *stopped = 1 and *t_stop is where
 * it began to. Returns a status (that of the dense output). */
static int lag_stop_check(const lag_system *sys, lag_stepper *stepper, real *e_old, int *stopped, real *t_stop)
{
    real e = lag_stop_function(sys->par, stepper->t, stepper->y);
    if (!(e < 0)) {
        *e_old = e;
        return LAG_OK;
    }
    *stopped = 1;
    return lag_stop_root(sys, stepper, *e_old, e, t_stop);
}
#endif

/* Set to 1 to stop the run between two steps (LAG_ERR_INTERRUPTED): by the standalone program's
 * SIGINT handler, or through ctypes by the Python side when Ctrl-C reaches it. */
volatile sig_atomic_t lag_interrupt = 0;
/* The time the integration has reached, for the progress line of `lagc run` (read through ctypes). */
volatile double lag_progress_t = 0;

/* The output grid: rows t0 + k dt for k = 0 .. last - 1, then t1 (a grid time within
 * LAG_GRID_SLACK dt of t1 is t1, so that 10 / 0.01 gives 1001 rows, not 1002); an interval longer
 * than the run gives the two rows t0 and t1. Returns `last`, the index of the final row. */
static long lag_last_row(real t0, real t1, real dt)
{
    real ratio = (t1 - t0) / dt;
    long last = (long)r_floor(ratio + LAG_GRID_SLACK);
    return ratio - last > LAG_GRID_SLACK || last == 0 ? last + 1 : last;
}

/* The step limit of a run from t0 to t1 whose final row is `last`: the options' max_steps if
 * given; for a fixed step (options->step > 0: rk4, gauss), the steps it implies, the user's own
 * count (one a step, and one more a row where a step is cut to land on it); else
 * LAG_DEFAULT_MAX_STEPS or LAG_STEPS_PER_ROW per output row, whichever is larger
 * (settings.step_limit); an adaptive run's work forecast stops it long before (lag_forecast). */
static long lag_step_limit(const lag_options *options, real t0, real t1, long last)
{
    if (options->max_steps > 0)
        return options->max_steps;
    if (options->step > 0) {
        real implied = r_floor((t1 - t0) / options->step) + 2 + last;
        return implied < (real)LAG_MAX_STEPS_CEILING ? (long)implied : LAG_MAX_STEPS_CEILING;
    }
    return last + 1 > LAG_DEFAULT_MAX_STEPS / LAG_STEPS_PER_ROW ? LAG_STEPS_PER_ROW * (last + 1) : LAG_DEFAULT_MAX_STEPS;
}

/* Step until the stepper reaches tk (or the stop condition ends the run), projecting after each
 * step; lag_interrupt ends it between two steps. */
static int lag_advance(lag_system *sys, lag_stepper *stepper, real tk, real *e_old, lag_report *report)
{
    int status = LAG_OK;
#if LAG_HAS_CONSTRAINTS
    real moved;
#elif !LAG_HAS_STOP
    (void)sys;      /* to project and to test the stop condition */
#endif
#if LAG_HAS_STOP
    while (stepper->t < tk && status == LAG_OK && !report->stopped) {
#else
    (void)e_old;
    while (stepper->t < tk && status == LAG_OK) {
#endif
        status = lag_stepper_step(stepper);
#if LAG_HAS_CONSTRAINTS
        if (status == LAG_OK) {
            status = lag_project(sys, stepper->t, stepper->y, &moved);
            if (status == LAG_OK)
                status = lag_stepper_restart(stepper);
        }
#endif
#if LAG_HAS_STOP
        if (status == LAG_OK)
            status = lag_stop_check(sys, stepper, e_old, &report->stopped, &report->t_stop);
#endif
        if (status == LAG_OK)
            status = lag_forecast_step(&report->forecast, stepper->t - stepper->t_old, stepper->t);
        lag_progress_t = (double)stepper->t;
        if (status == LAG_OK && lag_interrupt)
            status = LAG_ERR_INTERRUPTED;
    }
    return status;
}

/* The state at tk, which the stepper has reached: its own, or its dense output (projected). */
static int lag_state_at(lag_system *sys, lag_stepper *stepper, real tk, real *y)
{
    int status;
#if LAG_HAS_CONSTRAINTS
    real moved;
#else
    (void)sys;
#endif
    if (tk == stepper->t) {
        memcpy(y, stepper->y, sizeof(real) * LAG_NY);
        return LAG_OK;
    }
    status = lag_stepper_dense(stepper, tk, y);
#if LAG_HAS_CONSTRAINTS
    if (status == LAG_OK)
        status = lag_project(sys, tk, y, &moved);    /* output rows lie on the constraints too */
#endif
    return status;
}

/* The first row, at t0 from y0 (projected onto the constraints); the stop condition may hold
 * there already (then *last = 0: no more rows). */
static int lag_start(lag_system *sys, real t0, real *y, real *e_old, long *last, lag_sink sink, void *context,
                     lag_report *report)
{
    int status = LAG_OK;
#if LAG_HAS_CONSTRAINTS
    status = lag_project(sys, t0, y, &report->projection_start);
#else
    (void)lag_stepper_restart;     /* only constrained scenes project the state and restart */
#endif
    if (status == LAG_OK)
        status = lag_deliver(sys, t0, y, sink, context, report);
#if LAG_HAS_STOP
    if ((*e_old = lag_stop_function(sys->par, t0, y)) < 0) {    /* the condition holds at the start */
        report->stopped = 1;
        report->t_stop = t0;
        *last = 0;
    }
#else
    (void)e_old;
    (void)last;
#endif
    return status;
}

#ifndef LAG_FMU     /* an FMU steps from one communication point to the next (fmu_run.c) */
/* The row at tk, which the stepper has reached (lag_state_at). */
static int lag_deliver_at(lag_system *sys, lag_stepper *stepper, real tk, lag_sink sink, void *context,
                          lag_report *report)
{
    real y[LAG_NY];
    int status = lag_state_at(sys, stepper, tk, y);
    if (status != LAG_OK)
        return status;
    return lag_deliver(sys, tk, y, sink, context, report);
}

/* The report of a run that ended with `status` where the stepper stands. */
static void lag_finish(lag_system *sys, const lag_stepper *stepper, int status, lag_report *report)
{
    report->stats = stepper->stats;
#if LAG_HAS_SWITCHES
    report->switches = stepper->switches;
#endif
    report->status = status;
    if (status != LAG_OK) {
        report->t_fail = stepper->t;
        memcpy(report->y_fail, stepper->y, sizeof report->y_fail);
        report->rcond_fail = lag_condition(sys, report->t_fail, report->y_fail);
    }
}

/* The start of a run on the grid of lag_last_row, *last its final row: the first row, and the
 * stepper (zeroed here) at (t0, y0) with the step limit in *limited (the options it keeps). */
static int lag_begin(lag_system *sys, lag_stepper *stepper, const real *y0, real t0, real t1, real dt,
                     const lag_options *options, lag_options *limited, lag_sink sink, void *context,
                     lag_report *report, real *e_old, long *last)
{
    real y[LAG_NY];
    int status;
    memcpy(y, y0, sizeof y);
    memset(stepper, 0, sizeof *stepper);
    stepper->t = t0;           /* where a failure before the first step (projecting y0) is reported */
    memcpy(stepper->y, y, sizeof stepper->y);
    *last = lag_last_row(t0, t1, dt);
    *limited = *options;
    limited->max_steps = lag_step_limit(options, t0, t1, *last);
    report->forecast.start = t0;
    report->forecast.stop = t1;
    report->forecast.budget = options->step > 0 ? 0 : limited->max_steps;     /* a fixed step's count is known */
    lag_progress_t = (double)t0;
    status = lag_start(sys, t0, y, e_old, last, sink, context, report);
    if (status == LAG_OK)
        status = lag_stepper_init(stepper, sys, t0, y, t1, limited);
    return status;
}

/* Integrate from (t0, y0) to t1 and deliver the outputs on the grid of lag_last_row. The caller
 * has checked the grid (finite, t1 > t0, dt > 0, at most LAG_MAX_ROWS rows) and set sys->par. */
static int lag_integrate(lag_system *sys, const real *y0, real t0, real t1, real dt,
                         const lag_options *options, lag_sink sink, void *context, lag_report *report)
{
    lag_stepper *stepper = malloc(sizeof *stepper);
    lag_options limited;
    real e_old = 0;
    long k, last;
    int status;
    memset(report, 0, sizeof *report);
    lag_system_prepare(sys);
    if (stepper == NULL)
        return report->status = LAG_ERR_MAX_STEPS;
    status = lag_begin(sys, stepper, y0, t0, t1, dt, options, &limited, sink, context, report, &e_old, &last);
    for (k = 1; k <= last && status == LAG_OK; ++k) {
        real tk = k == last ? t1 : t0 + k * dt;
        if ((status = lag_advance(sys, stepper, tk, &e_old, report)) != LAG_OK)
            break;
#if LAG_HAS_STOP
        if (report->stopped && report->t_stop <= tk) {    /* the last row is at the event */
            tk = report->t_stop;
            last = k;
        }
#endif
        status = lag_deliver_at(sys, stepper, tk, sink, context, report);
    }
    lag_finish(sys, stepper, status, report);
    free(stepper);
    return status;
}
#endif
