/* sensors.c: encoder model (see sensors.h). */
#include "sensors.h"

/* Encoder reading [counts] of position xp [m] for a count size `resolution` [m] (nearest count). */
HH_INLINE double encoder_counts(double xp, double resolution) { return floor(xp / resolution + 0.5); }

/* Position [m] as the encoder reports it; resolution <= 0 means ideal. */
HH_INLINE double encoder_position(double xp, double resolution)
{
    return resolution <= 0.0 ? xp : encoder_counts(xp, resolution) * resolution;
}
