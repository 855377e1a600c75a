/* libFuzzer harness of the standalone C plant's decoder (src/hydrohil/export/c/rt/protocol.c).
 *
 * Built and run by `python benchmarks/fuzz.py --libfuzzer SECONDS` (clang -fsanitize=fuzzer,address,undefined;
 * Debian: apt-get install clang libclang-rt-14-dev), seeded with the Python fuzzer's datagrams. Besides the
 * sanitizers' memory and undefined-behaviour checks it asserts two properties of every accepted datagram:
 * its length is the one of its type, and encoding what was decoded and decoding that again gives the same
 * message (nothing is read from outside the datagram, nothing is lost).
 */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "protocol.h"

static int same(const hhil_message *a, const hhil_message *b)
{
    if (memcmp(&a->header, &b->header, sizeof a->header) != 0 && (a->header.type != b->header.type ||
        a->header.seq != b->header.seq || a->header.t_send_ns != b->header.t_send_ns ||
        a->header.echo_t_ns != b->header.echo_t_ns || a->header.echo_seq != b->header.echo_seq))
        return 0;
    if (a->header.type == HHIL_SENSOR) {
        const hhil_sensor *x = &a->sensor, *y = &b->sensor;
        return memcmp(&x->t_sim, &y->t_sim, 8) == 0 && x->step == y->step && x->encoder_counts == y->encoder_counts &&
               memcmp(&x->p1, &y->p1, 8) == 0 && memcmp(&x->p2, &y->p2, 8) == 0 && memcmp(&x->ps, &y->ps, 8) == 0 &&
               memcmp(&x->pt, &y->pt, 8) == 0 && x->status == y->status && x->travel_mode == y->travel_mode &&
               x->friction_mode == y->friction_mode && x->spool_mode == y->spool_mode;
    }
    if (a->header.type == HHIL_COMMAND)
        return memcmp(&a->command.u, &b->command.u, 8) == 0 && a->command.flags == b->command.flags;
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    hhil_message m, again;
    uint8_t buf[HHIL_MAX_DATAGRAM];
    size_t n;
    memset(&m, 0, sizeof m);
    memset(&again, 0, sizeof again);
    if (!hhil_decode(data, size, &m))
        return 0;
    switch (m.header.type) {
    case HHIL_SENSOR: n = hhil_encode_sensor(buf, &m.header, &m.sensor); break;
    case HHIL_COMMAND: n = hhil_encode_command(buf, &m.header, &m.command); break;
    default: n = hhil_encode_simple(buf, &m.header); break;
    }
    if (n != size || !hhil_decode(buf, n, &again) || !same(&m, &again))
        abort();
    return 0;
}
