/* control.h: the built-in controllers of the sampled loop. P: the paper's reference controller (§4),
 * u = clamp(Kp*(x_ref - x), -1, 1), Kp in 1/m, u the normalised valve command. */
#ifndef HH_CONTROL_H
#define HH_CONTROL_H
#include "core.h"

HH_INLINE double p_control(double kp, double x_ref, double x_meas);

#endif
