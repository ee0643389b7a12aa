/* DOP853: the explicit Runge-Kutta method of order 8 of Dormand and Prince, 12 stages plus f at
 * the new point (FSAL), with error estimates of orders 5 and 3 combined as in Hairer's DOP853:
 *     err = err5^2 / sqrt(err5^2 + 0.01 err3^2),
 * each estimate measured in the norm of HNW I, II.4, (4.11).  As h -> 0 (err5 = O(h^6),
 * err3 = O(h^4)) the combination is O(h^8), hence the exponent 1/8 of the step-size controller;
 * at large h it tends to err5.  An accepted step costs 12 right-hand side evaluations, a rejected
 * one 11.
 *
 * Method: Hairer-Norsett-Wanner I (HNW I), Section II.10 (the code DOP853).  Most coefficients
 * are irrational; they are the 30-digit decimals published with DOP853, which LAG_LIT rounds to
 * the working precision (exact enough for long double, not quite for __float128).
 * Dense output: the continuous extension of order 7 (HNW I, II.6 and II.10), which needs 3 further
 * stages.  They are computed only for a step that the dense output is asked about (a step that
 * contains an output time), on the first such request: outputs every 0.5 s with steps of 0.02 s
 * need them on one step in 25, and the steps themselves cost 12 evaluations, not 15.  The
 * stages of the last accepted step are kept until the next step starts.  The polynomial of
 * degree 7 in theta = (t - t_old)/h is kept in the nested form
 *     r1 + theta (r2 + theta1 (r3 + theta (r4 + theta1 (r5 + theta (r6 + theta1 (r7 + theta r8)))))),
 * theta1 = 1 - theta, which matches y and f at both ends of the step.
 * Step-size control (exponent 1/8, safety 0.9, factor within [0.2, 10]), the starting step and
 * the stiffness test (stability boundary 6.1): explicit_control.c, which must be pasted before
 * this file; the start, the accepted step and the restart: dormand_prince.c and explicit_step.c,
 * pasted after it.
 */

#define LAG_INTEGRATOR_NAME "dop853"
/* For the step protocol (dormand_prince.c, explicit_step.c): the power of h in the error
 * estimate, the trial, the stage that is f(t_new, y_new), the stiffness test's stability boundary. */
#define LAG_PAIR_ORDER 8
#define LAG_PAIR_TRIAL dop853_trial
#define LAG_PAIR_LAST_STAGE k13
#define LAG_PAIR_STIFFNESS_BOUNDARY LAG_DOP853_STABILITY_BOUNDARY

static const real dp8_c2 = LAG_LIT(0.526001519587677318785587544488e-01),
                  dp8_c3 = LAG_LIT(0.789002279381515978178381316732e-01),
                  dp8_c4 = LAG_LIT(0.118350341907227396726757197510e+00),
                  dp8_c5 = LAG_LIT(0.281649658092772603273242802490e+00),
                  dp8_c6 = LAG_LIT(0.333333333333333333333333333333e+00), dp8_c7 = LAG_LIT(0.25e+00),
                  dp8_c8 = LAG_LIT(0.307692307692307692307692307692e+00),
                  dp8_c9 = LAG_LIT(0.651282051282051282051282051282e+00), dp8_c10 = LAG_LIT(0.6e+00),
                  dp8_c11 = LAG_LIT(0.857142857142857142857142857142e+00);
static const real dp8_a2_1 = LAG_LIT(5.26001519587677318785587544488e-2);
static const real dp8_a3_1 = LAG_LIT(1.97250569845378994544595329183e-2),
                  dp8_a3_2 = LAG_LIT(5.91751709536136983633785987549e-2);
static const real dp8_a4_1 = LAG_LIT(2.95875854768068491816892993775e-2),
                  dp8_a4_3 = LAG_LIT(8.87627564304205475450678981324e-2);
static const real dp8_a5_1 = LAG_LIT(2.41365134159266685502369798665e-1),
                  dp8_a5_3 = -LAG_LIT(8.84549479328286085344864962717e-1),
                  dp8_a5_4 = LAG_LIT(9.24834003261792003115737966543e-1);
static const real dp8_a6_1 = LAG_LIT(3.7037037037037037037037037037e-2),
                  dp8_a6_4 = LAG_LIT(1.70828608729473871279604482173e-1),
                  dp8_a6_5 = LAG_LIT(1.25467687566822425016691814123e-1);
static const real dp8_a7_1 = LAG_LIT(3.7109375e-2),
                  dp8_a7_4 = LAG_LIT(1.70252211019544039314978060272e-1),
                  dp8_a7_5 = LAG_LIT(6.02165389804559606850219397283e-2),
                  dp8_a7_6 = -LAG_LIT(1.7578125e-2);
static const real dp8_a8_1 = LAG_LIT(3.70920001185047927108779319836e-2),
                  dp8_a8_4 = LAG_LIT(1.70383925712239993810214054705e-1),
                  dp8_a8_5 = LAG_LIT(1.07262030446373284651809199168e-1),
                  dp8_a8_6 = -LAG_LIT(1.53194377486244017527936158236e-2),
                  dp8_a8_7 = LAG_LIT(8.27378916381402288758473766002e-3);
static const real dp8_a9_1 = LAG_LIT(6.24110958716075717114429577812e-1),
                  dp8_a9_4 = -LAG_LIT(3.36089262944694129406857109825e0),
                  dp8_a9_5 = -LAG_LIT(8.68219346841726006818189891453e-1),
                  dp8_a9_6 = LAG_LIT(2.75920996994467083049415600797e1),
                  dp8_a9_7 = LAG_LIT(2.01540675504778934086186788979e1),
                  dp8_a9_8 = -LAG_LIT(4.34898841810699588477366255144e1);
static const real dp8_a10_1 = LAG_LIT(4.77662536438264365890433908527e-1),
                  dp8_a10_4 = -LAG_LIT(2.48811461997166764192642586468e0),
                  dp8_a10_5 = -LAG_LIT(5.90290826836842996371446475743e-1),
                  dp8_a10_6 = LAG_LIT(2.12300514481811942347288949897e1),
                  dp8_a10_7 = LAG_LIT(1.52792336328824235832596922938e1),
                  dp8_a10_8 = -LAG_LIT(3.32882109689848629194453265587e1),
                  dp8_a10_9 = -LAG_LIT(2.03312017085086261358222928593e-2);
static const real dp8_a11_1 = -LAG_LIT(9.3714243008598732571704021658e-1),
                  dp8_a11_4 = LAG_LIT(5.18637242884406370830023853209e0),
                  dp8_a11_5 = LAG_LIT(1.09143734899672957818500254654e0),
                  dp8_a11_6 = -LAG_LIT(8.14978701074692612513997267357e0),
                  dp8_a11_7 = -LAG_LIT(1.85200656599969598641566180701e1),
                  dp8_a11_8 = LAG_LIT(2.27394870993505042818970056734e1),
                  dp8_a11_9 = LAG_LIT(2.49360555267965238987089396762e0),
                  dp8_a11_10 = -LAG_LIT(3.0467644718982195003823669022e0);
static const real dp8_a12_1 = LAG_LIT(2.27331014751653820792359768449e0),
                  dp8_a12_4 = -LAG_LIT(1.05344954667372501984066689879e1),
                  dp8_a12_5 = -LAG_LIT(2.00087205822486249909675718444e0),
                  dp8_a12_6 = -LAG_LIT(1.79589318631187989172765950534e1),
                  dp8_a12_7 = LAG_LIT(2.79488845294199600508499808837e1),
                  dp8_a12_8 = -LAG_LIT(2.85899827713502369474065508674e0),
                  dp8_a12_9 = -LAG_LIT(8.87285693353062954433549289258e0),
                  dp8_a12_10 = LAG_LIT(1.23605671757943030647266201528e1),
                  dp8_a12_11 = LAG_LIT(6.43392746015763530355970484046e-1);
/* The weights of the order-8 solution (b_2 .. b_5 = 0). */
static const real dp8_b1 = LAG_LIT(5.42937341165687622380535766363e-2),
                  dp8_b6 = LAG_LIT(4.45031289275240888144113950566e0),
                  dp8_b7 = LAG_LIT(1.89151789931450038304281599044e0),
                  dp8_b8 = -LAG_LIT(5.8012039600105847814672114227e0),
                  dp8_b9 = LAG_LIT(3.1116436695781989440891606237e-1),
                  dp8_b10 = -LAG_LIT(1.52160949662516078556178806805e-1),
                  dp8_b11 = LAG_LIT(2.01365400804030348374776537501e-1),
                  dp8_b12 = LAG_LIT(4.47106157277725905176885569043e-2);
/* The weights of an order-3 solution, whose difference to y8 is the order-3 error estimate. */
static const real dp8_bhat1 = LAG_LIT(0.244094488188976377952755905512e+00),
                  dp8_bhat9 = LAG_LIT(0.733846688281611857341361741547e+00),
                  dp8_bhat12 = LAG_LIT(0.220588235294117647058823529412e-01);
/* The weights of the order-5 error estimate y8 - y5 (HNW I, II.10). */
static const real dp8_e1 = LAG_LIT(0.1312004499419488073250102996e-01),
                  dp8_e6 = -LAG_LIT(0.1225156446376204440720569753e+01),
                  dp8_e7 = -LAG_LIT(0.4957589496572501915214079952e+00),
                  dp8_e8 = LAG_LIT(0.1664377182454986536961530415e+01),
                  dp8_e9 = -LAG_LIT(0.3503288487499736816886487290e+00),
                  dp8_e10 = LAG_LIT(0.3341791187130174790297318841e+00),
                  dp8_e11 = LAG_LIT(0.8192320648511571246570742613e-01),
                  dp8_e12 = -LAG_LIT(0.2235530786388629525884427845e-01);
/* The three extra stages of the dense output. */
static const real dp8_c14 = LAG_LIT(0.1e+00), dp8_c15 = LAG_LIT(0.2e+00),
                  dp8_c16 = LAG_LIT(0.777777777777777777777777777778e+00);
static const real dp8_a14_1 = LAG_LIT(5.61675022830479523392909219681e-2),
                  dp8_a14_7 = LAG_LIT(2.53500210216624811088794765333e-1),
                  dp8_a14_8 = -LAG_LIT(2.46239037470802489917441475441e-1),
                  dp8_a14_9 = -LAG_LIT(1.24191423263816360469010140626e-1),
                  dp8_a14_10 = LAG_LIT(1.5329179827876569731206322685e-1),
                  dp8_a14_11 = LAG_LIT(8.20105229563468988491666602057e-3),
                  dp8_a14_12 = LAG_LIT(7.56789766054569976138603589584e-3),
                  dp8_a14_13 = -LAG_LIT(8.298e-3);
static const real dp8_a15_1 = LAG_LIT(3.18346481635021405060768473261e-2),
                  dp8_a15_6 = LAG_LIT(2.83009096723667755288322961402e-2),
                  dp8_a15_7 = LAG_LIT(5.35419883074385676223797384372e-2),
                  dp8_a15_8 = -LAG_LIT(5.49237485713909884646569340306e-2),
                  dp8_a15_11 = -LAG_LIT(1.08347328697249322858509316994e-4),
                  dp8_a15_12 = LAG_LIT(3.82571090835658412954920192323e-4),
                  dp8_a15_13 = -LAG_LIT(3.40465008687404560802977114492e-4),
                  dp8_a15_14 = LAG_LIT(1.41312443674632500278074618366e-1);
static const real dp8_a16_1 = -LAG_LIT(4.28896301583791923408573538692e-1),
                  dp8_a16_6 = -LAG_LIT(4.69762141536116384314449447206e0),
                  dp8_a16_7 = LAG_LIT(7.68342119606259904184240953878e0),
                  dp8_a16_8 = LAG_LIT(4.06898981839711007970213554331e0),
                  dp8_a16_9 = LAG_LIT(3.56727187455281109270669543021e-1),
                  dp8_a16_13 = -LAG_LIT(1.39902416515901462129418009734e-3),
                  dp8_a16_14 = LAG_LIT(2.9475147891527723389556272149e0),
                  dp8_a16_15 = -LAG_LIT(9.15095847217987001081870187138e0);
/* The dense output's coefficients of the terms r5..r8 (rows 4..7 of the publication). */
static const real dp8_d4_1 = -LAG_LIT(0.84289382761090128651353491142e+01),
                  dp8_d4_6 = LAG_LIT(0.56671495351937776962531783590e+00),
                  dp8_d4_7 = -LAG_LIT(0.30689499459498916912797304727e+01),
                  dp8_d4_8 = LAG_LIT(0.23846676565120698287728149680e+01),
                  dp8_d4_9 = LAG_LIT(0.21170345824450282767155149946e+01),
                  dp8_d4_10 = -LAG_LIT(0.87139158377797299206789907490e+00),
                  dp8_d4_11 = LAG_LIT(0.22404374302607882758541771650e+01),
                  dp8_d4_12 = LAG_LIT(0.63157877876946881815570249290e+00),
                  dp8_d4_13 = -LAG_LIT(0.88990336451333310820698117400e-01),
                  dp8_d4_14 = LAG_LIT(0.18148505520854727256656404962e+02),
                  dp8_d4_15 = -LAG_LIT(0.91946323924783554000451984436e+01),
                  dp8_d4_16 = -LAG_LIT(0.44360363875948939664310572000e+01);
static const real dp8_d5_1 = LAG_LIT(0.10427508642579134603413151009e+02),
                  dp8_d5_6 = LAG_LIT(0.24228349177525818288430175319e+03),
                  dp8_d5_7 = LAG_LIT(0.16520045171727028198505394887e+03),
                  dp8_d5_8 = -LAG_LIT(0.37454675472269020279518312152e+03),
                  dp8_d5_9 = -LAG_LIT(0.22113666853125306036270938578e+02),
                  dp8_d5_10 = LAG_LIT(0.77334326684722638389603898808e+01),
                  dp8_d5_11 = -LAG_LIT(0.30674084731089398182061213626e+02),
                  dp8_d5_12 = -LAG_LIT(0.93321305264302278729567221706e+01),
                  dp8_d5_13 = LAG_LIT(0.15697238121770843886131091075e+02),
                  dp8_d5_14 = -LAG_LIT(0.31139403219565177677282850411e+02),
                  dp8_d5_15 = -LAG_LIT(0.93529243588444783865713862664e+01),
                  dp8_d5_16 = LAG_LIT(0.35816841486394083752465898540e+02);
static const real dp8_d6_1 = LAG_LIT(0.19985053242002433820987653617e+02),
                  dp8_d6_6 = -LAG_LIT(0.38703730874935176555105901742e+03),
                  dp8_d6_7 = -LAG_LIT(0.18917813819516756882830838328e+03),
                  dp8_d6_8 = LAG_LIT(0.52780815920542364900561016686e+03),
                  dp8_d6_9 = -LAG_LIT(0.11573902539959630126141871134e+02),
                  dp8_d6_10 = LAG_LIT(0.68812326946963000169666922661e+01),
                  dp8_d6_11 = -LAG_LIT(0.10006050966910838403183860980e+01),
                  dp8_d6_12 = LAG_LIT(0.77771377980534432092869265740e+00),
                  dp8_d6_13 = -LAG_LIT(0.27782057523535084065932004339e+01),
                  dp8_d6_14 = -LAG_LIT(0.60196695231264120758267380846e+02),
                  dp8_d6_15 = LAG_LIT(0.84320405506677161018159903784e+02),
                  dp8_d6_16 = LAG_LIT(0.11992291136182789328035130030e+02);
static const real dp8_d7_1 = -LAG_LIT(0.25693933462703749003312586129e+02),
                  dp8_d7_6 = -LAG_LIT(0.15418974869023643374053993627e+03),
                  dp8_d7_7 = -LAG_LIT(0.23152937917604549567536039109e+03),
                  dp8_d7_8 = LAG_LIT(0.35763911791061412378285349910e+03),
                  dp8_d7_9 = LAG_LIT(0.93405324183624310003907691704e+02),
                  dp8_d7_10 = -LAG_LIT(0.37458323136451633156875139351e+02),
                  dp8_d7_11 = LAG_LIT(0.10409964950896230045147246184e+03),
                  dp8_d7_12 = LAG_LIT(0.29840293426660503123344363579e+02),
                  dp8_d7_13 = -LAG_LIT(0.43533456590011143754432175058e+02),
                  dp8_d7_14 = LAG_LIT(0.96324553959188282948394950600e+02),
                  dp8_d7_15 = -LAG_LIT(0.39177261675615439165231486172e+02),
                  dp8_d7_16 = -LAG_LIT(0.14972683625798562581422125276e+03);

typedef struct lag_stepper {
    LAG_STEPPER_PUBLIC(lag_stats)  /* t, t_old, y, h and stats, which the driver reads (runtime.h) */
    LAG_DORMAND_PRINCE_STATE(8)  /* sys, control, stiffness, h_done, k1, k1_done, dense, dense_built */
    real k2[LAG_NY], k3[LAG_NY], k4[LAG_NY], k5[LAG_NY], k6[LAG_NY], k7[LAG_NY], k8[LAG_NY];
    real k9[LAG_NY], k10[LAG_NY], k11[LAG_NY], k12[LAG_NY], k13[LAG_NY];
    real k14[LAG_NY], k15[LAG_NY], k16[LAG_NY];  /* the dense output's stages */
    real y_stage[LAG_NY];         /* argument of the stage being evaluated */
    real y_new[LAG_NY];           /* the order-8 solution of the current trial */
    real error5[LAG_NY], error3[LAG_NY];   /* its scaled error estimates, component by component */
} lag_stepper;

/* k = f(t, y_stage). */
static int dop853_stage(lag_stepper *s, real t, real *k)
{
    return lag_control_rhs(s->sys, &s->stats, t, s->y_stage, k);
}

/* Stages 2..12 of a trial of size h from (t, y) to t_new. */
static int dop853_stages(lag_stepper *s, real h, real t_new)
{
    const real t = s->t;
    int i, status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a2_1 * s->k1[i]);
    if ((status = dop853_stage(s, t + dp8_c2 * h, s->k2)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a3_1 * s->k1[i] + dp8_a3_2 * s->k2[i]);
    if ((status = dop853_stage(s, t + dp8_c3 * h, s->k3)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a4_1 * s->k1[i] + dp8_a4_3 * s->k3[i]);
    if ((status = dop853_stage(s, t + dp8_c4 * h, s->k4)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a5_1 * s->k1[i] + dp8_a5_3 * s->k3[i] + dp8_a5_4 * s->k4[i]);
    if ((status = dop853_stage(s, t + dp8_c5 * h, s->k5)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a6_1 * s->k1[i] + dp8_a6_4 * s->k4[i] + dp8_a6_5 * s->k5[i]);
    if ((status = dop853_stage(s, t + dp8_c6 * h, s->k6)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a7_1 * s->k1[i] + dp8_a7_4 * s->k4[i] + dp8_a7_5 * s->k5[i]
                                       + dp8_a7_6 * s->k6[i]);
    if ((status = dop853_stage(s, t + dp8_c7 * h, s->k7)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a8_1 * s->k1[i] + dp8_a8_4 * s->k4[i] + dp8_a8_5 * s->k5[i]
                                       + dp8_a8_6 * s->k6[i] + dp8_a8_7 * s->k7[i]);
    if ((status = dop853_stage(s, t + dp8_c8 * h, s->k8)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a9_1 * s->k1[i] + dp8_a9_4 * s->k4[i] + dp8_a9_5 * s->k5[i]
                                       + dp8_a9_6 * s->k6[i] + dp8_a9_7 * s->k7[i] + dp8_a9_8 * s->k8[i]);
    if ((status = dop853_stage(s, t + dp8_c9 * h, s->k9)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a10_1 * s->k1[i] + dp8_a10_4 * s->k4[i] + dp8_a10_5 * s->k5[i]
                                       + dp8_a10_6 * s->k6[i] + dp8_a10_7 * s->k7[i] + dp8_a10_8 * s->k8[i]
                                       + dp8_a10_9 * s->k9[i]);
    if ((status = dop853_stage(s, t + dp8_c10 * h, s->k10)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a11_1 * s->k1[i] + dp8_a11_4 * s->k4[i] + dp8_a11_5 * s->k5[i]
                                       + dp8_a11_6 * s->k6[i] + dp8_a11_7 * s->k7[i] + dp8_a11_8 * s->k8[i]
                                       + dp8_a11_9 * s->k9[i] + dp8_a11_10 * s->k10[i]);
    if ((status = dop853_stage(s, t + dp8_c11 * h, s->k11)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = s->y[i] + h * (dp8_a12_1 * s->k1[i] + dp8_a12_4 * s->k4[i] + dp8_a12_5 * s->k5[i]
                                       + dp8_a12_6 * s->k6[i] + dp8_a12_7 * s->k7[i] + dp8_a12_8 * s->k8[i]
                                       + dp8_a12_9 * s->k9[i] + dp8_a12_10 * s->k10[i]
                                       + dp8_a12_11 * s->k11[i]);
    return dop853_stage(s, t_new, s->k12);
}

/* The order-8 solution y_new of the trial and its combined scaled error estimate. */
static real dop853_solution(lag_stepper *s, real h)
{
    real sum5, sum3, increment, w, denominator;
    int i;
    for (i = 0; i < LAG_NY; ++i) {
        increment = dp8_b1 * s->k1[i] + dp8_b6 * s->k6[i] + dp8_b7 * s->k7[i] + dp8_b8 * s->k8[i]
                    + dp8_b9 * s->k9[i] + dp8_b10 * s->k10[i] + dp8_b11 * s->k11[i] + dp8_b12 * s->k12[i];
        s->y_new[i] = s->y[i] + h * increment;
        w = lag_control_scale(&s->control, s->y[i], s->y_new[i]);
        s->error3[i] = (increment - dp8_bhat1 * s->k1[i] - dp8_bhat9 * s->k9[i] - dp8_bhat12 * s->k12[i]) / w;
        s->error5[i] = (dp8_e1 * s->k1[i] + dp8_e6 * s->k6[i] + dp8_e7 * s->k7[i] + dp8_e8 * s->k8[i]
                        + dp8_e9 * s->k9[i] + dp8_e10 * s->k10[i] + dp8_e11 * s->k11[i]
                        + dp8_e12 * s->k12[i]) / w;
    }
    sum3 = lag_sum_of_squares(LAG_NY, s->error3);
    sum5 = lag_sum_of_squares(LAG_NY, s->error5);
    /* h err5^2 / sqrt(err5^2 + 0.01 err3^2) with err_q^2 = sum_q / n; a NaN stays a NaN */
    denominator = sum5 + LAG_LIT(0.01) * sum3;
    return denominator == 0 ? 0 : h * sum5 / r_sqrt(LAG_NY * denominator);
}

/* For a trial that passed the error test: f at the new point (stage 13, the next step's first stage). */
static int dop853_finish(lag_stepper *s, real h, real t_new)
{
    int status;
    if ((status = lag_control_rhs(s->sys, &s->stats, t_new, s->y_new, s->k13)) != LAG_OK)
        return status;
    /* stage 12 (at y_stage, still in place) and stage 13 both evaluate f at t_new */
    lag_stiffness_measure(&s->stiffness, h, s->y_new, s->y_stage, s->k13, s->k12);
    return LAG_OK;
}

/* The three extra stages of the dense output on the last accepted step, from t_old with the
 * state dense[0] and the stages k1_done, k6 .. k13 it kept. */
static int dop853_dense_stages(lag_stepper *s)
{
    const real t = s->t_old, h = s->h_done;
    const real *y = s->dense[0], *k1 = s->k1_done;
    int i, status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = y[i] + h * (dp8_a14_1 * k1[i] + dp8_a14_7 * s->k7[i] + dp8_a14_8 * s->k8[i]
                                    + dp8_a14_9 * s->k9[i] + dp8_a14_10 * s->k10[i]
                                    + dp8_a14_11 * s->k11[i] + dp8_a14_12 * s->k12[i]
                                    + dp8_a14_13 * s->k13[i]);
    if ((status = dop853_stage(s, t + dp8_c14 * h, s->k14)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = y[i] + h * (dp8_a15_1 * k1[i] + dp8_a15_6 * s->k6[i] + dp8_a15_7 * s->k7[i]
                                    + dp8_a15_8 * s->k8[i] + dp8_a15_11 * s->k11[i]
                                    + dp8_a15_12 * s->k12[i] + dp8_a15_13 * s->k13[i]
                                    + dp8_a15_14 * s->k14[i]);
    if ((status = dop853_stage(s, t + dp8_c15 * h, s->k15)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        s->y_stage[i] = y[i] + h * (dp8_a16_1 * k1[i] + dp8_a16_6 * s->k6[i] + dp8_a16_7 * s->k7[i]
                                    + dp8_a16_8 * s->k8[i] + dp8_a16_9 * s->k9[i]
                                    + dp8_a16_13 * s->k13[i] + dp8_a16_14 * s->k14[i]
                                    + dp8_a16_15 * s->k15[i]);
    return dop853_stage(s, t + dp8_c16 * h, s->k16);
}

/* A trial of size h from (t, y) to t_new: the stages, y_new and its scaled error; f at the new
 * point is spent only on a trial that passes the error test. */
static int dop853_trial(lag_stepper *s, real h, real t_new, real *err)
{
    int status = dop853_stages(s, h, t_new);
    if (status != LAG_OK)
        return status;
    *err = dop853_solution(s, h);
    return *err <= 1 ? dop853_finish(s, h, t_new) : LAG_OK;
}

/* r3..r8 of the continuous extension of the last accepted step (r1 = y_old and r2 = y_new - y_old
 * are set when it is accepted, r2 again when the driver moves y). */
static int dop853_build_dense(lag_stepper *s)
{
    const real h = s->h_done, *k1 = s->k1_done;
    int i, status;
    if ((status = dop853_dense_stages(s)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i) {
        real dy = s->y_new[i] - s->dense[0][i], slope0 = h * k1[i] - dy;
        s->dense[2][i] = slope0;
        s->dense[3][i] = dy - h * s->k13[i] - slope0;
        s->dense[4][i] = h * (dp8_d4_1 * k1[i] + dp8_d4_6 * s->k6[i] + dp8_d4_7 * s->k7[i]
                              + dp8_d4_8 * s->k8[i] + dp8_d4_9 * s->k9[i] + dp8_d4_10 * s->k10[i]
                              + dp8_d4_11 * s->k11[i] + dp8_d4_12 * s->k12[i] + dp8_d4_13 * s->k13[i]
                              + dp8_d4_14 * s->k14[i] + dp8_d4_15 * s->k15[i] + dp8_d4_16 * s->k16[i]);
        s->dense[5][i] = h * (dp8_d5_1 * k1[i] + dp8_d5_6 * s->k6[i] + dp8_d5_7 * s->k7[i]
                              + dp8_d5_8 * s->k8[i] + dp8_d5_9 * s->k9[i] + dp8_d5_10 * s->k10[i]
                              + dp8_d5_11 * s->k11[i] + dp8_d5_12 * s->k12[i] + dp8_d5_13 * s->k13[i]
                              + dp8_d5_14 * s->k14[i] + dp8_d5_15 * s->k15[i] + dp8_d5_16 * s->k16[i]);
        s->dense[6][i] = h * (dp8_d6_1 * k1[i] + dp8_d6_6 * s->k6[i] + dp8_d6_7 * s->k7[i]
                              + dp8_d6_8 * s->k8[i] + dp8_d6_9 * s->k9[i] + dp8_d6_10 * s->k10[i]
                              + dp8_d6_11 * s->k11[i] + dp8_d6_12 * s->k12[i] + dp8_d6_13 * s->k13[i]
                              + dp8_d6_14 * s->k14[i] + dp8_d6_15 * s->k15[i] + dp8_d6_16 * s->k16[i]);
        s->dense[7][i] = h * (dp8_d7_1 * k1[i] + dp8_d7_6 * s->k6[i] + dp8_d7_7 * s->k7[i]
                              + dp8_d7_8 * s->k8[i] + dp8_d7_9 * s->k9[i] + dp8_d7_10 * s->k10[i]
                              + dp8_d7_11 * s->k11[i] + dp8_d7_12 * s->k12[i] + dp8_d7_13 * s->k13[i]
                              + dp8_d7_14 * s->k14[i] + dp8_d7_15 * s->k15[i] + dp8_d7_16 * s->k16[i]);
    }
    s->dense_built = 1;
    return LAG_OK;
}

/* Valid on [t_old, t] once a step has been taken; the first call on a step evaluates the three
 * extra stages (and returns the status of a right-hand side that fails there). */
static int lag_stepper_dense(lag_stepper *s, real t, real *yout)
{
    real theta = (t - s->t_old) / s->h_done, theta1 = 1 - theta;
    int i, status;
    if (!s->dense_built && (status = dop853_build_dense(s)) != LAG_OK)
        return status;
    for (i = 0; i < LAG_NY; ++i)
        yout[i] = s->dense[0][i] + theta * (s->dense[1][i] + theta1 * (s->dense[2][i]
                  + theta * (s->dense[3][i] + theta1 * (s->dense[4][i] + theta * (s->dense[5][i]
                  + theta1 * (s->dense[6][i] + theta * s->dense[7][i]))))));
    return LAG_OK;
}
