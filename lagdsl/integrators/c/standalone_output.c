/* The standalone program's output: the CSV on standard output, the run summary on standard error,
 * and Ctrl-C, which stops the run between two steps and leaves the rows written a valid CSV. */

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
