/* loop.c: the sampled loop and the per-step API (see loop.h and hh.h). */
#include "loop.h"

int hh_initial_state(const double *p, double xp, double xs, double vs, double p1, double p2, double vp,
                     double *y, int64_t *m)
{
    double L = p[HH_CYLINDER_STROKE], f, r1, r2;
    int i, status = 0;
    /* at rest (SPEC §12.5, rest.c): the spool offset that holds the piston, the pressures that balance the
     * chambers' flows there (no fault wear: fault slots are 0 at the start) */
    if (isnan(xs))
        status = hh_rest_state(p, &xs, &r1, &r2);
    else
        hh_rest_pressures(p, xs, &r1, &r2);
    if (isnan(p1))
        p1 = r1;
    if (isnan(p2))
        p2 = r2;
    y[HH_XS] = xs;
    y[HH_VS] = vs;
    y[HH_P1] = p1;
    y[HH_P2] = p2;
    y[HH_XP] = xp;
    y[HH_VP] = vp;
    y[HH_Z] = 0.0;
    for (i = 0; i < HH_NM; i++)
        m[i] = 0;
    m[HH_M_SPOOL] = HH_SPOOL_LINEAR;
    f = external_force(p1, p2, p);
    if (xp <= 0.0 && f <= 0.0) {
        y[HH_XP] = 0.0;
        y[HH_VP] = 0.0;
        m[HH_M_TRAVEL] = HH_AT_RETRACT;
    } else if (xp >= L && f >= 0.0) {
        y[HH_XP] = L;
        y[HH_VP] = 0.0;
        m[HH_M_TRAVEL] = HH_AT_EXTEND;
    } else {
        y[HH_XP] = hh_min(hh_max(xp, 0.0), L);
        m[HH_M_TRAVEL] = HH_FREE;
        y[HH_Z] = hh_min(hh_max(f, -p[HH_FS_NEG]), p[HH_FS_POS]) / p[HH_FRICTION_SIGMA0];
    }
    m[HH_M_FRICTION] = HH_STICK;
    return status;
}

/* Non-finite or far outside any physical range. */
int hh_diverged(const double *y, const double *p)
{
    int i;
    for (i = 0; i < HH_NY; i++)
        if (!isfinite(y[i]))
            return 1;
    return fabs(y[HH_P1]) > 1e9 || fabs(y[HH_P2]) > 1e9 || fabs(y[HH_VP]) > 100.0 || fabs(y[HH_XS]) > 10.0
           || y[HH_XP] < -p[HH_CYLINDER_STROKE] || y[HH_XP] > 2.0 * p[HH_CYLINDER_STROKE];
}

HH_INLINE int sim_diverged(const hh_sim *sim)
{
    const double *y = sim->y, *p = sim->p;
    if (hh_diverged(y, p))
        return 1;
    return sim->bounded && (y[HH_P1] > 1.5 * p[HH_SUPPLY_PS] || y[HH_P2] > 1.5 * p[HH_SUPPLY_PS]
                            || fabs(y[HH_XS]) > 2.0);
}

/* The hybrid model's friction force at (y, m): the core's, or the generated model's. */
HH_INLINE double sim_friction(const hh_sim *sim, const double *y, const int64_t *m)
{
    if (sim->model == HH_MODEL_GENERATED)
        return sim->model_friction(sim->ctx, y, m, sim->p);
    return friction_force(y, m, sim->p);
}

double hh_sim_friction(const hh_sim *sim) { return sim_friction(sim, sim->y, sim->m); }

/* One log row of the state (y, m) at time t with command u and spool input ud. */
static void log_row(const hh_sim *sim, double t, double u, double ud, const double *y, const int64_t *m,
                    double events, double *row)
{
    const double *p = sim->p;
    int i;
    row[HH_LOG_T] = t;
    row[HH_LOG_U] = u;
    row[HH_LOG_UD] = ud;
    for (i = 0; i < HH_NY; i++)
        row[HH_LOG_XS + i] = y[i];
    if (sim->model == HH_MODEL_HYBRID || sim->model == HH_MODEL_GENERATED) {
        row[HH_LOG_FF] = sim_friction(sim, y, m);
        row[HH_LOG_TRAVEL] = (double)m[HH_M_TRAVEL];
        row[HH_LOG_FRICTION] = (double)m[HH_M_FRICTION];
        row[HH_LOG_SPOOL] = (double)m[HH_M_SPOOL];
    } else {   /* continuous models: modes read off the state, for plots only */
        double dz;
        row[HH_LOG_FF] = lugre(y[HH_VP], y[HH_Z], p, &dz);
        row[HH_LOG_TRAVEL] = y[HH_XP] < 0.0 ? HH_AT_RETRACT : y[HH_XP] > p[HH_CYLINDER_STROKE] ? HH_AT_EXTEND : HH_FREE;
        row[HH_LOG_FRICTION] = fabs(y[HH_VP]) < 1e-3 ? HH_STICK : y[HH_VP] > 0.0 ? HH_SLIP_POS : HH_SLIP_NEG;
        row[HH_LOG_SPOOL] = 0.0;
    }
    row[HH_LOG_EVENTS] = events;
}

void hh_sim_init(hh_sim *sim, const double *p, int model, int method, double h, double *delay_buf,
                 int delay_n, double delay_alpha)
{
    int i;
    for (i = 0; i < HH_NP; i++)
        sim->p[i] = p[i];
    sim->model = model;
    sim->method = method;
    sim->h = h;
    sim->k = 0;
    sim->bounded = 0;
    sim->advance = 0;
    sim->ctx = 0;
    sim->model_step = 0;
    sim->model_friction = 0;
    sim->progress = 0;
    sim->progress_ctx = 0;
    sim->delay.buf = delay_buf;
    sim->delay.n = delay_n;
    sim->delay.alpha = delay_alpha;
    sim->delay.size = delay_n + 2;
    hh_initial_state(sim->p, 0.0, 0.0, 0.0, NAN, NAN, 0.0, sim->y, sim->m);
    hh_sim_reset(sim);
}

void hh_sim_reset(hh_sim *sim)
{
    int i;
    sim->k = 0;
    hh_delay_init(&sim->delay, sim->delay.buf, sim->delay.n, sim->delay.alpha, sim->y[HH_XS]);
    for (i = 0; i < HH_NOUT; i++)
        sim->out[i] = 0.0;
    for (i = 0; i < HH_NY; i++)
        sim->out[HH_OUT_Y + i] = sim->y[i];
    sim->out[HH_OUT_TRAVEL] = (double)sim->m[HH_M_TRAVEL];
    sim->out[HH_OUT_FRICTION] = (double)sim->m[HH_M_FRICTION];
    sim->out[HH_OUT_SPOOL] = (double)sim->m[HH_M_SPOOL];
}

/* Advance the model one step h from t with the delay line's two commands; returns events, or -1 when an
 * external step failed. */
HH_INLINE int sim_advance(hh_sim *sim, double t, double u_new, double u_old, double ud)
{
    switch (sim->model) {
    case HH_MODEL_HYBRID:
        return hybrid_step(sim->method, sim->y, sim->m, sim->p, ud, sim->h);
    case HH_MODEL_CONTINUOUS:
        continuous_step(sim->method, sim->y, sim->p, ud, sim->h);
        return 0;
    case HH_MODEL_GENERATED:
        return sim->model_step(sim->ctx, sim->y, sim->m, sim->p, ud, sim->h);
    default:
        return sim->advance(sim->ctx, t, sim->h, sim->delay.alpha, u_old, u_new, sim->y) ? -1 : 0;
    }
}

int hh_sim_step(hh_sim *sim, double u)
{
    double u_new, u_old, ud;
    int ev, i;
    ud = delay_push(&sim->delay, u, &u_new, &u_old);
    ev = sim_advance(sim, (double)sim->k * sim->h, u_new, u_old, ud);
    sim->k++;
    sim->out[HH_OUT_T] = (double)sim->k * sim->h;   /* t = k*h exactly as the loop (no sum drift) */
    for (i = 0; i < HH_NY; i++)
        sim->out[HH_OUT_Y + i] = sim->y[i];
    sim->out[HH_OUT_FF] = sim->model == HH_MODEL_HYBRID || sim->model == HH_MODEL_GENERATED
                          ? sim_friction(sim, sim->y, sim->m) : 0.0;
    sim->out[HH_OUT_TRAVEL] = (double)sim->m[HH_M_TRAVEL];
    sim->out[HH_OUT_FRICTION] = (double)sim->m[HH_M_FRICTION];
    sim->out[HH_OUT_SPOOL] = (double)sim->m[HH_M_SPOOL];
    sim->out[HH_OUT_EVENTS] = ev;
    sim->out[HH_OUT_UD] = ud;
    return ev < 0 || sim_diverged(sim) ? HH_DIVERGED : HH_OK;
}

/* The drive's value and slope at step k (time t): value k, or the table's by zero-order hold (j: its place). */
HH_INLINE void drive_value(const hh_drive *drive, int64_t k, double t, int64_t *j, double *v, double *dv)
{
    if (drive->t_in == 0) {
        *v = drive->v_in[k];
        *dv = drive->dv_in != 0 ? drive->dv_in[k] : 0.0;
    } else {
        while (*j + 1 < drive->n_in && drive->t_in[*j + 1] <= t + 1e-15)
            (*j)++;
        *v = drive->v_in[*j];
        *dv = drive->dv_in != 0 ? drive->dv_in[*j] : 0.0;
    }
}

/* The loop through the rig step (drive->rig): read the rig's sensors, the controller's command (built in, a
 * callback, or the open-loop value), the steering events due, the rig's step (command path, faults, watchdog);
 * then row k: the state before the step, the command that drove the valve, the spool's input and the events
 * of the steps since the last row; beside it what the sensors reported. The last row (k = n) takes no step:
 * its command is the controller's and its spool input what the delay line would give it (as run_plain's). */
static int run_on_rig(hh_sim *sim, const hh_drive *drive, int64_t n_steps, int64_t every, double *log,
                      int64_t *steps_done, int64_t *rows)
{
    hh_rig *rig = drive->rig;
    double h = sim->h, events = 0.0, y0[HH_NY];
    int64_t m0[HH_NM], k, j = 0, row = 0, e = 0;
    int i;
    hh_rig_reading r;
    if (rig->sim != sim || sim->k != 0 || drive->log_from < 0)   /* the rig's plant, from its start */
        return HH_BAD_ARGUMENT;
    for (k = 0; k <= n_steps; k++) {
        double t = (double)k * h, v, dv, u, u_valve, ud, ev = 0.0;
        drive_value(drive, k, t, &j, &v, &dv);
        hh_rig_sense(rig, &r);
        if (drive->command != 0)
            u = drive->command(drive->ctx, k, t, v, dv, &r);
        else if (drive->kind == HH_DRIVE_CLOSED)
            u = hh_controller_update(drive->controller, drive->state, v, dv, (double)r.encoder * rig->count,
                                     r.p[HH_PRESSURE_P1], r.p[HH_PRESSURE_P2]);
        else
            u = v;
        if (drive->command != 0 && isnan(u)) {     /* the callback failed */
            *steps_done = k;
            *rows = row;
            return HH_STOPPED;
        }
        for (i = 0; i < HH_NY; i++)
            y0[i] = sim->y[i];
        for (i = 0; i < HH_NM; i++)
            m0[i] = sim->m[i];
        u_valve = u;
        if (k < n_steps) {
            while (e < drive->n_event_steps && drive->event_steps[e] < k)
                e++;
            if (e < drive->n_event_steps && drive->event_steps[e] == k && drive->on_event(drive->ctx, k) != 0) {
                *steps_done = k;
                *rows = row;
                return HH_STOPPED;
            }
            if ((drive->kind == HH_DRIVE_APPLIED ? hh_rig_step_applied(rig, k, u)
                                                 : hh_rig_step(rig, k, 1, u, &u_valve)) != HH_OK) {   /* not logged */
                *steps_done = k + 1;
                *rows = row;
                return HH_DIVERGED;
            }
            ev = sim->out[HH_OUT_EVENTS];
            ud = sim->out[HH_OUT_UD];
        } else {
            ud = delay_peek(&sim->delay, u);
        }
        if (k % every == 0 && k < drive->log_from) {
            events = 0.0;
        } else if (k % every == 0) {
            log_row(sim, t, u_valve, ud, y0, m0, events, log + row * HH_NLOG);
            if (drive->rig_log != 0) {
                double *x = drive->rig_log + row * HH_NRLOG;
                x[HH_RLOG_FAULTS] = (double)r.faults;
                x[HH_RLOG_X_MEAS] = (double)r.encoder * rig->count;
                x[HH_RLOG_P1_MEAS] = r.p[HH_PRESSURE_P1];
                x[HH_RLOG_P2_MEAS] = r.p[HH_PRESSURE_P2];
                x[HH_RLOG_PS_MEAS] = r.p[HH_PRESSURE_PS];
                x[HH_RLOG_WATCHDOG] = (r.status & HH_ST_WATCHDOG) ? 1.0 : 0.0;
            }
            row++;
            events = 0.0;
        }
        events += ev;
        if (sim->progress != 0 && k % 500 == 0 && sim->progress(sim->progress_ctx, k) != 0) {
            *steps_done = k < n_steps ? k + 1 : n_steps;
            *rows = row;
            return HH_STOPPED;
        }
    }
    *steps_done = n_steps;
    *rows = row;
    return HH_OK;
}

/* The loop of the plant alone: the controller on the readings of hh_rig_read (noise from drive->rng), the
 * command into the delay line, the model's step; row k logged before step k. A run may continue a previous
 * one (sim->k > 0): the last row's command and the controller's and noise's state are left as before it. */
static int run_plain(hh_sim *sim, const hh_drive *drive, int64_t n_steps, int64_t every, double *log,
                     int64_t *steps_done, int64_t *rows)
{
    double h = sim->h, t, u, ud, u_new = 0.0, u_old = 0.0, events = 0.0;   /* (set before any step) */
    double count = count_size(sim->p[HH_SENSORS_ENCODER_RESOLUTION]);
    int64_t k, j = 0, row = 0, k0 = sim->k;
    int ev, pressures = drive->kind == HH_DRIVE_CLOSED
                        && (drive->controller->kpl != 0.0 || sim->p[HH_SENSORS_PRESSURE_NOISE] > 0.0);
    hh_reading reading = {{0.0, 0.0, 0.0, 0.0}, 0, 0};
    for (k = 0; k <= n_steps; k++) {
        double v, dv;
        t = (double)(k0 + k) * h;
        drive_value(drive, k, t, &j, &v, &dv);
        if (drive->kind == HH_DRIVE_CLOSED) {   /* the controller on what the rig's sensors report */
            hh_controller_state kept;
            hh_rng kept_rng;
            if (k == n_steps) {   /* the last row's command only: a run continued from here samples it again */
                kept = *drive->state;
                kept_rng = *drive->rng;
            }
            if (pressures)
                hh_rig_read(sim, count, drive->rng, &reading);
            else    /* the pressures unused and no noise to draw: the encoder alone (the same reading) */
                reading.encoder = encoder_reading(sim->y[HH_XP], count);
            u = hh_controller_update(drive->controller, drive->state, v, dv, (double)reading.encoder * count,
                                     reading.p[HH_PRESSURE_P1], reading.p[HH_PRESSURE_P2]);
            if (k == n_steps) {
                *drive->state = kept;
                *drive->rng = kept_rng;
            }
        } else {
            u = v;
        }
        if (k == n_steps)     /* the last row: its command is logged, not pushed (a continued run pushes it) */
            ud = delay_peek(&sim->delay, u);
        else
            ud = delay_push(&sim->delay, u, &u_new, &u_old);
        if (k % every == 0) {
            log_row(sim, t, u, ud, sim->y, sim->m, events, log + row * HH_NLOG);
            row++;
            events = 0.0;
        }
        if (k == n_steps)
            break;
        ev = sim_advance(sim, t, u_new, u_old, ud);
        sim->k++;
        events += ev;
        if (ev < 0 || sim_diverged(sim)) {
            *steps_done = k + 1;
            *rows = row;
            return HH_DIVERGED;
        }
        if (sim->progress != 0 && k % 500 == 0 && sim->progress(sim->progress_ctx, k) != 0) {
            *steps_done = k + 1;
            *rows = row;
            return HH_STOPPED;
        }
    }
    *steps_done = n_steps;
    *rows = row;
    return HH_OK;
}

int hh_sim_run(hh_sim *sim, const hh_drive *drive, int64_t n_steps, int64_t every, double *log,
               int64_t *steps_done, int64_t *rows)
{
    *steps_done = 0;
    *rows = 0;
    if (every < 1 || n_steps < 0)
        return HH_BAD_ARGUMENT;
    return drive->rig != 0 ? run_on_rig(sim, drive, n_steps, every, log, steps_done, rows)
                           : run_plain(sim, drive, n_steps, every, log, steps_done, rows);
}
