/* DOPRI5: the explicit Runge-Kutta pair of Dormand and Prince, order 5 with an embedded order-4
 * error estimate, 7 stages of which the last is f at the new point (FSAL: "first same as last"),
 * so an accepted step costs 6 right-hand side evaluations.
 *
 * Coefficients: Hairer-Norsett-Wanner I (HNW I), Section II.5, Table 5.2 (all rational).
 * Dense output: the continuous extension of order 4 of HNW I, II.6 (Shampine's, built from the
 * same 7 stages at no extra evaluation), a quartic in theta = (t - t_old)/h written in the nested
 * form y_old + theta (r2 + (1-theta) (r3 + theta (r4 + (1-theta) r5))) which matches y and f at
 * both ends of the step.  r3..r5 are formed only for a step that the dense output is asked about
 * (a step that contains an output time), from the stages the step keeps until the next starts.
 * Step-size control (exponent 1/5, safety 0.9, factor within [0.2, 10]), error norm, starting
 * step and the stiffness test (stability boundary 3.25): explicit_control.c, which must be
 * pasted before this file; the start, the accepted step and the restart: dormand_prince.c and
 * explicit_step.c, pasted after it.
 */

#define LAG_INTEGRATOR_NAME "dopri5"
/* For the step protocol (dormand_prince.c, explicit_step.c): the power of h in the error
 * estimate, the trial, the stage that is f(t_new, y_new), the stiffness test's stability boundary. */
#define LAG_PAIR_ORDER 5
#define LAG_PAIR_TRIAL dopri5_trial
#define LAG_PAIR_LAST_STAGE k7
#define LAG_PAIR_STIFFNESS_BOUNDARY LAG_DOPRI5_STABILITY_BOUNDARY

static const real dp5_c2 = (real)1 / 5, dp5_c3 = (real)3 / 10, dp5_c4 = (real)4 / 5, dp5_c5 = (real)8 / 9;

static const real dp5_a21 = (real)1 / 5;
static const real dp5_a31 = (real)3 / 40, dp5_a32 = (real)9 / 40;
static const real dp5_a41 = (real)44 / 45, dp5_a42 = -(real)56 / 15, dp5_a43 = (real)32 / 9;
static const real dp5_a51 = (real)19372 / 6561, dp5_a52 = -(real)25360 / 2187,
                  dp5_a53 = (real)64448 / 6561, dp5_a54 = -(real)212 / 729;
static const real dp5_a61 = (real)9017 / 3168, dp5_a62 = -(real)355 / 33, dp5_a63 = (real)46732 / 5247,
                  dp5_a64 = (real)49 / 176, dp5_a65 = -(real)5103 / 18656;
/* The weights b_i of the order-5 solution, which is also stage 7 (b_2 = b_7 = 0). */
static const real dp5_b1 = (real)35 / 384, dp5_b3 = (real)500 / 1113, dp5_b4 = (real)125 / 192,
                  dp5_b5 = -(real)2187 / 6784, dp5_b6 = (real)11 / 84;
/* e_i = b_i - bhat_i: the difference of the order-5 and order-4 solutions (e_2 = 0). */
static const real dp5_e1 = (real)71 / 57600, dp5_e3 = -(real)71 / 16695, dp5_e4 = (real)71 / 1920,
                  dp5_e5 = -(real)17253 / 339200, dp5_e6 = (real)22 / 525, dp5_e7 = -(real)1 / 40;
/* The dense output's quartic term (d_2 = 0). */
static const real dp5_d1 = -(real)12715105075 / 11282082432, dp5_d3 = (real)87487479700 / 32700410799,
                  dp5_d4 = -(real)10690763975 / 1880347072, dp5_d5 = (real)701980252875 / 199316789632,
                  dp5_d6 = -(real)1453857185 / 822651844, dp5_d7 = (real)69997945 / 29380423;

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    LAG_DORMAND_PRINCE_STATE(5)  /* sys, control, stiffness, h_done, k1, k1_done, dense, dense_built */
    real k2[LAG_NY], k3[LAG_NY], k4[LAG_NY], k5[LAG_NY], k6[LAG_NY], k7[LAG_NY];
    real y_stage[LAG_NY];         /* argument of the stage being evaluated */
    real y_new[LAG_NY];           /* the order-5 solution of the current trial */
    real error[LAG_NY];           /* its scaled local error estimate, component by component */
} lag_stepper;

/* k = f(t, y_stage). */
static int dopri5_stage(lag_stepper *s, real t, real *k)
{
    return lag_control_rhs(s->sys, &s->stats, t, s->y_stage, k);
}

/* Stages 2..7 of a trial of size h from (t, y) to t_new, and the scaled error estimate. */
static int dopri5_trial(lag_stepper *s, real h, real t_new, real *err)
{
    int i, status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp5_a21 * s->k1[i]);
    if ((status = dopri5_stage(s, s->t + dp5_c2 * h, s->k2)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp5_a31 * s->k1[i] + dp5_a32 * s->k2[i]);
    if ((status = dopri5_stage(s, s->t + dp5_c3 * h, s->k3)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp5_a41 * s->k1[i] + dp5_a42 * s->k2[i] + dp5_a43 * s->k3[i]);
    if ((status = dopri5_stage(s, s->t + dp5_c4 * h, s->k4)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp5_a51 * s->k1[i] + dp5_a52 * s->k2[i] + dp5_a53 * s->k3[i]
                                       + dp5_a54 * s->k4[i]);
    if ((status = dopri5_stage(s, s->t + dp5_c5 * h, s->k5)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp5_a61 * s->k1[i] + dp5_a62 * s->k2[i] + dp5_a63 * s->k3[i]
                                       + dp5_a64 * s->k4[i] + dp5_a65 * s->k5[i]);
    if ((status = dopri5_stage(s, t_new, s->k6)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_new[i] = s->y[i] + h * (dp5_b1 * s->k1[i] + dp5_b3 * s->k3[i] + dp5_b4 * s->k4[i]
                                     + dp5_b5 * s->k5[i] + dp5_b6 * s->k6[i]);
    if ((status = lag_control_rhs(s->sys, &s->stats, t_new, s->y_new, s->k7)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->error[i] = h * (dp5_e1 * s->k1[i] + dp5_e3 * s->k3[i] + dp5_e4 * s->k4[i] + dp5_e5 * s->k5[i]
                           + dp5_e6 * s->k6[i] + dp5_e7 * s->k7[i])
                      / lag_control_scale(&s->control, s->y[i], s->y_new[i]);
    *err = r_sqrt(lag_sum_of_squares(LAG_NY, s->error) / LAG_NY);
    if (*err <= 1)      /* a step that passes: stages 6 and 7 (FSAL) both evaluate f at t_new */
        lag_stiffness_measure(&s->stiffness, h, s->y_new, s->y_stage, s->k7, s->k6);
    return LAG_OK;
}

/* r3..r5 of the continuous extension of the last accepted step (r1 = y_old and r2 = y_new - y_old
 * are set when it is accepted, r2 again when the driver moves y). */
static void dopri5_build_dense(lag_stepper *s)
{
    const real h = s->h_done, *k1 = s->k1_done;
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        real dy = s->y_new[i] - s->dense[0][i], slope0 = h * k1[i] - dy;
        s->dense[2][i] = slope0;
        s->dense[3][i] = dy - h * s->k7[i] - slope0;
        s->dense[4][i] = h * (dp5_d1 * k1[i] + dp5_d3 * s->k3[i] + dp5_d4 * s->k4[i]
                              + dp5_d5 * s->k5[i] + dp5_d6 * s->k6[i] + dp5_d7 * s->k7[i]);
    }
    s->dense_built = 1;
}

/* Valid on [t_old, t] once a step has been taken; needs no right-hand side (always LAG_OK). */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real theta = (t - s->t_old) / s->h_done, theta1 = 1 - theta;
    int i;
    if (!s->dense_built)
        dopri5_build_dense(s);
    for (i = 0; i < LAG_NY; ++i)
        yout[i] = s->dense[0][i] + theta * (s->dense[1][i] + theta1 * (s->dense[2][i]
                  + theta * (s->dense[3][i] + theta1 * s->dense[4][i])));
    return LAG_OK;
}
