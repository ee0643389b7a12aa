/* The standalone program: NAME=VALUE arguments, the CSV on standard output, the run summary on
 * standard error; with --batch, one member a line of standard input and one CSV of them all.
 *
 * Pasted last into every generated C file (lagdsl/codegen/c.py), after driver.c, library.c and
 * what the code generator writes for the scene's command line: LAG_SCENE_T_START,
 * LAG_SCENE_T_STOP, LAG_SCENE_T_INTERVAL and LAG_SCENE_OPTIONS (the scene's grid and options),
 * lag_option_setting and lag_print_options (its integrator's options), with LAG_HAS_TOLERANCES
 * the tables of the atol per component (LAG_NATOL, lag_atol_names, lag_atol_inputs,
 * lag_atol_family, lag_scene_atol_given), lag_stop_text (with
 * LAG_HAS_STOP), lag_counter_labels and lag_print_status (lagdsl/abi.py).
 */

#define LAG_LINE_MAX 4096                /* the longest line of batch input (and argument), with its newline */

static int lag_print_row(void *context, real t, const real *out)
{
    int i;
    (void)context;
    lag_print_real(stdout, t);
    for (i = 0; i < LAG_NOUT; ++i) {
        fputc(',', stdout);
        lag_print_real(stdout, out[i]);
    }
    fputc('\n', stdout);
    return 0;
}

/* The CSV header: the columns, after the member's number in batch mode. */
static void lag_print_header(int batch)
{
    int i;
    fputs(batch ? "member,t" : "t", stdout);
    for (i = 0; i < LAG_NOUT; ++i)
        fprintf(stdout, ",%s", lag_column_names[i]);
    fputc('\n', stdout);
}

/* The work counters as the summary labels them: "12 steps accepted, 3 rejected, ...". */
static void lag_print_counters(FILE *file, const long *counts)
{
    int i;
    for (i = 0; i < LAG_NCOUNTERS; ++i)
        fprintf(file, "%s%ld %s", i == 0 ? "" : ", ", counts[i], lag_counter_labels[i]);
}

static int lag_index_of(const char *const *names, int count, const char *name, size_t length)
{
    int i;
    for (i = 0; i < count; ++i)
        if (strlen(names[i]) == length && strncmp(names[i], name, length) == 0)
            return i;
    return -1;
}

/* `text` begins with `word`, in any case. */
static int lag_begins_with_word(const char *text, const char *word)
{
    for (; *word != '\0'; ++text, ++word)
        if (tolower((unsigned char)*text) != *word)
            return 0;
    return 1;
}

/* The length of the number `text` begins with (abi.NUMBER): a decimal number with an optional
 * sign, fraction and exponent, or inf, infinity or nan in any case; 0 if it begins with none. */
static size_t lag_number_length(const char *text)
{
    static const char *const words[] = { "infinity", "inf", "nan" };
    const char *c = text + (*text == '+' || *text == '-');
    int digits = 0, i;
    for (i = 0; i < 3; ++i)
        if (lag_begins_with_word(c, words[i]))
            return (size_t)(c - text) + strlen(words[i]);
    for (; isdigit((unsigned char)*c); ++c)
        digits = 1;
    if (*c == '.')
        for (++c; isdigit((unsigned char)*c); ++c)
            digits = 1;
    if (digits && (*c == 'e' || *c == 'E') && isdigit((unsigned char)c[1 + (c[1] == '+' || c[1] == '-')])) {
        c += 1 + (c[1] == '+' || c[1] == '-');
        while (isdigit((unsigned char)*c))
            ++c;
    }
    return digits ? (size_t)(c - text) : 0;
}

/* A value as `lagc run --set` takes it (abi.NUMBER), and nothing after it; strtod alone would
 * also take hexadecimal (0x10) and stop at a NUL byte. */
static int lag_parse_value(const char *text, real *value)
{
    size_t length = lag_number_length(text);
    char *end;
    if (length == 0 || text[length] != '\0')
        return 0;
    *value = r_strtod(text, &end);
    return end != text && *end == '\0';
}

/* What may differ between the members of a batch: parameters and initial values, given by name. */
typedef struct lag_member {
    real par[LAG_NP > 0 ? LAG_NP : 1];
    int fixed[LAG_NP > 0 ? LAG_NP : 1];    /* given, so not computed from the others */
    real start[LAG_NY];
    int overridden[LAG_NY];
} lag_member;

/* NAME=VALUE: the '=' and the value, or NULL after saying what is wrong (after `prefix`). */
static const char *lag_split_setting(const char *prefix, const char *text, real *value)
{
    const char *equals = strchr(text, '=');
    if (equals == NULL || !lag_parse_value(equals + 1, value)) {
        fprintf(stderr, "%s: expected NAME=VALUE, got '%s'\n", prefix, text);
        return NULL;
    }
    return equals;
}

/* The slot of lag_input_units that NAME (ending at `equals`) sets: a parameter, or a
 * coordinate's start or velocity; -1 for any other name. */
static int lag_input_slot(const char *text, const char *equals)
{
    const char *dot = NULL;
    const char *c;
    int index;
    for (c = text; c < equals; ++c)    /* the last '.' of the name */
        if (*c == '.')
            dot = c;
    if ((index = lag_index_of(lag_parameter_names, LAG_NP, text, (size_t)(equals - text))) >= 0)
        return index;
    if (dot != NULL && (index = lag_index_of(lag_coordinate_names, LAG_NQ, text, (size_t)(dot - text))) >= 0
        && (strncmp(dot, ".start=", 7) == 0 || strncmp(dot, ".velocity=", 10) == 0))
        return LAG_NP + (dot[1] == 's' ? index : LAG_NQ + index);
    return -1;
}

/* x in a unit whose factor to SI is scale + scale_low, in SI. The error of the product is
 * recovered exactly (fma), so the result is rounded once from within about 2^-106 of the exact
 * product: the value lagc run --set gives (settings.scaled_to_si). */
static real lag_in_si(real x, const lag_input_unit *unit)
{
    real product = x * (real)unit->scale;
    if (unit->scale_low == 0 || !r_isfinite(product))
        return product;
    return product + (LAG_FN(fma)(x, (real)unit->scale, -product) + x * (real)unit->scale_low);
}

/* The unit written after a number ("deg", " [deg]"), without the spaces and brackets, into
 * `unit` (of LAG_LINE_MAX characters). */
static void lag_written_unit(const char *text, char *unit)
{
    size_t length;
    while (isspace((unsigned char)*text))
        ++text;
    length = strlen(text);
    while (length > 0 && isspace((unsigned char)text[length - 1]))
        --length;
    if (length >= 2 && text[0] == '[' && text[length - 1] == ']') {
        text += 1;
        length -= 2;
    }
    memcpy(unit, text, length);
    unit[length] = '\0';
}

/* VALUE for input `slot`, in SI: a number in the input's declared unit, or a number and a unit,
 * the declared one or SI ("30 deg", "30deg", "30 [deg]", "0.52 rad"); 0 after saying what is wrong. */
static int lag_input_value(const char *prefix, const char *text, const char *equals, int slot, real *value)
{
    const lag_input_unit *declared = &lag_input_units[slot];
    const char *given = equals + 1;
    size_t length = lag_number_length(given);
    char number[LAG_LINE_MAX], unit[LAG_LINE_MAX];
    int name = (int)(equals - text);
    if (length == 0 || strlen(given) >= LAG_LINE_MAX) {
        fprintf(stderr, "%s: expected NAME=VALUE with a number (and a unit), got '%s'\n", prefix, text);
        return 0;
    }
    lag_written_unit(given + length, unit);
    if (unit[0] != '\0' && declared->unit[0] == '\0') {
        fprintf(stderr, "%s: %.*s: expected a plain number (the model declares no unit for it), got '%s'\n",
                prefix, name, text, given);
        return 0;
    }
    if (unit[0] != '\0' && strcmp(unit, declared->unit) != 0 && strcmp(unit, declared->si) != 0) {
        fprintf(stderr, "%s: %.*s: '%s' is not in %s (%s): give a plain number in %s, or write %s or %s after it\n",
                prefix, name, text, given, declared->unit, declared->dimension, declared->unit, declared->unit,
                declared->si);
        return 0;
    }
    memcpy(number, given, length);
    number[length] = '\0';
    *value = r_strtod(number, NULL);
    if (unit[0] == '\0' || strcmp(unit, declared->unit) == 0)
        *value = lag_in_si(*value, declared);
    return 1;
}

/* Set input `slot` of `member` to `value` (in SI). */
static void lag_set_input(lag_member *member, int slot, real value)
{
    if (slot < LAG_NP) {
        member->par[slot] = value;
        member->fixed[slot] = 1;
    } else {
        member->start[slot - LAG_NP] = value;
        member->overridden[slot - LAG_NP] = 1;
    }
}

/* NAME=VALUE of a parameter, or of a coordinate's start or velocity: set it in `member` and
 * return 1; 0 for any other name; -1 after saying what is wrong with VALUE. */
static int lag_member_setting(const char *prefix, const char *text, lag_member *member)
{
    const char *equals = strchr(text, '=');
    int slot = equals == NULL ? -1 : lag_input_slot(text, equals);
    real value;
    if (slot < 0)
        return 0;
    if (!lag_input_value(prefix, text, equals, slot, &value))
        return -1;
    lag_set_input(member, slot, value);
    return 1;
}

#if LAG_HAS_TOLERANCES
/* ---- atol per component (lagdsl/tolerances.py): --atol=NAME=VALUE, NAME one of lag_atol_names ---- */
static double lag_atol_given[LAG_NATOL];     /* in SI; negative: not given (the scene's, then the command line's) */
static double lag_atol_values[LAG_NY];       /* the atol of each component of y, when one is named */

/* --atol=NAME=VALUE (`text` is NAME=VALUE): VALUE in the declared unit of the component, or with
 * a unit, as a coordinate's start (its velocity's for der(NAME)) takes it. Returns 0 after saying
 * what is wrong. */
static int lag_atol_setting(const char *program, const char *text)
{
    const char *equals = strchr(text, '=');
    int k = lag_index_of(lag_atol_names, LAG_NATOL, text, (size_t)(equals - text));
    real value;
    if (k < 0) {
        fprintf(stderr, "%s: --atol=%s: '%.*s' is not a coordinate nor der() of one (run %s --help)\n", program,
                text, (int)(equals - text), text, program);
        return 0;
    }
    if (!lag_input_value(program, text, equals, lag_atol_inputs[k], &value))
        return 0;
    if (!(r_isfinite(value) && (LAG_ATOL_POSITIVE ? value > 0 : value >= 0))) {
        fprintf(stderr, "%s: --atol=%s: atol(%s) must be a finite number %s\n", program, text, lag_atol_names[k],
                LAG_ATOL_POSITIVE ? "> 0 for an implicit method" : ">= 0");
        return 0;
    }
    lag_atol_given[k] = (double)value;
    return 1;
}

/* The given atol of name `member`, else of name `family` (-1: none); negative when neither is. */
static double lag_atol_named(int family, int member)
{
    return lag_atol_given[member] >= 0 || family < 0 ? lag_atol_given[member] : lag_atol_given[family];
}

/* options->atol_each for a run from t0 to t1 (tolerances.atol_vector): NULL when no component is
 * named; else a named one's atol, the velocity of a coordinate named alone atol(q) / (t1 - t0),
 * the others options->atol. */
static void lag_atol_apply(lag_options *options, real t0, real t1)
{
    int i, named = 0;
    for (i = 0; i < LAG_NATOL; ++i)
        named |= lag_atol_given[i] >= 0;
    options->atol_each = named ? lag_atol_values : NULL;
    for (i = 0; i < LAG_NQ; ++i) {
        int family = lag_atol_family[i];
        double q = lag_atol_named(family, i);
        double v = lag_atol_named(family < 0 ? -1 : LAG_NATOL_PLAIN + family, LAG_NATOL_PLAIN + i);
        lag_atol_values[i] = q >= 0 ? q : (double)options->atol;
        lag_atol_values[LAG_NQ + i] = v >= 0 ? v : q >= 0 ? q / ((double)t1 - (double)t0) : (double)options->atol;
    }
}
#endif

static void lag_on_interrupt(int signal_number)
{
    (void)signal_number;
    lag_interrupt = 1;
}

/* Ctrl-C stops the run between two steps. With POSIX's sigaction the handler stays and a write
 * of a row that the signal interrupts resumes (SA_RESTART): ISO C's signal() gives neither on
 * every system, and an interrupted write would cut the last row of the CSV. */
static void lag_catch_interrupt(void)
{
#ifdef SA_RESTART
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_handler = lag_on_interrupt;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    sigaction(SIGINT, &action, NULL);
#else
    signal(SIGINT, lag_on_interrupt);
#endif
}

/* The checks of `lagc run`: a finite grid of at most LAG_MAX_ROWS rows. */
static int lag_check_grid(const char *program, real t0, real t1, real dt)
{
    real ratio = (t1 - t0) / dt;
    if (!r_isfinite(t0) || !r_isfinite(t1) || !r_isfinite(dt)) {
        fprintf(stderr, "%s: t.start, t.stop and t.interval must be finite numbers\n", program);
        return 0;
    }
    if (!(t1 > t0) || !(dt > 0)) {
        fprintf(stderr, "%s: need t.stop > t.start and t.interval > 0\n", program);
        return 0;
    }
    if (!(ratio < LAG_MAX_ROWS - 1) || lag_last_row(t0, t1, dt) + 1 > LAG_MAX_ROWS) {
        fprintf(stderr, "%s: the output grid from %.17g to %.17g every %.17g would have %.3g rows, more than "
                "the limit of %ld; choose a larger t.interval\n", program, (double)t0, (double)t1, (double)dt,
                (double)ratio + 1, LAG_MAX_ROWS);
        return 0;
    }
    return 1;
}

/* The checks of the tolerances (with LAG_HAS_TOLERANCES): not both 0, and rtol at least
 * LAG_RTOL_FLOOR (raised, with a warning). */
static int lag_check_tolerances(const char *program, lag_options *options)
{
#if LAG_HAS_TOLERANCES
    if (!(options->rtol > 0 || options->atol > 0)) {
        fprintf(stderr, "%s: rtol and atol cannot both be 0\n", program);
        return 0;
    }
    if (options->rtol < LAG_RTOL_FLOOR) {
        fprintf(stderr, "%s: warning: rtol = %g is below %d eps; raised to %g\n", program, (double)options->rtol,
                LAG_RTOL_FLOOR_EPS, (double)LAG_RTOL_FLOOR);
        options->rtol = LAG_RTOL_FLOOR;
    }
#else
    (void)program;
    (void)options;
#endif
    return 1;
}

/* Every parameter (given or derived) and every initial value must be a finite number. */
static int lag_check_inputs(const char *program, const real *par, const real *y0)
{
    int i;
    for (i = 0; i < LAG_NP; ++i)
        if (!r_isfinite(par[i])) {
            fprintf(stderr, "%s: the parameter %s is %g, not a finite number\n", program, lag_parameter_names[i],
                    (double)par[i]);
            return 0;
        }
    for (i = 0; i < LAG_NY; ++i)
        if (!r_isfinite(y0[i])) {
            fprintf(stderr, "%s: the initial %s of %s is %g, not a finite number\n", program,
                    i < LAG_NQ ? "value" : "velocity", lag_coordinate_names[i % LAG_NQ], (double)y0[i]);
            return 0;
        }
    return 1;
}

/* The member's parameters (the ones not given computed from the others) and initial state (the
 * scene's, where not given); 0 after saying what is not finite. */
static int lag_member_state(const char *prefix, lag_member *member, real *y0)
{
    int i;
    lag_derive_parameters(member->par, member->fixed);
    lag_initial_state(member->par, y0);
    for (i = 0; i < LAG_NY; ++i)
        if (member->overridden[i])
            y0[i] = member->start[i];
    return lag_check_inputs(prefix, member->par, y0);
}

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

/* OPTION=VALUE with the option's name as its flag (max_step -> max-step); 0 if too long. */
static int lag_option_text(const char *text, char *option)
{
    size_t i, length = strlen(text);
    int in_name = 1;
    if (length >= LAG_LINE_MAX)
        return 0;
    for (i = 0; i <= length; ++i) {
        in_name = in_name && text[i] != '=';
        option[i] = in_name && text[i] == '_' ? '-' : text[i];
    }
    return 1;
}

/* What NAME=VALUE is not: an option written without its dashes says how to give it (a
 * parameter of the same name would have taken the setting: the options have a syntax of their own). */
static void lag_unknown_setting(const char *program, const char *text, const char *equals)
{
    int length = (int)(equals - text);
    char option[LAG_LINE_MAX];
    if (lag_option_text(text, option) && lag_index_of(lag_option_names, LAG_NOPTIONS, option, (size_t)length) >= 0)
        fprintf(stderr, "%s: '%.*s' is an option of the integrator: write --%s\n", program, length, text, option);
    else
        fprintf(stderr, "%s: unknown setting '%.*s' (run %s --help)\n", program, length, text, program);
}

/* A name in the help, with its declared unit if it has one. */
static void lag_print_input(const char *name, const char *unit)
{
    if (unit[0] != '\0')
        printf(" %s [%s]", name, unit);
    else
        printf(" %s", name);
}

/* --help: what the program takes. */
static void lag_print_help(const char *program)
{
    int i;
    printf("usage: %s [--batch] [NAME=VALUE ...] [--OPTION=VALUE ...] > out.csv\n"
           "Simulates %s (%s); the CSV goes to standard output, the run summary to standard error.\n"
           "NAME is a parameter [in its declared unit]:", program, LAG_MODEL_NAME, LAG_SCENE_NAME);
    for (i = 0; i < LAG_NP; ++i)
        lag_print_input(lag_parameter_names[i], lag_input_units[i].unit);
    printf("\n  or COORDINATE.start, COORDINATE.velocity (initial values, in its unit and its unit per second),"
           "\n  COORDINATE one of:");
    for (i = 0; i < LAG_NQ; ++i)
        lag_print_input(lag_coordinate_names[i], lag_input_units[LAG_NP + i].unit);
    printf("\n  or t.start, t.stop, t.interval (the output grid).\nOPTION is an option of %s:", LAG_INTEGRATOR_NAME);
    for (i = 0; i < LAG_NOPTIONS; ++i)
        printf(" --%s", lag_option_names[i]);
#if LAG_HAS_TOLERANCES
    printf("\n  --atol=COMPONENT=VALUE sets the atol of one component of the state, in its declared unit (or"
           "\n  with a unit, as COMPONENT.start and .velocity take it), COMPONENT one of:");
    for (i = 0; i < LAG_NATOL; ++i)
        printf(" %s", lag_atol_names[i]);
#endif
    printf("\nVALUE is a decimal number (1e-12, -0.5; inf, nan) in the declared unit, as in the model file;\n"
           "  a parameter's or initial value's number may carry that unit or its SI unit instead ('30 deg',\n"
           "  30deg, '30 [deg]', 0.52rad; in --batch lines, without a space). t.start, t.stop, t.interval are\n"
           "  in seconds.\n"
           "--batch reads one member a line of standard input: NAME=VALUE settings of parameters and initial\n"
           "values, on top of the command line's; the CSV's first column is the member's number.\n");
}

/* The command line: parameters, initial values, the grid and the options, onto the scene's.
 * Returns 0 after saying what is wrong. */
static int lag_parse_arguments(int argc, char **argv, lag_member *given, real *grid, lag_options *options,
                               int *batch)
{
    int i, known;
    for (i = 1; i < argc; ++i) {
        const char *equals;
        real value;
        if (strcmp(argv[i], "--batch") == 0) {
            *batch = 1;
            continue;
        }
        if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            lag_print_help(argv[0]);
            exit(0);
        }
        if (strncmp(argv[i], "--", 2) == 0) {         /* an option: --rtol=1e-12, --max-step=0.1 */
            char option[LAG_LINE_MAX];
            if (!lag_option_text(argv[i] + 2, option)) {
                fprintf(stderr, "%s: an argument longer than %d characters\n", argv[0], LAG_LINE_MAX - 1);
                return 0;
            }
#if LAG_HAS_TOLERANCES
            if (strncmp(option, "atol=", 5) == 0 && strchr(option + 5, '=') != NULL) {    /* --atol=x=1e-18 */
                if (!lag_atol_setting(argv[0], option + 5))
                    return 0;
                continue;
            }
#endif
            if ((equals = lag_split_setting(argv[0], option, &value)) == NULL)
                return 0;
            if ((known = lag_option_setting(argv[0], option, equals, value, options)) == 0)
                fprintf(stderr, "%s: unknown option '--%.*s' (run %s --help)\n", argv[0], (int)(equals - option),
                        option, argv[0]);
            if (known <= 0)
                return 0;
            continue;
        }
        if ((known = lag_member_setting(argv[0], argv[i], given)) != 0) {
            if (known < 0)
                return 0;
            continue;
        }
        if ((equals = lag_split_setting(argv[0], argv[i], &value)) == NULL)
            return 0;
        if (strncmp(argv[i], "t.start=", 8) == 0) {
            grid[0] = value;
        } else if (strncmp(argv[i], "t.stop=", 7) == 0) {
            grid[1] = value;
        } else if (strncmp(argv[i], "t.interval=", 11) == 0) {
            grid[2] = value;
        } else {
            lag_unknown_setting(argv[0], argv[i], equals);
            return 0;
        }
    }
    return lag_check_grid(argv[0], grid[0], grid[1], grid[2]) && lag_check_tolerances(argv[0], options);
}

/* The integrator's work, and what the scene watches: the stiffness test, the switches, the stop
 * condition, the invariants and the constraints. */
static void lag_print_work(const lag_report *report, const lag_options *options, double seconds)
{
    double summary[LAG_SUMMARY_SIZE];
    long counts[LAG_NCOUNTERS];
    int i;
    lag_pack_summary(report, summary);
    for (i = 0; i < LAG_NCOUNTERS; ++i)
        counts[i] = (long)summary[LAG_SUMMARY_COUNTERS + i];
    fprintf(stderr, "integrator %s(", LAG_INTEGRATOR_NAME);    /* the options as used, as in a scene */
    lag_print_options(stderr, options);
#if LAG_HAS_TOLERANCES
    for (i = 0; i < LAG_NATOL; ++i)
        if (lag_atol_given[i] >= 0)
            fprintf(stderr, ", atol(%s) = %g", lag_atol_names[i], lag_atol_given[i]);
#endif
    fputs("): ", stderr);
    lag_print_counters(stderr, counts);
    fprintf(stderr, ", %.3g s CPU\n", seconds);
#if LAG_HAS_STIFFNESS_TEST
    lag_print_verdict(stderr, report);
#endif
#if LAG_HAS_SWITCHES
    fprintf(stderr, "auto: %ld switch%s", report->switches.count, report->switches.count == 1 ? "" : "es");
    for (i = 0; i < report->switches.count && i < LAG_AUTO_LOGGED; ++i)
        fprintf(stderr, "%sto %s at t = %.6g", i == 0 ? " (" : ", ", i % 2 == 0 ? "radau5" : "dop853",
                (double)report->switches.at[i]);
    fprintf(stderr, "%s; dop853 over %.6g of t, radau5 over %.6g\n",
            report->switches.count == 0 ? "" : report->switches.count > LAG_AUTO_LOGGED ? ", ...)" : ")",
            (double)report->switches.span[LAG_AUTO_EXPLICIT], (double)report->switches.span[LAG_AUTO_IMPLICIT]);
#endif
#if LAG_HAS_STOP
    if (report->stopped)
        fprintf(stderr, "stopped at t = %.17g, where %s\n", (double)report->t_stop, lag_stop_text);
#endif
#if LAG_HAS_INVARIANTS
    for (i = 0; i < LAG_NINV; ++i)
        fprintf(stderr, "drift of %s: %.3g (from %.17g)\n", lag_invariant_names[i],
                (double)report->invariant_drift[i], (double)report->invariant_start[i]);
#endif
#if LAG_HAS_CONSTRAINTS
    fprintf(stderr, "largest constraint residual (%s", lag_constraint_names[0]);
    for (i = 1; i < LAG_NC; ++i)
        fprintf(stderr, ", %s", lag_constraint_names[i]);
    fprintf(stderr, "): %.3g\n", (double)report->residual_max);
#endif
}

/* The run summary on standard error: the work (lag_print_work) and how the run failed. Returns
 * the exit status: 0, 1 after a failure, 130 when interrupted. */
static int lag_print_summary(const lag_report *report, const lag_options *options, long max_steps, double seconds)
{
    int i;
    lag_print_work(report, options, seconds);
    if (report->status == LAG_ERR_INTERRUPTED) {
        fprintf(stderr, "interrupted at t = %.17g after %ld rows\n", (double)report->t_fail, report->rows);
        return 130;    /* 128 + SIGINT, as a shell reports a run stopped by Ctrl-C */
    }
    if (report->status != LAG_OK) {
        fprintf(stderr, "the run is incomplete: %ld rows written\n", report->rows);
        fprintf(stderr, "simulation failed at t = %.17g: ", (double)report->t_fail);
        lag_print_status(stderr, report->status, max_steps, (double)report->rcond_fail,
                         (double)report->forecast.steps, (double)report->forecast.stop);
        fputs("\n  state:", stderr);
        for (i = 0; i < LAG_NQ; ++i)
            fprintf(stderr, " %s = %.17g, %s' = %.17g", lag_coordinate_names[i], (double)report->y_fail[i],
                    lag_coordinate_names[i], (double)report->y_fail[LAG_NQ + i]);
        fputc('\n', stderr);
        return 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    lag_system sys;
    lag_member given;
    lag_options options = LAG_SCENE_OPTIONS;
    lag_report report;
    real y0[LAG_NY], grid[3] = { LAG_SCENE_T_START, LAG_SCENE_T_STOP, LAG_SCENE_T_INTERVAL };
    int batch = 0;
    clock_t clock_start;
    memset(&given, 0, sizeof given);
    lag_default_parameters(given.par);
#if LAG_HAS_TOLERANCES
    memcpy(lag_atol_given, lag_scene_atol_given, sizeof lag_atol_given);
#endif
    if (!lag_parse_arguments(argc, argv, &given, grid, &options, &batch))
        return 2;
#if LAG_HAS_TOLERANCES
    lag_atol_apply(&options, grid[0], grid[1]);
#endif
    if (batch)
        return lag_batch_main(argv[0], &given, grid[0], grid[1], grid[2], &options);
    if (!lag_member_state(argv[0], &given, y0))
        return 2;
    memcpy(sys.par, given.par, sizeof sys.par);
    lag_print_header(0);
    lag_catch_interrupt();    /* stop between two steps, keeping the rows written so far */
    clock_start = clock();
    lag_integrate(&sys, y0, grid[0], grid[1], grid[2], &options, lag_print_row, NULL, &report);
    return lag_print_summary(&report, &options, lag_step_limit(&options, grid[0], grid[1], lag_last_row(grid[0], grid[1], grid[2])),
                             (double)(clock() - clock_start) / CLOCKS_PER_SEC);
}
