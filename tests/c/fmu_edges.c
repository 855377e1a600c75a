/* fmu_edges.c: what an importer may do to the FMU that a simulator run does not: calls on a NULL instance,
 * calls in the wrong FMI state, an FMU state set right after instantiation, truncated or foreign serialised
 * states. Built by tests/test_fmu.py with the FMU's own sources under AddressSanitizer and UBSan
 * (-DFMI=2 or -DFMI=3); prints the FMU's messages, "FAIL ..." for a check that did not hold, and exits 1 then. */
#include "fmi_shim.h"
#include "fmu_instance.h"     /* (plant_state_header: where a state's values begin) */
#include "hh_params.h"

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
    {   /* a state of this export whose values ask for another structure of its generated model (the cylinder's
         * bulk modulus law): refused whole, the instance stepping on as before. The value's place: the header,
         * then plant_fmu.c's state_values (par[PLANT_NPAR], six doubles, three int64s, p[HH_NP], ...) */
        size_t at = sizeof(plant_state_header) + sizeof(double) * (PLANT_NPAR + 6) + sizeof(int64_t) * 3
                    + sizeof(double) * HH_CYLINDER_BULK_MODULUS;
        double other;
        fstate s_other = NULL;
        memcpy(copy, bytes, n);
        memcpy(&other, copy + at, sizeof other);
        EXPECT(other == 0.0, "the exported law in the state (eq 21: 0)");
        other = 1.0;
        memcpy(copy + at, &other, sizeof other);
        EXPECT(deserialize(b, copy, n, &s_other) == OK, "a state of this export's format deserialised");
        EXPECT(set_state(b, s_other) == ERR, "a state asking for another structure refused");
        EXPECT(set_real(b, VR_U, 0.1) == OK && do_step(b, 300 * 5e-4, 5e-4) == OK, "b steps on after the refusal");
        free_state(b, &s_other);
    }

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
