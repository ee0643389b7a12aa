/* The sweep in SIMD lanes for dop853: LAG_LANES members integrated side by side, so that the
 * stages of their trial steps (the stage arguments and the model's right-hand side, lag_lane_rhs)
 * run as loops over the lanes that the compiler vectorises, entry [i][l] of every array being
 * component i of lane l (structure of arrays).
 *
 * Each lane is one member with its own scalar lag_stepper, report and output rows: its own t,
 * step size, error norm, accept or reject and step limit. Only the stages 2..12 of a trial and
 * f at its new point are computed in lanes; everything else (the trial's size, the order-8
 * solution and its error, the step-size control, the stiffness test, the dense output and the
 * driver's rows and work forecast) is the scalar code of dop853.c, explicit_control.c,
 * dormand_prince.c and driver.c, applied lane by lane. The lanes compute what the scalar path
 * computes, operation for operation and in the same order (C99 does not contract a*b + c into
 * an fma, and nothing is reassociated), so a member's rows, counters and summary equal those of
 * its lag_run bit for bit. A lane whose member has finished or failed is refilled with the next
 * member not yet begun, so a slow member holds up no other.
 *
 * Pasted after library.c (it reads lag_buffer, lag_grid_row, lag_member_inputs, lag_begin and
 * lag_pack_summary), for a scene without constraints or stop condition whose model gives
 * lag_lane_rhs (lagdsl/codegen/c_lanes.py).
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

/* One lane: its member (-1: empty), the member's run as lag_integrate keeps it, and the trial in
 * progress. */
typedef struct lag_lane {
    long member;
    lag_system sys;
    lag_options limited;           /* the options with the step limit, which the stepper keeps */
    lag_report report;
    lag_buffer rows;
    double *summary;
    real t0, t1, dt;
    long k, last;                  /* the next row to deliver, the final one */
    real h, t_new, err;            /* the trial: its size, its end, its scaled error */
    int trying;                    /* it takes a trial this round */
    int evaluating;                /* it counts the evaluation of the stage in progress */
    int status;                    /* of the trial so far */
} lag_lane;

/* The lanes of one thread: each lane's run, and the stages of the current trials side by side. */
typedef struct lag_lanes {
    lag_lane lane[LAG_LANES];
    lag_stepper stepper[LAG_LANES];
    const lag_system *sys[LAG_LANES];
    real par[LAG_NP > 0 ? LAG_NP : 1][LAG_LANES];
    real t[LAG_LANES], h[LAG_LANES], t_stage[LAG_LANES], acc[LAG_LANES];
    real y[LAG_NY][LAG_LANES], y_stage[LAG_NY][LAG_LANES];
    real k[13][LAG_NY][LAG_LANES];          /* k[s - 1]: stage s */
    int rhs_status[LAG_LANES];
} lag_lanes;

/* What every lane of a thread shares: the batch's inputs and outputs, and the next member. */
typedef struct lag_lane_batch {
    long members;
    const double *parameters, *initial, *settings;
    double *values, *summaries;
    long capacity, stride;
    long *next;                    /* the next member not yet begun, shared by the threads */
} lag_lane_batch;

/* The lane's member is done (status, at the stepper's place): its summary, and the lane empties. */
static void lag_lane_end(lag_lanes *lanes, int l, int status)
{
    lag_lane *lane = &lanes->lane[l];
    lag_finish(&lane->sys, &lanes->stepper[l], status, &lane->report);
    lag_pack_summary(&lane->report, lane->summary);
    lane->member = -1;
    lane->trying = 0;
#ifdef _OPENMP
#pragma omp atomic
#endif
    lag_batch_done += 1;
}

/* After the lane's stepper moved to t (or began there): the work forecast and Ctrl-C after a
 * step, then the rows it has reached, as lag_advance and lag_integrate deliver them; the member
 * ends when the last row is out or the run fails. */
static void lag_lane_rows(lag_lanes *lanes, int l, int stepped)
{
    lag_lane *lane = &lanes->lane[l];
    lag_stepper *s = &lanes->stepper[l];
    int status = LAG_OK;
    if (stepped) {
        status = lag_forecast_step(&lane->report.forecast, s->t - s->t_old, s->t);
        if (status == LAG_OK && lag_interrupt)
            status = LAG_ERR_INTERRUPTED;
    }
    while (status == LAG_OK && lane->k <= lane->last) {
        real tk = lane->k == lane->last ? lane->t1 : lane->t0 + lane->k * lane->dt;
        if (s->t < tk)
            return;
        status = lag_deliver_at(&lane->sys, s, tk, lag_grid_row, &lane->rows, &lane->report);
        lane->k += 1;
    }
    lag_lane_end(lanes, l, status);
}

/* Begin member b in lane l (as lag_run_member and lag_integrate begin it). */
static void lag_lane_begin(lag_lanes *lanes, int l, const lag_lane_batch *batch, long b)
{
    lag_lane *lane = &lanes->lane[l];
    const double *settings = batch->settings;
    lag_options options;
    real y0[LAG_NY], e_old = 0;
    int i, status;
    lane->member = b;
    lane->summary = batch->summaries + b * batch->stride;
    lane->rows.rows = batch->values + b * batch->capacity * LAG_NOUT;
    lane->rows.capacity = batch->capacity;
    lane->rows.used = 0;
    lane->t0 = settings[LAG_SET_T_START];
    lane->t1 = settings[LAG_SET_T_STOP];
    lane->dt = settings[LAG_SET_T_INTERVAL];
    lane->k = 1;
    lag_member_inputs(batch->parameters + b * LAG_NP, batch->initial + b * LAG_NY, settings, &lane->sys, &options, y0);
    memset(&lane->report, 0, sizeof lane->report);
    lag_system_prepare(&lane->sys);
    status = lag_begin(&lane->sys, &lanes->stepper[l], y0, lane->t0, lane->t1, lane->dt, &options, &lane->limited,
                       lag_grid_row, &lane->rows, &lane->report, &e_old, &lane->last);
    for (i = 0; i < LAG_NP; ++i)
        lanes->par[i][l] = lane->sys.par[i];
    if (status != LAG_OK)
        lag_lane_end(lanes, l, status);
    else
        lag_lane_rows(lanes, l, 0);
}

/* The next member not yet begun (members when none is left), taken by one thread only. */
static long lag_lanes_take(const lag_lane_batch *batch)
{
    long b;
#ifdef _OPENMP
#pragma omp atomic capture
#endif
    b = (*batch->next)++;
    return b < batch->members ? b : batch->members;
}

/* A member not begun because of Ctrl-C (lag_run_members marks it so). */
static void lag_lanes_skip(const lag_lane_batch *batch, long b)
{
    lag_summary_interrupted(batch->settings, batch->summaries + b * batch->stride);
#ifdef _OPENMP
#pragma omp atomic
#endif
    lag_batch_done += 1;
}

/* Fill the empty lanes with the next members; after Ctrl-C, members not begun are marked so. */
static void lag_lanes_fill(lag_lanes *lanes, const lag_lane_batch *batch)
{
    int l;
    for (l = 0; l < LAG_LANES; ++l) {
        while (lanes->lane[l].member < 0) {
            long b = lag_lanes_take(batch);
            if (b == batch->members)
                return;
            if (lag_interrupt)
                lag_lanes_skip(batch, b);
            else
                lag_lane_begin(lanes, l, batch, b);
        }
    }
}

/* Members one at a time (lag_run_member), for a thread whose lanes could not be allocated. */
static void lag_lanes_one_by_one(const lag_lane_batch *batch)
{
    long b;
    while ((b = lag_lanes_take(batch)) < batch->members) {
        lag_buffer rows;
        rows.rows = batch->values + b * batch->capacity * LAG_NOUT;
        rows.capacity = batch->capacity;
        rows.used = 0;
        if (lag_interrupt) {
            lag_lanes_skip(batch, b);
            continue;
        }
        lag_run_member(batch->parameters + b * LAG_NP, batch->initial + b * LAG_NY, batch->settings, lag_grid_row,
                       &rows, batch->summaries + b * batch->stride);
#ifdef _OPENMP
#pragma omp atomic
#endif
        lag_batch_done += 1;
    }
}

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

/* Whether a lane still holds a member. */
static int lag_lanes_busy(const lag_lanes *lanes)
{
    int l, busy = 0;
    for (l = 0; l < LAG_LANES; ++l)
        busy |= lanes->lane[l].member >= 0;
    return busy;
}

/* One thread's share of the batch: rounds of one trial in every lane, refilling the lanes as
 * their members end, until no member is left. */
static void lag_lanes_run(lag_lanes *lanes, const lag_lane_batch *batch)
{
    int l;
    memset(lanes, 0, sizeof *lanes);     /* an empty lane computes on zeros, and nothing reads it */
    for (l = 0; l < LAG_LANES; ++l) {
        lanes->lane[l].member = -1;
        lanes->sys[l] = &lanes->lane[l].sys;
    }
    for (;;) {
        lag_lanes_fill(lanes, batch);
        if (!lag_lanes_busy(lanes))
            return;
        if (lag_lanes_plan(lanes) > 0) {
            lag_lanes_stages(lanes);
            lag_lanes_finish(lanes, lag_lanes_solutions(lanes));
        }
    }
}

/* lag_run_batch in lanes: each thread runs LAG_LANES members at a time and takes the next member
 * not yet begun as one ends (one at a time, as lag_run_members, if its lanes cannot be allocated). */
static void lag_run_lanes(long members, const double *parameters, const double *initial, const double *settings,
                          double *values, long capacity, double *summaries, long stride, int threads)
{
    long next = 0;
    lag_lane_batch batch;
    batch.members = members;
    batch.parameters = parameters;
    batch.initial = initial;
    batch.settings = settings;
    batch.values = values;
    batch.summaries = summaries;
    batch.capacity = capacity;
    batch.stride = stride;
    batch.next = &next;
    lag_batch_done = 0;
#ifdef _OPENMP
#pragma omp parallel num_threads(threads > 0 ? threads : 1)
#else
    (void)threads;
#endif
    {
        lag_lanes *lanes = malloc(sizeof *lanes);
        if (lanes != NULL)
            lag_lanes_run(lanes, &batch);
        else
            lag_lanes_one_by_one(&batch);
        free(lanes);
    }
}
