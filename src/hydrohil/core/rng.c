/* rng.c: the noise source of the rig's transducers (rig.c) and of a circuit loop's sensor (the generated C
 * includes it): one generator, so a seed gives the same samples offline, in either plant and in the reference. */

#ifndef HH_CORE_LINKED   /* (hh.h's functions of this part; a translation unit linked with hh_core.c, which defines
                           them, leaves them out: core.h) */
/* xoshiro256** seeded by splitmix64 (Blackman & Vigna), normals by Box-Muller */
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
#endif
