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
 *
 * Four files in this order (lagdsl/integrators STANDALONE_FILES): this one, the values the program
 * is given (NAME=VALUE of an input, in its declared unit or with a unit; --atol=NAME=VALUE; the
 * checks of `lagc run` on the grid, the tolerances and the inputs), read the same way on the
 * command line and in batch lines; standalone_output.c (the CSV, the run summary, Ctrl-C);
 * standalone_batch.c (--batch); standalone.c (the command line and main).
 */

#define LAG_LINE_MAX 4096                /* the longest line of batch input (and argument), with its newline */

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
 * product: the value lagc run --set gives (given_values.scaled_to_si). */
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
