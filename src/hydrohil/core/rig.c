/* rig.c: the rig between a controller and the hybrid model (SPEC §8 "sensors", §10; docs/protocol.md):
 * the command path with its watchdog and safe state, the pressure transducers and their seeded noise.
 * The Python rig (simulation/rig.py, offline / lock-step / real time) and the standalone C plant
 * (`hydrohil export c`) both run these, so a scenario's readings and safe-state commands are the same
 * bit for bit whichever plant serves it. */

/* ---- noise source: xoshiro256** seeded by splitmix64 (Blackman & Vigna), normals by Box-Muller -------- */
static uint64_t splitmix64(uint64_t *x)
{
    uint64_t z = (*x += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

static uint64_t rotl64(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

void hh_rng_seed(hh_rng *r, uint64_t seed)
{
    int i;
    for (i = 0; i < 4; i++)
        r->s[i] = splitmix64(&seed);
}

/* Uniform in (0, 1]: 53 random bits, never 0 (Box-Muller takes its logarithm). */
double hh_rng_uniform(hh_rng *r)
{
    uint64_t *s = r->s, result = rotl64(s[1] * 5, 7) * 9, t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl64(s[3], 45);
    return ((double)(result >> 11) + 1.0) * 0x1.0p-53;
}

/* n standard normal samples (pairs by Box-Muller: a fixed cost per sample, no rejection loop). */
void hh_rng_normals(hh_rng *r, int n, double *out)
{
    int i;
    for (i = 0; i < n; i += 2) {
        double radius = sqrt(-2.0 * log(hh_rng_uniform(r))), angle = 6.283185307179586 * hh_rng_uniform(r);
        out[i] = radius * cos(angle);
        if (i + 1 < n)
            out[i + 1] = radius * sin(angle);
    }
}

/* ---- pressure transducer + ADC ------------------------------------------------------------------ */
/* Reading [Pa gauge] of a true pressure p with a noise sample [Pa]: clipped to [0, full_scale], quantised to
 * resolution (<= 0: none); *saturated = 1 when clipped. */
double hh_pressure_reading(double p, double full_scale, double resolution, double noise, int *saturated)
{
    double v = p + noise;
    *saturated = v < 0.0 || v > full_scale;
    v = hh_clamp(v, 0.0, full_scale);
    if (resolution > 0.0)
        v = floor(v / resolution + 0.5) * resolution;
    return v;
}

/* ---- command path: saturation, watchdog, safe state --------------------------------------------- */
void hh_watchdog_init(hh_watchdog *w)
{
    w->u_held = 0.0;
    w->k_delivered = 0;                 /* the watchdog counts from the start of the run */
    w->k_interfered = -((int64_t)1 << 62);
    w->delivered = 0;
    w->active = 0;
    w->trips = 0;
    w->trips_unexplained = 0;
    w->hold_x = 0.0;
}

/* The valve command of step k. `arrived`: a command u (ū) reached the plant for this step; it is saturated
 * to [-1, 1] and held. Silence longer than `timeout` [s] (counted in steps of h since the last arrival)
 * trips the safe state: ū = 0, or with `hold` a P loop (gain hold_kp [1/m]) on the position xp [m] at the
 * trip; the next arrival leaves it. A trip is *unexplained* when no injected fault held a command back since
 * the last arrival (k_interfered, set by the Python rig's fault injector). */
double hh_watchdog_command(hh_watchdog *w, int64_t k, int arrived, double u, double h, double timeout, int hold,
                           double hold_kp, double xp)
{
    int silent;
    if (arrived) {
        w->u_held = hh_clamp(u, -1.0, 1.0);
        w->k_delivered = k;
        w->delivered++;
    }
    silent = (double)(k - w->k_delivered) * h > timeout + 1e-12;
    if (silent && !w->active) {
        w->active = 1;
        w->trips++;
        if (w->k_interfered <= w->k_delivered)
            w->trips_unexplained++;
        w->hold_x = xp;
    } else if (!silent && w->active) {
        w->active = 0;
    }
    if (w->active)
        return hold ? p_control(hold_kp, w->hold_x, xp) : 0.0;
    return w->u_held;
}

int64_t hh_count_to_int(double c) { return count_to_int(c); }

/* ---- what the rig's sensors report --------------------------------------------------------------- */
/* The readings of sim's current state: the encoder in counts of size `count` [m] (nearest count), and the
 * transducers of p1, p2, ps, pt (sensors.pressure_range / _resolution / _noise of sim->p; four normal draws
 * from rng when the noise is on). The Python rig applies its sensor faults between the truth and these
 * models and calls the pieces; without faults it calls this, as the C plant does. */
void hh_rig_read(const hh_sim *sim, double count, hh_rng *rng, hh_reading *r)
{
    const double *p = sim->p, *y = sim->y;
    double noise[4] = {0.0, 0.0, 0.0, 0.0}, truth[4], sigma = p[HH_SENSORS_PRESSURE_NOISE];
    int i, sat;
    truth[0] = y[HH_P1];
    truth[1] = y[HH_P2];
    truth[2] = p[HH_SUPPLY_PS];
    truth[3] = p[HH_SUPPLY_PT];
    if (sigma > 0.0) {
        hh_rng_normals(rng, 4, noise);
        for (i = 0; i < 4; i++)
            noise[i] *= sigma;
    }
    r->saturated = 0;
    for (i = 0; i < 4; i++) {
        r->p[i] = hh_pressure_reading(truth[i], p[HH_SENSORS_PRESSURE_RANGE], p[HH_SENSORS_PRESSURE_RESOLUTION],
                                      noise[i], &sat);
        r->saturated |= sat;
    }
    r->encoder = encoder_reading(y[HH_XP], count);
}
