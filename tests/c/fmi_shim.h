/* fmi_shim.h: the FMI 2 / FMI 3 calls of the edge-case harnesses (fmu_edges.c, circuit_fmu_edges.c) behind
 * one set of names (-DFMI=2 or -DFMI=3), and their EXPECT. */
#ifndef FMI_SHIM_H
#define FMI_SHIM_H
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "config.h"
#if FMI == 3
#include "fmi3Functions.h"
#define OK fmi3OK
#define ERR fmi3Error
typedef fmi3Instance inst;
typedef fmi3FMUState fstate;
#else
#include "fmi2Functions.h"
#define OK fmi2OK
#define ERR fmi2Error
typedef fmi2Component inst;
typedef fmi2FMUstate fstate;
#endif

static int failures = 0;
#define EXPECT(cond, what)                                                                                      \
    do {                                                                                                        \
        if (!(cond)) {                                                                                          \
            printf("FAIL %s (line %d)\n", what, __LINE__);                                                     \
            failures++;                                                                                         \
        }                                                                                                       \
    } while (0)

#if FMI == 3
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message)
{
    (void)env;
    printf("LOG %d %s: %s\n", (int)status, category, message);
}

static inst make(const char *name)
{
    return fmi3InstantiateCoSimulation(name, PLANT_TOKEN, NULL, fmi3False, fmi3True, fmi3False, fmi3False, NULL, 0,
                                       NULL, logger, NULL);
}
static int enter_init(inst c) { return fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0); }
static int exit_init(inst c) { return fmi3ExitInitializationMode(c); }
static int setup(inst c) { (void)c; return OK; }
static int do_step(inst c, double t, double h)
{
    fmi3Boolean ev, term, early;
    fmi3Float64 last;
    return fmi3DoStep(c, t, h, fmi3True, &ev, &term, &early, &last);
}
static int set_real(inst c, unsigned vr, double v)
{
    fmi3ValueReference r = vr;
    return fmi3SetFloat64(c, &r, 1, &v, 1);
}
static int get_real(inst c, unsigned vr, double *v)
{
    fmi3ValueReference r = vr;
    return fmi3GetFloat64(c, &r, 1, v, 1);
}
static int get_state(inst c, fstate *s) { return fmi3GetFMUState(c, s); }
static int set_state(inst c, fstate s) { return fmi3SetFMUState(c, s); }
static int free_state(inst c, fstate *s) { return fmi3FreeFMUState(c, s); }
static int state_size(inst c, fstate s, size_t *n) { return fmi3SerializedFMUStateSize(c, s, n); }
static int serialize(inst c, fstate s, unsigned char *b, size_t n) { return fmi3SerializeFMUState(c, s, b, n); }
static int deserialize(inst c, const unsigned char *b, size_t n, fstate *s) { return fmi3DeserializeFMUState(c, b, n, s); }
static int terminate(inst c) { return fmi3Terminate(c); }
static void free_instance(inst c) { fmi3FreeInstance(c); }
#else
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...)
{
    va_list ap;
    (void)env;
    (void)name;
    printf("LOG %d %s: ", (int)status, category);
    va_start(ap, message);
    vprintf(message, ap);
    va_end(ap);
    printf("\n");
}

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
static inst make(const char *name)
{
    return fmi2Instantiate(name, fmi2CoSimulation, PLANT_TOKEN, NULL, &callbacks, fmi2False, fmi2True);
}
static int enter_init(inst c) { return fmi2EnterInitializationMode(c); }
static int exit_init(inst c) { return fmi2ExitInitializationMode(c); }
static int setup(inst c) { return fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0); }
static int do_step(inst c, double t, double h) { return fmi2DoStep(c, t, h, fmi2True); }
static int set_real(inst c, unsigned vr, double v)
{
    fmi2ValueReference r = vr;
    return fmi2SetReal(c, &r, 1, &v);
}
static int get_real(inst c, unsigned vr, double *v)
{
    fmi2ValueReference r = vr;
    return fmi2GetReal(c, &r, 1, v);
}
static int get_state(inst c, fstate *s) { return fmi2GetFMUstate(c, s); }
static int set_state(inst c, fstate s) { return fmi2SetFMUstate(c, s); }
static int free_state(inst c, fstate *s) { return fmi2FreeFMUstate(c, s); }
static int state_size(inst c, fstate s, size_t *n) { return fmi2SerializedFMUstateSize(c, s, n); }
static int serialize(inst c, fstate s, unsigned char *b, size_t n) { return fmi2SerializeFMUstate(c, s, (fmi2Byte *)b, n); }
static int deserialize(inst c, const unsigned char *b, size_t n, fstate *s)
{
    return fmi2DeSerializeFMUstate(c, (const fmi2Byte *)b, n, s);
}
static int terminate(inst c) { return fmi2Terminate(c); }
static void free_instance(inst c) { fmi2FreeInstance(c); }
#endif

#endif
