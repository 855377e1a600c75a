/* rt_options.c: the standalone plant's command line (rt_plant.h). Every value is checked against the
 * generated tables (hh_params.h: the parameters' keys, units and ranges; plant_config.h: this export's
 * values, the [hil] settings and the fault kinds) and refused with its range and unit. */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#define HH_PARAMS_TABLE            /* the parameter table (keys, units, ranges) for --set and --list */
#define PLANT_CONFIG_TABLES        /* this export's values and the settings' tables */
#include "rt_plant.h"



/* the message of a bad argument, then exit 2 (never returns) */
NORETURN void die_usage(const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "error: ");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fprintf(stderr, "\n(hydrohil_plant --help lists the options, --list the parameters and settings)\n");
    exit(2);
}

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

#ifndef PLANT_CIRCUIT
static int param_index(const char *key)
{
    int i;
    for (i = 0; i < HH_NP_SCHEMA; i++)
        if (strcmp(HH_PARAM_INFO[i].key, key) == 0)
            return i;
    return -1;
}
#endif

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

#ifndef PLANT_CIRCUIT
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
    if (PLANT_FIXED[i] && v != PLANT_PARAMS[i]) {
        char word[40];
        option_word(PLANT_OPTIONS[i], (int)PLANT_PARAMS[i], word, sizeof word);
        die_usage("--set %s: %s is fixed by this export (\"%s\": its generated model has that structure); export "
                  "the plant again with it (hydrohil export c --set %s=...)", assignment, key, word, key);
    }
    o->p[i] = v;
}

#endif

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

#ifndef PLANT_CIRCUIT
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

#endif

/* A fault TYPE:key=value,... (a [[faults]] entry; FAULT_KINDS: the schema's fields) into *f, its end [s] (NaN: none)
 * into *end. Returns 0, or -1 with the reason in err (the --fault option and the panel's fault_on share it). */
int fault_from_spec(const char *text, hh_fault *f, double *end, char *err, size_t size)
{
    char buf[512], *type, *rest, *item, *save = NULL;
    const fault_kind *kind = NULL;
    int i, given[6] = {0, 0, 0, 0, 0, 0};
    size_t used;
    if (strlen(text) >= sizeof buf) {
        snprintf(err, size, "too long (at most %d characters)", (int)sizeof buf - 1);
        return -1;
    }
    snprintf(buf, sizeof buf, "%s", text);
    type = buf;
    rest = strchr(buf, ':');
    if (rest)
        *rest++ = '\0';
    for (i = 0; i < HH_NFAULT_TYPES; i++)
        if (strcmp(FAULT_KINDS[i].type, type) == 0)
            kind = &FAULT_KINDS[i];
    if (!kind) {
        used = (size_t)snprintf(err, size, "unknown fault type '%s'; one of:", type);
        for (i = 0; i < HH_NFAULT_TYPES && used < size; i++)
            used += (size_t)snprintf(err + used, size - used, " %s", FAULT_KINDS[i].type);
        return -1;
    }
    memset(f, 0, sizeof *f);
    f->type = (int)(kind - FAULT_KINDS);
    f->a = f->b = NAN;
    *end = NAN;
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
            used = (size_t)snprintf(err, size, "%s has no field '%s'; its fields:", kind->type, item);
            for (j = 0; j < kind->nfields && used < size; j++)
                used += (size_t)snprintf(err + used, size - used, " %s", kind->fields[j].key);
            return -1;
        }
        j = (int)(fd - kind->fields);
        if (fd->slot == FIELD_SENSOR) {
            v = option_index(fd->options, eq);
            if (v < 0) {
                snprintf(err, size, "%s is one of %s, got '%s'", fd->key, fd->options, eq);
                return -1;
            }
        } else {
            if (!parse_number(eq, &v) || !isfinite(v)) {
                snprintf(err, size, "%s: not a number: '%s'", fd->key, eq);
                return -1;
            }
            if (fd->options) {             /* whole numbers of a list (hose_burst's line) */
                char word[32];
                snprintf(word, sizeof word, "%.0f", v);
                if (v != floor(v) || fabs(v) > 1e6 || option_index(fd->options, word) < 0) {
                    snprintf(err, size, "%s is one of %s, got %s", fd->key, fd->options, eq);
                    return -1;
                }
            } else if ((fd->lo_strict ? !(v > fd->lo) : !(v >= fd->lo)) || (fd->hi_strict ? !(v < fd->hi) : !(v <= fd->hi))) {
                snprintf(err, size, "%s must be %s %g and %s %g %s, got %s", fd->key, fd->lo_strict ? ">" : ">=",
                         fd->lo, fd->hi_strict ? "<" : "<=", fd->hi, fd->unit, eq);
                return -1;
            }
        }
        given[j] = 1;
        switch (fd->slot) {
        case FIELD_START: f->start = v; break;
        case FIELD_END: *end = v; break;
        case FIELD_SENSOR: f->sensor = (int)v; break;
        case FIELD_A: f->a = v; break;
        default: f->b = v;
        }
    }
    for (i = 0; i < kind->nfields; i++)
        if (kind->fields[i].required && !given[i]) {
            snprintf(err, size, "%s needs %s", kind->type, kind->fields[i].key);
            return -1;
        }
    /* the schema's rules across fields (simulation/faults.py) */
    if (!isnan(*end) && !(*end > f->start)) {
        snprintf(err, size, "end (%g s) must be after start (%g s)", *end, f->start);
        return -1;
    }
    if (f->type == HH_FAULT_LOAD_CHANGE && isnan(f->a) && isnan(f->b)) {
        snprintf(err, size, "load_change needs mass and/or force");
        return -1;
    }
    return 0;
}

/* A fault switched on from the panel as events.jsonl writes it: every field of its kind, start 0, no end (what
 * hydrohil.simulation.steering.fault_model makes of it); the length, or 0 when it does not fit. */
size_t fault_json(const hh_fault *f, char *buf, size_t size)
{
    const fault_kind *kind = &FAULT_KINDS[f->type];
    size_t n;
    int i;
    n = (size_t)snprintf(buf, size, "{\"type\": \"%s\"", kind->type);
    for (i = 0; i < kind->nfields && n < size; i++) {
        const fault_field *fd = &kind->fields[i];
        char word[64];
        double v = fd->slot == FIELD_A ? f->a : f->b;
        if (fd->slot == FIELD_START) {
            snprintf(word, sizeof word, "0.0");
        } else if (fd->slot == FIELD_END) {
            snprintf(word, sizeof word, "null");
        } else if (fd->slot == FIELD_SENSOR) {
            char name[32];
            option_word(fd->options, f->sensor, name, sizeof name);
            snprintf(word, sizeof word, "\"%s\"", name);
        } else if (isnan(v)) {
            snprintf(word, sizeof word, "null");
        } else if (fd->options) {                  /* whole numbers of a list (hose_burst's line) */
            snprintf(word, sizeof word, "%.0f", v);
        } else {
            fmt_double(word, sizeof word, v);
            if (!strpbrk(word, ".e"))
                strcat(word, ".0");
        }
        n += (size_t)snprintf(buf + n, size - n, ", \"%s\": %s", fd->key, word);
    }
    if (n + 2 > size)
        return 0;
    buf[n++] = '}';
    buf[n] = '\0';
    return n;
}

#ifndef PLANT_CIRCUIT
/* One --fault TYPE:key=value,... (exit 2 with the reason when it is not a valid fault) */
static void set_fault(options *o, const char *text)
{
    char err[600];
    if (o->nfault >= HH_MAX_FAULTS)
        die_usage("--fault %s: at most %d faults", text, HH_MAX_FAULTS);
    if (fault_from_spec(text, &o->faults[o->nfault], &o->fault_end[o->nfault], err, sizeof err) != 0)
        die_usage("--fault %s: %s", text, err);
    o->nfault++;
}

#endif

#ifndef PLANT_CIRCUIT
/* --list: the parameter set's values with their units and ranges */
static void list_parameters(const options *o)
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
        if (PLANT_FIXED[i])
            printf("  fixed by this export (its generated model's structure)");
        else if (PLANT_OPTIONS[i])
            printf("  one of %s (by name or index)", PLANT_OPTIONS[i]);
        else if (s->kind == HH_KIND_BOOLEAN)
            printf("  true | false");
        else if (isfinite(s->lo) || isfinite(s->hi))
            printf("  %s %g .. %g %s", s->lo_strict ? "(" : "[", s->lo, s->hi, s->hi_strict ? ")" : "]");
        printf("\n");
    }
}

/* --list: the initial state and the faults --fault takes */
static void list_initial_and_faults(const options *o)
{
    int i;
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
#endif

static void list_settings(const options *o)
{
    char v[40];
    int i;
#ifdef PLANT_CIRCUIT
    printf("%s: its parameters and state at rest are the export's (hydrohil circuit show lists them)\n",
           PLANT_DESCRIPTION);
#else
    list_parameters(o);
#endif
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
#ifndef PLANT_CIRCUIT
    list_initial_and_faults(o);
#endif
}

static void usage(void)
{
#ifdef PLANT_CIRCUIT
    printf("usage: hydrohil_plant [options]\n"
           "Serve %s over UDP, protocol v1's SIGNALS / INPUTS (docs/protocol.md), locked to the wall clock.\n\n"
           "  --bind HOST:PORT      listen address (default 127.0.0.1:47000; port 0: any free port, see READY)\n"
           "  --peer HOST:PORT      accept inputs only from this address (default: the first valid sender)\n"
           "  --allow-remote        allow a non-loopback --bind / --peer\n"
           "  --duration S          simulated time to serve [s] (default %g; 0: until stopped)\n"
           "  --log DIR             write DIR/plant_log.csv (streamed) and DIR/timing.json\n"
           "  --no-rows             no DIR/plant_log.csv of the whole run\n"
           "  --lockstep            advance one step per INPUTS packet, as fast as possible (no clock)\n"
           "  --cpu N               pin the plant to CPU N\n"
           "  --hil KEY=VALUE       a [hil] setting (watchdog_timeout, wait, the verdict's limits, ...)\n"
           "  --connect-timeout S   wait this long for the controller's first packet (= --hil connect_timeout=S)\n"
           "  --panel HOST:PORT     the live panel's side channel: telemetry out, steering in (hydrohil panel): hold an\n"
           "                        input, reset; with --log DIR the session's events, inputs and recordings in DIR\n"
           "  --list                print the [hil] settings, then exit\n\n"
           "The circuit's parameters, state at rest, drives and step (%g s) are the export's: export again to change\n"
           "them (hydrohil export c --scenario FILE [--set component.key=value]).\n"
           "Prints READY host:port once bound, PEER host:port once the controller spoke, the verdict at the end.\n"
           "Exit: 0 VALID, 3 INVALID, 4 no controller / link lost, 1 model diverged, 2 bad arguments, 130/143 signal.\n",
           PLANT_DESCRIPTION, PLANT_DURATION_DEFAULT, PLANT_STEP_DEFAULT);
    return;
#endif
    printf("usage: hydrohil_plant [options]\n"
           "Serve the virtual rig (%s) over UDP, protocol v1 (docs/protocol.md), locked to the wall clock.\n\n"
           "  --bind HOST:PORT      listen address (default 127.0.0.1:47000; port 0: any free port, see READY)\n"
           "  --peer HOST:PORT      accept commands only from this address (default: the first valid sender)\n"
           "  --allow-remote        allow a non-loopback --bind / --peer\n"
           "  --step S              plant step [s] (default %g)\n"
           "  --duration S          simulated time to serve [s] (default %g; 0: until stopped)\n"
           "  --log DIR             write DIR/plant_log.csv (streamed) and DIR/timing.json\n"
           "  --panel HOST:PORT     the live panel's side channel: telemetry out, steering in (hydrohil panel); with\n"
           "                        --log, DIR is the session folder (events.jsonl, commands.f64, recordings)\n"
           "  --no-rows             no DIR/plant_log.csv of the whole run (a panel session: recordings only)\n"
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

void parse_options(int argc, char **argv, options *o)
{
    enum { O_BIND = 1, O_PEER, O_REMOTE, O_STEP, O_DURATION, O_LOG, O_LOCKSTEP, O_CPU, O_SET, O_HIL, O_INITIAL,
           O_CONNECT, O_FAULT, O_PANEL, O_NO_ROWS, O_LIST, O_HELP };
    static const struct option longs[] = {
        {"bind", required_argument, 0, O_BIND}, {"peer", required_argument, 0, O_PEER},
        {"allow-remote", no_argument, 0, O_REMOTE}, {"step", required_argument, 0, O_STEP},
        {"duration", required_argument, 0, O_DURATION}, {"log", required_argument, 0, O_LOG},
        {"lockstep", no_argument, 0, O_LOCKSTEP}, {"cpu", required_argument, 0, O_CPU},
        {"set", required_argument, 0, O_SET}, {"hil", required_argument, 0, O_HIL},
        {"initial", required_argument, 0, O_INITIAL}, {"connect-timeout", required_argument, 0, O_CONNECT},
        {"fault", required_argument, 0, O_FAULT}, {"panel", required_argument, 0, O_PANEL},
        {"no-rows", no_argument, 0, O_NO_ROWS},
        {"list", no_argument, 0, O_LIST}, {"help", no_argument, 0, O_HELP}, {0, 0, 0, 0}};
    const char *bind_text = "127.0.0.1:47000", *peer_text = NULL, *panel_text = NULL;
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
            if (!parse_number(optarg, &o->duration) || !(o->duration >= 0 && o->duration <= 1e6))
                die_usage("--duration %s: must be >= 0 and <= 1e6 [s] (0: until stopped)", optarg);
            break;
        case O_LOG: o->log_dir = optarg; break;
        case O_LOCKSTEP: o->lockstep = 1; break;
        case O_CPU:
            if (!parse_number(optarg, &v) || v != floor(v) || v < 0 || v > 4095)
                die_usage("--cpu %s: a CPU number >= 0", optarg);
            o->cpu = (int)v;
            break;
#ifdef PLANT_CIRCUIT             /* a circuit's plant: its parameters and state at rest are the export's */
        case O_SET: case O_INITIAL: case O_FAULT:
            die_usage("--%s: not for a circuit's plant (its values are exported: hydrohil export c --scenario ... "
                      "--set component.key=value; faults are the paper's rig's)",
                      c == O_SET ? "set" : c == O_INITIAL ? "initial" : "fault");
        case O_PANEL: panel_text = optarg; break;
#else
        case O_SET: set_parameter(o, optarg); break;
        case O_INITIAL: set_initial(o, optarg); break;
        case O_FAULT: set_fault(o, optarg); break;
        case O_PANEL: panel_text = optarg; break;
#endif
        case O_HIL: set_hil(o, optarg); break;
        case O_NO_ROWS: o->no_rows = 1; break;
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
#ifndef PLANT_CIRCUIT
    if (hh_params_check(o->p, msg, sizeof msg) >= 0)
        die_usage("%s", msg);
#else
    (void)msg;
    if (o->hil[HIL_COMMAND_SCALE] != 1.0)
        die_usage("--hil command_scale: the paper's rig's (a circuit's inputs are in their SI units)");
#endif
    if (list) {
        list_settings(o);
        exit(0);
    }
#ifndef PLANT_CIRCUIT
    if (!(o->initial[0] >= 0.0 && o->initial[0] <= o->p[HH_CYLINDER_STROKE]) ||
        !(isnan(o->initial[1]) || (o->initial[1] >= -1.0 && o->initial[1] <= 1.0)))
        die_usage("--initial: need 0 <= xp <= cylinder.stroke (%g m) and -1 <= xs <= 1 (or nan), got xp %g, xs %g",
                  o->p[HH_CYLINDER_STROKE], o->initial[0], o->initial[1]);
#endif
    parse_address("--bind", bind_text, o->allow_remote, &o->bind, o->bind_text);
    if (peer_text) {
        parse_address("--peer", peer_text, o->allow_remote, &o->peer, o->peer_text);
        o->has_peer = 1;
    }
    if (panel_text) {            /* the panel's side channel is loopback only (as hydrohil plant's) */
        parse_address("--panel", panel_text, 0, &o->panel, o->panel_text);
        o->has_panel = 1;
    }
}

