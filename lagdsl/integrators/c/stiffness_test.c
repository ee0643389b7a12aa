/* Stiffness detection, Hairer-Norsett-Wanner I, Section IV.2 ("Automatic Stiffness Detection"),
 * as in the codes DOPRI5 and DOP853 (pasted after explicit_control.c, for those two only), with a
 * verdict on the kind of fast mode that held the steps.
 *
 * The trigger: the last two stages of the pairs evaluate f at the same time t + h, at the stage
 * argument y_stage and at the new solution y_new (FSAL), so
 *     h lambda = h ||f(t+h, y_new) - f(t+h, y_stage)|| / ||y_new - y_stage||
 * estimates h times the dominant eigenvalue of df/dy at no cost.  LAG_STIFF_STEPS accepted steps
 * with h lambda beyond the method's stability boundary (LAG_DOPRI5_STABILITY_BOUNDARY, ...),
 * without LAG_CALM_STEPS non-stiff ones in a row in between, call for a verdict.
 *
 * The verdict (lag_fast_mode): a fast mode excited above the tolerance must be resolved by any
 * method, while a damped or unexcited one is stiff in the sense an implicit method helps with
 * (it steps over it and damps what is left).  At the verdict's step (t, y, f = y'):
 *   rho^2 = ||J^2 v|| / ||v||, rho the spectral radius of J = df/dy, by LAG_FAST_ITERATIONS steps
 *     of power iteration on J^2 from v = f, each J u a difference quotient of f (the fast modes
 *     of a mechanical system come as pairs +-i omega or a +- i b, whose squares have one
 *     modulus, so the iteration on J^2 settles where one on J would oscillate);
 *   y'' = (f(t + d, y + d f) - f) / d with d = LAG_FAST_PROBE / rho, the time derivative of f
 *     along the solution: a fast mode of amplitude A contributes rho^2 A to it, the slow motion
 *     about Omega^2 |y| (Omega its frequency), a part (Omega / rho)^2 of that; J y'' (one more
 *     product) holds the fast mode a quarter period on, so that for a mode q = A cos(phi),
 *     q' = -omega A sin(phi) the sum below does not depend on its phase phi;
 *   amplitude = sqrt((|y''|^2 + |J y''|^2 / rho^2) / 2n) / rho^2, with |.| weighting component i
 *     by 1 / (atol + rtol |y_i|) (as the error test does): the fast mode's amplitude in units of
 *     the tolerance.
 * Above LAG_EXCITED_AMPLITUDE the mode is excited and must be resolved (LAG_VERDICT_OSCILLATION,
 * period 2 pi / rho): an implicit method would not take larger steps.  Below, it is
 * LAG_VERDICT_STIFF.  (While the pair runs at its stability boundary, its step-size control
 * holds an unexcited mode near the tolerance: amplitude 0.07 .. 8, hence the margin.)  The
 * verdict costs 2 LAG_FAST_ITERATIONS + 2 evaluations of f.  A stiff verdict is final; after an
 * oscillation the test goes on, and calls for the next verdict after twice as many stiff steps
 * (the oscillation may be damped slowly).  The statistics keep the first verdict, or the first
 * stiff one after an oscillation: the kind (stats->stiff), when, the counters then, rho and the
 * amplitude, and the mean step of the pair over the steps that made it (auto.c compares radau5's
 * steps with it). */
typedef struct lag_stiffness_test {
    real boundary;      /* h lambda beyond which a step counts as stiff */
    real h_lambda;      /* the estimate of the trial that is being accepted */
    int stiff_steps;    /* stiff accepted steps since the last run of non-stiff ones */
    int calm_steps;     /* non-stiff accepted steps in a row */
    long patience;      /* stiff steps that call for the next verdict */
    real window_t;      /* t and the trials (accepted + rejected) when the stiff steps began */
    long window_trials;
    real v[LAG_NY], jv[LAG_NY], probe[LAG_NY];   /* the power iteration's vectors, a probe's state */
} lag_stiffness_test;

static void lag_stiffness_start(lag_stiffness_test *test, real boundary)
{
    test->boundary = boundary;
    test->h_lambda = 0;
    test->stiff_steps = test->calm_steps = 0;
    test->patience = LAG_STIFF_STEPS;
}

/* h lambda of the trial of size h from its two derivatives at t + h (0 when y_new = y_stage). */
static void lag_stiffness_measure(lag_stiffness_test *test, real h, const real *y_new, const real *y_stage,
                                  const real *f_new, const real *f_stage)
{
    real df = 0, dy = 0;
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        df += (f_new[i] - f_stage[i]) * (f_new[i] - f_stage[i]);
        dy += (y_new[i] - y_stage[i]) * (y_new[i] - y_stage[i]);
    }
    test->h_lambda = dy > 0 ? h * r_sqrt(df / dy) : 0;
}

/* J u ~ (f(t, y + delta u) - f) / delta, delta = sqrt(eps) (1 + |y|) / |u|, into ju (u != ju);
 * `evals` counts the evaluation.  `probe` is scratch. */
static int lag_jacobian_product(const lag_system *sys, long *evals, real t, const real *y, const real *f,
                                const real *u, real *ju, real *probe)
{
    real size_u = 0, size_y = 0, delta;
    int i, status;
    for (i = 0; i < LAG_NY; ++i) {
        size_u += u[i] * u[i];
        size_y += y[i] * y[i];
    }
    if (!(size_u > 0) || !r_isfinite(size_u))
        return LAG_ERR_NONFINITE;
    delta = r_sqrt(REAL_EPSILON) * (1 + r_sqrt(size_y)) / r_sqrt(size_u);
    for (i = 0; i < LAG_NY; ++i)
        probe[i] = y[i] + delta * u[i];
    status = lag_rhs(sys, t, probe, ju);
    *evals += 1;
    for (i = 0; i < LAG_NY; ++i)
        ju[i] = (ju[i] - f[i]) / delta;
    return status;
}

/* One step of power iteration on J^2 at (t, y), f = f(t, y): v <- J^2 v / |J^2 v|; returns
 * |J^2 v| / |v| (an estimate of rho^2), 0 when nothing was learnt (J^2 v = 0, a failed f). */
static real lag_power_step(const lag_system *sys, long *evals, real t, const real *y, const real *f,
                           real *v, real *jv, real *probe)
{
    real before = 0, size = 0;
    int i;
    for (i = 0; i < LAG_NY; ++i)
        before += v[i] * v[i];
    if (lag_jacobian_product(sys, evals, t, y, f, v, jv, probe) != LAG_OK
        || lag_jacobian_product(sys, evals, t, y, f, jv, v, probe) != LAG_OK)
        return 0;
    for (i = 0; i < LAG_NY; ++i)
        size += v[i] * v[i];
    size = r_sqrt(size);
    if (!(size > 0) || !r_isfinite(size))
        return 0;
    for (i = 0; i < LAG_NY; ++i)
        v[i] /= size;
    return size / r_sqrt(before);
}

/* The kind of the fast mode at (t, y), f = f(t, y) (the rule above): LAG_VERDICT_STIFF or
 * LAG_VERDICT_OSCILLATION, with rho and the amplitude; 0 when a probe failed. */
static int lag_fast_mode(lag_stiffness_test *test, const lag_system *sys, const lag_control *control,
                         long *evals, real t, const real *y, const real *f, real *rho, real *amplitude)
{
    real rho2 = 0, d, w, sum = 0;
    int i, k;
    memcpy(test->v, f, sizeof test->v);
    for (k = 0; k < LAG_FAST_ITERATIONS; ++k)
        if (!((rho2 = lag_power_step(sys, evals, t, y, f, test->v, test->jv, test->probe)) > 0))
            return 0;
    *rho = r_sqrt(rho2);
    d = LAG_FAST_PROBE / *rho;
    for (i = 0; i < LAG_NY; ++i)
        test->probe[i] = y[i] + d * f[i];
    *evals += 1;
    if (lag_rhs(sys, t + d, test->probe, test->jv) != LAG_OK)
        return 0;
    for (i = 0; i < LAG_NY; ++i)
        test->v[i] = (test->jv[i] - f[i]) / d;     /* y'' */
    if (lag_jacobian_product(sys, evals, t, y, f, test->v, test->jv, test->probe) != LAG_OK)
        return 0;
    for (i = 0; i < LAG_NY; ++i) {
        w = lag_control_scale(control, y[i], y[i]);
        sum += (test->v[i] / w) * (test->v[i] / w) + (test->jv[i] / w) * (test->jv[i] / w) / rho2;
    }
    *amplitude = r_sqrt(sum / (2 * LAG_NY)) / rho2;
    if (!r_isfinite(*amplitude))
        return 0;
    return *amplitude > LAG_EXCITED_AMPLITUDE ? LAG_VERDICT_OSCILLATION : LAG_VERDICT_STIFF;
}

/* Count the accepted step that ended at (t, y) with f = f(t, y); stats already counts it. */
static void lag_stiffness_record(lag_stiffness_test *test, const lag_system *sys, const lag_control *control,
                                 lag_stats *stats, real t, const real *y, const real *f)
{
    real rho = 0, amplitude = 0;
    int kind;
    if (stats->stiff == LAG_VERDICT_STIFF)
        return;
    if (!(test->h_lambda > test->boundary)) {
        if (++test->calm_steps == LAG_CALM_STEPS)
            test->stiff_steps = 0;
        return;
    }
    test->calm_steps = 0;
    if (test->stiff_steps++ == 0) {
        test->window_t = t;
        test->window_trials = stats->accepted + stats->rejected;
    }
    if (test->stiff_steps < test->patience)
        return;
    test->stiff_steps = 0;
    kind = lag_fast_mode(test, sys, control, &stats->rhs_evals, t, y, f, &rho, &amplitude);
    if (kind == LAG_VERDICT_OSCILLATION)
        test->patience *= 2;
    if (kind == 0 || (stats->stiff && kind == LAG_VERDICT_OSCILLATION))
        return;
    stats->stiff = kind;
    stats->stiff_time = t;
    stats->stiff_rate = rho;
    stats->stiff_amplitude = amplitude;
    stats->stiff_step = (t - test->window_t) / (stats->accepted + stats->rejected - test->window_trials);
    stats->stiff_accepted = stats->accepted;
    stats->stiff_rejected = stats->rejected;
    stats->stiff_rhs_evals = stats->rhs_evals;
}
