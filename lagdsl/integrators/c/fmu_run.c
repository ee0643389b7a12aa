/* An FMU instance's run: initialization, model exchange (the importer integrates dy/dt, the
 * stop condition is its event indicator) and co-simulation (a communication step with the
 * scene's integrator, as lagc run steps: driver.c's loop, its projection and its stop test).
 * Pasted after fmu.c and fmu_values.c, before fmi2.c.
 */

/* The checks of lagc run on what a run begins with: finite parameters and initial values, and
 * (co-simulation) tolerances that can be met. */
static int lag_fmu_check_start(lag_fmu *fmu)
{
    int i;
    for (i = 0; i < LAG_NP; ++i)
        if (!r_isfinite(fmu->sys.par[i]))
            return lag_fmu_error(fmu, "the parameter %s is %g, not a finite number", lag_parameter_names[i],
                                 (double)fmu->sys.par[i]);
    for (i = 0; i < LAG_NY; ++i)
        if (!r_isfinite(fmu->y[i]))
            return lag_fmu_error(fmu, "the initial %s of %s is %g, not a finite number", i < LAG_NQ ? "value" : "velocity",
                                 lag_coordinate_names[i % LAG_NQ], (double)fmu->y[i]);
#if LAG_HAS_TOLERANCES
    if (fmu->kind == LAG_FMU_CS && !(fmu->options.rtol > 0 || fmu->options.atol > 0))
        return lag_fmu_error(fmu, "integrator.rtol and integrator.atol cannot both be 0");
    if (fmu->kind == LAG_FMU_CS && fmu->options.rtol < LAG_RTOL_FLOOR) {
        lag_fmu_log(fmu, LAG_FMU_WARNING, LAG_FMU_LOG_WARNING, "integrator.rtol = %g is below %d eps; raised to %g",
                    (double)fmu->options.rtol, LAG_RTOL_FLOOR_EPS, (double)LAG_RTOL_FLOOR);
        fmu->options.rtol = LAG_RTOL_FLOOR;
    }
#endif
    return LAG_FMU_OK;
}

/* fmi2EnterInitializationMode, fmi3EnterInitializationMode. */
static int lag_fmu_enter_initialization(lag_fmu *fmu, const char *function)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_INSTANTIATED, -1))
        return LAG_FMU_ERROR;
    fmu->mode = LAG_FMU_INITIALIZATION;
    return LAG_FMU_OK;
}

static int lag_fmu_ignore_row(void *context, real t, const real *out)
{
    (void)context;
    (void)t;
    (void)out;
    return 0;
}

/* The atol of each component of y for the stepper (lag_options.atol_each): NULL when every
 * integrator.atol.<component> is 0, else each one's, options.atol where it is 0. */
static const double *lag_fmu_atol_each(lag_fmu *fmu)
{
    int i, named = 0;
    for (i = 0; i < LAG_NY; ++i) {
        named |= fmu->atol_each[i] > 0;
        fmu->atol_used[i] = fmu->atol_each[i] > 0 ? fmu->atol_each[i] : (double)fmu->options.atol;
    }
    return named ? fmu->atol_used : NULL;
}

/* Begin the integration at (t, y) as lag_integrate begins a run: the state projected onto the
 * constraints, the stop condition tested there, the stepper started with the options and a step
 * limit for a run to t_end, the end it never steps beyond. */
static int lag_fmu_begin(lag_fmu *fmu)
{
    lag_options limited = fmu->options;
    long last = lag_last_row(fmu->t, fmu->t_end, LAG_FMU_T_INTERVAL);
    int status;
    memset(&fmu->report, 0, sizeof fmu->report);
    memset(fmu->stepper, 0, sizeof *fmu->stepper);
    fmu->stepper->t = fmu->t;
    memcpy(fmu->stepper->y, fmu->y, sizeof fmu->stepper->y);
    limited.max_steps = fmu->step_limit = lag_step_limit(&fmu->options, fmu->t, fmu->t_end, last);
    limited.atol_each = lag_fmu_atol_each(fmu);
    lag_fmu_prepare(fmu);
    fmu->fresh = 0;
    status = lag_start(&fmu->sys, fmu->t, fmu->y, &fmu->e_old, &last, lag_fmu_ignore_row, NULL, &fmu->report);
    if (status == LAG_OK)
        status = lag_stepper_init(fmu->stepper, &fmu->sys, fmu->t, fmu->y, fmu->t_end, &limited);
    if (status != LAG_OK)
        return lag_fmu_failure(fmu, status, limited.max_steps, fmu->t, fmu->y);
    fmu->restart = 0;
#if LAG_HAS_STOP
    if ((fmu->terminated = fmu->report.stopped))
        lag_fmu_log(fmu, LAG_FMU_OK, LAG_FMU_LOG_EVENTS, "the stop condition %s holds at the start, t = %.17g",
                    LAG_FMU_STOP_TEXT, (double)fmu->t);
#endif
    return LAG_FMU_OK;
}

/* Begin again where the run stands, to step to tk: after a parameter changed, or beyond the end
 * the stepper was given (no stop time was defined; the run goes on for the scene's span more). */
static int lag_fmu_restart(lag_fmu *fmu, real tk)
{
    fmu->t_end = r_fmax(fmu->t_end, r_fmax(tk, fmu->t + (LAG_FMU_T_STOP - LAG_FMU_T_START)));
    lag_fmu_log(fmu, LAG_FMU_OK, LAG_FMU_LOG_EVENTS, "the integrator begins again at t = %.17g (%s)", (double)fmu->t,
                fmu->restart ? "a parameter changed" : "beyond the stop time it was given");
    return lag_fmu_begin(fmu);
}

/* fmi2DoStep, fmi3DoStep: from t (where the FMU stands) to t + h, or to where the stop condition
 * ends the run (*stopped, at *reached). The integrator steps as in lagc run, over the
 * communication points; the state at one is the stepper's, or its dense output projected onto
 * the constraints: on the grid of lagc run, the rows of lagc run. */
static int lag_fmu_do_step(lag_fmu *fmu, const char *function, double t, double h, int *stopped, double *reached)
{
    real tk = t + h, y[LAG_NY];
    int status = LAG_OK;
    *stopped = 0;
    *reached = fmu->t;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_STEP, LAG_FMU_CS))
        return LAG_FMU_ERROR;
    if (!(h > 0) || !r_isfinite(tk) || r_fabs(t - fmu->t) > 64 * REAL_EPSILON * r_fmax(r_fabs(t), h))
        return lag_fmu_error(fmu, "%s from %.17g by %.17g: the FMU stands at t = %.17g, and a step must be finite "
                             "and positive", function, t, h, (double)fmu->t);
    if (fmu->terminated)
        return lag_fmu_error(fmu, "%s: the stop condition %s ended the run at t = %.17g", function,
                             LAG_FMU_STOP_TEXT, (double)fmu->t);
    if (fmu->stop_defined && tk > fmu->t_stop) {
        if (tk - fmu->t_stop > LAG_GRID_SLACK * h)
            return lag_fmu_error(fmu, "%s to %.17g: beyond the experiment's stop time %.17g", function, (double)tk,
                                 (double)fmu->t_stop);
        tk = fmu->t_stop;      /* a communication point within rounding of the stop time is the stop time */
    }
    if (fmu->restart || tk > fmu->t_end)
        if ((status = lag_fmu_restart(fmu, tk)) != LAG_FMU_OK)
            return status;
    status = lag_advance(&fmu->sys, fmu->stepper, tk, &fmu->e_old, &fmu->report);
#if LAG_HAS_STOP
    if (status == LAG_OK && fmu->report.stopped && fmu->report.t_stop <= tk) {
        tk = fmu->report.t_stop;
        *stopped = fmu->terminated = 1;
        lag_fmu_log(fmu, LAG_FMU_OK, LAG_FMU_LOG_EVENTS, "the stop condition %s holds from t = %.17g",
                    LAG_FMU_STOP_TEXT, (double)tk);
    }
#endif
    if (status == LAG_OK)
        status = lag_state_at(&fmu->sys, fmu->stepper, tk, y);
    if (status != LAG_OK)
        return lag_fmu_failure(fmu, status, fmu->step_limit, fmu->stepper->t, fmu->stepper->y);
    memcpy(fmu->y, y, sizeof y);
    fmu->t = *reached = tk;
    fmu->fresh = 0;
    return LAG_FMU_OK;
}

/* fmi2ExitInitializationMode, fmi3ExitInitializationMode: the run begins. In model exchange the
 * state is projected onto the constraints and the instance enters event mode; in co-simulation
 * the integration begins (lag_fmu_begin) and the instance enters step mode. */
static int lag_fmu_exit_initialization(lag_fmu *fmu, const char *function)
{
    int status;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_INITIALIZATION, -1))
        return LAG_FMU_ERROR;
    if ((status = lag_fmu_check_start(fmu)) != LAG_FMU_OK)
        return status;
    if (fmu->kind == LAG_FMU_CS) {
        fmu->t_end = fmu->t_stop;
        if ((status = lag_fmu_begin(fmu)) == LAG_FMU_OK)
            fmu->mode = LAG_FMU_STEP;
        return status;
    }
#if LAG_HAS_CONSTRAINTS
    {
        real moved;
        if ((status = lag_project(&fmu->sys, fmu->t, fmu->y, &moved)) != LAG_OK)
            return lag_fmu_error(fmu, "the initial state cannot be projected onto the constraints at t = %.17g: %s",
                                 (double)fmu->t, lag_status_remedy(status));
        fmu->fresh = 0;
    }
#endif
    fmu->mode = LAG_FMU_EVENT;
    return LAG_FMU_OK;
}

/* fmi2Terminate, fmi3Terminate. */
static int lag_fmu_terminate(lag_fmu *fmu, const char *function)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVENT | LAG_FMU_CONTINUOUS | LAG_FMU_STEP, -1))
        return LAG_FMU_ERROR;
    fmu->mode = LAG_FMU_TERMINATED;
    return LAG_FMU_OK;
}

/* ---- model exchange ---- */

/* The number of event indicators: the stop condition's. */
#define LAG_FMU_NINDICATORS LAG_HAS_STOP

/* fmi2SetTime, fmi3SetTime. */
static int lag_fmu_set_time(lag_fmu *fmu, const char *function, double t)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVENT | LAG_FMU_CONTINUOUS, LAG_FMU_ME))
        return LAG_FMU_ERROR;
    if (!r_isfinite(t))
        return lag_fmu_error(fmu, "%s: the time must be a finite number, got %g", function, t);
    fmu->t = t;
    fmu->fresh = 0;
    return LAG_FMU_OK;
}

/* fmi2SetContinuousStates, fmi3SetContinuousStates: y = (q, q'). */
static int lag_fmu_set_states(lag_fmu *fmu, const char *function, const double *x, size_t count)
{
    int i;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_CONTINUOUS, LAG_FMU_ME)
        || lag_fmu_count(fmu, function, x, count, LAG_NY) != LAG_FMU_OK)
        return LAG_FMU_ERROR;
    for (i = 0; i < LAG_NY; ++i)
        fmu->y[i] = x[i];
    fmu->fresh = 0;
    return LAG_FMU_OK;
}

/* fmi2GetContinuousStates, fmi3GetContinuousStates; with `nominal`, the nominals (all 1). */
static int lag_fmu_get_states(lag_fmu *fmu, const char *function, double *x, size_t count, int nominal)
{
    int i;
    if (!lag_fmu_allowed(fmu, function, nominal ? LAG_FMU_ANY_MODE : LAG_FMU_EVALUATED, LAG_FMU_ME)
        || lag_fmu_count(fmu, function, x, count, LAG_NY) != LAG_FMU_OK)
        return LAG_FMU_ERROR;
    for (i = 0; i < LAG_NY; ++i)
        x[i] = nominal ? 1.0 : (double)fmu->y[i];
    return LAG_FMU_OK;
}

/* fmi2GetDerivatives, fmi3GetContinuousStateDerivatives: dy/dt = (q', q''). */
static int lag_fmu_get_derivatives(lag_fmu *fmu, const char *function, double *dx, size_t count)
{
    int i, status = LAG_FMU_ERROR;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVALUATED, LAG_FMU_ME)
        || lag_fmu_count(fmu, function, dx, count, LAG_NY) != LAG_FMU_OK)
        return LAG_FMU_ERROR;
#if LAG_FMU_MODEL_EXCHANGE
    if ((status = lag_fmu_derivatives(fmu)) == LAG_FMU_OK)
        for (i = 0; i < LAG_NY; ++i)
            dx[i] = (double)fmu->dydt[i];
#else
    for (i = 0; i < LAG_NY; ++i)    /* unreachable: no instance is for model exchange */
        dx[i] = 0;
#endif
    return status;
}

/* fmi2GetEventIndicators, fmi3GetEventIndicators: the stop function, negative where it holds. */
static int lag_fmu_get_indicators(lag_fmu *fmu, const char *function, double *z, size_t count)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVALUATED, LAG_FMU_ME)
        || lag_fmu_count(fmu, function, z, count, LAG_FMU_NINDICATORS) != LAG_FMU_OK)
        return LAG_FMU_ERROR;
#if LAG_HAS_STOP
    z[0] = (double)lag_stop_function(fmu->sys.par, fmu->t, fmu->y);
#else
    (void)z;
#endif
    return LAG_FMU_OK;
}

/* fmi2EnterEventMode, fmi3EnterEventMode (model exchange): from continuous time, as after the
 * event indicator crossed zero. */
static int lag_fmu_enter_event_mode(lag_fmu *fmu, const char *function)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_CONTINUOUS, LAG_FMU_ME))
        return LAG_FMU_ERROR;
    fmu->mode = LAG_FMU_EVENT;
    fmu->crossed = 1;
    return LAG_FMU_OK;
}

/* fmi2NewDiscreteStates, fmi3UpdateDiscreteStates: the model has no discrete states; the only
 * event is the stop condition, which asks the importer to end the simulation (*terminate): where
 * it holds, as at the start of lagc run (e < 0), or where the indicator has crossed zero. */
static int lag_fmu_update_discrete(lag_fmu *fmu, const char *function, int *terminate)
{
    *terminate = 0;
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVENT, LAG_FMU_ME))
        return LAG_FMU_ERROR;
#if LAG_HAS_STOP
    {
        real e = lag_stop_function(fmu->sys.par, fmu->t, fmu->y);
        if (e < 0 || (e <= 0 && fmu->crossed)) {
            *terminate = 1;
            lag_fmu_log(fmu, LAG_FMU_OK, LAG_FMU_LOG_EVENTS, "the stop condition %s holds at t = %.17g",
                        LAG_FMU_STOP_TEXT, (double)fmu->t);
        }
    }
#endif
    return LAG_FMU_OK;
}

/* fmi2EnterContinuousTimeMode, fmi3EnterContinuousTimeMode. */
static int lag_fmu_enter_continuous(lag_fmu *fmu, const char *function)
{
    if (!lag_fmu_allowed(fmu, function, LAG_FMU_EVENT, LAG_FMU_ME))
        return LAG_FMU_ERROR;
    fmu->mode = LAG_FMU_CONTINUOUS;
    fmu->crossed = 0;
    return LAG_FMU_OK;
}

/* fmi2CompletedIntegratorStep, fmi3CompletedIntegratorStep: nothing to do (no step events; the
 * importer's state is not projected onto the constraints, so their residual drifts with its
 * error, docs/language.md). */
static int lag_fmu_completed_step(lag_fmu *fmu, const char *function)
{
    return lag_fmu_allowed(fmu, function, LAG_FMU_CONTINUOUS, LAG_FMU_ME) ? LAG_FMU_OK : LAG_FMU_ERROR;
}
