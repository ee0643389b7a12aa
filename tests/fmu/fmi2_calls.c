/* Calls every function an FMI 2.0 FMU of lagdsl exports, in and out of order, with good and bad
 * value references and arrays, and checks the status of each (tests/fmu/test_fmu_c.py compiles
 * it with the FMU's source under the strict flags and the address and undefined-behaviour
 * sanitizers). Arguments: the GUID, then the value references of a parameter, a state, an
 * output and an integer (an integrator option), and a value reference the FMU does not have.
 * Prints "ok" and exits 0 when every check holds, else names the first that does not.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

static int logged;

static void logger(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    char text[4096];
    va_list arguments;
    (void)environment;
    va_start(arguments, message);
    vsnprintf(text, sizeof text, message, arguments);
    va_end(arguments);
    ++logged;
    printf("log %s %d %s: %s\n", name, (int)status, category, text);
}

#define CHECK(call, expected)                                                               \
    do {                                                                                    \
        fmi2Status got_ = (call);                                                           \
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

static const fmi2CallbackFunctions callbacks = { logger, NULL, NULL, NULL, NULL };
static const char *guid;
static fmi2ValueReference parameter, state, output, integer, missing;

/* Every function with a NULL instance: fmi2Error, no crash. */
static void null_instance(void)
{
    fmi2Real r = 0;
    fmi2Integer i = 0;
    fmi2Boolean b = 0;
    fmi2String s = NULL;
    fmi2Status status;
    fmi2EventInfo info;
    fmi2FMUstate saved = NULL;
    size_t size = 0;
    fmi2Byte bytes[1];
    CHECK(fmi2SetDebugLogging(NULL, fmi2True, 0, NULL), fmi2Error);
    CHECK(fmi2SetupExperiment(NULL, fmi2False, 0, 0, fmi2False, 0), fmi2Error);
    CHECK(fmi2EnterInitializationMode(NULL), fmi2Error);
    CHECK(fmi2ExitInitializationMode(NULL), fmi2Error);
    CHECK(fmi2Terminate(NULL), fmi2Error);
    CHECK(fmi2Reset(NULL), fmi2Error);
    CHECK(fmi2GetReal(NULL, &output, 1, &r), fmi2Error);
    CHECK(fmi2GetInteger(NULL, &integer, 1, &i), fmi2Error);
    CHECK(fmi2GetBoolean(NULL, &missing, 1, &b), fmi2Error);
    CHECK(fmi2GetString(NULL, &missing, 1, &s), fmi2Error);
    CHECK(fmi2SetReal(NULL, &parameter, 1, &r), fmi2Error);
    CHECK(fmi2SetInteger(NULL, &integer, 1, &i), fmi2Error);
    CHECK(fmi2SetBoolean(NULL, &missing, 1, &b), fmi2Error);
    CHECK(fmi2SetString(NULL, &missing, 1, &s), fmi2Error);
    CHECK(fmi2GetFMUstate(NULL, &saved), fmi2Error);
    CHECK(fmi2SetFMUstate(NULL, saved), fmi2Error);
    CHECK(fmi2FreeFMUstate(NULL, &saved), fmi2Error);
    CHECK(fmi2SerializedFMUstateSize(NULL, saved, &size), fmi2Error);
    CHECK(fmi2SerializeFMUstate(NULL, saved, bytes, 1), fmi2Error);
    CHECK(fmi2DeSerializeFMUstate(NULL, bytes, 1, &saved), fmi2Error);
    CHECK(fmi2GetDirectionalDerivative(NULL, &output, 1, &parameter, 1, &r, &r), fmi2Error);
    CHECK(fmi2EnterEventMode(NULL), fmi2Error);
    CHECK(fmi2NewDiscreteStates(NULL, &info), fmi2Error);
    CHECK(fmi2EnterContinuousTimeMode(NULL), fmi2Error);
    CHECK(fmi2CompletedIntegratorStep(NULL, fmi2True, &b, &b), fmi2Error);
    CHECK(fmi2SetTime(NULL, 0), fmi2Error);
    CHECK(fmi2SetContinuousStates(NULL, &r, 1), fmi2Error);
    CHECK(fmi2GetDerivatives(NULL, &r, 1), fmi2Error);
    CHECK(fmi2GetEventIndicators(NULL, &r, 0), fmi2Error);
    CHECK(fmi2GetContinuousStates(NULL, &r, 1), fmi2Error);
    CHECK(fmi2GetNominalsOfContinuousStates(NULL, &r, 1), fmi2Error);
    CHECK(fmi2SetRealInputDerivatives(NULL, &parameter, 1, &i, &r), fmi2Error);
    CHECK(fmi2GetRealOutputDerivatives(NULL, &output, 1, &i, &r), fmi2Error);
    CHECK(fmi2DoStep(NULL, 0, 0.1, fmi2True), fmi2Error);
    CHECK(fmi2CancelStep(NULL), fmi2Error);
    CHECK(fmi2GetStatus(NULL, fmi2DoStepStatus, &status), fmi2Error);
    CHECK(fmi2GetRealStatus(NULL, fmi2LastSuccessfulTime, &r), fmi2Error);
    CHECK(fmi2GetIntegerStatus(NULL, fmi2DoStepStatus, &i), fmi2Error);
    CHECK(fmi2GetBooleanStatus(NULL, fmi2Terminated, &b), fmi2Error);
    CHECK(fmi2GetStringStatus(NULL, fmi2PendingStatus, &s), fmi2Error);
    fmi2FreeInstance(NULL);
}

/* Instances that cannot be made: NULL, with the reason logged. */
static void refused_instances(void)
{
    int before = logged;
    REQUIRE(fmi2Instantiate("x", fmi2CoSimulation, "{not-this-guid}", "", &callbacks, fmi2False, fmi2False) == NULL);
    REQUIRE(fmi2Instantiate(NULL, fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False) == NULL);
    REQUIRE(fmi2Instantiate("", fmi2ModelExchange, guid, "", &callbacks, fmi2False, fmi2False) == NULL);
    REQUIRE(fmi2Instantiate("x", (fmi2Type)7, guid, "", &callbacks, fmi2False, fmi2False) == NULL);
    REQUIRE(fmi2Instantiate("x", fmi2CoSimulation, NULL, "", &callbacks, fmi2False, fmi2False) == NULL);
    REQUIRE(fmi2Instantiate("x", fmi2CoSimulation, guid, "", NULL, fmi2False, fmi2False) == NULL);
    REQUIRE(logged == before + 5);
}

/* A call out of order or a bad argument puts the instance in the error mode; reset leaves it. */
static void out_of_order(fmi2Component c)
{
    fmi2Real r = 1, x[1];
    fmi2Integer i = 0;
    fmi2Boolean b = 0;
    fmi2String s = NULL;
    fmi2FMUstate saved = NULL;
    CHECK(fmi2DoStep(c, 0, 0.1, fmi2True), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2ExitInitializationMode(c), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2Terminate(c), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2GetReal(c, &output, 1, &r), fmi2Error);        /* nothing computed before initialization */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetReal(c, &missing, 1, &r), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetReal(c, &output, 1, &r), fmi2Error);        /* computed: cannot be set */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetReal(c, &parameter, 1, NULL), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetInteger(c, &parameter, 1, &i), fmi2Error);  /* a real, not an integer */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetInteger(c, &integer, 1, &i), fmi2OK);
    i = -5;
    CHECK(fmi2SetInteger(c, &integer, 1, &i), fmi2Error);    /* no step limit is negative */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetBoolean(c, &missing, 1, &b), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2GetString(c, &missing, 1, &s), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetBoolean(c, NULL, 0, NULL), fmi2OK);          /* nothing to set */
    CHECK(fmi2SetDebugLogging(c, fmi2True, 1, &s), fmi2Error); /* a NULL category */
    CHECK(fmi2Reset(c), fmi2OK);
    s = "noSuchCategory";
    CHECK(fmi2SetDebugLogging(c, fmi2True, 1, &s), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    s = "logEvents";
    CHECK(fmi2SetDebugLogging(c, fmi2True, 1, &s), fmi2OK);
    CHECK(fmi2SetupExperiment(c, fmi2False, 0, 1, fmi2True, 0.5), fmi2Error);   /* stop before start */
    CHECK(fmi2Reset(c), fmi2OK);
    r = HUGE_VAL;
    CHECK(fmi2SetReal(c, &parameter, 1, &r), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2GetFMUstate(c, &saved), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetFMUstate(c, saved), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2FreeFMUstate(c, &saved), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2GetDirectionalDerivative(c, &output, 1, &parameter, 1, &r, x), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
}

static fmi2Component instance(fmi2Type type)
{
    fmi2Component c = fmi2Instantiate("lagdsl test", type, guid, "file:///tmp", &callbacks, fmi2False, fmi2False);
    REQUIRE(c != NULL);
    return c;
}

static void initialize(fmi2Component c, double stop)
{
    fmi2Real m = 1.5;
    CHECK(fmi2SetReal(c, &parameter, 1, &m), fmi2OK);
    CHECK(fmi2SetupExperiment(c, fmi2True, 1e-8, 0, fmi2True, stop), fmi2OK);
    CHECK(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK(fmi2SetupExperiment(c, fmi2False, 0, 0, fmi2False, 0), fmi2Error);   /* too late */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2SetReal(c, &parameter, 1, &m), fmi2OK);
    CHECK(fmi2SetupExperiment(c, fmi2True, 1e-8, 0, fmi2True, stop), fmi2OK);
    CHECK(fmi2EnterInitializationMode(c), fmi2OK);
    CHECK(fmi2ExitInitializationMode(c), fmi2OK);
}

static void co_simulation(void)
{
    fmi2Component c = instance(fmi2CoSimulation);
    fmi2Real r = 0, y = 0, t = 0, x[1];
    fmi2Integer i = 0;
    fmi2Boolean b = 1, b2 = 0;
    fmi2Status status;
    fmi2String s = NULL;
    fmi2EventInfo info;
    int k;
    out_of_order(c);
    initialize(c, 1.0);
    CHECK(fmi2GetReal(c, &output, 1, &r), fmi2OK);
    CHECK(fmi2GetInteger(c, &integer, 1, &i), fmi2OK);
    CHECK(fmi2SetInteger(c, &integer, 1, &i), fmi2Error);    /* an option is fixed after initialization */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    for (k = 0; k < 10; ++k)
        CHECK(fmi2DoStep(c, 0.1 * k, 0.1, fmi2True), fmi2OK);
    CHECK(fmi2GetReal(c, &state, 1, &y), fmi2OK);
    CHECK(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t), fmi2OK);
    REQUIRE(t > 0.999999 && t < 1.000001);
    CHECK(fmi2GetBooleanStatus(c, fmi2Terminated, &b), fmi2OK);
    REQUIRE(b == fmi2False);
    CHECK(fmi2GetStatus(c, fmi2DoStepStatus, &status), fmi2Discard);
    CHECK(fmi2GetIntegerStatus(c, fmi2DoStepStatus, &i), fmi2Discard);
    CHECK(fmi2GetStringStatus(c, fmi2PendingStatus, &s), fmi2Discard);
    CHECK(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, NULL), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0.5, 0.1, fmi2True), fmi2Error);     /* not where the FMU stands */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0, 2.0, fmi2True), fmi2Error);       /* beyond the stop time */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0, -0.1, fmi2True), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2CancelStep(c), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2SetTime(c, 0.5), fmi2Error);                   /* a model exchange function */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2GetDerivatives(c, x, 1), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2NewDiscreteStates(c, &info), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2CompletedIntegratorStep(c, fmi2True, &b, &b2), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2SetRealInputDerivatives(c, &parameter, 1, &i, &r), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2GetRealOutputDerivatives(c, &output, 1, &i, &r), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0, 0.25, fmi2True), fmi2OK);
    r = 2.0;
    CHECK(fmi2SetReal(c, &parameter, 1, &r), fmi2OK);        /* tunable between steps: the integrator begins again */
    CHECK(fmi2DoStep(c, 0.25, 0.25, fmi2True), fmi2OK);
    CHECK(fmi2SetReal(c, &state, 1, &r), fmi2Error);         /* a state is set before the run only */
    CHECK(fmi2Terminate(c), fmi2Error);                      /* not from the error mode */
    CHECK(fmi2GetReal(c, &state, 1, &r), fmi2OK);            /* values stay readable there */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0, 0.25, fmi2True), fmi2OK);
    CHECK(fmi2Terminate(c), fmi2OK);
    CHECK(fmi2Terminate(c), fmi2Error);                      /* terminated already */
    fmi2FreeInstance(c);
}

static void model_exchange(size_t n)
{
    fmi2Component c = instance(fmi2ModelExchange);
    fmi2Real *x = calloc(n, sizeof *x), *dx = calloc(n, sizeof *dx), r = 0, t = 0, h = 1e-3;
    fmi2Boolean enter = 1, terminate = 1;
    fmi2EventInfo info;
    size_t k, step;
    REQUIRE(x != NULL && dx != NULL);
    CHECK(fmi2GetContinuousStates(c, x, n), fmi2Error);          /* before initialization */
    CHECK(fmi2Reset(c), fmi2OK);
    CHECK(fmi2GetNominalsOfContinuousStates(c, x, n), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2NewDiscreteStates(c, &info), fmi2OK);
    REQUIRE(!info.terminateSimulation && !info.newDiscreteStatesNeeded);
    CHECK(fmi2NewDiscreteStates(c, NULL), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2EnterContinuousTimeMode(c), fmi2OK);
    CHECK(fmi2GetContinuousStates(c, x, n + 1), fmi2Error);      /* the wrong count */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2EnterContinuousTimeMode(c), fmi2OK);
    CHECK(fmi2GetContinuousStates(c, x, n), fmi2OK);
    for (step = 0; step < 100; ++step) {                          /* explicit Euler */
        CHECK(fmi2GetDerivatives(c, dx, n), fmi2OK);
        t += h;
        CHECK(fmi2SetTime(c, t), fmi2OK);
        for (k = 0; k < n; ++k)
            x[k] += h * dx[k];
        CHECK(fmi2SetContinuousStates(c, x, n), fmi2OK);
        CHECK(fmi2GetEventIndicators(c, &r, 0), fmi2OK);
        CHECK(fmi2CompletedIntegratorStep(c, fmi2True, &enter, &terminate), fmi2OK);
        REQUIRE(!enter && !terminate);
    }
    CHECK(fmi2GetReal(c, &output, 1, &r), fmi2OK);
    CHECK(fmi2GetDerivatives(c, NULL, n), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2EnterContinuousTimeMode(c), fmi2OK);
    CHECK(fmi2EnterEventMode(c), fmi2OK);
    CHECK(fmi2NewDiscreteStates(c, &info), fmi2OK);
    CHECK(fmi2SetContinuousStates(c, x, n), fmi2Error);          /* not in event mode */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2DoStep(c, 0, 0.1, fmi2True), fmi2Error);           /* a co-simulation function */
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &r), fmi2Error);
    CHECK(fmi2Reset(c), fmi2OK);
    initialize(c, 1.0);
    CHECK(fmi2Terminate(c), fmi2OK);
    CHECK(fmi2GetReal(c, &state, 1, &r), fmi2OK);               /* values stay readable */
    fmi2FreeInstance(c);
    free(x);
    free(dx);
}

int main(int argc, char **argv)
{
    if (argc != 8) {
        printf("usage: %s GUID PARAMETER STATE OUTPUT INTEGER MISSING NSTATES\n", argv[0]);
        return 2;
    }
    guid = argv[1];
    parameter = (fmi2ValueReference)strtoul(argv[2], NULL, 10);
    state = (fmi2ValueReference)strtoul(argv[3], NULL, 10);
    output = (fmi2ValueReference)strtoul(argv[4], NULL, 10);
    integer = (fmi2ValueReference)strtoul(argv[5], NULL, 10);
    missing = (fmi2ValueReference)strtoul(argv[6], NULL, 10);
    REQUIRE(strcmp(fmi2GetVersion(), "2.0") == 0 && strcmp(fmi2GetTypesPlatform(), "default") == 0);
    null_instance();
    refused_instances();
    co_simulation();
    model_exchange((size_t)strtoul(argv[7], NULL, 10));
    printf("ok\n");
    return 0;
}
