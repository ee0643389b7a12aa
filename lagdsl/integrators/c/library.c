/* The entry points of the shared library, for the Python side (ctypes: lagdsl/run/runner.py and
 * lagdsl/run/sweep.py): doubles in, doubles out.
 *
 * Pasted after driver.c and the generated lag_pack_summary. A run takes the settings vector
 * (its entries LAG_SET_T_START ... LAG_SET_MAX_STEPS, lagdsl.abi.SETTINGS; max_steps 0 for the
 * default limit; then the atol of each of the LAG_NY components of y), already checked as `lagc run` checks them, and writes its summary as
 * lagdsl.abi.SummaryLayout lays it out (LAG_SUMMARY_SIZE doubles). The caller resets
 * lag_interrupt before a call, and may put it between lag_guard_enter and lag_guard_exit, or call
 * lag_run_guarded, which does both.
 */

int lag_run(const double *parameters, const double *initial, const double *settings,
            double *rows, long capacity, double *summary);
void lag_run_batch(long members, const double *parameters, const double *initial, const double *settings,
                   double *values, long capacity, double *summaries, long stride, int threads);

typedef struct lag_buffer { double *rows; long capacity, used; } lag_buffer;

static int lag_buffer_row(void *context, real t, const real *out)
{
    lag_buffer *buffer = context;
    int i;
    if (buffer->used >= buffer->capacity)
        return 1;
    buffer->rows[buffer->used * (LAG_NOUT + 1)] = (double)t;
    for (i = 0; i < LAG_NOUT; ++i)
        buffer->rows[buffer->used * (LAG_NOUT + 1) + 1 + i] = (double)out[i];
    buffer->used += 1;
    return 0;
}

/* The inputs of one run: `parameters` (LAG_NP) into sys (zeroed here), `initial` (LAG_NY) into y0
 * and the options of `settings`. */
static void lag_member_inputs(const double *parameters, const double *initial, const double *settings,
                              lag_system *sys, lag_options *options, real *y0)
{
    int i;
    memset(sys, 0, sizeof *sys);    /* a model without parameters still has the placeholder par[0] */
    for (i = 0; i < LAG_NP; ++i)
        sys->par[i] = parameters[i];
    for (i = 0; i < LAG_NY; ++i)
        y0[i] = initial[i];
    options->rtol = settings[LAG_SET_RTOL];
    options->atol = settings[LAG_SET_ATOL];
    options->step = settings[LAG_SET_STEP];
    options->max_step = settings[LAG_SET_MAX_STEP];
    options->stages = (int)settings[LAG_SET_STAGES];
    options->norm = (int)settings[LAG_SET_NORM];
    options->max_steps = (long)settings[LAG_SET_MAX_STEPS];
    options->atol_each = settings + LAG_SETTINGS;
}

/* One run of the model with `parameters` (LAG_NP) from `initial` (LAG_NY) on `settings`; its
 * rows go to `sink`, its summary to `summary`. */
static int lag_run_member(const double *parameters, const double *initial, const double *settings,
                          lag_sink sink, void *context, double *summary)
{
    lag_system sys;
    lag_options options;
    lag_report report;
    real y0[LAG_NY];
    lag_member_inputs(parameters, initial, settings, &sys, &options, y0);
    lag_integrate(&sys, y0, settings[LAG_SET_T_START], settings[LAG_SET_T_STOP], settings[LAG_SET_T_INTERVAL],
                  &options, sink, context, &report);
    lag_pack_summary(&report, summary);
    return report.status;
}

/* One run: the rows (t and the columns) go to `rows`, at most `capacity` of them. */
int lag_run(const double *parameters, const double *initial, const double *settings,
            double *rows, long capacity, double *summary)
{
    lag_buffer buffer;
    buffer.rows = rows;
    buffer.capacity = capacity;
    buffer.used = 0;
    return lag_run_member(parameters, initial, settings, lag_buffer_row, &buffer, summary);
}

/* Members finished so far, for the progress bar of a sweep (read through ctypes). */
volatile long lag_batch_done = 0;

/* A member's output grid: the columns of each row, without t (every member shares the grid). */
static int lag_grid_row(void *context, real t, const real *out)
{
    lag_buffer *grid = context;
    int i;
    (void)t;
    if (grid->used >= grid->capacity)
        return 1;
    for (i = 0; i < LAG_NOUT; ++i)
        grid->rows[grid->used * LAG_NOUT + i] = (double)out[i];
    grid->used += 1;
    return 0;
}

/* The summary of a member not begun because lag_interrupt was set: interrupted at t0, no rows. */
static void lag_summary_interrupted(const double *settings, double *summary)
{
    memset(summary, 0, sizeof(double) * LAG_SUMMARY_SIZE);
    summary[LAG_SUMMARY_STATUS] = LAG_ERR_INTERRUPTED;
    summary[LAG_SUMMARY_T_FAIL] = settings[LAG_SET_T_START];
}

/* The loop of lag_run_batch, for any sink of the layout of lag_buffer: member b's rows, `width`
 * doubles each, go to values[b * capacity * width ...]. A member not begun when lag_interrupt is
 * set has the status LAG_ERR_INTERRUPTED at t0 and no rows. */
static void lag_run_members(long members, const double *parameters, const double *initial, const double *settings,
                            lag_sink sink, long width, double *values, long capacity, double *summaries, long stride,
                            int threads)
{
    long b;
    lag_batch_done = 0;
#ifdef _OPENMP
#pragma omp parallel for schedule(dynamic) num_threads(threads > 0 ? threads : 1)
#else
    (void)threads;
#endif
    for (b = 0; b < members; ++b) {
        double *summary = summaries + b * stride;
        lag_buffer buffer;
        buffer.rows = values + b * capacity * width;
        buffer.capacity = capacity;
        buffer.used = 0;
        if (lag_interrupt) {
            lag_summary_interrupted(settings, summary);
        } else {
            lag_run_member(parameters + b * LAG_NP, initial + b * LAG_NY, settings, sink, &buffer, summary);
        }
#ifdef _OPENMP
#pragma omp atomic
#endif
        lag_batch_done += 1;
    }
}

/* Integrate `members` runs that share the settings (as lag_run) but each have their own
 * parameters (members x LAG_NP) and initial state (members x LAG_NY). Member b writes its rows
 * (the columns, without t) to values[b * capacity * LAG_NOUT ...] and its summary to
 * summaries[b * stride ...]; a failure ends only that member. The members are independent, so
 * they run in parallel on `threads` OpenMP threads when the library is built with OpenMP, and
 * one after another otherwise, with the same results bit for bit. After lag_interrupt is set,
 * members not yet begun are not begun (status LAG_ERR_INTERRUPTED, no rows). */
#if LAG_HAS_LANES
static void lag_run_lanes(long members, const double *parameters, const double *initial, const double *settings,
                          double *values, long capacity, double *summaries, long stride, int threads);
#endif

void lag_run_batch(long members, const double *parameters, const double *initial, const double *settings,
                   double *values, long capacity, double *summaries, long stride, int threads)
{
#if LAG_HAS_LANES      /* lanes.c, pasted after this file: the same results bit for bit */
    lag_run_lanes(members, parameters, initial, settings, values, capacity, summaries, stride, threads);
#else
    lag_run_members(members, parameters, initial, settings, lag_grid_row, LAG_NOUT, values, capacity, summaries,
                    stride, threads);
#endif
}

#ifdef SA_RESTART       /* POSIX sigaction (model.c.j2 asks for it on Unix); elsewhere Python watches Ctrl-C itself */
/* Ctrl-C during a call made in Python's main thread (lagdsl/run/interrupt.py): while the call
 * runs, the main thread executes no Python, so Python's own handler could only note the press
 * for later. Between lag_guard_enter and lag_guard_exit, SIGINT (and SIGTERM if `terminate`)
 * instead set lag_interrupt, which the driver reads after each step, and are noted for
 * lag_guard_exit, which puts the handlers found on entry back whole (sigaction: their flags too;
 * signal() would add SA_RESTART to Python's, whose blocking calls rely on EINTR). Two system
 * calls a guarded call, four with SIGTERM. */
static volatile sig_atomic_t lag_noted_interrupt = 0, lag_noted_terminate = 0;
static struct sigaction lag_saved_interrupt, lag_saved_terminate;
static int lag_guarded = 0;     /* which of the two lag_guard_exit puts back: 1 SIGINT, 2 both */

static void lag_on_guarded_signal(int signal_number)
{
    lag_interrupt = 1;
    if (signal_number == SIGTERM)
        lag_noted_terminate = 1;
    else
        lag_noted_interrupt = 1;
}

void lag_guard_enter(int terminate);
int lag_guard_exit(void);

void lag_guard_enter(int terminate)
{
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_handler = lag_on_guarded_signal;
    sigemptyset(&action.sa_mask);
    sigaddset(&action.sa_mask, SIGINT);
    sigaddset(&action.sa_mask, SIGTERM);
    action.sa_flags = SA_RESTART;       /* another thread's blocking call is not cut short */
    lag_noted_interrupt = lag_noted_terminate = 0;
    if (sigaction(SIGINT, &action, &lag_saved_interrupt) != 0)
        return;
    lag_guarded = 1;
    if (terminate && sigaction(SIGTERM, &action, &lag_saved_terminate) == 0)
        lag_guarded = 2;
}

/* Put back the handlers lag_guard_enter found (nothing if it installed none); returns the signal
 * noted since (SIGTERM if both were), or 0. */
int lag_guard_exit(void)
{
    if (lag_guarded == 2)
        sigaction(SIGTERM, &lag_saved_terminate, NULL);
    if (lag_guarded >= 1)
        sigaction(SIGINT, &lag_saved_interrupt, NULL);
    lag_guarded = 0;
    return lag_noted_terminate ? SIGTERM : lag_noted_interrupt ? SIGINT : 0;
}

/* lag_run within the guard, lag_interrupt reset first: a repeated call from Python's main thread
 * makes one foreign call instead of three (each several microseconds after a long run, which has
 * emptied the caches). The signal lag_guard_exit noted goes to `noted`. */
int lag_run_guarded(int terminate, int *noted, const double *parameters, const double *initial,
                    const double *settings, double *rows, long capacity, double *summary);

int lag_run_guarded(int terminate, int *noted, const double *parameters, const double *initial,
                    const double *settings, double *rows, long capacity, double *summary)
{
    int status;
    lag_interrupt = 0;
    lag_guard_enter(terminate);
    status = lag_run(parameters, initial, settings, rows, capacity, summary);
    *noted = lag_guard_exit();
    return status;
}
#endif
