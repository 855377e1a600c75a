/* rig.c: the rig between a controller and the hybrid model (SPEC §8 "sensors", §10; docs/protocol.md):
 * the command path with its watchdog and safe state, the pressure transducers and their seeded noise.
 * The Python rig (simulation/rig.py, offline / lock-step / real time) and the standalone C plant
 * (`hydrohil export c`) both run these, so a scenario's readings and safe-state commands are the same
 * bit for bit whichever plant serves it. */

/* ---- pressure transducer + ADC ------------------------------------------------------------------ */
/* Reading [Pa gauge] of a true pressure p with a noise sample [Pa]: sensors.c's transducer (clipped to
 * [0, full_scale], quantised to resolution, <= 0: none; *saturated = 1 when clipped), exported. */
double hh_pressure_reading(double p, double full_scale, double resolution, double noise, int *saturated)
{
    return pressure_reading(p, full_scale, resolution, noise, saturated);
}

int64_t hh_count_to_int(double c) { return count_to_int(c); }

/* ---- what the rig's sensors report --------------------------------------------------------------- */
/* The readings of sim's current state: the encoder in counts of size `count` [m] (nearest count), and the
 * transducers of p1, p2, ps, pt (sensors.pressure_range / _resolution / _noise of sim->p; four normal draws
 * from rng when the noise is on): the readings of the plant alone in hh_sim_run (no rig). The rig's own
 * sensing, with its sensor faults between the truth and these models, is hh_rig_sense. */
void hh_rig_read(const hh_sim *sim, double count, hh_rng *rng, hh_reading *r)
{
    const double *p = sim->p, *y = sim->y;
    double noise[HH_NPRESSURES] = {0.0}, truth[HH_NPRESSURES], sigma = p[HH_SENSORS_PRESSURE_NOISE];
    int i, sat;
    truth[HH_PRESSURE_P1] = y[HH_P1];
    truth[HH_PRESSURE_P2] = y[HH_P2];
    truth[HH_PRESSURE_PS] = p[HH_SUPPLY_PS];
    truth[HH_PRESSURE_PT] = p[HH_SUPPLY_PT];
    if (sigma > 0.0) {
        hh_rng_normals(rng, HH_NPRESSURES, noise);
        for (i = 0; i < HH_NPRESSURES; i++)
            noise[i] *= sigma;
    }
    r->saturated = 0;
    for (i = 0; i < HH_NPRESSURES; i++) {
        r->p[i] = hh_pressure_reading(truth[i], p[HH_SENSORS_PRESSURE_RANGE], p[HH_SENSORS_PRESSURE_RESOLUTION],
                                      noise[i], &sat);
        r->saturated |= sat;
    }
    r->encoder = encoder_reading(y[HH_XP], count);
}

/* ---- the rig step with its fault table (simulation/faults.py documents each type) --------------- */
static const char *const FAULT_NAMES[HH_NFAULT_TYPES] = {
    "sensor_stuck", "sensor_offset", "sensor_noise", "sensor_dropout", "encoder_count_loss", "spool_stuck",
    "valve_bandwidth", "valve_leakage", "command_inversion", "supply_pressure", "seal_wear", "hose_burst",
    "load_change", "packet_loss", "network_delay", "reordering", "controller_silence"};

const char *hh_fault_type_name(int type) { return type >= 0 && type < HH_NFAULT_TYPES ? FAULT_NAMES[type] : 0; }

void hh_rig_init(hh_rig *r, hh_sim *sim, double count, uint64_t seed, double timeout, int hold, double hold_kp,
                 double *fifo, int64_t fifo_cap)
{
    int i;
    r->sim = sim;
    for (i = 0; i < HH_NP; i++)
        r->base[i] = sim->p[i];
    r->nfault = 0;
    r->mask = 0;
    r->seed = seed;
    r->count = count;
    r->timeout = timeout;
    r->hold = hold;
    r->hold_kp = hold_kp;
    hh_watchdog_init(&r->link);
    hh_rng_seed(&r->noise, seed);
    r->lost_counts = 0.0;
    r->last_counts = 0.0;
    r->have_last = 0;
    hh_wire_init(&r->wire, 1, fifo, fifo_cap);
}

HH_INLINE int is_parameter_fault(int type)
{
    return type == HH_FAULT_SPOOL_STUCK || type == HH_FAULT_VALVE_BANDWIDTH || type == HH_FAULT_VALVE_LEAKAGE
           || type == HH_FAULT_SUPPLY_PRESSURE || type == HH_FAULT_SEAL_WEAR || type == HH_FAULT_HOSE_BURST
           || type == HH_FAULT_LOAD_CHANGE;
}

/* sim->p = the fault-free parameters with the active parameter faults applied in slot order; `started`: the
 * faults beginning now (a stuck spool stops where it is); sensor_stuck's held values of inactive faults freed. */
static void rebuild(hh_rig *r, uint64_t started)
{
    double *p = r->sim->p;
    const double *base = r->base;
    int i;
    for (i = 0; i < HH_NP; i++)
        p[i] = base[i];
    for (i = 0; i < r->nfault; i++) {
        const hh_fault *f = &r->fault[i];
        if (!(r->mask >> i & 1) || !is_parameter_fault(f->type))
            continue;
        switch (f->type) {
        case HH_FAULT_SPOOL_STUCK:
            p[HH_SPOOL_LV] = 0.0;
            if (started >> i & 1)
                r->sim->y[HH_VS] = 0.0;
            break;
        case HH_FAULT_VALVE_BANDWIDTH: p[HH_SPOOL_WN] = base[HH_SPOOL_WN] * f->a; break;
        case HH_FAULT_VALVE_LEAKAGE: p[HH_VALVE_WEAR] += f->a; break;
        case HH_FAULT_SUPPLY_PRESSURE: p[HH_SUPPLY_PS] = hh_max(f->a, base[HH_SUPPLY_PT]); break;
        case HH_FAULT_SEAL_WEAR: p[HH_CYLINDER_G_LKC] = f->a; break;
        case HH_FAULT_HOSE_BURST: p[f->a == 1.0 ? HH_BURST1 : HH_BURST2] += f->b; break;
        default:   /* HH_FAULT_LOAD_CHANGE */
            if (!isnan(f->a))
                p[HH_LOAD_MASS] = f->a;
            if (!isnan(f->b))
                p[HH_LOAD_FORCE] = f->b;
        }
    }
    for (i = 0; i < r->nfault; i++)
        if (!(r->mask >> i & 1))
            r->fault[i].stuck = NAN;
}

void hh_rig_begin(hh_rig *r, int64_t k)
{
    uint64_t mask = 0;
    int i;
    for (i = 0; i < r->nfault; i++)
        if (r->fault[i].k_start <= k && k < r->fault[i].k_end)
            mask |= (uint64_t)1 << i;
    if (mask != r->mask) {
        uint64_t started = mask & ~r->mask;
        r->mask = mask;
        rebuild(r, started);
    }
}

void hh_rig_set_base(hh_rig *r, const double *base)
{
    int i;
    for (i = 0; i < HH_NP; i++)
        r->base[i] = base[i];
    rebuild(r, 0);
}

void hh_tuned_base(const double *base0, const double *tunables, double *p)
{
    static const int friction[6] = {HH_FC_POS, HH_FC_NEG, HH_FS_POS, HH_FS_NEG, HH_KV_POS, HH_KV_NEG};
    int i;
    for (i = 0; i < HH_NP; i++)
        p[i] = base0[i];
    if (!isnan(tunables[HH_TUNE_MASS]))
        p[HH_LOAD_MASS] = tunables[HH_TUNE_MASS];
    if (!isnan(tunables[HH_TUNE_FORCE]))
        p[HH_LOAD_FORCE] = tunables[HH_TUNE_FORCE];
    if (!isnan(tunables[HH_TUNE_SUPPLY_PRESSURE]))
        p[HH_SUPPLY_PS] = fmax(tunables[HH_TUNE_SUPPLY_PRESSURE], base0[HH_SUPPLY_PT]);
    if (!isnan(tunables[HH_TUNE_FRICTION_SCALE]))
        for (i = 0; i < 6; i++)
            p[friction[i]] = base0[friction[i]] * tunables[HH_TUNE_FRICTION_SCALE];
}

int hh_rig_add(hh_rig *r, const hh_fault *f)
{
    hh_fault *g;
    if (r->nfault >= HH_MAX_FAULTS)
        return -1;
    g = &r->fault[r->nfault];
    *g = *f;
    g->stuck = NAN;
    hh_fault_seed(g, r->seed, r->nfault);
    return r->nfault++;
}

int hh_rig_add_live(hh_rig *r, const hh_fault *f, int64_t k)
{
    int i;
    for (i = 0; i < r->nfault; i++)
        if (r->fault[i].k_end <= k && !(r->mask >> i & 1))
            break;
    if (i == r->nfault && r->nfault >= HH_MAX_FAULTS)
        return -1;
    r->fault[i] = *f;
    r->fault[i].k_start = k;
    r->fault[i].k_end = HH_NEVER;
    r->fault[i].stuck = NAN;
    hh_fault_seed(&r->fault[i], r->seed, i);
    if (i == r->nfault)
        r->nfault++;
    hh_rig_begin(r, k);
    return i;
}

int hh_rig_end(hh_rig *r, int slot, int64_t k)
{
    if (slot < 0 || slot >= r->nfault || r->fault[slot].k_end <= k)
        return -1;
    r->fault[slot].k_end = k;
    hh_rig_begin(r, k);
    return 0;
}

HH_INLINE int active(const hh_rig *r, int i, int type) { return (r->mask >> i & 1) && r->fault[i].type == type; }

static int any_active(const hh_rig *r, int type)
{
    int i;
    for (i = 0; i < r->nfault; i++)
        if (active(r, i, type))
            return 1;
    return 0;
}

int hh_rig_step(hh_rig *r, int64_t k, int arrived, double u, double *u_valve)
{
    hh_sim *sim = r->sim;
    double v;
    int got;
    if (!isfinite(u))                   /* no command at all (the wire refuses one; an offline caller may not) */
        arrived = 0;
    if (r->nfault == 0) {               /* no fault table: the command path alone (the common case, no loops) */
        v = hh_watchdog_command(&r->link, k, arrived, u, sim->h, r->timeout, r->hold, r->hold_kp,
                                sim->out[HH_OUT_Y + HH_XP]);
        *u_valve = v;
        return hh_sim_step(sim, v) == HH_OK ? HH_OK : HH_DIVERGED;
    }
    hh_rig_begin(r, k);
    v = u;
    got = hh_wire_deliver(&r->wire, r->fault, r->nfault, r->mask, sim->h, arrived, &v);   /* (link.c) */
    if ((arrived && !got) || any_active(r, HH_FAULT_CONTROLLER_SILENCE))
        r->link.k_interfered = k;       /* an injected fault held the controller's command back this step */
    v = hh_watchdog_command(&r->link, k, got, got ? v : 0.0, sim->h, r->timeout, r->hold, r->hold_kp,
                            sim->out[HH_OUT_Y + HH_XP]);
    if (any_active(r, HH_FAULT_COMMAND_INVERSION))
        v = -v;
    *u_valve = v;
    if (hh_sim_step(sim, v) != HH_OK)
        return HH_DIVERGED;
    hh_rig_begin(r, k + 1);             /* the faults of t_(k+1): its sensor reading and its step */
    return HH_OK;
}

int hh_rig_step_applied(hh_rig *r, int64_t k, double u)
{
    hh_rig_begin(r, k);
    if (hh_sim_step(r->sim, u) != HH_OK)
        return HH_DIVERGED;
    hh_rig_begin(r, k + 1);
    return HH_OK;
}

/* A sensor's value after the active faults on it, in slot order. */
static double sense(hh_rig *r, int sensor, double value, double t)
{
    int i;
    for (i = 0; i < r->nfault; i++) {
        hh_fault *f = &r->fault[i];
        if (!(r->mask >> i & 1) || f->sensor != sensor || f->type > HH_FAULT_SENSOR_DROPOUT)
            continue;
        if (f->type == HH_FAULT_SENSOR_STUCK) {
            if (isnan(f->stuck))
                f->stuck = value;
            value = f->stuck;
        } else if (f->type == HH_FAULT_SENSOR_OFFSET) {
            value += f->a + f->b * hh_max(t - f->start, 0.0);
        } else if (f->type == HH_FAULT_SENSOR_NOISE) {
            double z;
            hh_rng_normals(&f->rng, 1, &z);
            value += f->a * z;
        } else {
            value = 0.0;
        }
    }
    return value;
}

void hh_rig_sense(hh_rig *r, hh_rig_reading *out)
{
    const hh_sim *sim = r->sim;
    const double *p = sim->p, *y = sim->y;
    double t = sim->out[HH_OUT_T], counts = encoder_counts(y[HH_XP], r->count), c, truth[HH_NPRESSURES];
    double noise[HH_NPRESSURES] = {0.0}, sigma = p[HH_SENSORS_PRESSURE_NOISE];
    int i, sat, saturated = 0;
    int64_t travel = sim->m[HH_M_TRAVEL];
    /* the encoder: lost counts stay lost, then the position sensor's faults (in metres) */
    if (r->have_last && r->mask)
        for (i = 0; i < r->nfault; i++)
            if (active(r, i, HH_FAULT_ENCODER_COUNT_LOSS))
                r->lost_counts += copysign(r->fault[i].a * fabs(counts - r->last_counts), counts - r->last_counts);
    r->last_counts = counts;
    r->have_last = 1;
    c = counts - nearbyint(r->lost_counts);
    if (r->mask)
        c = floor(sense(r, HH_SENSOR_POSITION, c * r->count, t) / r->count + 0.5);
    out->encoder = count_to_int(c);
    /* the transducers: faults on the truth, then noise, range and ADC */
    truth[HH_PRESSURE_P1] = y[HH_P1];
    truth[HH_PRESSURE_P2] = y[HH_P2];
    truth[HH_PRESSURE_PS] = p[HH_SUPPLY_PS];
    truth[HH_PRESSURE_PT] = p[HH_SUPPLY_PT];
    if (sigma > 0.0) {
        hh_rng_normals(&r->noise, HH_NPRESSURES, noise);
        for (i = 0; i < HH_NPRESSURES; i++)
            noise[i] *= sigma;
    }
    for (i = 0; i < HH_NPRESSURES; i++) {
        double v = r->mask ? sense(r, HH_SENSOR_P1 + i, truth[i], t) : truth[i];   /* sensors: position, then these */
        out->p[i] = hh_pressure_reading(v, p[HH_SENSORS_PRESSURE_RANGE], p[HH_SENSORS_PRESSURE_RESOLUTION], noise[i],
                                        &sat);
        saturated |= sat;
    }
    out->faults = r->mask;
    out->status = (saturated ? HH_ST_SATURATED : 0) | (r->link.active ? HH_ST_WATCHDOG : 0)
                  | (travel == HH_AT_RETRACT ? HH_ST_AT_RETRACT : travel == HH_AT_EXTEND ? HH_ST_AT_EXTEND : 0)
                  | (sim->m[HH_M_FRICTION] == HH_STICK ? HH_ST_STICK : 0) | (r->mask ? HH_ST_FAULT_INJECTED : 0);
}
