/* The entry points of FMI 3.0 that run an instance: model exchange (the importer integrates the
 * derivatives; the stop condition is the event indicator) and co-simulation (fmi3DoStep with the
 * scene's integrator; the stop condition ends a step early). Pasted after fmi3.c.
 */

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_unsupported(instance, "fmi3EnterConfigurationMode",
                                                              "structural parameters");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_unsupported(instance, "fmi3ExitConfigurationMode",
                                                              "structural parameters");
}

/* No discrete states: nothing to evaluate, in the modes FMI 3.0 allows it. */
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    if (instance == NULL)
        return fmi3Error;
    return lag_fmu_allowed(instance, "fmi3EvaluateDiscreteStates", LAG_FMU_INITIALIZATION | LAG_FMU_EVENT, -1)
               ? fmi3OK : fmi3Error;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    int terminate, status;
    if (instance == NULL)
        return fmi3Error;
    if (discreteStatesNeedUpdate == NULL || terminateSimulation == NULL || nominalsOfContinuousStatesChanged == NULL
        || valuesOfContinuousStatesChanged == NULL || nextEventTimeDefined == NULL || nextEventTime == NULL)
        return (fmi3Status)lag_fmu_count(instance, "fmi3UpdateDiscreteStates", NULL, 1, 1);
    status = lag_fmu_update_discrete(instance, "fmi3UpdateDiscreteStates", &terminate);
    *discreteStatesNeedUpdate = *nominalsOfContinuousStatesChanged = *valuesOfContinuousStatesChanged = false;
    *nextEventTimeDefined = false;
    *nextEventTime = 0;
    *terminateSimulation = terminate != 0;
    return (fmi3Status)status;
}

/* ---- model exchange ---- */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_enter_continuous(instance, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (instance == NULL)
        return fmi3Error;
    if (enterEventMode == NULL || terminateSimulation == NULL)
        return (fmi3Status)lag_fmu_count(instance, "fmi3CompletedIntegratorStep", NULL, 1, 1);
    *enterEventMode = *terminateSimulation = false;
    return (fmi3Status)lag_fmu_completed_step(instance, "fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    return instance == NULL ? fmi3Error : (fmi3Status)lag_fmu_set_time(instance, "fmi3SetTime", time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_set_states(instance, "fmi3SetContinuousStates", continuousStates,
                                                             nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_get_derivatives(instance, "fmi3GetContinuousStateDerivatives",
                                                                  derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_get_indicators(instance, "fmi3GetEventIndicators", eventIndicators,
                                                                 nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_get_states(instance, "fmi3GetContinuousStates", continuousStates,
                                                             nContinuousStates, 0);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_get_states(instance, "fmi3GetNominalsOfContinuousStates", nominals,
                                                             nContinuousStates, 1);
}

/* The numbers of event indicators and of states, which do not depend on the parameters. */
static fmi3Status lag_fmi3_number(fmi3Instance instance, const char *function, size_t *number, size_t value)
{
    if (instance == NULL)
        return fmi3Error;
    if (!lag_fmu_allowed(instance, function, LAG_FMU_ANY_MODE, LAG_FMU_ME))
        return fmi3Error;
    if (number == NULL)
        return (fmi3Status)lag_fmu_count(instance, function, NULL, 1, 1);
    *number = value;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    return lag_fmi3_number(instance, "fmi3GetNumberOfEventIndicators", nEventIndicators, LAG_FMU_NINDICATORS);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    return lag_fmi3_number(instance, "fmi3GetNumberOfContinuousStates", nContinuousStates, LAG_NY);
}

/* ---- co-simulation ---- */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error : (fmi3Status)lag_fmu_unsupported(instance, "fmi3EnterStepMode", "hasEventMode");
}

/* A step cut short by the stop condition asks to terminate the simulation, the FMU standing at
 * *lastSuccessfulTime, where the condition began to hold; that is an early return
 * (*earlyReturn) if the importer allowed one at instantiation (FMI 3.0, section 4.2.5). */
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    int stopped, status;
    double reached;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (instance == NULL)
        return fmi3Error;
    if (eventHandlingNeeded == NULL || terminateSimulation == NULL || earlyReturn == NULL || lastSuccessfulTime == NULL)
        return (fmi3Status)lag_fmu_count(instance, "fmi3DoStep", NULL, 1, 1);
    status = lag_fmu_do_step(instance, "fmi3DoStep", currentCommunicationPoint, communicationStepSize, &stopped,
                             &reached);
    *eventHandlingNeeded = false;
    *terminateSimulation = stopped != 0;
    *earlyReturn = stopped && ((lag_fmi3 *)instance)->early_return;
    *lastSuccessfulTime = reached;
    return (fmi3Status)status;
}
