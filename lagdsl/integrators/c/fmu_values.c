/* An FMU instance's variables (fmu.c): finding a value reference, setting parameters, initial
 * values and integrator options in the modes FMI allows, and reading every variable, the outputs
 * and the derivatives computed at (t, y) when asked. Pasted after fmu.c, before fmu_run.c.
 */

/* The variable of value reference `reference` with type `type`, or NULL. */
static const lag_fmu_variable *lag_fmu_find(unsigned long reference, int type)
{
    size_t low = 0, high = LAG_FMU_NVARIABLES;
    while (low < high) {
        size_t middle = low + (high - low) / 2;
        if (lag_fmu_variables[middle].reference < reference)
            low = middle + 1;
        else
            high = middle;
    }
    if (low == LAG_FMU_NVARIABLES || lag_fmu_variables[low].reference != reference
        || lag_fmu_variables[low].type != type)
        return NULL;
    return &lag_fmu_variables[low];
}

static int lag_fmu_bad_reference(lag_fmu *fmu, const char *function, unsigned long reference)
{
    return lag_fmu_error(fmu, "%s: value reference %lu is none of this FMU's variables of that type", function,
                         reference);
}

/* The reals of lag_options by their LAG_SET_ position (NULL for stages and max_steps, integers). */
static real *lag_fmu_real_option(lag_options *options, int index)
{
    switch (index) {
    case LAG_SET_RTOL:
        return &options->rtol;
    case LAG_SET_ATOL:
        return &options->atol;
    case LAG_SET_STEP:
        return &options->step;
    case LAG_SET_MAX_STEP:
        return &options->max_step;
    default:
        return NULL;
    }
}

/* After a parameter changed: the parameters computed from it, and (before the run) the initial
 * values computed from them; in co-simulation the stepper begins again at the next step. */
static void lag_fmu_parameters_changed(lag_fmu *fmu)
{
    lag_derive_parameters(fmu->sys.par, fmu->fixed);
    if (fmu->mode & (LAG_FMU_INSTANTIATED | LAG_FMU_INITIALIZATION))
        lag_fmu_start_values(fmu);
    fmu->fresh = fmu->prepared = 0;
    fmu->restart = 1;
}

/* A variable that may be set only in the modes `allowed`, set in another: refuse it. */
static int lag_fmu_settable(lag_fmu *fmu, const char *function, unsigned long reference, int allowed)
{
    if (fmu->mode & allowed)
        return 1;
    lag_fmu_error(fmu, "%s: the variable of value reference %lu may not be set in %s", function, reference,
                  lag_fmu_mode_name(fmu->mode));
    return 0;
}

/* A tunable parameter: before the run, in event mode (model exchange) or between steps. */
static int lag_fmu_set_parameter(lag_fmu *fmu, const char *function, const lag_fmu_variable *variable, double value)
{
    if (!lag_fmu_settable(fmu, function, variable->reference,
                          LAG_FMU_INSTANTIATED | LAG_FMU_INITIALIZATION | LAG_FMU_EVENT | LAG_FMU_STEP))
        return LAG_FMU_ERROR;
    if (!r_isfinite(value))
        return lag_fmu_error(fmu, "%s: the parameter %s must be a finite number, got %g", function,
                             lag_parameter_names[variable->index], value);
    fmu->sys.par[variable->index] = value;
    fmu->fixed[variable->index] = 1;
    lag_fmu_parameters_changed(fmu);
    return LAG_FMU_OK;
}

/* An initial value, before the run. */
static int lag_fmu_set_start(lag_fmu *fmu, const char *function, const lag_fmu_variable *variable, double value)
{
    int i = variable->index;
    if (!lag_fmu_settable(fmu, function, variable->reference, LAG_FMU_INSTANTIATED | LAG_FMU_INITIALIZATION))
        return LAG_FMU_ERROR;
    if (!r_isfinite(value))
        return lag_fmu_error(fmu, "%s: the initial %s of %s must be a finite number, got %g", function,
                             i < LAG_NQ ? "value" : "velocity", lag_coordinate_names[i % LAG_NQ], value);
    fmu->y[i] = value;
    fmu->given[i] = 1;
    fmu->fresh = 0;
    return LAG_FMU_OK;
}

/* An integrator option (co-simulation), before the run, with the checks of lagc run. */
static int lag_fmu_set_option(lag_fmu *fmu, const char *function, const lag_fmu_variable *variable, double value)
{
    const char *refusal = lag_fmu_option_refusal(variable->index, value);
    real *field = lag_fmu_real_option(&fmu->options, variable->index);
    if (!lag_fmu_settable(fmu, function, variable->reference, LAG_FMU_INSTANTIATED | LAG_FMU_INITIALIZATION))
        return LAG_FMU_ERROR;
    if (refusal != NULL)
        return lag_fmu_error(fmu, "%s: the integrator option of value reference %lu must be %s, got %g", function,
                             variable->reference, refusal, value);
    if (field != NULL)
        *field = value;
    else if (variable->index == LAG_SET_STAGES)
        fmu->options.stages = (int)value;
    else if (variable->index == LAG_SET_NORM)
        fmu->options.norm = (int)value;
    else
        fmu->options.max_steps = (long)value;
    return LAG_FMU_OK;
}

/* The atol of one component of y (co-simulation), before the run: a finite number >= 0 (0: integrator.atol). */
static int lag_fmu_set_tolerance(lag_fmu *fmu, const char *function, const lag_fmu_variable *variable, double value)
{
    if (!lag_fmu_settable(fmu, function, variable->reference, LAG_FMU_INSTANTIATED | LAG_FMU_INITIALIZATION))
        return LAG_FMU_ERROR;
    if (!(r_isfinite(value) && value >= 0))
        return lag_fmu_error(fmu, "%s: the atol of value reference %lu must be a finite number >= 0 (0: "
                             "integrator.atol), got %g", function, variable->reference, value);
    fmu->atol_each[variable->index] = value;
    return LAG_FMU_OK;
}

/* fmi2SetReal, fmi3SetFloat64 (one value): parameters, initial values and integrator options. */
static int lag_fmu_set_real(lag_fmu *fmu, const char *function, unsigned long reference, double value)
{
    const lag_fmu_variable *variable = lag_fmu_find(reference, LAG_FMU_REAL);
    if (variable == NULL)
        return lag_fmu_bad_reference(fmu, function, reference);
    switch (variable->kind) {
    case LAG_FMU_PARAMETER:
        return lag_fmu_set_parameter(fmu, function, variable, value);
    case LAG_FMU_STATE:
        return lag_fmu_set_start(fmu, function, variable, value);
    case LAG_FMU_OPTION:
        return lag_fmu_set_option(fmu, function, variable, value);
    case LAG_FMU_TOLERANCE:
        return lag_fmu_set_tolerance(fmu, function, variable, value);
    default:
        return lag_fmu_error(fmu, "%s: the variable of value reference %lu is computed by the FMU; it cannot be set",
                             function, reference);
    }
}

/* fmi2SetInteger, fmi3SetInt32 (one value): the integer options of the integrator. */
static int lag_fmu_set_integer(lag_fmu *fmu, const char *function, unsigned long reference, long value)
{
    const lag_fmu_variable *variable = lag_fmu_find(reference, LAG_FMU_INTEGER);
    if (variable == NULL)
        return lag_fmu_bad_reference(fmu, function, reference);
    return lag_fmu_set_option(fmu, function, variable, (double)value);
}

static int lag_fmu_get_integer(lag_fmu *fmu, const char *function, unsigned long reference, long *value)
{
    const lag_fmu_variable *variable = lag_fmu_find(reference, LAG_FMU_INTEGER);
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVALUATED, -1))
        return LAG_FMU_ERROR;
    if (variable == NULL)
        return lag_fmu_bad_reference(fmu, function, reference);
    *value = variable->index == LAG_SET_STAGES ? (long)fmu->options.stages
             : variable->index == LAG_SET_NORM ? (long)fmu->options.norm : fmu->options.max_steps;
    return LAG_FMU_OK;
}

/* lag_system_prepare (a constant M is factored there) after the parameters changed. */
static void lag_fmu_prepare(lag_fmu *fmu)
{
    if (!fmu->prepared)
        lag_system_prepare(&fmu->sys);
    fmu->prepared = 1;
}

/* A numerical failure of the model or the integrator (`status`, a lag_status) at (t, y), logged
 * with the time, the state and the remedy: in model exchange a discard (the importer may try a
 * smaller step), in co-simulation an error. */
static int lag_fmu_failure(lag_fmu *fmu, int status, long max_steps, real t, const real *y)
{
    char message[512], state[1024] = "";
    size_t used = 0;
    int i;
    lag_format_status(message, sizeof message, status, max_steps, (double)lag_condition(&fmu->sys, t, y),
                      (double)fmu->report.forecast.steps, (double)fmu->report.forecast.stop);
    for (i = 0; i < LAG_NQ && used < sizeof state; ++i) {
        int length = snprintf(state + used, sizeof state - used, " %s = %.17g, %s' = %.17g", lag_coordinate_names[i],
                              (double)y[i], lag_coordinate_names[i], (double)y[LAG_NQ + i]);
        used += length > 0 ? (size_t)length : 0;
    }
    if (fmu->kind == LAG_FMU_ME) {
        lag_fmu_log(fmu, LAG_FMU_DISCARD, LAG_FMU_LOG_DISCARD, "at t = %.17g: %s; state:%s", (double)t, message, state);
        return LAG_FMU_DISCARD;
    }
    return lag_fmu_error(fmu, "simulation failed at t = %.17g: %s (%s); state:%s", (double)t, message,
                         lag_status_remedy(status), state);
}

/* The output columns at (t, y). */
static int lag_fmu_outputs(lag_fmu *fmu)
{
    int status;
#if LAG_HAS_INVARIANTS
    real inv[LAG_NINV];
#endif
    if (fmu->fresh & LAG_FMU_HAVE_OUTPUTS)
        return LAG_FMU_OK;
    lag_fmu_prepare(fmu);
#if LAG_HAS_INVARIANTS
    status = lag_outputs(&fmu->sys, fmu->t, fmu->y, fmu->out, inv);
#else
    status = lag_outputs(&fmu->sys, fmu->t, fmu->y, fmu->out);
#endif
    if (status != LAG_OK)
        return lag_fmu_failure(fmu, status, 0, fmu->t, fmu->y);
    fmu->fresh |= LAG_FMU_HAVE_OUTPUTS;
    return LAG_FMU_OK;
}
#if LAG_FMU_MODEL_EXCHANGE

/* dy/dt = (q', q'') at (t, y): the accelerations from the mass matrix solve (and the constraints
 * through the same solve, K = [[M, -A^T], [A, 0]]), as every run computes them. */
static int lag_fmu_derivatives(lag_fmu *fmu)
{
    int status;
    if (fmu->fresh & LAG_FMU_HAVE_DERIVATIVES)
        return LAG_FMU_OK;
    lag_fmu_prepare(fmu);
    if ((status = lag_rhs(&fmu->sys, fmu->t, fmu->y, fmu->dydt)) != LAG_OK)
        return lag_fmu_failure(fmu, status, 0, fmu->t, fmu->y);
    fmu->fresh |= LAG_FMU_HAVE_DERIVATIVES;
    return LAG_FMU_OK;
}
#endif

/* fmi2GetReal, fmi3GetFloat64 (one value): outputs and accelerations are computed at (t, y). */
static int lag_fmu_get_real(lag_fmu *fmu, const char *function, unsigned long reference, double *value)
{
    const lag_fmu_variable *variable = lag_fmu_find(reference, LAG_FMU_REAL);
    int status = LAG_FMU_OK;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVALUATED, -1))
        return LAG_FMU_ERROR;
    if (variable == NULL)
        return lag_fmu_bad_reference(fmu, function, reference);
    switch (variable->kind) {
    case LAG_FMU_TIME:
        *value = (double)fmu->t;
        break;
    case LAG_FMU_PARAMETER:
        *value = (double)fmu->sys.par[variable->index];
        break;
    case LAG_FMU_OPTION:
        *value = (double)*lag_fmu_real_option(&fmu->options, variable->index);
        break;
    case LAG_FMU_TOLERANCE:
        *value = fmu->atol_each[variable->index];
        break;
    case LAG_FMU_STATE:
        *value = (double)fmu->y[variable->index];
        break;
    case LAG_FMU_OUTPUT:
        if ((status = lag_fmu_outputs(fmu)) == LAG_FMU_OK)
            *value = (double)fmu->out[variable->index];
        break;
#if LAG_FMU_MODEL_EXCHANGE
    case LAG_FMU_ACCELERATION:
        if ((status = lag_fmu_derivatives(fmu)) == LAG_FMU_OK)
            *value = (double)fmu->dydt[variable->index];
        break;
#endif
#if LAG_HAS_STOP
    case LAG_FMU_INDICATOR:
        *value = (double)lag_stop_function(fmu->sys.par, fmu->t, fmu->y);
        break;
#endif
    default:
        return lag_fmu_bad_reference(fmu, function, reference);
    }
    return status;
}
