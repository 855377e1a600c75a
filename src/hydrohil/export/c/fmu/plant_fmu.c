/* plant_fmu.c: the exported plant's instance (see plant_fmu.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "plant_fmu.h"

#define STATE_TAG "hydrohil FMU state"
#define STATE_VERSION 4u        /* 2: the rig's command path (hh_watchdog) saved too; 3: the shared header;
                                 * 4: Model Exchange's mode, time and delayed input */
#define DELAY_MAX 100000000       /* a saved delay line longer than this is not one of this plant's */

/* the spool's input in Model Exchange: u saturated, delayed by spool.delay (fmu_instance.h: fmu_delay) */
static double me_ud(const plant *pl) { return fmu_delay_value(&pl->me_u, pl->t_me); }

void plant_defaults(plant *pl)
{
    int i;
    for (i = 0; i < PLANT_NPAR; i++)
        pl->par[i] = PLANT_START[i];
    pl->u = 0.0;
    pl->f_load = pl->par[HH_LOAD_FORCE];
    pl->ps = pl->par[HH_SUPPLY_PS];
    pl->f_load_set = pl->ps_set = 0;
    pl->t0 = pl->t_comm = 0.0;
    pl->xs_rest = 0.0;
    pl->prepared = 0;
    pl->mode = PLANT_INSTANTIATED;
}

/* The rig around the instance's sim: the command path alone (an FMU's input arrives every step: the watchdog
 * never trips; no fault table; its readings are the FMU's outputs, not the rig's sensing). */
static void rig_init(plant *pl)
{
    hh_rig_init(&pl->rig, &pl->sim, 1e-6, 0, HUGE_VAL, 0, 0.0, NULL, 0);
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
    rig_init(pl);
    return pl;
}

void plant_free(plant *pl)
{
    if (pl) {
        free(pl->dbuf);
        free(pl);
    }
}

static const char *const KIND_WORDS[] = {"a Real", "an Integer", "a Boolean", "an Enumeration"};

/* A parameter set (any kind: its value as the core's double), before the end of initialisation only. */
static int set_parameter(plant *pl, unsigned vr, double v)
{
    if (pl->mode != PLANT_INSTANTIATED && pl->mode != PLANT_INITIALIZING) {
        plant_logf(pl, PLANT_ERROR, "parameter %s is fixed after initialisation", PLANT_NAMES[vr]);
        return PLANT_ERROR;
    }
    pl->par[vr] = v;
    pl->prepared = 0;
    return PLANT_OK;
}

/* vr is a parameter of kind `kind`; else PLANT_ERROR saying which setter or getter it takes (`call`: "set", "get"). */
static int parameter_of_kind(plant *pl, unsigned vr, int kind, const char *call)
{
    if (vr < PLANT_NPAR && (PLANT_KIND[vr] == kind || (kind == PLANT_KIND_INT && PLANT_KIND[vr] == PLANT_KIND_ENUM)))
        return PLANT_OK;
    if (vr < PLANT_NPAR)
        plant_logf(pl, PLANT_ERROR, "parameter %s is %s: %s it as one", PLANT_NAMES[vr], KIND_WORDS[PLANT_KIND[vr]], call);
    else
        plant_logf(pl, PLANT_ERROR, "value reference %u is not %s to %s", vr, KIND_WORDS[kind], call);
    return PLANT_ERROR;
}

int plant_set_integer(plant *pl, unsigned vr, int v)
{
    return parameter_of_kind(pl, vr, PLANT_KIND_INT, "set") == PLANT_OK ? set_parameter(pl, vr, (double)v) : PLANT_ERROR;
}

int plant_set_boolean(plant *pl, unsigned vr, int v)
{
    return parameter_of_kind(pl, vr, PLANT_KIND_BOOL, "set") == PLANT_OK ? set_parameter(pl, vr, v ? 1.0 : 0.0)
                                                                         : PLANT_ERROR;
}

int plant_get_boolean(plant *pl, unsigned vr, int *v)
{
    if (parameter_of_kind(pl, vr, PLANT_KIND_BOOL, "get") != PLANT_OK)
        return PLANT_ERROR;
    *v = pl->par[vr] != 0.0;
    return PLANT_OK;
}

int plant_set_real(plant *pl, unsigned vr, double v)
{
    if (vr < PLANT_NPAR && PLANT_KIND[vr] != PLANT_KIND_REAL)
        return parameter_of_kind(pl, vr, PLANT_KIND_REAL, "set");
    if (vr < PLANT_NPAR)
        return set_parameter(pl, vr, v);
    switch (vr) {
    case VR_U:   /* saturated to [-1, 1] when stepping, as the rig's command path does */
        if (!isfinite(v)) {
            plant_logf(pl, PLANT_ERROR, "input u = %g: the normalised valve command must be finite", v);
            return PLANT_ERROR;
        }
        pl->u = v;
        if (pl->me && pl->mode == PLANT_STEPPING)    /* (ME: it reaches the spool spool.delay later) */
            return fmu_delay_set(pl, &pl->me_u, pl->t_me, hh_command_clamp(v), pl->me_event);
        return PLANT_OK;
    case VR_F_LOAD:
        if (!isfinite(v)) {
            plant_logf(pl, PLANT_ERROR, "input F_load = %g N: must be finite", v);
            return PLANT_ERROR;
        }
        pl->f_load = v;
        pl->f_load_set = 1;
        pl->prepared = 0;
        if (pl->me && pl->mode == PLANT_STEPPING)    /* (ME: at once; Co-Simulation: from the next doStep) */
            pl->sim.p[HH_LOAD_FORCE] = v;
        return PLANT_OK;
    case VR_PS:
        if (!(isfinite(v) && v > pl->par[HH_SUPPLY_PT] && v <= 1e8)) {
            plant_logf(pl, PLANT_ERROR, "input ps = %g Pa: the supply pressure must exceed supply.pt (%g Pa) and be <= 1e8 Pa", v,
                       pl->par[HH_SUPPLY_PT]);
            return PLANT_ERROR;
        }
        pl->ps = v;
        pl->ps_set = 1;
        pl->prepared = 0;
        if (pl->me && pl->mode == PLANT_STEPPING)
            pl->sim.p[HH_SUPPLY_PS] = v;
        return PLANT_OK;
    default:
        plant_logf(pl, PLANT_ERROR, "value reference %u is not a settable Real", vr);
        return PLANT_ERROR;
    }
}

/* The core's parameter vector p[HH_NP] of the parameters as set and the inputs F_load and ps, checked;
 * PLANT_ERROR with a message when a value is out of range. */
static int model_params(plant *pl, double *p)
{
    double h = pl->par[VR_STEP], xp0 = pl->par[VR_XP0], xs0 = pl->par[VR_XS0];
    char msg[400];
    int i;
    for (i = 0; i < HH_NP; i++)
        p[i] = i < HH_NP_SCHEMA ? pl->par[i] : 0.0;
    if (hh_params_check(p, msg, sizeof msg) >= 0) {
        plant_logf(pl, PLANT_ERROR, "%s", msg);
        return PLANT_ERROR;
    }
    if (!(h >= 1e-7 && h <= 0.01)) {
        plant_logf(pl, PLANT_ERROR, "parameter step = %g s: the internal fixed step must be in [1e-7, 0.01] s", h);
        return PLANT_ERROR;
    }
    if (!(xp0 >= 0.0 && xp0 <= p[HH_CYLINDER_STROKE]) || !(xs0 >= -1.0 && xs0 <= 1.0)) {
        plant_logf(pl, PLANT_ERROR, "initial state initial.xp = %g m, initial.xs = %g: need 0 <= initial.xp <= "
                   "cylinder.stroke (%g m) and -1 <= initial.xs <= 1", xp0, xs0, p[HH_CYLINDER_STROKE]);
        return PLANT_ERROR;
    }
    hh_params_derive(p);
    p[HH_LOAD_FORCE] = pl->f_load_set ? pl->f_load : p[HH_LOAD_FORCE];
    p[HH_SUPPLY_PS] = pl->ps_set ? pl->ps : p[HH_SUPPLY_PS];
    return PLANT_OK;
}

/* sim steps the generated model (paper_model.h); PLANT_ERROR with the reason when the parameters ask for another
 * structure than the export's. */
static int attach_model(plant *pl)
{
    char why[400];
    if (paper_model_attach(&pl->model, &pl->sim, PLANT_METHOD, why, sizeof why) != 0) {
        plant_logf(pl, PLANT_ERROR, "%s", why);
        return PLANT_ERROR;
    }
    return PLANT_OK;
}

/* The initial state of the parameters as set (SPEC §12.5): at rest (initial.at_rest: the spool offset that holds
 * the piston, the pressures balancing the chambers' flows) or with the spool at xs0; sim and its delay line
 * set up, xs_rest computed. */
int plant_prepare(plant *pl)
{
    double p[HH_NP], h = pl->par[VR_STEP], alpha, p1, p2;
    int n, held;
    char why[400];
    if (model_params(pl, p) != PLANT_OK)
        return PLANT_ERROR;
    if (paper_model_structure_check(p, why, sizeof why) != 0) {    /* (before anything of the instance changes) */
        plant_logf(pl, PLANT_ERROR, "%s", why);
        return PLANT_ERROR;
    }
    if (!pl->f_load_set)
        pl->f_load = p[HH_LOAD_FORCE];
    if (!pl->ps_set)
        pl->ps = p[HH_SUPPLY_PS];
    n = hh_delay_steps(p[HH_SPOOL_DELAY], h, &alpha);
    if (pl->dbuf_size != n + 2) {
        free(pl->dbuf);
        pl->dbuf_size = 0;
        pl->dbuf = malloc(sizeof(double) * (size_t)(n + 2));
        if (!pl->dbuf) {
            plant_logf(pl, PLANT_ERROR, "out of memory for a delay line of %d steps", n);
            return PLANT_ERROR;
        }
        pl->dbuf_size = n + 2;
    }
    hh_sim_init(&pl->sim, p, HH_MODEL_HYBRID, PLANT_METHOD, h, pl->dbuf, n, alpha);
    if (attach_model(pl) != PLANT_OK)
        return PLANT_ERROR;
    held = hh_rest_state(pl->sim.p, &pl->xs_rest, &p1, &p2) == 0;
    hh_initial_state(pl->sim.p, pl->par[VR_XP0], pl->par[VR_AT_REST] == 1.0 ? pl->xs_rest : pl->par[VR_XS0], 0.0,
                     NAN, NAN, 0.0, pl->sim.y, pl->sim.m);
    hh_sim_reset(&pl->sim);
    rig_init(pl);
    if (!held && pl->par[VR_AT_REST] == 1.0 && pl->sim.m[HH_M_TRAVEL] == HH_FREE)
        plant_logf(pl, PLANT_WARNING, "no spool position holds the piston at rest: the load is more than the cylinder "
                   "gives at a supply pressure of %g bar; the spool starts centred and the load moves the piston", p[HH_SUPPLY_PS] / 1e5);
    if (pl->par[VR_AT_REST] == 1.0 && pl->par[VR_XS0] != 0.0)
        plant_logf(pl, PLANT_WARNING, "initial.xs = %g is not used: initial.at_rest = true starts the spool at the "
                   "offset that holds the piston (%g); set initial.at_rest = false to start at initial.xs",
                   pl->par[VR_XS0], pl->xs_rest);
    pl->prepared = 1;
    return PLANT_OK;
}

int plant_get_real(plant *pl, unsigned vr, double *v)
{
    const double *y = pl->sim.y;
    if (vr < PLANT_NPAR && PLANT_KIND[vr] != PLANT_KIND_REAL)
        return parameter_of_kind(pl, vr, PLANT_KIND_REAL, "get");
    if (vr < PLANT_NPAR) {
        *v = pl->par[vr];
        return PLANT_OK;
    }
    switch (vr) {
    case VR_U: *v = pl->u; return PLANT_OK;
    case VR_F_LOAD: *v = pl->f_load; return PLANT_OK;
    case VR_PS: *v = pl->ps; return PLANT_OK;
    default: break;
    }
    if (pl->mode == PLANT_INSTANTIATED) {
        plant_logf(pl, PLANT_ERROR, "value reference %u: outputs and calculated parameters exist from "
                   "initialisation mode on", vr);
        return PLANT_ERROR;
    }
    if (pl->mode == PLANT_INITIALIZING && !pl->prepared && plant_prepare(pl) != PLANT_OK)   /* the initial values of */
        return PLANT_ERROR;                                                            /* what is set now */
    switch (vr) {
    case VR_XS_REST: *v = pl->xs_rest; return PLANT_OK;
    case VR_XP: *v = y[HH_XP]; return PLANT_OK;
    case VR_VP: *v = y[HH_VP]; return PLANT_OK;
    case VR_P1: *v = y[HH_P1]; return PLANT_OK;
    case VR_P2: *v = y[HH_P2]; return PLANT_OK;
    case VR_XS: *v = y[HH_XS]; return PLANT_OK;
    case VR_VS: *v = y[HH_VS]; return PLANT_OK;
    case VR_Z: *v = y[HH_Z]; return PLANT_OK;
    case VR_FF: *v = hh_sim_friction(&pl->sim); return PLANT_OK;
    default:
        break;
    }
    if (vr >= VR_DER0 && vr < VR_DER0 + HH_NY) {            /* a state's derivative (Model Exchange's) */
        double dx[HH_NY];
        hc_core_me_derivatives(&pl->model.ctx, y, pl->sim.m, pl->sim.p, me_ud(pl), dx);
        *v = dx[vr - VR_DER0];
        return PLANT_OK;
    }
    if (vr >= VR_EVENT0 && vr < VR_EVENT0 + PLANT_NZ) {     /* an event indicator (a guard of the statechart) */
        double z[PLANT_NZ];
        hc_core_me_indicators(&pl->model.ctx, y, pl->sim.m, pl->sim.p, me_ud(pl), z);
        *v = z[vr - VR_EVENT0];
        return PLANT_OK;
    }
    plant_logf(pl, PLANT_ERROR, "value reference %u is not a Real", vr);
    return PLANT_ERROR;
}

/* ---- Model Exchange: the importer's solver integrates the hybrid model (its circuit's generated model behind
 * the core's layout: hc_core_me_*), the states the core's (HH_NY, in its order), the spool's input u saturated
 * and delayed by spool.delay (me_u: a time event at each change), the rig's command path without its watchdog */
int plant_me_start(plant *pl)
{
    fmu_delay_init(&pl->me_u, pl->sim.p[HH_SPOOL_DELAY], pl->t0, hh_command_clamp(pl->u));
    pl->sim.p[HH_LOAD_FORCE] = pl->f_load;
    pl->sim.p[HH_SUPPLY_PS] = pl->ps;
    return PLANT_OK;
}

int plant_me_states(plant *pl, double *x, size_t nx, int set)
{
    size_t i;
    if (plant_me_size(pl, nx, HH_NY, "continuous states") != PLANT_OK)
        return PLANT_ERROR;
    for (i = 0; i < nx; i++) {
        if (set)
            pl->sim.y[i] = x[i];
        else
            x[i] = pl->sim.y[i];
    }
    return PLANT_OK;
}

int plant_me_nominals(plant *pl, double *x, size_t nx)
{
    size_t i;
    if (plant_me_size(pl, nx, HH_NY, "continuous states") != PLANT_OK)
        return PLANT_ERROR;
    for (i = 0; i < nx; i++)
        x[i] = PLANT_NOMINAL[i];
    return PLANT_OK;
}

int plant_me_derivatives(plant *pl, double *dx, size_t nx)
{
    if (plant_me_size(pl, nx, HH_NY, "derivatives") != PLANT_OK)
        return PLANT_ERROR;
    hc_core_me_derivatives(&pl->model.ctx, pl->sim.y, pl->sim.m, pl->sim.p, me_ud(pl), dx);
    return PLANT_OK;
}

int plant_me_indicators(plant *pl, double *z, size_t nz)
{
    if (plant_me_size(pl, nz, PLANT_NZ, "event indicators") != PLANT_OK)
        return PLANT_ERROR;
    hc_core_me_indicators(&pl->model.ctx, pl->sim.y, pl->sim.m, pl->sim.p, me_ud(pl), z);
    return PLANT_OK;
}

int plant_me_update(plant *pl, int *changed, int *next_defined, double *next)
{
    fmu_delay_event(&pl->me_u, pl->t_me);
    *changed = hc_core_me_event(&pl->model.ctx, pl->sim.y, pl->sim.m, pl->sim.p, me_ud(pl));
    *next_defined = fmu_delay_next(&pl->me_u, pl->t_me, next);
    return PLANT_OK;
}

int plant_me_step_done(plant *pl, int *enter_event, int *terminate)
{
    const double *y = pl->sim.y;
    *terminate = hh_diverged(y, pl->sim.p);
    if (*terminate) {
        plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (travel %d, friction %d, spool %d): xs %g, "
                   "vs %g, p1 %g Pa, p2 %g Pa, xp %g m, vp %g m/s, z %g m", pl->t_me, (int)pl->sim.m[HH_M_TRAVEL],
                   (int)pl->sim.m[HH_M_FRICTION], (int)pl->sim.m[HH_M_SPOOL], y[HH_XS], y[HH_VS], y[HH_P1], y[HH_P2],
                   y[HH_XP], y[HH_VP], y[HH_Z]);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    *enter_event = hc_core_me_step_event(&pl->model.ctx, y, pl->sim.m, pl->sim.p, me_ud(pl));
    return fmu_delay_accept(pl, &pl->me_u, pl->t_me);
}

int plant_get_integer(plant *pl, unsigned vr, int *v)
{
    double res, c;
    if (vr < PLANT_NPAR) {                       /* an Integer or Enumeration parameter */
        if (parameter_of_kind(pl, vr, PLANT_KIND_INT, "get") != PLANT_OK)
            return PLANT_ERROR;
        *v = (int)pl->par[vr];
        return PLANT_OK;
    }
    if (vr != VR_TRAVEL && vr != VR_FRICTION && vr != VR_SPOOL && vr != VR_ENCODER) {
        plant_logf(pl, PLANT_ERROR, "value reference %u is not an Integer or an Enumeration", vr);
        return PLANT_ERROR;
    }
    if (pl->mode == PLANT_INSTANTIATED) {
        plant_logf(pl, PLANT_ERROR, "value reference %u: outputs exist from initialisation mode on", vr);
        return PLANT_ERROR;
    }
    if (pl->mode == PLANT_INITIALIZING && !pl->prepared && plant_prepare(pl) != PLANT_OK)
        return PLANT_ERROR;
    switch (vr) {
    case VR_TRAVEL: *v = (int)pl->sim.m[HH_M_TRAVEL]; return PLANT_OK;
    case VR_FRICTION: *v = (int)pl->sim.m[HH_M_FRICTION]; return PLANT_OK;
    case VR_SPOOL: *v = (int)pl->sim.m[HH_M_SPOOL]; return PLANT_OK;
    default:   /* VR_ENCODER: counts of the encoder (sensors.encoder_resolution; 0: ideal, counted in nm) */
        res = pl->par[HH_SENSORS_ENCODER_RESOLUTION];
        c = hh_encoder_counts(pl->sim.y[HH_XP], hh_count_size(res));
        *v = c > 2147483647.0 ? 2147483647 : c < -2147483647.0 ? -2147483647 : (int)c;
        return PLANT_OK;
    }
}

/* A communication step of any size: the plant steps on its own grid t0 + k*h, as many whole internal steps as
 * end by the communication point t + dt (within 1e-6 h); the rest carries over to the next doStep. The outputs
 * are those of the last grid point at or before the communication point; inputs set there drive the internal
 * steps the next doStep takes (the first of them begins at that grid point), each held over its step. */
int plant_do_step(plant *pl, double t, double dt)
{
    double h = pl->sim.h, u_valve;
    long long n, i;
    if (plant_step_check(pl, t, dt, h) != PLANT_OK)
        return PLANT_ERROR;
    n = (long long)floor((t + dt - pl->t0) / h + 1e-6) - (long long)pl->sim.k;
    pl->sim.p[HH_LOAD_FORCE] = pl->f_load;
    pl->sim.p[HH_SUPPLY_PS] = pl->ps;
    for (i = 0; i < n; i++) {
        if (hh_rig_step(&pl->rig, pl->sim.k, 1, pl->u, &u_valve) != HH_OK) {   /* the rig's step, saturating u */
            const double *y = pl->sim.y;
            plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (travel %d, friction %d, spool %d): "
                       "xs %g, vs %g, p1 %g Pa, p2 %g Pa, xp %g m, vp %g m/s, z %g m", pl->t0 + pl->sim.out[HH_OUT_T],
                       (int)pl->sim.m[HH_M_TRAVEL], (int)pl->sim.m[HH_M_FRICTION], (int)pl->sim.m[HH_M_SPOOL], y[HH_XS],
                       y[HH_VS], y[HH_P1], y[HH_P2], y[HH_XP], y[HH_VP], y[HH_Z]);
            pl->mode = PLANT_FAILED;
            return PLANT_ERROR;
        }
    }
    pl->t_comm = t + dt;
    return PLANT_OK;
}

/* ---- FMU state: values only, as one block (the header: fmu_instance.h) -------------------------------- */
typedef struct {
    double par[PLANT_NPAR], u, f_load, ps, t0, t_comm, xs_rest;
    int64_t f_load_set, ps_set, mode;
    double p[HH_NP], y[HH_NY], out[HH_NOUT], h, delay_alpha;
    int64_t m[HH_NM], k, model, method, bounded, delay_pos, delay_n;
    double link_u_held, link_hold_x;          /* the rig's command path (hh_watchdog) */
    int64_t link_k_delivered, link_k_interfered, link_delivered, link_active, link_trips, link_trips_unexplained;
    int64_t me, me_event;                     /* Model Exchange */
    double t_me;
    fmu_delay me_u;
} state_values;

static void state_header_of(plant_state_header *hd, uint64_t dbuf_size)
{
    const uint64_t dims[6] = {PLANT_NPAR, HH_NP, HH_NY, HH_NM, HH_NOUT, 0};
    plant_state_header_of(hd, STATE_TAG, STATE_VERSION, dims, sizeof(state_values), dbuf_size);
}

/* Whether `bytes` (size bytes) is a state block of this FMU: its tag, format version, token, layout and size. */
int plant_state_check(plant *pl, const void *bytes, size_t size)
{
    plant_state_header hd, mine;
    if (plant_state_header_read(pl, bytes, size, STATE_TAG, STATE_VERSION, &hd) != PLANT_OK)
        return PLANT_ERROR;
    if (hd.extra > DELAY_MAX) {
        plant_logf(pl, PLANT_ERROR, "FMU state with a delay line of %llu steps: not one of this plant's",
                   (unsigned long long)hd.extra);
        return PLANT_ERROR;
    }
    state_header_of(&mine, hd.extra);
    return plant_state_header_match(pl, &hd, &mine, size);
}

int plant_state_get(plant *pl, void **state)
{
    plant_state_header hd;
    state_values v;
    const hh_sim *s = &pl->sim;
    char *bytes;
    int i;
    state_header_of(&hd, (uint64_t)pl->dbuf_size);
    bytes = *state ? realloc(*state, hd.total) : malloc(hd.total);
    if (!bytes) {
        plant_logf(pl, PLANT_ERROR, "out of memory for an FMU state");
        return PLANT_ERROR;
    }
    memset(&v, 0, sizeof v);
    memcpy(v.par, pl->par, sizeof v.par);
    v.u = pl->u;
    v.f_load = pl->f_load;
    v.ps = pl->ps;
    v.t0 = pl->t0;
    v.t_comm = pl->t_comm;
    v.xs_rest = pl->xs_rest;
    v.f_load_set = pl->f_load_set;
    v.ps_set = pl->ps_set;
    v.mode = pl->mode;
    memcpy(v.p, s->p, sizeof v.p);
    memcpy(v.y, s->y, sizeof v.y);
    memcpy(v.out, s->out, sizeof v.out);
    for (i = 0; i < HH_NM; i++)
        v.m[i] = s->m[i];
    v.h = s->h;
    v.k = s->k;
    v.model = s->model;
    v.method = s->method;
    v.bounded = s->bounded;
    v.delay_alpha = s->delay.alpha;
    v.delay_pos = s->delay.pos;
    v.delay_n = s->delay.n;
    v.link_u_held = pl->rig.link.u_held;
    v.link_hold_x = pl->rig.link.hold_x;
    v.link_k_delivered = pl->rig.link.k_delivered;
    v.link_k_interfered = pl->rig.link.k_interfered;
    v.link_delivered = pl->rig.link.delivered;
    v.link_active = pl->rig.link.active;
    v.link_trips = pl->rig.link.trips;
    v.link_trips_unexplained = pl->rig.link.trips_unexplained;
    v.me = pl->me;
    v.me_event = pl->me_event;
    v.t_me = pl->t_me;
    v.me_u = pl->me_u;
    memcpy(bytes, &hd, sizeof hd);
    memcpy(bytes + sizeof hd, &v, sizeof v);
    if (pl->dbuf_size > 0)
        memcpy(bytes + sizeof hd + sizeof v, pl->dbuf, sizeof(double) * (size_t)pl->dbuf_size);
    *state = bytes;
    return PLANT_OK;
}

/* Whether a state's values are ones this FMU makes: a state taken before initialisation has no delay line
 * and no model yet; one taken after has the hybrid model, the FMU's method and step, modes in their ranges. */
static int state_values_valid(const state_values *v, uint64_t dbuf_size)
{
    if (v->mode < PLANT_INSTANTIATED || v->mode > PLANT_FAILED || v->me_u.n < 0 || v->me_u.n > FMU_DELAY_CAP)
        return 0;
    if (dbuf_size == 0)
        return v->mode <= PLANT_INITIALIZING && v->delay_n == 0;
    return v->delay_n + 2 == (int64_t)dbuf_size && v->delay_pos >= 0 && v->delay_pos < (int64_t)dbuf_size
           && v->model == HH_MODEL_GENERATED && v->method == PLANT_METHOD && isfinite(v->h) && v->h > 0.0
           && v->h == v->par[VR_STEP] && v->k >= 0 && v->m[HH_M_TRAVEL] >= HH_FREE
           && v->m[HH_M_TRAVEL] <= HH_AT_EXTEND && v->m[HH_M_FRICTION] >= HH_STICK
           && v->m[HH_M_FRICTION] <= HH_SLIP_NEG && v->m[HH_M_SPOOL] >= HH_SPOOL_LINEAR
           && v->m[HH_M_SPOOL] <= HH_SPOOL_AT_END;
}

int plant_state_set(plant *pl, const void *state)
{
    const char *bytes = state;
    plant_state_header hd;
    state_values v;
    hh_sim *s = &pl->sim;
    char why[400];
    int i;
    if (!state) {
        plant_logf(pl, PLANT_ERROR, "no FMU state given");
        return PLANT_ERROR;
    }
    if (plant_state_check(pl, state, plant_state_block_size(state)) != PLANT_OK)
        return PLANT_ERROR;
    memcpy(&hd, bytes, sizeof hd);
    memcpy(&v, bytes + sizeof hd, sizeof v);
    if (v.me != pl->me) {
        plant_logf(pl, PLANT_ERROR, "FMU state of a %s instance: this one is %s's", v.me ? "Model Exchange" :
                   "Co-Simulation", pl->me ? "Model Exchange" : "Co-Simulation");
        return PLANT_ERROR;
    }
    if (hd.extra > 0 && paper_model_structure_check(v.p, why, sizeof why) != 0) {   /* (its generated model's) */
        plant_logf(pl, PLANT_ERROR, "FMU state refused: %s", why);
        return PLANT_ERROR;
    }
    if (!state_values_valid(&v, hd.extra)) {
        plant_logf(pl, PLANT_ERROR, "FMU state with inconsistent values (mode %lld, model %lld, method %lld, step %g s, "
                   "k %lld, delay line %lld of %llu)", (long long)v.mode, (long long)v.model, (long long)v.method,
                   v.h, (long long)v.k, (long long)v.delay_n, (unsigned long long)hd.extra);
        return PLANT_ERROR;
    }
    if ((uint64_t)pl->dbuf_size != hd.extra) {   /* e.g. a state set right after instantiation */
        double *buf = hd.extra > 0 ? malloc(sizeof(double) * (size_t)hd.extra) : NULL;
        if (hd.extra > 0 && !buf) {
            plant_logf(pl, PLANT_ERROR, "out of memory for the FMU state's delay line");
            return PLANT_ERROR;
        }
        free(pl->dbuf);
        pl->dbuf = buf;
        pl->dbuf_size = (int)hd.extra;
    }
    memcpy(pl->par, v.par, sizeof v.par);
    pl->u = v.u;
    pl->f_load = v.f_load;
    pl->ps = v.ps;
    pl->t0 = v.t0;
    pl->t_comm = v.t_comm;
    pl->xs_rest = v.xs_rest;
    pl->f_load_set = (int)v.f_load_set;
    pl->ps_set = (int)v.ps_set;
    pl->mode = (int)v.mode;
    pl->prepared = 0;
    memset(s, 0, sizeof *s);
    memcpy(s->p, v.p, sizeof v.p);
    memcpy(s->y, v.y, sizeof v.y);
    memcpy(s->out, v.out, sizeof v.out);
    for (i = 0; i < HH_NM; i++)
        s->m[i] = v.m[i];
    s->h = v.h;
    s->k = v.k;
    s->model = (int)v.model;
    s->method = (int)v.method;
    s->bounded = (int)v.bounded;
    s->delay.buf = pl->dbuf;
    s->delay.size = pl->dbuf_size;
    s->delay.pos = (int)v.delay_pos;
    s->delay.n = (int)v.delay_n;
    s->delay.alpha = v.delay_alpha;
    if (pl->dbuf_size > 0 && attach_model(pl) != PLANT_OK) {   /* (a state after initialisation: its model; its
                                                                 * structure was checked with its values) */
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    rig_init(pl);
    pl->rig.link.u_held = v.link_u_held;
    pl->rig.link.hold_x = v.link_hold_x;
    pl->rig.link.k_delivered = v.link_k_delivered;
    pl->rig.link.k_interfered = v.link_k_interfered;
    pl->rig.link.delivered = v.link_delivered;
    pl->rig.link.active = (int)v.link_active;
    pl->rig.link.trips = v.link_trips;
    pl->rig.link.trips_unexplained = v.link_trips_unexplained;
    pl->me = (int)v.me;
    pl->me_event = (int)v.me_event;
    pl->t_me = v.t_me;
    pl->me_u = v.me_u;
    if (pl->dbuf_size > 0)
        memcpy(pl->dbuf, bytes + sizeof hd + sizeof v, sizeof(double) * (size_t)pl->dbuf_size);
    return PLANT_OK;
}
