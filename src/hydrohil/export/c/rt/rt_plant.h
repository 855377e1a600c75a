/* rt_plant.h: what the parts of the standalone real-time plant share (`hydrohil export c`).
 *
 *   rt_plant.c    the plant: clock, UDP, the step loop around the core's rig step, main
 *   rt_options.c  the command line: options, --set / --hil / --initial / --fault checked against the
 *                 generated tables (plant_config.h, hh_params.h), --list, --help
 *   rt_log.c      plant_log.csv: a ring of rows filled by the step loop, formatted by a writer thread
 *   rt_report.c   timing.json and the verdict (hydrohil.hil.verdict's rules and words)
 */
#ifndef RT_PLANT_H
#define RT_PLANT_H

#include <netinet/in.h>
#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "hh.h"
#include "latency.h"
#include "plant_config.h"
#include "protocol.h"

#define SENT_RING 64              /* send times of the last sensor packets, for the round trip */

#if defined(__GNUC__)
#define NORETURN __attribute__((noreturn))
#else
#define NORETURN
#endif

/* ---- clocks ------------------------------------------------------------------------------------- */
static inline int64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static inline int64_t wall_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* ---- options (rt_options.c) ------------------------------------------------------------------- */
typedef struct {
    struct sockaddr_in bind, peer;
    char bind_text[128], peer_text[128];
    int has_peer, allow_remote, lockstep, cpu;
    double step, duration;
    const char *log_dir;
    double hil[HIL_N];
    double initial[4];          /* xp [m], xs [-], p1, p2 [Pa] (NaN: at rest) */
    double p[HH_NP];
    hh_fault faults[HH_MAX_FAULTS];   /* --fault: the scheduled faults (start, end [s]: steps set at init) */
    double fault_end[HH_MAX_FAULTS];  /* [s], NaN: to the end of the run */
    int nfault;
} options;

/* the message of a bad argument, then exit 2 (never returns) */
NORETURN void die_usage(const char *fmt, ...);
/* the command line into o (exits 0 after --help / --list, 2 on a bad argument) */
void parse_options(int argc, char **argv, options *o);

/* ---- plant_log.csv (rt_log.c) ----------------------------------------------------------------- */
typedef struct {
    FILE *fh;
    double (*rows)[HH_NPLOG];
    volatile uint32_t head;     /* rows written by the step loop (only it writes head; wraps, LOG_RING | 2^32) */
    volatile uint32_t tail;     /* rows formatted by the writer (only it writes tail) */
    volatile int done;
    int64_t dropped;            /* rows the ring had no room for */
    char *text;                 /* formatted rows not yet written (writer thread) */
    size_t text_len;
    pthread_t thread;
    int started;
} log_writer;

/* Shortest text that reads back to the same double (as Python's repr); "nan" / "inf" / "-inf". */
void fmt_double(char *buf, size_t size, double v);
int log_open(log_writer *w, const char *dir);      /* 0, or -1 with the message printed */
void log_push(log_writer *w, const double *row);   /* never blocks: a row without room is counted, dropped */
void log_close(log_writer *w);                     /* the writer drains the ring, the file is closed */

/* ---- the plant (rt_plant.c) ------------------------------------------------------------------- */
typedef struct {
    int64_t k;
    int64_t t_mono, t_wall;
} sent_stamp;

typedef struct {
    options *o;
    hh_sim sim;
    double *delay_buf;
    hh_rig rig;                 /* the core's rig step: command path, watchdog, faults, sensing */
    double *fifo;               /* network_delay's commands in flight (when a network_delay is given) */
    int sock;
    int kernel_stamps;
    struct sockaddr_in peer;
    int has_peer;
    int64_t n;                  /* steps planned */
    int64_t h_ns, spin_ns;
    int spin;
    /* counters */
    int64_t packets_rx, packets_bad, packets_foreign, packets_lost, packets_reordered, late_commands,
        packets_dropped_kernel, overruns;
    latency_hist jitter, compute, rtt, rtt_seen;
    /* latest command */
    double cmd_u;
    int cmd_new;
    int64_t cmd_seq, cmd_echo, cmd_t_arrival;
    sent_stamp sent[SENT_RING];
    int stop_requested, stop_signal;
    char fault[600], link_error[300];
    log_writer log;
    double row[HH_NPLOG];  /* columns HH_PLOG_* (hh_shape.h) */
    /* os report */
    char os_cpu[80], os_rt[120];
    int os_cpu_granted, timer_slack, memory_locked;
} plant;

typedef hh_rig_reading reading;

/* ---- timing.json (rt_report.c) ---------------------------------------------------------------- */
/* room for the longest reason: "the model failed: " and a fault message (fault[600]) */
#define REASON_SIZE 640

/* Write timing.json of the run (same keys as the Python plant's) with its verdict; returns the number of
 * reasons the run is INVALID (0: VALID), the reasons in reasons[]. */
int write_timing(plant *pl, int64_t steps, int64_t t0, int64_t t_end, int64_t drift_ns, FILE *fh,
                 char reasons[][REASON_SIZE]);

#endif
