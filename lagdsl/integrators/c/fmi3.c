/* The entry points of FMI 3.0 for model exchange and co-simulation, over the instance of fmu.c,
 * fmu_values.c and fmu_run.c. The FMI headers are the Modelica Association's (vendored in
 * lagdsl/integrators/c/third_party/fmi/, shipped in the FMU's sources/). Every function returns fmi3Error
 * for a NULL instance, and through lag_fmu_error for a call in the wrong mode or with a bad
 * value reference (the instance then enters the error mode: only getters, reset and free
 * remain). The variables are Float64 and Int32 scalars; the getters and setters of the other
 * types have no variable to reach, and what the modelDescription.xml does not claim (event mode
 * in co-simulation, scheduled execution, clocks, FMU states, partial derivatives, dependencies,
 * configuration mode) is refused.
 */
#include "fmi3Functions.h"

typedef struct lag_fmi3 {
    lag_fmu fmu;                            /* first: an fmi3Instance is a lag_fmu */
    fmi3LogMessageCallback logger;
    fmi3InstanceEnvironment environment;
    int early_return;                       /* the importer allows fmi3DoStep to return early */
} lag_fmi3;

static void lag_fmi3_log(const lag_fmu *fmu, int status, const char *category, const char *message)
{
    const lag_fmi3 *instance = (const lag_fmi3 *)fmu;
    instance->logger(instance->environment, (fmi3Status)status, category, message);
}

/* An instance of `kind`, or NULL with the reason given to the logger. */
static fmi3Instance lag_fmi3_instantiate(fmi3String name, fmi3String token, int kind, fmi3Boolean loggingOn,
                                         fmi3InstanceEnvironment environment, fmi3LogMessageCallback logger)
{
    const char *refusal = lag_fmu_refusal(name, token, kind);
    lag_fmi3 *instance = NULL;
    if (refusal == NULL && (instance = (lag_fmi3 *)lag_fmu_create(sizeof *instance, name, kind, loggingOn)) == NULL)
        refusal = "out of memory";
    if (refusal != NULL) {
        if (logger != NULL)
            logger(environment, fmi3Error, "logStatusError", refusal);
        return NULL;
    }
    instance->logger = logger;
    instance->environment = environment;
    instance->fmu.logger = logger != NULL ? lag_fmi3_log : NULL;
    return instance;
}

/* The values of a get or a set: one a value reference (the variables are scalars). */
static int lag_fmi3_values(fmi3Instance instance, const char *function, size_t nValueReferences, size_t nValues)
{
    return lag_fmu_count(instance, function, "", nValues, nValueReferences);
}

/* A getter and a setter of a type without variables: any value reference is a bad one. */
#define LAG_FMI3_NO_VARIABLES(type, get, set)                                                                     \
    fmi3Status get(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,    \
                   type values[], size_t nValues)                                                                 \
    {                                                                                                             \
        (void)values;                                                                                             \
        (void)nValues;                                                                                            \
        return instance == NULL ? fmi3Error                                                                       \
                                : (fmi3Status)lag_fmu_no_variables(instance, #get, valueReferences, nValueReferences); \
    }                                                                                                             \
    fmi3Status set(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,    \
                   const type values[], size_t nValues)                                                           \
    {                                                                                                             \
        (void)values;                                                                                             \
        (void)nValues;                                                                                            \
        return instance == NULL ? fmi3Error                                                                       \
                                : (fmi3Status)lag_fmu_no_variables(instance, #set, valueReferences, nValueReferences); \
    }

/* A function for a capability this FMU does not have: its parameters (the instance first), and
 * the statements that mark the others unused. */
#define LAG_FMI3_UNSUPPORTED(function, capability, parameters, unused)                                            \
    fmi3Status function parameters                                                                                \
    {                                                                                                             \
        unused                                                                                                    \
        return instance == NULL ? fmi3Error : (fmi3Status)lag_fmu_unsupported(instance, #function, capability);  \
    }

const char *fmi3GetVersion(void)
{
    return fmi3Version;
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    if (instance == NULL)
        return fmi3Error;
    if (nCategories > 0 && categories == NULL)
        return (fmi3Status)lag_fmu_arrays(instance, "fmi3SetDebugLogging", categories, categories, nCategories);
    return (fmi3Status)lag_fmu_set_logging(instance, loggingOn, nCategories, categories);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)resourcePath;
    (void)visible;
    return lag_fmi3_instantiate(instanceName, instantiationToken, LAG_FMU_ME, loggingOn, instanceEnvironment,
                                logMessage);
}

/* Without event mode (hasEventMode is false: eventModeUsed is not honoured) or intermediate
 * updates; an early return is the stop condition's, where the importer allows it. */
fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    fmi3Instance instance;
    (void)resourcePath;
    (void)visible;
    (void)eventModeUsed;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    instance = lag_fmi3_instantiate(instanceName, instantiationToken, LAG_FMU_CS, loggingOn, instanceEnvironment,
                                    logMessage);
    if (instance != NULL)
        ((lag_fmi3 *)instance)->early_return = earlyReturnAllowed;
    return instance;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage != NULL)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "this FMU is for model exchange and co-simulation, not scheduled execution");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    if (instance != NULL)
        lag_fmu_free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    int status;
    if (instance == NULL)
        return fmi3Error;
    if (!lag_fmu_allowed(instance, "fmi3EnterInitializationMode", LAG_FMU_INSTANTIATED, -1))
        return fmi3Error;
    status = lag_fmu_setup(instance, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime);
    return status != LAG_FMU_OK ? (fmi3Status)status
                                : (fmi3Status)lag_fmu_enter_initialization(instance, "fmi3EnterInitializationMode");
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_exit_initialization(instance, "fmi3ExitInitializationMode");
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error : (fmi3Status)lag_fmu_enter_event_mode(instance, "fmi3EnterEventMode");
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    return instance == NULL ? fmi3Error : (fmi3Status)lag_fmu_terminate(instance, "fmi3Terminate");
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (instance == NULL)
        return fmi3Error;
    lag_fmu_defaults(instance);
    return fmi3OK;
}

/* ---- variables: Float64 and Int32 ---- */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues)
{
    size_t i;
    int status;
    if (instance == NULL)
        return fmi3Error;
    status = lag_fmi3_values(instance, "fmi3GetFloat64", nValueReferences, nValues);
    if (status == LAG_FMU_OK)
        status = lag_fmu_arrays(instance, "fmi3GetFloat64", valueReferences, values, nValueReferences);
    for (i = 0; i < nValueReferences && status == LAG_FMU_OK; ++i)
        status = lag_fmu_get_real(instance, "fmi3GetFloat64", valueReferences[i], &values[i]);
    return (fmi3Status)status;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues)
{
    size_t i;
    int status;
    if (instance == NULL)
        return fmi3Error;
    status = lag_fmi3_values(instance, "fmi3SetFloat64", nValueReferences, nValues);
    if (status == LAG_FMU_OK)
        status = lag_fmu_arrays(instance, "fmi3SetFloat64", valueReferences, values, nValueReferences);
    for (i = 0; i < nValueReferences && status == LAG_FMU_OK; ++i)
        status = lag_fmu_set_real(instance, "fmi3SetFloat64", valueReferences[i], values[i]);
    return (fmi3Status)status;
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Int32 values[], size_t nValues)
{
    size_t i;
    int status;
    long number = 0;
    if (instance == NULL)
        return fmi3Error;
    status = lag_fmi3_values(instance, "fmi3GetInt32", nValueReferences, nValues);
    if (status == LAG_FMU_OK)
        status = lag_fmu_arrays(instance, "fmi3GetInt32", valueReferences, values, nValueReferences);
    for (i = 0; i < nValueReferences && status == LAG_FMU_OK; ++i)
        if ((status = lag_fmu_get_integer(instance, "fmi3GetInt32", valueReferences[i], &number)) == LAG_FMU_OK)
            values[i] = (fmi3Int32)number;
    return (fmi3Status)status;
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Int32 values[], size_t nValues)
{
    size_t i;
    int status;
    if (instance == NULL)
        return fmi3Error;
    status = lag_fmi3_values(instance, "fmi3SetInt32", nValueReferences, nValues);
    if (status == LAG_FMU_OK)
        status = lag_fmu_arrays(instance, "fmi3SetInt32", valueReferences, values, nValueReferences);
    for (i = 0; i < nValueReferences && status == LAG_FMU_OK; ++i)
        status = lag_fmu_set_integer(instance, "fmi3SetInt32", valueReferences[i], values[i]);
    return (fmi3Status)status;
}

LAG_FMI3_NO_VARIABLES(fmi3Float32, fmi3GetFloat32, fmi3SetFloat32)
LAG_FMI3_NO_VARIABLES(fmi3Int8, fmi3GetInt8, fmi3SetInt8)
LAG_FMI3_NO_VARIABLES(fmi3UInt8, fmi3GetUInt8, fmi3SetUInt8)
LAG_FMI3_NO_VARIABLES(fmi3Int16, fmi3GetInt16, fmi3SetInt16)
LAG_FMI3_NO_VARIABLES(fmi3UInt16, fmi3GetUInt16, fmi3SetUInt16)
LAG_FMI3_NO_VARIABLES(fmi3UInt32, fmi3GetUInt32, fmi3SetUInt32)
LAG_FMI3_NO_VARIABLES(fmi3Int64, fmi3GetInt64, fmi3SetInt64)
LAG_FMI3_NO_VARIABLES(fmi3UInt64, fmi3GetUInt64, fmi3SetUInt64)
LAG_FMI3_NO_VARIABLES(fmi3Boolean, fmi3GetBoolean, fmi3SetBoolean)
LAG_FMI3_NO_VARIABLES(fmi3String, fmi3GetString, fmi3SetString)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues)
{
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_no_variables(instance, "fmi3GetBinary", valueReferences,
                                                               nValueReferences);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues)
{
    (void)valueSizes;
    (void)values;
    (void)nValues;
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_no_variables(instance, "fmi3SetBinary", valueReferences,
                                                               nValueReferences);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[])
{
    (void)values;
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_no_variables(instance, "fmi3GetClock", valueReferences,
                                                               nValueReferences);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[])
{
    (void)values;
    return instance == NULL ? fmi3Error
                            : (fmi3Status)lag_fmu_no_variables(instance, "fmi3SetClock", valueReferences,
                                                               nValueReferences);
}

/* ---- what this FMU does not support ---- */

LAG_FMI3_UNSUPPORTED(fmi3GetNumberOfVariableDependencies, "dependencies",
                     (fmi3Instance instance, fmi3ValueReference valueReference, size_t *nDependencies),
                     (void)valueReference; (void)nDependencies;)
LAG_FMI3_UNSUPPORTED(fmi3GetVariableDependencies, "dependencies",
                     (fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[],
                      fmi3ValueReference independents[], size_t elementIndicesOfIndependents[],
                      fmi3DependencyKind dependencyKinds[], size_t nDependencies),
                     (void)dependent; (void)elementIndicesOfDependent; (void)independents;
                     (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)nDependencies;)
LAG_FMI3_UNSUPPORTED(fmi3GetFMUState, "canGetAndSetFMUState",
                     (fmi3Instance instance, fmi3FMUState *FMUState),
                     (void)FMUState;)
LAG_FMI3_UNSUPPORTED(fmi3SetFMUState, "canGetAndSetFMUState",
                     (fmi3Instance instance, fmi3FMUState FMUState),
                     (void)FMUState;)
LAG_FMI3_UNSUPPORTED(fmi3FreeFMUState, "canGetAndSetFMUState",
                     (fmi3Instance instance, fmi3FMUState *FMUState),
                     (void)FMUState;)
LAG_FMI3_UNSUPPORTED(fmi3SerializedFMUStateSize, "canSerializeFMUState",
                     (fmi3Instance instance, fmi3FMUState FMUState, size_t *size),
                     (void)FMUState; (void)size;)
LAG_FMI3_UNSUPPORTED(fmi3SerializeFMUState, "canSerializeFMUState",
                     (fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size),
                     (void)FMUState; (void)serializedState; (void)size;)
LAG_FMI3_UNSUPPORTED(fmi3DeserializeFMUState, "canSerializeFMUState",
                     (fmi3Instance instance, const fmi3Byte serializedState[], size_t size, fmi3FMUState *FMUState),
                     (void)serializedState; (void)size; (void)FMUState;)
LAG_FMI3_UNSUPPORTED(fmi3GetDirectionalDerivative, "providesDirectionalDerivatives",
                     (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                      const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                      fmi3Float64 sensitivity[], size_t nSensitivity),
                     (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
                     (void)sensitivity; (void)nSensitivity;)
LAG_FMI3_UNSUPPORTED(fmi3GetAdjointDerivative, "providesAdjointDerivatives",
                     (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                      const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                      fmi3Float64 sensitivity[], size_t nSensitivity),
                     (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
                     (void)sensitivity; (void)nSensitivity;)
LAG_FMI3_UNSUPPORTED(fmi3GetIntervalDecimal, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]),
                     (void)valueReferences; (void)nValueReferences; (void)intervals; (void)qualifiers;)
LAG_FMI3_UNSUPPORTED(fmi3GetIntervalFraction, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]),
                     (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;
                     (void)qualifiers;)
LAG_FMI3_UNSUPPORTED(fmi3GetShiftDecimal, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      fmi3Float64 shifts[]),
                     (void)valueReferences; (void)nValueReferences; (void)shifts;)
LAG_FMI3_UNSUPPORTED(fmi3GetShiftFraction, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      fmi3UInt64 counters[], fmi3UInt64 resolutions[]),
                     (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;)
LAG_FMI3_UNSUPPORTED(fmi3SetIntervalDecimal, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      const fmi3Float64 intervals[]),
                     (void)valueReferences; (void)nValueReferences; (void)intervals;)
LAG_FMI3_UNSUPPORTED(fmi3SetIntervalFraction, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
                     (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;)
LAG_FMI3_UNSUPPORTED(fmi3SetShiftDecimal, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      const fmi3Float64 shifts[]),
                     (void)valueReferences; (void)nValueReferences; (void)shifts;)
LAG_FMI3_UNSUPPORTED(fmi3SetShiftFraction, "clocks",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
                     (void)valueReferences; (void)nValueReferences; (void)counters; (void)resolutions;)
LAG_FMI3_UNSUPPORTED(fmi3GetOutputDerivatives, "maxOutputDerivativeOrder",
                     (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                      const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues),
                     (void)valueReferences; (void)nValueReferences; (void)orders; (void)values; (void)nValues;)
LAG_FMI3_UNSUPPORTED(fmi3ActivateModelPartition, "scheduled execution",
                     (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime),
                     (void)clockReference; (void)activationTime;)
