/* rt_rig.c: the paper's rig behind the standalone plant (rt_plant.h, "what the plant serves"): the core's
 * hybrid model and rig step (command path, watchdog, faults, the encoder and pressure transducers), the SENSOR /
 * COMMAND packets of protocol v1, its plant_log.csv row. The same C as the Python plant's VirtualRig. */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt_plant.h"

/* The sensors' readings (the core's rig step, as the Python plant's) and the status bits of the wire. */
static void read_sensors(plant *pl, reading *r)
{
    hh_rig_sense(&pl->rig, r);
    r->status |= pl->o->lockstep ? HH_ST_LOCKSTEP : 0;
}

void model_send_sensor(plant *pl, int64_t k, uint32_t status)
{
    uint8_t buf[HHIL_SENSOR_LEN];
    hhil_header h;
    hhil_sensor s;
    reading *r = &pl->reading;
    read_sensors(pl, r);
    r->status |= status;
    h.type = HHIL_SENSOR;
    h.seq = (uint32_t)k;
    h.t_send_ns = mono_ns();
    h.echo_t_ns = pl->cmd_t_arrival;
    h.echo_seq = (uint32_t)(pl->cmd_seq > 0 ? pl->cmd_seq : 0);
    s.t_sim = pl->sim.out[HH_OUT_T];
    s.step = (uint64_t)k;
    s.encoder_counts = r->encoder;
    s.p1 = r->p[HH_PRESSURE_P1];
    s.p2 = r->p[HH_PRESSURE_P2];
    s.ps = r->p[HH_PRESSURE_PS];
    s.pt = r->p[HH_PRESSURE_PT];
    s.status = r->status;
    s.travel_mode = (uint8_t)pl->sim.m[HH_M_TRAVEL];
    s.friction_mode = (uint8_t)pl->sim.m[HH_M_FRICTION];
    s.spool_mode = (uint8_t)pl->sim.m[HH_M_SPOOL];
    hhil_encode_sensor(buf, &h, &s);
    transmit(pl, k, buf, sizeof buf, h.t_send_ns);
}

int model_init(plant *pl)
{
    options *o = pl->o;
    double alpha, res = o->p[HH_SENSORS_ENCODER_RESOLUTION];
    int n;
    hh_params_derive(o->p);
    n = hh_delay_steps(o->p[HH_SPOOL_DELAY], o->step, &alpha);
    pl->delay_buf = calloc((size_t)n + 2, sizeof(double));
    if (!pl->delay_buf) {
        fprintf(stderr, "error: out of memory for a delay line of %d steps\n", n);
        return -1;
    }
    hh_sim_init(&pl->sim, o->p, HH_MODEL_HYBRID, HH_RK3, o->step, pl->delay_buf, n, alpha);
    {   /* the rig: its watchdog counts from step 0, the faults of step 0 apply (as the Python plant's) */
        int64_t cap = 0;
        int i;
        for (i = 0; i < o->nfault + o->has_panel; i++)    /* (the panel may switch a network_delay on) */
            if ((i == o->nfault || o->faults[i].type == HH_FAULT_NETWORK_DELAY) && !pl->fifo) {   /* up to 1 s */
                cap = (int64_t)ceil(1.0 / o->step) + 2;
                pl->fifo = malloc(sizeof(double) * (size_t)cap);
                if (!pl->fifo) {
                    fprintf(stderr, "error: out of memory for a network delay of %lld steps\n", (long long)cap);
                    return -1;
                }
            }
        hh_rig_init(&pl->rig, &pl->sim, hh_count_size(res), (uint64_t)o->hil[HIL_SEED], o->hil[HIL_WATCHDOG_TIMEOUT],
                    o->hil[HIL_SAFE_STATE] == HIL_SAFE_STATE_HOLD, o->hil[HIL_HOLD_KP], pl->fifo, cap);
        for (i = 0; i < o->nfault; i++) {
            hh_fault f = o->faults[i];
            f.k_start = (int64_t)ceil(f.start / o->step - 1e-9);      /* as Python's math.ceil (faults.k_range) */
            f.k_end = isnan(o->fault_end[i]) ? HH_NEVER : (int64_t)ceil(o->fault_end[i] / o->step - 1e-9);
            hh_rig_add(&pl->rig, &f);
        }
        hh_rig_begin(&pl->rig, 0);
    }
    pl->link = &pl->rig.link;
    return 0;
}

/* The model at its initial state (plant time 0), of the fault-free parameters (the rig's base: a fault active
 * at step 0 hits a rig at rest); the rig's watchdog, faults and noise go on (as the Python plant's). */
void plant_reset(plant *pl)
{
    const double *x = pl->o->initial;
    if (hh_initial_state(pl->rig.base, x[0], x[1], 0.0, x[2], x[3], 0.0, pl->sim.y, pl->sim.m) != 0
        && pl->sim.m[HH_M_TRAVEL] == HH_FREE && (isnan(x[2]) || isnan(x[3])))
        fprintf(stderr, "warning: no spool position holds the piston at rest (the load is more than the cylinder "
                        "gives at %g bar): the spool starts centred and the load moves the piston\n", pl->rig.base[HH_SUPPLY_PS] / 1e5);
    hh_sim_reset(&pl->sim);
}


static void describe_divergence(plant *pl)
{
    const double *y = pl->sim.y;
    const int64_t *m = pl->sim.m;
    char b[HH_NY][32];
    snprintf(pl->fault, sizeof pl->fault,
             "simulation diverged at t = %.6f s (non-finite or unphysical state); modes: travel=%s, friction=%s, "
             "spool=%s; state: xs=%s, vs=%s, p1=%s, p2=%s, xp=%s, vp=%s, z=%s", pl->sim.out[HH_OUT_T],
             TRAVEL_NAMES[m[HH_M_TRAVEL] % HH_N_TRAVEL], FRICTION_NAMES[m[HH_M_FRICTION] % HH_N_FRICTION],
             SPOOL_NAMES[m[HH_M_SPOOL] % HH_N_SPOOL], fmt_g6(b[0], y[HH_XS]), fmt_g6(b[1], y[HH_VS]),
             fmt_g6(b[2], y[HH_P1]), fmt_g6(b[3], y[HH_P2]), fmt_g6(b[4], y[HH_XP]), fmt_g6(b[5], y[HH_VP]), fmt_g6(b[6], y[HH_Z]));
}


void model_reset(plant *pl) { plant_reset(pl); }

void model_warm_up(plant *pl)
{
    plant_reset(pl);            /* one step pages in the code and data a step touches; then the initial state */
    hh_sim_step(&pl->sim, 0.0);
    plant_reset(pl);
}

int model_accepts(const plant *pl, const hhil_message *msg)
{
    (void)pl;
    return msg->header.type != HHIL_SIGNALS && msg->header.type != HHIL_INPUTS;
}

void model_take(plant *pl, const hhil_message *msg)
{
    pl->cmd_u = msg->command.u / pl->o->hil[HIL_COMMAND_SCALE];
}

int model_step(plant *pl, int64_t k, int arrived, double *u)
{
    if (hh_rig_step(&pl->rig, k, arrived, *u, u) != HH_OK) {
        describe_divergence(pl);
        return -1;
    }
    return 0;
}

void model_timing(const plant *pl, FILE *fh)
{
    int i;
    fputs(",\n  \"faults_injected\": [", fh);   /* the fault of each slot: scheduled, or switched on from the panel */
    for (i = 0; i < pl->rig.nfault; i++) {
        if (i)
            fputs(", ", fh);
        json_string_value(fh, hh_fault_type_name(pl->rig.fault[i].type));
    }
    fputc(']', fh);
}

const log_columns *model_log_columns(void) { return &RIG_LOG_COLUMNS; }

void model_free(plant *pl)
{
    free(pl->delay_buf);
    free(pl->fifo);
}

void model_log_row(plant *pl, int64_t k, double wall, int64_t jitter_ns, int64_t compute_ns, double u)
{
    const reading *r = &pl->reading;
    double *row = pl->row;
    const double *out = pl->sim.out;
    if (!pl->log.fh && !pl->side.rec.active)
        return;
    row[HH_PLOG_K] = (double)k;
    row[HH_PLOG_T] = out[HH_OUT_T];
    row[HH_PLOG_WALL] = wall;
    row[HH_PLOG_JITTER_US] = (double)jitter_ns / 1e3;
    row[HH_PLOG_COMPUTE_US] = (double)compute_ns / 1e3;
    row[HH_PLOG_U] = u;
    row[HH_PLOG_CMD_SEQ] = (double)pl->cmd_seq;
    row[HH_PLOG_CMD_AGE] = pl->cmd_seq >= 0 ? (double)(k - 1 - pl->cmd_echo) : -1.0;
    row[HH_PLOG_WATCHDOG] = pl->rig.link.active;
    row[HH_PLOG_XS] = out[HH_OUT_Y + HH_XS];
    row[HH_PLOG_P1] = out[HH_OUT_Y + HH_P1];
    row[HH_PLOG_P2] = out[HH_OUT_Y + HH_P2];
    row[HH_PLOG_XP] = out[HH_OUT_Y + HH_XP];
    row[HH_PLOG_VP] = out[HH_OUT_Y + HH_VP];
    row[HH_PLOG_FF] = out[HH_OUT_FF];
    row[HH_PLOG_TRAVEL_MODE] = out[HH_OUT_TRAVEL];
    row[HH_PLOG_FRICTION_MODE] = out[HH_OUT_FRICTION];
    row[HH_PLOG_SPOOL_MODE] = out[HH_OUT_SPOOL];
    row[HH_PLOG_ENCODER] = (double)r->encoder;
    row[HH_PLOG_P1_MEAS] = r->p[HH_PRESSURE_P1];
    row[HH_PLOG_P2_MEAS] = r->p[HH_PRESSURE_P2];
    row[HH_PLOG_PS_MEAS] = r->p[HH_PRESSURE_PS];
    row[HH_PLOG_FAULTS] = (double)r->faults;
    row[HH_PLOG_STATUS] = (double)r->status;
    log_push(&pl->log, row);
    if (pl->side.rec.active)       /* a recording of the live panel: its rows, its own histograms */
        side_record_row(pl, row, jitter_ns, compute_ns);
}

