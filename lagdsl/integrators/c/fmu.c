/* An FMU instance (Functional Mock-up Interface), whatever the FMI version: the model's
 * parameters and state, its mode in the FMI state machine, the checks of every call, logging,
 * the experiment. fmu_values.c follows with its variables by value reference, fmu_run.c with
 * model exchange (the derivatives from lag_rhs, the stop condition's event indicator) and
 * co-simulation (a communication step with the scene's integrator, driver.c's loop), then fmi2.c
 * with the entry points of FMI 2.0.
 *
 * Pasted after driver.c when lagc exports an FMU (lagdsl/codegen/fmu.py), after what the
 * generator writes for the export:
 *   LAG_FMU_TOKEN                  the GUID (FMI 2) or instantiation token (FMI 3) of this export
 *   LAG_FMU_MODEL_EXCHANGE         1 if exported for model exchange (the model has lag_rhs then)
 *   LAG_FMU_CO_SIMULATION          1 if exported for co-simulation (its code is always compiled:
 *                                  the integrator's, which co-simulation needs, is in every FMU)
 *   LAG_FMU_NVARIABLES, LAG_FMU_VARIABLES   the variables, sorted by value reference
 *   LAG_FMU_T_START, LAG_FMU_T_STOP, LAG_FMU_T_INTERVAL, LAG_FMU_OPTIONS   the scene's grid, options
 *   LAG_FMU_CATEGORIES, LAG_FMU_NCATEGORIES, enum lag_fmu_category   the log categories
 *   LAG_FMU_STOP_TEXT              the stop condition as written ("" without one)
 *   lag_fmu_option_refusal         the checks of lagc run on an integrator option
 *   lag_format_status              a status's message and remedy (lagdsl.abi.STATUSES)
 */
#include <stdarg.h>

/* The modes of the FMI state machine (FMI 2.0 sections 3.2.3 and 4.2.4, FMI 3.0 section 3.2),
 * as bits, so that a function names the modes it may be called in as one mask. */
enum lag_fmu_mode {
    LAG_FMU_INSTANTIATED = 1, LAG_FMU_INITIALIZATION = 2, LAG_FMU_EVENT = 4, LAG_FMU_CONTINUOUS = 8,
    LAG_FMU_STEP = 16, LAG_FMU_TERMINATED = 32, LAG_FMU_FAILED = 64
};
#define LAG_FMU_ANY_MODE 127
#define LAG_FMU_EVALUATED (LAG_FMU_INITIALIZATION | LAG_FMU_EVENT | LAG_FMU_CONTINUOUS | LAG_FMU_STEP \
                           | LAG_FMU_TERMINATED | LAG_FMU_FAILED)      /* where values may be read */
static const char *const lag_fmu_mode_names[] = { "instantiated mode", "initialization mode", "event mode",
    "continuous-time mode", "step mode", "terminated mode", "error mode" };

/* The statuses of FMI functions, numbered as fmi2Status and fmi3Status. */
enum lag_fmu_status { LAG_FMU_OK, LAG_FMU_WARNING, LAG_FMU_DISCARD, LAG_FMU_ERROR, LAG_FMU_FATAL };
enum lag_fmu_kind { LAG_FMU_ME, LAG_FMU_CS };

/* What a value reference stands for: time, a parameter (par[index]), an integrator option
 * (index: its LAG_SET_ position), an entry of the state y, an acceleration (entry index of
 * dy/dt), an output column, the stop condition's event indicator, or the atol of entry index
 * of y (co-simulation). */
enum lag_fmu_variable_kind {
    LAG_FMU_TIME, LAG_FMU_PARAMETER, LAG_FMU_OPTION, LAG_FMU_STATE, LAG_FMU_ACCELERATION, LAG_FMU_OUTPUT,
    LAG_FMU_INDICATOR, LAG_FMU_TOLERANCE
};
enum lag_fmu_type { LAG_FMU_REAL, LAG_FMU_INTEGER };
typedef struct lag_fmu_variable {
    unsigned long reference;
    unsigned char kind, type;
    int index;
} lag_fmu_variable;
static const lag_fmu_variable lag_fmu_variables[LAG_FMU_NVARIABLES] = LAG_FMU_VARIABLES;
static const char *const lag_fmu_categories[LAG_FMU_NCATEGORIES] = LAG_FMU_CATEGORIES;

/* What an instance has computed at its (t, y) and parameters, kept until one of them changes. */
enum lag_fmu_fresh { LAG_FMU_HAVE_DERIVATIVES = 1, LAG_FMU_HAVE_OUTPUTS = 2 };

typedef struct lag_fmu lag_fmu;
/* Hands a message to the importer's callback, as the FMI version asks (fmi2.c, fmi3.c). */
typedef void (*lag_fmu_logger)(const lag_fmu *fmu, int status, const char *category, const char *message);

struct lag_fmu {
    lag_fmu_logger logger;
    char *name;
    int kind, mode;
    unsigned logging;                       /* bit c: category c is logged (errors always are) */
    lag_system sys;
    int fixed[LAG_NP > 0 ? LAG_NP : 1];     /* parameters set: not computed from the others */
    real t, y[LAG_NY];
    int given[LAG_NY];                      /* initial values set: not computed from the parameters */
    real t_stop;
    int stop_defined;
    int fresh;                              /* enum lag_fmu_fresh */
    int prepared;                           /* lag_system_prepare has seen the parameters */
    int crossed;                            /* in event mode: entered from continuous time */
    real dydt[LAG_NY], out[LAG_NOUT];
    lag_options options;
    double atol_each[LAG_NY];               /* integrator.atol.<component>; 0: options.atol */
    double atol_used[LAG_NY];               /* what options.atol_each points to when one is not 0 */
    lag_stepper *stepper;
    lag_report report;                      /* the stop condition's: stopped, t_stop */
    real e_old, t_end;                      /* the stop function at the last step, the stepper's end */
    long step_limit;                        /* the stepper's, for a run to t_end */
    int restart;                            /* the parameters changed since the stepper began */
    int terminated;                         /* the stop condition ended the run at t */
};

static void lag_fmu_vlog(const lag_fmu *fmu, int status, int category, const char *format, va_list arguments)
{
    char message[2048];
    if (fmu->logger == NULL || (status < LAG_FMU_ERROR && !(fmu->logging & (1u << category))))
        return;
    vsnprintf(message, sizeof message, format, arguments);
    fmu->logger(fmu, status, lag_fmu_categories[category], message);
}

static void lag_fmu_log(const lag_fmu *fmu, int status, int category, const char *format, ...)
{
    va_list arguments;
    va_start(arguments, format);
    lag_fmu_vlog(fmu, status, category, format, arguments);
    va_end(arguments);
}

/* Say what went wrong and enter the error mode, as FMI asks after fmi2Error and fmi3Error:
 * from there only getters, reset and free are allowed. Returns LAG_FMU_ERROR. */
static int lag_fmu_error(lag_fmu *fmu, const char *format, ...)
{
    va_list arguments;
    va_start(arguments, format);
    lag_fmu_vlog(fmu, LAG_FMU_ERROR, LAG_FMU_LOG_ERROR, format, arguments);
    va_end(arguments);
    fmu->mode = LAG_FMU_FAILED;
    return LAG_FMU_ERROR;
}

static const char *lag_fmu_mode_name(int mode)
{
    int bit = 0;
    while ((1 << bit) < mode)
        ++bit;
    return lag_fmu_mode_names[bit];
}

/* Whether `function` may be called now, in one of the modes `allowed` (and by an instance of
 * the kind it is for, unless `kind` is negative); if not, say so and enter the error mode. */
static int lag_fmu_allowed(lag_fmu *fmu, const char *function, int allowed, int kind)
{
    if (kind >= 0 && fmu->kind != kind)
        lag_fmu_error(fmu, "%s is a %s function; this instance is for %s", function,
                      kind == LAG_FMU_ME ? "model exchange" : "co-simulation",
                      fmu->kind == LAG_FMU_ME ? "model exchange" : "co-simulation");
    else if (!(fmu->mode & allowed))
        lag_fmu_error(fmu, "%s may not be called in %s", function, lag_fmu_mode_name(fmu->mode));
    else
        return 1;
    return 0;
}

/* An array `values` of `given` entries that must have `count`: refuse it if it has not (or is NULL). */
static int lag_fmu_count(lag_fmu *fmu, const char *function, const void *values, size_t given, size_t count)
{
    if (given == count && (values != NULL || count == 0))
        return LAG_FMU_OK;
    return lag_fmu_error(fmu, "%s: an array of %lu values given (%s), this FMU has %lu", function,
                         (unsigned long)given, values == NULL ? "NULL" : "not NULL", (unsigned long)count);
}

/* The arrays of a get or a set: `count` value references and as many values, not NULL. */
static int lag_fmu_arrays(lag_fmu *fmu, const char *function, const void *references, const void *values,
                          size_t count)
{
    if (count == 0 || (references != NULL && values != NULL))
        return LAG_FMU_OK;
    return lag_fmu_error(fmu, "%s: NULL instead of an array of %lu value references or values", function,
                         (unsigned long)count);
}

/* Why an instance cannot be made, or NULL: it needs a name, the token of this export (the
 * binary and modelDescription.xml of one export), and a kind this FMU was exported for. */
static const char *lag_fmu_refusal(const char *name, const char *token, int kind)
{
    if (name == NULL || name[0] == '\0')
        return "an instance needs a name";
    if (token == NULL || strcmp(token, LAG_FMU_TOKEN) != 0)
        return "the GUID (instantiation token) given is not this FMU's: the binary and the modelDescription.xml "
               "come from different exports";
    if ((kind == LAG_FMU_ME && !LAG_FMU_MODEL_EXCHANGE) || (kind == LAG_FMU_CS && !LAG_FMU_CO_SIMULATION))
        return kind == LAG_FMU_ME ? "this FMU was exported for co-simulation only (lagc --kind)"
                                  : "this FMU was exported for model exchange only (lagc --kind)";
    return NULL;
}

/* A function of a capability this FMU does not have (its modelDescription.xml says so). */
static int lag_fmu_unsupported(lag_fmu *fmu, const char *function, const char *capability)
{
    return lag_fmu_error(fmu, "%s: this FMU does not support it (%s)", function, capability);
}

/* A get or a set of a type this FMU has no variables of: any value reference is a bad one. */
static int lag_fmu_no_variables(lag_fmu *fmu, const char *function, const void *references, size_t count)
{
    if (count == 0)
        return LAG_FMU_OK;
    if (references == NULL)
        return lag_fmu_arrays(fmu, function, references, NULL, count);
    return lag_fmu_error(fmu, "%s: this FMU has no variables of that type", function);
}

/* The initial values not set are those of the scene, from the parameters. */
static void lag_fmu_start_values(lag_fmu *fmu)
{
    real y0[LAG_NY];
    int i;
    lag_initial_state(fmu->sys.par, y0);
    for (i = 0; i < LAG_NY; ++i)
        if (!fmu->given[i])
            fmu->y[i] = y0[i];
    fmu->fresh = 0;
}

/* The start values of every variable: the scene's. */
static void lag_fmu_defaults(lag_fmu *fmu)
{
    lag_options options = LAG_FMU_OPTIONS;
    static const double atol_each[LAG_NY] = LAG_FMU_ATOL_EACH;
    memset(&fmu->sys, 0, sizeof fmu->sys);    /* a model without parameters still has par[0] */
    lag_default_parameters(fmu->sys.par);
    memset(fmu->fixed, 0, sizeof fmu->fixed);
    memset(fmu->given, 0, sizeof fmu->given);
    fmu->t = LAG_FMU_T_START;
    fmu->t_stop = LAG_FMU_T_STOP;
    fmu->stop_defined = 0;
    fmu->crossed = 0;
    fmu->options = options;
    memcpy(fmu->atol_each, atol_each, sizeof fmu->atol_each);
    fmu->prepared = 0;
    lag_fmu_start_values(fmu);
    fmu->restart = fmu->terminated = 0;
    fmu->mode = LAG_FMU_INSTANTIATED;
}

/* A new instance of `size` bytes (the FMI version's record, which begins with a lag_fmu), or NULL. */
static lag_fmu *lag_fmu_create(size_t size, const char *name, int kind, int logging)
{
    lag_fmu *fmu = calloc(1, size);
    if (fmu == NULL)
        return NULL;
    fmu->name = malloc(strlen(name) + 1);
    fmu->stepper = kind == LAG_FMU_CS ? malloc(sizeof *fmu->stepper) : NULL;
    if (fmu->name == NULL || (kind == LAG_FMU_CS && fmu->stepper == NULL)) {
        free(fmu->stepper);
        free(fmu->name);
        free(fmu);
        return NULL;
    }
    strcpy(fmu->name, name);
    fmu->kind = kind;
    fmu->logging = logging ? ~0u : 0u;
    lag_fmu_defaults(fmu);
    return fmu;
}

static void lag_fmu_free(lag_fmu *fmu)
{
    free(fmu->stepper);
    free(fmu->name);
    free(fmu);
}

/* fmi2SetDebugLogging, fmi3SetDebugLogging: logging on or off for the categories named (all if none). */
static int lag_fmu_set_logging(lag_fmu *fmu, int on, size_t count, const char *const *categories)
{
    size_t i;
    int c;
    if (count == 0)
        fmu->logging = on ? ~0u : 0u;
    for (i = 0; i < count; ++i) {
        for (c = 0; c < LAG_FMU_NCATEGORIES && (categories[i] == NULL || strcmp(categories[i], lag_fmu_categories[c]) != 0); ++c)
            ;
        if (c == LAG_FMU_NCATEGORIES)
            return lag_fmu_error(fmu, "no log category '%s' (this FMU's are in its modelDescription.xml)",
                                 categories[i] == NULL ? "(null)" : categories[i]);
        fmu->logging = on ? fmu->logging | 1u << c : fmu->logging & ~(1u << c);
    }
    return LAG_FMU_OK;
}

/* The experiment: the start time, the stop time if defined, and the tolerance, rtol of the
 * co-simulation's integrator, if defined (and the integrator has one). */
static int lag_fmu_setup(lag_fmu *fmu, int tolerance_defined, double tolerance, double start, int stop_defined,
                         double stop)
{
    if (!r_isfinite(start) || (stop_defined && !(r_isfinite(stop) && stop > start)))
        return lag_fmu_error(fmu, "the experiment from %.17g to %.17g: need finite times and stop > start", start,
                             stop);
    fmu->t = start;
    fmu->stop_defined = stop_defined;
    fmu->t_stop = stop_defined ? stop : start + (LAG_FMU_T_STOP - LAG_FMU_T_START);
    fmu->fresh = 0;
#if LAG_HAS_TOLERANCES
    if (tolerance_defined && fmu->kind == LAG_FMU_CS) {
        if (lag_fmu_option_refusal(LAG_SET_RTOL, tolerance) != NULL)
            return lag_fmu_error(fmu, "the experiment's tolerance %g is no rtol: rtol must be %s", tolerance,
                                 lag_fmu_option_refusal(LAG_SET_RTOL, tolerance));
        fmu->options.rtol = tolerance;
    }
#else
    (void)tolerance_defined;
    (void)tolerance;
#endif
    return LAG_FMU_OK;
}
