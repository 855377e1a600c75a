/* rt_circuit.c: a circuit generated from its description behind the standalone plant (rt_plant.h, "what the
 * plant serves"): the generated C's step (circuit.c: hc_step, hc_row, hc_sensed), the core's command path
 * (link.c: the scenario's network faults, then the watchdog), the SIGNALS / INPUTS packets of protocol v1
 * (docs/protocol.md) and its plant_log.csv row. The rules are the Python plant's (src/hydrohil/circuits/rig.py,
 * CircuitRig): each step takes the scenario's drives and replaces the inputs the controller has set by their latest values (a loop's command from the
 * start: the one that holds its piston), saturated to their ranges; the watchdog's safe state sets the
 * commanded inputs to 0 (the end of their range nearest to it), or with --hil safe_state=hold the loop's command
 * to the P law (hold_kp) holding its measured signal at its value at the trip (link.c: hh_path_apply_held). The
 * export's values (circuit_plant.h) are
 * fixed: no --set, --initial or --fault. The live panel (--panel, rt_side.c): the circuit's telemetry (time, its
 * signals, its inputs as applied), an input the controller does not drive held from the panel and given back to
 * its drive, a parameter changed (the slots the panel derives for it: this plant has no derivations), reset
 * to rest. */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt_side.h"
#include "circuit_plant.h"

/* the generated circuit's per-step interface (circuit.c) */
int hc_step(const double *P, double *y, int64_t *m, const double *u, int method, double h);
void hc_row(const double *P, const double *y, const int64_t *m, const double *u, double t, double *row);
int64_t hc_unphysical(const double *P, const double *y);
void hc_state_bounds(const double *P, double *lo, double *hi);
double hc_sensed(double x, double *sensor, void *rng, int64_t k);

static struct {
    double P[CIRCUIT_NP], y[CIRCUIT_NY], u[CIRCUIT_NU], row[CIRCUIT_NLOG];
    int64_t m[CIRCUIT_NM];
    double cmd[CIRCUIT_NU];           /* the latest value of each input the controller set */
    uint32_t set;                     /* bit j: input j set by the controller (the loop's command from the start) */
    uint32_t pending_mask;            /* the latest INPUTS, for the next step */
    double pending[CIRCUIT_NU];
    double drive[CIRCUIT_NU];         /* the scenario's drive of each input at the current step */
    int drive_next;                   /* the next change of CIRCUIT_DRIVE_* */
    uint32_t held;                    /* bit j: input j held by the live panel at hold[j] (in place of its drive) */
    double hold[CIRCUIT_NU];
    int saturated;
    uint32_t status;                  /* of the last sensor packet (logged) */
    hh_path path;                     /* the network faults on the packets, the watchdog (link.c) */
    hh_fault net[CIRCUIT_NNET > 0 ? CIRCUIT_NNET : 1];
    double fifo[CIRCUIT_FIFO_CAP > 0 ? CIRCUIT_FIFO_CAP * (CIRCUIT_NINPUTS + 2) : 1];
    double packet[CIRCUIT_NINPUTS + 1];   /* the mask, the values */
    hh_rng rng[1 + CIRCUIT_SENSOR_NF];  /* the loop's sensor noise, its faults' streams (seeded at each reset) */
    double sensor[CIRCUIT_SENSOR_N];  /* its sensor and faults (a stuck one's memory: new at each reset) */
    double logrow[LOG_HEAD + CIRCUIT_NSIGNALS + CIRCUIT_NINPUTS];
} C;

static const log_columns COLUMNS = {LOG_HEAD + CIRCUIT_NSIGNALS + CIRCUIT_NINPUTS, CIRCUIT_PLOG_NAMES,
                                    CIRCUIT_PLOG_KINDS};

const log_columns *model_log_columns(void) { return &COLUMNS; }

static void row_now(double t) { hc_row(C.P, C.y, C.m, C.u, t, C.row); }

int model_init(plant *pl)
{
    if (pl->o->step != CIRCUIT_STEP) {
        fprintf(stderr, "error: a circuit's plant steps at its export's step (%g s), got %g s\n", CIRCUIT_STEP,
                pl->o->step);
        return -1;
    }
    if (pl->o->hil[HIL_SAFE_STATE] == HIL_SAFE_STATE_HOLD && !CIRCUIT_HOLDS) {
        fprintf(stderr, "error: --hil safe_state=hold: a circuit's hold gain is in its loop's units, so the scenario "
                        "chooses it ([hil] safe_state = \"hold\" with its hold_kp, then --hil hold_kp=... here)\n");
        return -1;
    }
    pl->link = &C.path.link;
    model_reset(pl);
    return 0;
}

/* The command path from the export's network faults (circuits/network.py: their steps computed there), their
 * streams seeded by the run's seed and their places in the scenario's faults, its watchdog counting from 0. */
static void path_reset(const plant *pl)
{
    int i;
    for (i = 0; i < CIRCUIT_NNET; i++) {
        hh_fault *f = &C.net[i];
        memset(f, 0, sizeof *f);
        f->type = CIRCUIT_NET_TYPE[i];
        f->sensor = -1;
        f->a = CIRCUIT_NET_VALUE[i];
        f->k_start = CIRCUIT_NET_K0[i];
        f->k_end = CIRCUIT_NET_K1[i];
        f->stuck = NAN;
        hh_fault_seed(f, (uint64_t)pl->o->hil[HIL_SEED], CIRCUIT_NET_SLOT[i]);   /* (its place in [[faults]]) */
    }
    hh_path_init(&C.path, C.net, CIRCUIT_NNET, CIRCUIT_STEP, pl->o->hil[HIL_WATCHDOG_TIMEOUT], CIRCUIT_NINPUTS + 1,
                 CIRCUIT_FIFO_CAP > 0 ? C.fifo : NULL, CIRCUIT_FIFO_CAP);
    C.path.hold_kp = pl->o->hil[HIL_SAFE_STATE] == HIL_SAFE_STATE_HOLD ? pl->o->hil[HIL_HOLD_KP] : 0.0;
}

void model_reset(plant *pl)
{
    memcpy(C.P, CIRCUIT_P, sizeof C.P);
    memcpy(C.y, CIRCUIT_Y0, sizeof C.y);
    memcpy(C.m, CIRCUIT_M0, sizeof C.m);
    memcpy(C.u, CIRCUIT_U0, sizeof C.u);
    memcpy(C.cmd, CIRCUIT_U0, sizeof C.cmd);
    memcpy(C.drive, CIRCUIT_DRIVE0, sizeof C.drive);
    C.drive_next = 0;
    C.held = 0U;
    C.set = CIRCUIT_COMMANDED;     /* (the loop's command, an open loop's commands: driven from the start) */
    C.pending_mask = 0;
    C.saturated = 0;
    C.status = 0;
    path_reset(pl);
    {
        int i;
        hh_rng_seed(&C.rng[0], CIRCUIT_SENSOR_SEED);
        for (i = 0; i < CIRCUIT_SENSOR_NF; i++)   /* (circuits/run.py Loop.streams) */
            hh_rng_stream(&C.rng[1 + i], (uint64_t)pl->o->hil[HIL_SEED], CIRCUIT_SENSOR_SLOT[i]);
    }
    memcpy(C.sensor, CIRCUIT_SENSOR, sizeof C.sensor);
    row_now(0.0);
}

void model_warm_up(plant *pl)
{
    int arrived = 0;
    double u = 0.0;
    model_step(pl, 0, arrived, &u);
    model_reset(pl);
}

int model_accepts(const plant *pl, const hhil_message *msg)
{
    (void)pl;
    switch (msg->header.type) {
    case HHIL_INPUTS: return msg->inputs.layout == CIRCUIT_LAYOUT && msg->inputs.n == CIRCUIT_NINPUTS;
    case HHIL_SENSOR:
    case HHIL_COMMAND:
    case HHIL_SIGNALS: return 0;      /* the paper's rig's packets, or a plant's */
    default: return 1;                /* HELLO, BYE */
    }
}

void model_take(plant *pl, const hhil_message *msg)
{
    (void)pl;
    C.pending_mask = msg->inputs.mask;
    memcpy(C.pending, msg->inputs.values, sizeof(double) * CIRCUIT_NINPUTS);
}


static void describe_divergence(plant *pl, double t, int status)
{
    int64_t bad = status == 4 ? hc_unphysical(C.P, C.y) : 0;   /* (4: the state out of its physical range) */
    double lo[CIRCUIT_NSTATES + 1], hi[CIRCUIT_NSTATES + 1];   /* (+1: C has no empty arrays) */
    char b[32], l[32], r[32];
    size_t n;
    int i;
    hc_state_bounds(C.P, lo, hi);
    if (bad > 0)
        n = (size_t)snprintf(pl->fault, sizeof pl->fault, "simulation diverged at t = %.6f s (%s = %s outside its "
                             "physical range [%s, %s]); modes: ", t, CIRCUIT_STATE_NAMES[bad - 1],
                             fmt_g6(b, C.y[bad - 1]), fmt_g6(l, lo[bad - 1]), fmt_g6(r, hi[bad - 1]));
    else
        n = (size_t)snprintf(pl->fault, sizeof pl->fault, "simulation diverged at t = %.6f s (a state is not "
                             "finite); modes: ", t);
    for (i = 0; i < CIRCUIT_NMODES && n < sizeof pl->fault; i++)
        n += (size_t)snprintf(pl->fault + n, sizeof pl->fault - n, "%s%s=%s", i ? ", " : "", CIRCUIT_MODE_NAMES[i],
                              CIRCUIT_MODE_WORDS[CIRCUIT_MODE_FIRST[i] + (int)C.m[i]]);
    if (n < sizeof pl->fault)
        n += (size_t)snprintf(pl->fault + n, sizeof pl->fault - n, "; state: ");
    for (i = 0; i < CIRCUIT_NSTATES && n < sizeof pl->fault; i++)
        n += (size_t)snprintf(pl->fault + n, sizeof pl->fault - n, "%s%s=%s", i ? ", " : "", CIRCUIT_STATE_NAMES[i],
                              fmt_g6(b, C.y[i]));
}

int model_step(plant *pl, int64_t k, int arrived, double *u)
{
    int j;
    double x = CIRCUIT_MEASURE >= 0 ? C.row[CIRCUIT_MEASURE >= 0 ? CIRCUIT_MEASURE : 0] : 0.0;   /* ("hold"'s) */
    (void)u;
    if (arrived) {
        C.packet[0] = (double)C.pending_mask;
        memcpy(C.packet + 1, C.pending, sizeof(double) * CIRCUIT_NINPUTS);
    }
    if (hh_path_step(&C.path, k, arrived, C.packet, x)) {      /* (network faults, the watchdog: link.c) */
        uint32_t mask = (uint32_t)C.packet[0];
        for (j = 0; j < CIRCUIT_NINPUTS; j++)
            if (mask >> j & 1U)
                C.cmd[j] = C.packet[1 + j];
        C.set |= mask;
    }
    if (CIRCUIT_REPEAT && k > 0 && k % CIRCUIT_NSTEPS == 0) {     /* the drives again from their start */
        memcpy(C.drive, CIRCUIT_DRIVE0, sizeof C.drive);
        C.drive_next = 0;
    }
    while (C.drive_next < CIRCUIT_NDRIVES &&                   /* the drives at step k */
           CIRCUIT_DRIVE_STEP[C.drive_next] <= (CIRCUIT_REPEAT ? k % CIRCUIT_NSTEPS : k)) {
        C.drive[CIRCUIT_DRIVE_INPUT[C.drive_next]] = CIRCUIT_DRIVE_VALUE[C.drive_next];
        C.drive_next++;
    }
    memcpy(C.u, C.drive, sizeof C.u);
    for (j = 0; j < CIRCUIT_NINPUTS; j++)                      /* held from the panel (never a commanded one) */
        if (C.held >> j & 1U)
            C.u[j] = C.hold[j];
    C.saturated = 0;
    for (j = 0; j < CIRCUIT_NINPUTS; j++) {   /* (the safe state, a command_inversion, the range: link.c) */
        int saturated;
        if (!(C.set >> j & 1U))
            continue;
        C.u[j] = j == CIRCUIT_LOOP_COMMAND ? hh_path_apply_held(&C.path, C.cmd[j], CIRCUIT_LO[j], CIRCUIT_HI[j], x,
                                                                &saturated)
                                           : hh_path_apply(&C.path, C.cmd[j], CIRCUIT_LO[j], CIRCUIT_HI[j], &saturated);
        C.saturated |= saturated;
    }
    int status = hc_step(C.P, C.y, C.m, C.u, CIRCUIT_METHOD, CIRCUIT_STEP);
    if (status != 0) {
        describe_divergence(pl, (double)(k + 1) * CIRCUIT_STEP, status);
        return -1;
    }
    row_now((double)(k + 1) * CIRCUIT_STEP);
    return 0;
}

void model_send_sensor(plant *pl, int64_t k, uint32_t status)
{
    uint8_t buf[HHIL_HEADER_LEN + HHIL_SIGNALS_FIXED + 8 * CIRCUIT_NSIGNALS + 4];
    double values[CIRCUIT_NSIGNALS];
    hhil_header h;
    size_t n;
    memcpy(values, C.row + CIRCUIT_LOG_T + 1, sizeof values);   /* the signals: every column after time */
    if (CIRCUIT_MEASURE > 0)                        /* the loop's signal through its sensor */
        values[CIRCUIT_MEASURE - CIRCUIT_LOG_T - 1] = hc_sensed(C.row[CIRCUIT_MEASURE], CIRCUIT_HAS_SENSOR ? C.sensor : NULL,
                                                                  C.rng, k);
    status |= (pl->o->lockstep ? HH_ST_LOCKSTEP : 0U) | (C.path.link.active ? HH_ST_WATCHDOG : 0U) |
              (C.saturated ? HH_ST_SATURATED : 0U);
    C.status = status;
    h.type = HHIL_SIGNALS;
    h.seq = (uint32_t)k;
    h.t_send_ns = mono_ns();
    h.echo_t_ns = pl->cmd_t_arrival;
    h.echo_seq = (uint32_t)(pl->cmd_seq > 0 ? pl->cmd_seq : 0);
    n = hhil_encode_signals(buf, &h, C.row[CIRCUIT_LOG_T], (uint64_t)k, status, CIRCUIT_LAYOUT, values, CIRCUIT_NSIGNALS);
    transmit(pl, k, buf, n, h.t_send_ns);
}

void model_log_row(plant *pl, int64_t k, double wall, int64_t jitter_ns, int64_t compute_ns, double u)
{
    double *r = C.logrow;
    (void)u;
    if (!pl->log.fh && !pl->side.rec.active)
        return;
    r[CPLOG_K] = (double)k;
    r[CPLOG_T] = C.row[CIRCUIT_LOG_T];
    r[CPLOG_WALL] = wall;
    r[CPLOG_JITTER_US] = (double)jitter_ns / 1e3;
    r[CPLOG_COMPUTE_US] = (double)compute_ns / 1e3;
    r[CPLOG_CMD_SEQ] = (double)pl->cmd_seq;
    r[CPLOG_CMD_AGE] = pl->cmd_seq >= 0 ? (double)(k - 1 - pl->cmd_echo) : -1.0;
    r[CPLOG_WATCHDOG] = C.path.link.active;
    r[CPLOG_STATUS] = (double)C.status;
    memcpy(r + LOG_HEAD, C.row + CIRCUIT_LOG_T + 1, sizeof(double) * CIRCUIT_NSIGNALS);
    memcpy(r + LOG_HEAD + CIRCUIT_NSIGNALS, C.u, sizeof(double) * CIRCUIT_NINPUTS);
    log_push(&pl->log, r);
    if (pl->side.rec.active)       /* a recording of the live panel: its rows, its own histograms */
        side_record_row(pl, r, jitter_ns, compute_ns);
}

void model_timing(const plant *pl, FILE *fh)
{
    (void)pl;
    fputs(",\n  \"faults_injected\": [],\n  \"circuit\": ", fh);
    json_string_value(fh, CIRCUIT_NAME);
    fprintf(fh, ",\n  \"layout\": %lu,\n  \"signals\": %d,\n  \"inputs\": %d", (unsigned long)CIRCUIT_LAYOUT,
            CIRCUIT_NSIGNALS, CIRCUIT_NINPUTS);
}

void model_free(plant *pl) { (void)pl; }

/* ---- the live panel (rt_side.h): the circuit's telemetry, inputs and steering --------------------------- */
const char MODEL_STEER_OPS[] = "input, set, fault, reset";
/* (the export refuses a circuit beyond the link's limits: circuits/link.py check_link_size; here for the buffers) */
typedef char circuit_fits_the_link[((int)CIRCUIT_NSIGNALS <= (int)HHIL_MAX_SIGNALS &&
                                    (int)CIRCUIT_NINPUTS <= (int)HHIL_MAX_INPUTS && (int)CIRCUIT_NSIDE <= (int)SIDE_MAX_COLUMNS &&
                                    (int)CIRCUIT_NINPUTS <= (int)SIDE_MAX_COMMANDS) ? 1 : -1];

const char *const *model_side_columns(int *n)
{
    *n = CIRCUIT_NSIDE;
    return CIRCUIT_SIDE_NAMES;
}

void model_side_open(plant *pl) { (void)pl; }

int model_side_commands(plant *pl, double u, double *out)     /* every input as applied (hydrohil.hil.session) */
{
    (void)pl; (void)u;
    memcpy(out, C.u, sizeof(double) * CIRCUIT_NINPUTS);   /* (at most SIDE_MAX_COMMANDS: the link's inputs) */
    return CIRCUIT_NINPUTS;
}

/* (circuits/link.side_columns: t, the signals, the inputs as applied, jitter_us, compute_us, watchdog) */
enum { SIDE_T, SIDE_SIGNALS, SIDE_INPUTS = SIDE_SIGNALS + CIRCUIT_NSIGNALS, SIDE_JITTER_US = SIDE_INPUTS + CIRCUIT_NINPUTS,
       SIDE_COMPUTE_US, SIDE_WATCHDOG };

void model_side_row(plant *pl, double *row, const reading *r, int64_t late_ns, int64_t compute_ns, double u)
{
    (void)pl; (void)r; (void)u;
    row[SIDE_T] = C.row[CIRCUIT_LOG_T];
    memcpy(row + SIDE_SIGNALS, C.row + CIRCUIT_LOG_T + 1, sizeof(double) * CIRCUIT_NSIGNALS);
    memcpy(row + SIDE_INPUTS, C.u, sizeof(double) * CIRCUIT_NINPUTS);
    row[SIDE_JITTER_US] = (double)late_ns / 1e3;
    row[SIDE_COMPUTE_US] = (double)compute_ns / 1e3;
    row[SIDE_WATCHDOG] = C.path.link.active;
}

/* set: a parameter changed from the next step on. The plant has no derivations of its own: the panel sends the
 * slots of the parameter vector the change sets, its derived values with them (circuits/rig.py,
 * parameter_change: {"slot": value, ...}), every one checked here before any is applied. */
static int steer_set(const jobject *o, text *ev, char *err, size_t err_size)
{
    static const char *const fields[] = {"name", "value", "slots", NULL};
    const jfield *name = side_field(o, "name"), *value = side_field(o, "value"), *slots = side_field(o, "slots");
    const char *odd = side_unexpected_field(o, fields);
    int idx[J_FIELDS], n = 0, i;
    double v[J_FIELDS];
    if (odd) {
        snprintf(err, err_size, "%.100s: not a field of set", odd);
        return SIDE_REFUSED;
    }
    if (!name || name->kind != J_STR || strlen(name->str) > 100 || !value || value->kind != J_NUM || !slots ||
        slots->kind != J_OBJ) {
        snprintf(err, err_size, "set: name, value and slots (the parameter vector's slots it sets, as the panel "
                 "derives them: {\"slot\": value})");
        return SIDE_REFUSED;
    }
    for (i = 0; i < o->n; i++) {
        const jfield *f = &o->f[i];
        char *end;
        long j;
        if (strncmp(f->key, "slots.", 6) != 0)
            continue;
        j = strtol(f->key + 6, &end, 10);
        if (*end || end == f->key + 6 || j < 0 || j >= CIRCUIT_NP || f->kind != J_NUM || !isfinite(f->num)) {
            snprintf(err, err_size, "slots.%.40s: a slot of the parameter vector (0 to %d) and a finite number",
                     f->key + 6, CIRCUIT_NP - 1);
            return SIDE_REFUSED;
        }
        idx[n] = (int)j;
        v[n++] = f->num;
    }
    if (n == 0) {
        snprintf(err, err_size, "slots: empty (the parameter's own slot at least)");
        return SIDE_REFUSED;
    }
    for (i = 0; i < n; i++)
        C.P[idx[i]] = v[i];
    side_puts(ev, ", \"name\": ");
    side_put_string(ev, name->str);
    side_puts(ev, ", \"value\": ");
    side_put_double(ev, value->num);
    side_puts(ev, ", \"slots\": {");
    for (i = 0; i < n; i++) {
        char key[16];
        snprintf(key, sizeof key, "%d", idx[i]);
        side_puts(ev, i ? ", " : "");
        side_put_string(ev, key);
        side_puts(ev, ": ");
        side_put_double(ev, v[i]);
    }
    side_puts(ev, "}");
    return SIDE_APPLIED;
}

/* fault: a scenario's fault switched on or off at the boundary of step k, from then on. The panel sends what it
 * changes (circuits/faults.py live_switch, as circuits/rig.py switch_fault applies it): the inputs it holds
 * ({"input's place": value}: a leak's opening, a parameter's value and what derives from it; the event log
 * names them), its row of the loop's
 * sensor (sensor_vector's layout: 7 values, then 6 per fault: type, first step, end step, a, b, memory) or its
 * place in the command path, active on [k, never) (on) or on no step (off); switched on, a sensor's memory is
 * fresh (a stuck reading's or a count loss's NaN, an offset's drift from step k). */
enum { SENSOR_HEAD = 7, SENSOR_ROW = 6, SENSOR_STUCK = 1, SENSOR_COUNT_LOSS = 5 };   /* (generate.py's hc_sensed) */

static int steer_fault(const jobject *o, int64_t k, text *ev, char *err, size_t err_size)
{
    static const char *const fields[] = {"slot", "on", "inputs", "sensor", "network", NULL};
    const jfield *slot = side_field(o, "slot"), *on = side_field(o, "on"), *sensor = side_field(o, "sensor"),
                 *network = side_field(o, "network"), *inputs = side_field(o, "inputs");
    const char *odd = side_unexpected_field(o, fields);
    int idx[J_FIELDS], n = 0, i, row = -1, net = -1;
    double v[J_FIELDS];
    if (odd && strncmp(odd, "inputs.", 7) != 0) {
        snprintf(err, err_size, "%.100s: not a field of fault", odd);
        return SIDE_REFUSED;
    }
    if (!slot || !side_integral(slot, 0, 1e9) || !on || on->kind != J_BOOL || (inputs && inputs->kind != J_OBJ)) {
        snprintf(err, err_size, "fault: slot (its place in the scenario's [[faults]]), on (true or false) and what "
                 "it changes as the panel derives it (inputs, sensor, network)");
        return SIDE_REFUSED;
    }
    if (sensor) {
        if (!side_integral(sensor, -1, CIRCUIT_SENSOR_NF - 1)) {
            snprintf(err, err_size, "sensor: -1 or a row of the loop's sensor (0 to %d)", CIRCUIT_SENSOR_NF - 1);
            return SIDE_REFUSED;
        }
        row = (int)sensor->num;
    }
    if (network) {
        if (!side_integral(network, -1, CIRCUIT_NNET - 1)) {
            snprintf(err, err_size, "network: -1 or a place in the command path (0 to %d)", CIRCUIT_NNET - 1);
            return SIDE_REFUSED;
        }
        net = (int)network->num;
    }
    for (i = 0; i < o->n; i++) {
        const jfield *f = &o->f[i];
        char *end;
        long j;
        if (strchr(f->key, '.') && strncmp(f->key, "inputs.", 7) != 0) {
            snprintf(err, err_size, "%.100s: not a field of fault", f->key);
            return SIDE_REFUSED;
        }
        if (strncmp(f->key, "inputs.", 7) != 0)
            continue;
        j = strtol(f->key + 7, &end, 10);
        if (*end || end == f->key + 7 || j < 0 || j >= CIRCUIT_NINPUTS || f->kind != J_NUM || !isfinite(f->num)) {
            snprintf(err, err_size, "inputs.%.40s: an input's place (0 to %d) and a finite number", f->key + 7,
                     CIRCUIT_NINPUTS - 1);
            return SIDE_REFUSED;
        }
        idx[n] = (int)j;
        v[n++] = f->num;
    }
    for (i = 0; i < n; i++) {
        C.held |= 1U << idx[i];
        C.hold[idx[i]] = v[i];
    }
    if (row >= 0) {
        double *F = C.sensor + SENSOR_HEAD + SENSOR_ROW * row;
        F[1] = (double)k;
        F[2] = on->num ? (double)HH_NEVER : (double)k;
        if (on->num)
            F[5] = (int)F[0] == SENSOR_STUCK || (int)F[0] == SENSOR_COUNT_LOSS ? NAN : (double)k * CIRCUIT_STEP;
    }
    if (net >= 0) {
        C.net[net].k_start = k;
        C.net[net].k_end = on->num ? HH_NEVER : k;
    }
    side_puts(ev, ", \"slot\": ");
    side_put_int(ev, (int64_t)slot->num);
    side_puts(ev, on->num ? ", \"on\": true, \"inputs\": {" : ", \"on\": false, \"inputs\": {");
    for (i = 0; i < n; i++) {
        side_puts(ev, i ? ", " : "");
        side_put_string(ev, CIRCUIT_INPUT_NAMES[idx[i]]);
        side_puts(ev, ": ");
        side_put_double(ev, v[i]);
    }
    side_puts(ev, "}, \"sensor\": ");
    side_put_int(ev, row);
    side_puts(ev, ", \"network\": ");
    side_put_int(ev, net);
    return SIDE_APPLIED;
}

/* A circuit's plant events (simulation/steering.py's parse_circuit_event, apply_circuit_event): input (one the
 * controller does not drive, held at a value in its range, or null: back to its drive), set (steer_set: the
 * slots the panel derived), fault (steer_fault), reset (the states and modes back to rest; the step count,
 * drives, held inputs and command path go on). */
int model_steer(plant *pl, const jobject *o, const char *op, int64_t k, text *ev, char *extra, size_t extra_size,
                char *err, size_t err_size)
{
    static const char *const none[] = {NULL}, *const input_fields[] = {"name", "value", NULL};
    const char *odd;
    (void)pl; (void)k; (void)extra; (void)extra_size;
    if (strcmp(op, "set") == 0)
        return steer_set(o, ev, err, err_size);
    if (strcmp(op, "fault") == 0)
        return steer_fault(o, k, ev, err, err_size);
    if (strcmp(op, "input") != 0 && strcmp(op, "reset") != 0)
        return SIDE_UNKNOWN;
    if ((odd = side_unexpected_field(o, strcmp(op, "input") == 0 ? input_fields : none)) != NULL) {
        snprintf(err, err_size, "%.100s: not a field of %s", odd, op);
        return SIDE_REFUSED;
    }
    if (strcmp(op, "input") == 0) {
        const jfield *name = side_field(o, "name"), *value = side_field(o, "value");
        int j = -1, i;
        for (i = 0; name && name->kind == J_STR && i < CIRCUIT_NINPUTS; i++)
            if (strcmp(CIRCUIT_INPUT_NAMES[i], name->str) == 0)
                j = i;
        if (j < 0) {
            size_t used = (size_t)snprintf(err, err_size, "%.100s: not an input of circuit '%s' (inputs:",
                                           name && name->kind == J_STR ? name->str : "name", CIRCUIT_NAME);
            for (i = 0; i < CIRCUIT_NINPUTS && used < err_size; i++)
                used += (size_t)snprintf(err + used, err_size - used, "%s %s", i ? "," : "", CIRCUIT_INPUT_NAMES[i]);
            if (used < err_size)
                snprintf(err + used, err_size - used, ")");
            return SIDE_REFUSED;
        }
        if (j == CIRCUIT_LOOP_COMMAND) {
            snprintf(err, err_size, "%s: the closed loop's command: its controller drives it (steer its reference "
                     "or gains)", CIRCUIT_INPUT_NAMES[j]);
            return SIDE_REFUSED;
        }
        if (value && value->kind != J_NULL && value->kind != J_NUM) {
            snprintf(err, err_size, "value: a number (its unit: %s) or null (back to its drive)", CIRCUIT_INPUT_UNITS[j]);
            return SIDE_REFUSED;
        }
        if (value && value->kind == J_NUM && !(value->num >= CIRCUIT_LO[j] && value->num <= CIRCUIT_HI[j])) {
            snprintf(err, err_size, "%s: must be >= %g and <= %g %s, got %g", CIRCUIT_INPUT_NAMES[j], CIRCUIT_LO[j],
                     CIRCUIT_HI[j], CIRCUIT_INPUT_UNITS[j], value->num);
            return SIDE_REFUSED;
        }
        side_puts(ev, ", \"name\": ");
        side_put_string(ev, CIRCUIT_INPUT_NAMES[j]);
        side_puts(ev, ", \"value\": ");
        if (value && value->kind == J_NUM) {
            C.held |= 1U << j;
            C.hold[j] = value->num;
            side_put_double(ev, value->num);
        } else {
            C.held &= ~(1U << j);
            side_puts(ev, "null");
        }
    } else {                                          /* reset: the state at rest, the rest goes on */
        memcpy(C.y, CIRCUIT_Y0, sizeof C.y);
        memcpy(C.m, CIRCUIT_M0, sizeof C.m);
        row_now(0.0);
    }
    return SIDE_APPLIED;
}
