/* rt_side.c: the standalone plant's side channel to the live panel (rt_plant.h), as hydrohil plant's
 * (hil/sidechannel.py, hil/session.py, simulation/steering.py; docs/protocol.md "Panel side channel"):
 *
 *   telemetry   a row per step (core/shape.py SIDE_PLANT_COLUMNS) sent in batches of SIDE_BATCH rows with the
 *               plant's counters, non-blocking: a batch the panel has no room for is dropped and counted;
 *   steering    JSON messages read (non-blocking) once per batch, applied at the boundary before step k:
 *               set (a tunable), fault_on (a [[faults]] entry, checked as --fault checks it), fault_off,
 *               reset, stop, record_start {"dir"}, record_stop; answered {"ack": id, "k": k, ...} or
 *               {"ack": id, "error": "..."}; a repeated id is answered again, never applied twice;
 *   session     with --log: DIR/events.jsonl (every applied event with its k, replayable by
 *               hydrohil.hil.session.replay_session), DIR/commands.f64 (the command applied at each step),
 *               recordings (DIR/.../plant_log.csv + timing.json of the steps recorded).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "rt_plant.h"

/* ---- a JSON object of the panel: flat fields and one nested object (a fault) ---------------------- */
enum { J_STR, J_NUM, J_NULL, J_BOOL };
#define J_FIELDS 32

typedef struct {
    char key[64];                 /* "op", ...; a nested object's fields "fault.type", ... */
    int kind;
    double num;
    const char *str;              /* J_STR: decoded (in the object's string store) */
    const char *raw;              /* the value as the message wrote it (an object: its text) */
    size_t raw_len;
} jfield;

typedef struct {
    jfield f[J_FIELDS];
    int n;
    char store[SIDE_MSG];
    size_t used;
} jobject;

static const char *skip_ws(const char *p, const char *e)
{
    while (p < e && (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r'))
        p++;
    return p;
}

static int hex4(const char *p, const char *e, unsigned *v)
{
    int i;
    *v = 0;
    if (e - p < 4)
        return 0;
    for (i = 0; i < 4; i++) {
        char c = p[i];
        *v <<= 4;
        if (c >= '0' && c <= '9')
            *v |= (unsigned)(c - '0');
        else if (c >= 'a' && c <= 'f')
            *v |= (unsigned)(c - 'a' + 10);
        else if (c >= 'A' && c <= 'F')
            *v |= (unsigned)(c - 'A' + 10);
        else
            return 0;
    }
    return 1;
}

/* A JSON string at p (at its opening quote) decoded into the store; the position after it, or NULL. */
static const char *parse_string(const char *p, const char *e, jobject *o, const char **out)
{
    char *d = o->store + o->used, *end = o->store + sizeof o->store - 4;
    *out = d;
    if (p >= e || *p != '"')
        return NULL;
    for (p++; p < e && *p != '"'; p++) {
        unsigned c = (unsigned char)*p;
        if (d >= end || c < 0x20)
            return NULL;
        if (c != '\\') {
            *d++ = (char)c;
            continue;
        }
        if (++p >= e)
            return NULL;
        switch (*p) {
        case '"': *d++ = '"'; break;
        case '\\': *d++ = '\\'; break;
        case '/': *d++ = '/'; break;
        case 'b': *d++ = '\b'; break;
        case 'f': *d++ = '\f'; break;
        case 'n': *d++ = '\n'; break;
        case 'r': *d++ = '\r'; break;
        case 't': *d++ = '\t'; break;
        case 'u': {
            unsigned v, lo;
            if (!hex4(p + 1, e, &v))
                return NULL;
            p += 4;
            if (v >= 0xD800 && v < 0xDC00) {           /* a surrogate pair */
                if (e - p < 7 || p[1] != '\\' || p[2] != 'u' || !hex4(p + 3, e, &lo) || lo < 0xDC00 || lo > 0xDFFF)
                    return NULL;
                v = 0x10000 + ((v - 0xD800) << 10) + (lo - 0xDC00);
                p += 6;
            } else if (v >= 0xDC00 && v < 0xE000) {
                return NULL;
            }
            if (v == 0)
                return NULL;                            /* no NUL inside a C string */
            if (v < 0x80) {
                *d++ = (char)v;
            } else if (v < 0x800) {
                *d++ = (char)(0xC0 | (v >> 6));
                *d++ = (char)(0x80 | (v & 0x3F));
            } else if (v < 0x10000) {
                *d++ = (char)(0xE0 | (v >> 12));
                *d++ = (char)(0x80 | ((v >> 6) & 0x3F));
                *d++ = (char)(0x80 | (v & 0x3F));
            } else {
                *d++ = (char)(0xF0 | (v >> 18));
                *d++ = (char)(0x80 | ((v >> 12) & 0x3F));
                *d++ = (char)(0x80 | ((v >> 6) & 0x3F));
                *d++ = (char)(0x80 | (v & 0x3F));
            }
            break;
        }
        default: return NULL;
        }
    }
    if (p >= e)
        return NULL;
    *d++ = '\0';
    o->used = (size_t)(d - o->store);
    return p + 1;
}

/* A JSON number (its grammar: no leading '+', no hex, inf or nan as strtod would take) */
static const char *parse_number_json(const char *p, const char *e, double *v)
{
    char buf[64];
    const char *q = p;
    char *end;
    size_t n;
    if (q < e && *q == '-')
        q++;
    if (q >= e || *q < '0' || *q > '9')
        return NULL;
    while (q < e && ((*q >= '0' && *q <= '9') || *q == '.' || *q == 'e' || *q == 'E' || *q == '+' || *q == '-'))
        q++;
    n = (size_t)(q - p);
    if (n >= sizeof buf)
        return NULL;
    memcpy(buf, p, n);
    buf[n] = '\0';
    errno = 0;
    *v = strtod(buf, &end);
    if (*end || errno == ERANGE || !isfinite(*v))
        return NULL;
    return q;
}

/* An object's fields at p (after its '{'), keys prefixed by prefix; nested objects only at depth 0. */
static const char *parse_members(const char *p, const char *e, jobject *o, const char *prefix, int depth)
{
    p = skip_ws(p, e);
    if (p < e && *p == '}')
        return p + 1;
    for (;;) {
        const char *key;
        jfield *f;
        p = skip_ws(p, e);
        p = parse_string(p, e, o, &key);
        if (!p || o->n >= J_FIELDS)
            return NULL;
        f = &o->f[o->n++];
        if ((size_t)snprintf(f->key, sizeof f->key, "%s%s", prefix, key) >= sizeof f->key)
            return NULL;
        p = skip_ws(p, e);
        if (p >= e || *p != ':')
            return NULL;
        p = skip_ws(p + 1, e);
        f->raw = p;
        f->str = NULL;
        if (p < e && *p == '"') {
            f->kind = J_STR;
            p = parse_string(p, e, o, &f->str);
        } else if (p < e && *p == '{' && depth == 0) {
            char nested[72];
            f->kind = J_NULL;                       /* the object itself: its fields follow as key.field */
            snprintf(nested, sizeof nested, "%s.", f->key);
            p = parse_members(p + 1, e, o, nested, 1);
        } else if (e - p >= 4 && strncmp(p, "null", 4) == 0) {
            f->kind = J_NULL;
            p += 4;
        } else if (e - p >= 4 && strncmp(p, "true", 4) == 0) {
            f->kind = J_BOOL;
            f->num = 1;
            p += 4;
        } else if (e - p >= 5 && strncmp(p, "false", 5) == 0) {
            f->kind = J_BOOL;
            f->num = 0;
            p += 5;
        } else {
            f->kind = J_NUM;
            p = parse_number_json(p, e, &f->num);
        }
        if (!p)
            return NULL;
        f->raw_len = (size_t)(p - f->raw);
        p = skip_ws(p, e);
        if (p < e && *p == ',') {
            p++;
            continue;
        }
        if (p < e && *p == '}')
            return p + 1;
        return NULL;
    }
}

static int parse_object(const char *text, size_t n, jobject *o)
{
    const char *p = skip_ws(text, text + n), *e = text + n;
    o->n = 0;
    o->used = 0;
    if (p >= e || *p != '{')
        return 0;
    p = parse_members(p + 1, e, o, "", 0);
    return p && skip_ws(p, e) == e;
}

static const jfield *field(const jobject *o, const char *key)
{
    int i;
    for (i = 0; i < o->n; i++)
        if (strcmp(o->f[i].key, key) == 0)
            return &o->f[i];
    return NULL;
}

/* ---- writing JSON ------------------------------------------------------------------------------ */
typedef struct {
    char *buf;
    size_t size, n;
} text;

static void put(text *t, const char *s, size_t n)
{
    if (t->n + n + 1 > t->size)
        n = t->n + 1 < t->size ? t->size - t->n - 1 : 0;
    memcpy(t->buf + t->n, s, n);
    t->n += n;
    t->buf[t->n] = '\0';
}

static void puts_(text *t, const char *s) { put(t, s, strlen(s)); }

static void put_string(text *t, const char *s)
{
    put(t, "\"", 1);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        char esc[8];
        if (c == '"' || c == '\\') {
            esc[0] = '\\';
            esc[1] = (char)c;
            put(t, esc, 2);
        } else if (c < 0x20) {
            snprintf(esc, sizeof esc, "\\u%04x", c);
            put(t, esc, 6);
        } else {
            put(t, (const char *)&c, 1);
        }
    }
    put(t, "\"", 1);
}

static void put_int(text *t, int64_t v)
{
    char b[32];
    snprintf(b, sizeof b, "%lld", (long long)v);
    puts_(t, b);
}

/* ---- the channel -------------------------------------------------------------------------------- */
static void say(plant *pl, const char *msg, size_t n)
{
    (void)send(pl->side.sock, msg, n, MSG_DONTWAIT);     /* no panel / buffer full: lost, the panel resends */
}

static side_seen *seen_find(side_channel *s, int64_t id)
{
    int i;
    for (i = 0; i < SIDE_SEEN; i++)
        if (s->seen[i].id == id)
            return &s->seen[i];
    return NULL;
}

static side_seen *seen_add(side_channel *s, int64_t id)
{
    side_seen *e = &s->seen[s->seen_next];
    s->seen_next = (s->seen_next + 1) % SIDE_SEEN;
    free(e->answer);
    e->answer = NULL;
    e->id = id;
    return e;
}

/* Answer message id with the fields in extra (",\"k\": 12, ..." or ",\"error\": ..."); kept for a retry. */
static void answer(plant *pl, int64_t id, const char *extra)
{
    char buf[SIDE_MSG];
    text t = {buf, sizeof buf, 0};
    side_seen *e = seen_find(&pl->side, id);
    puts_(&t, "{\"ack\": ");
    put_int(&t, id);
    puts_(&t, extra);
    puts_(&t, "}");
    if (e) {
        free(e->answer);
        e->answer = strdup(buf);
    }
    say(pl, buf, t.n);
}

static void answer_error(plant *pl, int64_t id, const char *message)
{
    char buf[SIDE_MSG];
    text t = {buf, sizeof buf, 0};
    puts_(&t, ", \"error\": ");
    put_string(&t, message);
    answer(pl, id, buf);
}

static int make_dirs(const char *dir)
{
    char path[4096];
    size_t i, n = strlen(dir);
    if (n == 0 || n >= sizeof path)
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

static void flush_commands(side_channel *s)
{
    if (s->commands && s->ncmds) {
        uint8_t bytes[SIDE_COMMANDS * 8];
        int i, j;
        for (i = 0; i < s->ncmds; i++) {          /* float64, little-endian (numpy's "<f8") */
            uint64_t bits;
            memcpy(&bits, &s->cmds[i], 8);
            for (j = 0; j < 8; j++)
                bytes[8 * i + j] = (uint8_t)(bits >> (8 * j));
        }
        fwrite(bytes, 8, (size_t)s->ncmds, s->commands);
        fflush(s->commands);
    }
    s->ncmds = 0;
}

/* record_stop: the recording's log closed, its timing.json written; the answer's fields into t */
static void record_stop(plant *pl, int64_t k, text *t)
{
    recording *r = &pl->side.rec;
    char path[4200], reasons[8][REASON_SIZE];
    FILE *fh;
    int nreasons = 0;
    log_close(&r->log);
    r->active = 0;
    flush_commands(&pl->side);
    snprintf(path, sizeof path, "%s/timing.json", r->dir);
    fh = fopen(path, "w");
    if (fh) {
        nreasons = write_timing_window(pl, r, k - r->k0, mono_ns(), fh, reasons);
        fclose(fh);
    }
    puts_(t, ", \"dir\": ");
    put_string(t, r->dir);
    puts_(t, ", \"steps\": ");
    put_int(t, k - r->k0);
    puts_(t, nreasons ? ", \"verdict\": \"INVALID\"" : ", \"verdict\": \"VALID\"");
}

/* One applied event into events.jsonl: {"k": k, <the message's fields but id>, "result": {...}} */
static void log_event(plant *pl, int64_t k, const jobject *o, const char *result)
{
    char buf[SIDE_MSG + 256];
    text t = {buf, sizeof buf, 0};
    int i;
    if (!pl->side.events)
        return;
    puts_(&t, "{\"k\": ");
    put_int(&t, k);
    for (i = 0; i < o->n; i++) {
        const jfield *f = &o->f[i];
        if (strchr(f->key, '.') || strcmp(f->key, "id") == 0 || strcmp(f->key, "k") == 0 || strcmp(f->key, "result") == 0)
            continue;                               /* nested fields are in their object's raw text */
        puts_(&t, ", ");
        put_string(&t, f->key);
        puts_(&t, ": ");
        put(&t, f->raw, f->raw_len);
    }
    if (result)
        puts_(&t, result);
    puts_(&t, "}\n");
    fputs(buf, pl->side.events);
    fflush(pl->side.events);                        /* a crash keeps what was applied */
}

/* The fault of a fault_on as --fault's TYPE:key=value,... text (start and end: it acts from now until off) */
static int fault_spec(const jobject *o, char *spec, size_t size, char *err, size_t errsize)
{
    const jfield *type = field(o, "fault.type");
    text t = {spec, size, 0};
    int i;
    if (!type || type->kind != J_STR) {
        snprintf(err, errsize, "fault.type: a fault type is needed (--list shows them)");
        return -1;
    }
    puts_(&t, type->str);
    puts_(&t, ":start=0");                          /* on from now (steering.fault_model), until fault_off */
    for (i = 0; i < o->n; i++) {
        const jfield *f = &o->f[i];
        const char *key = f->key + 6;
        if (strncmp(f->key, "fault.", 6) != 0 || strcmp(key, "type") == 0 || strcmp(key, "start") == 0 ||
            strcmp(key, "end") == 0 || f->kind == J_NULL)
            continue;
        if (f->kind == J_BOOL) {
            snprintf(err, errsize, "fault.%s: not a number", key);
            return -1;
        }
        puts_(&t, ",");
        puts_(&t, key);
        puts_(&t, "=");
        if (f->kind == J_STR)
            puts_(&t, f->str);
        else
            put(&t, f->raw, f->raw_len);
    }
    if (t.n + 1 >= size) {
        snprintf(err, errsize, "fault: too many fields");
        return -1;
    }
    return 0;
}

static int integral(const jfield *f, double lo, double hi)
{
    return f && f->kind == J_NUM && f->num == floor(f->num) && f->num >= lo && f->num <= hi;
}

/* Apply one steering message at the boundary before step k (simulation/steering.py's rules), answer it. */
static void steer(plant *pl, const jobject *o, int64_t id, int64_t k)
{
    side_channel *s = &pl->side;
    const jfield *op = field(o, "op");
    char extra[SIDE_MSG], err[SIDE_MSG], result[64];
    text t = {extra, sizeof extra, 0};
    extra[0] = '\0';
    result[0] = '\0';
    if (!op || op->kind != J_STR) {
        answer_error(pl, id, "op: a steering operation is needed (set, fault_on, fault_off, reset, stop, "
                             "record_start, record_stop)");
        return;
    }
    if (strcmp(op->str, "stop") == 0) {
        pl->stop_requested = 1;
    } else if (strcmp(op->str, "record_start") == 0 || strcmp(op->str, "record_stop") == 0) {
        const jfield *dir = field(o, "dir");
        if (!s->events) {
            answer_error(pl, id, "recording needs a session folder (hydrohil panel)");
            return;
        }
        if (op->str[7] == 's' && op->str[8] == 't' && op->str[9] == 'a') {      /* record_start */
            recording *r = &s->rec;
            if (r->active) {
                snprintf(err, sizeof err, "already recording into %.4000s", r->dir);
                answer_error(pl, id, err);
                return;
            }
            if (!dir || dir->kind != J_STR || strlen(dir->str) >= sizeof r->dir) {
                answer_error(pl, id, "dir: the recording's folder is needed");
                return;
            }
            if (make_dirs(dir->str) != 0) {
                snprintf(err, sizeof err, "cannot make %.4000s: %s", dir->str, strerror(errno));
                answer_error(pl, id, err);
                return;
            }
            memset(&r->jitter, 0, sizeof r->jitter);
            memset(&r->compute, 0, sizeof r->compute);
            if (log_open(&r->log, dir->str, err, sizeof err) != 0) {
                answer_error(pl, id, err);
                return;
            }
            snprintf(r->dir, sizeof r->dir, "%s", dir->str);
            r->k0 = k;
            r->c0 = counts_now(pl);
            r->t0_ns = mono_ns();
            r->active = 1;
            puts_(&t, ", \"dir\": ");
            put_string(&t, r->dir);
        } else {
            if (!s->rec.active) {
                answer_error(pl, id, "not recording");
                return;
            }
            record_stop(pl, k, &t);
        }
        {
            char buf[SIDE_MSG];
            text a = {buf, sizeof buf, 0};
            puts_(&a, ", \"k\": ");
            put_int(&a, k);
            puts_(&a, extra);
            answer(pl, id, buf);
        }
        return;
    } else if (strcmp(op->str, "set") == 0) {
        const jfield *name = field(o, "name"), *value = field(o, "value");
        const tunable *tu = NULL;
        int i;
        double p[HH_NP];
        for (i = 0; name && name->kind == J_STR && i < HH_NTUNABLES; i++)
            if (strcmp(TUNABLES[i].name, name->str) == 0)
                tu = &TUNABLES[i];
        if (!tu) {
            size_t used = (size_t)snprintf(err, sizeof err, "name: one of");
            for (i = 0; i < HH_NTUNABLES && used < sizeof err; i++)
                used += (size_t)snprintf(err + used, sizeof err - used, " %s", TUNABLES[i].name);
            answer_error(pl, id, err);
            return;
        }
        if (!value || value->kind != J_NUM) {
            answer_error(pl, id, "value: a number is needed");
            return;
        }
        if (!(value->num >= tu->lo && value->num <= tu->hi)) {
            snprintf(err, sizeof err, "%s must be in [%g, %g] %s, got %g", tu->description, tu->lo, tu->hi, tu->unit,
                     value->num);
            answer_error(pl, id, err);
            return;
        }
        s->tunables[tu - TUNABLES] = value->num;
        hh_tuned_base(s->base0, s->tunables, p);
        hh_rig_set_base(&pl->rig, p);
    } else if (strcmp(op->str, "fault_on") == 0) {
        char spec[1024];
        hh_fault f;
        double end;
        int slot;
        if (fault_spec(o, spec, sizeof spec, err, sizeof err) != 0 ||
            fault_from_spec(spec, &f, &end, err, sizeof err) != 0) {
            char msg[SIDE_MSG];
            snprintf(msg, sizeof msg, "fault: %.8000s", err);
            answer_error(pl, id, msg);
            return;
        }
        if (f.type == HH_FAULT_NETWORK_DELAY && !pl->fifo) {
            answer_error(pl, id, "fault: network_delay needs its delay line (start the plant with --panel)");
            return;
        }
        slot = hh_rig_add_live(&pl->rig, &f, k);
        if (slot < 0) {
            snprintf(err, sizeof err, "at most %d faults at a time", HH_MAX_FAULTS);
            answer_error(pl, id, err);
            return;
        }
        snprintf(result, sizeof result, ", \"result\": {\"slot\": %d}", slot);
        puts_(&t, ", \"slot\": ");
        put_int(&t, slot);
    } else if (strcmp(op->str, "fault_off") == 0) {
        const jfield *slot = field(o, "slot");
        if (!integral(slot, 0, HH_MAX_FAULTS - 1)) {
            snprintf(err, sizeof err, "slot: a whole number from 0 to %d", HH_MAX_FAULTS - 1);
            answer_error(pl, id, err);
            return;
        }
        if (hh_rig_end(&pl->rig, (int)slot->num, k) != 0) {
            snprintf(err, sizeof err, "no active fault in slot %d", (int)slot->num);
            answer_error(pl, id, err);
            return;
        }
    } else if (strcmp(op->str, "reset") == 0) {
        plant_reset(pl);
    } else {
        snprintf(err, sizeof err, "op: '%s' is not a plant operation (set, fault_on, fault_off, reset, stop, "
                                  "record_start, record_stop)", op->str);
        answer_error(pl, id, err);
        return;
    }
    if (strcmp(op->str, "stop") != 0)
        log_event(pl, k, o, result[0] ? result : NULL);
    {
        char buf[SIDE_MSG];
        text a = {buf, sizeof buf, 0};
        puts_(&a, ", \"k\": ");
        put_int(&a, k);
        puts_(&a, extra);
        answer(pl, id, buf);
    }
}

/* A datagram from the panel: a valid JSON object with a whole-number id not seen before -> *o, *id, 1. A retry
 * of an answered id is answered again; anything else is ignored (0). */
static int take_message(plant *pl, const char *data, size_t n, jobject *o, int64_t *id)
{
    const jfield *f;
    side_seen *e;
    if (!parse_object(data, n, o))
        return 0;
    f = field(o, "id");
    if (!integral(f, -9.0e15, 9.0e15))
        return 0;
    *id = (int64_t)f->num;
    e = seen_find(&pl->side, *id);
    if (e) {
        if (e->answer)
            say(pl, e->answer, strlen(e->answer));
        return 0;
    }
    seen_add(&pl->side, *id);
    return 1;
}

static void poll_and_steer(plant *pl, int64_t k)
{
    static char data[SIDE_MSG];
    static jobject o;
    for (;;) {
        int64_t id;
        ssize_t n = recv(pl->side.sock, data, sizeof data, MSG_DONTWAIT);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return;                 /* nothing more (or the panel is gone: ICMP refused) */
        if (take_message(pl, data, (size_t)n, &o, &id))
            steer(pl, &o, id, k);
    }
}

/* ---- what rt_plant.c calls ---------------------------------------------------------------------- */
int side_open(plant *pl)
{
    side_channel *s = &pl->side;
    const options *o = pl->o;
    int i;
    s->sock = -1;
    for (i = 0; i < SIDE_SEEN; i++)
        s->seen[i].id = -1;
    for (i = 0; i < HH_NTUNABLES; i++)
        s->tunables[i] = NAN;
    for (i = 0; i < HH_NP; i++)
        s->base0[i] = pl->rig.base[i];
    if (!o->has_panel)
        return 0;
    s->sock = socket(AF_INET, SOCK_DGRAM, 0);
    if (s->sock < 0 || connect(s->sock, (const struct sockaddr *)&o->panel, sizeof o->panel) != 0) {
        fprintf(stderr, "error: the panel's side channel %s: %s\n", o->panel_text, strerror(errno));
        return -1;
    }
    if (o->log_dir) {
        char path[4200];
        snprintf(path, sizeof path, "%s/events.jsonl", o->log_dir);
        s->events = fopen(path, "a");
        snprintf(path, sizeof path, "%s/commands.f64", o->log_dir);
        s->commands = s->events ? fopen(path, "wb") : NULL;
        if (!s->events || !s->commands) {
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
            return -1;
        }
    }
    {
        char buf[2048];
        text t = {buf, sizeof buf, 0};
        puts_(&t, "{\"hello\": \"plant\", \"columns\": [");
        for (i = 0; i < HH_NSIDE; i++) {
            if (i)
                puts_(&t, ", ");
            put_string(&t, SIDE_NAMES[i]);
        }
        puts_(&t, "]}");
        say(pl, buf, t.n);
    }
    return 0;
}

int side_fd(const plant *pl) { return pl->side.sock; }

void side_poll_waiting(plant *pl)
{
    static char data[SIDE_MSG];
    static jobject o;
    side_channel *s = &pl->side;
    if (s->sock < 0)
        return;
    for (;;) {
        int64_t id;
        const jfield *op;
        ssize_t n = recv(s->sock, data, sizeof data, MSG_DONTWAIT);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return;
        if (!take_message(pl, data, (size_t)n, &o, &id))
            continue;
        op = field(&o, "op");
        if ((op && op->kind == J_STR && strcmp(op->str, "stop") == 0) || s->nqueue == SIDE_QUEUE) {
            steer(pl, &o, id, 0);           /* stop at once (a full queue: the rest now too, at step 0) */
        } else {
            memcpy(s->queue[s->nqueue], data, (size_t)n);
            s->queue_len[s->nqueue++] = (size_t)n;
        }
    }
}

void side_apply_queued(plant *pl)
{
    static jobject o;
    side_channel *s = &pl->side;
    int i;
    for (i = 0; i < s->nqueue; i++) {
        const jfield *f;
        if (!parse_object(s->queue[i], s->queue_len[i], &o) || !(f = field(&o, "id")))
            continue;
        steer(pl, &o, (int64_t)f->num, 0);
    }
    s->nqueue = 0;
}

static void send_batch(plant *pl, int64_t steps)
{
    side_channel *s = &pl->side;
    static uint8_t buf[HHIL_TM_HEADER_LEN + 8 * HHIL_TM_COUNTERS + 8 * SIDE_BATCH * HH_NSIDE];
    int64_t c[HH_NSIDEC];
    size_t n;
    if (!s->n)
        return;
    c[HH_SIDEC_OVERRUNS] = pl->overruns;
    c[HH_SIDEC_LATE_COMMANDS] = pl->late_commands;
    c[HH_SIDEC_WATCHDOG_TRIPS] = pl->rig.link.trips;
    c[HH_SIDEC_WATCHDOG_TRIPS_UNEXPLAINED] = pl->rig.link.trips_unexplained;
    c[HH_SIDEC_PACKETS_LOST] = pl->packets_lost;
    c[HH_SIDEC_TELEMETRY_DROPPED] = s->dropped;
    c[HH_SIDEC_JITTER_MAX_NS] = pl->jitter.max_ns;
    c[HH_SIDEC_STEPS] = steps;
    n = hhil_encode_telemetry(buf, HHIL_TM_ROLE_PLANT, s->k0, c, s->rows, HH_NSIDE, s->n);
    if (send(s->sock, buf, n, MSG_DONTWAIT) == (ssize_t)n)
        s->sent++;
    else
        s->dropped++;               /* EAGAIN (the panel stalls), ECONNREFUSED (no panel): dropped, counted */
    s->n = 0;
}

void side_row(plant *pl, int64_t k, const reading *r, int64_t late_ns, int64_t compute_ns, double u)
{
    side_channel *s = &pl->side;
    const double *out = pl->sim.out;
    double *row;
    if (s->sock < 0)
        return;
    if (s->commands) {
        s->cmds[s->ncmds++] = u;
        if (s->ncmds == SIDE_COMMANDS)
            flush_commands(s);
    }
    if (s->n == 0)
        s->k0 = k;
    row = s->rows + (size_t)s->n * HH_NSIDE;
    row[HH_SIDE_T] = out[HH_OUT_T];
    row[HH_SIDE_XP] = out[HH_OUT_Y + HH_XP];
    row[HH_SIDE_VP] = out[HH_OUT_Y + HH_VP];
    row[HH_SIDE_XS] = out[HH_OUT_Y + HH_XS];
    row[HH_SIDE_U] = u;
    row[HH_SIDE_P1] = out[HH_OUT_Y + HH_P1];
    row[HH_SIDE_P2] = out[HH_OUT_Y + HH_P2];
    row[HH_SIDE_PS] = pl->sim.p[HH_SUPPLY_PS];
    row[HH_SIDE_FF] = out[HH_OUT_FF];
    row[HH_SIDE_TRAVEL_MODE] = out[HH_OUT_TRAVEL];
    row[HH_SIDE_FRICTION_MODE] = out[HH_OUT_FRICTION];
    row[HH_SIDE_SPOOL_MODE] = out[HH_OUT_SPOOL];
    row[HH_SIDE_JITTER_US] = (double)late_ns / 1e3;
    row[HH_SIDE_COMPUTE_US] = (double)compute_ns / 1e3;
    row[HH_SIDE_WATCHDOG] = pl->rig.link.active;
    row[HH_SIDE_FAULTS] = (double)r->faults;
    row[HH_SIDE_X_MEAS] = (double)r->encoder * pl->rig.count;
    if (++s->n == SIDE_BATCH) {
        send_batch(pl, k);
        poll_and_steer(pl, k);
    }
}

void side_close(plant *pl, int64_t k_done)
{
    side_channel *s = &pl->side;
    int i;
    if (s->sock < 0)
        return;
    if (s->rec.active) {
        char buf[SIDE_MSG];
        text t = {buf, sizeof buf, 0};
        record_stop(pl, k_done, &t);
    }
    flush_commands(s);
    if (s->commands)
        fclose(s->commands);
    if (s->events)
        fclose(s->events);
    s->commands = s->events = NULL;
    send_batch(pl, k_done);
    for (i = 0; i < SIDE_SEEN; i++) {
        free(s->seen[i].answer);
        s->seen[i].answer = NULL;
    }
    close(s->sock);
    s->sock = -1;
}
