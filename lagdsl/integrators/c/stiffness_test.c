/* Stiffness detection, Hairer-Norsett-Wanner I, Section IV.2 ("Automatic Stiffness Detection"),
 * as in the codes DOPRI5 and DOP853 (pasted after explicit_control.c, for those two only).  The
 * last two stages of the pairs evaluate f at the same time t + h, at the stage argument y_stage
 * and at the new solution y_new (FSAL), so
 *     h lambda = h ||f(t+h, y_new) - f(t+h, y_stage)|| / ||y_new - y_stage||
 * estimates h times the dominant eigenvalue of df/dy.  A step whose h lambda exceeds the method's
 * stability boundary (3.25 for DOPRI5, 6.1 for DOP853) was limited by stability rather than
 * accuracy; 15 such accepted steps, without 6 non-stiff ones in a row in between, mean the
 * problem is stiff: the first time, the counters are recorded in the statistics (stiff = 1), so
 * that the run summary can say when, what the explicit method has cost since, and recommend an
 * implicit method. */
typedef struct lag_stiffness_test {
    real boundary;      /* h lambda beyond which a step counts as stiff */
    real h_lambda;      /* the estimate of the trial that is being accepted */
    int stiff_steps;    /* stiff accepted steps since the last run of non-stiff ones */
    int calm_steps;     /* non-stiff accepted steps in a row */
} lag_stiffness_test;

#define LAG_STIFF_STEPS 15   /* stiff steps that make the verdict */
#define LAG_CALM_STEPS 6     /* non-stiff steps in a row that clear the stiff count */

static void lag_stiffness_start(lag_stiffness_test *test, real boundary)
{
    test->boundary = boundary;
    test->h_lambda = 0;
    test->stiff_steps = test->calm_steps = 0;
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

/* Count the accepted step that ended at t; stats already counts it. */
static void lag_stiffness_record(lag_stiffness_test *test, lag_stats *stats, real t)
{
    if (!(test->h_lambda > test->boundary)) {
        if (++test->calm_steps == LAG_CALM_STEPS)
            test->stiff_steps = 0;
        return;
    }
    test->calm_steps = 0;
    if (++test->stiff_steps == LAG_STIFF_STEPS && !stats->stiff) {
        stats->stiff = 1;
        stats->stiff_time = t;
        stats->stiff_accepted = stats->accepted;
        stats->stiff_rejected = stats->rejected;
        stats->stiff_rhs_evals = stats->rhs_evals;
    }
}
