/* dop853 in SIMD lanes (lanes.c): only the stages 2..12 of a trial and f at its new point are
 * computed in lanes (the stage arguments and the model's right-hand side, lag_lane_rhs,
 * codegen/c_lanes.py); everything else (the trial's size, the order-8 solution and its error, the
 * step-size control, the stiffness test, the dense output) is the scalar code of dop853.c,
 * explicit_control.c and dormand_prince.c, applied lane by lane. The lanes compute what the
 * scalar path computes, operation for operation and in the same order (C99 does not contract
 * a*b + c into an fma, and nothing is reassociated), so a member's results equal its lag_run's
 * bit for bit.
 */

/* The stages 2..12 of a trial: each one's node c (NULL for stage 12, which is at t_new) and its
 * coefficients a_sj, nonzero for the stages `from` (HNW I, II.10; the constants of dop853.c). */
typedef struct dp8_lane_stage {
    const real *c;
    int count;
    int from[10];
    const real *a[10];
} dp8_lane_stage;

static const dp8_lane_stage dp8_lane_stages[11] = {
    { &dp8_c2, 1, { 1 }, { &dp8_a2_1 } },
    { &dp8_c3, 2, { 1, 2 }, { &dp8_a3_1, &dp8_a3_2 } },
    { &dp8_c4, 2, { 1, 3 }, { &dp8_a4_1, &dp8_a4_3 } },
    { &dp8_c5, 3, { 1, 3, 4 }, { &dp8_a5_1, &dp8_a5_3, &dp8_a5_4 } },
    { &dp8_c6, 3, { 1, 4, 5 }, { &dp8_a6_1, &dp8_a6_4, &dp8_a6_5 } },
    { &dp8_c7, 4, { 1, 4, 5, 6 }, { &dp8_a7_1, &dp8_a7_4, &dp8_a7_5, &dp8_a7_6 } },
    { &dp8_c8, 5, { 1, 4, 5, 6, 7 }, { &dp8_a8_1, &dp8_a8_4, &dp8_a8_5, &dp8_a8_6, &dp8_a8_7 } },
    { &dp8_c9, 6, { 1, 4, 5, 6, 7, 8 }, { &dp8_a9_1, &dp8_a9_4, &dp8_a9_5, &dp8_a9_6, &dp8_a9_7, &dp8_a9_8 } },
    { &dp8_c10, 7, { 1, 4, 5, 6, 7, 8, 9 },
      { &dp8_a10_1, &dp8_a10_4, &dp8_a10_5, &dp8_a10_6, &dp8_a10_7, &dp8_a10_8, &dp8_a10_9 } },
    { &dp8_c11, 8, { 1, 4, 5, 6, 7, 8, 9, 10 },
      { &dp8_a11_1, &dp8_a11_4, &dp8_a11_5, &dp8_a11_6, &dp8_a11_7, &dp8_a11_8, &dp8_a11_9, &dp8_a11_10 } },
    { NULL, 9, { 1, 4, 5, 6, 7, 8, 9, 10, 11 },
      { &dp8_a12_1, &dp8_a12_4, &dp8_a12_5, &dp8_a12_6, &dp8_a12_7, &dp8_a12_8, &dp8_a12_9, &dp8_a12_10,
        &dp8_a12_11 } }
};

/* The lanes of one thread: each lane's run, and the stages of the current trials side by side. */
struct lag_lanes {
    lag_lane lane[LAG_LANES];
    lag_stepper stepper[LAG_LANES];
    const lag_system *sys[LAG_LANES];
    real par[LAG_NP > 0 ? LAG_NP : 1][LAG_LANES];
    real t[LAG_LANES], h[LAG_LANES], t_stage[LAG_LANES], acc[LAG_LANES];
    real y[LAG_NY][LAG_LANES], y_stage[LAG_NY][LAG_LANES];
    real k[13][LAG_NY][LAG_LANES];          /* k[s - 1]: stage s */
    int rhs_status[LAG_LANES];
};

/* The size and end of each lane's next trial (lag_control_trial), and its state and first stage
 * side by side; a lane whose trial cannot be taken (step limit, collapse) ends. Returns the
 * number of lanes that take a trial. */
static int lag_lanes_plan(lag_lanes *lanes)
{
    int i, l, trying = 0;
    for (l = 0; l < LAG_LANES; ++l) {
        lag_lane *lane = &lanes->lane[l];
        lag_stepper *s = &lanes->stepper[l];
        lane->trying = lane->evaluating = 0;
        if (lane->member < 0)
            continue;
        lane->status = lag_control_trial(&s->control, &s->stats, s->t, s->h, &lane->h, &lane->t_new);
        if (lane->status != LAG_OK) {
            lag_lane_end(lanes, l, lane->status);
            continue;
        }
        lane->trying = lane->evaluating = 1;
        lanes->t[l] = s->t;
        lanes->h[l] = lane->h;
        for (i = 0; i < LAG_NY; ++i) {
            lanes->y[i][l] = s->y[i];
            lanes->k[0][i][l] = s->k1[i];
        }
        ++trying;
    }
    return trying;
}

/* f(t_stage, y_stage) of every lane into k; an evaluating lane counts the evaluation and takes
 * its status, unless an earlier stage of its trial failed (then, as dop853_stages returns early,
 * neither). */
static void lag_lanes_rhs(lag_lanes *lanes, real (*k)[LAG_LANES])
{
    int l;
    lag_lane_rhs(lanes->sys, (const real (*)[LAG_LANES])lanes->par, lanes->t_stage,
                 (const real (*)[LAG_LANES])lanes->y_stage, k, lanes->rhs_status);
    for (l = 0; l < LAG_LANES; ++l) {
        lag_lane *lane = &lanes->lane[l];
        if (lane->evaluating && lane->status == LAG_OK) {
            ++lanes->stepper[l].stats.rhs_evals;
            lane->status = lanes->rhs_status[l];
        }
    }
}

/* Stages 2..12 of every lane's trial (dop853_stages), side by side: y_stage = y + h sum_j a_sj k_j,
 * summed in the order of dop853.c. */
static void lag_lanes_stages(lag_lanes *lanes)
{
    int s, i, j, l;
    for (s = 0; s < 11; ++s) {
        const dp8_lane_stage *stage = &dp8_lane_stages[s];
        for (i = 0; i < LAG_NY; ++i) {
            const real a0 = *stage->a[0];
            LAG_SIMD
            for (l = 0; l < LAG_LANES; ++l)
                lanes->acc[l] = a0 * lanes->k[stage->from[0] - 1][i][l];
            for (j = 1; j < stage->count; ++j) {
                const real a = *stage->a[j];
                const real *kj = lanes->k[stage->from[j] - 1][i];
                LAG_SIMD
                for (l = 0; l < LAG_LANES; ++l)
                    lanes->acc[l] += a * kj[l];
            }
            LAG_SIMD
            for (l = 0; l < LAG_LANES; ++l)
                lanes->y_stage[i][l] = lanes->y[i][l] + lanes->h[l] * lanes->acc[l];
        }
        LAG_SIMD
        for (l = 0; l < LAG_LANES; ++l)
            lanes->t_stage[l] = stage->c != NULL ? lanes->t[l] + *stage->c * lanes->h[l] : lanes->lane[l].t_new;
        lag_lanes_rhs(lanes, lanes->k[s + 1]);
    }
}

/* Each trying lane's stages into its stepper, its order-8 solution and scaled error
 * (dop853_solution); a lane that passes the error test evaluates f at its new point next (its
 * new state in y_stage). Returns the number of lanes that passed. */
static int lag_lanes_solutions(lag_lanes *lanes)
{
    int i, l, s, passed = 0;
    for (l = 0; l < LAG_LANES; ++l) {
        lag_lane *lane = &lanes->lane[l];
        lag_stepper *st = &lanes->stepper[l];
        real *stages[7] = { st->k6, st->k7, st->k8, st->k9, st->k10, st->k11, st->k12 };
        lane->evaluating = 0;
        if (!lane->trying || lane->status != LAG_OK)
            continue;
        for (i = 0; i < LAG_NY; ++i) {
            for (s = 0; s < 7; ++s)
                stages[s][i] = lanes->k[5 + s][i][l];
            st->y_stage[i] = lanes->y_stage[i][l];
        }
        lane->err = dop853_solution(st, lane->h);
        if (lane->err <= 1) {
            for (i = 0; i < LAG_NY; ++i)
                lanes->y_stage[i][l] = st->y_new[i];
            lanes->t_stage[l] = lane->t_new;
            lane->evaluating = 1;
            ++passed;
        }
    }
    return passed;
}

/* f at the new point of the lanes that passed (dop853_finish), and every trying lane's verdict
 * (lag_control_update): an accepted step moves the lane's stepper and delivers its rows. */
static void lag_lanes_finish(lag_lanes *lanes, int passed)
{
    int i, l;
    if (passed > 0)
        lag_lanes_rhs(lanes, lanes->k[12]);
    for (l = 0; l < LAG_LANES; ++l) {
        lag_lane *lane = &lanes->lane[l];
        lag_stepper *s = &lanes->stepper[l];
        if (!lane->trying)
            continue;
        if (lane->evaluating && lane->status == LAG_OK) {
            for (i = 0; i < LAG_NY; ++i)
                s->k13[i] = lanes->k[12][i][l];
            lag_stiffness_measure(&s->stiffness, lane->h, s->y_new, s->y_stage, s->k13, s->k12);
        }
        if (lag_control_update(&s->control, &s->stats, lane->status, lane->h, lane->err, &s->h)) {
            dormand_prince_accept(s, lane->h, lane->t_new);
            memcpy(s->y, s->y_new, sizeof s->y);
            s->t_old = s->t;
            s->t = lane->t_new;
            lag_lane_rows(lanes, l, 1);
        }
    }
}

/* One trial in every busy lane. */
static void lag_lanes_round(lag_lanes *lanes)
{
    if (lag_lanes_plan(lanes) > 0) {
        lag_lanes_stages(lanes);
        lag_lanes_finish(lanes, lag_lanes_solutions(lanes));
    }
}
