/* The sweep in SIMD lanes, what every method's lanes share: LAG_LANES members integrated side by
 * side by one thread, so that the method's arithmetic runs as loops over the lanes that the
 * compiler vectorises, entry [i][l] of every array being component i of lane l (structure of
 * arrays).
 *
 * Each lane is one member with its own scalar lag_stepper, report and output rows: its own t,
 * step size, error norm, accept or reject and step limit. The method's file (dop853_lanes.c,
 * taylor_lanes.c; codegen/c.py puts it where LAG_LANES_METHOD stands below) defines struct
 * lag_lanes (the fields below and its own arrays) and lag_lanes_round, one step or trial
 * of every busy lane; the delivery of rows, the work forecast and the summaries are the scalar
 * code of driver.c and library.c, applied lane by lane, so that a member's rows, counters and
 * summary equal those of its lag_run bit for bit where the method's lanes compute what its
 * scalar path computes. A lane whose member has finished or failed is refilled with the next
 * member not yet begun, so a slow member holds up no other.
 *
 * Pasted after library.c (it reads lag_buffer, lag_grid_row, lag_member_inputs, lag_begin and
 * lag_pack_summary), for a scene without constraints or stop condition.
 */

/* One lane: its member (-1: empty), the member's run as lag_integrate keeps it, and the trial in
 * progress (the fields a method's round uses). */
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

/* What every lane of a thread shares: the batch's inputs and outputs, and the next member. */
typedef struct lag_lane_batch {
    long members;
    const double *parameters, *initial, *settings;
    double *values, *summaries;
    long capacity, stride;
    long *next;                    /* the next member not yet begun, shared by the threads */
} lag_lane_batch;

/* The lanes of one thread: the method's file defines it, with the fields
 *     lag_lane lane[LAG_LANES]; lag_stepper stepper[LAG_LANES];
 *     const lag_system *sys[LAG_LANES]; real par[LAG_NP > 0 ? LAG_NP : 1][LAG_LANES];
 * (each lane's run, its stepper, its system, its parameters side by side), in any order; it begins
 * at a LAG_LANES_ALIGN-byte boundary, so arrays over the lanes put first are aligned vectors. */
typedef struct lag_lanes lag_lanes;
#define LAG_LANES_ALIGN 64         /* a cache line, the widest vector: where a lag_lanes begins */
static real lag_lane_row_time(const lag_lane *lane);
static void lag_lane_end(lag_lanes *lanes, int l, int status);
static void lag_lane_rows(lag_lanes *lanes, int l, int stepped);
static void lag_lanes_round(lag_lanes *lanes);

/* LAG_LANES_METHOD */

/* The time of the lane's next row (lag_grid_row's grid, ending at t1). */
static real lag_lane_row_time(const lag_lane *lane)
{
    return lane->k == lane->last ? lane->t1 : lane->t0 + lane->k * lane->dt;
}

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
        real tk = lag_lane_row_time(lane);
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

/* Whether a lane still holds a member. */
static int lag_lanes_busy(const lag_lanes *lanes)
{
    int l, busy = 0;
    for (l = 0; l < LAG_LANES; ++l)
        busy |= lanes->lane[l].member >= 0;
    return busy;
}

/* One thread's share of the batch: rounds of one step or trial in every lane, refilling the lanes as
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
        lag_lanes_round(lanes);
    }
}

/* The lanes in an allocation of sizeof(lag_lanes) + LAG_LANES_ALIGN bytes, at its first
 * LAG_LANES_ALIGN-byte boundary (C99 has no aligned allocation; malloc promises 16 bytes). */
static lag_lanes *lag_lanes_aligned(char *block)
{
    return (lag_lanes *)(block + (LAG_LANES_ALIGN - (size_t)block % LAG_LANES_ALIGN));
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
        char *block = malloc(sizeof(lag_lanes) + LAG_LANES_ALIGN);
        if (block != NULL)
            lag_lanes_run(lag_lanes_aligned(block), &batch);
        else
            lag_lanes_one_by_one(&batch);
        free(block);
    }
}
