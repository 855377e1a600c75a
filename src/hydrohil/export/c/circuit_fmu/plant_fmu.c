/* plant_fmu.c: an exported circuit's instance (see plant_fmu.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "plant_fmu.h"

#define STATE_TAG "hydrohil circuit state"
#define STATE_VERSION 2u            /* 2: Model Exchange's mode, time and delayed inputs */
#define REST_S 20.0                  /* simulated seconds of the rest march when inputs set change the rest */
#define REST_TOL 1e-13

void plant_defaults(plant *pl)
{
    memcpy(pl->v.P, CIRCUIT_P, sizeof pl->v.P);
    memcpy(pl->v.u, CIRCUIT_U0, sizeof pl->v.u);
    memcpy(pl->v.y, CIRCUIT_Y0, sizeof pl->v.y);
    memcpy(pl->v.m, CIRCUIT_M0, sizeof pl->v.m);
    memset(pl->v.row, 0, sizeof pl->v.row);
    pl->v.row_valid = 0;
    pl->v.k = 0;
    pl->t0 = pl->t_comm = 0.0;
    pl->v.inputs_set = 0;
    pl->prepared = 0;
    pl->mode = PLANT_INSTANTIATED;
}

plant *plant_new(const char *name, plant_log_fn log, void *env)
{
    plant *pl = calloc(1, sizeof *pl);
    if (!pl)
        return 0;
    snprintf(pl->name, sizeof pl->name, "%s", name ? name : CIRCUIT_NAME);
    pl->log = log;
    pl->env = env;
    plant_defaults(pl);
    return pl;
}

void plant_free(plant *pl) { free(pl); }

int plant_set_real(plant *pl, unsigned vr, double v)
{
    if (vr >= VR_INPUT0 && vr < VR_INPUT0 + CIRCUIT_NINPUTS) {
        if (!isfinite(v)) {
            plant_logf(pl, PLANT_ERROR, "input %s = %g: must be finite", CIRCUIT_INPUT_NAMES[vr - VR_INPUT0], v);
            return PLANT_ERROR;
        }
        pl->v.u[vr - VR_INPUT0] = v;
        pl->v.row_valid = 0;              /* (an output may depend on an input directly: an orifice's flow) */
        if (pl->me && pl->mode == PLANT_STEPPING) {   /* (ME: a delayed input reaches its component later) */
            int64_t d;
            for (d = 0; d < pl->me_nd; d++)
                if (pl->me_idx[d] == (int64_t)(vr - VR_INPUT0))
                    return fmu_delay_set(pl, &pl->me_in[d], pl->t_me, v, pl->me_event);
        }
        if (pl->mode == PLANT_INSTANTIATED || pl->mode == PLANT_INITIALIZING) {
            pl->v.inputs_set = 1;
            pl->prepared = 0;
        }
        return PLANT_OK;
    }
    plant_logf(pl, PLANT_ERROR, "value reference %u is not a settable Real (the circuit's parameters are fixed at "
               "export: hydrohil export fmu --circuit ... --set component.key=value)", vr);
    return PLANT_ERROR;
}

/* The initial state: the circuit's state at rest as exported (under the inputs' start values); inputs set
 * before initialisation to other values: the node pressures marched to their rest under them (the components'
 * states held and the nodes given in [initial] too, REST_S simulated seconds at most; without the exporter's
 * final root polish). */
int plant_prepare(plant *pl)
{
    int i, differ = 0;
    for (i = 0; i < CIRCUIT_NINPUTS; i++)
        differ |= pl->v.u[i] != CIRCUIT_U0[i];
    memcpy(pl->v.y, CIRCUIT_Y0, sizeof pl->v.y);
    memcpy(pl->v.m, CIRCUIT_M0, sizeof pl->v.m);
    if (pl->v.inputs_set && differ) {    /* the nodes given in [initial] keep theirs (CIRCUIT_HELD) */
        hc_init(pl->v.P, pl->v.u, CIRCUIT_STEP, pl->v.y, pl->v.m);
        if (hc_rest(pl->v.P, pl->v.u, pl->v.y, pl->v.m, CIRCUIT_HELD, CIRCUIT_METHOD, CIRCUIT_STEP,
                    (int64_t)(REST_S / CIRCUIT_STEP), REST_TOL) < 0)
            plant_logf(pl, PLANT_WARNING, "the node pressures did not settle in %g s under the inputs set: the run "
                       "starts from where they are", REST_S);
    }
    pl->v.k = 0;
    pl->v.row_valid = 0;
    pl->prepared = 1;
    return PLANT_OK;
}

/* the inputs as the components see them now (Model Exchange: each delayed one its delay ago) */
static void me_inputs(const plant *pl, double *u)
{
    int64_t d;
    memcpy(u, pl->v.u, sizeof pl->v.u);
    for (d = 0; d < pl->me_nd; d++)
        u[pl->me_idx[d]] = fmu_delay_value(&pl->me_in[d], pl->t_me);
}

static int outputs_ready(plant *pl, unsigned vr)
{
    if (pl->mode == PLANT_INSTANTIATED) {
        plant_logf(pl, PLANT_ERROR, "value reference %u: outputs exist from initialisation mode on", vr);
        return PLANT_ERROR;
    }
    if (pl->mode == PLANT_INITIALIZING && !pl->prepared && plant_prepare(pl) != PLANT_OK)
        return PLANT_ERROR;
    if (!pl->v.row_valid && pl->me && pl->mode == PLANT_STEPPING) {
        double u[CIRCUIT_NU];
        me_inputs(pl, u);
        hc_row(pl->v.P, pl->v.y, pl->v.m, u, pl->t_me, pl->v.row);
        pl->v.row_valid = 1;
    } else if (!pl->v.row_valid) {
        hc_row(pl->v.P, pl->v.y, pl->v.m, pl->v.u, (double)pl->v.k * CIRCUIT_STEP, pl->v.row);
        pl->v.row_valid = 1;
    }
    return PLANT_OK;
}

int plant_get_real(plant *pl, unsigned vr, double *v)
{
    if (vr >= VR_INPUT0 && vr < VR_INPUT0 + CIRCUIT_NINPUTS) {
        *v = pl->v.u[vr - VR_INPUT0];
        return PLANT_OK;
    }
    if (vr >= VR_OUTPUT0 && vr < VR_OUTPUT0 + CIRCUIT_NOUTPUTS) {
        if (outputs_ready(pl, vr) != PLANT_OK)
            return PLANT_ERROR;
        *v = pl->v.row[CIRCUIT_OUTPUT_COLUMN[vr - VR_OUTPUT0]];
        return PLANT_OK;
    }
    if (vr >= VR_LOCAL0 && vr < VR_LOCAL0 + CIRCUIT_NSTATES) {    /* a state that is no output (ME's) */
        if (outputs_ready(pl, vr) != PLANT_OK)
            return PLANT_ERROR;
        *v = pl->v.y[vr - VR_LOCAL0];
        return PLANT_OK;
    }
    if ((vr >= VR_DER0 && vr < VR_DER0 + CIRCUIT_NSTATES) || (vr >= VR_EVENT0 && vr < VR_EVENT0 + PLANT_NZ)) {
        double u[CIRCUIT_NU], w[CIRCUIT_NSTATES + PLANT_NZ + 1];
        if (outputs_ready(pl, vr) != PLANT_OK)
            return PLANT_ERROR;
        me_inputs(pl, u);
        if (vr >= VR_DER0 && vr < VR_DER0 + CIRCUIT_NSTATES) {
            hc_rhs(pl->v.P, pl->v.y, pl->v.m, u, w);
            *v = w[vr - VR_DER0];
        } else {
            hc_me_indicators(pl->v.P, pl->v.y, pl->v.m, u, w);
            *v = w[vr - VR_EVENT0];
        }
        return PLANT_OK;
    }
    plant_logf(pl, PLANT_ERROR, "value reference %u is not a Real", vr);
    return PLANT_ERROR;
}

/* ---- Model Exchange: the importer's solver integrates the circuit's hybrid model (its generated hc_rhs, the
 * guards as event indicators, hc_me_event's transitions), each delayed input its delay late (fmu_delay) ---- */
int plant_me_start(plant *pl)
{
    double tau[CIRCUIT_NDELAY];
    int64_t d;
    pl->me_nd = hc_me_delays(pl->v.P, pl->me_idx, tau);
    for (d = 0; d < pl->me_nd; d++)
        fmu_delay_init(&pl->me_in[d], tau[d], pl->t0, pl->v.u[pl->me_idx[d]]);
    return PLANT_OK;
}

int plant_me_states(plant *pl, double *x, size_t nx, int set)
{
    size_t i;
    if (plant_me_size(pl, nx, CIRCUIT_NSTATES, "continuous states") != PLANT_OK)
        return PLANT_ERROR;
    for (i = 0; i < nx; i++) {
        if (set)
            pl->v.y[i] = x[i];
        else
            x[i] = pl->v.y[i];
    }
    pl->v.row_valid &= !set;
    return PLANT_OK;
}

int plant_me_nominals(plant *pl, double *x, size_t nx)
{
    if (plant_me_size(pl, nx, CIRCUIT_NSTATES, "continuous states") != PLANT_OK)
        return PLANT_ERROR;
    memcpy(x, CIRCUIT_NOMINAL, sizeof(double) * nx);
    return PLANT_OK;
}

int plant_me_derivatives(plant *pl, double *dx, size_t nx)
{
    double u[CIRCUIT_NU], dy[CIRCUIT_NSTATES + 1];
    if (plant_me_size(pl, nx, CIRCUIT_NSTATES, "derivatives") != PLANT_OK)
        return PLANT_ERROR;
    me_inputs(pl, u);
    hc_rhs(pl->v.P, pl->v.y, pl->v.m, u, dy);
    memcpy(dx, dy, sizeof(double) * nx);
    return PLANT_OK;
}

int plant_me_indicators(plant *pl, double *z, size_t nz)
{
    double u[CIRCUIT_NU], g[PLANT_NZ + 1];
    if (plant_me_size(pl, nz, PLANT_NZ, "event indicators") != PLANT_OK)
        return PLANT_ERROR;
    me_inputs(pl, u);
    hc_me_indicators(pl->v.P, pl->v.y, pl->v.m, u, g);
    memcpy(z, g, sizeof(double) * nz);
    return PLANT_OK;
}

int plant_me_update(plant *pl, int *changed, int *next_defined, double *next)
{
    double u[CIRCUIT_NU], t;
    int64_t d;
    for (d = 0; d < pl->me_nd; d++)
        fmu_delay_event(&pl->me_in[d], pl->t_me);
    me_inputs(pl, u);
    *changed = hc_me_event(pl->v.P, pl->v.y, pl->v.m, u);
    pl->v.row_valid = 0;
    *next_defined = 0;
    for (d = 0; d < pl->me_nd; d++)
        if (fmu_delay_next(&pl->me_in[d], pl->t_me, &t) && (!*next_defined || t < *next)) {
            *next = t;
            *next_defined = 1;
        }
    return PLANT_OK;
}

int plant_me_step_done(plant *pl, int *enter_event, int *terminate)
{
    double u[CIRCUIT_NU], lo[CIRCUIT_NSTATES + 1], hi[CIRCUIT_NSTATES + 1];
    int64_t bad = hc_unphysical(pl->v.P, pl->v.y), d;
    *terminate = bad != 0;
    if (bad) {
        hc_state_bounds(pl->v.P, lo, hi);
        plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (%s = %.6g outside its physical range "
                   "[%.6g, %.6g])", pl->t_me, CIRCUIT_STATE_NAMES[bad - 1], pl->v.y[bad - 1], lo[bad - 1], hi[bad - 1]);
        pl->mode = PLANT_FAILED;
        return PLANT_ERROR;
    }
    me_inputs(pl, u);
    *enter_event = hc_me_step_event(pl->v.P, pl->v.y, pl->v.m, u);
    for (d = 0; d < pl->me_nd; d++)
        if (fmu_delay_accept(pl, &pl->me_in[d], pl->t_me) != PLANT_OK)
            return PLANT_ERROR;
    return PLANT_OK;
}

int plant_get_integer(plant *pl, unsigned vr, int *v)
{
    if (vr >= VR_MODE0 && vr < VR_MODE0 + CIRCUIT_NMODES) {
        if (outputs_ready(pl, vr) != PLANT_OK)
            return PLANT_ERROR;
        *v = (int)pl->v.m[vr - VR_MODE0];
        return PLANT_OK;
    }
    plant_logf(pl, PLANT_ERROR, "value reference %u is not an Enumeration (the modes)", vr);
    return PLANT_ERROR;
}

/* a circuit's FMU has no settable Integer or Enumeration and no Boolean: its parameters are the export's */
int plant_set_integer(plant *pl, unsigned vr, int v)
{
    (void)v;
    plant_logf(pl, PLANT_ERROR, "value reference %u: this FMU has no settable Integer or Enumeration (its modes are "
               "outputs, its parameters fixed by the export)", vr);
    return PLANT_ERROR;
}

int plant_get_boolean(plant *pl, unsigned vr, int *v)
{
    (void)v;
    plant_logf(pl, PLANT_ERROR, "value reference %u: this FMU has no Boolean variable", vr);
    return PLANT_ERROR;
}

int plant_set_boolean(plant *pl, unsigned vr, int v)
{
    (void)v;
    return plant_get_boolean(pl, vr, &v);
}

/* A communication step of any size: the plant steps on its own grid t0 + k*h, as many whole internal steps as
 * end by the communication point t + dt (within 1e-6 h), the inputs held over each; the outputs are those of
 * the last grid point at or before the communication point under the inputs as set when they are read (the
 * rig's FMU steps the same way). */
int plant_do_step(plant *pl, double t, double dt)
{
    const double h = CIRCUIT_STEP;
    long long n, i;
    if (plant_step_check(pl, t, dt, h) != PLANT_OK)
        return PLANT_ERROR;
    n = (long long)floor((t + dt - pl->t0) / h + 1e-6) - (long long)pl->v.k;
    for (i = 0; i < n; i++) {
        int status = hc_step(pl->v.P, pl->v.y, pl->v.m, pl->v.u, CIRCUIT_METHOD, h);
        if (status != 0) {
            int64_t bad = status == 4 ? hc_unphysical(pl->v.P, pl->v.y) : 0;   /* (4: out of its range) */
            double lo[CIRCUIT_NSTATES + 1], hi[CIRCUIT_NSTATES + 1];   /* (+1: C has no empty arrays) */
            hc_state_bounds(pl->v.P, lo, hi);
            if (bad > 0)
                plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (%s = %.6g outside its physical "
                           "range [%.6g, %.6g])", pl->t0 + (double)(pl->v.k + 1) * h, CIRCUIT_STATE_NAMES[bad - 1],
                           pl->v.y[bad - 1], lo[bad - 1], hi[bad - 1]);
            else
                plant_logf(pl, PLANT_ERROR, "the simulation diverged at t = %.6g s (a state is not finite)",
                           pl->t0 + (double)(pl->v.k + 1) * h);
            pl->mode = PLANT_FAILED;
            return PLANT_ERROR;
        }
        pl->v.k++;
    }
    pl->v.row_valid = 0;
    pl->t_comm = t + dt;
    return PLANT_OK;
}

/* ---- FMU state: values only, as one block ----------------------------------------------------------- */
typedef struct {
    circuit_values v;
    double t0, t_comm;
    int64_t mode, prepared;
    int64_t me, me_event, me_nd, me_idx[CIRCUIT_NDELAY];     /* Model Exchange */
    double t_me;
    fmu_delay me_in[CIRCUIT_NDELAY];
} state_values;

static void state_header_of(plant_state_header *hd)
{
    const uint64_t dims[6] = {CIRCUIT_NP, CIRCUIT_NU, CIRCUIT_NY, CIRCUIT_NM, CIRCUIT_NLOG, 0};
    plant_state_header_of(hd, STATE_TAG, STATE_VERSION, dims, sizeof(state_values), 0);
}

int plant_state_check(plant *pl, const void *bytes, size_t size)
{
    plant_state_header hd, mine;
    if (plant_state_header_read(pl, bytes, size, STATE_TAG, STATE_VERSION, &hd) != PLANT_OK)
        return PLANT_ERROR;
    state_header_of(&mine);
    return plant_state_header_match(pl, &hd, &mine, size);
}

int plant_state_get(plant *pl, void **state)
{
    plant_state_header hd;
    state_values v;
    char *bytes;
    state_header_of(&hd);
    bytes = *state ? realloc(*state, hd.total) : malloc(hd.total);
    if (!bytes) {
        plant_logf(pl, PLANT_ERROR, "out of memory for an FMU state");
        return PLANT_ERROR;
    }
    memset(&v, 0, sizeof v);
    v.v = pl->v;
    v.t0 = pl->t0;
    v.t_comm = pl->t_comm;
    v.mode = pl->mode;
    v.prepared = pl->prepared;
    v.me = pl->me;
    v.me_event = pl->me_event;
    v.me_nd = pl->me_nd;
    memcpy(v.me_idx, pl->me_idx, sizeof v.me_idx);
    v.t_me = pl->t_me;
    memcpy(v.me_in, pl->me_in, sizeof v.me_in);
    memcpy(bytes, &hd, sizeof hd);
    memcpy(bytes + sizeof hd, &v, sizeof v);
    *state = bytes;
    return PLANT_OK;
}

int plant_state_set(plant *pl, const void *state)
{
    state_values v;
    int64_t i;
    if (!state) {
        plant_logf(pl, PLANT_ERROR, "no FMU state given");
        return PLANT_ERROR;
    }
    if (plant_state_check(pl, state, plant_state_block_size(state)) != PLANT_OK)
        return PLANT_ERROR;
    memcpy(&v, (const char *)state + sizeof(plant_state_header), sizeof v);
    if (v.me != pl->me) {
        plant_logf(pl, PLANT_ERROR, "FMU state of a %s instance: this one is %s's", v.me ? "Model Exchange" :
                   "Co-Simulation", pl->me ? "Model Exchange" : "Co-Simulation");
        return PLANT_ERROR;
    }
    if (v.mode < PLANT_INSTANTIATED || v.mode > PLANT_FAILED || v.v.k < 0 || v.me_nd < 0 || v.me_nd > CIRCUIT_NDELAY) {
        plant_logf(pl, PLANT_ERROR, "FMU state with inconsistent values (mode %lld, k %lld)", (long long)v.mode,
                   (long long)v.v.k);
        return PLANT_ERROR;
    }
    for (i = 0; i < v.me_nd; i++)
        if (v.me_in[i].n < 1 || v.me_in[i].n > FMU_DELAY_CAP || v.me_idx[i] < 0 || v.me_idx[i] >= CIRCUIT_NU) {
            plant_logf(pl, PLANT_ERROR, "FMU state with an inconsistent delayed input (%lld)", (long long)i);
            return PLANT_ERROR;
        }
    pl->v = v.v;
    pl->v.row_valid = 0;
    pl->t0 = v.t0;
    pl->t_comm = v.t_comm;
    pl->mode = (int)v.mode;
    pl->prepared = (int)v.prepared;
    pl->me_event = (int)v.me_event;
    pl->me_nd = v.me_nd;
    memcpy(pl->me_idx, v.me_idx, sizeof v.me_idx);
    pl->t_me = v.t_me;
    memcpy(pl->me_in, v.me_in, sizeof v.me_in);
    return PLANT_OK;
}
