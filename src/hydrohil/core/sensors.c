/* sensors.c: encoder model (see sensors.h). */
#include "sensors.h"

/* Encoder reading [counts] of position xp [m] for a count size `resolution` [m] (nearest count). */
HH_INLINE double encoder_counts(double xp, double resolution) { return floor(xp / resolution + 0.5); }

/* Size [m] of one count as the rig reports it: the resolution, or HH_IDEAL_COUNT for an ideal encoder. */
HH_INLINE double count_size(double resolution) { return resolution > 0.0 ? resolution : HH_IDEAL_COUNT; }
