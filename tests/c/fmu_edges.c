/* fmu_edges.c: what an importer may do to the FMU that a simulator run does not: calls on a NULL instance,
 * calls in the wrong FMI state, an FMU state set right after instantiation, truncated or foreign serialised
 * states. Built by tests/test_fmu.py with the FMU's own sources under AddressSanitizer and UBSan
 * (-DFMI=2 or -DFMI=3); prints the FMU's messages, "FAIL ..." for a check that did not hold, and exits 1 then. */
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

int main(void)
{
    inst a, b;
    fstate sa = NULL, sb = NULL, bad = NULL;
    unsigned char *bytes, *copy;
    size_t n = 0;
    double v, xa = 0.0, xb = 0.0;
    int k;

    /* 1. no instance */
    EXPECT(do_step(NULL, 0.0, 5e-4) == ERR, "doStep(NULL)");
    EXPECT(enter_init(NULL) == ERR && exit_init(NULL) == ERR && terminate(NULL) == ERR, "init/terminate(NULL)");
    EXPECT(set_real(NULL, VR_U, 0.1) == ERR && get_real(NULL, VR_XP, &v) == ERR, "get/set(NULL)");
    EXPECT(get_state(NULL, &sa) == ERR && set_state(NULL, sa) == ERR && state_size(NULL, sa, &n) == ERR,
           "FMU state calls on NULL");
    EXPECT(deserialize(NULL, (const unsigned char *)"x", 1, &sa) == ERR, "deserialise(NULL)");
    free_instance(NULL);

    /* 2. the wrong state */
    a = make("a");
    EXPECT(a != NULL, "instantiate");
    EXPECT(do_step(a, 0.0, 5e-4) == ERR, "doStep before initialisation");
    EXPECT(exit_init(a) == ERR, "exitInitializationMode before entering it");
    EXPECT(terminate(a) == ERR, "terminate before initialisation");
    EXPECT(get_real(a, VR_XP, &v) == ERR, "an output before initialisation");
    EXPECT(setup(a) == OK && enter_init(a) == OK, "setup and enter initialisation");
    EXPECT(enter_init(a) == ERR, "enterInitializationMode twice");
    EXPECT(get_real(a, VR_XP, &v) == OK && v > 0.0, "an output in initialisation mode");
    EXPECT(exit_init(a) == OK, "exit initialisation");
#if FMI == 2
    EXPECT(setup(a) == ERR, "setupExperiment after initialisation");
#endif
    EXPECT(set_real(a, VR_XP0, 0.1) == ERR, "a parameter after initialisation");

    /* 3. a state taken while stepping, set into an instance that was only instantiated */
    for (k = 0; k < 100; k++) {
        EXPECT(set_real(a, VR_U, 0.3) == OK, "set u");
        EXPECT(do_step(a, k * 5e-4, 5e-4) == OK, "doStep");
    }
    EXPECT(get_state(a, &sa) == OK && state_size(a, sa, &n) == OK && n > 0, "get and size a state");
    bytes = malloc(n);
    copy = malloc(n);
    EXPECT(serialize(a, sa, bytes, n) == OK, "serialise");
    EXPECT(serialize(a, sa, bytes, n - 1) == ERR, "serialise into a buffer one byte short");
    b = make("b");
    EXPECT(deserialize(b, bytes, n, &sb) == OK, "deserialise");
    EXPECT(set_state(b, sb) == OK, "set a state right after instantiation");
    for (k = 100; k < 300; k++) {
        set_real(a, VR_U, -0.2);
        set_real(b, VR_U, -0.2);
        EXPECT(do_step(a, k * 5e-4, 5e-4) == OK && do_step(b, k * 5e-4, 5e-4) == OK, "doStep a, b");
    }
    get_real(a, VR_XP, &xa);
    get_real(b, VR_XP, &xb);
    EXPECT(xa == xb && xa != 0.0, "the restored instance continues exactly");
    printf("xp after the restored run: %.17g %.17g\n", xa, xb);

    /* 4. serialised states that are not this FMU's: each refused, nothing read past the bytes given */
    EXPECT(deserialize(b, bytes, n - 1, &bad) == ERR && bad == NULL, "a state one byte short");
    EXPECT(deserialize(b, bytes, 16, &bad) == ERR && bad == NULL, "a state of 16 bytes");
    EXPECT(deserialize(b, bytes, n + 8, &bad) == ERR, "a state with 8 bytes too many");
    memcpy(copy, bytes, n);
    copy[0] ^= 0x20;
    EXPECT(deserialize(b, copy, n, &bad) == ERR, "a state without the tag");
    memcpy(copy, bytes, n);
    copy[24] += 1;                          /* the format version */
    EXPECT(deserialize(b, copy, n, &bad) == ERR, "a state of another format version");
    memcpy(copy, bytes, n);
    copy[33] = copy[33] == 'a' ? 'b' : 'a';  /* the export's token */
    EXPECT(deserialize(b, copy, n, &bad) == ERR, "a state of another export");
    EXPECT(bad == NULL, "no state made of a refused one");

    /* 5. states taken before initialisation (no delay line yet) set back into a stepping instance; and a
     * doStep that goes back in time */
    {
        inst c = make("c"), d = make("d");
        fstate s_inst = NULL, s_init = NULL;
        double xc = 0.0, xd = 0.0;
        EXPECT(get_state(c, &s_inst) == OK, "a state right after instantiation");
        EXPECT(setup(c) == OK && enter_init(c) == OK && get_state(c, &s_init) == OK, "a state in initialisation");
        EXPECT(exit_init(c) == OK, "exit initialisation (c)");
        for (k = 0; k < 50; k++)
            EXPECT(set_real(c, VR_U, 0.5) == OK && do_step(c, k * 5e-4, 5e-4) == OK, "doStep c");
        EXPECT(do_step(c, 10 * 5e-4, 5e-4) == ERR, "a doStep before the last communication point");
        EXPECT(set_state(c, s_init) == OK, "the initialisation-mode state set back after stepping");
        EXPECT(exit_init(c) == OK, "initialisation completed again");
        EXPECT(set_state(c, s_inst) == OK, "the instantiated state set back");
        EXPECT(do_step(c, 0.0, 5e-4) == ERR, "no doStep in the restored instantiated state");
        EXPECT(setup(c) == OK && enter_init(c) == OK && exit_init(c) == OK, "initialised again");
        EXPECT(setup(d) == OK && enter_init(d) == OK && exit_init(d) == OK, "a fresh instance");
        for (k = 0; k < 200; k++) {
            set_real(c, VR_U, -0.3);
            set_real(d, VR_U, -0.3);
            EXPECT(do_step(c, k * 5e-4, 5e-4) == OK && do_step(d, k * 5e-4, 5e-4) == OK, "doStep c, d");
        }
        get_real(c, VR_XP, &xc);
        get_real(d, VR_XP, &xd);
        EXPECT(xc == xd, "an instance reset through a state runs as a fresh one");
        free_state(c, &s_inst);
        free_state(c, &s_init);
        free_instance(c);
        free_instance(d);
    }

    EXPECT(terminate(a) == OK && terminate(a) == ERR, "terminate once");
    free_state(a, &sa);
    free_state(b, &sb);
    free_state(b, NULL);
    free(bytes);
    free(copy);
    free_instance(a);
    free_instance(b);
    printf("%s: %d failed\n", failures ? "FAILED" : "ok", failures);
    return failures ? 1 : 0;
}
