/* rt_side.c: the standalone plant's side channel to the live panel (rt_side.h), as hydrohil plant's
 * (hil/sidechannel.py, hil/session.py, simulation/steering.py; docs/protocol.md "Panel side channel"), for either
 * model behind the plant (the paper's rig, rt_rig.c; a circuit, rt_circuit.c: each gives its telemetry columns
 * and row, the commands a session records and its steering operations, model_side_* / model_steer):
 *
 *   telemetry   a row per step (the model's columns) sent in batches of SIDE_BATCH rows with the plant's
 *               counters, non-blocking: a batch the panel has no room for is dropped and counted;
 *   steering    JSON messages read (non-blocking) once per batch, applied at the boundary before step k: the
 *               model's operations, and stop, record_start {"dir"}, record_stop here; answered {"ack": id, "k": k,
 *               ...} or {"ack": id, "error": "..."}; a repeated id is answered again, never applied twice;
 *   session     with --log: DIR/events.jsonl (every applied event with its k, replayable by
 *               hydrohil.hil.session.replay_session or hydrohil.hil.circuit.replay_circuit_session),
 *               DIR/commands.f64 (the model's commands applied at each step), recordings (DIR/.../plant_log.csv +
 *               timing.json of the steps recorded, the model's log columns).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include "rt_side.h"

/* ---- a JSON object of the panel: flat fields and one nested object (rt_side.h) ----------------------- */
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

/* The length of the UTF-8 sequence at p (1..4), or 0 when it is not one (overlong, surrogate, beyond U+10FFFF). */
static int utf8_length(const unsigned char *p, const unsigned char *e)
{
    int n, i;
    unsigned lo = 0x80, hi = 0xBF;
    if (p[0] < 0x80)
        return 1;
    if (p[0] >= 0xC2 && p[0] <= 0xDF)
        n = 2;
    else if (p[0] >= 0xE0 && p[0] <= 0xEF) {
        n = 3;
        lo = p[0] == 0xE0 ? 0xA0 : 0x80;
        hi = p[0] == 0xED ? 0x9F : 0xBF;
    } else if (p[0] >= 0xF0 && p[0] <= 0xF4) {
        n = 4;
        lo = p[0] == 0xF0 ? 0x90 : 0x80;
        hi = p[0] == 0xF4 ? 0x8F : 0xBF;
    } else
        return 0;
    if (e - p < n || p[1] < lo || p[1] > hi)
        return 0;
    for (i = 2; i < n; i++)
        if (p[i] < 0x80 || p[i] > 0xBF)
            return 0;
    return n;
}

/* A JSON string at p (at its opening quote) decoded into the store; the position after it, or NULL. */
static const char *parse_string(const char *p, const char *e, jobject *o, const char **out)
{
    char *d = o->store + o->used, *end = o->store + sizeof o->store - 5;
    *out = d;
    if (p >= e || *p != '"')
        return NULL;
    for (p++; p < e && *p != '"'; p++) {
        unsigned c = (unsigned char)*p;
        if (d >= end || c < 0x20)
            return NULL;
        if (c >= 0x80) {                                /* valid UTF-8 only: the answers echo it */
            int n = utf8_length((const unsigned char *)p, (const unsigned char *)e);
            if (!n)
                return NULL;
            memcpy(d, p, (size_t)n);
            d += n;
            p += n - 1;
            continue;
        }
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

static int digit(const char *q, const char *e) { return q < e && *q >= '0' && *q <= '9'; }

/* A JSON number, its grammar exactly: -?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)? (finite) */
static const char *parse_number_json(const char *p, const char *e, double *v)
{
    char buf[64];
    const char *q = p;
    char *end;
    size_t n;
    if (q < e && *q == '-')
        q++;
    if (!digit(q, e))
        return NULL;
    if (*q == '0')
        q++;
    else
        while (digit(q, e))
            q++;
    if (q < e && *q == '.') {
        if (!digit(++q, e))
            return NULL;
        while (digit(q, e))
            q++;
    }
    if (q < e && (*q == 'e' || *q == 'E')) {
        q++;
        if (q < e && (*q == '+' || *q == '-'))
            q++;
        if (!digit(q, e))
            return NULL;
        while (digit(q, e))
            q++;
    }
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
        if (strchr(key, '.') || (size_t)snprintf(f->key, sizeof f->key, "%s%s", prefix, key) >= sizeof f->key)
            return NULL;
        {
            int i;
            for (i = 0; i < o->n - 1; i++)          /* a key given twice: which one counts is not clear */
                if (strcmp(o->f[i].key, f->key) == 0)
                    return NULL;
        }
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
            f->kind = J_OBJ;                        /* the object itself: its fields follow as key.field */
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

const jfield *side_field(const jobject *o, const char *key)
{
    int i;
    for (i = 0; i < o->n; i++)
        if (strcmp(o->f[i].key, key) == 0)
            return &o->f[i];
    return NULL;
}

/* ---- writing JSON ------------------------------------------------------------------------------ */
void side_put(text *t, const char *s, size_t n)
{
    if (t->n + n + 1 > t->size) {
        t->overflow = 1;
        return;
    }
    memcpy(t->buf + t->n, s, n);
    t->n += n;
    t->buf[t->n] = '\0';
}

void side_puts(text *t, const char *s) { side_put(t, s, strlen(s)); }

/* s as a JSON string (s is valid UTF-8: the parser took only that, the plant's own texts are ASCII) */
void side_put_string(text *t, const char *s)
{
    side_put(t, "\"", 1);
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        char esc[8];
        if (c == '"' || c == '\\') {
            esc[0] = '\\';
            esc[1] = (char)c;
            side_put(t, esc, 2);
        } else if (c < 0x20) {
            snprintf(esc, sizeof esc, "\\u%04x", c);
            side_put(t, esc, 6);
        } else {
            side_put(t, (const char *)&c, 1);
        }
    }
    side_put(t, "\"", 1);
}

void side_put_int(text *t, int64_t v)
{
    char b[32];
    snprintf(b, sizeof b, "%lld", (long long)v);
    side_puts(t, b);
}

/* a float as Python's json writes it (repr: shortest round trip, ".0" on whole numbers) */
void side_put_double(text *t, double v)
{
    char b[40];
    fmt_double(b, sizeof b, v);
    if (!strpbrk(b, ".e"))
        strcat(b, ".0");
    side_puts(t, b);
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
        if (s->seen[i].used && s->seen[i].id == id)
            return &s->seen[i];
    return NULL;
}

static void seen_add(side_channel *s, int64_t id)
{
    side_seen *e = &s->seen[s->seen_next];
    s->seen_next = (s->seen_next + 1) % SIDE_SEEN;
    free(e->answer);
    e->answer = NULL;
    e->used = 1;
    e->id = id;
}

/* Answer message id with the fields in extra (", \"k\": 12, ..." or ", \"error\": ..."); kept for a retry. */
static void answer(plant *pl, int64_t id, const char *extra)
{
    char buf[SIDE_MSG];
    text t = {buf, sizeof buf, 0, 0};
    side_seen *e = seen_find(&pl->side, id);
    side_puts(&t, "{\"ack\": ");
    side_put_int(&t, id);
    side_puts(&t, extra);
    side_puts(&t, "}");
    if (t.overflow) {
        t.n = (size_t)snprintf(buf, sizeof buf, "{\"ack\": %lld, \"error\": \"the answer is too long\"}", (long long)id);
    }
    if (e) {
        free(e->answer);
        e->answer = strdup(buf);
    }
    say(pl, buf, t.n);
}

static void answer_error(plant *pl, int64_t id, const char *message)
{
    char buf[SIDE_MSG];
    text t = {buf, sizeof buf, 0, 0};
    side_puts(&t, ", \"error\": ");
    side_put_string(&t, message);
    answer(pl, id, t.overflow ? ", \"error\": \"refused (the reason is too long to say)\"" : buf);
}

static void answer_applied(plant *pl, int64_t id, int64_t k, const char *extra)
{
    char buf[SIDE_MSG];
    text t = {buf, sizeof buf, 0, 0};
    side_puts(&t, ", \"k\": ");
    side_put_int(&t, k);
    side_puts(&t, extra);
    answer(pl, id, buf);
}

/* ---- the session writer: the session folder's files, written off the step loop ------------------ */
static uint32_t load32(const uint32_t *v) { return __atomic_load_n(v, __ATOMIC_ACQUIRE); }
static void store32(uint32_t *v, uint32_t x) { __atomic_store_n(v, x, __ATOMIC_RELEASE); }
static int load_state(const int *v) { return __atomic_load_n(v, __ATOMIC_ACQUIRE); }
static void store_state(int *v, int x) { __atomic_store_n(v, x, __ATOMIC_RELEASE); }

static int write_all(FILE *fh, const char *text, size_t n)
{
    return fh && fwrite(text, 1, n, fh) == n && fflush(fh) == 0;
}

/* One pass over what the step loop handed over; returns whether there was anything. */
static int writer_pass(side_channel *s)
{
    side_writer *w = &s->w;
    recording *r = &s->rec;
    uint32_t head, tail;
    int busy = 0, state = load_state(&r->state);
    head = load32(&w->cmd_head);
    if ((tail = w->cmd_tail) != head) {           /* commands.f64: float64, little-endian (numpy's "<f8") */
        uint8_t bytes[8 * 256];
        while (tail != head) {
            int n = 0, j;
            for (; n < 256 && tail != head; n++, tail++) {
                uint64_t bits;
                memcpy(&bits, &w->cmds[tail % w->cmd_room], 8);
                for (j = 0; j < 8; j++)
                    bytes[8 * n + j] = (uint8_t)(bits >> (8 * j));
            }
            fwrite(bytes, 8, (size_t)n, w->commands);
        }
        fflush(w->commands);
        store32(&w->cmd_tail, tail);
        busy = 1;
    }
    head = load32(&w->ev_head);
    if ((tail = w->ev_tail) != head) {            /* events.jsonl: a crash keeps what was applied */
        for (; tail != head; tail++)
            fputs(w->ev[tail % SIDE_EVENTS], w->events);
        fflush(w->events);
        store32(&w->ev_tail, tail);
        busy = 1;
    }
    if (state != REC_IDLE && !w->rec_fh && !r->error[0]) {
        char path[4200];
        snprintf(path, sizeof path, "%s/plant_log.csv", r->dir);
        w->rec_fh = fopen(path, "w");
        if (!w->rec_fh)
            snprintf(r->error, sizeof r->error, "cannot write %.4200s: %s", path, strerror(errno));
        else
            log_header_of(model_log_columns(), w->rec_fh);
    }
    head = load32(&w->row_head);
    if ((tail = w->row_tail) != head) {
        for (; tail != head; tail++) {
            if (w->text_len + SIDE_ROW_TEXT * (size_t)w->ncols > SIDE_TEXT)   /* (a row's text fits) */
                w->text_len = (write_all(w->rec_fh, w->text, w->text_len), 0);
            w->text_len += log_format_row_of(model_log_columns(), w->text + w->text_len,
                                             w->rows + (size_t)(tail % SIDE_RING) * (size_t)w->ncols);
        }
        store32(&w->row_tail, tail);
        busy = 1;
    }
    if (state == REC_CLOSING && load32(&w->row_tail) == r->close_head) {
        write_all(w->rec_fh, w->text, w->text_len);
        w->text_len = 0;
        if (w->rec_fh)
            fclose(w->rec_fh);
        w->rec_fh = NULL;
        if (!r->error[0]) {
            char path[4200];
            FILE *fh;
            snprintf(path, sizeof path, "%s/timing.json", r->dir);
            fh = fopen(path, "w");
            if (!write_all(fh, r->timing, r->timing_len))
                snprintf(r->error, sizeof r->error, "cannot write %.4200s: %s", path, strerror(errno));
            if (fh)
                fclose(fh);
        }
        store_state(&r->state, REC_IDLE);
        busy = 1;
    }
    return busy;
}

static void *writer_thread(void *arg)
{
    side_channel *s = arg;
    for (;;) {
        int quit = load_state(&s->w.quit);
        if (writer_pass(s))
            continue;
        if (quit && load_state(&s->rec.state) == REC_IDLE)
            break;
        {
            struct timespec nap = {0, 1000000};   /* 1 ms: the step loop never signals (no syscall for it) */
            nanosleep(&nap, NULL);
        }
    }
    fclose(s->w.commands);
    fclose(s->w.events);
    return NULL;
}

/* Room for one more event line (a change is refused, not applied unlogged, when the writer is behind). */
static int event_room(const side_channel *s)
{
    return !s->session || s->w.ev_head - load32(&s->w.ev_tail) < SIDE_EVENTS;
}

static void push_event(side_channel *s, const char *line)
{
    if (!s->session)
        return;
    snprintf(s->w.ev[s->w.ev_head % SIDE_EVENTS], SIDE_EVENT_LINE, "%s", line);
    store32(&s->w.ev_head, s->w.ev_head + 1U);
}

void side_record_row(plant *pl, const double *row, int64_t jitter_ns, int64_t compute_ns)
{
    side_writer *w = &pl->side.w;
    recording *r = &pl->side.rec;
    latency_add(&r->jitter, jitter_ns);
    latency_add(&r->compute, compute_ns);
    if (w->row_head - load32(&w->row_tail) >= SIDE_RING) {
        r->dropped++;               /* the writer fell 8 s behind: lose a row, never a step */
        return;
    }
    memcpy(w->rows + (size_t)(w->row_head % SIDE_RING) * (size_t)w->ncols, row, sizeof(double) * (size_t)w->ncols);
    store32(&w->row_head, w->row_head + 1U);
}

/* record_stop at boundary k: the rows end, timing.json made here and handed to the writer with them; the answer
 * (id >= 0) goes once both are written (the panel reads them then). */
static void record_stop(plant *pl, int64_t k, int64_t id)
{
    recording *r = &pl->side.rec;
    char reasons[8][REASON_SIZE];
    text t = {r->answer, sizeof r->answer, 0, 0};
    FILE *fh = fmemopen(r->timing, sizeof r->timing, "w");
    int nreasons = 0;
    r->active = 0;
    r->timing_len = 0;
    if (fh) {
        nreasons = write_timing_window(pl, r, k - r->k0, mono_ns(), fh, reasons);
        r->timing_len = (size_t)ftell(fh);
        fclose(fh);
    }
    side_puts(&t, ", \"k\": ");
    side_put_int(&t, k);
    side_puts(&t, ", \"dir\": ");
    side_put_string(&t, r->dir);
    side_puts(&t, ", \"steps\": ");
    side_put_int(&t, k - r->k0);
    side_puts(&t, nreasons ? ", \"verdict\": \"INVALID\"" : ", \"verdict\": \"VALID\"");
    r->answer_id = id;
    r->close_head = pl->side.w.row_head;
    store_state(&r->state, REC_CLOSING);
}

/* A record_stop written by now: its answer (or what could not be written) */
static void answer_recording(plant *pl)
{
    recording *r = &pl->side.rec;
    if (r->answer_id < 0 || load_state(&r->state) != REC_IDLE)
        return;
    if (r->error[0]) {
        answer_error(pl, r->answer_id, r->error);
    } else {
        char buf[SIDE_MSG];
        snprintf(buf, sizeof buf, "%s", r->answer);
        answer(pl, r->answer_id, buf + 0);
    }
    r->answer_id = -1;
}

/* ---- steering (simulation/steering.py's events, the plant's) ------------------------------------ */
int side_integral(const jfield *f, double lo, double hi)
{
    return f && f->kind == J_NUM && f->num == floor(f->num) && f->num >= lo && f->num <= hi;
}

/* The message's fields are id, op, k, result (ignored) and those of its op: NULL, or the first other one. */
const char *side_unexpected_field(const jobject *o, const char *const *allowed)
{
    int i, j;
    for (i = 0; i < o->n; i++) {
        const char *key = o->f[i].key;
        int ok = strchr(key, '.') != NULL || strcmp(key, "id") == 0 || strcmp(key, "op") == 0 ||
                 strcmp(key, "k") == 0 || strcmp(key, "result") == 0;
        for (j = 0; !ok && allowed[j]; j++)
            ok = strcmp(key, allowed[j]) == 0;
        if (!ok)
            return key;
    }
    return NULL;
}

static void record_start(plant *pl, const jobject *o, int64_t id, int64_t k)
{
    recording *r = &pl->side.rec;
    const jfield *dir = side_field(o, "dir");
    char err[SIDE_MSG];
    const char *c;
    int bad = !dir || dir->kind != J_STR || !dir->str[0] || strlen(dir->str) >= sizeof r->dir;
    for (c = dir && dir->kind == J_STR ? dir->str : ""; !bad && *c; c++)
        bad = (unsigned char)*c < 0x20;
    if (bad) {
        answer_error(pl, id, "dir: the recording's folder is needed (a path without control characters)");
        return;
    }
    if (r->active) {
        snprintf(err, sizeof err, "already recording into %.4000s", r->dir);
        answer_error(pl, id, err);
        return;
    }
    if (load_state(&r->state) != REC_IDLE) {
        answer_error(pl, id, "the last recording is still being written: try again");
        return;
    }
    if (make_dirs(dir->str) != 0 || access(dir->str, W_OK) != 0) {
        snprintf(err, sizeof err, "cannot write into %.4000s: %s", dir->str, strerror(errno));
        answer_error(pl, id, err);
        return;
    }
    snprintf(r->dir, sizeof r->dir, "%s", dir->str);
    memset(&r->jitter, 0, sizeof r->jitter);
    memset(&r->compute, 0, sizeof r->compute);
    r->error[0] = '\0';
    r->dropped = 0;
    r->k0 = k;
    r->c0 = counts_now(pl);
    r->t0_ns = mono_ns();
    r->active = 1;
    store_state(&r->state, REC_OPEN);
    {
        char buf[SIDE_MSG];
        text t = {buf, sizeof buf, 0, 0};
        side_puts(&t, ", \"dir\": ");
        side_put_string(&t, r->dir);
        answer_applied(pl, id, k, buf);
    }
}

/* Apply one steering message at the boundary before step k (simulation/steering.py's rules: stop and the
 * recordings here, the model's operations by model_steer), log it in events.jsonl as the Python plant does (its
 * checked values, not the message's text), answer it. */
static void steer(plant *pl, const jobject *o, int64_t id, int64_t k)
{
    static const char *const none[] = {NULL}, *const record_fields[] = {"dir", NULL};
    side_channel *s = &pl->side;
    const jfield *op = side_field(o, "op");
    const char *odd;
    char err[SIDE_MSG], line[SIDE_EVENT_LINE], extra[64] = "";
    text ev = {line, sizeof line, 0, 0};
    int own = op && op->kind == J_STR && (strcmp(op->str, "stop") == 0 || strcmp(op->str, "record_start") == 0 ||
                                          strcmp(op->str, "record_stop") == 0);
    if (!op || op->kind != J_STR) {
        snprintf(err, sizeof err, "op: a steering operation is needed (%s, stop, record_start, record_stop)",
                 MODEL_STEER_OPS);
        answer_error(pl, id, err);
        return;
    }
    if (own && (odd = side_unexpected_field(o, strcmp(op->str, "record_start") == 0 ? record_fields : none))) {
        snprintf(err, sizeof err, "%.100s: not a field of %s", odd, op->str);
        answer_error(pl, id, err);
        return;
    }
    if (strcmp(op->str, "stop") == 0) {
        pl->stop_requested = 1;
        answer_applied(pl, id, k, "");
        return;
    }
    if (own) {                                        /* record_start, record_stop */
        if (!s->session) {
            answer_error(pl, id, "recording needs a session folder (hydrohil panel)");
        } else if (strcmp(op->str, "record_start") == 0) {
            record_start(pl, o, id, k);
        } else if (!s->rec.active) {
            answer_error(pl, id, "not recording");
        } else {
            record_stop(pl, k, id);               /* answered once written (answer_recording) */
        }
        return;
    }
    if (!event_room(s)) {
        answer_error(pl, id, "the session's event log is behind: try again");
        return;
    }
    side_puts(&ev, "{\"k\": ");
    side_put_int(&ev, k);
    side_puts(&ev, ", \"op\": ");
    side_put_string(&ev, op->str);
    switch (model_steer(pl, o, op->str, k, &ev, extra, sizeof extra, err, sizeof err)) {
    case SIDE_APPLIED:
        side_puts(&ev, "}\n");
        push_event(s, line);                          /* (fits: the longest event is a fault_on, < 1.2 kB) */
        answer_applied(pl, id, k, extra);
        return;
    case SIDE_REFUSED:
        answer_error(pl, id, err);
        return;
    default:
        snprintf(err, sizeof err, "op: '%.100s' is not a plant operation (%s, stop, record_start, record_stop)",
                 op->str, MODEL_STEER_OPS);
        answer_error(pl, id, err);
    }
}

/* A datagram from the panel: a valid JSON object with a whole-number id not seen before -> *o, *id, 1. A retry
 * of an answered id is answered again; anything else is ignored (0). take = 0: read, not taken (a full
 * queue: the panel resends it) unless it is a stop. */
static int take_message(plant *pl, const char *data, size_t n, jobject *o, int64_t *id, int take)
{
    const jfield *f, *op;
    side_seen *e;
    if (!parse_object(data, n, o))
        return 0;
    f = side_field(o, "id");
    if (!side_integral(f, -9.0e15, 9.0e15))
        return 0;
    *id = (int64_t)f->num;
    e = seen_find(&pl->side, *id);
    if (e) {
        if (e->answer)
            say(pl, e->answer, strlen(e->answer));
        return 0;
    }
    op = side_field(o, "op");
    if (!take && !(op && op->kind == J_STR && strcmp(op->str, "stop") == 0))
        return 0;
    seen_add(&pl->side, *id);
    return 1;
}

static void poll_and_steer(plant *pl, int64_t k)
{
    static char data[SIDE_MSG];
    static jobject o;
    int i;
    for (i = 0; i < SIDE_POLL_MAX; i++) {             /* at most this many a batch: a flood cannot hold the loop */
        int64_t id;
        ssize_t n = recv(pl->side.sock, data, sizeof data, MSG_DONTWAIT);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return;                 /* nothing more (or the panel is gone: ICMP refused) */
        if (take_message(pl, data, (size_t)n, &o, &id, 1))
            steer(pl, &o, id, k);
    }
}

/* ---- what rt_plant.c calls ---------------------------------------------------------------------- */
int side_open(plant *pl)
{
    side_channel *s = &pl->side;
    const options *o = pl->o;
    int i;
    const char *const *names = model_side_columns(&s->ncols);
    s->sock = -1;
    s->rec.answer_id = -1;
    model_side_open(pl);
    if (!o->has_panel)
        return 0;
    s->sock = socket(AF_INET, SOCK_DGRAM, 0);
    if (s->sock < 0 || connect(s->sock, (const struct sockaddr *)&o->panel, sizeof o->panel) != 0) {
        fprintf(stderr, "error: the panel's side channel %s: %s\n", o->panel_text, strerror(errno));
        return -1;
    }
    if (o->log_dir) {               /* the session folder, written by the session writer (started here: before
                                     * realtime_setup, so it keeps the normal policy) */
        side_writer *w = &s->w;
        char path[4200];
        snprintf(path, sizeof path, "%s/events.jsonl", o->log_dir);
        w->events = fopen(path, "a");
        snprintf(path, sizeof path, "%s/commands.f64", o->log_dir);
        w->commands = w->events ? fopen(path, "wb") : NULL;
        if (!w->events || !w->commands) {
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
            return -1;
        }
        w->ncols = model_log_columns()->n;
        {                               /* commands.f64: SIDE_RING steps of the model's commands (a circuit: its
                                         * inputs), a power of two of them (the counters wrap cleanly) */
            double probe[SIDE_MAX_COMMANDS];
            int ncmds = model_side_commands(pl, 0.0, probe);
            for (w->cmd_room = SIDE_RING; w->cmd_room < (uint32_t)SIDE_RING * (uint32_t)ncmds; w->cmd_room <<= 1)
                ;
        }
        w->cmds = malloc(sizeof(double) * w->cmd_room);
        w->ev = malloc(sizeof *w->ev * SIDE_EVENTS);
        w->rows = malloc(sizeof(double) * SIDE_RING * (size_t)w->ncols);
        w->text = malloc(SIDE_TEXT);
        if (!w->cmds || !w->ev || !w->rows || !w->text) {
            fprintf(stderr, "error: out of memory for the session writer\n");
            return -1;
        }
        if (start_writer_thread(&w->thread, writer_thread, s) != 0) {
            fprintf(stderr, "error: cannot start the session writer thread\n");
            return -1;
        }
        w->started = s->session = 1;
    }
    {
        static char buf[65507];         /* (the largest UDP datagram: a circuit's hundreds of columns) */
        text t = {buf, sizeof buf, 0, 0};
        side_puts(&t, "{\"hello\": \"plant\", \"columns\": [");
        for (i = 0; i < s->ncols; i++) {
            if (i)
                side_puts(&t, ", ");
            side_put_string(&t, names[i]);
        }
        side_puts(&t, "]}");
        if (t.overflow) {
            fprintf(stderr, "error: the panel's hello does not fit a datagram (%d columns)\n", s->ncols);
            return -1;
        }
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
    int i;
    if (s->sock < 0)
        return;
    for (i = 0; i < SIDE_POLL_MAX; i++) {
        int64_t id;
        const jfield *op;
        ssize_t n = recv(s->sock, data, sizeof data, MSG_DONTWAIT);
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return;
        if (!take_message(pl, data, (size_t)n, &o, &id, s->nqueue < SIDE_QUEUE))
            continue;
        op = side_field(&o, "op");
        if (op && op->kind == J_STR && strcmp(op->str, "stop") == 0) {
            steer(pl, &o, id, 0);           /* stop at once; the rest at step 0, in order */
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
        if (parse_object(s->queue[i], s->queue_len[i], &o) && (f = side_field(&o, "id")) != NULL)
            steer(pl, &o, (int64_t)f->num, 0);
    }
    s->nqueue = 0;
}

static void send_batch(plant *pl, int64_t steps)
{
    side_channel *s = &pl->side;
    static uint8_t buf[HHIL_TM_HEADER_LEN + 8 * HHIL_TM_COUNTERS + 8 * SIDE_BATCH * SIDE_MAX_COLUMNS];
    int64_t c[HH_NSIDEC];
    size_t n;
    if (!s->n)
        return;
    c[HH_SIDEC_OVERRUNS] = pl->overruns;
    c[HH_SIDEC_LATE_COMMANDS] = pl->late_commands;
    c[HH_SIDEC_WATCHDOG_TRIPS] = pl->link->trips;
    c[HH_SIDEC_WATCHDOG_TRIPS_UNEXPLAINED] = pl->link->trips_unexplained;
    c[HH_SIDEC_PACKETS_LOST] = pl->packets_lost;
    c[HH_SIDEC_TELEMETRY_DROPPED] = s->dropped;
    c[HH_SIDEC_JITTER_MAX_NS] = pl->jitter.max_ns;
    c[HH_SIDEC_STEPS] = steps;
    n = hhil_encode_telemetry(buf, HHIL_TM_ROLE_PLANT, s->k0, c, s->rows, s->ncols, s->n);
    if (send(s->sock, buf, n, MSG_DONTWAIT) == (ssize_t)n)
        s->sent++;
    else
        s->dropped++;               /* EAGAIN (the panel stalls), ECONNREFUSED (no panel): dropped, counted */
    s->n = 0;
}

void side_row(plant *pl, int64_t k, const reading *r, int64_t late_ns, int64_t compute_ns, double u)
{
    side_channel *s = &pl->side;
    if (s->sock < 0)
        return;
    if (s->session) {                 /* commands.f64: the command (a circuit: every input) applied at each step */
        side_writer *w = &s->w;
        double cmds[SIDE_MAX_COMMANDS];
        int i, n = model_side_commands(pl, u, cmds);
        if (w->cmd_head - load32(&w->cmd_tail) + (uint32_t)n <= w->cmd_room) {
            for (i = 0; i < n; i++)
                w->cmds[(w->cmd_head + (uint32_t)i) % w->cmd_room] = cmds[i];
            store32(&w->cmd_head, w->cmd_head + (uint32_t)n);
        } else {
            w->cmds_dropped++;        /* (the writer fell seconds behind) */
        }
    }
    if (s->n == 0)
        s->k0 = k;
    model_side_row(pl, s->rows + (size_t)s->n * (size_t)s->ncols, r, late_ns, compute_ns, u);
    if (++s->n == SIDE_BATCH) {
        send_batch(pl, k);
        answer_recording(pl);
        poll_and_steer(pl, k);
    }
}

void side_close(plant *pl, int64_t k_done)
{
    side_channel *s = &pl->side;
    int i;
    if (s->sock < 0)
        return;
    if (s->rec.active)                /* a recording open at the end ends here (as the Python plant's) */
        record_stop(pl, k_done, -1);
    if (s->w.started) {               /* the end of the run: waiting for the writer is allowed now */
        store_state(&s->w.quit, 1);
        pthread_join(s->w.thread, NULL);
        s->w.started = 0;
    }
    if (s->w.cmds_dropped)            /* (commands.f64 lost steps: the session no longer replays from them) */
        fprintf(stderr, "warning: the session writer fell behind: %lld steps' commands not in commands.f64\n",
                (long long)s->w.cmds_dropped);
    answer_recording(pl);
    send_batch(pl, k_done);
    for (i = 0; i < SIDE_SEEN; i++) {
        free(s->seen[i].answer);
        s->seen[i].answer = NULL;
    }
    free(s->w.cmds);
    free(s->w.ev);
    free(s->w.rows);
    free(s->w.text);
    close(s->sock);
    s->sock = -1;
}
