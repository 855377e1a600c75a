/* rt_plant.c: hydrohil's standalone real-time plant (`hydrohil export c`), no Python on the target.
 *
 * The same virtual rig as `hydrohil plant` (src/hydrohil/hil/plant.py), from the same C core: the hybrid
 * model (RK3 at a fixed step), the rig's command path with its watchdog and safe state and the pressure
 * transducers (core/rig.c), served over UDP with protocol v1 (docs/protocol.md, protocol.c), locked to the
 * wall clock by absolute deadlines (clock_nanosleep TIMER_ABSTIME on CLOCK_MONOTONIC), SCHED_FIFO and
 * mlockall where permitted (reported in timing.json). It writes the same plant_log.csv (streamed by a
 * writer thread: the step loop only copies a row into a ring) and timing.json with the same keys and the
 * VALID / INVALID verdict of hydrohil.hil.verdict.
 *
 * Timeline of step k (h = plant step, t0 = start instant): sleep until t0 + k*h - spin, spin to t0 + k*h
 * reading arrivals, take the latest valid command (or the watchdog's safe command), advance the model one
 * step, send the sensor packet of the state at (k+1)*h. Jitter = start of step k - (t0 + k*h); an overrun
 * is a step that starts after t0 + (k+1)*h. --lockstep replaces the clock by the exchange itself.
 *
 * Exit codes as hydrohil's: 0 VALID, 3 INVALID (logs and verdict complete), 4 no controller / link lost,
 * 1 the model diverged, 2 bad arguments, 130 / 143 stopped by SIGINT / SIGTERM (logs written).
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define HH_PARAMS_TABLE            /* the parameter table (keys, units, ranges) for --set and --list */
#include "hh.h"
#include "latency.h"
#include "plant_config.h"
#include "protocol.h"

#define SPIN_NS 150000LL          /* busy-wait the last 150 us before a deadline ... */
#define SPIN_FRACTION 0.3         /* ... but at most 30 % of a step (RT throttling) */
#define SENT_RING 64              /* send times of the last sensor packets, for the round trip */
#define LOG_RING (1 << 14)        /* rows between the step loop and the log writer (8 s at 2 kHz) */
#define LOG_FLUSH_ROWS 2000
#define LOG_FLUSH_NS 500000000LL

/* ---- plant_log.csv columns (hydrohil.hil.plant.LOG_COLUMNS) -------------------------------------- */
enum { C_K, C_T, C_WALL, C_JITTER, C_COMPUTE, C_U, C_CMD_SEQ, C_CMD_AGE, C_WATCHDOG, C_XS, C_P1, C_P2, C_XP, C_VP,
       C_FF, C_TRAVEL, C_FRICTION, C_SPOOL, C_ENCODER, C_P1_MEAS, C_P2_MEAS, C_PS_MEAS, C_FAULTS, C_STATUS,
       NCOL };
static const char *const COLUMNS[NCOL] = {
    "k", "t", "wall", "jitter_us", "compute_us", "u", "cmd_seq", "cmd_age", "watchdog", "xs", "p1", "p2", "xp",
    "vp", "ff", "travel_mode", "friction_mode", "spool_mode", "encoder", "p1_meas", "p2_meas", "ps_meas", "faults",
    "status"};
static const char *const TRAVEL_NAMES[] = {"free", "at_retract_stop", "at_extend_stop"};
static const char *const FRICTION_NAMES[] = {"stick", "slip_pos", "slip_neg"};
static const char *const SPOOL_NAMES[] = {"linear", "acc_limited", "vel_limited", "at_end"};

/* ---- clocks ------------------------------------------------------------------------------------- */
static int64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static int64_t wall_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

/* ---- signals ------------------------------------------------------------------------------------ */
static volatile sig_atomic_t g_signal = 0;

static void on_signal(int sig) { g_signal = sig; }

/* ---- options ------------------------------------------------------------------------------------ */
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

#if defined(__GNUC__)
#define NORETURN __attribute__((noreturn))
#else
#define NORETURN
#endif

/* the message of a bad argument, then exit 2 (never returns) */
NORETURN static void die_usage(const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "error: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(hydrohil_plant --help lists the options, --list the parameters and settings)\n");
    exit(2);
}

static void fmt_double(char *buf, size_t size, double v);

static int parse_number(const char *text, double *v)
{
    char *end;
    if (!text || !*text)
        return 0;
    errno = 0;
    *v = strtod(text, &end);
    return *end == '\0' && errno != ERANGE;
}

static void parse_address(const char *opt, const char *text, int allow_remote, struct sockaddr_in *a, char *copy)
{
    char host[100];
    const char *colon = strrchr(text, ':');
    double port = -1.0;
    size_t n;
    if (!colon || !parse_number(colon + 1, &port) || port != floor(port) || port < 0 || port > 65535)
        die_usage("%s %s: expected HOST:PORT, e.g. 127.0.0.1:47000", opt, text);
    n = (size_t)(colon - text);
    if (n >= sizeof host)
        die_usage("%s %s: host name too long", opt, text);
    memcpy(host, text, n);
    host[n] = '\0';
    if (n == 0 || strcmp(host, "localhost") == 0)
        strcpy(host, "127.0.0.1");
    if (!allow_remote && strcmp(host, "127.0.0.1") != 0)
        die_usage("%s %s: binding a non-loopback address exposes the plant to the network; pass --allow-remote",
                  opt, text);
    memset(a, 0, sizeof *a);
    a->sin_family = AF_INET;
    a->sin_port = htons((uint16_t)port);
    if (inet_pton(AF_INET, host, &a->sin_addr) != 1)
        die_usage("%s %s: %s is not an IPv4 address", opt, text, host);
    snprintf(copy, 128, "%s", text);
}

static int param_index(const char *key)
{
    int i;
    for (i = 0; i < HH_NP_SCHEMA; i++)
        if (strcmp(HH_PARAM_INFO[i].key, key) == 0)
            return i;
    return -1;
}

/* option value `word` of a "a|b|c" list: its index, or -1 */
static int option_index(const char *options, const char *word)
{
    int i = 0;
    size_t n = strlen(word);
    const char *s = options;
    while (s && *s) {
        const char *bar = strchr(s, '|');
        size_t len = bar ? (size_t)(bar - s) : strlen(s);
        if (len == n && strncmp(s, word, n) == 0)
            return i;
        i++;
        s = bar ? bar + 1 : NULL;
    }
    return -1;
}

/* the index-th word of a "a|b|c" list into buf */
static void option_word(const char *options, int index, char *buf, size_t size)
{
    const char *s = options;
    int i;
    for (i = 0; i < index && s; i++) {
        s = strchr(s, '|');
        s = s ? s + 1 : NULL;
    }
    if (!s) {
        snprintf(buf, size, "?");
        return;
    }
    snprintf(buf, size, "%.*s", (int)(strchr(s, '|') ? (size_t)(strchr(s, '|') - s) : strlen(s)), s);
}

/* KEY=VALUE of option `opt`: KEY into key (size bytes); returns a pointer to the '=' (exit 2 if none). */
static const char *split_assignment(const char *opt, const char *assignment, char *key, size_t size,
                                    const char *example)
{
    const char *eq = strchr(assignment, '=');
    if (!eq || (size_t)(eq - assignment) >= size)
        die_usage("%s %s: expected KEY=VALUE, e.g. %s %s", opt, assignment, opt, example);
    memcpy(key, assignment, (size_t)(eq - assignment));
    key[eq - assignment] = '\0';
    return eq;
}

static void set_parameter(options *o, const char *assignment)
{
    char key[128];
    const char *eq = split_assignment("--set", assignment, key, sizeof key, "load.mass=300");
    double v;
    int i = param_index(key);
    if (i < 0)
        die_usage("--set %s: no parameter '%s' in the set (--list shows them)", assignment, key);
    if (PLANT_OPTIONS[i] && option_index(PLANT_OPTIONS[i], eq + 1) >= 0)
        v = option_index(PLANT_OPTIONS[i], eq + 1);
    else if (HH_PARAM_INFO[i].kind == HH_KIND_BOOLEAN && (strcmp(eq + 1, "true") == 0 || strcmp(eq + 1, "false") == 0))
        v = strcmp(eq + 1, "true") == 0;
    else if (!parse_number(eq + 1, &v))
        die_usage("--set %s: %s expects a number [%s]%s%s", assignment, key, HH_PARAM_INFO[i].unit,
                  PLANT_OPTIONS[i] ? " or one of " : "", PLANT_OPTIONS[i] ? PLANT_OPTIONS[i] : "");
    o->p[i] = v;
}

static void set_hil(options *o, const char *assignment)
{
    char key[64];
    const char *eq = split_assignment("--hil", assignment, key, sizeof key, "watchdog_timeout=0.1");
    const plant_setting *s = NULL;
    double v;
    int i;
    for (i = 0; i < HIL_N; i++)
        if (strcmp(HIL_SETTINGS[i].key, key) == 0)
            s = &HIL_SETTINGS[i];
    if (!s)
        die_usage("--hil %s: no [hil] setting '%s' in the C plant (--list shows them)", assignment, key);
    i = (int)(s - HIL_SETTINGS);
    if (s->kind == SET_ENUM) {
        v = option_index(s->options, eq + 1);
        if (v < 0)
            die_usage("--hil %s: %s is one of %s", assignment, key, s->options);
    } else if (s->kind == SET_INT) {      /* exact integers: 2^53 + 1 must not round to an admissible 2^53 */
        char *end;
        long long n;
        errno = 0;
        n = strtoll(eq + 1, &end, 10);
        if (!eq[1] || *end || errno == ERANGE || (double)n < s->lo ||
            (s->hi < 9.2e18 && n > (long long)s->hi))
            die_usage("--hil %s: %s must be a whole number >= %g and <= %g", assignment, key, s->lo, s->hi);
        v = (double)n;
    } else {
        if (!parse_number(eq + 1, &v))
            die_usage("--hil %s: %s expects a number [%s]", assignment, key, s->unit);
        if (v < s->lo || (s->lo_strict && v == s->lo) || v > s->hi || (s->hi_strict && v == s->hi))
            die_usage("--hil %s: %s must be %s %g and %s %g [%s]", assignment, key, s->lo_strict ? ">" : ">=", s->lo,
                      s->hi_strict ? "<" : "<=", s->hi, s->unit);
    }
    o->hil[i] = v;
}

static void set_initial(options *o, const char *assignment)
{
    static const char *const keys[4] = {"xp", "xs", "p1", "p2"};
    const char *eq = strchr(assignment, '=');
    int i;
    for (i = 0; i < 4; i++)
        if (eq && (size_t)(eq - assignment) == strlen(keys[i]) && strncmp(assignment, keys[i], 2) == 0)
            break;
    if (i == 4)
        die_usage("--initial %s: expected xp=M, xs=X, p1=PA or p2=PA (nan: at rest)", assignment);
    if (!parse_number(eq + 1, &o->initial[i]))
        die_usage("--initial %s: not a number", assignment);
}

/* One --fault TYPE:key=value,... (the [[faults]] entry of a scenario; FAULT_KINDS: the schema's fields). */
static void set_fault(options *o, const char *text)
{
    char buf[512], *type, *rest, *item, *save = NULL;
    const fault_kind *kind = NULL;
    hh_fault *f;
    int i, given[6] = {0, 0, 0, 0, 0, 0};
    if (o->nfault >= HH_MAX_FAULTS)
        die_usage("--fault %s: at most %d faults", text, HH_MAX_FAULTS);
    snprintf(buf, sizeof buf, "%s", text);
    type = buf;
    rest = strchr(buf, ':');
    if (rest)
        *rest++ = '\0';
    for (i = 0; i < HH_NFAULT_TYPES; i++)
        if (strcmp(FAULT_KINDS[i].type, type) == 0)
            kind = &FAULT_KINDS[i];
    if (!kind) {
        fprintf(stderr, "error: --fault %s: unknown fault type '%s'; one of:", text, type);
        for (i = 0; i < HH_NFAULT_TYPES; i++)
            fprintf(stderr, " %s", FAULT_KINDS[i].type);
        fprintf(stderr, "\n");
        exit(2);
    }
    f = &o->faults[o->nfault];
    memset(f, 0, sizeof *f);
    f->type = (int)(kind - FAULT_KINDS);
    f->a = f->b = NAN;
    o->fault_end[o->nfault] = NAN;
    for (i = 0; i < kind->nfields; i++) {      /* defaults */
        const fault_field *fd = &kind->fields[i];
        if (fd->slot == FIELD_A)
            f->a = fd->value;
        else if (fd->slot == FIELD_B)
            f->b = fd->value;
    }
    for (item = rest ? strtok_r(rest, ",", &save) : NULL; item; item = strtok_r(NULL, ",", &save)) {
        char *eq = strchr(item, '=');
        const fault_field *fd = NULL;
        double v;
        int j;
        if (eq)
            *eq++ = '\0';
        for (j = 0; j < kind->nfields; j++)
            if (strcmp(kind->fields[j].key, item) == 0)
                fd = &kind->fields[j];
        if (!eq || !fd) {
            fprintf(stderr, "error: --fault %s: %s has no field '%s'; its fields:", text, kind->type, item);
            for (j = 0; j < kind->nfields; j++)
                fprintf(stderr, " %s", kind->fields[j].key);
            fprintf(stderr, "\n");
            exit(2);
        }
        j = (int)(fd - kind->fields);
        if (fd->slot == FIELD_SENSOR) {
            v = option_index(fd->options, eq);
            if (v < 0)
                die_usage("--fault %s: %s is one of %s, got '%s'", text, fd->key, fd->options, eq);
        } else {
            if (!parse_number(eq, &v) || !isfinite(v))
                die_usage("--fault %s: %s: not a number: '%s'", text, fd->key, eq);
            if (fd->options) {             /* numbers of a list (hose_burst's line) */
                char word[32];
                snprintf(word, sizeof word, "%g", v);
                if (option_index(fd->options, word) < 0)
                    die_usage("--fault %s: %s is one of %s, got %s", text, fd->key, fd->options, eq);
            } else if ((fd->lo_strict ? !(v > fd->lo) : !(v >= fd->lo)) || (fd->hi_strict ? !(v < fd->hi) : !(v <= fd->hi))) {
                die_usage("--fault %s: %s must be %s %g and %s %g %s, got %s", text, fd->key, fd->lo_strict ? ">" : ">=",
                          fd->lo, fd->hi_strict ? "<" : "<=", fd->hi, fd->unit, eq);
            }
        }
        given[j] = 1;
        switch (fd->slot) {
        case FIELD_START: f->start = v; break;
        case FIELD_END: o->fault_end[o->nfault] = v; break;
        case FIELD_SENSOR: f->sensor = (int)v; break;
        case FIELD_A: f->a = v; break;
        default: f->b = v;
        }
    }
    for (i = 0; i < kind->nfields; i++)
        if (kind->fields[i].required && !given[i])
            die_usage("--fault %s: %s needs %s", text, kind->type, kind->fields[i].key);
    /* the schema's rules across fields (simulation/faults.py) */
    if (!isnan(o->fault_end[o->nfault]) && !(o->fault_end[o->nfault] > f->start))
        die_usage("--fault %s: end (%g s) must be after start (%g s)", text, o->fault_end[o->nfault], f->start);
    if (f->type == HH_FAULT_LOAD_CHANGE && isnan(f->a) && isnan(f->b))
        die_usage("--fault %s: load_change needs mass and/or force", text);
    o->nfault++;
}

static void list_settings(const options *o)
{
    char v[40];
    int i;
    printf("parameters (--set KEY=VALUE; this export's values):\n");
    for (i = 0; i < HH_NP_SCHEMA; i++) {
        const hh_param_info *s = &HH_PARAM_INFO[i];
        if (PLANT_OPTIONS[i])
            option_word(PLANT_OPTIONS[i], (int)o->p[i], v, sizeof v);
        else if (s->kind == HH_KIND_BOOLEAN)
            snprintf(v, sizeof v, "%s", o->p[i] != 0.0 ? "true" : "false");
        else
            fmt_double(v, sizeof v, o->p[i]);
        printf("  %-34s %-22s [%s]", s->key, v, s->unit);
        if (PLANT_OPTIONS[i])
            printf("  one of %s (by name or index)", PLANT_OPTIONS[i]);
        else if (s->kind == HH_KIND_BOOLEAN)
            printf("  true | false");
        else if (isfinite(s->lo) || isfinite(s->hi))
            printf("  %s %g .. %g %s", s->lo_strict ? "(" : "[", s->lo, s->hi, s->hi_strict ? ")" : "]");
        printf("\n");
    }
    printf("[hil] settings (--hil KEY=VALUE):\n");
    for (i = 0; i < HIL_N; i++) {
        const plant_setting *s = &HIL_SETTINGS[i];
        if (s->kind == SET_ENUM) {
            option_word(s->options, (int)o->hil[i], v, sizeof v);
            printf("  %-24s %-12s one of %s: %s\n", s->key, v, s->options, s->description);
        }
        else
            printf("  %-24s %-12g [%s] %s%g .. %g%s: %s\n", s->key, o->hil[i], s->unit, s->lo_strict ? "(" : "[", s->lo,
                   s->hi, s->hi_strict ? ")" : "]", s->description);
    }
    printf("initial state (--initial KEY=VALUE): xp %g m, xs %g, p1 %g Pa, p2 %g Pa (nan: at rest: the spool offset "
           "that holds the piston, the pressures balancing the chambers' flows)\n",
           o->initial[0], o->initial[1], o->initial[2], o->initial[3]);
    printf("faults (--fault TYPE:KEY=VALUE,...; %d given):\n", o->nfault);
    for (i = 0; i < HH_NFAULT_TYPES; i++) {
        const fault_kind *kd = &FAULT_KINDS[i];
        int j;
        printf("  %-20s", kd->type);
        for (j = 0; j < kd->nfields; j++) {
            const fault_field *fd = &kd->fields[j];
            printf(" %s%s%s%s", fd->key, fd->required ? "" : "?", fd->options ? " in " : "",
                   fd->options ? fd->options : "");
            if (!fd->options && strcmp(fd->unit, "-") != 0)
                printf(" %s", fd->unit);
        }
        printf("\n");
    }
}

static void usage(void)
{
    printf("usage: hydrohil_plant [options]\n"
           "Serve the virtual rig (%s) over UDP, protocol v1 (docs/protocol.md), locked to the wall clock.\n\n"
           "  --bind HOST:PORT      listen address (default 127.0.0.1:47000; port 0: any free port, see READY)\n"
           "  --peer HOST:PORT      accept commands only from this address (default: the first valid sender)\n"
           "  --allow-remote        allow a non-loopback --bind / --peer\n"
           "  --step S              plant step [s] (default %g)\n"
           "  --duration S          simulated time to serve [s] (default %g)\n"
           "  --log DIR             write DIR/plant_log.csv (streamed) and DIR/timing.json\n"
           "  --lockstep            advance one step per command, as fast as possible (no clock)\n"
           "  --cpu N               pin the plant to CPU N\n"
           "  --set KEY=VALUE       a parameter of the set (--list shows keys, units, ranges, values)\n"
           "  --hil KEY=VALUE       a [hil] setting (watchdog_timeout, safe_state, command_scale, ...)\n"
           "  --initial KEY=VALUE   initial state: xp [m], xs [-], p1 / p2 [Pa] (nan, the default: at rest)\n"
           "  --fault TYPE:KEY=VALUE,...  a scheduled fault, as a [[faults]] entry (repeatable), e.g.\n"
           "                        --fault hose_burst:start=2,end=2.3,line=2 (--list shows the types and fields)\n"
           "  --connect-timeout S   wait this long for the controller's first packet (= --hil connect_timeout=S)\n"
           "  --list                print the parameters, settings and initial state, then exit\n\n"
           "Prints READY host:port once bound, PEER host:port once the controller spoke, the verdict at the end.\n"
           "Exit: 0 VALID, 3 INVALID, 4 no controller / link lost, 1 model diverged, 2 bad arguments, 130/143 signal.\n",
           PLANT_DESCRIPTION, PLANT_STEP_DEFAULT, PLANT_DURATION_DEFAULT);
}

static void parse_options(int argc, char **argv, options *o)
{
    enum { O_BIND = 1, O_PEER, O_REMOTE, O_STEP, O_DURATION, O_LOG, O_LOCKSTEP, O_CPU, O_SET, O_HIL, O_INITIAL,
           O_CONNECT, O_FAULT, O_LIST, O_HELP };
    static const struct option longs[] = {
        {"bind", required_argument, 0, O_BIND}, {"peer", required_argument, 0, O_PEER},
        {"allow-remote", no_argument, 0, O_REMOTE}, {"step", required_argument, 0, O_STEP},
        {"duration", required_argument, 0, O_DURATION}, {"log", required_argument, 0, O_LOG},
        {"lockstep", no_argument, 0, O_LOCKSTEP}, {"cpu", required_argument, 0, O_CPU},
        {"set", required_argument, 0, O_SET}, {"hil", required_argument, 0, O_HIL},
        {"initial", required_argument, 0, O_INITIAL}, {"connect-timeout", required_argument, 0, O_CONNECT},
        {"fault", required_argument, 0, O_FAULT},
        {"list", no_argument, 0, O_LIST}, {"help", no_argument, 0, O_HELP}, {0, 0, 0, 0}};
    const char *bind_text = "127.0.0.1:47000", *peer_text = NULL;
    char msg[400], buf[80];
    int c, i, list = 0;
    double v;
    memset(o, 0, sizeof *o);
    o->cpu = -1;
    o->step = PLANT_STEP_DEFAULT;
    o->duration = PLANT_DURATION_DEFAULT;
    for (i = 0; i < HIL_N; i++)
        o->hil[i] = HIL_SETTINGS[i].value;
    for (i = 0; i < 4; i++)
        o->initial[i] = PLANT_INITIAL[i];
    for (i = 0; i < HH_NP_SCHEMA; i++)
        o->p[i] = PLANT_PARAMS[i];
    opterr = 0;
    while ((c = getopt_long(argc, argv, "", longs, NULL)) != -1) {
        switch (c) {
        case O_BIND: bind_text = optarg; break;
        case O_PEER: peer_text = optarg; break;
        case O_REMOTE: o->allow_remote = 1; break;
        case O_STEP:
            if (!parse_number(optarg, &o->step) || !(o->step > 1e-6 && o->step <= 0.01))
                die_usage("--step %s: the plant step must be > 1e-06 and <= 0.01 [s]", optarg);
            break;
        case O_DURATION:
            if (!parse_number(optarg, &o->duration) || !(o->duration > 0 && o->duration <= 1e6))
                die_usage("--duration %s: must be > 0 and <= 1e6 [s]", optarg);
            break;
        case O_LOG: o->log_dir = optarg; break;
        case O_LOCKSTEP: o->lockstep = 1; break;
        case O_CPU:
            if (!parse_number(optarg, &v) || v != floor(v) || v < 0 || v > 4095)
                die_usage("--cpu %s: a CPU number >= 0", optarg);
            o->cpu = (int)v;
            break;
        case O_SET: set_parameter(o, optarg); break;
        case O_HIL: set_hil(o, optarg); break;
        case O_INITIAL: set_initial(o, optarg); break;
        case O_FAULT: set_fault(o, optarg); break;
        case O_CONNECT:
            snprintf(buf, sizeof buf, "connect_timeout=%s", optarg);
            set_hil(o, buf);
            break;
        case O_LIST: list = 1; break;
        case O_HELP: usage(); exit(0);
        default: die_usage("unknown option or missing value: %s", argv[optind - 1]);
        }
    }
    if (optind < argc)
        die_usage("unexpected argument %s", argv[optind]);
    if (nearbyint(o->duration / o->step) >= 2147483647.0)    /* sequence numbers are u32 on the wire */
        die_usage("--duration %g with --step %g: at most 2^31 - 1 steps per run", o->duration, o->step);
    if (hh_params_check(o->p, msg, sizeof msg) >= 0)
        die_usage("%s", msg);
    if (list) {
        list_settings(o);
        exit(0);
    }
    if (!(o->initial[0] >= 0.0 && o->initial[0] <= o->p[HH_CYLINDER_STROKE]) ||
        !(isnan(o->initial[1]) || (o->initial[1] >= -1.0 && o->initial[1] <= 1.0)))
        die_usage("--initial: need 0 <= xp <= cylinder.stroke (%g m) and -1 <= xs <= 1 (or nan), got xp %g, xs %g",
                  o->p[HH_CYLINDER_STROKE], o->initial[0], o->initial[1]);
    parse_address("--bind", bind_text, o->allow_remote, &o->bind, o->bind_text);
    if (peer_text) {
        parse_address("--peer", peer_text, o->allow_remote, &o->peer, o->peer_text);
        o->has_peer = 1;
    }
}

/* ---- numbers as text ---------------------------------------------------------------------------- */
/* Shortest text that reads back to the same double (as Python's repr); "nan" / "inf" / "-inf". */
static void fmt_double(char *buf, size_t size, double v)
{
    int prec;
    if (isnan(v)) {
        snprintf(buf, size, "nan");
        return;
    }
    if (isinf(v)) {
        snprintf(buf, size, v > 0 ? "inf" : "-inf");
        return;
    }
    for (prec = 15; prec < 17; prec++) {
        snprintf(buf, size, "%.*g", prec, v);
        if (strtod(buf, NULL) == v)
            return;
    }
    snprintf(buf, size, "%.17g", v);
}

/* ---- the log writer: a ring of rows filled by the step loop, formatted by a thread --------------- */
typedef struct {
    FILE *fh;
    double (*rows)[NCOL];
    volatile uint32_t head;     /* rows written by the step loop (only it writes head; wraps, LOG_RING | 2^32) */
    volatile uint32_t tail;     /* rows formatted by the writer (only it writes tail) */
    volatile int done;
    int64_t dropped;            /* rows the ring had no room for */
    char *text;                 /* formatted rows not yet written (writer thread) */
    size_t text_len;
    pthread_t thread;
    int started;
} log_writer;

#define LOG_TEXT (1 << 20)          /* formatted rows handed to the OS as whole lines */

/* One row as CSV text (modes as names, counters as integers, floats exact) at t; returns its length. */
static size_t format_row(char *t, const double *r)
{
    char v[40];
    size_t n = 0;
    int j;
    for (j = 0; j < NCOL; j++) {
        const char *word = NULL;
        if (j)
            t[n++] = ',';
        switch (j) {
        case C_TRAVEL: word = TRAVEL_NAMES[(int)r[j] % 3]; break;
        case C_FRICTION: word = FRICTION_NAMES[(int)r[j] % 3]; break;
        case C_SPOOL: word = SPOOL_NAMES[(int)r[j] % 4]; break;
        case C_K: case C_CMD_SEQ: case C_CMD_AGE: case C_WATCHDOG: case C_ENCODER: case C_FAULTS: case C_STATUS:
            snprintf(v, sizeof v, "%lld", (long long)r[j]);
            word = v;
            break;
        default:
            fmt_double(v, sizeof v, r[j]);
            /* Python's repr of a whole float keeps ".0": the same text in both plants' logs */
            if (isfinite(r[j]) && !strpbrk(v, ".e"))
                strcat(v, ".0");
            word = v;
        }
        memcpy(t + n, word, strlen(word));
        n += strlen(word);
    }
    t[n++] = '\n';
    return n;
}

/* Hand the formatted text to the OS: whole lines only, so a plant killed with SIGKILL leaves a log that
 * ends with a complete row. */
static void flush_text(log_writer *w)
{
    size_t done = 0;
    while (done < w->text_len) {
        ssize_t k = write(fileno(w->fh), w->text + done, w->text_len - done);
        if (k < 0) {
            if (errno == EINTR)
                continue;
            break;
        }
        done += (size_t)k;
    }
    w->text_len = 0;
}

static void *log_thread(void *arg)
{
    log_writer *w = arg;
    int64_t last_flush = mono_ns();
    uint64_t since_flush = 0;
    for (;;) {
        uint32_t head = __atomic_load_n(&w->head, __ATOMIC_ACQUIRE), tail = w->tail;
        int done = __atomic_load_n(&w->done, __ATOMIC_ACQUIRE);
        while (tail != head) {
            if (w->text_len + 2048 > LOG_TEXT)
                flush_text(w);
            w->text_len += format_row(w->text + w->text_len, w->rows[tail % LOG_RING]);
            tail++;
            since_flush++;
            __atomic_store_n(&w->tail, tail, __ATOMIC_RELEASE);
        }
        if (since_flush >= LOG_FLUSH_ROWS || (since_flush && mono_ns() - last_flush >= LOG_FLUSH_NS)) {
            flush_text(w);          /* a plant killed with SIGKILL leaves a readable log to here */
            since_flush = 0;
            last_flush = mono_ns();
        }
        if (done && tail == __atomic_load_n(&w->head, __ATOMIC_ACQUIRE))
            break;
        if (tail == head) {
            struct timespec nap = {0, 2000000};   /* 2 ms: the step loop never signals (no syscall for it) */
            nanosleep(&nap, NULL);
        }
    }
    flush_text(w);
    return NULL;
}

static int log_open(log_writer *w, const char *dir)
{
    char path[4096];
    int j;
    memset(w, 0, sizeof *w);
    if (!dir)
        return 0;
    snprintf(path, sizeof path, "%s/plant_log.csv", dir);
    w->fh = fopen(path, "w");
    if (!w->fh) {
        fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
        return -1;
    }
    w->rows = calloc(LOG_RING, sizeof *w->rows);
    w->text = malloc(LOG_TEXT);
    if (!w->rows || !w->text) {
        fprintf(stderr, "error: out of memory for the log ring\n");
        return -1;
    }
    for (j = 0; j < NCOL; j++)
        fprintf(w->fh, "%s%s", j ? "," : "", COLUMNS[j]);
    fputc('\n', w->fh);
    fflush(w->fh);              /* the header by stdio; the rows by write(2) on the same descriptor */
    {
        sigset_t block, old;
        int rc;
        sigemptyset(&block);
        sigaddset(&block, SIGINT);
        sigaddset(&block, SIGTERM);
        pthread_sigmask(SIG_BLOCK, &block, &old);      /* the writer inherits the mask: signals go to the loop */
        rc = pthread_create(&w->thread, NULL, log_thread, w);
        pthread_sigmask(SIG_SETMASK, &old, NULL);
        if (rc != 0) {
            fprintf(stderr, "error: cannot start the log writer thread\n");
            return -1;
        }
    }
    w->started = 1;
    return 0;
}

static void log_push(log_writer *w, const double *row)
{
    uint32_t head = w->head;
    if (!w->fh)
        return;
    if ((uint32_t)(head - __atomic_load_n(&w->tail, __ATOMIC_ACQUIRE)) >= LOG_RING) {
        w->dropped++;               /* the writer fell 8 s behind: lose a row, never a step */
        return;
    }
    memcpy(w->rows[head % LOG_RING], row, sizeof(double) * NCOL);
    __atomic_store_n(&w->head, head + 1U, __ATOMIC_RELEASE);
}

static void log_close(log_writer *w)
{
    if (!w->fh)
        return;
    if (w->started) {
        __atomic_store_n(&w->done, 1, __ATOMIC_RELEASE);
        pthread_join(w->thread, NULL);
    }
    fclose(w->fh);
    free(w->rows);
    free(w->text);
    w->fh = NULL;
}

/* ---- the plant ---------------------------------------------------------------------------------- */
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
    double row[NCOL];
    /* os report */
    char os_cpu[80], os_rt[120];
    int os_cpu_granted, timer_slack, memory_locked;
} plant;

typedef hh_rig_reading reading;

/* The sensors' readings (the core's rig step, as the Python plant's) and the status bits of the wire. */
static void read_sensors(plant *pl, reading *r)
{
    hh_rig_sense(&pl->rig, r);
    r->status |= pl->o->lockstep ? HHIL_ST_LOCKSTEP : 0;
}

static void send_to_peer(plant *pl, const uint8_t *buf, size_t n)
{
    if (pl->has_peer)
        sendto(pl->sock, buf, n, 0, (const struct sockaddr *)&pl->peer, sizeof pl->peer);
}

static void send_sensor(plant *pl, int64_t k, uint32_t status, reading *r)
{
    uint8_t buf[HHIL_SENSOR_LEN];
    hhil_header h;
    hhil_sensor s;
    sent_stamp *st;
    read_sensors(pl, r);
    r->status |= status;
    h.type = HHIL_SENSOR;
    h.seq = (uint32_t)k;
    h.t_send_ns = mono_ns();
    h.echo_t_ns = pl->cmd_t_arrival;
    h.echo_seq = (uint32_t)(pl->cmd_seq > 0 ? pl->cmd_seq : 0);
    s.t_sim = pl->sim.out[HH_OUT_T];
    s.step = (uint64_t)k;
    s.encoder_counts = r->encoder;
    s.p1 = r->p[0];
    s.p2 = r->p[1];
    s.ps = r->p[2];
    s.pt = r->p[3];
    s.status = r->status;
    s.travel_mode = (uint8_t)pl->sim.m[HH_M_TRAVEL];
    s.friction_mode = (uint8_t)pl->sim.m[HH_M_FRICTION];
    s.spool_mode = (uint8_t)pl->sim.m[HH_M_SPOOL];
    hhil_encode_sensor(buf, &h, &s);
    st = &pl->sent[k % SENT_RING];
    st->k = k;
    st->t_mono = h.t_send_ns;
    st->t_wall = wall_ns();
    send_to_peer(pl, buf, sizeof buf);
}

static int same_address(const struct sockaddr_in *a, const struct sockaddr_in *b)
{
    return a->sin_addr.s_addr == b->sin_addr.s_addr && a->sin_port == b->sin_port;
}

static void receive(plant *pl, const uint8_t *data, size_t n, const struct sockaddr_in *from, int64_t t_arr,
                    int64_t t_kernel)
{
    hhil_message msg;
    if (!hhil_decode(data, n, &msg)) {
        pl->packets_bad++;
        return;
    }
    if (!pl->has_peer) {
        pl->peer = *from;
        pl->has_peer = 1;
    } else if (!same_address(from, &pl->peer)) {
        pl->packets_foreign++;
        return;
    }
    pl->packets_rx++;
    if (msg.header.type == HHIL_COMMAND) {
        int64_t seq = msg.header.seq;
        sent_stamp *st;
        if (seq <= pl->cmd_seq) {
            pl->packets_reordered++;
            return;
        }
        if (pl->cmd_seq >= 0 && seq > pl->cmd_seq + 1)
            pl->packets_lost += seq - pl->cmd_seq - 1;
        pl->cmd_seq = seq;
        pl->cmd_echo = msg.header.echo_seq;
        pl->cmd_t_arrival = t_arr;
        pl->cmd_u = msg.command.u / pl->o->hil[HIL_COMMAND_SCALE];
        pl->cmd_new = 1;
        st = &pl->sent[msg.header.echo_seq % SENT_RING];
        if (st->k == (int64_t)msg.header.echo_seq) {
            latency_add(&pl->rtt_seen, t_arr - st->t_mono);
            latency_add(&pl->rtt, t_kernel >= 0 ? t_kernel - st->t_wall : t_arr - st->t_mono);
            st->k = -1;
        }
        if (msg.command.flags & HHIL_CMD_STOP)
            pl->stop_requested = 1;
    } else if (msg.header.type == HHIL_BYE) {
        pl->stop_requested = 1;
    }
}

/* Read the datagrams waiting on the socket (non-blocking), at most `max`, with their kernel arrival stamps. */
static void drain_at_most(plant *pl, int max)
{
    uint8_t data[HHIL_MAX_DATAGRAM + 1];
    char control[256];
    for (; max > 0; max--) {
        struct sockaddr_in from;
        struct iovec iov = {data, sizeof data};
        struct msghdr mh;
        struct cmsghdr *cm;
        int64_t t_kernel = -1;
        ssize_t n;
        memset(&mh, 0, sizeof mh);
        mh.msg_name = &from;
        mh.msg_namelen = sizeof from;
        mh.msg_iov = &iov;
        mh.msg_iovlen = 1;
        mh.msg_control = control;
        mh.msg_controllen = sizeof control;
        n = recvmsg(pl->sock, &mh, MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return;                 /* EAGAIN: empty (other errors, e.g. ICMP refusals: nothing to read) */
        }
        for (cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm)) {
            if (cm->cmsg_level != SOL_SOCKET)
                continue;
            if (cm->cmsg_type == SO_TIMESTAMPNS) {
                struct timespec ts;
                memcpy(&ts, CMSG_DATA(cm), sizeof ts);
                t_kernel = (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
            }
#ifdef SO_RXQ_OVFL
            else if (cm->cmsg_type == SO_RXQ_OVFL) {
                uint32_t drops;
                memcpy(&drops, CMSG_DATA(cm), sizeof drops);
                pl->packets_dropped_kernel = drops;
            }
#endif
        }
        receive(pl, data, (size_t)n, &from, mono_ns(), t_kernel);
    }
}

static void drain(plant *pl) { drain_at_most(pl, 1 << 30); }

static void check_signal(plant *pl)
{
    if (g_signal) {
        pl->stop_requested = 1;
        pl->stop_signal = g_signal;
    }
}

/* Wait for step k's instant `deadline`: sleep on the socket until spin_ns before it (reading arrivals as
 * they come, as the Python plant's select does), then clock_nanosleep to that absolute instant (the
 * remainder ppoll's relative timeout left), then spin to the deadline reading arrivals. */
static void wait_until(plant *pl, int64_t deadline)
{
    int64_t wake = deadline - pl->spin_ns, left;
    struct pollfd fd = {0, POLLIN, 0};
    fd.fd = pl->sock;
    while ((left = wake - mono_ns()) > 0 && !pl->stop_requested) {
        struct timespec rel = {(time_t)(left / 1000000000LL), (long)(left % 1000000000LL)};
        if (ppoll(&fd, 1, &rel, NULL) > 0)
            drain(pl);
        check_signal(pl);
    }
    if (wake > mono_ns() && !pl->stop_requested) {
        struct timespec ts = {(time_t)(wake / 1000000000LL), (long)(wake % 1000000000LL)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
            check_signal(pl);
            if (pl->stop_requested)
                break;
        }
    }
    while (mono_ns() < deadline)
        drain(pl);
}

/* Block until the command answering sensor packet k arrives (lock-step); a controller silent for
 * [hil] link_timeout ends the run with a link error. */
static void wait_lockstep(plant *pl, int64_t k)
{
    int64_t limit = mono_ns() + (int64_t)(pl->o->hil[HIL_LINK_TIMEOUT] * 1e9);
    while (pl->cmd_echo < k && !pl->stop_requested) {
        int64_t left = limit - mono_ns();
        struct pollfd fd = {pl->sock, POLLIN, 0};
        if (left <= 0) {
            snprintf(pl->link_error, sizeof pl->link_error, "controller silent for %g s at step %lld (lock-step)",
                     pl->o->hil[HIL_LINK_TIMEOUT], (long long)k);
            pl->stop_requested = 1;
            return;
        }
        if (poll(&fd, 1, (int)(left < 200000000LL ? left / 1000000 + 1 : 200)) > 0)
            drain(pl);
        check_signal(pl);
    }
}

/* Block until a valid packet from the (configured or first) controller, at most [hil] connect_timeout. */
static int wait_for_controller(plant *pl)
{
    int64_t end = mono_ns() + (int64_t)(pl->o->hil[HIL_CONNECT_TIMEOUT] * 1e9);
    while (pl->packets_rx == 0 && !pl->stop_requested) {
        int64_t left = end - mono_ns();
        struct pollfd fd = {pl->sock, POLLIN, 0};
        if (left <= 0)
            return 0;
        if (poll(&fd, 1, (int)(left < 200000000LL ? left / 1000000 + 1 : 200)) > 0)
            drain_at_most(pl, 1);       /* one at a time: a command queued behind the HELLO is step 0's */
        check_signal(pl);
    }
    return pl->packets_rx > 0;
}

/* What step k uses: the command that arrived for it (1, *u) or none (0). Counts a late command. */
static int take_command(plant *pl, int64_t k, double *u)
{
    if (pl->cmd_echo < k && !pl->rig.link.active)
        pl->late_commands++;
    if (!pl->cmd_new)
        return 0;
    pl->cmd_new = 0;
    *u = pl->cmd_u;
    return 1;
}

static void log_row(plant *pl, int64_t k, const reading *r, double wall, int64_t jitter_ns, int64_t compute_ns,
                    double u)
{
    double *row = pl->row;
    const double *out = pl->sim.out;
    if (!pl->log.fh)
        return;
    row[C_K] = (double)k;
    row[C_T] = out[HH_OUT_T];
    row[C_WALL] = wall;
    row[C_JITTER] = (double)jitter_ns / 1e3;
    row[C_COMPUTE] = (double)compute_ns / 1e3;
    row[C_U] = u;
    row[C_CMD_SEQ] = (double)pl->cmd_seq;
    row[C_CMD_AGE] = pl->cmd_seq >= 0 ? (double)(k - 1 - pl->cmd_echo) : -1.0;
    row[C_WATCHDOG] = pl->rig.link.active;
    row[C_XS] = out[HH_OUT_Y + HH_XS];
    row[C_P1] = out[HH_OUT_Y + HH_P1];
    row[C_P2] = out[HH_OUT_Y + HH_P2];
    row[C_XP] = out[HH_OUT_Y + HH_XP];
    row[C_VP] = out[HH_OUT_Y + HH_VP];
    row[C_FF] = out[HH_OUT_FF];
    row[C_TRAVEL] = out[HH_OUT_TRAVEL];
    row[C_FRICTION] = out[HH_OUT_FRICTION];
    row[C_SPOOL] = out[HH_OUT_SPOOL];
    row[C_ENCODER] = (double)r->encoder;
    row[C_P1_MEAS] = r->p[0];
    row[C_P2_MEAS] = r->p[1];
    row[C_PS_MEAS] = r->p[2];
    row[C_FAULTS] = (double)r->faults;
    row[C_STATUS] = (double)r->status;
    log_push(&pl->log, row);
}

/* The name Python gives an OS error (the Python plant reports "not permitted (PermissionError)"). */
static const char *error_name(int err)
{
    return err == EPERM || err == EACCES ? "PermissionError" : err == EINVAL ? "OSError (EINVAL)" : "OSError";
}

static void realtime_setup(plant *pl)
{
    const options *o = pl->o;
    snprintf(pl->os_cpu, sizeof pl->os_cpu, "null");
    if (o->cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(o->cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) == 0)
            snprintf(pl->os_cpu, sizeof pl->os_cpu, "%d", o->cpu);
        else
            snprintf(pl->os_cpu, sizeof pl->os_cpu, "\"not permitted (%s)\"", error_name(errno));
        if (pl->log.started)        /* the whole process on the plant's CPU: the writer takes its idle time */
            pthread_setaffinity_np(pl->log.thread, sizeof set, &set);
    }
    if (o->lockstep) {
        snprintf(pl->os_rt, sizeof pl->os_rt, "lock-step");
        return;
    }
    if (pl->spin) {    /* a SCHED_FIFO task that never sleeps is stopped by the kernel's RT throttling */
        if (setpriority(PRIO_PROCESS, 0, -20) == 0)
            snprintf(pl->os_rt, sizeof pl->os_rt, "normal policy, nice -20 (spin)");
        else
            snprintf(pl->os_rt, sizeof pl->os_rt, "not permitted (%s); normal priority", error_name(errno));
    } else {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = 50;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0)
            snprintf(pl->os_rt, sizeof pl->os_rt, "SCHED_FIFO 50");
        else
            snprintf(pl->os_rt, sizeof pl->os_rt, "not permitted (%s); normal priority", error_name(errno));
    }
    pl->timer_slack = prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0;
    pl->memory_locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;   /* no paging in the loop */
}

/* ---- timing.json -------------------------------------------------------------------------------- */
typedef struct {
    FILE *fh;
    int first;
} json_out;

static void json_key(json_out *j, const char *key)
{
    fprintf(j->fh, "%s\n  \"%s\": ", j->first ? "" : ",", key);
    j->first = 0;
}

static void json_string_value(FILE *fh, const char *s)
{
    fputc('"', fh);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            fprintf(fh, "\\%c", c);
        else if (c < 0x20)
            fprintf(fh, "\\u%04x", c);
        else
            fputc(c, fh);
    }
    fputc('"', fh);
}

static void json_num_value(FILE *fh, double v)
{
    char buf[40];
    if (!isfinite(v)) {
        fputs("null", fh);
        return;
    }
    fmt_double(buf, sizeof buf, v);
    if (!strpbrk(buf, ".e"))
        strcat(buf, ".0");
    fputs(buf, fh);
}

static void json_num(json_out *j, const char *key, double v) { json_key(j, key); json_num_value(j->fh, v); }

static void json_int(json_out *j, const char *key, int64_t v)
{
    json_key(j, key);
    fprintf(j->fh, "%lld", (long long)v);
}

static void json_str(json_out *j, const char *key, const char *v)
{
    json_key(j, key);
    if (v && *v)
        json_string_value(j->fh, v);
    else
        fputs("null", j->fh);
}

static void json_raw(json_out *j, const char *key, const char *v)
{
    json_key(j, key);
    fputs(v, j->fh);
}

/* room for the longest reason: "the model failed: " and a fault message (fault[600]) */
#define REASON_SIZE 640

/* The verdict (hydrohil.hil.verdict.judge, same rules and words): reasons, count returned. */
static int judge(const plant *pl, int64_t steps, char reasons[][REASON_SIZE])
{
    const double *hil = pl->o->hil;
    int n = 0;
    if (pl->link_error[0])
        snprintf(reasons[n++], REASON_SIZE, "%s", pl->link_error);
    if (pl->fault[0])
        snprintf(reasons[n++], REASON_SIZE, "the model failed: %s", pl->fault);
    if (!pl->o->lockstep && steps) {
        double late = (double)pl->late_commands, over = (double)pl->overruns, s = (double)steps;
        double stall_us = latency_max_us(&pl->jitter);
        if (late > hil[HIL_MAX_LATE_COMMANDS] * s)
            snprintf(reasons[n++], REASON_SIZE, "%lld of %lld commands late (%.1f%% > %.1f%%)", (long long)pl->late_commands,
                     (long long)steps, late / s * 100.0, hil[HIL_MAX_LATE_COMMANDS] * 100.0);
        if (over > hil[HIL_MAX_OVERRUNS] * s)
            snprintf(reasons[n++], REASON_SIZE, "%lld of %lld steps overran (%.1f%% > %.1f%%)", (long long)pl->overruns,
                     (long long)steps, over / s * 100.0, hil[HIL_MAX_OVERRUNS] * 100.0);
        if (isfinite(stall_us) && stall_us > hil[HIL_MAX_STALL] * 1e6)
            snprintf(reasons[n++], REASON_SIZE, "the plant stalled %.1f ms (> %g ms)", stall_us / 1e3, hil[HIL_MAX_STALL] * 1e3);
    }
    if ((double)pl->rig.link.trips_unexplained > hil[HIL_MAX_WATCHDOG_TRIPS])
        snprintf(reasons[n++], REASON_SIZE, "%lld watchdog trip(s) without an injected fault (no command reached the plant "
                 "for %g ms; allowed %lld)", (long long)pl->rig.link.trips_unexplained, hil[HIL_WATCHDOG_TIMEOUT] * 1e3,
                 (long long)hil[HIL_MAX_WATCHDOG_TRIPS]);
    return n;
}

static int write_timing(plant *pl, int64_t steps, int64_t t0, int64_t t_end, int64_t drift_ns, FILE *fh,
                        char reasons[][REASON_SIZE])
{
    const options *o = pl->o;
    json_out j = {fh, 1};
    int lock = o->lockstep, nreasons = judge(pl, steps, reasons), i;
    double na = NAN;
    fputc('{', fh);
    json_str(&j, "mode", lock ? "lockstep" : "realtime");
    json_num(&j, "step_s", o->step);
    json_int(&j, "steps", steps);
    json_int(&j, "steps_planned", pl->n);
    if (lock)
        json_raw(&j, "overruns", "null");
    else
        json_int(&j, "overruns", pl->overruns);
    json_num(&j, "jitter_us_p50", lock ? na : latency_percentile(&pl->jitter, 50));
    json_num(&j, "jitter_us_p99", lock ? na : latency_percentile(&pl->jitter, 99));
    json_num(&j, "jitter_us_p999", lock ? na : latency_percentile(&pl->jitter, 99.9));
    json_num(&j, "jitter_us_max", lock ? na : latency_max_us(&pl->jitter));
    json_num(&j, "compute_us_p50", latency_percentile(&pl->compute, 50));
    json_num(&j, "compute_us_p99", latency_percentile(&pl->compute, 99));
    json_num(&j, "compute_us_max", latency_max_us(&pl->compute));
    json_num(&j, "rtt_us_p50", lock ? na : latency_percentile(&pl->rtt, 50));
    json_num(&j, "rtt_us_p99", lock ? na : latency_percentile(&pl->rtt, 99));
    json_num(&j, "rtt_seen_us_p50", lock ? na : latency_percentile(&pl->rtt_seen, 50));
    json_num(&j, "rtt_seen_us_p99", lock ? na : latency_percentile(&pl->rtt_seen, 99));
    json_str(&j, "rtt_source", pl->kernel_stamps ? "kernel receive timestamp (SO_TIMESTAMPNS)" : "plant process");
    json_int(&j, "packets_rx", pl->packets_rx);
    json_int(&j, "packets_bad", pl->packets_bad);
    json_int(&j, "packets_foreign", pl->packets_foreign);
    json_int(&j, "packets_lost", pl->packets_lost);
    json_int(&j, "packets_reordered", pl->packets_reordered);
    json_int(&j, "late_commands", pl->late_commands);
    json_int(&j, "packets_dropped_kernel", pl->packets_dropped_kernel);
    json_int(&j, "watchdog_trips", pl->rig.link.trips);
    json_int(&j, "watchdog_trips_unexplained", pl->rig.link.trips_unexplained);
    json_int(&j, "commands_delivered", pl->rig.link.delivered);
    json_key(&j, "faults_injected");
    fputc('[', fh);
    for (i = 0; i < o->nfault; i++) {
        if (i)
            fputs(", ", fh);
        json_string_value(fh, hh_fault_type_name(o->faults[i].type));
    }
    fputc(']', fh);
    json_num(&j, "simulated_s", (double)steps * o->step);
    json_num(&j, "wall_s", (double)(t_end - t0) / 1e9);
    json_num(&j, "drift_ms", lock ? na : (double)drift_ns / 1e6);
    json_str(&j, "fault", pl->fault);
    json_str(&j, "link_error", pl->link_error);
    json_raw(&j, "stopped_early", pl->stop_requested ? "true" : "false");
    if (pl->stop_signal)
        json_int(&j, "stop_signal", pl->stop_signal);
    else
        json_raw(&j, "stop_signal", "null");
    json_str(&j, "statistics", "histograms, 1.2 % bins (bounded memory); max exact");
    json_raw(&j, "os_cpu", pl->os_cpu);
    json_str(&j, "os_rt_priority", pl->os_rt);
    json_str(&j, "os_timer_slack", pl->timer_slack ? "1 ns" : "default");
    if (!lock)
        json_raw(&j, "os_memory_locked", pl->memory_locked ? "true" : "false");
    json_str(&j, "plant", "c");
    json_int(&j, "log_rows_dropped", pl->log.dropped);
    if (lock)
        json_num(&j, "steps_per_s", (double)steps / fmax((double)(t_end - t0) / 1e9, 1e-9));
    json_key(&j, "verdict");
    fprintf(fh, "{\n    \"valid\": %s,\n    \"verdict\": \"%s\",\n    \"reasons\": [", nreasons ? "false" : "true",
            nreasons ? "INVALID" : "VALID");
    for (i = 0; i < nreasons; i++) {
        fprintf(fh, "%s\n      ", i ? "," : "");
        json_string_value(fh, reasons[i]);
    }
    fprintf(fh, "%s],\n    \"criteria\": {\n      \"max_late_commands\": ", nreasons ? "\n    " : "");
    json_num_value(fh, o->hil[HIL_MAX_LATE_COMMANDS]);
    fprintf(fh, ",\n      \"max_overruns\": ");
    json_num_value(fh, o->hil[HIL_MAX_OVERRUNS]);
    fprintf(fh, ",\n      \"max_stall_s\": ");
    json_num_value(fh, o->hil[HIL_MAX_STALL]);
    fprintf(fh, ",\n      \"max_watchdog_trips\": %lld\n    }\n  }\n}\n", (long long)o->hil[HIL_MAX_WATCHDOG_TRIPS]);
    return nreasons;
}

/* ---- main --------------------------------------------------------------------------------------- */
static int open_socket(plant *pl)
{
    int one = 1, rcvbuf = 1 << 20;
    socklen_t len = sizeof pl->o->bind;
    struct sockaddr_in bound;
    pl->sock = socket(AF_INET, SOCK_DGRAM, 0);
    if (pl->sock < 0) {
        fprintf(stderr, "error: socket: %s\n", strerror(errno));
        return -1;
    }
    setsockopt(pl->sock, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
#ifdef SO_RXQ_OVFL
    setsockopt(pl->sock, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
#endif
    pl->kernel_stamps = setsockopt(pl->sock, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) == 0;
    if (bind(pl->sock, (const struct sockaddr *)&pl->o->bind, sizeof pl->o->bind) < 0) {
        fprintf(stderr, "error: cannot bind %s: %s\n", pl->o->bind_text, strerror(errno));
        return -1;
    }
    getsockname(pl->sock, (struct sockaddr *)&bound, &len);
    {
        char host[INET_ADDRSTRLEN];
        inet_ntop(AF_INET, &bound.sin_addr, host, sizeof host);
        printf("READY %s:%d\n", host, ntohs(bound.sin_port));
        fflush(stdout);
    }
    return 0;
}

static int plant_init(plant *pl, options *o)
{
    double alpha, res = o->p[HH_SENSORS_ENCODER_RESOLUTION];
    int n;
    memset(pl, 0, sizeof *pl);
    pl->o = o;
    hh_params_derive(o->p);
    n = hh_delay_steps(o->p[HH_SPOOL_DELAY], o->step, &alpha);
    pl->delay_buf = calloc((size_t)n + 2, sizeof(double));
    if (!pl->delay_buf) {
        fprintf(stderr, "error: out of memory for a delay line of %d steps\n", n);
        return -1;
    }
    hh_sim_init(&pl->sim, o->p, HH_MODEL_HYBRID, HH_RK3, o->step, pl->delay_buf, n, alpha);
    {   /* the rig: its watchdog counts from step 0, the faults of step 0 apply (as the Python plant's) */
        int64_t cap = 0;
        int i;
        for (i = 0; i < o->nfault; i++)
            if (o->faults[i].type == HH_FAULT_NETWORK_DELAY && !pl->fifo) {   /* up to 1 s (the schema's bound) */
                cap = (int64_t)ceil(1.0 / o->step) + 2;
                pl->fifo = malloc(sizeof(double) * (size_t)cap);
                if (!pl->fifo) {
                    fprintf(stderr, "error: out of memory for a network delay of %lld steps\n", (long long)cap);
                    return -1;
                }
            }
        hh_rig_init(&pl->rig, &pl->sim, hh_count_size(res), (uint64_t)o->hil[HIL_SEED], o->hil[HIL_WATCHDOG_TIMEOUT],
                    o->hil[HIL_SAFE_STATE] == HIL_SAFE_STATE_HOLD, o->hil[HIL_HOLD_KP], pl->fifo, cap);
        for (i = 0; i < o->nfault; i++) {
            hh_fault f = o->faults[i];
            f.k_start = (int64_t)ceil(f.start / o->step - 1e-9);      /* as Python's math.ceil (faults.k_range) */
            f.k_end = isnan(o->fault_end[i]) ? HH_NEVER : (int64_t)ceil(o->fault_end[i] / o->step - 1e-9);
            hh_rig_add(&pl->rig, &f);
        }
        hh_rig_begin(&pl->rig, 0);
    }
    pl->n = (int64_t)nearbyint(o->duration / o->step);     /* half to even, as Python's round() */
    pl->h_ns = (int64_t)nearbyint(o->step * 1e9);
    pl->spin = o->hil[HIL_WAIT] == HIL_WAIT_SPIN;
    pl->spin_ns = pl->spin ? 2 * pl->h_ns : (int64_t)fmin((double)SPIN_NS, SPIN_FRACTION * (double)pl->h_ns);
    pl->cmd_seq = pl->cmd_echo = -1;
    {
        int i;
        for (i = 0; i < SENT_RING; i++)
            pl->sent[i].k = -1;
    }
    return 0;
}

/* The model at its initial state (plant time 0), of the fault-free parameters (the rig's base: a fault active
 * at step 0 hits a rig at rest); the rig's watchdog, faults and noise go on (as the Python plant's). */
static void plant_reset(plant *pl)
{
    const double *x = pl->o->initial;
    if (hh_initial_state(pl->rig.base, x[0], x[1], 0.0, x[2], x[3], 0.0, pl->sim.y, pl->sim.m) != 0
        && pl->sim.m[HH_M_TRAVEL] == HH_FREE && (isnan(x[2]) || isnan(x[3])))
        fprintf(stderr, "warning: no spool position holds the piston at rest (the load is more than the cylinder "
                        "gives at %g bar): the spool starts centred and the load moves the piston\n", pl->rig.base[HH_SUPPLY_PS] / 1e5);
    hh_sim_reset(&pl->sim);
}

/* %.6g as Python formats it ("nan", "inf", "-inf"; glibc would write "-nan") */
static const char *g6(char *buf, double v)
{
    if (isnan(v))
        return "nan";
    if (isinf(v))
        return v > 0 ? "inf" : "-inf";
    snprintf(buf, 32, "%.6g", v);
    return buf;
}

static void describe_divergence(plant *pl)
{
    const double *y = pl->sim.y;
    const int64_t *m = pl->sim.m;
    char b[7][32];
    snprintf(pl->fault, sizeof pl->fault,
             "simulation diverged at t = %.6f s (non-finite or unphysical state); modes: travel=%s, friction=%s, "
             "spool=%s; state: xs=%s, vs=%s, p1=%s, p2=%s, xp=%s, vp=%s, z=%s", pl->sim.out[HH_OUT_T],
             TRAVEL_NAMES[m[0] % 3], FRICTION_NAMES[m[1] % 3], SPOOL_NAMES[m[2] % 4], g6(b[0], y[0]), g6(b[1], y[1]),
             g6(b[2], y[2]), g6(b[3], y[3]), g6(b[4], y[4]), g6(b[5], y[5]), g6(b[6], y[6]));
}

/* mkdir -p */
static int make_dirs(const char *dir)
{
    char path[4096];
    size_t i, n = strlen(dir);
    if (n >= sizeof path)
        return -1;
    memcpy(path, dir, n + 1);
    for (i = 1; i <= n; i++) {
        if (path[i] == '/' || path[i] == '\0') {
            char c = path[i];
            path[i] = '\0';
            if (mkdir(path, 0777) != 0 && errno != EEXIST)
                return -1;
            path[i] = c;
        }
    }
    return 0;
}

int main(int argc, char **argv)
{
    static options o;
    static plant pl;
    static char reasons[8][REASON_SIZE];
    struct sigaction sa;
    reading r;
    int64_t t0, t_end, last_start, k, k_done = 0, drift_ns;
    uint32_t status_extra = 0;
    int nreasons, code;
    FILE *timing_fh = NULL;
    char path[4096];

    parse_options(argc, argv, &o);
    memset(&sa, 0, sizeof sa);
    sigemptyset(&sa.sa_mask);
    sa.sa_handler = on_signal;          /* no SA_RESTART: sleeps and polls return at a signal */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    if (o.log_dir) {
        snprintf(path, sizeof path, "%s/timing.json.part", o.log_dir);
        if (make_dirs(o.log_dir) != 0 || !(timing_fh = fopen(path, "w"))) {   /* can we write there? */
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
            return 2;
        }
        fclose(timing_fh);
        unlink(path);                   /* written at the end, then renamed: never a partial timing.json */
        timing_fh = NULL;
    }
    if (plant_init(&pl, &o) < 0 || log_open(&pl.log, o.log_dir) < 0)
        return 2;
    if (o.has_peer) {
        pl.peer = o.peer;
        pl.has_peer = 1;
    }
    /* warm up: one step pages in the code and data a step touches; then the initial state */
    plant_reset(&pl);
    hh_sim_step(&pl.sim, 0.0);
    plant_reset(&pl);
    if (open_socket(&pl) < 0)
        return 2;
    realtime_setup(&pl);               /* after the writer thread started: it keeps the normal policy */
    check_signal(&pl);

    if (!wait_for_controller(&pl)) {
        if (!pl.stop_requested)
            snprintf(pl.link_error, sizeof pl.link_error, "no controller packet within %g s (%lld bad, %lld foreign "
                     "packets)", o.hil[HIL_CONNECT_TIMEOUT], (long long)pl.packets_bad, (long long)pl.packets_foreign);
        t0 = t_end = mono_ns();
        drift_ns = 0;
    } else {
        char host[INET_ADDRSTRLEN];
        inet_ntop(AF_INET, &pl.peer.sin_addr, host, sizeof host);
        printf("PEER %s:%d\n", host, ntohs(pl.peer.sin_port));
        fflush(stdout);
        pl.cmd_new = 0;                 /* HELLO / early packets are not commands for step 0 */
        t0 = mono_ns() + 2 * pl.h_ns;
        last_start = t0;
        send_sensor(&pl, 0, 0, &r);
        log_row(&pl, 0, &r, 0.0, 0, 0, 0.0);
        for (k = 0; k < pl.n; k++) {
            int64_t start, late, end;
            double u = 0.0;
            int arrived;
            if (o.lockstep) {
                wait_lockstep(&pl, k);
                start = mono_ns();
                late = 0;
            } else {
                int64_t deadline = t0 + k * pl.h_ns;
                wait_until(&pl, deadline);
                start = last_start = mono_ns();
                drain(&pl);
                late = start - deadline;
                status_extra = late > pl.h_ns ? HHIL_ST_OVERRUN : 0;
                pl.overruns += late > pl.h_ns;
            }
            check_signal(&pl);
            arrived = take_command(&pl, k, &u);
            if (hh_rig_step(&pl.rig, k, arrived, u, &u) != HH_OK) {
                describe_divergence(&pl);
                send_sensor(&pl, k + 1, HHIL_ST_FAULT | HHIL_ST_FINAL, &r);
                break;
            }
            send_sensor(&pl, k + 1, status_extra | ((k + 1 == pl.n || pl.stop_requested) ? HHIL_ST_FINAL : 0), &r);
            end = mono_ns();
            latency_add(&pl.jitter, late);
            latency_add(&pl.compute, end - start);
            k_done = k + 1;
            log_row(&pl, k + 1, &r, o.lockstep ? 0.0 : (double)(start - t0) / 1e9, late, end - start, u);
            if (pl.stop_requested)
                break;
        }
        t_end = mono_ns();
        drain(&pl);                     /* count what arrived up to the end (fuzzing, a controller's last words) */
        {
            uint8_t bye[HHIL_SIMPLE_LEN];
            hhil_header h = {HHIL_BYE, (uint32_t)(k_done + 1), t_end, 0, 0};
            int i;
            hhil_encode_simple(bye, &h);
            for (i = 0; i < 3; i++)     /* tell the controller the run is over */
                send_to_peer(&pl, bye, sizeof bye);
        }
        drift_ns = last_start - (t0 + (k_done > 1 ? k_done - 1 : 0) * pl.h_ns);
    }
    log_close(&pl.log);
    nreasons = write_timing(&pl, k_done, t0, t_end, drift_ns, stderr, reasons);   /* as the Python plant */
    if (o.log_dir) {
        char final_path[4096];
        timing_fh = fopen(path, "w");
        if (!timing_fh) {
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
        } else {
            write_timing(&pl, k_done, t0, t_end, drift_ns, timing_fh, reasons);
            fclose(timing_fh);
            snprintf(final_path, sizeof final_path, "%s/timing.json", o.log_dir);
            rename(path, final_path);
        }
    }
    if (pl.link_error[0])
        fprintf(stderr, "error: %s\n", pl.link_error);
    if (pl.fault[0])
        fprintf(stderr, "error: %s\n", pl.fault);
    if (nreasons) {
        int i;
        printf("verdict: INVALID: ");
        for (i = 0; i < nreasons; i++)
            printf("%s%s", i ? "; " : "", reasons[i]);
        printf("\n");
    } else {
        printf("verdict: VALID\n");
    }
    fflush(stdout);
    code = pl.link_error[0] ? 4 : pl.fault[0] ? 1 : pl.stop_signal ? 128 + pl.stop_signal : nreasons ? 3 : 0;
    close(pl.sock);
    free(pl.delay_buf);
    free(pl.fifo);
    return code;
}
