/* The standalone program's command line (NAME=VALUE, --OPTION=VALUE, --batch, --help) and main:
 * one run of the scene, or with --batch one per line of standard input (standalone_batch.c). */

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
