/* The entry points of FMI 2.0 for model exchange and co-simulation, over the instance of fmu.c
 * and fmu_run.c. The FMI headers are the Modelica Association's (vendored in
 * lagdsl/integrators/c/third_party/fmi/, shipped in the FMU's sources/). Every function returns fmi2Error for
 * a NULL instance, and through lag_fmu_error for a call in the wrong mode or with a bad value
 * reference (the instance then enters the error mode: only getters, reset and free remain).
 */
#include "fmi2Functions.h"

typedef struct lag_fmi2 {
    lag_fmu fmu;                            /* first: an fmi2Component is a lag_fmu */
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment environment;
} lag_fmi2;

/* FMI 2's logger reads the message as a printf format: its '%' are doubled. */
static void lag_fmi2_log(const lag_fmu *fmu, int status, const char *category, const char *message)
{
    const lag_fmi2 *instance = (const lag_fmi2 *)fmu;
    char escaped[4096];
    size_t i, j = 0;
    for (i = 0; message[i] != '\0' && j + 2 < sizeof escaped; ++i) {
        if (message[i] == '%')
            escaped[j++] = '%';
        escaped[j++] = message[i];
    }
    escaped[j] = '\0';
    instance->logger(instance->environment, fmu->name, (fmi2Status)status, category, escaped);
}

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    if (c == NULL)
        return fmi2Error;
    if (nCategories > 0 && categories == NULL)
        return (fmi2Status)lag_fmu_arrays(c, "fmi2SetDebugLogging", categories, categories, nCategories);
    return (fmi2Status)lag_fmu_set_logging(c, loggingOn, nCategories, categories);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    int kind = fmuType == fmi2ModelExchange ? LAG_FMU_ME : fmuType == fmi2CoSimulation ? LAG_FMU_CS : -1;
    const char *refusal = kind < 0 ? "the FMU type is neither model exchange nor co-simulation"
                                   : lag_fmu_refusal(instanceName, fmuGUID, kind);
    lag_fmi2 *instance = NULL;
    (void)fmuResourceLocation;
    (void)visible;
    if (functions == NULL)
        return NULL;
    if (refusal == NULL && (instance = (lag_fmi2 *)lag_fmu_create(sizeof *instance, instanceName, kind, loggingOn)) == NULL)
        refusal = "out of memory";
    if (refusal != NULL) {
        if (functions->logger != NULL)
            functions->logger(functions->componentEnvironment, instanceName != NULL ? instanceName : "", fmi2Error,
                              "logStatusError", refusal);
        return NULL;
    }
    instance->logger = functions->logger;
    instance->environment = functions->componentEnvironment;
    instance->fmu.logger = functions->logger != NULL ? lag_fmi2_log : NULL;
    return instance;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (c != NULL)
        lag_fmu_free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    if (c == NULL)
        return fmi2Error;
    if (!lag_fmu_allowed(c, "fmi2SetupExperiment", LAG_FMU_INSTANTIATED, -1))
        return fmi2Error;
    return (fmi2Status)lag_fmu_setup(c, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_enter_initialization(c, "fmi2EnterInitializationMode");
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_exit_initialization(c, "fmi2ExitInitializationMode");
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_terminate(c, "fmi2Terminate");
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (c == NULL)
        return fmi2Error;
    lag_fmu_defaults(c);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    size_t i;
    int status;
    if (c == NULL)
        return fmi2Error;
    status = lag_fmu_arrays(c, "fmi2GetReal", vr, value, nvr);
    for (i = 0; i < nvr && status == LAG_FMU_OK; ++i)
        status = lag_fmu_get_real(c, "fmi2GetReal", vr[i], &value[i]);
    return (fmi2Status)status;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    size_t i;
    int status;
    long number = 0;
    if (c == NULL)
        return fmi2Error;
    status = lag_fmu_arrays(c, "fmi2GetInteger", vr, value, nvr);
    for (i = 0; i < nvr && status == LAG_FMU_OK; ++i)
        if ((status = lag_fmu_get_integer(c, "fmi2GetInteger", vr[i], &number)) == LAG_FMU_OK)
            value[i] = (fmi2Integer)number;
    return (fmi2Status)status;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    (void)value;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_no_variables(c, "fmi2GetBoolean", vr, nvr);
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    (void)value;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_no_variables(c, "fmi2GetString", vr, nvr);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    size_t i;
    int status;
    if (c == NULL)
        return fmi2Error;
    status = lag_fmu_arrays(c, "fmi2SetReal", vr, value, nvr);
    for (i = 0; i < nvr && status == LAG_FMU_OK; ++i)
        status = lag_fmu_set_real(c, "fmi2SetReal", vr[i], value[i]);
    return (fmi2Status)status;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    size_t i;
    int status;
    if (c == NULL)
        return fmi2Error;
    status = lag_fmu_arrays(c, "fmi2SetInteger", vr, value, nvr);
    for (i = 0; i < nvr && status == LAG_FMU_OK; ++i)
        status = lag_fmu_set_integer(c, "fmi2SetInteger", vr[i], value[i]);
    return (fmi2Status)status;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    (void)value;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_no_variables(c, "fmi2SetBoolean", vr, nvr);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    (void)value;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_no_variables(c, "fmi2SetString", vr, nvr);
}

/* ---- what this FMU does not support (canGetAndSetFMUstate, providesDirectionalDerivative,
 * canInterpolateInputs, maxOutputDerivativeOrder and canRunAsynchronuously are false or 0) ---- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_unsupported(c, "fmi2GetFMUstate", "canGetAndSetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    (void)FMUstate;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_unsupported(c, "fmi2SetFMUstate", "canGetAndSetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    (void)FMUstate;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_unsupported(c, "fmi2FreeFMUstate", "canGetAndSetFMUstate");
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    (void)FMUstate;
    (void)size;
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_unsupported(c, "fmi2SerializedFMUstateSize", "canSerializeFMUstate");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size)
{
    (void)FMUstate;
    (void)serializedState;
    (void)size;
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_unsupported(c, "fmi2SerializeFMUstate", "canSerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    (void)serializedState;
    (void)size;
    (void)FMUstate;
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_unsupported(c, "fmi2DeSerializeFMUstate", "canSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_unsupported(c, "fmi2GetDirectionalDerivative",
                                                       "providesDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_unsupported(c, "fmi2SetRealInputDerivatives", "canInterpolateInputs");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_unsupported(c, "fmi2GetRealOutputDerivatives", "maxOutputDerivativeOrder");
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_unsupported(c, "fmi2CancelStep", "canRunAsynchronuously");
}

/* ---- model exchange ---- */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_enter_event_mode(c, "fmi2EnterEventMode");
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *fmi2eventInfo)
{
    int terminate, status;
    if (c == NULL)
        return fmi2Error;
    if (fmi2eventInfo == NULL)
        return (fmi2Status)lag_fmu_count(c, "fmi2NewDiscreteStates", fmi2eventInfo, 1, 1);
    status = lag_fmu_update_discrete(c, "fmi2NewDiscreteStates", &terminate);
    fmi2eventInfo->newDiscreteStatesNeeded = fmi2False;
    fmi2eventInfo->terminateSimulation = terminate ? fmi2True : fmi2False;
    fmi2eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    fmi2eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    fmi2eventInfo->nextEventTimeDefined = fmi2False;
    fmi2eventInfo->nextEventTime = 0;
    return (fmi2Status)status;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_enter_continuous(c, "fmi2EnterContinuousTimeMode");
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c == NULL)
        return fmi2Error;
    if (enterEventMode == NULL || terminateSimulation == NULL)
        return (fmi2Status)lag_fmu_count(c, "fmi2CompletedIntegratorStep", NULL, 1, 1);
    *enterEventMode = *terminateSimulation = fmi2False;
    return (fmi2Status)lag_fmu_completed_step(c, "fmi2CompletedIntegratorStep");
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_set_time(c, "fmi2SetTime", time);
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_set_states(c, "fmi2SetContinuousStates", x, nx);
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_get_derivatives(c, "fmi2GetDerivatives", derivatives, nx);
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_get_indicators(c, "fmi2GetEventIndicators", eventIndicators, ni);
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    return c == NULL ? fmi2Error : (fmi2Status)lag_fmu_get_states(c, "fmi2GetContinuousStates", x, nx, 0);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    return c == NULL ? fmi2Error
                     : (fmi2Status)lag_fmu_get_states(c, "fmi2GetNominalsOfContinuousStates", x_nominal, nx, 1);
}

/* ---- co-simulation ---- */

/* A step cut short by the stop condition is fmi2Discard, with fmi2Terminated true and
 * fmi2LastSuccessfulTime the time where the condition began to hold (FMI 2.0, 4.2.2). */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    int stopped, status;
    double reached;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (c == NULL)
        return fmi2Error;
    status = lag_fmu_do_step(c, "fmi2DoStep", currentCommunicationPoint, communicationStepSize, &stopped, &reached);
    return status == LAG_FMU_OK && stopped ? fmi2Discard : (fmi2Status)status;
}

/* The statuses a co-simulation instance can report: fmi2LastSuccessfulTime and fmi2Terminated;
 * the others are about asynchronous steps (fmi2Pending), which it never takes: fmi2Discard. */
static fmi2Status lag_fmi2_status(fmi2Component c, const char *function, fmi2StatusKind s, int known,
                                  const void *value)
{
    if (c == NULL)
        return fmi2Error;
    if (!lag_fmu_allowed(c, function, LAG_FMU_EVALUATED, LAG_FMU_CS))
        return fmi2Error;
    if (value == NULL)
        return (fmi2Status)lag_fmu_count(c, function, value, 1, 1);
    return (int)s == known ? fmi2OK : fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    return lag_fmi2_status(c, "fmi2GetStatus", s, -1, value);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    fmi2Status status = lag_fmi2_status(c, "fmi2GetRealStatus", s, fmi2LastSuccessfulTime, value);
    if (status == fmi2OK)
        *value = (double)((lag_fmu *)c)->t;
    return status;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    return lag_fmi2_status(c, "fmi2GetIntegerStatus", s, -1, value);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    fmi2Status status = lag_fmi2_status(c, "fmi2GetBooleanStatus", s, fmi2Terminated, value);
    if (status == fmi2OK)
        *value = ((lag_fmu *)c)->terminated ? fmi2True : fmi2False;    /* the stop condition ended the run */
    return status;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    return lag_fmi2_status(c, "fmi2GetStringStatus", s, -1, value);
}
