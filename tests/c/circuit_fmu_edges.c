/* circuit_fmu_edges.c: what an importer may do to a circuit's FMU that a simulator run does not, under
 * AddressSanitizer and UBSan (built by tests/test_circuit_fmu.py with the FMU's own sources): calls on NULL and
 * in the wrong state, inputs set before initialisation (the rest marched again), outputs before initialisation,
 * unknown value references, a state set into a fresh instance continuing exactly, truncated or foreign states.
 * Prints the FMU's messages, "FAIL ..." for a check that did not hold, and exits 1 then. */
#include "fmi_shim.h"

int main(void)
{
    inst a, b;
    fstate sa = NULL, sb = NULL, bad = NULL;
    unsigned char *bytes, *copy;
    size_t n = 0;
    double v, xa = 0.0, xb = 0.0;
    int k;
    const unsigned IN0 = VR_INPUT0, OUT0 = VR_OUTPUT0;

    EXPECT(do_step(NULL, 0.0, 5e-4) == ERR && set_real(NULL, IN0, 0.1) == ERR && get_real(NULL, OUT0, &v) == ERR,
           "calls on NULL");
    a = make("a");
    EXPECT(a != NULL, "instantiate a");
    EXPECT(get_real(a, OUT0, &v) == ERR, "an output before initialisation");
    EXPECT(do_step(a, 0.0, 5e-4) == ERR, "doStep before initialisation");
    EXPECT(set_real(a, 1, 1.0) == ERR && set_real(a, OUT0, 1.0) == ERR, "a parameter or an output set");
    EXPECT(get_real(a, 999999, &v) == ERR, "an unknown value reference");
#if CIRCUIT_NINPUTS > 0
    EXPECT(set_real(a, IN0, 0.0 / 0.0) == ERR, "a NaN input");
    EXPECT(set_real(a, IN0, CIRCUIT_U0[0] * 0.5 + 0.1) == OK, "an input set before initialisation");
#endif
    EXPECT(setup(a) == OK && enter_init(a) == OK, "enter initialisation");
    EXPECT(get_real(a, OUT0, &v) == OK, "an output in initialisation");
    EXPECT(exit_init(a) == OK, "exit initialisation");
    for (k = 0; k < 400; k++)
        EXPECT(do_step(a, k * CIRCUIT_STEP, CIRCUIT_STEP) == OK, "doStep a");
    EXPECT(do_step(a, 0.0, CIRCUIT_STEP) == ERR, "a doStep back in time");
    EXPECT(get_state(a, &sa) == OK && state_size(a, sa, &n) == OK && n > 0, "a state and its size");
    bytes = malloc(n);
    copy = malloc(n + 8);
    EXPECT(serialize(a, sa, bytes, n) == OK, "serialise");
    b = make("b");
    EXPECT(deserialize(b, bytes, n, &sb) == OK && set_state(b, sb) == OK, "a state set into a fresh instance");
    for (k = 400; k < 800; k++) {
        EXPECT(do_step(a, k * CIRCUIT_STEP, CIRCUIT_STEP) == OK && do_step(b, k * CIRCUIT_STEP, CIRCUIT_STEP) == OK,
               "doStep a, b");
    }
    get_real(a, OUT0 + CIRCUIT_NOUTPUTS - 1, &xa);
    get_real(b, OUT0 + CIRCUIT_NOUTPUTS - 1, &xb);
    EXPECT(xa == xb, "the restored instance continues exactly");
    EXPECT(deserialize(b, bytes, n - 1, &bad) == ERR && bad == NULL, "a state one byte short");
    EXPECT(deserialize(b, bytes, 16, &bad) == ERR && bad == NULL, "a state of 16 bytes");
    memcpy(copy, bytes, n);
    memset(copy + n, 0, 8);
    EXPECT(deserialize(b, copy, n + 8, &bad) == ERR, "a state with 8 bytes too many");
    copy[0] ^= 0x20;
    EXPECT(deserialize(b, copy, n, &bad) == ERR, "a state without the tag");
    memcpy(copy, bytes, n);
    copy[24] += 1;
    EXPECT(deserialize(b, copy, n, &bad) == ERR, "a state of another format version");
    memcpy(copy, bytes, n);
    copy[33] = copy[33] == 'a' ? 'b' : 'a';
    EXPECT(deserialize(b, copy, n, &bad) == ERR && bad == NULL, "a state of another export");
    EXPECT(terminate(a) == OK && terminate(a) == ERR, "terminate once");
    free_state(a, &sa);
    free_state(b, &sb);
    free_instance(a);
    free_instance(b);
    free(bytes);
    free(copy);
    printf("ok: %d failed\n", failures);
    return failures ? 1 : 0;
}
