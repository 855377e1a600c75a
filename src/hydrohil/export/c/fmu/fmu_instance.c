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
    if (!pl->prepared && plant_prepare(pl) != PLANT_OK) {
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    pl->mode = PLANT_STEPPING;
    return PLANT_OK;
}

int plant_terminate(plant *pl)
{
    if (pl->mode != PLANT_STEPPING)
        return plant_wrong_mode(pl, "terminating", "step");
    pl->mode = PLANT_TERMINATED;
    return PLANT_OK;
}

/* The checks of a doStep at t with step dt on an internal grid of step h: in step mode, a finite step > 0, not
 * before the last communication point (a warning when after it: the plant steps through the gap). */
int plant_step_check(plant *pl, double t, double dt, double h)
{
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
