/* rt_log.c: plant_log.csv of the standalone plant (rt_plant.h): the step loop copies a row into a ring,
 * a writer thread formats rows (the same text as the Python plant's) and hands whole lines to the OS. */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rt_plant.h"

#define LOG_RING (1 << 14)        /* rows between the step loop and the log writer (8 s at 2 kHz) */
#define LOG_FLUSH_ROWS 2000
#define LOG_FLUSH_NS 500000000LL

/* ---- numbers as text ---------------------------------------------------------------------------- */
/* Shortest text that reads back to the same double (as Python's repr); "nan" / "inf" / "-inf". */
void fmt_double(char *buf, size_t size, double v)
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

const char *fmt_g6(char *buf, double v)
{
    if (isnan(v))
        return "nan";
    if (isinf(v))
        return v > 0 ? "inf" : "-inf";
    snprintf(buf, 32, "%.6g", v);
    return buf;
}

/* ---- the log writer: a ring of rows filled by the step loop, formatted by a thread --------------- */


#define LOG_TEXT (1 << 20)          /* formatted rows handed to the OS as whole lines */

const log_columns RIG_LOG_COLUMNS = {HH_NPLOG, PLANT_LOG_NAMES, PLANT_LOG_KINDS};

size_t log_format_row_of(const log_columns *cols, char *t, const double *r) { return format_row(cols, t, r); }

size_t format_row(const log_columns *cols, char *t, const double *r)
{
    char v[40];
    size_t n = 0;
    int j;
    for (j = 0; j < cols->n; j++) {
        const char *word = NULL;
        if (j)
            t[n++] = ',';
        switch (cols->kinds[j]) {         /* how core/shape.py (or the circuit's export) says it is written */
        case PLOG_MODE_TRAVEL: word = TRAVEL_NAMES[(int)r[j] % HH_N_TRAVEL]; break;
        case PLOG_MODE_FRICTION: word = FRICTION_NAMES[(int)r[j] % HH_N_FRICTION]; break;
        case PLOG_MODE_SPOOL: word = SPOOL_NAMES[(int)r[j] % HH_N_SPOOL]; break;
        case PLOG_INT:
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
            if (w->text_len + SIDE_ROW_TEXT * (size_t)w->cols->n > LOG_TEXT)   /* (a row's text fits) */
                flush_text(w);
            w->text_len += format_row(w->cols, w->text + w->text_len, w->rows + (size_t)(tail % LOG_RING) * w->cols->n);
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

int start_writer_thread(pthread_t *thread, void *(*run)(void *), void *arg)
{
    sigset_t block, old;
    int rc;
    sigemptyset(&block);
    sigaddset(&block, SIGINT);
    sigaddset(&block, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &block, &old);      /* the writer inherits the mask: signals go to the loop */
    rc = pthread_create(thread, NULL, run, arg);
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return rc;
}

static void header(const log_columns *cols, FILE *fh)
{
    int j;
    for (j = 0; j < cols->n; j++)
        fprintf(fh, "%s%s", j ? "," : "", cols->names[j]);
    fputc('\n', fh);
}

void log_header_of(const log_columns *cols, FILE *fh) { header(cols, fh); }

int log_open(log_writer *w, const log_columns *cols, const char *dir, char *err, size_t size)
{
    char path[4096];
    memset(w, 0, sizeof *w);
    w->cols = cols;
    if (!dir)
        return 0;
    snprintf(path, sizeof path, "%s/plant_log.csv", dir);
    w->fh = fopen(path, "w");
    if (!w->fh) {
        snprintf(err, size, "cannot write %s: %s", path, strerror(errno));
        return -1;
    }
    w->rows = calloc((size_t)LOG_RING * (size_t)cols->n, sizeof *w->rows);
    w->text = malloc(LOG_TEXT);
    if (!w->rows || !w->text) {
        snprintf(err, size, "out of memory for the log ring");
        fclose(w->fh);
        free(w->rows);
        free(w->text);
        w->fh = NULL;
        return -1;
    }
    header(cols, w->fh);
    fflush(w->fh);              /* the header by stdio; the rows by write(2) on the same descriptor */
    {
        if (start_writer_thread(&w->thread, log_thread, w) != 0) {
            snprintf(err, size, "cannot start the log writer thread");
            fclose(w->fh);
            free(w->rows);
            free(w->text);
            w->fh = NULL;
            return -1;
        }
    }
    w->started = 1;
    return 0;
}

void log_push(log_writer *w, const double *row)
{
    uint32_t head = w->head;
    if (!w->fh)
        return;
    if ((uint32_t)(head - __atomic_load_n(&w->tail, __ATOMIC_ACQUIRE)) >= LOG_RING) {
        w->dropped++;               /* the writer fell 8 s behind: lose a row, never a step */
        return;
    }
    memcpy(w->rows + (size_t)(head % LOG_RING) * w->cols->n, row, sizeof(double) * (size_t)w->cols->n);
    __atomic_store_n(&w->head, head + 1U, __ATOMIC_RELEASE);
}

void log_close(log_writer *w)
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

