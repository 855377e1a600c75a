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
    struct sockaddr_in bind, peer, panel;
    char bind_text[128], peer_text[128], panel_text[128];
    int has_peer, allow_remote, lockstep, cpu, has_panel, no_rows;
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
/* A fault TYPE:key=value,... into *f and its end [s] (NaN: none): 0, or -1 with the reason in err. */
int fault_from_spec(const char *text, hh_fault *f, double *end, char *err, size_t size);
/* The fault as a JSON object with every field of its kind (start 0, end null): its length, 0 if too long. */
size_t fault_json(const hh_fault *f, char *buf, size_t size);

/* ---- plant_log.csv (rt_log.c) ----------------------------------------------------------------- */
typedef struct {                 /* the columns of a plant_log.csv: names, and how each is written (PLOG_*) */
    int n;
    const char *const *names;
    const int *kinds;
} log_columns;
extern const log_columns RIG_LOG_COLUMNS;   /* the paper's rig's (core/shape.py PLANT_LOG) */

typedef struct {
    FILE *fh;
    const log_columns *cols;
    double *rows;               /* LOG_RING rows of cols->n */
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
/* %.6g as Python formats it ("nan", "inf", "-inf"; glibc would write "-nan") into buf (32 bytes); returns it. */
const char *fmt_g6(char *buf, double v);
/* One plant-log row as CSV text (modes as names, counters as integers, floats exact) at t; its length. */
size_t format_row(const log_columns *cols, char *t, const double *row);
size_t log_format_row_of(const log_columns *cols, char *t, const double *row);   /* (a panel recording's) */
void log_header_of(const log_columns *cols, FILE *fh);      /* the CSV header line of a plant_log.csv */
/* A writer thread that leaves SIGINT/SIGTERM to the step loop; pthread_create's result. */
int start_writer_thread(pthread_t *thread, void *(*run)(void *), void *arg);
/* DIR/plant_log.csv of these columns with its header, its writer thread started: 0, or -1 with the reason */
int log_open(log_writer *w, const log_columns *cols, const char *dir, char *err, size_t size);
void log_push(log_writer *w, const double *row);   /* never blocks: a row without room is counted, dropped */
void log_close(log_writer *w);                     /* the writer drains the ring, the file is closed */

/* ---- the live panel: side channel, session folder, recordings (rt_side.c) ----------------------- */
#define SIDE_BATCH 20             /* telemetry rows per datagram (10 ms at 0.5 ms), as hil/sidechannel.py */
#define SIDE_SEEN 256             /* steering ids remembered: a retry is answered again, never applied twice */
#define SIDE_QUEUE 16             /* steering that came before the controller spoke: applied at step 0 */
#define SIDE_MSG 8192             /* the longest steering message, and answer, taken */
#define SIDE_POLL_MAX 64          /* steering messages read per batch at most */
#define SIDE_EVENT_LINE 2048      /* one applied event's line of events.jsonl */
#define SIDE_EVENTS 64            /* event lines between the step loop and the session writer */
#define SIDE_RING (1 << 14)       /* commands, and recorded rows, between the step loop and the writer (8 s) */
#define SIDE_MAX_COLUMNS (HHIL_MAX_SIGNALS + HHIL_MAX_INPUTS + 8)   /* a telemetry row's (a circuit's: its link's) */
#define SIDE_MAX_COMMANDS HHIL_MAX_INPUTS   /* commands.f64 values a step at most (a circuit: its inputs) */
#define SIDE_TEXT (1 << 16)       /* the writer's formatted recording rows */
#define SIDE_ROW_TEXT 32          /* characters a logged value takes at most (with its comma) */

/* the counters of a run (or of a recording: since its start) */
typedef struct {
    int64_t packets_rx, packets_bad, packets_foreign, packets_lost, packets_reordered, late_commands,
        packets_dropped_kernel, overruns, watchdog_trips, watchdog_trips_unexplained, commands_delivered;
} run_counts;

typedef struct {
    int used;
    int64_t id;
    char *answer;                 /* NULL until answered (then resent to a retry) */
} side_seen;

/* A recording of the live panel: rows k0+1 .. k1 into dir/plant_log.csv with their own histograms, then its
 * timing.json. The step loop moves it idle -> open (record_start) -> closing (record_stop: rows and timing.json
 * handed over); the session writer moves it back to idle once both are written; the answer waits for that. */
enum { REC_IDLE, REC_OPEN, REC_CLOSING };
typedef struct {
    int state;                    /* REC_*, atomic */
    int active;                   /* the step loop pushes its rows (the loop's own flag) */
    char dir[4096];
    int64_t k0, t0_ns, dropped;
    latency_hist jitter, compute;
    run_counts c0;                /* the counters at its start */
    uint32_t close_head;          /* rows of the ring up to here are the closing recording's */
    char timing[16384];           /* its timing.json, written by the writer */
    size_t timing_len;
    char error[4400];             /* what the writer could not write */
    int64_t answer_id;            /* the record_stop to answer once written (-1: none) */
    char answer[SIDE_MSG];
} recording;

/* The session writer: a thread that writes the session folder's files, so the step loop never writes a file:
 * commands.f64 (a ring of doubles), events.jsonl (a ring of lines), the recording's rows and timing.json. */
typedef struct {
    pthread_t thread;
    int started, quit;            /* quit: atomic */
    FILE *events, *commands, *rec_fh;
    double *cmds;                 /* cmd_room values: SIDE_RING steps' commands at least, a power of two */
    uint32_t cmd_room;
    uint32_t cmd_head, cmd_tail;  /* atomic: head written by the loop, tail by the writer */
    char (*ev)[SIDE_EVENT_LINE];
    uint32_t ev_head, ev_tail;
    double *rows;                 /* SIDE_RING rows of ncols (the model's plant_log.csv columns) */
    int ncols;
    uint32_t row_head, row_tail;
    char *text;                   /* the writer's formatted rows */
    size_t text_len;
    int64_t cmds_dropped;
} side_writer;

typedef struct {
    int sock;                     /* -1: no panel */
    double rows[SIDE_BATCH * SIDE_MAX_COLUMNS];
    int ncols;                    /* the model's telemetry columns (model_side_columns) */
    int n;
    int64_t k0, sent, dropped;
    side_seen seen[SIDE_SEEN];
    int seen_next;
    char queue[SIDE_QUEUE][SIDE_MSG];
    size_t queue_len[SIDE_QUEUE];
    int nqueue;
    int session;                  /* a session folder (--log with --panel): the writer runs */
    side_writer w;
    recording rec;
} side_channel;

/* ---- the plant (rt_plant.c) ------------------------------------------------------------------- */
typedef hh_rig_reading reading;

typedef struct {
    int64_t k;
    int64_t t_mono, t_wall;
} sent_stamp;

typedef struct {
    options *o;
    hh_watchdog *link;          /* the model's command-path watchdog (the rig's, or a circuit's) */
    reading reading;            /* the rig's last sensor readings (for its log row and the panel) */
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
    side_channel side;     /* the live panel (--panel) */
    int64_t t0;            /* the run's start instant (mono_ns) */
    /* os report */
    char os_cpu[80], os_rt[120];
    int os_cpu_granted, timer_slack, memory_locked;
} plant;


int make_dirs(const char *dir);                 /* mkdir -p: 0, or -1 (errno set) (rt_plant.c) */
/* Send sensor packet k (n bytes) to the controller, its send time (t_mono) kept for the round trip (rt_plant.c). */
void transmit(plant *pl, int64_t k, const uint8_t *buf, size_t n, int64_t t_mono);
/* The rig at its initial state (plant time 0) of its fault-free parameters (rt_rig.c). */
void plant_reset(plant *pl);

/* ---- what the plant serves: the paper's rig (rt_rig.c) or a circuit (rt_circuit.c), one of them linked ---- */
int model_init(plant *pl);                      /* after the options: 0, or -1 with the message printed */
void model_reset(plant *pl);                    /* the state a run starts from, plant time 0 */
void model_warm_up(plant *pl);                  /* one step (its pages touched), then model_reset */
int model_accepts(const plant *pl, const hhil_message *msg);    /* a packet it takes: 1 (0: counted bad) */
void model_take(plant *pl, const hhil_message *msg);           /* a COMMAND / INPUTS for the next step */
void model_send_sensor(plant *pl, int64_t k, uint32_t status); /* SENSOR / SIGNALS of the state now, sent */
/* Step k -> k+1 with the command that arrived for it (`arrived`, the rig's *u); *u: the rig's applied command.
 * 0, or -1 with pl->fault describing the divergence (time, modes, state). */
int model_step(plant *pl, int64_t k, int arrived, double *u);
void model_log_row(plant *pl, int64_t k, double wall, int64_t jitter_ns, int64_t compute_ns, double u);
/* Its own members of timing.json, each written as ,\n  "key": value ("faults_injected", a circuit's name, ...). */
void model_timing(const plant *pl, FILE *fh);
void json_string_value(FILE *fh, const char *s);   /* a JSON string, escaped (rt_report.c) */
void model_free(plant *pl);
const log_columns *model_log_columns(void);     /* its plant_log.csv's columns */
/* The run's counters now (rt_report.c). */
run_counts counts_now(const plant *pl);

/* The side channel (rt_side.c); every function does nothing without --panel. */
int side_open(plant *pl);                       /* 0, or -1 with the message printed (before realtime_setup) */
void side_record_row(plant *pl, const double *row, int64_t jitter_ns, int64_t compute_ns);   /* a recording's */
int side_fd(const plant *pl);                   /* its socket (-1: none), to wait on beside the plant's */
void side_poll_waiting(plant *pl);              /* before step 0: "stop" now, the rest queued for step 0 */
void side_apply_queued(plant *pl);              /* at step 0 */
/* Row k of the telemetry (after step k-1, its command u); every SIDE_BATCH rows: send the batch, then apply the
 * steering that came, at the boundary before step k. */
void side_row(plant *pl, int64_t k, const reading *r, int64_t late_ns, int64_t compute_ns, double u);
void side_close(plant *pl, int64_t k_done);     /* recording ended, session files closed, last batch sent */

/* ---- timing.json (rt_report.c) ---------------------------------------------------------------- */
/* room for the longest reason: "the model failed: " and a fault message (fault[600]) */
#define REASON_SIZE 640

/* Write timing.json of the run (same keys as the Python plant's) with its verdict; returns the number of
 * reasons the run is INVALID (0: VALID), the reasons in reasons[]. */
int write_timing(plant *pl, int64_t steps, int64_t t0, int64_t t_end, int64_t drift_ns, FILE *fh,
                 char reasons[][REASON_SIZE]);
/* The same of a recording (its steps, its histograms, its counters since its start; t0: its start). */
int write_timing_window(plant *pl, const recording *win, int64_t steps, int64_t t_end, FILE *fh,
                        char reasons[][REASON_SIZE]);

#endif
