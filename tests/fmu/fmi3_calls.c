/* Calls every function an FMI 3.0 FMU of lagdsl exports: each with a NULL instance, then a
 * co-simulation and a model exchange run with calls out of order and bad value references and
 * arrays between them, checking the status of each (tests/fmu/test_fmu_c.py compiles it with the
 * FMU's source under the strict flags and the address and undefined-behaviour sanitizers).
 * Arguments: as fmi2_calls.c's (the instantiation token first).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

static int logged;

static void logger(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)environment;
    ++logged;
    printf("log %d %s: %s\n", (int)status, category, message);
}

#define CHECK(call, expected)                                                               \
    do {                                                                                    \
        fmi3Status got_ = (call);                                                           \
        if (got_ != (expected)) {                                                           \
            printf("failed at line %d: %s returned %d, expected %d\n", __LINE__, #call,     \
                   (int)got_, (int)(expected));                                             \
            exit(1);                                                                        \
        }                                                                                   \
    } while (0)
#define REQUIRE(condition)                                                                  \
    do {                                                                                    \
        if (!(condition)) {                                                                 \
            printf("failed at line %d: %s\n", __LINE__, #condition);                      \
            exit(1);                                                                        \
        }                                                                                   \
    } while (0)

static const char *token;
static fmi3ValueReference parameter, state, output, integer, missing;

/* Every function taking an instance, with NULL: fmi3Error, no crash. */
static void null_instance(void)
{
    fmi3Float64 r = 0;
    fmi3Float32 f = 0;
    fmi3Int8 i8 = 0;
    fmi3UInt8 u8 = 0;
    fmi3Int16 i16 = 0;
    fmi3UInt16 u16 = 0;
    fmi3Int32 i32 = 0;
    fmi3UInt32 u32 = 0;
    fmi3Int64 i64 = 0;
    fmi3UInt64 u64 = 0;
    fmi3Boolean b = false, b2 = false, b3 = false, b4 = false;
    fmi3String s = NULL;
    fmi3Binary binary = NULL;
    fmi3Clock clock = false;
    fmi3Byte byte = 0;
    fmi3FMUState saved = NULL;
    fmi3IntervalQualifier qualifier;
    fmi3DependencyKind dependency;
    size_t n = 0;
    CHECK(fmi3SetDebugLogging(NULL, true, 0, NULL), fmi3Error);
    CHECK(fmi3EnterInitializationMode(NULL, false, 0, 0, false, 0), fmi3Error);
    CHECK(fmi3ExitInitializationMode(NULL), fmi3Error);
    CHECK(fmi3EnterEventMode(NULL), fmi3Error);
    CHECK(fmi3Terminate(NULL), fmi3Error);
    CHECK(fmi3Reset(NULL), fmi3Error);
    CHECK(fmi3GetFloat32(NULL, &missing, 1, &f, 1), fmi3Error);
    CHECK(fmi3GetFloat64(NULL, &output, 1, &r, 1), fmi3Error);
    CHECK(fmi3GetInt8(NULL, &missing, 1, &i8, 1), fmi3Error);
    CHECK(fmi3GetUInt8(NULL, &missing, 1, &u8, 1), fmi3Error);
    CHECK(fmi3GetInt16(NULL, &missing, 1, &i16, 1), fmi3Error);
    CHECK(fmi3GetUInt16(NULL, &missing, 1, &u16, 1), fmi3Error);
    CHECK(fmi3GetInt32(NULL, &integer, 1, &i32, 1), fmi3Error);
    CHECK(fmi3GetUInt32(NULL, &missing, 1, &u32, 1), fmi3Error);
    CHECK(fmi3GetInt64(NULL, &missing, 1, &i64, 1), fmi3Error);
    CHECK(fmi3GetUInt64(NULL, &missing, 1, &u64, 1), fmi3Error);
    CHECK(fmi3GetBoolean(NULL, &missing, 1, &b, 1), fmi3Error);
    CHECK(fmi3GetString(NULL, &missing, 1, &s, 1), fmi3Error);
    CHECK(fmi3GetBinary(NULL, &missing, 1, &n, &binary, 1), fmi3Error);
    CHECK(fmi3GetClock(NULL, &missing, 1, &clock), fmi3Error);
    CHECK(fmi3SetFloat32(NULL, &missing, 1, &f, 1), fmi3Error);
    CHECK(fmi3SetFloat64(NULL, &parameter, 1, &r, 1), fmi3Error);
    CHECK(fmi3SetInt8(NULL, &missing, 1, &i8, 1), fmi3Error);
    CHECK(fmi3SetUInt8(NULL, &missing, 1, &u8, 1), fmi3Error);
    CHECK(fmi3SetInt16(NULL, &missing, 1, &i16, 1), fmi3Error);
    CHECK(fmi3SetUInt16(NULL, &missing, 1, &u16, 1), fmi3Error);
    CHECK(fmi3SetInt32(NULL, &integer, 1, &i32, 1), fmi3Error);
    CHECK(fmi3SetUInt32(NULL, &missing, 1, &u32, 1), fmi3Error);
    CHECK(fmi3SetInt64(NULL, &missing, 1, &i64, 1), fmi3Error);
    CHECK(fmi3SetUInt64(NULL, &missing, 1, &u64, 1), fmi3Error);
    CHECK(fmi3SetBoolean(NULL, &missing, 1, &b, 1), fmi3Error);
    CHECK(fmi3SetString(NULL, &missing, 1, &s, 1), fmi3Error);
    CHECK(fmi3SetBinary(NULL, &missing, 1, &n, &binary, 1), fmi3Error);
    CHECK(fmi3SetClock(NULL, &missing, 1, &clock), fmi3Error);
    CHECK(fmi3GetNumberOfVariableDependencies(NULL, output, &n), fmi3Error);
    CHECK(fmi3GetVariableDependencies(NULL, output, &n, &parameter, &n, &dependency, 1), fmi3Error);
    CHECK(fmi3GetFMUState(NULL, &saved), fmi3Error);
    CHECK(fmi3SetFMUState(NULL, saved), fmi3Error);
    CHECK(fmi3FreeFMUState(NULL, &saved), fmi3Error);
    CHECK(fmi3SerializedFMUStateSize(NULL, saved, &n), fmi3Error);
    CHECK(fmi3SerializeFMUState(NULL, saved, &byte, 1), fmi3Error);
    CHECK(fmi3DeserializeFMUState(NULL, &byte, 1, &saved), fmi3Error);
    CHECK(fmi3GetDirectionalDerivative(NULL, &output, 1, &parameter, 1, &r, 1, &r, 1), fmi3Error);
    CHECK(fmi3GetAdjointDerivative(NULL, &output, 1, &parameter, 1, &r, 1, &r, 1), fmi3Error);
    CHECK(fmi3EnterConfigurationMode(NULL), fmi3Error);
    CHECK(fmi3ExitConfigurationMode(NULL), fmi3Error);
    CHECK(fmi3GetIntervalDecimal(NULL, &missing, 1, &r, &qualifier), fmi3Error);
    CHECK(fmi3GetIntervalFraction(NULL, &missing, 1, &u64, &u64, &qualifier), fmi3Error);
    CHECK(fmi3GetShiftDecimal(NULL, &missing, 1, &r), fmi3Error);
    CHECK(fmi3GetShiftFraction(NULL, &missing, 1, &u64, &u64), fmi3Error);
    CHECK(fmi3SetIntervalDecimal(NULL, &missing, 1, &r), fmi3Error);
    CHECK(fmi3SetIntervalFraction(NULL, &missing, 1, &u64, &u64), fmi3Error);
    CHECK(fmi3SetShiftDecimal(NULL, &missing, 1, &r), fmi3Error);
    CHECK(fmi3SetShiftFraction(NULL, &missing, 1, &u64, &u64), fmi3Error);
    CHECK(fmi3EvaluateDiscreteStates(NULL), fmi3Error);
    CHECK(fmi3UpdateDiscreteStates(NULL, &b, &b2, &b3, &b4, &clock, &r), fmi3Error);
    CHECK(fmi3EnterContinuousTimeMode(NULL), fmi3Error);
    CHECK(fmi3CompletedIntegratorStep(NULL, true, &b, &b2), fmi3Error);
    CHECK(fmi3SetTime(NULL, 0), fmi3Error);
    CHECK(fmi3SetContinuousStates(NULL, &r, 1), fmi3Error);
    CHECK(fmi3GetContinuousStateDerivatives(NULL, &r, 1), fmi3Error);
    CHECK(fmi3GetEventIndicators(NULL, &r, 0), fmi3Error);
    CHECK(fmi3GetContinuousStates(NULL, &r, 1), fmi3Error);
    CHECK(fmi3GetNominalsOfContinuousStates(NULL, &r, 1), fmi3Error);
    CHECK(fmi3GetNumberOfEventIndicators(NULL, &n), fmi3Error);
    CHECK(fmi3GetNumberOfContinuousStates(NULL, &n), fmi3Error);
    CHECK(fmi3EnterStepMode(NULL), fmi3Error);
    CHECK(fmi3GetOutputDerivatives(NULL, &output, 1, &i32, &r, 1), fmi3Error);
    CHECK(fmi3DoStep(NULL, 0, 0.1, true, &b, &b2, &b3, &r), fmi3Error);
    CHECK(fmi3ActivateModelPartition(NULL, missing, 0), fmi3Error);
    fmi3FreeInstance(NULL);
}

static void refused_instances(void)
{
    int before = logged;
    REQUIRE(fmi3InstantiateCoSimulation("x", "{not-this-token}", "", false, false, false, false, NULL, 0, NULL, logger,
                                        NULL) == NULL);
    REQUIRE(fmi3InstantiateModelExchange(NULL, token, "", false, false, NULL, logger) == NULL);
    REQUIRE(fmi3InstantiateScheduledExecution("x", token, "", false, false, NULL, logger, NULL, NULL, NULL) == NULL);
    REQUIRE(logged == before + 3);
}

static void initialize(fmi3Instance c)
{
    fmi3Float64 m = 1.5;
    CHECK(fmi3SetFloat64(c, &parameter, 1, &m, 1), fmi3OK);
    CHECK(fmi3EnterInitializationMode(c, true, 1e-8, 0, true, 1.0), fmi3OK);
    CHECK(fmi3ExitInitializationMode(c), fmi3OK);
}

static void co_simulation(void)
{
    fmi3Instance c = fmi3InstantiateCoSimulation("cs", token, "", false, false, false, true, NULL, 0, NULL, logger,
                                                 NULL);
    fmi3Float64 r = 0, values[2] = { 0, 0 }, reached = 0;
    fmi3Int32 steps = 0;
    fmi3Boolean event = true, terminate = true, early = true;
    fmi3FMUState saved = NULL;
    size_t n = 0;
    int k;
    REQUIRE(c != NULL);
    CHECK(fmi3DoStep(c, 0, 0.1, true, &event, &terminate, &early, &reached), fmi3Error);   /* before the run */
    CHECK(fmi3Reset(c), fmi3OK);
    CHECK(fmi3SetFloat64(c, &missing, 1, &r, 1), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    CHECK(fmi3SetFloat64(c, &parameter, 1, values, 2), fmi3Error);     /* two values for one reference */
    CHECK(fmi3Reset(c), fmi3OK);
    CHECK(fmi3SetInt32(c, &integer, 1, &steps, 1), fmi3OK);
    CHECK(fmi3GetFMUState(c, &saved), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    CHECK(fmi3GetNumberOfContinuousStates(c, &n), fmi3Error);          /* a model exchange function */
    CHECK(fmi3Reset(c), fmi3OK);
    CHECK(fmi3EnterStepMode(c), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3GetInt32(c, &integer, 1, &steps, 1), fmi3OK);
    for (k = 0; k < 10; ++k) {
        CHECK(fmi3DoStep(c, 0.1 * k, 0.1, true, &event, &terminate, &early, &reached), fmi3OK);
        REQUIRE(!event && !terminate && !early);
    }
    REQUIRE(fabs(reached - 1.0) < 1e-12);
    CHECK(fmi3GetFloat64(c, &output, 1, &r, 1), fmi3OK);
    CHECK(fmi3DoStep(c, 1.0, 0.1, true, &event, &terminate, &early, &reached), fmi3Error);  /* beyond the stop */
    CHECK(fmi3GetFloat64(c, &state, 1, &r, 1), fmi3OK);                /* readable in the error mode */
    CHECK(fmi3Terminate(c), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3DoStep(c, 0, 0.5, true, NULL, &terminate, &early, &reached), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3DoStep(c, 0, 0.5, true, &event, &terminate, &early, &reached), fmi3OK);
    CHECK(fmi3Terminate(c), fmi3OK);
    fmi3FreeInstance(c);
}

static void model_exchange(size_t n)
{
    fmi3Instance c = fmi3InstantiateModelExchange("me", token, "", false, false, NULL, logger);
    fmi3Float64 *x = calloc(n, sizeof *x), *dx = calloc(n, sizeof *dx), r = 0, t = 0, h = 1e-3, next = 0;
    fmi3Boolean update = true, terminate = true, nominals = true, values = true, defined = true, enter = true;
    size_t count = 0, k, step;
    REQUIRE(c != NULL && x != NULL && dx != NULL);
    CHECK(fmi3GetNumberOfContinuousStates(c, &count), fmi3OK);
    REQUIRE(count == n);
    CHECK(fmi3GetNumberOfEventIndicators(c, &count), fmi3OK);
    CHECK(fmi3GetNominalsOfContinuousStates(c, x, n), fmi3OK);
    CHECK(fmi3GetContinuousStates(c, x, n), fmi3Error);                /* before initialization */
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3EvaluateDiscreteStates(c), fmi3OK);
    CHECK(fmi3UpdateDiscreteStates(c, &update, &terminate, &nominals, &values, &defined, &next), fmi3OK);
    REQUIRE(!update && !terminate && !nominals && !values && !defined);
    CHECK(fmi3EnterContinuousTimeMode(c), fmi3OK);
    CHECK(fmi3GetContinuousStates(c, x, n + 1), fmi3Error);            /* the wrong count */
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3EnterContinuousTimeMode(c), fmi3OK);
    CHECK(fmi3GetContinuousStates(c, x, n), fmi3OK);
    for (step = 0; step < 100; ++step) {                                /* explicit Euler */
        CHECK(fmi3GetContinuousStateDerivatives(c, dx, n), fmi3OK);
        t += h;
        CHECK(fmi3SetTime(c, t), fmi3OK);
        for (k = 0; k < n; ++k)
            x[k] += h * dx[k];
        CHECK(fmi3SetContinuousStates(c, x, n), fmi3OK);
        CHECK(fmi3GetEventIndicators(c, &r, count), fmi3OK);
        CHECK(fmi3CompletedIntegratorStep(c, true, &enter, &terminate), fmi3OK);
        REQUIRE(!enter && !terminate);
    }
    CHECK(fmi3GetFloat64(c, &output, 1, &r, 1), fmi3OK);
    CHECK(fmi3SetTime(c, HUGE_VAL), fmi3Error);
    CHECK(fmi3Reset(c), fmi3OK);
    initialize(c);
    CHECK(fmi3EnterContinuousTimeMode(c), fmi3OK);
    CHECK(fmi3EnterEventMode(c), fmi3OK);
    CHECK(fmi3UpdateDiscreteStates(c, &update, &terminate, &nominals, &values, &defined, &next), fmi3OK);
    CHECK(fmi3Terminate(c), fmi3OK);
    CHECK(fmi3GetFloat64(c, &state, 1, &r, 1), fmi3OK);
    fmi3FreeInstance(c);
    free(x);
    free(dx);
}

int main(int argc, char **argv)
{
    if (argc != 8) {
        printf("usage: %s TOKEN PARAMETER STATE OUTPUT INTEGER MISSING NSTATES\n", argv[0]);
        return 2;
    }
    token = argv[1];
    parameter = (fmi3ValueReference)strtoul(argv[2], NULL, 10);
    state = (fmi3ValueReference)strtoul(argv[3], NULL, 10);
    output = (fmi3ValueReference)strtoul(argv[4], NULL, 10);
    integer = (fmi3ValueReference)strtoul(argv[5], NULL, 10);
    missing = (fmi3ValueReference)strtoul(argv[6], NULL, 10);
    REQUIRE(strcmp(fmi3GetVersion(), "3.0") == 0);
    null_instance();
    refused_instances();
    co_simulation();
    model_exchange((size_t)strtoul(argv[7], NULL, 10));
    printf("ok\n");
    return 0;
}
