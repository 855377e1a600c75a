/* rt_report.c: timing.json of the standalone plant (rt_plant.h), with the keys of the Python plant's and
 * the verdict of hydrohil.hil.verdict (same rules, same words). */
#include <math.h>
#include <string.h>

#include "rt_plant.h"

typedef struct {
    FILE *fh;
    int first;
} json_out;

static void json_key(json_out *j, const char *key)
{
    fprintf(j->fh, "%s\n  \"%s\": ", j->first ? "" : ",", key);
    j->first = 0;
}

void json_string_value(FILE *fh, const char *s)
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

run_counts counts_now(const plant *pl)
{
    run_counts c;
    c.packets_rx = pl->packets_rx;
    c.packets_bad = pl->packets_bad;
    c.packets_foreign = pl->packets_foreign;
    c.packets_lost = pl->packets_lost;
    c.packets_reordered = pl->packets_reordered;
    c.late_commands = pl->late_commands;
    c.packets_dropped_kernel = pl->packets_dropped_kernel;
    c.overruns = pl->overruns;
    c.watchdog_trips = pl->link->trips;
    c.watchdog_trips_unexplained = pl->link->trips_unexplained;
    c.commands_delivered = pl->link->delivered;
    return c;
}

/* The verdict (hydrohil.hil.verdict.judge, same rules and words): reasons, count returned. */
static int judge(const plant *pl, const run_counts *c, const latency_hist *jitter, int64_t steps,
                 char reasons[][REASON_SIZE])
{
    const double *hil = pl->o->hil;
    int n = 0;
    if (pl->link_error[0])
        snprintf(reasons[n++], REASON_SIZE, "%s", pl->link_error);
    if (pl->fault[0])
        snprintf(reasons[n++], REASON_SIZE, "the model failed: %s", pl->fault);
    if (!pl->o->lockstep && steps) {
        double late = (double)c->late_commands, over = (double)c->overruns, s = (double)steps;
        double stall_us = latency_max_us(jitter);
        if (late > hil[HIL_MAX_LATE_COMMANDS] * s)
            snprintf(reasons[n++], REASON_SIZE, "%lld of %lld commands late (%.1f%% > %.1f%%)", (long long)c->late_commands,
                     (long long)steps, late / s * 100.0, hil[HIL_MAX_LATE_COMMANDS] * 100.0);
        if (over > hil[HIL_MAX_OVERRUNS] * s)
            snprintf(reasons[n++], REASON_SIZE, "%lld of %lld steps overran (%.1f%% > %.1f%%)", (long long)c->overruns,
                     (long long)steps, over / s * 100.0, hil[HIL_MAX_OVERRUNS] * 100.0);
        if (isfinite(stall_us) && stall_us > hil[HIL_MAX_STALL] * 1e6)
            snprintf(reasons[n++], REASON_SIZE, "the plant stalled %.1f ms (> %g ms)", stall_us / 1e3, hil[HIL_MAX_STALL] * 1e3);
    }
    if ((double)c->watchdog_trips_unexplained > hil[HIL_MAX_WATCHDOG_TRIPS])
        snprintf(reasons[n++], REASON_SIZE, "%lld watchdog trip(s) without an injected fault (no command reached the plant "
                 "for %g ms; allowed %lld)", (long long)c->watchdog_trips_unexplained, hil[HIL_WATCHDOG_TIMEOUT] * 1e3,
                 (long long)hil[HIL_MAX_WATCHDOG_TRIPS]);
    return n;
}

/* timing.json of the run (win NULL) or of a recording: the keys of the Python plant's, in its order */
static int timing(plant *pl, const recording *win, int64_t steps, int64_t t0, int64_t t_end, int64_t drift_ns,
                  FILE *fh, char reasons[][REASON_SIZE])
{
    const options *o = pl->o;
    json_out j = {fh, 1};
    run_counts c = counts_now(pl);
    const latency_hist *jitter = win ? &win->jitter : &pl->jitter, *compute = win ? &win->compute : &pl->compute;
    int lock = o->lockstep, nreasons, i;
    double na = NAN;
    if (win) {
#define SINCE(f) c.f -= win->c0.f
        SINCE(packets_rx); SINCE(packets_bad); SINCE(packets_foreign); SINCE(packets_lost); SINCE(packets_reordered);
        SINCE(late_commands); SINCE(packets_dropped_kernel); SINCE(overruns); SINCE(watchdog_trips);
        SINCE(watchdog_trips_unexplained); SINCE(commands_delivered);
#undef SINCE
        t0 = win->t0_ns;
    }
    nreasons = judge(pl, &c, jitter, steps, reasons);
    fputc('{', fh);
    json_str(&j, "mode", lock ? "lockstep" : "realtime");
    json_num(&j, "step_s", o->step);
    json_int(&j, "steps", steps);
    json_int(&j, "steps_planned", win ? steps : pl->n);
    if (lock)
        json_raw(&j, "overruns", "null");
    else
        json_int(&j, "overruns", c.overruns);
    json_num(&j, "jitter_us_p50", lock ? na : latency_percentile(jitter, 50));
    json_num(&j, "jitter_us_p99", lock ? na : latency_percentile(jitter, 99));
    json_num(&j, "jitter_us_p999", lock ? na : latency_percentile(jitter, 99.9));
    json_num(&j, "jitter_us_max", lock ? na : latency_max_us(jitter));
    json_num(&j, "compute_us_p50", latency_percentile(compute, 50));
    json_num(&j, "compute_us_p99", latency_percentile(compute, 99));
    json_num(&j, "compute_us_max", latency_max_us(compute));
    json_num(&j, "rtt_us_p50", lock ? na : latency_percentile(&pl->rtt, 50));
    json_num(&j, "rtt_us_p99", lock ? na : latency_percentile(&pl->rtt, 99));
    json_num(&j, "rtt_seen_us_p50", lock ? na : latency_percentile(&pl->rtt_seen, 50));
    json_num(&j, "rtt_seen_us_p99", lock ? na : latency_percentile(&pl->rtt_seen, 99));
    json_str(&j, "rtt_source", pl->kernel_stamps ? "kernel receive timestamp (SO_TIMESTAMPNS)" : "plant process");
    json_int(&j, "packets_rx", c.packets_rx);
    json_int(&j, "packets_bad", c.packets_bad);
    json_int(&j, "packets_foreign", c.packets_foreign);
    json_int(&j, "packets_lost", c.packets_lost);
    json_int(&j, "packets_reordered", c.packets_reordered);
    json_int(&j, "late_commands", c.late_commands);
    json_int(&j, "packets_dropped_kernel", c.packets_dropped_kernel);
    json_int(&j, "watchdog_trips", c.watchdog_trips);
    json_int(&j, "watchdog_trips_unexplained", c.watchdog_trips_unexplained);
    json_int(&j, "commands_delivered", c.commands_delivered);
    model_timing(pl, fh);                 /* the model's own keys (faults_injected, a circuit's name, ...) */
    json_num(&j, "simulated_s", (double)steps * o->step);
    json_num(&j, "wall_s", (double)(t_end - t0) / 1e9);
    json_num(&j, "drift_ms", lock || win ? na : (double)drift_ns / 1e6);
    json_str(&j, "fault", pl->fault);
    json_str(&j, "link_error", pl->link_error);
    /* (a controller's BYE after the last step is no early stop) */
    json_raw(&j, "stopped_early", pl->stop_requested && (win || steps < pl->n) ? "true" : "false");
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
    json_int(&j, "log_rows_dropped", win ? win->dropped : pl->log.dropped);
    if (o->has_panel) {
        json_int(&j, "telemetry_batches_sent", pl->side.sent);
        json_int(&j, "telemetry_batches_dropped", pl->side.dropped);
    }
    if (win) {
        json_key(&j, "recorded_steps");
        fprintf(fh, "[%lld, %lld]", (long long)win->k0, (long long)(win->k0 + steps));
        json_str(&j, "rtt_scope", "session so far");
    }
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

int write_timing(plant *pl, int64_t steps, int64_t t0, int64_t t_end, int64_t drift_ns, FILE *fh,
                 char reasons[][REASON_SIZE])
{
    return timing(pl, NULL, steps, t0, t_end, drift_ns, fh, reasons);
}

int write_timing_window(plant *pl, const recording *win, int64_t steps, int64_t t_end, FILE *fh,
                        char reasons[][REASON_SIZE])
{
    return timing(pl, win, steps, win->t0_ns, t_end, 0, fh, reasons);
}
