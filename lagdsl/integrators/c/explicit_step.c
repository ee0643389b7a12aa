/* The step protocol of the embedded explicit pairs dopri5.c, dop853.c and rkn8.c: the start
 * (f at the initial state, the starting step) and an accepted step (trials of decreasing size
 * until one passes the error test), with the step-size control of explicit_control.c.
 *
 * Pasted after the pair's file, which defines its lag_stepper (with the members t, t_old, y, h,
 * stats, sys, control and y_new, the new state of the current trial) and names its parts:
 *   LAG_PAIR_ORDER                      p, the power of h in its error estimate
 *   LAG_PAIR_START(s, f)                its own state at (t0, y0), f = f(t0, y0)
 *   LAG_PAIR_TRIAL(s, h, t_new, &err)   a trial of size h from (t, y): y_new and the scaled error
 *                                       err; returns LAG_OK or the status of a failed stage
 *   LAG_PAIR_ACCEPT(s, h, t_new)        what it keeps of an accepted trial, before the step moves
 *                                       the state to (t_new, y_new)
 * (macros, so that each part of a composite names its own; undefined at the end of this file).
 */

static int lag_stepper_init(lag_stepper *s, const lag_system *sys, real t0, const real *y0,
                            real t_end, const lag_options *opt)
{
    real f[LAG_NY];
    int status;
    memset(&s->stats, 0, sizeof s->stats);
    s->sys = sys;
    s->t = s->t_old = t0;
    memcpy(s->y, y0, sizeof s->y);
    lag_control_init(&s->control, opt, t0, t_end, LAG_PAIR_ORDER);
    if ((status = lag_control_rhs(sys, &s->stats, t0, s->y, f)) != LAG_OK)
        return status;
    LAG_PAIR_START(s, f);
    s->h = lag_control_first_step(&s->control, opt, sys, &s->stats, t0, s->y, f);
    return LAG_OK;
}

static int lag_stepper_step(lag_stepper *s)
{
    real h, t_new, err = 0;
    int status;
    while (s->t < s->control.t_end) {
        if ((status = lag_control_trial(&s->control, &s->stats, s->t, s->h, &h, &t_new)) != LAG_OK)
            return status;
        status = LAG_PAIR_TRIAL(s, h, t_new, &err);
        if (lag_control_update(&s->control, &s->stats, status, h, err, &s->h)) {
            LAG_PAIR_ACCEPT(s, h, t_new);
            memcpy(s->y, s->y_new, sizeof s->y);
            s->t_old = s->t;
            s->t = t_new;
            break;
        }
    }
    return LAG_OK;
}

#undef LAG_PAIR_ORDER
#undef LAG_PAIR_START
#undef LAG_PAIR_TRIAL
#undef LAG_PAIR_ACCEPT
