/* fmi2Functions.c: FMI 2.0 Co-Simulation and Model Exchange interfaces of the exported plant (plant_fmu.h).
 * Every function of the standard's header is defined; input/output derivatives answer fmi2Error. */
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"
#include "plant_fmu.h"

typedef struct {
    plant *pl;
    fmi2CallbackFunctions cb;
    int logging;
} fmu2;

static void forward_log2(void *env, const char *instance, int status, const char *category, const char *msg)
{
    fmu2 *f = env;
    if (!f->cb.logger || (status == PLANT_OK && !f->logging))
        return;
    f->cb.logger(f->cb.componentEnvironment, instance, status == PLANT_ERROR ? fmi2Error
                 : status == PLANT_WARNING ? fmi2Warning : fmi2OK, category, "%s", msg);
}

static fmi2Status st(int s) { return s == PLANT_OK ? fmi2OK : s == PLANT_WARNING ? fmi2Warning : fmi2Error; }
#define PL(c) (((fmu2 *)(c))->pl)
#define UNSUPPORTED(c, what) (plant_logf(PL(c), PLANT_ERROR, "%s is not supported", what), fmi2Error)
/* a call on no instance (NULL) answers fmi2Error: there is no logger to say more */
#define CHECK(c)                                                                                                \
    do {                                                                                                        \
        if (!(c))                                                                                               \
            return fmi2Error;                                                                                   \
    } while (0)

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories;
    (void)categories;
    CHECK(c);
    ((fmu2 *)c)->logging = loggingOn;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn)
{
    fmu2 *f;
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions || (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) || !fmuGUID ||
        strcmp(fmuGUID, PLANT_TOKEN) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error, "logStatusError",
                              "hydrohil_plant: a Model Exchange and Co-Simulation FMU of token %s (got type %d, token "
                              "%s)", PLANT_TOKEN, (int)fmuType, fmuGUID ? fmuGUID : "none");
        return NULL;
    }
    f = calloc(1, sizeof *f);
    if (!f)
        return NULL;
    f->cb = *functions;
    f->logging = loggingOn;
    f->pl = plant_new(instanceName, forward_log2, f);
    if (!f->pl) {
        free(f);
        return NULL;
    }
    f->pl->me = fmuType == fmi2ModelExchange;
    return f;
}

void fmi2FreeInstance(fmi2Component c)
{
    if (c) {
        plant_free(PL(c));
        free(c);
    }
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    CHECK(c);
    return st(plant_setup(PL(c), startTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    CHECK(c);
    return st(plant_enter_init(PL(c), PL(c)->t0));
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    CHECK(c);
    return st(plant_exit_init(PL(c)));
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    CHECK(c);
    return st(plant_terminate(PL(c)));
}

fmi2Status fmi2Reset(fmi2Component c)
{
    CHECK(c);
    plant_defaults(PL(c));
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (plant_get_real(PL(c), vr[i], &value[i]) != PLANT_OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (plant_get_integer(PL(c), vr[i], &value[i]) != PLANT_OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++) {
        int b;
        if (plant_get_boolean(PL(c), vr[i], &b) != PLANT_OK)
            return fmi2Error;
        value[i] = b ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[])
{
    CHECK(c);
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : UNSUPPORTED(c, "fmi2GetString (the FMU has no String variable)");
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (plant_set_real(PL(c), vr[i], value[i]) != PLANT_OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++)          /* (an Integer's or an Enumeration's) */
        if (plant_set_integer(PL(c), vr[i], value[i]) != PLANT_OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[])
{
    size_t i;
    CHECK(c);
    if (nvr > 0 && (!vr || !value))
        return fmi2Error;
    for (i = 0; i < nvr; i++)
        if (plant_set_boolean(PL(c), vr[i], value[i] != fmi2False) != PLANT_OK)
            return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[])
{
    CHECK(c);
    (void)vr;
    (void)value;
    return nvr == 0 ? fmi2OK : UNSUPPORTED(c, "fmi2SetString (the FMU has no String variable)");
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    CHECK(c);
    if (!state)
        return fmi2Error;
    return st(plant_state_get(PL(c), state));
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state)
{
    CHECK(c);
    return st(plant_state_set(PL(c), state));
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state)
{
    CHECK(c);
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size)
{
    CHECK(c);
    if (!state || !size) {
        plant_logf(PL(c), PLANT_ERROR, "the size of no FMU state");
        return fmi2Error;
    }
    *size = plant_state_block_size(state);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte serialized[], size_t size)
{
    CHECK(c);
    return st(plant_state_serialize(PL(c), state, serialized, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serialized[], size_t size, fmi2FMUstate *state)
{
    CHECK(c);
    return st(plant_state_deserialize(PL(c), serialized, size, state));
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[])
{
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    CHECK(c);
    return UNSUPPORTED(c, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    CHECK(c);
    return UNSUPPORTED(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[])
{
    (void)vr; (void)nvr; (void)order; (void)value;
    CHECK(c);
    return UNSUPPORTED(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(c);
    return st(plant_do_step(PL(c), currentCommunicationPoint, communicationStepSize));
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    CHECK(c);
    return UNSUPPORTED(c, "fmi2CancelStep (doStep is synchronous)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s;
    CHECK(c);
    if (!value)
        return fmi2Error;
    *value = PL(c)->mode == PLANT_FAILED ? fmi2Error : fmi2OK;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    CHECK(c);
    if (s != fmi2LastSuccessfulTime || !value)
        return UNSUPPORTED(c, "fmi2GetRealStatus of this kind");
    *value = PL(c)->t_comm;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    (void)s; (void)value;
    CHECK(c);
    return UNSUPPORTED(c, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    CHECK(c);
    if (s == fmi2Terminated && value) {
        *value = fmi2False;
        return fmi2OK;
    }
    return UNSUPPORTED(c, "fmi2GetBooleanStatus of this kind");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    (void)s; (void)value;
    CHECK(c);
    return UNSUPPORTED(c, "fmi2GetStringStatus");
}

/* ---- Model Exchange (fmu_instance.h: plant_me_*) ------------------------------------------------------------ */
fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    CHECK(c);
    if (plant_me_check(PL(c), "fmi2EnterEventMode", -1) != PLANT_OK)
        return fmi2Error;
    PL(c)->me_event = 1;
    return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info)
{
    int changed = 0, next_defined = 0;
    double next = 0.0;
    CHECK(c);
    if (!info || plant_me_check(PL(c), "fmi2NewDiscreteStates", 1) != PLANT_OK)
        return fmi2Error;
    if (plant_me_update(PL(c), &changed, &next_defined, &next) != PLANT_OK)
        return fmi2Error;
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    info->nextEventTimeDefined = next_defined ? fmi2True : fmi2False;
    info->nextEventTime = next;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    CHECK(c);
    if (plant_me_check(PL(c), "fmi2EnterContinuousTimeMode", 1) != PLANT_OK)
        return fmi2Error;
    PL(c)->me_event = 0;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    int event = 0, stop = 0;
    (void)noSetFMUStatePriorToCurrentPoint;
    CHECK(c);
    if (!enterEventMode || !terminateSimulation || plant_me_check(PL(c), "fmi2CompletedIntegratorStep", 0) != PLANT_OK)
        return fmi2Error;
    if (plant_me_step_done(PL(c), &event, &stop) != PLANT_OK) {
        *terminateSimulation = fmi2True;
        return fmi2Error;
    }
    *enterEventMode = event ? fmi2True : fmi2False;
    *terminateSimulation = stop ? fmi2True : fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    CHECK(c);
    return st(plant_me_set_time(PL(c), time));
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    CHECK(c);
    if ((nx > 0 && !x) || plant_me_check(PL(c), "fmi2SetContinuousStates", -1) != PLANT_OK)
        return fmi2Error;
    return st(plant_me_states(PL(c), (double *)x, nx, 1));
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    CHECK(c);
    if ((nx > 0 && !derivatives) || plant_me_check(PL(c), "fmi2GetDerivatives", -1) != PLANT_OK)
        return fmi2Error;
    return st(plant_me_derivatives(PL(c), derivatives, nx));
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    CHECK(c);
    if ((ni > 0 && !eventIndicators) || plant_me_check(PL(c), "fmi2GetEventIndicators", -1) != PLANT_OK)
        return fmi2Error;
    return st(plant_me_indicators(PL(c), eventIndicators, ni));
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    CHECK(c);
    if ((nx > 0 && !x) || plant_me_check(PL(c), "fmi2GetContinuousStates", -1) != PLANT_OK)
        return fmi2Error;
    return st(plant_me_states(PL(c), x, nx, 0));
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    CHECK(c);
    if ((nx > 0 && !x_nominal) || !PL(c)->me) {
        plant_logf(PL(c), PLANT_ERROR, "fmi2GetNominalsOfContinuousStates: a Model Exchange call");
        return fmi2Error;
    }
    return st(plant_me_nominals(PL(c), x_nominal, nx));
}
