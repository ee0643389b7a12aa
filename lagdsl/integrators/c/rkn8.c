/* RKN8: the explicit Runge-Kutta-Nystrom pair of order 8(6) of Dormand, El-Mikkawy and Prince,
 * RKN8(6)9 (IMA J. Numer. Anal. 7 (1987) 423-430), for second-order systems whose accelerations
 * do not depend on the velocities:
 *     q'' = a(t, q),   y = (q, v), v = q'.
 * Method: Hairer-Norsett-Wanner I (HNW I), Section II.14 (Nystrom methods, (14.12)): with
 * g_1 = a(t, q) and, for i = 2..8,
 *     Q_i = q + h (c_i v + h sum_{j<i} abar_ij g_j),   g_i = a(t + c_i h, Q_i),
 * the step is
 *     q_new = q + h (v + h sum_i bbar_i g_i),   v_new = v + h sum_i b_i g_i,
 * and g_9 = a(t + h, q_new) is the next step's g_1 (FSAL; bbar = abar_9). The embedded pair of
 * order 6 differs by the weights e (positions) and e' (velocities, which use g_9 too):
 *     err_q = h^2 sum_i e_i g_i,   err_v = h sum_i e'_i g_i,
 * measured together in the norm of HNW I, II.4, (4.11) over the 2n components; err = O(h^7),
 * hence the exponent 1/7 of the step-size controller. A step, accepted or rejected, costs 8
 * evaluations of a. The coefficients are rational, written as quotients of integers that are
 * exact in every precision (so each is rounded once, to the working precision).
 *
 * Why a Nystrom method: the stage arithmetic runs over the n positions only (a first-order pair
 * such as DOP853 runs over the 2n components of y, and copies v into f at every stage), and the
 * pair is more accurate per step on such problems: on the 200-mass FPU chain at rtol 1e-9 its
 * error is below that of DOP853 at rtol 1e-11 (benchmarks/large_systems.py).
 *
 * Dense output: the method has no continuous extension, so y at t_old < t_out < t is a step of
 * the same method from (t_old, y_old) of size t_out - t_old (7 evaluations, g_1 being kept): as
 * accurate as an accepted step, and the steps themselves do not depend on the output grid.
 * When the output interval is shorter than the steps, dop853 (whose dense output is nearly free)
 * is the cheaper choice.
 * Step-size control (safety 0.9, factor within [0.2, 10]) and the starting step (from f = (v, a)):
 * explicit_control.c, which must be pasted before this file; the start and the accepted step:
 * explicit_step.c, pasted after it.
 */

#define LAG_INTEGRATOR_NAME "rkn8"
/* For the step protocol (explicit_step.c): the power of h in the error estimate, and its parts. */
#define LAG_PAIR_ORDER 7
#define LAG_PAIR_START rkn8_start
#define LAG_PAIR_TRIAL rkn8_trial
#define LAG_PAIR_ACCEPT rkn8_accept

static const real rkn8_c2 = (real)1 / 20, rkn8_c3 = (real)1 / 10, rkn8_c4 = (real)3 / 10,
                  rkn8_c5 = (real)1 / 2, rkn8_c6 = (real)7 / 10, rkn8_c7 = (real)9 / 10;
static const real rkn8_a2_1 = (real)1 / 800;
static const real rkn8_a3_1 = (real)1 / 600, rkn8_a3_2 = (real)1 / 300;
static const real rkn8_a4_1 = (real)9 / 200, rkn8_a4_2 = -(real)9 / 100, rkn8_a4_3 = (real)9 / 100;
static const real rkn8_a5_1 = -(real)66701 / 197352, rkn8_a5_2 = (real)28325 / 32892,
                  rkn8_a5_3 = -(real)2665 / 5482, rkn8_a5_4 = (real)2170 / 24669;
static const real rkn8_a6_1 = (real)227015747 / 304251000, rkn8_a6_2 = -(real)54897451 / 30425100,
                  rkn8_a6_3 = (real)12942349 / 10141700, rkn8_a6_4 = -(real)9499 / 304251,
                  rkn8_a6_5 = (real)539 / 9250;
static const real rkn8_a7_1 = -(real)1131891597 / 901789000, rkn8_a7_2 = (real)41964921 / 12882700,
                  rkn8_a7_3 = -(real)6663147 / 3220675, rkn8_a7_4 = (real)270954 / 644135,
                  rkn8_a7_5 = -(real)108 / 5875, rkn8_a7_6 = (real)114 / 1645;
static const real rkn8_a8_1 = (real)13836959 / 3667458, rkn8_a8_2 = -(real)17731450 / 1833729,
                  rkn8_a8_3 = (real)1063919505 / 156478208, rkn8_a8_4 = -(real)33213845 / 39119552,
                  rkn8_a8_5 = (real)13335 / 28544, rkn8_a8_6 = -(real)705 / 14272,
                  rkn8_a8_7 = (real)1645 / 57088;
/* bbar (positions, h^2) and b (velocities, h); bbar_2 = bbar_8 = b_2 = 0 */
static const real rkn8_bbar1 = (real)223 / 7938, rkn8_bbar3 = (real)1175 / 8064,
                  rkn8_bbar4 = (real)925 / 6048, rkn8_bbar5 = (real)41 / 448,
                  rkn8_bbar6 = (real)925 / 14112, rkn8_bbar7 = (real)1175 / 72576;
static const real rkn8_b1 = (real)223 / 7938, rkn8_b3 = (real)5875 / 36288, rkn8_b4 = (real)4625 / 21168,
                  rkn8_b5 = (real)41 / 224, rkn8_b6 = (real)4625 / 21168, rkn8_b7 = (real)5875 / 36288,
                  rkn8_b8 = (real)223 / 7938;
/* e = bbar - bbar_hat and e' = b - b_hat of the embedded order-6 pair, each the difference of
 * the two published weights (rounded once in the working precision, then subtracted) */
static const real rkn8_e1 = (real)223 / 7938 - (real)7987313 / 109941300,
                  rkn8_e3 = (real)1175 / 8064 - (real)1610737 / 44674560,
                  rkn8_e4 = (real)925 / 6048 - (real)10023263 / 33505920,
                  rkn8_e5 = (real)41 / 448 + (real)497221 / 12409600,
                  rkn8_e6 = (real)925 / 14112 - (real)10023263 / 78180480,
                  rkn8_e7 = (real)1175 / 72576 - (real)1610737 / 402071040;
static const real rkn8_ev1 = (real)223 / 7938 - (real)7987313 / 109941300,
                  rkn8_ev3 = (real)5875 / 36288 - (real)1610737 / 40207104,
                  rkn8_ev4 = (real)4625 / 21168 - (real)10023263 / 23454144,
                  rkn8_ev5 = (real)41 / 224 + (real)497221 / 6204800,
                  rkn8_ev6 = (real)4625 / 21168 - (real)10023263 / 23454144,
                  rkn8_ev7 = (real)5875 / 36288 - (real)1610737 / 40207104,
                  rkn8_ev8 = (real)223 / 7938 + (real)4251941 / 54970650,
                  rkn8_ev9 = -(real)3 / 20;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    const lag_system *sys;
    lag_control control;
    real g[9][LAG_NQ];            /* g_1 .. g_9 of the current trial; g[0] = a(t, q) */
    real y_old[LAG_NY];           /* the state at t_old, */
    real g_old[LAG_NQ];           /* and a there: where the dense output's steps start */
    real stage[LAG_NY];           /* (Q_i, -): a reads the positions only */
    real y_new[LAG_NY];           /* the order-8 solution of the current trial */
    real error[LAG_NY];           /* its scaled error estimate, component by component */
} lag_stepper;

/* g = a(t, Q) at the positions in s->stage. */
static int rkn8_acceleration(lag_stepper *s, real t, real *g)
{
    ++s->stats.rhs_evals;
    return lag_accelerations(s->sys, t, s->stage, g);
}

/* Stages 2..8 of a step of size h from (t, q, v) with g[0] = a(t, q); the last stage is g[7]. */
static int rkn8_stages(lag_stepper *s, real t, const real *q, const real *v, real h)
{
    real (*g)[LAG_NQ] = s->g;
    int i, status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c2 * v[i] + h * (rkn8_a2_1 * g[0][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c2 * h, g[1])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c3 * v[i] + h * (rkn8_a3_1 * g[0][i] + rkn8_a3_2 * g[1][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c3 * h, g[2])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c4 * v[i] + h * (rkn8_a4_1 * g[0][i] + rkn8_a4_2 * g[1][i]
                                                        + rkn8_a4_3 * g[2][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c4 * h, g[3])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c5 * v[i] + h * (rkn8_a5_1 * g[0][i] + rkn8_a5_2 * g[1][i]
                                                        + rkn8_a5_3 * g[2][i] + rkn8_a5_4 * g[3][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c5 * h, g[4])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c6 * v[i] + h * (rkn8_a6_1 * g[0][i] + rkn8_a6_2 * g[1][i]
                                                        + rkn8_a6_3 * g[2][i] + rkn8_a6_4 * g[3][i]
                                                        + rkn8_a6_5 * g[4][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c6 * h, g[5])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (rkn8_c7 * v[i] + h * (rkn8_a7_1 * g[0][i] + rkn8_a7_2 * g[1][i]
                                                        + rkn8_a7_3 * g[2][i] + rkn8_a7_4 * g[3][i]
                                                        + rkn8_a7_5 * g[4][i] + rkn8_a7_6 * g[5][i]));
    if ((status = rkn8_acceleration(s, t + rkn8_c7 * h, g[6])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i)
        s->stage[i] = q[i] + h * (v[i] + h * (rkn8_a8_1 * g[0][i] + rkn8_a8_2 * g[1][i] + rkn8_a8_3 * g[2][i]
                                              + rkn8_a8_4 * g[3][i] + rkn8_a8_5 * g[4][i]
                                              + rkn8_a8_6 * g[5][i] + rkn8_a8_7 * g[6][i]));
    return rkn8_acceleration(s, t + h, g[7]);
}

/* The order-8 solution of a step of size h from (q, v) into out = (q_new, v_new). */
static void rkn8_solution(const lag_stepper *s, const real *q, const real *v, real h, real *out)
{
    const real (*g)[LAG_NQ] = (const real (*)[LAG_NQ])s->g;
    int i;
    for (i = 0; i < LAG_NQ; ++i) {
        out[i] = q[i] + h * (v[i] + h * (rkn8_bbar1 * g[0][i] + rkn8_bbar3 * g[2][i] + rkn8_bbar4 * g[3][i]
                                         + rkn8_bbar5 * g[4][i] + rkn8_bbar6 * g[5][i]
                                         + rkn8_bbar7 * g[6][i]));
        out[LAG_NQ + i] = v[i] + h * (rkn8_b1 * g[0][i] + rkn8_b3 * g[2][i] + rkn8_b4 * g[3][i]
                                      + rkn8_b5 * g[4][i] + rkn8_b6 * g[5][i] + rkn8_b7 * g[6][i]
                                      + rkn8_b8 * g[7][i]);
    }
}

/* A trial of size h from (t, y) to t_new: y_new, g_9 = a(t_new, q_new), and the scaled error. */
static int rkn8_trial(lag_stepper *s, real h, real t_new, real *err)
{
    const real (*g)[LAG_NQ] = (const real (*)[LAG_NQ])s->g;
    const real *q = s->y, *v = s->y + LAG_NQ;
    int i, status;
    if ((status = rkn8_stages(s, s->t, q, v, h)) != LAG_OK)
        return status;
    rkn8_solution(s, q, v, h, s->y_new);
    memcpy(s->stage, s->y_new, sizeof(real) * LAG_NQ);
    if ((status = rkn8_acceleration(s, t_new, s->g[8])) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NQ; ++i) {
        real error_q = h * h * (rkn8_e1 * g[0][i] + rkn8_e3 * g[2][i] + rkn8_e4 * g[3][i] + rkn8_e5 * g[4][i]
                                + rkn8_e6 * g[5][i] + rkn8_e7 * g[6][i]);
        real error_v = h * (rkn8_ev1 * g[0][i] + rkn8_ev3 * g[2][i] + rkn8_ev4 * g[3][i] + rkn8_ev5 * g[4][i]
                            + rkn8_ev6 * g[5][i] + rkn8_ev7 * g[6][i] + rkn8_ev8 * g[7][i]
                            + rkn8_ev9 * g[8][i]);
        s->error[i] = error_q / lag_control_scale(&s->control, i, q[i], s->y_new[i]);
        s->error[LAG_NQ + i] = error_v / lag_control_scale(&s->control, LAG_NQ + i, v[i], s->y_new[LAG_NQ + i]);
    }
    *err = r_sqrt(lag_sum_of_squares(LAG_NY, s->error) / LAG_NY);
    return LAG_OK;
}

/* The start at (t0, y0 = s->y) with f = (v, a(t0, q)). */
static void rkn8_start(lag_stepper *s, const real *f)
{
    memcpy(s->y_old, s->y, sizeof s->y_old);
    memset(s->stage, 0, sizeof s->stage);
    memcpy(s->g[0], f + LAG_NQ, sizeof s->g[0]);
    memcpy(s->g_old, s->g[0], sizeof s->g_old);
}

/* Accept the trial: keep the start of the step for the dense output; g_9 is the next g_1. */
static void rkn8_accept(lag_stepper *s, real h, real t_new)
{
    (void)h;
    (void)t_new;
    memcpy(s->y_old, s->y, sizeof s->y);
    memcpy(s->g_old, s->g[0], sizeof s->g_old);
    memcpy(s->g[0], s->g[8], sizeof s->g[0]);
}

/* y at t_old <= t <= t: the end of the step itself, or a step of size t - t_old from its start
 * (which overwrites g[1..7]: the next trial recomputes them). */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    const real *q = s->y_old, *v = s->y_old + LAG_NQ;
    real g1[LAG_NQ];
    int status;
    if (t == s->t || s->t == s->t_old) {
        memcpy(yout, t == s->t ? s->y : s->y_old, sizeof s->y);
        return LAG_OK;
    }
    memcpy(g1, s->g[0], sizeof g1);
    memcpy(s->g[0], s->g_old, sizeof g1);
    status = rkn8_stages(s, s->t_old, q, v, t - s->t_old);
    if (status == LAG_OK)
        rkn8_solution(s, q, v, t - s->t_old, yout);
    memcpy(s->g[0], g1, sizeof g1);
    return status;
}

/* The driver moved y: a at the new positions is the next step's g_1. */
static int lag_stepper_restart(lag_stepper *s)
{
    memcpy(s->stage, s->y, sizeof(real) * LAG_NQ);
    return rkn8_acceleration(s, s->t, s->g[0]);
}
