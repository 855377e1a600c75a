/* sensors.h: sensor interface models shared by offline simulation and the HIL plant (SPEC §8, §10). */
#ifndef HH_SENSORS_H
#define HH_SENSORS_H
#include "core.h"

HH_INLINE double encoder_counts(double xp, double resolution);
HH_INLINE double count_size(double resolution);

#endif
