/* sensors.h: sensor interface models shared by offline simulation and the HIL plant (SPEC §8, §10). */
#ifndef HH_SENSORS_H
#define HH_SENSORS_H
#include "core.h"

HH_INLINE double encoder_counts(double xp, double resolution);
HH_INLINE double count_size(double resolution);
HH_INLINE int64_t count_to_int(double c);
HH_INLINE int64_t encoder_reading(double xp, double count);
HH_INLINE double pressure_reading(double p, double full_scale, double resolution, double noise, int *saturated);

#endif
