/* fmu_instance.c: what every exported plant's instance shares (plant_fmu.h declares it): logging, the FMI life
 * cycle's modes, the checks of a communication step, an FMU state's serialisation. The model's instance layer
 * (plant_fmu.c: the paper's rig, or a circuit's) gives plant_prepare (the initial state of the values set),
 * plant_state_check and plant_state_block_size. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "plant_fmu.h"

void plant_logf(plant *pl, int status, const char *fmt, ...)
{
    char msg[512];
    va_list ap;
    if (!pl->log)
        return;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    pl->log(pl->env, pl->name, status, status == PLANT_ERROR ? "logStatusError" : status == PLANT_WARNING
            ? "logStatusWarning" : "logAll", msg);
}

int plant_wrong_mode(plant *pl, const char *call, const char *where)
{
    static const char *const names[] = {"instantiated", "initialisation", "step", "terminated", "failed"};
    plant_logf(pl, PLANT_ERROR, "%s: only in %s mode (the instance is in %s mode)", call, where, names[pl->mode]);
    return PLANT_ERROR;
}

int plant_setup(plant *pl, double t0)
{
    if (pl->mode != PLANT_INSTANTIATED)
        return plant_wrong_mode(pl, "setting up the experiment", "instantiated");
    pl->t0 = pl->t_comm = t0;
    return PLANT_OK;
}

int plant_enter_init(plant *pl, double t0)
{
    if (pl->mode != PLANT_INSTANTIATED)
        return plant_wrong_mode(pl, "entering initialisation mode", "instantiated");
    pl->t0 = pl->t_comm = t0;
    pl->mode = PLANT_INITIALIZING;
    return PLANT_OK;
}

int plant_exit_init(plant *pl)
{
    if (pl->mode != PLANT_INITIALIZING)
        return plant_wrong_mode(pl, "exiting initialisation mode", "initialisation");
    if ((!pl->prepared && plant_prepare(pl) != PLANT_OK) || (pl->me && plant_me_start(pl) != PLANT_OK)) {
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    pl->mode = PLANT_STEPPING;
    pl->me_event = pl->me;            /* (an ME instance: in event mode now, FMI's rule) */
    pl->t_me = pl->t0;
    return PLANT_OK;
}

int plant_me_check(plant *pl, const char *call, int event)
{
    if (!pl->me) {
        plant_logf(pl, PLANT_ERROR, "%s: a Model Exchange call, and this instance is Co-Simulation's", call);
        return PLANT_ERROR;
    }
    if (pl->mode != PLANT_STEPPING)
        return plant_wrong_mode(pl, call, "event or continuous-time (initialise first; a failed instance must be "
                                "reset)");
    if (event >= 0 && pl->me_event != event) {
        plant_logf(pl, PLANT_ERROR, "%s: only in %s mode (the instance is in %s mode)", call,
                   event ? "event" : "continuous-time", pl->me_event ? "event" : "continuous-time");
        return PLANT_ERROR;
    }
    return PLANT_OK;
}

int plant_me_set_time(plant *pl, double t)
{
    if (pl->me && (pl->mode == PLANT_INSTANTIATED || pl->mode == PLANT_INITIALIZING)) {
        pl->t_me = t;
        return PLANT_OK;
    }
    if (plant_me_check(pl, "setTime", -1) != PLANT_OK)
        return PLANT_ERROR;
    if (!isfinite(t)) {          /* (a solver's trial points may go back within its step: any finite time) */
        plant_logf(pl, PLANT_ERROR, "setTime(%g s): not a finite time", t);
        return PLANT_ERROR;
    }
    pl->t_me = t;
    return PLANT_OK;
}

void fmu_delay_init(fmu_delay *d, double tau, double t0, double value)
{
    d->tau = tau;
    d->now = value;
    d->t_now = t0;
    d->n = 1;
    d->t[0] = t0;
    d->v[0] = value;
    d->t_done = t0;
}

/* (t, v) appended to the history, its samples older than what the model still needs (t - tau) dropped */
static int delay_keep(plant *pl, fmu_delay *d, double t, double v)
{
    int drop = 0, i;
    while (drop + 1 < d->n && d->t[drop + 1] <= t - d->tau && d->t[drop + 1] <= d->t_done - d->tau)
        drop++;
    if (drop > 0) {
        for (i = drop; i < d->n; i++) {
            d->t[i - drop] = d->t[i];
            d->v[i - drop] = d->v[i];
        }
        d->n -= drop;
    }
    if (d->n == FMU_DELAY_CAP) {
        plant_logf(pl, PLANT_ERROR, "an input's history within its delay of %g s: more than %d values (steps of the "
                   "solver shorter than %g s)", d->tau, FMU_DELAY_CAP, d->tau / FMU_DELAY_CAP);
        return PLANT_ERROR;
    }
    d->t[d->n] = t;
    d->v[d->n++] = v;
    return PLANT_OK;
}

int fmu_delay_set(plant *pl, fmu_delay *d, double t, double value, int event)
{
    double before = d->now;
    d->now = value;
    d->t_now = t;
    if (d->tau <= 0.0 || !event || value == before)
        return PLANT_OK;
    if (d->t[d->n - 1] < t && delay_keep(pl, d, t, before) != PLANT_OK)   /* (the value up to the step) */
        return PLANT_ERROR;
    if (d->t[d->n - 1] == t && d->n >= 2 && d->t[d->n - 2] == t) {    /* (set again at the same event) */
        d->v[d->n - 1] = value;
        return PLANT_OK;
    }
    return delay_keep(pl, d, t, value);
}

int fmu_delay_accept(plant *pl, fmu_delay *d, double t)
{
    if (d->tau <= 0.0 || !(t > d->t[d->n - 1]))
        return PLANT_OK;
    return delay_keep(pl, d, t, d->now);
}

void fmu_delay_event(fmu_delay *d, double t)
{
    if (t > d->t_done)
        d->t_done = t;
}

double fmu_delay_value(const fmu_delay *d, double t)
{
    double s = t - d->tau, ta, tb;
    int i;
    if (d->tau <= 0.0)
        return d->now;
    if (s <= d->t[0])
        return d->v[0];
    for (i = 1; i < d->n; i++) {
        if (d->t[i] == d->t[i - 1]) {        /* a step at t[i]: its new value once its time event was handled */
            if (s >= d->t[i] && d->t[i] + d->tau <= d->t_done + 1e-12 * (1.0 + fabs(d->t_done)))
                continue;
            if (s >= d->t[i])
                return d->v[i - 1];
            continue;
        }
        if (s < d->t[i]) {                   /* between two samples: linear (a continuous input) */
            ta = d->t[i - 1];
            tb = d->t[i];
            return d->v[i - 1] + (d->v[i] - d->v[i - 1]) * (s - ta) / (tb - ta);
        }
    }
    ta = d->t[d->n - 1];                      /* beyond the history: towards the value set last */
    tb = d->t_now;
    if (tb > ta && s < tb)
        return d->v[d->n - 1] + (d->now - d->v[d->n - 1]) * (s - ta) / (tb - ta);
    return s >= tb ? d->now : d->v[d->n - 1];
}

int fmu_delay_next(const fmu_delay *d, double t, double *next)
{
    int i;
    if (d->tau <= 0.0)
        return 0;
    for (i = 1; i < d->n; i++)
        if (d->t[i] == d->t[i - 1] && d->t[i] + d->tau > t + 1e-12 * (1.0 + fabs(t))) {
            *next = d->t[i] + d->tau;
            return 1;
        }
    return 0;
}

int plant_terminate(plant *pl)
{
    if (pl->mode != PLANT_STEPPING)
        return plant_wrong_mode(pl, "terminating", pl->me ? "event or continuous-time" : "step");
    pl->mode = PLANT_TERMINATED;
    return PLANT_OK;
}

int plant_me_size(plant *pl, size_t n, size_t want, const char *what)
{
    if (n == want)
        return PLANT_OK;
    plant_logf(pl, PLANT_ERROR, "%zu %s: this FMU has %zu", n, what, want);
    return PLANT_ERROR;
}

/* The checks of a doStep at t with step dt on an internal grid of step h: in step mode, a finite step > 0, not
 * before the last communication point (a warning when after it: the plant steps through the gap). */
int plant_step_check(plant *pl, double t, double dt, double h)
{
    if (pl->me) {
        plant_logf(pl, PLANT_ERROR, "doStep: a Co-Simulation call, and this instance is Model Exchange's");
        return PLANT_ERROR;
    }
    if (pl->mode != PLANT_STEPPING)
        return plant_wrong_mode(pl, "doStep", "step (initialise first; a failed instance must be reset)");
    if (!(dt > 0.0 && isfinite(dt) && isfinite(t))) {
        plant_logf(pl, PLANT_ERROR, "doStep at t = %g s with a step of %g s: need a finite step > 0", t, dt);
        return PLANT_ERROR;
    }
    if (t < pl->t_comm - 1e-6 * h - 1e-12 * fabs(t)) {
        plant_logf(pl, PLANT_ERROR, "doStep at t = %.9g s, before the last communication point t = %.9g s (set an "
                   "FMU state to go back)", t, pl->t_comm);
        return PLANT_ERROR;
    }
    if (t > pl->t_comm + 1e-6 * h + 1e-12 * fabs(t))
        plant_logf(pl, PLANT_WARNING, "doStep at t = %.9g s, the last communication point was t = %.9g s: the plant "
                   "steps through the gap with the inputs held", t, pl->t_comm);
    return PLANT_OK;
}

void plant_state_header_of(plant_state_header *hd, const char *tag, uint32_t version, const uint64_t dims[6],
                           uint64_t values_size, uint64_t extra)
{
    memset(hd, 0, sizeof *hd);
    snprintf(hd->tag, sizeof hd->tag, "%s", tag);
    hd->version = version;
    hd->header_size = sizeof(plant_state_header);
    snprintf(hd->token, sizeof hd->token, "%s", PLANT_TOKEN);
    memcpy(hd->dims, dims, sizeof hd->dims);
    hd->values_size = values_size;
    hd->extra = extra;
    hd->total = sizeof(plant_state_header) + values_size + sizeof(double) * extra;
}

int plant_state_header_read(plant *pl, const void *bytes, size_t size, const char *tag, uint32_t version,
                            plant_state_header *hd)
{
    if (!bytes) {
        plant_logf(pl, PLANT_ERROR, "no FMU state given");
        return PLANT_ERROR;
    }
    if (size < sizeof *hd) {
        plant_logf(pl, PLANT_ERROR, "FMU state of %zu bytes: too short for a hydrohil FMU state (its header alone "
                   "has %zu)", size, sizeof *hd);
        return PLANT_ERROR;
    }
    memcpy(hd, bytes, sizeof *hd);
    if (memcmp(hd->tag, tag, strlen(tag) + 1) != 0) {
        plant_logf(pl, PLANT_ERROR, "not a hydrohil FMU state (no '%s' tag)", tag);
        return PLANT_ERROR;
    }
    if (hd->version != version) {
        plant_logf(pl, PLANT_ERROR, "FMU state of format %u: this FMU reads format %u", hd->version, version);
        return PLANT_ERROR;
    }
    hd->token[sizeof hd->token - 1] = '\0';
    if (strcmp(hd->token, PLANT_TOKEN) != 0) {
        plant_logf(pl, PLANT_ERROR, "FMU state of another export (token %s; this FMU is %s)", hd->token, PLANT_TOKEN);
        return PLANT_ERROR;
    }
    return PLANT_OK;
}

int plant_state_header_match(plant *pl, const plant_state_header *hd, const plant_state_header *mine, size_t size)
{
    if (memcmp(hd, mine, sizeof *hd) != 0 || hd->total != size) {
        plant_logf(pl, PLANT_ERROR, "FMU state of %zu bytes: its header describes another layout or %llu bytes",
                   size, (unsigned long long)hd->total);
        return PLANT_ERROR;
    }
    return PLANT_OK;
}

size_t plant_state_block_size(const void *state)
{
    plant_state_header hd;
    memcpy(&hd, state, sizeof hd);
    return (size_t)hd.total;
}

int plant_state_serialize(plant *pl, const void *state, void *bytes, size_t size)
{
    if (!state || !bytes || size != plant_state_block_size(state)) {
        plant_logf(pl, PLANT_ERROR, "serialising an FMU state into a buffer of another size (%zu bytes)", size);
        return PLANT_ERROR;
    }
    memcpy(bytes, state, size);
    return PLANT_OK;
}

int plant_state_deserialize(plant *pl, const void *bytes, size_t size, void **state)
{
    void *copy;
    if (!state) {
        plant_logf(pl, PLANT_ERROR, "deserialising an FMU state: no place for it given");
        return PLANT_ERROR;
    }
    if (plant_state_check(pl, bytes, size) != PLANT_OK)
        return PLANT_ERROR;
    copy = malloc(size);
    if (!copy) {
        plant_logf(pl, PLANT_ERROR, "out of memory for an FMU state of %zu bytes", size);
        return PLANT_ERROR;
    }
    memcpy(copy, bytes, size);
    free(*state);
    *state = copy;
    return PLANT_OK;
}
