/* The standalone program's batch mode (--batch): the members read from standard input, run in
 * chunks over lag_run_members (library.c), their rows written in member order in one CSV. */

/* ---- batch mode: one member a line of standard input ---- */
#define LAG_BATCH_VALUES (1L << 22)      /* the doubles of output held at once: members run in chunks */

/* The members read so far: their parameters and initial states, as lag_run_batch takes them. */
typedef struct lag_members { long count, allocated; double *parameters, *initial; } lag_members;

static int lag_members_add(lag_members *members, const real *par, const real *y0)
{
    int i;
    if (members->count == members->allocated) {
        long allocated = members->allocated > 0 ? 2 * members->allocated : 64;
        double *parameters = realloc(members->parameters, (size_t)allocated * (LAG_NP + 1) * sizeof(double));
        double *initial = parameters == NULL ? NULL : realloc(members->initial, (size_t)allocated * LAG_NY * sizeof(double));
        if (parameters != NULL)
            members->parameters = parameters;
        if (initial == NULL)
            return 0;
        members->initial = initial;
        members->allocated = allocated;
    }
    for (i = 0; i < LAG_NP; ++i)
        members->parameters[members->count * LAG_NP + i] = (double)par[i];
    for (i = 0; i < LAG_NY; ++i)
        members->initial[members->count * LAG_NY + i] = (double)y0[i];
    members->count += 1;
    return 1;
}

/* One line of `stream` into `line`, without its newline: 1, or 0 at the end of the input, -1
 * when it is longer than LAG_LINE_MAX - 1 characters, -2 when it holds a NUL byte (which would
 * end it early for every string function: the rest of the line unseen). */
static int lag_read_line(FILE *stream, char *line)
{
    size_t length = 0;
    int c, nul = 0;
    while ((c = getc(stream)) != EOF && c != '\n') {
        nul = nul || c == '\0';
        if (length < LAG_LINE_MAX - 1)
            line[length] = (char)c;
        length += 1;
    }
    if (c == EOF && length == 0)
        return 0;
    line[length < LAG_LINE_MAX - 1 ? length : LAG_LINE_MAX - 1] = '\0';
    return length > LAG_LINE_MAX - 1 ? -1 : nul ? -2 : 1;
}

/* Read the members from standard input, one a line of NAME=VALUE settings (parameters,
 * q.start, q.velocity) on top of the command line's (`common`); blank lines and lines that
 * begin with '#' hold no member. Returns 0 after saying what is wrong, as "line N: ...". */
static int lag_read_members(const char *program, const lag_member *common, lag_members *members)
{
    char line[LAG_LINE_MAX], prefix[300];
    long number = 0;
    int read;
    while ((read = lag_read_line(stdin, line)) != 0) {
        lag_member member = *common;
        real y0[LAG_NY];
        char *word;
        snprintf(prefix, sizeof prefix, "%.256s: line %ld", program, ++number);
        if (read < 0) {
            if (read == -1)
                fprintf(stderr, "%s: longer than %d characters\n", prefix, LAG_LINE_MAX - 1);
            else
                fprintf(stderr, "%s: holds a NUL byte\n", prefix);
            return 0;
        }
        word = strtok(line, " \t\r\n");
        if (word == NULL || word[0] == '#')
            continue;
        for (; word != NULL; word = strtok(NULL, " \t\r\n")) {
            real value;
            const char *equals;
            int set = lag_member_setting(prefix, word, &member);
            if (set < 0)
                return 0;
            if (set > 0)
                continue;
            if ((equals = lag_split_setting(prefix, word, &value)) == NULL)
                return 0;
            fprintf(stderr, "%s: '%.*s' is not a parameter or a coordinate's start or velocity; only those "
                    "differ between members (give the others on the command line)\n", prefix,
                    (int)(equals - word), word);
            return 0;
        }
        if (!lag_member_state(prefix, &member, y0))
            return 0;
        if (!lag_members_add(members, member.par, y0)) {
            fprintf(stderr, "%s: out of memory\n", prefix);
            return 0;
        }
    }
    if (ferror(stdin)) {
        fprintf(stderr, "%s: cannot read standard input\n", program);
        return 0;
    }
    return 1;
}

/* Write member `number`'s rows (`width` doubles each) and add its counters to `totals`; say how
 * it failed (its step limit and stop time in `settings`). Returns its status. */
static int lag_write_member(long number, const double *summary, const double *rows, long width,
                            const double *settings, long *totals)
{
    int status = (int)summary[LAG_SUMMARY_STATUS], i;
    long r;
    for (r = 0; r < (long)summary[LAG_SUMMARY_ROWS]; ++r) {
        real out[LAG_NOUT];
        for (i = 0; i < LAG_NOUT; ++i)
            out[i] = (real)rows[r * width + 1 + i];
        fprintf(stdout, "%ld,", number);
        lag_print_row(NULL, (real)rows[r * width], out);
    }
    for (i = 0; i < LAG_NCOUNTERS; ++i)
        totals[i] += (long)summary[LAG_SUMMARY_COUNTERS + i];
    if (status != LAG_OK && status != LAG_ERR_INTERRUPTED) {
        fprintf(stderr, "member %ld: simulation failed at t = %.17g after %ld rows: ", number,
                summary[LAG_SUMMARY_T_FAIL], (long)summary[LAG_SUMMARY_ROWS]);
        lag_print_status(stderr, status, (long)settings[LAG_SET_MAX_STEPS], summary[LAG_SUMMARY_RCOND_FAIL],
                         summary[LAG_SUMMARY_FORECAST], settings[LAG_SET_T_STOP]);
        fputc('\n', stderr);
    }
    return status;
}

/* Run the members in chunks on the grid of `settings` (OpenMP threads when built with -fopenmp)
 * and write their rows in member order, each with its member's number first; a failure ends only
 * its member. Returns the exit status: 0, 1 when a member failed, 130 when interrupted. */
static int lag_run_standalone_batch(const lag_members *members, const double *settings, long capacity)
{
    long width = LAG_NOUT + 1, chunk = LAG_BATCH_VALUES / (capacity * width), first, b, failed = 0, unfinished = -1;
    long totals[LAG_NCOUNTERS] = {0};
    double *values, *summaries;
    int threads = 1;
    clock_t clock_start = clock();
#ifdef _OPENMP
    threads = omp_get_max_threads();    /* OMP_NUM_THREADS, else the processors */
#endif
    chunk = chunk < 1 ? 1 : chunk > members->count ? members->count : chunk;
    values = malloc((size_t)(chunk * capacity * width + 1) * sizeof(double));
    summaries = malloc((size_t)(chunk * LAG_SUMMARY_SIZE + 1) * sizeof(double));
    if (values == NULL || summaries == NULL) {
        free(values);
        free(summaries);
        fputs("batch: out of memory\n", stderr);
        return 1;
    }
    for (first = 0; first < members->count && !lag_interrupt; first += chunk) {
        long count = members->count - first < chunk ? members->count - first : chunk;
        lag_run_members(count, members->parameters + first * LAG_NP, members->initial + first * LAG_NY, settings,
                        lag_buffer_row, width, values, capacity, summaries, LAG_SUMMARY_SIZE, threads);
        for (b = 0; b < count; ++b) {
            int status = lag_write_member(first + b, summaries + b * LAG_SUMMARY_SIZE, values + b * capacity * width,
                                          width, settings, totals);
            if (status == LAG_ERR_INTERRUPTED && unfinished < 0)
                unfinished = first + b;
            failed += status != LAG_OK && status != LAG_ERR_INTERRUPTED;
        }
    }
    free(values);
    free(summaries);
    fprintf(stderr, "%ld members, %ld failed; integrator %s, in all: ", members->count, failed, LAG_INTEGRATOR_NAME);
    lag_print_counters(stderr, totals);
    fprintf(stderr, ", %.3g s CPU\n", (double)(clock() - clock_start) / CLOCKS_PER_SEC);
    if (lag_interrupt) {
        fprintf(stderr, "interrupted: member %ld is incomplete, and so may be those after it\n", unfinished);
        return 130;
    }
    return failed > 0;
}

/* `--batch`: the members from standard input on the command line's settings (`given`, t0, t1,
 * dt, options, all checked), one CSV. Returns the exit status (2 for bad input). */
static int lag_batch_main(const char *program, const lag_member *given, real t0, real t1, real dt,
                          const lag_options *options)
{
    lag_members members = { 0, 0, NULL, NULL };
    double settings[LAG_SETTINGS + LAG_NY];
    long last = lag_last_row(t0, t1, dt);
    int i, status = 2;
    settings[LAG_SET_T_START] = (double)t0;
    settings[LAG_SET_T_STOP] = (double)t1;
    settings[LAG_SET_T_INTERVAL] = (double)dt;
    settings[LAG_SET_RTOL] = (double)options->rtol;
    settings[LAG_SET_ATOL] = (double)options->atol;
    settings[LAG_SET_STEP] = (double)options->step;
    settings[LAG_SET_MAX_STEP] = (double)options->max_step;
    settings[LAG_SET_STAGES] = options->stages;
    settings[LAG_SET_NORM] = options->norm;
    settings[LAG_SET_MAX_STEPS] = (double)lag_step_limit(options, t0, t1, last);
    for (i = 0; i < LAG_NY; ++i)
        settings[LAG_SETTINGS + i] = (double)LAG_ATOL(options, i);
    if (lag_read_members(program, given, &members)) {
        lag_print_header(1);
        lag_catch_interrupt();    /* members in flight stop, the others are not begun */
        status = members.count > 0 ? lag_run_standalone_batch(&members, settings, last + 1) : 0;
    }
    free(members.parameters);
    free(members.initial);
    return status;
}
