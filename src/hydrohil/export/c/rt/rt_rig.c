/* rt_rig.c: the paper's rig behind the standalone plant (rt_plant.h, "what the plant serves"): the hybrid model
 * generated from its circuit (paper_model.h: circuit.c behind the core's loop) in the core's rig step (command
 * path, watchdog, faults, the encoder and pressure transducers), the SENSOR / COMMAND packets of protocol v1, its
 * plant_log.csv row. The same C as the Python plant's VirtualRig. */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "paper_model.h"
#include "rt_side.h"

static paper_model generated;     /* the rig's model (one plant a process) */

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
    {
        char why[400];
        if (paper_model_attach(&generated, &pl->sim, HH_RK3, why, sizeof why) != 0)
            die_usage("%s", why);
    }
    {   /* the rig: its watchdog counts from step 0, the faults of step 0 apply (as the Python plant's) */
        int64_t cap = 0;
        int i;
        for (i = 0; i < o->nfault + o->has_panel; i++)    /* (the panel may switch a network_delay on) */
            if ((i == o->nfault || o->faults[i].type == HH_FAULT_NETWORK_DELAY) && !pl->fifo) {   /* up to 1 s */
                cap = (int64_t)ceil(1.0 / o->step) + 2;
                pl->fifo = malloc(sizeof(double) * 2 * (size_t)cap);   /* (slots of 2: hh_wire) */
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


/* ---- the live panel (rt_side.h): the rig's telemetry, commands and steering ------------------------- */
static double side_base0[HH_NP];           /* the scenario's parameters; the tunables set (NaN: not set) act on them */
static double side_tunables[HH_NTUNABLES];
const char MODEL_STEER_OPS[] = "set, fault_on, fault_off, reset";

const char *const *model_side_columns(int *n)
{
    *n = HH_NSIDE;
    return SIDE_NAMES;
}

void model_side_open(plant *pl)
{
    int i;
    for (i = 0; i < HH_NTUNABLES; i++)
        side_tunables[i] = NAN;
    for (i = 0; i < HH_NP; i++)
        side_base0[i] = pl->rig.base[i];
}

int model_side_commands(plant *pl, double u, double *out)
{
    (void)pl;
    *out = u;
    return 1;
}

void model_side_row(plant *pl, double *row, const reading *r, int64_t late_ns, int64_t compute_ns, double u)
{
    const double *out = pl->sim.out;
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
}

/* The fault of a fault_on as --fault's TYPE:key=value,... text, on from now (start 0; end ignored: it lasts until
 * fault_off, as hydrohil.simulation.steering.fault_model). -1 with the reason when it is not one. */
static int fault_spec(const jobject *o, char *spec, size_t size, char *err, size_t errsize)
{
    const jfield *type = side_field(o, "fault.type"), *fault = side_field(o, "fault");
    text t = {spec, size, 0, 0};
    int i;
    if (!fault || fault->kind != J_OBJ) {
        snprintf(err, errsize, "fault: an object with the fault's type and fields is needed");
        return -1;
    }
    if (!type || type->kind != J_STR || strpbrk(type->str, ",=:")) {
        snprintf(err, errsize, "fault.type: a fault type is needed");
        return -1;
    }
    side_puts(&t, type->str);
    side_puts(&t, ":start=0");
    for (i = 0; i < o->n; i++) {
        const jfield *f = &o->f[i];
        const char *key = f->key + 6;
        if (strncmp(f->key, "fault.", 6) != 0 || strcmp(key, "type") == 0 || strcmp(key, "start") == 0 ||
            strcmp(key, "end") == 0 || f->kind == J_NULL)
            continue;
        if (f->kind == J_BOOL || f->kind == J_OBJ || strpbrk(key, ",=:") ||
            (f->kind == J_STR && strpbrk(f->str, ",=:"))) {
            snprintf(err, errsize, "fault.%.100s: not a value of a fault's field", key);
            return -1;
        }
        side_puts(&t, ",");
        side_puts(&t, key);
        side_puts(&t, "=");
        if (f->kind == J_STR)
            side_puts(&t, f->str);
        else
            side_put(&t, f->raw, f->raw_len);            /* strict JSON number text: strtod reads it exactly */
    }
    if (t.overflow) {
        snprintf(err, errsize, "fault: too long");
        return -1;
    }
    return 0;
}

/* The rig's steering (simulation/steering.py's plant events): set (a tunable), fault_on, fault_off, reset. */
int model_steer(plant *pl, const jobject *o, const char *op, int64_t k, text *ev, char *extra, size_t extra_size,
                char *err, size_t err_size)
{
    static const char *const none[] = {NULL}, *const set_fields[] = {"name", "value", NULL},
                      *const fault_on_fields[] = {"fault", NULL}, *const fault_off_fields[] = {"slot", NULL};
    const char *const *allowed, *odd;
    if (strcmp(op, "set") == 0)
        allowed = set_fields;
    else if (strcmp(op, "fault_on") == 0)
        allowed = fault_on_fields;
    else if (strcmp(op, "fault_off") == 0)
        allowed = fault_off_fields;
    else if (strcmp(op, "reset") == 0)
        allowed = none;
    else
        return SIDE_UNKNOWN;
    if ((odd = side_unexpected_field(o, allowed)) != NULL) {
        snprintf(err, err_size, "%.100s: not a field of %s", odd, op);
        return SIDE_REFUSED;
    }
    if (strcmp(op, "set") == 0) {
        const jfield *name = side_field(o, "name"), *value = side_field(o, "value");
        const tunable *tu = NULL;
        int i;
        double p[HH_NP];
        for (i = 0; name && name->kind == J_STR && i < HH_NTUNABLES; i++)
            if (strcmp(TUNABLES[i].name, name->str) == 0)
                tu = &TUNABLES[i];
        if (!tu) {
            size_t used = (size_t)snprintf(err, err_size, "name: one of");
            for (i = 0; i < HH_NTUNABLES && used < err_size; i++)
                used += (size_t)snprintf(err + used, err_size - used, " %s", TUNABLES[i].name);
            return SIDE_REFUSED;
        }
        if (!value || value->kind != J_NUM) {
            snprintf(err, err_size, "value: a number is needed");
            return SIDE_REFUSED;
        }
        if (!(value->num >= tu->lo && value->num <= tu->hi)) {
            snprintf(err, err_size, "%s must be in [%g, %g] %s, got %g", tu->description, tu->lo, tu->hi, tu->unit,
                     value->num);
            return SIDE_REFUSED;
        }
        side_tunables[tu - TUNABLES] = value->num;
        hh_tuned_base(side_base0, side_tunables, p);
        hh_rig_set_base(&pl->rig, p);
        side_puts(ev, ", \"name\": ");
        side_put_string(ev, tu->name);
        side_puts(ev, ", \"value\": ");
        side_put_double(ev, value->num);
    } else if (strcmp(op, "fault_on") == 0) {
        char spec[1024], fault[1024], why[SIDE_MSG];
        hh_fault f;
        double end;
        int slot;
        if (fault_spec(o, spec, sizeof spec, why, sizeof why) != 0 ||
            fault_from_spec(spec, &f, &end, why, sizeof why) != 0) {
            snprintf(err, err_size, "fault: %.7000s", why);
            return SIDE_REFUSED;
        }
        if (f.type == HH_FAULT_NETWORK_DELAY && !pl->fifo) {
            snprintf(err, err_size, "fault: network_delay needs its delay line (start the plant with --panel)");
            return SIDE_REFUSED;
        }
        if (fault_json(&f, fault, sizeof fault) == 0) {
            snprintf(err, err_size, "fault: too long");
            return SIDE_REFUSED;
        }
        slot = hh_rig_add_live(&pl->rig, &f, k);
        if (slot < 0) {
            snprintf(err, err_size, "at most %d faults at a time", HH_MAX_FAULTS);
            return SIDE_REFUSED;
        }
        side_puts(ev, ", \"fault\": ");
        side_puts(ev, fault);
        side_puts(ev, ", \"result\": {\"slot\": ");
        side_put_int(ev, slot);
        side_puts(ev, "}");
        snprintf(extra, extra_size, ", \"slot\": %d", slot);
    } else if (strcmp(op, "fault_off") == 0) {
        const jfield *slot = side_field(o, "slot");
        if (!side_integral(slot, 0, HH_MAX_FAULTS - 1)) {
            snprintf(err, err_size, "slot: a whole number from 0 to %d", HH_MAX_FAULTS - 1);
            return SIDE_REFUSED;
        }
        if (hh_rig_end(&pl->rig, (int)slot->num, k) != 0) {
            snprintf(err, err_size, "no active fault in slot %d", (int)slot->num);
            return SIDE_REFUSED;
        }
        side_puts(ev, ", \"slot\": ");
        side_put_int(ev, (int64_t)slot->num);
    } else {                                          /* reset */
        plant_reset(pl);
    }
    return SIDE_APPLIED;
}
