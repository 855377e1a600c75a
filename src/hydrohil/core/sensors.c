/* sensors.c: encoder model (see sensors.h). */
#include "sensors.h"

/* Encoder reading [counts] of position xp [m] for a count size `resolution` [m] (nearest count). */
HH_INLINE double encoder_counts(double xp, double resolution) { return floor(xp / resolution + 0.5); }

/* A count as an integer: NaN (a diverged state) reads 0, beyond +-2^62 saturates (no undefined cast). */
HH_INLINE int64_t count_to_int(double c)
{
    const double lim = 4611686018427387904.0;   /* 2^62 */
    if (c != c)
        return 0;
    return c >= lim ? (int64_t)lim : c <= -lim ? -(int64_t)lim : (int64_t)c;
}

/* What the encoder reports [counts] for position xp [m] with counts of `count` [m]. */
HH_INLINE int64_t encoder_reading(double xp, double count) { return count_to_int(encoder_counts(xp, count)); }

/* Size [m] of one count as the rig reports it: the resolution, or HH_IDEAL_COUNT for an ideal encoder. */
HH_INLINE double count_size(double resolution) { return resolution > 0.0 ? resolution : HH_IDEAL_COUNT; }

/* What a pressure transducer reports [Pa] of pressure p [Pa] with its noise sample `noise` [Pa] added: clamped to
 * [0, full_scale] (*saturated set when outside), to its ADC quantum `resolution` (0: none). The rig's transducers
 * (rig.c) and a circuit's state feedback (generated hc_run) read through it. */
HH_INLINE double pressure_reading(double p, double full_scale, double resolution, double noise, int *saturated)
{
    double v = p + noise;
    *saturated = v < 0.0 || v > full_scale;
    v = hh_clamp(v, 0.0, full_scale);
    if (resolution > 0.0)
        v = floor(v / resolution + 0.5) * resolution;
    return v;
}
