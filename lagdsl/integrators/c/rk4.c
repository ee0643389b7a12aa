/* RK4: the classical explicit Runge-Kutta method of order 4 with a fixed step,
 * Hairer-Norsett-Wanner I (HNW I), Section II.1 (Kutta 1901, "the" Runge-Kutta method).
 *
 * The steps end at t0 + n*step, the last one is shortened to end exactly at t_end.
 * f(t, y) at the end of each step is computed once and serves both as the first stage of the
 * next step and as the end slope of the dense output, so a step costs 4 evaluations.
 * Dense output: the cubic Hermite interpolant of y and f at both ends of the step (HNW I, II.6),
 * of order 3: its local error O(h^4) matches the global error of the method.
 */

#define LAG_INTEGRATOR_NAME "rk4"

/* Work counters, printed by the run summary (a fixed step has no rejections to count). */
typedef struct lag_stats {
    long accepted, rhs_evals;
} lag_stats;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    const lag_system *sys;
    real t0, t_end;
    long steps;        /* number of steps from t0 to t_end, the last one possibly shorter */
    real f[LAG_NY];    /* f(t, y) */
    real y_old[LAG_NY], f_old[LAG_NY];  /* y and f at t_old, for the dense output */
} lag_stepper;

static int rk4_rhs(lag_stepper *s, real t, const real *y, real *f)
{
    ++s->stats.rhs_evals;
    return lag_rhs(s->sys, t, y, f);
}

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    memset(&s->stats, 0, sizeof s->stats);
    s->sys = sys;
    s->t = s->t_old = s->t0 = t0;
    s->t_end = t_end;
    s->h = opt->step;
    memcpy(s->y, y0, sizeof s->y);
    memcpy(s->y_old, y0, sizeof s->y_old);
    if (!(opt->step > 0))
        return LAG_ERR_STEP_TOO_SMALL;
    if ((s->steps = lag_step_count(t0, t_end, opt->step, opt->max_steps)) < 0)
        return LAG_ERR_MAX_STEPS;      /* known before the first step: the step is too small */
    return rk4_rhs(s, t0, s->y, s->f);
}

/* One step of size h = t_new - t from (t, y, f = k1): the new state and its derivative. */
static int rk4_advance(lag_stepper *s, real t_new, real *y_new, real *f_new)
{
    real k2[LAG_NY], k3[LAG_NY], k4[LAG_NY], y_stage[LAG_NY];
    real h = t_new - s->t, t_mid = s->t + h / 2;
    int i, status;
    for (i = 0; i < LAG_NY; ++i)
        y_stage[i] = s->y[i] + (h / 2) * s->f[i];
    if ((status = rk4_rhs(s, t_mid, y_stage, k2)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        y_stage[i] = s->y[i] + (h / 2) * k2[i];
    if ((status = rk4_rhs(s, t_mid, y_stage, k3)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        y_stage[i] = s->y[i] + h * k3[i];
    if ((status = rk4_rhs(s, t_new, y_stage, k4)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        y_new[i] = s->y[i] + (h / 6) * (s->f[i] + 2 * (k2[i] + k3[i]) + k4[i]);
    return rk4_rhs(s, t_new, y_new, f_new);
}

static int lag_stepper_step(lag_stepper *s)
{
    real y_new[LAG_NY], f_new[LAG_NY], t_new;
    long n = s->stats.accepted + 1;
    int status;
    if (n > s->steps)
        return LAG_OK;
    /* from t0 rather than by accumulation, so the grid does not drift */
    t_new = n == s->steps ? s->t_end : s->t0 + (real)n * s->h;
    if ((status = rk4_advance(s, t_new, y_new, f_new)) != LAG_OK)
        return status;
    memcpy(s->y_old, s->y, sizeof s->y_old);
    memcpy(s->f_old, s->f, sizeof s->f_old);
    memcpy(s->y, y_new, sizeof s->y);
    memcpy(s->f, f_new, sizeof s->f);
    s->t_old = s->t;
    s->t = t_new;
    ++s->stats.accepted;
    return LAG_OK;
}

/* Valid on [t_old, t] once a step has been taken:
 * y_old + theta (dy + (1-theta) (h f_old - dy + theta (2 dy - h f_old - h f))), dy = y - y_old. */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real h = s->t - s->t_old, theta = (t - s->t_old) / h, theta1 = 1 - theta;
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        real dy = s->y[i] - s->y_old[i], slope0 = h * s->f_old[i] - dy;
        yout[i] = s->y_old[i] + theta * (dy + theta1 * (slope0 + theta * (dy - h * s->f[i] - slope0)));
    }
    return LAG_OK;
}

/* The driver moved y (projection): the derivative there starts the next step and ends the
 * dense output, which therefore ends at the moved state. */
static int lag_stepper_restart(lag_stepper *s)
{
    return rk4_rhs(s, s->t, s->y, s->f);
}
