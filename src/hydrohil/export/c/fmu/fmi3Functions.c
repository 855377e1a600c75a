/* fmi3Functions.c: FMI 3.0 Co-Simulation interface of the exported plant (plant_fmu.h). Every function of
 * the standard's header is defined; what a Co-Simulation FMU without clocks, events or derivatives does
 * not offer answers fmi3Error with a message. */
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"
#include "plant_fmu.h"

#define VR_TIME 999

typedef struct {
    plant *pl;
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
    int logging;
} fmu3;

static void forward_log3(void *env, const char *instance, int status, const char *category, const char *msg)
{
    fmu3 *f = env;
    (void)instance;
    if (!f->log || (status == PLANT_OK && !f->logging))
        return;
    f->log(f->env, status == PLANT_ERROR ? fmi3Error : status == PLANT_WARNING ? fmi3Warning : fmi3OK, category, msg);
}

static fmi3Status st(int s) { return s == PLANT_OK ? fmi3OK : s == PLANT_WARNING ? fmi3Warning : fmi3Error; }
#define PL(c) (((fmu3 *)(c))->pl)
/* a call on no instance (NULL) answers fmi3Error: there is no logger to say more */
#define CHECK(c)                                                                                                \
    do {                                                                                                        \
        if (!(c))                                                                                               \
            return fmi3Error;                                                                                   \
    } while (0)
/* what every getter and setter of values checks: an instance, one value per reference (no arrays), both given */
#define CHECK_VALUES(c, vr, nvr, values, nValues)                                                               \
    do {                                                                                                        \
        CHECK(c);                                                                                               \
        if ((nValues) != (nvr))                                                                                 \
            return unsupported(c, "arrays (nValues != nValueReferences)");                                      \
        if ((nvr) > 0 && (!(vr) || !(values)))                                                                  \
            return fmi3Error;                                                                                   \
    } while (0)
static fmi3Status unsupported(fmi3Instance c, const char *what)
{
    CHECK(c);
    plant_logf(PL(c), PLANT_ERROR, "%s is not supported by this FMU", what);
    return fmi3Error;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean loggingOn, size_t nCategories, const fmi3String categories[])
{
    (void)nCategories;
    (void)categories;
    CHECK(c);
    ((fmu3 *)c)->logging = loggingOn;
    return fmi3OK;
}

/* an instance of the plant (Model Exchange: me), or NULL with the reason given to logMessage */
static fmi3Instance instantiate(fmi3String instanceName, fmi3String instantiationToken, fmi3Boolean loggingOn,
                                fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage, int me)
{
    fmu3 *f;
    if (!instantiationToken || strcmp(instantiationToken, PLANT_TOKEN) != 0) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "hydrohil_plant: instantiation token of another export");
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->env = instanceEnvironment;
    f->log = logMessage;
    f->logging = loggingOn;
    f->pl = plant_new(instanceName, forward_log3, f);
    if (!f->pl) {
        free(f);
        return NULL;
    }
    f->pl->me = me;
    return f;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    (void)resourcePath; (void)visible;
    return instantiate(instanceName, instantiationToken, loggingOn, instanceEnvironment, logMessage, 1);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)resourcePath; (void)visible; (void)earlyReturnAllowed; (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables; (void)intermediateUpdate;
    if (eventModeUsed) {
        if (logMessage)
            logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                       "hydrohil_plant: Co-Simulation's event mode is not supported");
        return NULL;
    }
    return instantiate(instanceName, instantiationToken, loggingOn, instanceEnvironment, logMessage, 0);
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage)
        logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                   "hydrohil_plant: a Model Exchange and Co-Simulation FMU (no scheduled execution)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance c)
{
    if (c) {
        plant_free(PL(c));
        free(c);
    }
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    CHECK(c);
    return st(plant_enter_init(PL(c), startTime));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance c)
{
    CHECK(c);
    return st(plant_exit_init(PL(c)));
}
fmi3Status fmi3EnterEventMode(fmi3Instance c)
{
    CHECK(c);
    if (plant_me_check(PL(c), "fmi3EnterEventMode", -1) != PLANT_OK)
        return fmi3Error;
    PL(c)->me_event = 1;
    return fmi3OK;
}

fmi3Status fmi3Terminate(fmi3Instance c)
{
    CHECK(c);
    return st(plant_terminate(PL(c)));
}

fmi3Status fmi3Reset(fmi3Instance c)
{
    CHECK(c);
    plant_defaults(PL(c));
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++) {
        if (vr[i] == VR_TIME) {
            values[i] = PL(c)->t_comm;
            continue;
        }
        if (plant_get_real(PL(c), vr[i], &values[i]) != PLANT_OK)
            return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++)
        if (plant_set_real(PL(c), vr[i], values[i]) != PLANT_OK)
            return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[], size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++) {
        int v;
        if (plant_get_integer(PL(c), vr[i], &v) != PLANT_OK)
            return fmi3Error;
        values[i] = v;
    }
    return fmi3OK;
}

fmi3Status fmi3GetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Int64 values[], size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++) {        /* (an Enumeration's: FMI 3 reads them as Int64) */
        int v;
        if (plant_get_integer(PL(c), vr[i], &v) != PLANT_OK)
            return fmi3Error;
        values[i] = v;
    }
    return fmi3OK;
}

fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Boolean values[],
                          size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++) {
        int b;
        if (plant_get_boolean(PL(c), vr[i], &b) != PLANT_OK)
            return fmi3Error;
        values[i] = b ? fmi3True : fmi3False;
    }
    return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++)
        if (plant_set_integer(PL(c), vr[i], values[i]) != PLANT_OK)
            return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3SetInt64(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Int64 values[],
                        size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++) {        /* (an Enumeration's: its items' values are the core's codes) */
        if (values[i] < -2147483647 || values[i] > 2147483647) {
            plant_logf(PL(c), PLANT_ERROR, "value reference %u: %lld is no value of this FMU's", vr[i],
                       (long long)values[i]);
            return fmi3Error;
        }
        if (plant_set_integer(PL(c), vr[i], (int)values[i]) != PLANT_OK)
            return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Boolean values[],
                          size_t nValues)
{
    size_t i;
    CHECK_VALUES(c, vr, nvr, values, nValues);
    for (i = 0; i < nvr; i++)
        if (plant_set_boolean(PL(c), vr[i], values[i] != fmi3False) != PLANT_OK)
            return fmi3Error;
    return fmi3OK;
}

/* getters and setters of the types this FMU has no variable of */
#define NO_GET(NAME, T)                                                                                         \
    fmi3Status NAME(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, T values[], size_t nValues)     \
    {                                                                                                            \
        (void)vr; (void)values; (void)nValues;                                                                  \
        CHECK(c);                                                                                               \
        return nvr == 0 ? fmi3OK : unsupported(c, #NAME " (no variable of that type)");                         \
    }
#define NO_SET(NAME, T)                                                                                         \
    fmi3Status NAME(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const T values[], size_t nValues) \
    {                                                                                                            \
        (void)vr; (void)values; (void)nValues;                                                                  \
        CHECK(c);                                                                                               \
        return nvr == 0 ? fmi3OK : unsupported(c, #NAME " (no settable variable of that type)");                \
    }
NO_GET(fmi3GetFloat32, fmi3Float32)
NO_GET(fmi3GetInt8, fmi3Int8)
NO_GET(fmi3GetUInt8, fmi3UInt8)
NO_GET(fmi3GetInt16, fmi3Int16)
NO_GET(fmi3GetUInt16, fmi3UInt16)
NO_GET(fmi3GetUInt32, fmi3UInt32)
NO_GET(fmi3GetUInt64, fmi3UInt64)
NO_GET(fmi3GetString, fmi3String)
NO_SET(fmi3SetFloat32, fmi3Float32)
NO_SET(fmi3SetInt8, fmi3Int8)
NO_SET(fmi3SetUInt8, fmi3UInt8)
NO_SET(fmi3SetInt16, fmi3Int16)
NO_SET(fmi3SetUInt16, fmi3UInt16)
NO_SET(fmi3SetUInt32, fmi3UInt32)
NO_SET(fmi3SetUInt64, fmi3UInt64)
NO_SET(fmi3SetString, fmi3String)

fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr == 0 ? fmi3OK : unsupported(c, "fmi3GetBinary");
}

fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues)
{
    (void)vr; (void)valueSizes; (void)values; (void)nValues;
    return nvr == 0 ? fmi3OK : unsupported(c, "fmi3SetBinary");
}

fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[])
{
    (void)vr; (void)values;
    return nvr == 0 ? fmi3OK : unsupported(c, "fmi3GetClock");
}

fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[])
{
    (void)vr; (void)values;
    return nvr == 0 ? fmi3OK : unsupported(c, "fmi3SetClock");
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance c, fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    (void)valueReference; (void)nDependencies;
    return unsupported(c, "fmi3GetNumberOfVariableDependencies");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance c, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies)
{
    (void)dependent; (void)elementIndicesOfDependent; (void)independents; (void)elementIndicesOfIndependents;
    (void)dependencyKinds; (void)nDependencies;
    return unsupported(c, "fmi3GetVariableDependencies");
}

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state)
{
    CHECK(c);
    if (!state)
        return fmi3Error;
    return st(plant_state_get(PL(c), state));
}

fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state)
{
    CHECK(c);
    return st(plant_state_set(PL(c), state));
}

fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state)
{
    CHECK(c);
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState state, size_t *size)
{
    CHECK(c);
    if (!state || !size) {
        plant_logf(PL(c), PLANT_ERROR, "the size of no FMU state");
        return fmi3Error;
    }
    *size = plant_state_block_size(state);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState state, fmi3Byte serialized[], size_t size)
{
    CHECK(c);
    return st(plant_state_serialize(PL(c), state, serialized, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serialized[], size_t size, fmi3FMUState *state)
{
    CHECK(c);
    return st(plant_state_deserialize(PL(c), serialized, size, state));
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetDirectionalDerivative");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance c, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity)
{
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed; (void)sensitivity;
    (void)nSensitivity;
    return unsupported(c, "fmi3GetAdjointDerivative");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) { return unsupported(c, "fmi3EnterConfigurationMode"); }
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) { return unsupported(c, "fmi3ExitConfigurationMode"); }

fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[])
{
    (void)vr; (void)nvr; (void)intervals; (void)qualifiers;
    return unsupported(c, "clocks (fmi3GetIntervalDecimal)");
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions; (void)qualifiers;
    return unsupported(c, "clocks (fmi3GetIntervalFraction)");
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 shifts[])
{
    (void)vr; (void)nvr; (void)shifts;
    return unsupported(c, "clocks (fmi3GetShiftDecimal)");
}

fmi3Status fmi3GetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return unsupported(c, "clocks (fmi3GetShiftFraction)");
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 intervals[])
{
    (void)vr; (void)nvr; (void)intervals;
    return unsupported(c, "clocks (fmi3SetIntervalDecimal)");
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return unsupported(c, "clocks (fmi3SetIntervalFraction)");
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 shifts[])
{
    (void)vr; (void)nvr; (void)shifts;
    return unsupported(c, "clocks (fmi3SetShiftDecimal)");
}

fmi3Status fmi3SetShiftFraction(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                const fmi3UInt64 counters[], const fmi3UInt64 resolutions[])
{
    (void)vr; (void)nvr; (void)counters; (void)resolutions;
    return unsupported(c, "clocks (fmi3SetShiftFraction)");
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance c) { return unsupported(c, "fmi3EvaluateDiscreteStates"); }

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime)
{
    int changed = 0, next_defined = 0;
    double next = 0.0;
    CHECK(c);
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime ||
        plant_me_check(PL(c), "fmi3UpdateDiscreteStates", 1) != PLANT_OK)
        return fmi3Error;
    if (plant_me_update(PL(c), &changed, &next_defined, &next) != PLANT_OK)
        return fmi3Error;
    *discreteStatesNeedUpdate = fmi3False;
    *terminateSimulation = fmi3False;
    *nominalsOfContinuousStatesChanged = fmi3False;
    *valuesOfContinuousStatesChanged = changed ? fmi3True : fmi3False;
    *nextEventTimeDefined = next_defined ? fmi3True : fmi3False;
    *nextEventTime = next;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c)
{
    CHECK(c);
    if (plant_me_check(PL(c), "fmi3EnterContinuousTimeMode", 1) != PLANT_OK)
        return fmi3Error;
    PL(c)->me_event = 0;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation)
{
    int event = 0, stop = 0;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(c);
    if (!enterEventMode || !terminateSimulation || plant_me_check(PL(c), "fmi3CompletedIntegratorStep", 0) != PLANT_OK)
        return fmi3Error;
    if (plant_me_step_done(PL(c), &event, &stop) != PLANT_OK) {
        *terminateSimulation = fmi3True;
        return fmi3Error;
    }
    *enterEventMode = event ? fmi3True : fmi3False;
    *terminateSimulation = stop ? fmi3True : fmi3False;
    return fmi3OK;
}

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time)
{
    CHECK(c);
    return plant_me_set_time(PL(c), time) == PLANT_OK ? fmi3OK : fmi3Error;
}

/* a call of Model Exchange's on n values (x: its array), in either mode */
static int me_call(fmi3Instance c, const char *call, const void *x, size_t n)
{
    return (n == 0 || x) && plant_me_check(PL(c), call, -1) == PLANT_OK;
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n)
{
    CHECK(c);
    if (!me_call(c, "fmi3SetContinuousStates", x, n))
        return fmi3Error;
    return plant_me_states(PL(c), (double *)x, n, 1) == PLANT_OK ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n)
{
    CHECK(c);
    if (!me_call(c, "fmi3GetContinuousStateDerivatives", d, n))
        return fmi3Error;
    return plant_me_derivatives(PL(c), d, n) == PLANT_OK ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 e[], size_t n)
{
    CHECK(c);
    if (!me_call(c, "fmi3GetEventIndicators", e, n))
        return fmi3Error;
    return plant_me_indicators(PL(c), e, n) == PLANT_OK ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n)
{
    CHECK(c);
    if (!me_call(c, "fmi3GetContinuousStates", x, n))
        return fmi3Error;
    return plant_me_states(PL(c), x, n, 0) == PLANT_OK ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n)
{
    CHECK(c);
    if ((n > 0 && !x) || !PL(c)->me)
        return unsupported(c, "fmi3GetNominalsOfContinuousStates of a Co-Simulation instance");
    return plant_me_nominals(PL(c), x, n) == PLANT_OK ? fmi3OK : fmi3Error;
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n)
{
    CHECK(c);
    if (!n)
        return fmi3Error;
    *n = PLANT_NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n)
{
    CHECK(c);
    if (!n)
        return fmi3Error;
    *n = PLANT_NX;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance c) { return unsupported(c, "fmi3EnterStepMode (no event mode)"); }

fmi3Status fmi3GetOutputDerivatives(fmi3Instance c, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues)
{
    (void)vr; (void)nvr; (void)orders; (void)values; (void)nValues;
    return unsupported(c, "fmi3GetOutputDerivatives");
}

fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    fmi3Status s;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(c);
    s = st(plant_do_step(PL(c), currentCommunicationPoint, communicationStepSize));
    if (eventHandlingNeeded)
        *eventHandlingNeeded = fmi3False;
    if (terminateSimulation)
        *terminateSimulation = fmi3False;
    if (earlyReturn)
        *earlyReturn = fmi3False;
    if (lastSuccessfulTime)
        *lastSuccessfulTime = PL(c)->t_comm;
    return s;
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance c, fmi3ValueReference clockReference, fmi3Float64 activationTime)
{
    (void)clockReference; (void)activationTime;
    return unsupported(c, "Scheduled Execution");
}
