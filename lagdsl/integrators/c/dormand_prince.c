/* What the Dormand-Prince pairs dopri5.c and dop853.c share beyond the step protocol: f at the
 * end of a step is the next step's first stage k1 (FSAL), the stiffness test (stiffness_test.c)
 * judges each accepted step, and the continuous extension on the last accepted step [t_old, t]
 * is kept as terms r1, r2, ... in dense[]: r1 = y_old and r2 = y_new - y_old are set when the step
 * is accepted, the others only when the dense output is first asked about the step (dense_built),
 * from the stages it kept (k1_done, the first stage of that step, and the later ones).
 *
 * Pasted after the pair's file and before explicit_step.c, whose LAG_PAIR_START and
 * LAG_PAIR_ACCEPT it defines. The pair's file names its last stage, f(t_new, y_new), as
 * LAG_PAIR_LAST_STAGE and its stability boundary as LAG_PAIR_STIFFNESS_BOUNDARY (a constant of the
 * registry, lagdsl/integrators/registry.py).
 */

/* The start at (t0, y0 = s->y), f = f(t0, y0): until the first step, the dense output is the
 * constant y0. */
static void dormand_prince_start(lag_stepper *s, const real *f)
{
    int i;
    memset(s->dense, 0, sizeof s->dense);
    for (i = 0; i < LAG_NY; ++i)
        s->dense[0][i] = s->y[i];
    s->dense_built = 1;
    s->h_done = 0;
    lag_stiffness_start(&s->stiffness, LAG_PAIR_STIFFNESS_BOUNDARY);
    memcpy(s->k1, f, sizeof s->k1);
}

/* An accepted trial of size h to t_new: r1 and r2 of its dense output, its first stage and the
 * next one's, and its count in the stiffness test (whose h lambda the trial measured), at the
 * new state y_new with f = k1. */
static void dormand_prince_accept(lag_stepper *s, real h, real t_new)
{
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        s->dense[0][i] = s->y[i];
        s->dense[1][i] = s->y_new[i] - s->y[i];
    }
    s->dense_built = 0;
    memcpy(s->k1_done, s->k1, sizeof s->k1);
    memcpy(s->k1, s->LAG_PAIR_LAST_STAGE, sizeof s->k1);
    s->h_done = h;
    lag_stiffness_record(&s->stiffness, s->sys, &s->control, &s->stats, t_new, s->y_new, s->k1);
}

/* The driver moved y (projection): refresh the FSAL derivative, and add theta (y - y_end) to the
 * dense output so that it still ends at the state the next step starts from. */
static int lag_stepper_restart(lag_stepper *s)
{
    int i;
    for (i = 0; i < LAG_NY; ++i)
        s->dense[1][i] = s->y[i] - s->dense[0][i];
    return lag_control_rhs(s->sys, &s->stats, s->t, s->y, s->k1);
}

#define LAG_PAIR_START dormand_prince_start
#define LAG_PAIR_ACCEPT dormand_prince_accept
#undef LAG_PAIR_LAST_STAGE
#undef LAG_PAIR_STIFFNESS_BOUNDARY
