/* hh.h: the public interface of the hydrohil C core (C99, libm only).
 *
 * The core is the one source of the plant's physics (SPEC §3-§6): the servo-solenoid valve, the
 * differential cylinder, LuGre friction, the hybrid statechart, the continuous reference model's
 * right-hand side, the fixed-step Runge-Kutta tableaus, the fractional input delay, the sensor models,
 * the built-in controllers, the one sampled loop (controller -> delay -> step -> log) and the rig's
 * command path (watchdog, safe state) and transducers shared by the Python and the C plant.
 *
 * Every function works on memory the caller owns: no allocation, no global state, so any number of
 * instances run in one process and in parallel threads. The parameter vector p[HH_NP] is laid out by
 * hh_params.h, generated from the pydantic schema at build time.
 */
#ifndef HH_H
#define HH_H

#include <stddef.h>
#include <stdint.h>
#include "hh_compat.h"           /* the same numbers from every build: no fused multiply-add (and old glibc symbols) */
#include "hh_params.h"
#include "hh_shape.h"            /* the plant's shape (state, modes, outputs, logs, sensors, status bits) */

#ifdef __cplusplus
extern "C" {
#endif

/* ---- state y[HH_NY], modes m[HH_NM] and their values, out[HH_NOUT], log columns: hh_shape.h ------ */
/* limits of the spool acting (bits; spool_bode.c reports them per Bode point) */
enum { HH_SPOOL_ACTS_ACC = 1, HH_SPOOL_ACTS_VEL = 2, HH_SPOOL_ACTS_END = 4 };

/* ---- guards of the hybrid statechart (hybrid.c) --------------------------------------------- */
enum { HH_G_NONE = -1, HH_G_RETRACT, HH_G_EXTEND, HH_G_BREAK_POS, HH_G_BREAK_NEG, HH_G_REVERSE, HH_G_LEAVE };
#define HH_MAX_EVENTS 3

/* ---- fixed-step methods (rk.c) and models --------------------------------------------------- */
enum { HH_EULER, HH_HEUN, HH_RK3, HH_RK4, HH_NMETHODS };
enum { HH_MODEL_HYBRID, HH_MODEL_CONTINUOUS, HH_MODEL_EXTERNAL, HH_MODEL_GENERATED };
/* HH_MODEL_EXTERNAL: the loop's step is a callback that advances y over [t, t + h] with the spool input
 * u_old over the first alpha*h and u_new after it (the SciPy LSODA/Radau reference); nonzero: failed. */
typedef int (*hh_advance_fn)(void *ctx, double t, double h, double alpha, double u_old, double u_new, double *y);
/* HH_MODEL_GENERATED: the hybrid model of another module (the code generated from the paper's circuit,
 * circuits/generate.py: hc_core_hybrid_step, hc_core_friction) behind the loop's state, modes and parameters:
 * `step` takes one step of h with the spool input ud (the loop's delay line) and returns the events located
 * (< 0: failed); `friction` gives the friction force of a state and its modes (the log's ff). */
typedef int (*hh_model_step_fn)(void *ctx, double *y, int64_t *m, const double *p, double ud, double h);
typedef double (*hh_model_friction_fn)(void *ctx, const double *y, const int64_t *m, const double *p);
typedef int (*hh_progress_fn)(void *ctx, int64_t k);   /* nonzero: stop the run (HH_STOPPED) */

/* ---- constants ------------------------------------------------------------------------------ */
#define HH_P_MIN (-0.99e5)              /* Pa gauge: pressures are floored here (cavitation) */
#define HH_P_ATM 1e5                    /* Pa: the atmospheric pressure of eq 21 */
#define HH_LPM_PER_SQRT_BAR (1.0 / 60000.0 / 316.22776601683796)  /* (l/min)/sqrt(bar) in (m^3/s)/sqrt(Pa) */
#define HH_IDEAL_COUNT 1e-9             /* m: count size of an ideal encoder where counts must be integers */

enum { HH_OK = 0, HH_DIVERGED = 1, HH_BAD_ARGUMENT = 2, HH_STOPPED = 3 };   /* HH_STOPPED: a callback failed */

/* ---- parameters (params.c) ------------------------------------------------------------------ */
/* Fill the model slots (friction set per direction from friction.asymmetric; reference-model and
 * stiff-chamber constants; fault slots 0) from the schema slots. */
void hh_params_derive(double *p);
/* Check the schema slots against the schema's ranges and cross-field rules. Returns -1 when all hold,
 * else the index of the first bad slot, with a message in msg (msg_size bytes, always terminated). */
int hh_params_check(const double *p, char *msg, size_t msg_size);
const char *hh_param_name(int index);           /* "spool.wn"; NULL beyond HH_NP */
const char *hh_param_unit(int index);

/* ---- model pieces (for tests, identification and the SciPy reference) ----------------------- */
double hh_orifice_flow(double area, double dp, double dp_t);
/* The stability interval of method's tableau on the negative real axis: explicit steps are stable for
 * |lambda*h| below it (2 for Euler and Heun, 2.51 RK3, 2.79 RK4). */
double hh_real_axis_limit(int method);
double hh_orifice_slope(double area, double dp, double dp_t);
int hh_spool_derivatives(double xs, double vs, double ud, const double *p, double *dxs, double *dvs);
void hh_reference_rhs(const double *y, double ud, const double *p, double *dy);
double hh_lugre_force(double v, double z, const double *p);
double hh_external_force(double p1, double p2, const double *p);
double hh_friction_force(const double *y, const int64_t *m, const double *p);
/* The plant at rest (rest.c, SPEC §12.5): (p1, p2) [Pa] at which both chambers' net inflows (valve flows,
 * internal leakage) vanish with the spool at xs. */
void hh_rest_pressures(const double *p, double xs, double *p1, double *p2);
/* The spool offset *xs in [-1, 1] at which the rest pressures hold the piston (force balance, friction
 * zero) and those pressures; returns 0, or -1 when no spool position holds the load (then *xs = 0 and the
 * pressures at rest there). */
int hh_rest_state(const double *p, double *xs, double *p1, double *p2);
/* Initial state (SPEC §12.5, scenarios): xs NaN -> at rest (hh_rest_state); chamber pressures NaN -> the
 * pressures at rest at xs; the piston on a stop when pressed onto it, else free with the bristles
 * balancing the net force up to breakaway. Returns hh_rest_state's status (0 when xs was given). */
int hh_initial_state(const double *p, double xp, double xs, double vs, double p1, double p2, double vp,
                     double *y, int64_t *m);
/* One fixed step h of the hybrid model (y, m in place) with spool input ud; returns the events. */
int hh_hybrid_step(int method, double *y, int64_t *m, const double *p, double ud, double h);
double hh_encoder_counts(double xp, double resolution);
double hh_count_size(double resolution);   /* m per count as the rig reports */
double hh_p_control(double kp, double x_ref, double x_meas);

/* ---- built-in position controllers (control.c; the law and its units in control.h) ---------- */
enum { HH_CTRL_P, HH_CTRL_PI, HH_CTRL_PID, HH_CTRL_P_FF, HH_CTRL_STATE_FEEDBACK };
enum { HH_AW_CLAMP, HH_AW_BACK_CALCULATION };
typedef struct {
    int type;                   /* HH_CTRL_* */
    double h;                   /* sample time [s] */
    double kp, ki, kd;          /* ū/m, ū/(m·s), ū/(m/s) */
    double tf;                  /* velocity-estimate (derivative) filter time constant [s] */
    int antiwindup;             /* HH_AW_* */
    double tt;                  /* back-calculation tracking time constant [s] */
    double kff;                 /* velocity feed-forward from the reference's slope [ū/(m/s)] */
    double u_bias;              /* constant valve-null compensation [ū] */
    double u_deadband, e_deadband;   /* deadband compensation [ū] reached at an error of e_deadband [m] */
    double kpl;                 /* load-pressure gain [ū/Pa] */
    double tpl;                 /* load-pressure high-pass time constant [s] (0: static feedback) */
    double area_ratio;          /* A2/A1 of the load pressure p1 - (A2/A1)*p2 */
    double u_min, u_max;        /* output limits [ū] */
} hh_controller;
typedef struct {
    double integral, velocity, x_prev, pl_prev, pl_filtered;
    int started;
} hh_controller_state;
void hh_controller_reset(hh_controller_state *s);
/* One sample: the command ū for the reference x_ref [m] (slope dx_ref [m/s]), the encoder reading x [m]
 * and the pressure readings p1, p2 [Pa gauge]; updates the state. */
double hh_controller_update(const hh_controller *c, hh_controller_state *s, double x_ref, double dx_ref, double x,
                            double p1, double p2);

/* ---- the sampled loop (loop.c) -------------------------------------------------------------- */
/* Input delay (SPEC §3.1) as a ring of zero-order-held commands; buf holds n + 2 doubles. */
typedef struct {
    double *buf;
    int size;            /* n + 2 */
    int pos;
    int n;               /* whole steps */
    double alpha;        /* fraction of a step */
} hh_delay;

int hh_delay_steps(double delay, double h, double *alpha);   /* n with delay = (n + alpha)*h */
void hh_delay_init(hh_delay *d, double *buf, int n, double alpha, double u0);

typedef struct {
    double p[HH_NP];
    double y[HH_NY];
    int64_t m[HH_NM];
    double out[HH_NOUT];        /* the last step's outputs (hh_sim_step) */
    int model;                  /* HH_MODEL_HYBRID | HH_MODEL_CONTINUOUS | HH_MODEL_EXTERNAL | HH_MODEL_GENERATED */
    int method;                 /* HH_EULER .. HH_RK4 */
    double h;                   /* fixed step [s] */
    int64_t k;                  /* steps done */
    hh_delay delay;
    int bounded;                /* also stop when a pressure > 1.5 Ps or |xs| > 2 (maxstep's bounds) */
    hh_advance_fn advance;      /* HH_MODEL_EXTERNAL */
    void *ctx;                  /* passed to advance, model_step and model_friction */
    hh_model_step_fn model_step;            /* HH_MODEL_GENERATED */
    hh_model_friction_fn model_friction;
    hh_progress_fn progress;    /* called every 500 steps of hh_sim_run when set */
    void *progress_ctx;         /* passed to progress */
} hh_sim;

/* Drive of a run: open loop (values are commands u) or closed loop (values are positions x_ref [m], slopes
 * dx_ref [m/s] optional): each step the sensors are read as the rig reads them (hh_rig_read: encoder counts,
 * pressure transducers with noise drawn from rng) and the controller computes u from them. t_in == NULL:
 * value k holds over step k; else a table (t_in, v_in, dv_in, n_in) sampled by zero-order hold at t_k.
 *
 * With a rig (rig != NULL: the run through the rig step of rig.c, its faults, command path and watchdog) the
 * rig's sensing gives the readings (rng unused), its step takes the command through the command path, and
 * rig_log (when set) gets HH_NRLOG columns per row: what the sensors reported, the faults, the watchdog. Row k
 * holds the state at t_k and the command that drove the valve over step k. A controller in Python comes in
 * as `command` (kind closed or open: its output is the command); `on_event` is called before the steps listed
 * in event_steps (ascending; steering replays). Either callback's failure stops the run with HH_STOPPED.
 * Kind applied (through a rig only): the values are the commands that drove the valve (a run's log replayed:
 * hh_rig_step_applied, the command path skipped). log_from: rows of the steps before it are not written (a
 * replay that keeps the end of a long run); 0 in every other run. */
enum { HH_DRIVE_OPEN, HH_DRIVE_CLOSED, HH_DRIVE_APPLIED };
typedef struct { uint64_t s[4]; } hh_rng;         /* xoshiro256** state (rng.c) */
typedef struct hh_rig hh_rig;                     /* the rig step (rig.c, below) */
typedef struct hh_rig_reading hh_rig_reading;
typedef double (*hh_command_fn)(void *ctx, int64_t k, double t, double v, double dv, const hh_rig_reading *r);
typedef int (*hh_event_fn)(void *ctx, int64_t k);
typedef struct {
    int kind;
    const hh_controller *controller;     /* closed loop */
    hh_controller_state *state;
    hh_rng *rng;                         /* closed loop: the pressure readings' noise (seeded by the caller) */
    const double *t_in;
    const double *v_in;
    const double *dv_in;                 /* NULL: slopes 0 */
    int64_t n_in;
    hh_rig *rig;                         /* NULL: the plant alone */
    hh_command_fn command;               /* NULL: the built-in controller (closed) or the values (open) */
    hh_event_fn on_event;
    void *ctx;                           /* of command and on_event */
    const int64_t *event_steps;
    int64_t n_event_steps;
    double *rig_log;                     /* rows x HH_NRLOG, or NULL */
    int64_t log_from;                    /* the first step logged (through a rig) */
} hh_drive;

/* Set up sim (state from hh_initial_state's arguments) with a delay buffer of hh_delay_steps + 2. */
void hh_sim_init(hh_sim *sim, const double *p, int model, int method, double h, double *delay_buf,
                 int delay_n, double delay_alpha);
void hh_sim_reset(hh_sim *sim);   /* k = 0, delay line filled with y[XS], out from the state */
/* One step of the per-step API with command u: fills sim->out; returns HH_OK or HH_DIVERGED. */
int hh_sim_step(hh_sim *sim, double u);
/* The hybrid model's friction force [N] at the loop's state: the core's, or the generated model's. */
double hh_sim_friction(const hh_sim *sim);
/* THE sampled loop: n_steps steps from the current state (of the plant alone, or through drive->rig); a log
 * row (HH_NLOG columns) every `every` steps, the first at the start. Returns HH_OK / HH_DIVERGED, HH_STOPPED
 * (a callback of the drive failed), or HH_BAD_ARGUMENT (nothing done) for every < 1 or n_steps < 0;
 * *steps_done and *rows written. */
int hh_sim_run(hh_sim *sim, const hh_drive *drive, int64_t n_steps, int64_t every, double *log,
               int64_t *steps_done, int64_t *rows);
/* Whether y is non-finite or far outside any physical range (divergence, hybrid.h). */
int hh_diverged(const double *y, const double *p);

/* ---- the rig: command path, watchdog, pressure transducers, noise (rig.c) ------------------- */
void hh_rng_seed(hh_rng *r, uint64_t seed);
double hh_rng_uniform(hh_rng *r);                  /* (0, 1] */
void hh_rng_normals(hh_rng *r, int n, double *out);   /* n standard normal samples */
double hh_pressure_reading(double p, double full_scale, double resolution, double noise, int *saturated);
typedef struct {
    double u_held;              /* the last command that reached the valve, saturated to [-1, 1] */
    int64_t k_delivered;        /* the step it arrived */
    int64_t k_interfered;       /* the last step an injected fault held a command back */
    int64_t delivered;          /* commands that reached the valve */
    int active;                 /* safe state on */
    int64_t trips;              /* safe-state entries */
    int64_t trips_unexplained;  /* ... with no injected fault to explain the silence */
    double hold_x;              /* position held by the 'hold' safe state [m] */
} hh_watchdog;
typedef struct {
    double p[HH_NPRESSURES];    /* p1, p2, ps, pt as the transducers report [Pa gauge] (HH_PRESSURE_*) */
    int64_t encoder;            /* encoder reading [counts] */
    int saturated;              /* a pressure reading is clipped */
} hh_reading;
void hh_watchdog_init(hh_watchdog *w);
double hh_command_clamp(double u);          /* the command path's saturation of ū to [-1, 1] (rig, FMU) */
void hh_rig_read(const hh_sim *sim, double count, hh_rng *rng, hh_reading *r);
int64_t hh_count_to_int(double counts);     /* NaN -> 0, saturated at +-2^62 */
double hh_watchdog_command(hh_watchdog *w, int64_t k, int arrived, double u, double h, double timeout, int hold,
                           double hold_kp, double xp);

/* ---- the rig step: command path, watchdog, fault injection, sensing (rig.c) ------------------ */
/* Status bits (HH_ST_*, hh_shape.h: the wire protocol's, docs/protocol.md): the rig sets watchdog, the end
 * stops, stick, saturated and fault_injected; the plant servers the others. */
/* Fault types (the [[faults]] of a scenario, simulation/faults.py; names: hh_fault_type_name). */
enum { HH_FAULT_SENSOR_STUCK, HH_FAULT_SENSOR_OFFSET, HH_FAULT_SENSOR_NOISE, HH_FAULT_SENSOR_DROPOUT,
       HH_FAULT_ENCODER_COUNT_LOSS, HH_FAULT_SPOOL_STUCK, HH_FAULT_VALVE_BANDWIDTH, HH_FAULT_VALVE_LEAKAGE,
       HH_FAULT_COMMAND_INVERSION, HH_FAULT_SUPPLY_PRESSURE, HH_FAULT_SEAL_WEAR, HH_FAULT_HOSE_BURST,
       HH_FAULT_LOAD_CHANGE, HH_FAULT_PACKET_LOSS, HH_FAULT_NETWORK_DELAY, HH_FAULT_REORDERING,
       HH_FAULT_CONTROLLER_SILENCE, HH_NFAULT_TYPES };
#define HH_MAX_FAULTS 53         /* the active-fault mask is logged as a double: exact to 2^53 */
#define HH_NEVER ((int64_t)1 << 62)
/* One fault of the table. a, b: its parameters in the order its schema declares them (sensor_offset: offset,
 * drift; sensor_noise: std; encoder_count_loss: fraction; valve_bandwidth: factor; valve_leakage: section;
 * supply_pressure: ps; seal_wear: g_lkc; hose_burst: line, section; load_change: mass, force (NaN: unchanged);
 * packet_loss and reordering: probability; network_delay: delay [s]). Active on k_start <= k < k_end. */
typedef struct {
    int type, sensor;
    double a, b;
    double start;               /* [s] as written: sensor_offset's drift counts from it */
    int64_t k_start, k_end;
    hh_rng rng;                 /* its own stream, seeded by the run's seed and its slot */
    double stuck;               /* sensor_stuck: the value held (NaN until the first reading while active) */
} hh_fault;

/* ---- the network between a controller and a plant (link.c) --------------------------------------------- */
/* A plant's command packets (stride doubles each: the paper's rig 1, a circuit its inputs' mask and values) on
 * their way through the network faults of a fault table. fifo: network_delay's packets in flight, cap slots of
 * stride + 1 doubles, cap >= the longest delay in steps + 2 (fifo NULL: no delay line). */
typedef struct {
    int stride;
    double *fifo;
    int64_t cap, head, n;
    int held_back;              /* reordering: a packet held back (it arrives after the next, stale) */
} hh_wire;
void hh_wire_init(hh_wire *w, int stride, double *fifo, int64_t cap);
void hh_rng_stream(hh_rng *r, uint64_t seed, int slot);        /* a fault's stream: the run's seed, its slot */
void hh_fault_seed(hh_fault *f, uint64_t seed, int slot);      /* hh_rng_stream of its rng */
uint64_t hh_fault_mask(const hh_fault *f, int n, int64_t k);   /* bit i: fault i active at step k */
/* The packet sent for a step (sent 0: none) through the active (mask) network faults: 1 when a packet reaches
 * the plant (in packet), 0 when none does. */
int hh_wire_deliver(hh_wire *w, hh_fault *fault, int nfault, uint64_t mask, double h, int sent, double *packet);
/* A circuit's command path: its network faults (hh_fault with k_start, k_end, their streams seeded by
 * hh_fault_seed with their place in the scenario's table), the wire, the watchdog (link.active: the safe
 * state; trips unexplained when no injected fault held a packet back). */
typedef struct {
    hh_fault *fault;
    int nfault;
    hh_wire wire;
    hh_watchdog link;
    double h, timeout;
    int inverted;               /* a command_inversion active at the step: the plant applies each command negated */
    double hold_kp;             /* > 0: the safe state "hold", this P gain on the held signal (hh_path_apply_held) */
} hh_path;
void hh_path_init(hh_path *p, hh_fault *fault, int nfault, double h, double timeout, int stride, double *fifo,
                  int64_t cap);
/* Step k's packet (sent 0: none) through the faults of step k and the watchdog: 1 when it reaches the plant;
 * x: the held signal's value at step k (its truth; the safe state "hold" keeps the value of its trip). */
int hh_path_step(hh_path *p, int64_t k, int sent, double *packet, double x);
/* What a commanded input receives at the plant after hh_path_step: the last command that arrived (held), 0 in the
 * watchdog's safe state, negated under a command_inversion, saturated to the input's range [lo, hi];
 * *saturated (when not NULL): 1 when a command was clamped (not the safe state's 0). */
double hh_path_apply(const hh_path *p, double held, double lo, double hi, int *saturated);
/* hh_path_apply for the input that holds the held signal (a loop's command): in the safe state "hold"
 * (hold_kp > 0) the P law hold_kp*(x at the trip - x) on its value x now, in place of 0 (the rig's hold). */
double hh_path_apply_held(const hh_path *p, double held, double lo, double hi, double x, int *saturated);

/* The rig around one sim: the faults act on the parameters through a copy of the fault-free ones (base), the
 * model reads only sim->p. wire: commands of one value (hh_rig_init's fifo: 2 doubles per slot, fifo_cap slots
 * >= the longest network_delay in steps + 2). */
struct hh_rig {
    hh_sim *sim;
    double base[HH_NP];
    hh_fault fault[HH_MAX_FAULTS];
    int nfault;
    uint64_t mask;              /* bit i: fault i active at the current step */
    uint64_t seed;
    double count;               /* m per encoder count */
    double timeout, hold_kp;    /* watchdog timeout [s]; the 'hold' safe state's gain [1/m] */
    int hold;                   /* safe state: 1 hold the position, 0 centre the valve */
    hh_watchdog link;
    hh_rng noise;               /* the pressure transducers' noise */
    double lost_counts, last_counts;   /* encoder_count_loss: counts lost so far; the last true count */
    int have_last;
    hh_wire wire;
};
struct hh_rig_reading {
    int64_t encoder;            /* counts, as the rig reports them */
    double p[HH_NPRESSURES];    /* p1, p2, ps, pt as the transducers report [Pa gauge] (HH_PRESSURE_*) */
    uint32_t status;            /* HH_ST_* */
    uint64_t faults;            /* bit i: fault i active */
};
const char *hh_fault_type_name(int type);    /* "sensor_stuck", ...; NULL beyond the last */
/* Set up the rig around sim (its p: the fault-free parameters); the watchdog counts from step 0. */
void hh_rig_init(hh_rig *r, hh_sim *sim, double count, uint64_t seed, double timeout, int hold, double hold_kp,
                 double *fifo, int64_t fifo_cap);
/* A scheduled fault (its k_start, k_end set) in the next slot; returns the slot, -1 when the table is full. */
int hh_rig_add(hh_rig *r, const hh_fault *f);
/* A fault switched on from step k until hh_rig_end (the live panel): the first free slot (never used, or its
 * fault ended by k) or the next; its random stream restarts from the slot's seed. Returns the slot or -1. */
int hh_rig_add_live(hh_rig *r, const hh_fault *f, int64_t k);
/* Switch the fault in `slot` off from step k on; -1 when no fault is active there. */
int hh_rig_end(hh_rig *r, int slot, int64_t k);
void hh_rig_set_base(hh_rig *r, const double *base);   /* new fault-free parameters (tunables) */
/* The parameters of a running rig with the live panel's tunables (HH_TUNE_*, core/shape.py TUNABLES; NaN: not
 * set) applied to the scenario's base0: mass, external force, supply pressure (at least the tank's), a scale on
 * every friction force. */
void hh_tuned_base(const double *base0, const double *tunables, double *p);
void hh_rig_begin(hh_rig *r, int64_t k);   /* the faults of step k: the active set, the parameters */
/* Step k -> k+1 with the command that arrived for it (arrived = 0: none): network faults, the watchdog and
 * its safe state, command faults, the model step, the faults of k + 1. *u_valve: what drove the valve.
 * Returns HH_OK or HH_DIVERGED. */
int hh_rig_step(hh_rig *r, int64_t k, int arrived, double u, double *u_valve);
int hh_rig_step_applied(hh_rig *r, int64_t k, double u);   /* the same with the valve's command (a replay) */
/* What the sensors report of the current state: interface models and sensor faults, the status bits. */
void hh_rig_sense(hh_rig *r, hh_rig_reading *out);

/* ---- the plant linearised at rest (linear.c) ------------------------------------------------ */
/* Net valve flows into the chambers [m^3/s] (SPEC §3.2, no leakage): q1 = q_s1 - q_1t, q2 = q_s2 - q_2t. */
void hh_valve_flows(const double *p, double xs, double p1, double p2, double *q1, double *q2);
/* A[6*6], B[6*2] (row-major) of state [xs, vs, p1, p2, vp, xp], inputs [ū, F_L] at the operating point
 * (xs, p1, p2, xp, vp = 0) with friction slope dFf/dvp [N.s/m]; coef[8] = beta1, beta2, V1, V2, Kq1, Kq2,
 * Kc1, Kc2 (linear.c). */
void hh_linearise(const double *p, double xs, double p1, double p2, double xp, double friction_slope, double *A,
                  double *B, double *coef);

/* ---- steady-state sine response of the spool (spool_bode.c) --------------------------------- */
/* Periodic when a half period ends where it began (sign flipped) within this, relative to the output amplitude. */
extern const double hh_spool_steady_tol;
/* Work doubles needed by hh_spool_bode_point at this frequency. */
int64_t hh_spool_bode_work(double freq);
/* The periodic steady state under u = amplitude*sin(2 pi f t) (spool_bode.c) of the plant's spool (its limits
 * and its ends): output half peak-to-peak, phase of the fundamental [rad], half periods simulated (at most
 * max_half_periods), residual, the limits that acted in the periodic state (HH_SPOOL_ACTS_* bits) and its
 * peaks[2] = (largest |v̄s| [1/s], largest demanded |a*| [1/s²] before the clamp). */
void hh_steady_sine_response(const double *p, double amplitude, double freq, int64_t max_half_periods,
                             double *work, double *a_out, double *phase, int64_t *half_periods, double *residual,
                             int64_t *limits, double *peaks);
/* Periodic steady state of the spool model (SPEC §3.1, §9.1) under u = amplitude*sin(2 pi f t):
 * gain [dB], phase [deg, wrapped], half periods simulated, periodicity residual, limits acting, peaks[2]. */
void hh_spool_bode_point(const double *p, double amplitude, double freq, int max_periods, double *work,
                         double *gain_db, double *phase_deg, int64_t *half_periods, double *residual,
                         int64_t *limits, double *peaks);
/* hh_spool_bode_point at n points; peaks[2 * i], peaks[2 * i + 1] of point i. */
void hh_spool_bode(const double *p, int64_t n, const double *amplitude, const double *freq, int max_periods,
                   double *work, double *gain_db, double *phase_deg, int64_t *half_periods, double *residual,
                   int64_t *limits, double *peaks);

#ifdef __cplusplus
}
#endif
#endif
