/* protocol.h: hydrohil HIL wire protocol, version 1 (docs/protocol.md), in C for the standalone plant.
 *
 * Every datagram = 32-byte header | payload | CRC-32 (IEEE 802.3, zlib's, over everything before it), all
 * little-endian whatever the host (bytes are written one by one), length fixed by the type. hhil_decode
 * accepts exactly what hydrohil.hil.protocol.decode accepts; nothing here trusts network input.
 */
#ifndef HHIL_PROTOCOL_H
#define HHIL_PROTOCOL_H
#include <stddef.h>
#include <stdint.h>

#define HHIL_VERSION 1
enum { HHIL_SENSOR = 1, HHIL_COMMAND = 2, HHIL_HELLO = 3, HHIL_BYE = 4, HHIL_SIGNALS = 5, HHIL_INPUTS = 6 };
enum { HHIL_HEADER_LEN = 32, HHIL_SENSOR_LEN = 100, HHIL_COMMAND_LEN = 52, HHIL_SIMPLE_LEN = 36,
       HHIL_MAX_DATAGRAM = 1472,                  /* a UDP payload in one Ethernet frame */
       HHIL_SIGNALS_FIXED = 28, HHIL_INPUTS_FIXED = 16,   /* a circuit packet: fixed part, then n float64 */
       HHIL_MAX_SIGNALS = (1472 - 32 - 28 - 4) / 8, HHIL_MAX_INPUTS = 32 };

/* status bits of a SENSOR packet: HH_ST_* of hh_shape.h (generated from core/shape.py, docs/protocol.md) */
enum { HHIL_CMD_STOP = 1 << 0 };   /* COMMAND flags */

typedef struct {
    uint16_t type;
    uint32_t seq;            /* sender's sequence number; SENSOR: the plant step k */
    int64_t t_send_ns;       /* sender's monotonic clock at sending */
    int64_t echo_t_ns;
    uint32_t echo_seq;
} hhil_header;

typedef struct {
    double t_sim;
    uint64_t step;
    int64_t encoder_counts;
    double p1, p2, ps, pt;   /* Pa gauge, as the sensors report */
    uint32_t status;
    uint8_t travel_mode, friction_mode, spool_mode;
} hhil_sensor;

typedef struct {
    double u;                /* valve command in the configured unit */
    uint32_t flags;
} hhil_command;

typedef struct {             /* a circuit's INPUTS: input i set when bit i of mask is (docs/protocol.md) */
    uint32_t layout, flags, mask;
    uint16_t n;
    double values[HHIL_MAX_INPUTS];
} hhil_inputs;

typedef struct {
    hhil_header header;
    hhil_sensor sensor;      /* valid when header.type == HHIL_SENSOR */
    hhil_command command;    /* valid when header.type == HHIL_COMMAND */
    hhil_inputs inputs;      /* valid when header.type == HHIL_INPUTS */
} hhil_message;

uint32_t hhil_crc32(const uint8_t *data, size_t n);
/* Encoders write a whole datagram into buf (at least its length) and return the length. */
size_t hhil_encode_sensor(uint8_t *buf, const hhil_header *h, const hhil_sensor *s);
size_t hhil_encode_command(uint8_t *buf, const hhil_header *h, const hhil_command *c);
size_t hhil_encode_simple(uint8_t *buf, const hhil_header *h);   /* HELLO or BYE */
/* A circuit's SIGNALS: t_sim, step, status, layout and its n values (n <= HHIL_MAX_SIGNALS). */
size_t hhil_encode_signals(uint8_t *buf, const hhil_header *h, double t_sim, uint64_t step, uint32_t status,
                           uint32_t layout, const double *values, int n);
/* 1 and *msg filled for a valid datagram of n bytes; 0 for anything malformed, truncated, corrupted, of
 * another version or type, a command whose u is NaN/Inf, INPUTS with more than HHIL_MAX_INPUTS values, a mask
 * bit beyond them or a set value NaN/Inf (the receiver counts it as bad). SIGNALS are not decoded (a plant
 * never takes them): they are reported valid with their header only. */
int hhil_decode(const uint8_t *buf, size_t n, hhil_message *msg);

/* The panel's side channel (docs/protocol.md, "Panel side channel"; hydrohil.hil.sidechannel): a telemetry
 * datagram = "HHTM", version, role, columns, rows, 0 (u8 u8 u16 u16 u16), first step k0 (i64), 8 counters
 * (i64), rows x columns float64, little-endian. Returns its length. */
enum { HHIL_TM_VERSION = 1, HHIL_TM_ROLE_PLANT = 1, HHIL_TM_HEADER_LEN = 20, HHIL_TM_COUNTERS = 8 };
size_t hhil_encode_telemetry(uint8_t *buf, uint8_t role, int64_t k0, const int64_t *counters, const double *rows,
                             int ncols, int nrows);

#endif
