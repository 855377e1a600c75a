/* plant_fmu.c: the exported plant's instance (see plant_fmu.h). */
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

void plant_defaults(plant *pl)
{
    int i;
    for (i = 0; i < PLANT_NPAR; i++)
        pl->par[i] = PLANT_START[i];
    pl->u = 0.0;
    pl->f_load = pl->par[HH_LOAD_FORCE];
    pl->ps = pl->par[HH_SUPPLY_PS];
    pl->f_load_set = pl->ps_set = 0;
    pl->t0 = 0.0;
    pl->mode = PLANT_INSTANTIATED;
}

plant *plant_new(const char *name, plant_log_fn log, void *env)
{
    plant *pl = calloc(1, sizeof *pl);
    if (!pl)
        return 0;
    snprintf(pl->name, sizeof pl->name, "%s", name ? name : "hydrohil_plant");
    pl->log = log;
    pl->env = env;
    plant_defaults(pl);
    return pl;
}

void plant_free(plant *pl)
{
    if (pl) {
        free(pl->dbuf);
        free(pl);
    }
}

int plant_set_real(plant *pl, unsigned vr, double v)
{
    if (vr < PLANT_NPAR) {
        if (pl->mode != PLANT_INSTANTIATED && pl->mode != PLANT_INITIALIZING) {
            plant_logf(pl, PLANT_ERROR, "parameter %s is fixed after initialisation", PLANT_NAMES[vr]);
            return PLANT_ERROR;
        }
        pl->par[vr] = v;
        return PLANT_OK;
    }
    switch (vr) {
    case VR_U:
        if (!(v >= -1.0 && v <= 1.0)) {
            plant_logf(pl, PLANT_ERROR, "input u = %g: the normalised valve command must be in [-1, 1]", v);
            return PLANT_ERROR;
        }
        pl->u = v;
        return PLANT_OK;
    case VR_F_LOAD:
        if (!isfinite(v)) {
            plant_logf(pl, PLANT_ERROR, "input F_load = %g N: must be finite", v);
            return PLANT_ERROR;
        }
        pl->f_load = v;
        pl->f_load_set = 1;
        return PLANT_OK;
    case VR_PS:
        if (!(isfinite(v) && v > pl->par[HH_SUPPLY_PT] && v <= 1e8)) {
            plant_logf(pl, PLANT_ERROR, "input ps = %g Pa: the supply pressure must exceed supply.pt (%g Pa) and be <= 1e8 Pa", v,
                       pl->par[HH_SUPPLY_PT]);
            return PLANT_ERROR;
        }
        pl->ps = v;
        pl->ps_set = 1;
        return PLANT_OK;
    default:
        plant_logf(pl, PLANT_ERROR, "value reference %u is not a settable Real", vr);
        return PLANT_ERROR;
    }
}

int plant_get_real(plant *pl, unsigned vr, double *v)
{
    const double *y = pl->sim.y;
    if (vr < PLANT_NPAR) {
        *v = pl->par[vr];
        return PLANT_OK;
    }
    switch (vr) {
    case VR_U: *v = pl->u; return PLANT_OK;
    case VR_F_LOAD: *v = pl->f_load; return PLANT_OK;
    case VR_PS: *v = pl->ps; return PLANT_OK;
    case VR_XP: *v = y[HH_XP]; return PLANT_OK;
    case VR_VP: *v = y[HH_VP]; return PLANT_OK;
    case VR_P1: *v = y[HH_P1]; return PLANT_OK;
    case VR_P2: *v = y[HH_P2]; return PLANT_OK;
    case VR_XS: *v = y[HH_XS]; return PLANT_OK;
    case VR_FF: *v = hh_friction_force(y, pl->sim.m, pl->sim.p); return PLANT_OK;
    default:
        plant_logf(pl, PLANT_ERROR, "value reference %u is not a Real", vr);
        return PLANT_ERROR;
    }
}

int plant_get_integer(plant *pl, unsigned vr, int *v)
{
    double res, c;
    switch (vr) {
    case VR_TRAVEL: *v = (int)pl->sim.m[HH_M_TRAVEL]; return PLANT_OK;
    case VR_FRICTION: *v = (int)pl->sim.m[HH_M_FRICTION]; return PLANT_OK;
    case VR_SPOOL: *v = (int)pl->sim.m[HH_M_SPOOL]; return PLANT_OK;
    case VR_ENCODER:   /* counts of the encoder (sensors.encoder_resolution; 0: ideal, counted in nm) */
        res = pl->par[HH_SENSORS_ENCODER_RESOLUTION];
        c = hh_encoder_counts(pl->sim.y[HH_XP], hh_count_size(res));
        *v = c > 2147483647.0 ? 2147483647 : c < -2147483647.0 ? -2147483647 : (int)c;
        return PLANT_OK;
    default:
        plant_logf(pl, PLANT_ERROR, "value reference %u is not an Integer", vr);
        return PLANT_ERROR;
    }
}

int plant_enter_init(plant *pl, double t0)
{
    pl->t0 = t0;
    pl->mode = PLANT_INITIALIZING;
    return PLANT_OK;
}

int plant_exit_init(plant *pl)
{
    double p[HH_NP], h = pl->par[VR_STEP], xp0 = pl->par[VR_XP0], xs0 = pl->par[VR_XS0], alpha;
    char msg[400];
    int i, n;
    for (i = 0; i < HH_NP; i++)
        p[i] = i < HH_NP_SCHEMA ? pl->par[i] : 0.0;
    if (hh_params_check(p, msg, sizeof msg) >= 0) {
        plant_logf(pl, PLANT_ERROR, "%s", msg);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    if (!(h >= 1e-7 && h <= 0.01)) {
        plant_logf(pl, PLANT_ERROR, "parameter step = %g s: the internal fixed step must be in [1e-7, 0.01] s", h);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    if (!(xp0 >= 0.0 && xp0 <= p[HH_CYLINDER_STROKE]) || !(xs0 >= -1.0 && xs0 <= 1.0)) {
        plant_logf(pl, PLANT_ERROR, "initial state xp0 = %g m, xs0 = %g: need 0 <= xp0 <= cylinder.stroke (%g m) "
                   "and -1 <= xs0 <= 1", xp0, xs0, p[HH_CYLINDER_STROKE]);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    hh_params_derive(p);
    if (!pl->f_load_set)
        pl->f_load = p[HH_LOAD_FORCE];
    if (!pl->ps_set)
        pl->ps = p[HH_SUPPLY_PS];
    p[HH_LOAD_FORCE] = pl->f_load;
    p[HH_SUPPLY_PS] = pl->ps;
    n = hh_delay_steps(p[HH_SPOOL_DELAY], h, &alpha);
    free(pl->dbuf);
    pl->dbuf_size = n + 2;
    pl->dbuf = malloc(sizeof(double) * (size_t)pl->dbuf_size);
    if (!pl->dbuf) {
        plant_logf(pl, PLANT_ERROR, "out of memory for a delay line of %d steps", n);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    hh_sim_init(&pl->sim, p, HH_MODEL_HYBRID, PLANT_METHOD, h, pl->dbuf, n, alpha);
    hh_initial_state(pl->sim.p, xp0, xs0, 0.0, NAN, NAN, 0.0, pl->sim.y, pl->sim.m);
    hh_sim_reset(&pl->sim);
    pl->mode = PLANT_STEPPING;
    return PLANT_OK;
}

int plant_do_step(plant *pl, double t, double dt)
{
    double h = pl->sim.h, r;
    long long n, i;
    if (pl->mode != PLANT_STEPPING) {
        plant_logf(pl, PLANT_ERROR, "doStep outside step mode (initialise first; a failed instance must be reset)");
        return PLANT_ERROR;
    }
    r = dt / h;
    n = llround(r);
    if (n < 1 || fabs(r - (double)n) > 1e-6) {
        plant_logf(pl, PLANT_ERROR, "communication step %g s is not a whole multiple of the internal step %g s", dt, h);
        return PLANT_ERROR;
    }
    if (fabs(t - (pl->t0 + (double)pl->sim.k * h)) > 1e-6 * h + 1e-12) {
        plant_logf(pl, PLANT_WARNING, "doStep at t = %.9g s, the plant is at t = %.9g s", t,
                   pl->t0 + (double)pl->sim.k * h);
    }
    pl->sim.p[HH_LOAD_FORCE] = pl->f_load;
    pl->sim.p[HH_SUPPLY_PS] = pl->ps;
    for (i = 0; i < n; i++) {
        if (hh_sim_step(&pl->sim, pl->u) != HH_OK) {
            const double *y = pl->sim.y;
            plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (travel %d, friction %d, spool %d): "
                       "xs %g, vs %g, p1 %g Pa, p2 %g Pa, xp %g m, vp %g m/s, z %g m", pl->t0 + pl->sim.out[HH_OUT_T],
                       (int)pl->sim.m[0], (int)pl->sim.m[1], (int)pl->sim.m[2], y[0], y[1], y[2], y[3], y[4], y[5],
                       y[6]);
            pl->mode = PLANT_FAILED;
            return PLANT_ERROR;
        }
    }
    return PLANT_OK;
}

static size_t plant_state_size(const plant *pl)
{
    return sizeof(plant) + sizeof(double) * (size_t)pl->dbuf_size;
}

int plant_state_get(plant *pl, void **state)
{
    size_t n = plant_state_size(pl);
    char *bytes = *state ? realloc(*state, sizeof(size_t) + n) : malloc(sizeof(size_t) + n);
    if (!bytes) {
        plant_logf(pl, PLANT_ERROR, "out of memory for an FMU state");
        return PLANT_ERROR;
    }
    memcpy(bytes, &n, sizeof n);
    memcpy(bytes + sizeof n, pl, sizeof(plant));
    if (pl->dbuf_size > 0)
        memcpy(bytes + sizeof n + sizeof(plant), pl->dbuf, sizeof(double) * (size_t)pl->dbuf_size);
    *state = bytes;
    return PLANT_OK;
}

int plant_state_set(plant *pl, const void *state)
{
    const char *bytes = state;
    plant saved;
    double *buf = pl->dbuf;
    size_t n;
    if (!state) {
        plant_logf(pl, PLANT_ERROR, "no FMU state given");
        return PLANT_ERROR;
    }
    memcpy(&n, bytes, sizeof n);
    memcpy(&saved, bytes + sizeof n, sizeof(plant));
    if (n != plant_state_size(&saved) || saved.dbuf_size != pl->dbuf_size) {
        plant_logf(pl, PLANT_ERROR, "FMU state of another configuration (delay line %d vs %d steps)",
                   saved.dbuf_size, pl->dbuf_size);
        return PLANT_ERROR;
    }
    saved.log = pl->log;        /* this instance's callbacks and memory, the saved values */
    saved.env = pl->env;
    memcpy(saved.name, pl->name, sizeof saved.name);
    saved.dbuf = buf;
    saved.sim.delay.buf = buf;
    *pl = saved;
    if (pl->dbuf_size > 0)
        memcpy(buf, bytes + sizeof n + sizeof(plant), sizeof(double) * (size_t)pl->dbuf_size);
    return PLANT_OK;
}

size_t plant_state_block_size(const void *state)
{
    size_t n;
    memcpy(&n, state, sizeof n);
    return n + sizeof n;
}

int plant_state_serialize(plant *pl, const void *state, void *bytes, size_t size)
{
    if (!state || size != plant_state_block_size(state)) {
        plant_logf(pl, PLANT_ERROR, "serialising an FMU state into a buffer of another size");
        return PLANT_ERROR;
    }
    memcpy(bytes, state, size);
    return PLANT_OK;
}

int plant_state_deserialize(const void *bytes, size_t size, void **state)
{
    void *copy = malloc(size);
    if (!copy)
        return PLANT_ERROR;
    memcpy(copy, bytes, size);
    free(*state);
    *state = copy;
    return PLANT_OK;
}
