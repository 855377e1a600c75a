/* protocol.c: encode / decode of protocol v1 (see protocol.h). */
#include <math.h>
#include <string.h>
#include "protocol.h"

/* CRC-32/IEEE, reflected polynomial 0xEDB88320, four bits at a time (a 16-entry table: small and portable). */
static const uint32_t CRC_NIBBLE[16] = {
    0x00000000U, 0x1DB71064U, 0x3B6E20C8U, 0x26D930ACU, 0x76DC4190U, 0x6B6B51F4U, 0x4DB26158U, 0x5005713CU,
    0xEDB88320U, 0xF00F9344U, 0xD6D6A3E8U, 0xCB61B38CU, 0x9B64C2B0U, 0x86D3D2D4U, 0xA00AE278U, 0xBDBDF21CU};

uint32_t hhil_crc32(const uint8_t *data, size_t n)
{
    uint32_t crc = 0xFFFFFFFFU;
    size_t i;
    for (i = 0; i < n; i++) {
        crc ^= data[i];
        crc = (crc >> 4) ^ CRC_NIBBLE[crc & 15U];
        crc = (crc >> 4) ^ CRC_NIBBLE[crc & 15U];
    }
    return ~crc;
}

static void put_u16(uint8_t *b, uint16_t v) { b[0] = (uint8_t)v; b[1] = (uint8_t)(v >> 8); }

static void put_u32(uint8_t *b, uint32_t v)
{
    int i;
    for (i = 0; i < 4; i++)
        b[i] = (uint8_t)(v >> (8 * i));
}

static void put_u64(uint8_t *b, uint64_t v)
{
    int i;
    for (i = 0; i < 8; i++)
        b[i] = (uint8_t)(v >> (8 * i));
}

static void put_f64(uint8_t *b, double v)
{
    uint64_t bits;
    memcpy(&bits, &v, 8);
    put_u64(b, bits);
}

static uint16_t get_u16(const uint8_t *b) { return (uint16_t)(b[0] | (b[1] << 8)); }

static uint32_t get_u32(const uint8_t *b)
{
    return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
}

static uint64_t get_u64(const uint8_t *b) { return (uint64_t)get_u32(b) | ((uint64_t)get_u32(b + 4) << 32); }

static double get_f64(const uint8_t *b)
{
    uint64_t bits = get_u64(b);
    double v;
    memcpy(&v, &bits, 8);
    return v;
}

static void put_header(uint8_t *b, const hhil_header *h)
{
    memcpy(b, "HHIL", 4);
    put_u16(b + 4, HHIL_VERSION);
    put_u16(b + 6, h->type);
    put_u32(b + 8, h->seq);
    put_u64(b + 12, (uint64_t)h->t_send_ns);
    put_u64(b + 20, (uint64_t)h->echo_t_ns);
    put_u32(b + 28, h->echo_seq);
}

static size_t seal(uint8_t *b, size_t len)
{
    put_u32(b + len - 4, hhil_crc32(b, len - 4));
    return len;
}

size_t hhil_encode_sensor(uint8_t *b, const hhil_header *h, const hhil_sensor *s)
{
    hhil_header hh = *h;
    hh.type = HHIL_SENSOR;
    put_header(b, &hh);
    put_f64(b + 32, s->t_sim);
    put_u64(b + 40, s->step);
    put_u64(b + 48, (uint64_t)s->encoder_counts);
    put_f64(b + 56, s->p1);
    put_f64(b + 64, s->p2);
    put_f64(b + 72, s->ps);
    put_f64(b + 80, s->pt);
    put_u32(b + 88, s->status);
    b[92] = s->travel_mode;
    b[93] = s->friction_mode;
    b[94] = s->spool_mode;
    b[95] = 0;
    return seal(b, HHIL_SENSOR_LEN);
}

size_t hhil_encode_command(uint8_t *b, const hhil_header *h, const hhil_command *c)
{
    hhil_header hh = *h;
    hh.type = HHIL_COMMAND;
    put_header(b, &hh);
    put_f64(b + 32, c->u);
    put_u32(b + 40, c->flags);
    put_u32(b + 44, 0);
    return seal(b, HHIL_COMMAND_LEN);
}

size_t hhil_encode_simple(uint8_t *b, const hhil_header *h)
{
    put_header(b, h);
    return seal(b, HHIL_SIMPLE_LEN);
}

size_t hhil_encode_signals(uint8_t *b, const hhil_header *h, double t_sim, uint64_t step, uint32_t status,
                           uint32_t layout, const double *values, int n)
{
    hhil_header hh = *h;
    int i;
    hh.type = HHIL_SIGNALS;
    put_header(b, &hh);
    put_f64(b + 32, t_sim);
    put_u64(b + 40, step);
    put_u32(b + 48, status);
    put_u32(b + 52, layout);
    put_u16(b + 56, (uint16_t)n);
    put_u16(b + 58, 0);
    for (i = 0; i < n; i++)
        put_f64(b + 60 + 8 * i, values[i]);
    return seal(b, (size_t)(HHIL_HEADER_LEN + HHIL_SIGNALS_FIXED + 8 * n + 4));
}

/* The length a datagram of its type must have (a circuit packet's from its count); 0: no such type. */
static size_t length_of(uint16_t type, const uint8_t *b, size_t n)
{
    switch (type) {
    case HHIL_SIGNALS:
        return n >= HHIL_HEADER_LEN + HHIL_SIGNALS_FIXED ? HHIL_HEADER_LEN + HHIL_SIGNALS_FIXED + 8 * (size_t)get_u16(b + 56) + 4
                                                        : 0;
    case HHIL_INPUTS:
        return n >= HHIL_HEADER_LEN + HHIL_INPUTS_FIXED ? HHIL_HEADER_LEN + HHIL_INPUTS_FIXED + 8 * (size_t)get_u16(b + 44) + 4
                                                       : 0;
    case HHIL_SENSOR: return HHIL_SENSOR_LEN;
    case HHIL_COMMAND: return HHIL_COMMAND_LEN;
    case HHIL_HELLO:
    case HHIL_BYE: return HHIL_SIMPLE_LEN;
    default: return 0;
    }
}

int hhil_decode(const uint8_t *b, size_t n, hhil_message *msg)
{
    hhil_header *h = &msg->header;
    if (n < HHIL_HEADER_LEN + 4 || n > HHIL_MAX_DATAGRAM)
        return 0;
    if (memcmp(b, "HHIL", 4) != 0 || get_u16(b + 4) != HHIL_VERSION)
        return 0;
    h->type = get_u16(b + 6);
    if (length_of(h->type, b, n) != n || get_u32(b + n - 4) != hhil_crc32(b, n - 4))
        return 0;
    h->seq = get_u32(b + 8);
    h->t_send_ns = (int64_t)get_u64(b + 12);
    h->echo_t_ns = (int64_t)get_u64(b + 20);
    h->echo_seq = get_u32(b + 28);
    if (h->type == HHIL_SENSOR) {
        hhil_sensor *s = &msg->sensor;
        s->t_sim = get_f64(b + 32);
        s->step = get_u64(b + 40);
        s->encoder_counts = (int64_t)get_u64(b + 48);
        s->p1 = get_f64(b + 56);
        s->p2 = get_f64(b + 64);
        s->ps = get_f64(b + 72);
        s->pt = get_f64(b + 80);
        s->status = get_u32(b + 88);
        s->travel_mode = b[92];
        s->friction_mode = b[93];
        s->spool_mode = b[94];
    } else if (h->type == HHIL_COMMAND) {
        msg->command.u = get_f64(b + 32);
        msg->command.flags = get_u32(b + 40);
        if (!isfinite(msg->command.u))
            return 0;              /* NaN/Inf command: a bad packet */
    } else if (h->type == HHIL_INPUTS) {
        hhil_inputs *in = &msg->inputs;
        int i;
        in->layout = get_u32(b + 32);
        in->flags = get_u32(b + 36);
        in->mask = get_u32(b + 40);
        in->n = get_u16(b + 44);
        if (in->n > HHIL_MAX_INPUTS || (in->n < 32 && (in->mask >> in->n) != 0))
            return 0;              /* more values than a mask can name, or a bit beyond them */
        for (i = 0; i < in->n; i++) {
            in->values[i] = get_f64(b + 48 + 8 * i);
            if ((in->mask >> i & 1U) && !isfinite(in->values[i]))
                return 0;          /* a set input that is not finite */
        }
    }
    return 1;
}

size_t hhil_encode_telemetry(uint8_t *buf, uint8_t role, int64_t k0, const int64_t *counters, const double *rows,
                             int ncols, int nrows)
{
    size_t n = HHIL_TM_HEADER_LEN, i;
    memcpy(buf, "HHTM", 4);
    buf[4] = HHIL_TM_VERSION;
    buf[5] = role;
    put_u16(buf + 6, (uint16_t)ncols);
    put_u16(buf + 8, (uint16_t)nrows);
    put_u16(buf + 10, 0);
    put_u64(buf + 12, (uint64_t)k0);
    for (i = 0; i < HHIL_TM_COUNTERS; i++, n += 8)
        put_u64(buf + n, (uint64_t)counters[i]);
    for (i = 0; i < (size_t)ncols * (size_t)nrows; i++, n += 8)
        put_f64(buf + n, rows[i]);
    return n;
}
